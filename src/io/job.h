/*
 * job.h: dtx job files (JSON), parsed and checked against
 * schemas/job.schema.json.
 *
 * A job names its inputs by file + HDF5 path.  Relative file names are
 * resolved against the directory of the job file; the parsed job holds
 * resolved paths.  Example (jobs/cat-lion.json):
 *
 *   {
 *     "dtx_job": 1,
 *     "method": "sp04",
 *     "source": { "file": "data/cat-lion.h5", "mesh": "/meshes/cat",
 *                 "sequences": ["/sequences/cat-poses"] },
 *     "targets": [ { "name": "lion", "file": "data/cat-lion.h5",
 *                    "mesh": "/meshes/lion",
 *                    "markers": { "file": "data/cat-lion.h5",
 *                                 "path": "/markers/cat-lion" } } ],
 *     "output": { "file": "out/cat-lion.h5", "dtype": "float32" },
 *     "sp04": { "w_smooth": 1.0, "w_identity": 0.3,
 *               "w_closest": [1, 100, 5000, 5000, 5000, 5000] }
 *   }
 */
#ifndef DTX_JOB_H
#define DTX_JOB_H

#include "status.h"
#include "transfer.h"

#include <stdint.h>

#define DTX_JOB_VERSION 1

typedef enum { DTX_DTYPE_FLOAT32 = 0, DTX_DTYPE_FLOAT64 = 1 } dtx_dtype;

typedef enum {
    DTX_METHOD_SP04 = 0,
    DTX_METHOD_MULTICOMPONENT,
    DTX_METHOD_SPRINGS,
    DTX_METHOD_BIHARMONIC
} dtx_method;

/* How the global translation of each result frame is chosen. */
typedef enum {
    DTX_TRANSLATION_FIXED = 0, /* result centroid = target rest centroid (default) */
    DTX_TRANSLATION_FOLLOW,    /* centroid moves with the source centroid, scaled */
    DTX_TRANSLATION_PINS       /* only the pinned vertices fix it (needs pins) */
} dtx_translation;

typedef struct {
    int32_t vertex;  /* 0-based target vertex */
    double pos[3];   /* position it is held at in every frame */
} dtx_pin;

/* Markers: either a CSV file (csv != NULL, with its index base) or an HDF5
 * marker set (file + path). */
typedef struct {
    char *csv;      /* resolved path or NULL */
    int index_base; /* 0 or 1, required with csv */
    char *file;     /* resolved path or NULL */
    char *path;     /* HDF5 group, with file */
} dtx_job_markers;

typedef struct {
    char *name;  /* result group name; defaults to the mesh group's base name */
    char *file;  /* resolved path of the HDF5 file holding the mesh */
    char *mesh;  /* HDF5 path of the rest mesh group */
    dtx_job_markers markers;
    dtx_translation translation;
    int32_t npins;
    dtx_pin *pins;
    double weld_tolerance; /* [0] weld twins within this distance; < 0: no welding */
} dtx_job_target;

/* sp04 parameters (defaults in brackets). */
typedef struct {
    double w_smooth;       /* [1.0] correspondence smoothness weight */
    double w_identity;     /* [0.3] correspondence identity weight (paper: 0.001) */
    int n_closest;         /* number of closest-point iterations */
    double w_closest[16];  /* [1, 100, 5000, 5000, 5000, 5000] closest-point weights */
    double max_distance;   /* [0.1] closest-point / pairing threshold, as a
                              fraction of the target's size (dtx_rms_extent) */
    double max_angle_deg;  /* [90] normals must differ by less than this */
    int weights;           /* ["area"] DTX_CORR_WEIGHTS_AREA or _ELEMENT ("element"):
                              see dtx_corr_params */
} dtx_sp04_params;

/* Where the biharmonic method's key points come from. */
typedef enum {
    DTX_BH_KEYS_MARKERS = 0, /* each target's markers are its key points */
    DTX_BH_KEYS_AUTO         /* selected on the source, mapped through sp04's correspondence */
} dtx_bh_keys;

/* biharmonic parameters (defaults in brackets: dtx_kp_params_default,
 * dtx_skin_params_default; see the schema for their meaning). */
typedef struct {
    dtx_bh_keys keypoints;   /* [markers] */
    int32_t candidates;      /* [100] auto: farthest-point candidates */
    double eps;              /* [0.03] auto: stop adding at this error */
    int32_t max_keypoints;   /* [40] auto: at most this many key points */
    int32_t training_frames; /* [32] frames for the clustering and the selection */
    dtx_bh_params transfer;  /* the transfer's: skin.lambda, skin.gamma_logr,
                                skin.gamma_s [0.5, 1, 0.1] fit and clustering
                                weights from the job, the rest core's defaults */
} dtx_bh_job_params;

