/*
 * h5inspect.h: what a dtx HDF5 file holds, as data for `dtx inspect`.
 *
 * dtx_h5_inspect opens the file read-only (dtx_h5_open: a file that is not
 * HDF5, or not in the dtx layout, is refused with a message saying what
 * was found) and walks the group of every kind the compiled-in layout
 * description lists (/meshes, /sequences, /markers, /correspondences,
 * /results, and any kind added later, shown generically), through
 * namespace groups (/results/<target>/<sequence>), including groups still
 * under a temporary name (".dtx-tmp-": a run that is going on or was
 * interrupted; its frames done are counted too).  It reads only shapes, attributes, the
 * small per-frame datasets (frame_done, residual) and the meshes (for
 * their connected components and bounds), never the frames.
 *
 * An object that cannot be read is listed with a `problem` message rather
 * than failing the whole inspection; `dtx validate` gives the details.
 *
 * Thread-safety: as the rest of the HDF5 layer (one thread at a time).
 */
#ifndef DTX_H5INSPECT_H
#define DTX_H5INSPECT_H

#include "status.h"

#include <stdint.h>

typedef enum {
    DTX_H5_KIND_MESH,
    DTX_H5_KIND_SEQUENCE,
    DTX_H5_KIND_MARKERS,
    DTX_H5_KIND_CORRESPONDENCE,
    DTX_H5_KIND_RESULT,
    /* A kind of the layout description without a reading of its own here
     * (e.g. /keypoints): its objects are listed with their datasets' shapes
     * and their attributes. */
    DTX_H5_KIND_OTHER
} dtx_h5_kind;

/* A kind of object, as the compiled-in layout description
 * (schemas/hdf5-layout-v1.json) lists them. */
typedef struct {
    dtx_h5_kind kind;
    char *name;  /* "meshes", "sequences", ..., "results", or another kind's name */
    char *group; /* "/meshes", ... */
} dtx_h5_kind_info;

/* An attribute as text: strings as stored; scalar integers in decimal;
 * scalar floats with %.17g; anything else described, e.g. "(3 integers)". */
typedef struct {
    char *name;
    char *value;
} dtx_h5_attr_text;

/* One object.  Fields that do not apply to the kind, or could not be read,
 * are -1 (counts) or NaN (residuals) or NULL (strings). */
typedef struct {
    dtx_h5_kind kind;
    int kind_index; /* into dtx_h5_summary.kinds */
    char *path;     /* where the group is (a temporary name when temporary) */
    int temporary;  /* 1: under a ".dtx-tmp-" name */
    char *problem;  /* NULL, or why the object could not be read */
    /* meshes */
    int32_t nv, nf, components;
    double bounds[6]; /* min x, y, z, max x, y, z */
    /* sequences and results: frames, frames done (= frames for sequences),
     * vertices, stored dtype, frames per chunk, the mesh (rest or target)
     * the frames belong to */
    int64_t nframes, frames_done;
    int is_f64, chunk_frames;
    char *mesh;
    /* sequences: the frames' file names as imported (nframes strings), or
     * NULL when the sequence has none */
    char **frame_names;
    /* results: residuals of the frames done (NaN when none) */
    double residual_min, residual_max, residual_mean;
    /* results with frame_stats: frames done whose solve converged (-1
     * without frame_stats); with frame_grad_norm: the largest final
     * gradient norm of a frame done and that frame, the lowest on ties
     * (NaN and -1 without it or with no frame done) */
    int64_t frames_converged;
    double grad_norm_max;
    int64_t grad_norm_max_frame;
    /* markers: markers; correspondences: triangle pairs; other kinds: the
     * first dimension of the first dataset */
    int64_t count;
    /* other kinds: the datasets the layout names, with their shapes,
     * e.g. "vertex (12), position (12 x 3)" */
    char *datasets;
    /* every attribute of the group, in name order */
    int64_t nattrs;
    dtx_h5_attr_text *attrs;
} dtx_h5_item;

typedef struct {
    int64_t nkinds; /* every kind of the layout, in its order */
    dtx_h5_kind_info *kinds;
    int64_t nattrs; /* root attributes (format, format_version, ...) */
    dtx_h5_attr_text *attrs;
    int64_t nitems; /* by kind (in the order of kinds), then by path */
    dtx_h5_item *items;
    int64_t nother; /* top-level members that are not kind groups */
    char **other;
} dtx_h5_summary;

/* Fills *out (zeroed first) with the summary of the file at path.
 * Errors: those of dtx_h5_open (DTX_EIO, DTX_EFORMAT), DTX_ENOMEM.  On
 * failure *out is empty.  Free with dtx_h5_summary_free. */
dtx_status dtx_h5_inspect(const char *path, dtx_h5_summary *out, dtx_error *err);

/* The value of attribute name among attrs, or NULL. */
const char *dtx_h5_attr_find(const dtx_h5_attr_text *attrs, int64_t n, const char *name);

/* Frees everything *s owns and zeroes it.  Accepts NULL. */
void dtx_h5_summary_free(dtx_h5_summary *s);

#endif /* DTX_H5INSPECT_H */