typedef struct {
    int version;          /* dtx_job */
    dtx_method method;
    char *text;           /* the job file's text, verbatim (for provenance) */
    char *job_path;       /* the job file's path as given */

    char *source_file;    /* resolved */
    char *source_mesh;    /* HDF5 path */
    int32_t nsequences;
    char **sequences;     /* HDF5 paths */
    double source_weld_tolerance; /* [0] as dtx_job_target.weld_tolerance */

    int32_t ntargets;
    dtx_job_target *targets;

    char *output_file;    /* resolved */
    dtx_dtype output_dtype;
    char *export_obj_dir; /* resolved or NULL: also write OBJ frames here */
    char *corr_store;     /* resolved or NULL: correspondence_store, the directory of
                             correspondences shared by jobs (src/io/corr_store.h) */
    int32_t block_frames; /* [64] frames per block (read/solve/write unit) */
    int collective_io;    /* [0] frames written with collective MPI-IO (else independent) */

    dtx_sp04_params sp04;  /* also the multicomponent correspondence's weights */
    dtx_mc_params mc;      /* multicomponent (core's struct and defaults) */
    dtx_bh_job_params bh;
    dtx_springs_params springs; /* springs (core's struct and defaults) */
} dtx_job;

/* Reads, parses and validates the job at path.  On failure err->msg names
 * the file, the location in the document (a JSON pointer such as
 * /targets/0/markers/index_base) and what was expected; *job is left empty.
 * Checks done here: JSON syntax (with line number; a NUL byte anywhere in
 * the text is a syntax error, not a silently shortened string), the schema (unknown
 * keys, types, required fields, enums, ranges), and cross-field rules (csv
 * markers need index_base; pins need translation "pins" or "fixed"; output
 * file must differ from every input file; input files must exist; method
 * biharmonic takes no pins; markers are required except with method
 * springs, where a target without them must share the source's
 * connectivity, which `dtx run` checks). */
dtx_status dtx_job_load(const char *path, dtx_job *job, dtx_error *err);

/* The same from a string already in memory; base_dir resolves relative
 * paths; name is used in messages.  Does not check that files exist when
 * check_files is 0 (used by the fuzzer and unit tests). */
dtx_status dtx_job_parse(const char *text, size_t len, const char *name, const char *base_dir,
                         int check_files, dtx_job *job, dtx_error *err);
/* (Details for both: text need not be NUL-terminated; name may be NULL
 * ("job" in messages, job_path NULL); base_dir NULL or "" means the current
 * directory.  Resolved paths are absolute: the base directory is made
 * canonical with realpath() when it exists, leading ".." of a relative
 * path go up from it, "." and repeated "/" are dropped, nothing else is
 * touched.  Messages read "NAME: at /json/pointer: what was expected, got
 * what", or "NAME:LINE:COL: JSON syntax error ..." (DTX_EPARSE); schema
 * and cross-field errors are DTX_EJOB, an unreadable job file DTX_EIO.
 * The target name defaults to the last part of its mesh path and must be
 * unique; a pinned vertex may not repeat; the output file is compared to
 * the inputs as files (same inode, or same canonical path).  Thread-safe
 * apart from strerror().) */

/* Frees everything the job owns and zeroes it.  Accepts NULL. */
void dtx_job_free(dtx_job *job);

/* Canonical parameter text of the job's method (JSON), for provenance and
 * for cache keys.  Caller frees. */
char *dtx_job_params_json(const dtx_job *job);
/* (Format: {"method":"sp04","sp04":{...}} with every parameter, defaults
 * included; multicomponent adds its own object before "sp04", springs its
 * own after it (the proxy of a target of other connectivity is sp04's
 * correspondence); biharmonic
 * is {"biharmonic":{...},"method":"biharmonic"}, with "sp04":{...} after
 * it when its key points are "auto" (they are mapped through sp04's
 * correspondence); keys sorted by byte value at every level, no spaces, numbers
 * printed with %.17g (needs the default "C" LC_NUMERIC locale).  NULL when
 * out of memory or job is NULL.  Thread-safe.) */

/* The method named by a result's "parameters" text (dtx_job_params_json's
 * format) and its settings from that text into *prm (the method's defaults
 * for any not given).  NULL, *prm untouched, when the text does not parse
 * or names no known method.  Thread-safe. */
const dtx_transfer_method *dtx_job_params_read(const char *params_json, dtx_transfer_params *prm);

/* Canonical parameter text of the correspondence the job's method builds
 * on (corr: its table's correspondence, transfer.h), for the correspondence
 * cache key: sp04's text, as dtx_job_params_json gives it for the job with
 * method sp04, for DTX_TRANSFER_CORR_SP04, so that the methods building on
 * sp04's correspondence (springs' proxies, biharmonic's key points) share
 * it and changing their own parameters does not recompute it; the job's
 * own text otherwise.  Caller frees; NULL when out of memory or job is
 * NULL. */
char *dtx_job_corr_params_json(const dtx_job *job, dtx_transfer_corr corr);

/* The job's method as core's tagged parameters (transfer.h): its kind, and
 * the job's values over that method's defaults. */
void dtx_job_transfer_params(const dtx_job *job, dtx_transfer_params *p);

/* The job schema, schemas/job.schema.json, as built into the binary (the
 * build embeds the file, cmake/embed.cmake) so that dtx works without the
 * source tree: its whole text, NUL-terminated and newly allocated (caller
 * frees); NULL when out of memory.  Thread-safe. */
char *dtx_job_schema_text(void);

#endif /* DTX_JOB_H */
