/*
 * h5layout.h: the dtx HDF5 layout, version 1 (schemas/hdf5-layout-v1.md),
 * read and written serially or in parallel (MPI-IO).
 *
 * One file holds meshes, sequences (animations of a rest mesh), marker sets,
 * correspondences and results:
 *
 *   /                        attrs format="dtx", format_version=1, created_by
 *   /meshes/<name>           vertices f64 nv x 3, faces i32 nf x 3 (0-based)
 *   /sequences/<name>        positions f32|f64 T x nv x 3, link rest -> mesh
 *   /markers/<name>          source_vertex, target_vertex i32 m, label str m
 *   /keypoints/<name>        vertex i32 n, position f64 n x 3, label str n,
 *                            error f64 S (selected key points of a source)
 *   /correspondences/<name>  pairs i32 P x 2, deformed_source f64 nv_s x 3
 *   /weights/<name>          handles i32 m, weights f64 nv x m (a cache)
 *   /results/<name>          positions T x nv x 3, residual f64 T,
 *                            frame_done u8 T, link target -> mesh
 *
 * Conventions of this API:
 * - Arrays are row-major and flat: "nv x 3 doubles" means V[3*i + k].
 * - Group arguments are absolute HDF5 paths ("/meshes/lion").  Every object
 *   group is first written under a temporary sibling name
 *   ("/meshes/.dtx-tmp-lion") and moved to its final name only when complete
 *   (dtx_h5_commit_group), so an interrupted writer never leaves a
 *   half-written object under its final name.  Writers refuse to overwrite
 *   an existing object (remove it first with dtx_h5_remove); a stale
 *   temporary group of the same name is removed.
 * - Strings (attributes and string datasets) are written as variable-length
 *   UTF-8; readers also accept fixed-length strings (as numpy/h5py "S" arrays
 *   produce).
 * - Every function returns DTX_OK or an error status with err->msg naming the
 *   file, the HDF5 path and the problem, e.g.
 *   "cat.h5: /sequences/cat-poses/positions: expected 3 dimensions
 *   T x nv x 3, found 2".  Nothing is printed (dtx_h5_init turns HDF5's own
 *   error printing off; the innermost HDF5 error text is appended to our
 *   message when an HDF5 call fails).
 * - Every HDF5 identifier opened by a function is closed on every path;
 *   objects returned to the caller (files, dtx_h5_seq, dtx_h5_result) are
 *   closed by the matching close function.
 *
 * Serial and parallel access.  A file opened with comm == MPI_COMM_NULL uses
 * the POSIX (sec2) driver; MPI need not be initialised.  A file opened with a
 * communicator uses the MPI-IO driver, and then (HDF5 rule) every call that
 * creates, deletes, moves or modifies an object or an attribute is
 * collective: every rank of comm calls it with the same arguments.  Reading
 * is independent (any rank alone may read).  Frame writes may be independent
 * or collective (the `collective` flag).  Limitations of parallel HDF5 1.10,
 * checked with clear errors: datasets with filters (gzip) and
 * variable-length string datasets (frame_names, marker labels) cannot be
 * written through MPI-IO; write those serially.
 *
 * Thread-safety: the Debian HDF5 build is not thread-safe; call these
 * functions from one thread at a time (the OpenMP loops of the core library
 * never call them).
 */
#ifndef DTX_H5LAYOUT_H
#define DTX_H5LAYOUT_H

#include "markers.h"
#include "mesh.h"
#include "status.h"

#include <hdf5.h>
#include <mpi.h>

#include <stddef.h>
#include <stdint.h>

#define DTX_H5_FORMAT "dtx"
#define DTX_H5_FORMAT_VERSION 1
/* Longest HDF5 path (including the NUL) this API handles. */
#define DTX_H5_PATH_MAX 1024
/* Prefix of the temporary name an object group is written under. */
#define DTX_H5_TMP_PREFIX ".dtx-tmp-"
/* FNV-1a 64-bit offset basis (14695981039346656037 = 0xcbf29ce484222325):
 * the start value of dtx_hash_bytes. */
#define DTX_HASH_INIT UINT64_C(0xcbf29ce484222325)
/* Default number of frames per chunk of positions datasets. */
#define DTX_H5_DEFAULT_CHUNK_FRAMES 16

/* ------------------------------------------------------------------ setup */

/* Turns off HDF5's automatic error printing on the calling thread's default
 * error stack (dtx produces its own messages).  Idempotent; dtx_h5_create,
 * dtx_h5_open and dtx_h5_validate call it too. */
void dtx_h5_init(void);

/* ---------------------------------------------------------------- hashing */

/* One FNV-1a 64-bit step over n bytes at p, starting from h (use
 * DTX_HASH_INIT for a fresh hash).  Pure; thread-safe. */
uint64_t dtx_hash_bytes(uint64_t h, const void *p, size_t n);

/* FNV-1a 64 of the mesh content: the little-endian IEEE-754 bytes of V
 * (nv x 3 doubles, row-major), then the little-endian bytes of F (nf x 3
 * int32).  Independent of the machine's byte order; equals, in numpy,
 * fnv1a64(V.astype('<f8').tobytes() + F.astype('<i4').tobytes()). */
uint64_t dtx_mesh_hash(const dtx_mesh *m);

/* Writes h as 16 lowercase hex digits and a NUL into out[17]. */
void dtx_hash_hex(uint64_t h, char out[17]);

/* ------------------------------------------------------------------ files */

/* Creates (truncating) the file at path and writes the root attributes
 * format, format_version and created_by.  comm: MPI_COMM_NULL for serial
 * access, else a communicator whose ranks all call this collectively.
 * *file receives the file id (close with dtx_h5_close). */
dtx_status dtx_h5_create(const char *path, MPI_Comm comm, hid_t *file, dtx_error *err);

/* Opens an existing dtx file, read-only or (writable != 0) read-write, and
 * checks format == "dtx" and format_version == 1; otherwise DTX_EFORMAT
 * with a message naming what was found.  A missing or non-HDF5 file gives
 * DTX_EIO / DTX_EFORMAT.  comm as for dtx_h5_create. */
dtx_status dtx_h5_open(const char *path, MPI_Comm comm, int writable, hid_t *file,
                       dtx_error *err);

/* Closes *file (a no-op when *file < 0) and sets *file = H5I_INVALID_HID.
 * Collective on a parallel file.  Every object opened inside the file must
 * have been closed first (dtx_h5_seq_close, dtx_h5_result_close). */
dtx_status dtx_h5_close(hid_t *file, dtx_error *err);

/* H5Fflush of the whole file (collective on a parallel file). */
dtx_status dtx_h5_flush(hid_t file, dtx_error *err);

/* Reserves disk blocks for everything the file has allocated so far (call
 * it after a flush: fallocate with KEEP_SIZE of the file's size, on its
 * path), so that writing the frames
 * later only fills blocks: on ext4 that made writing a new 1.2 GB file about
 * 7x faster here.  Best effort, except that a full disk or quota
 * (ENOSPC, EDQUOT, EFBIG) is DTX_EIO at once, before any frame is
 * computed; other failures (a file system without fallocate, say) are
 * ignored.  Not collective: call it on one rank. */
dtx_status dtx_h5_preallocate(hid_t file, dtx_error *err);

/* 1 when the file (or the file of object id) was opened with the MPI-IO
 * driver, 0 otherwise. */
int dtx_h5_is_parallel(hid_t id);

/* The name of the file holding object id, copied into buf[n] (truncated;
 * "?" when unknown).  Returns buf. */
const char *dtx_h5_filename(hid_t id, char *buf, size_t n);

/* ------------------------------------------------------ paths and groups */

/* 1 when path names an existing object in file (every intermediate link
 * existing, soft links resolving), else 0.  Never fails. */
int dtx_h5_path_exists(hid_t file, const char *path);

/* Creates the group at path and any missing intermediate groups; an
 * existing group is fine. */
dtx_status dtx_h5_create_groups(hid_t file, const char *path, dtx_error *err);

/* Longest object name (one path component, in bytes) dtx writes or reads
 * as an input's name: long enough for any real name, short enough that
 * "/results/TARGET/.dtx-tmp-SEQUENCE" stays far below DTX_H5_PATH_MAX. */
#define DTX_H5_NAME_MAX 255
/* Names starting with this are reserved for dtx's own temporary objects. */
#define DTX_H5_RESERVED_PREFIX ".dtx-"

/* The one rule for the name of an object dtx writes (the NAME of
 * /meshes/NAME, /sequences/NAME, /results/TARGET/NAME, ...): not empty, no
 * '/', not "." or ".." (which HDF5 reads as the current and the parent
 * group), not starting with ".dtx-" (reserved: a temporary group of an
 * interrupted writer), no control character (bytes 1-31 and 127), at most
 * DTX_H5_NAME_MAX bytes.  Returns DTX_OK or DTX_EINVAL with err->msg
 * "\"NAME\" cannot name an HDF5 object: REASON" (control characters shown
 * as '?'); the caller prefixes where the name came from.  Used by every
 * writer (on the last component of the group path), by `dtx import` for
 * --name and by the job parser; schemas/job.schema.json mirrors it for
 * target names.  Pure; thread-safe. */
dtx_status dtx_h5_check_name(const char *name, dtx_error *err);

/* The temporary name of final path: "/a/b/name" -> "/a/b/.dtx-tmp-name",
 * written into tmp[n].  DTX_EINVAL when final is not an absolute path with
 * a last component, or too long. */
dtx_status dtx_h5_tmp_path(const char *final, char *tmp, size_t n, dtx_error *err);

/* Moves the group at tmp to final (creating missing intermediate groups).
 * When final already exists: replace != 0 deletes it first, replace == 0
 * fails with DTX_EINVAL.  HDF5 has no atomic rename-over, so with replace
 * the old object is unlinked just before the move. */
dtx_status dtx_h5_commit_group(hid_t file, const char *tmp, const char *final, int replace,
                               dtx_error *err);

/* Unlinks the object at path (a no-op when nothing is there).  HDF5 does
 * not reclaim the space (h5repack does). */
dtx_status dtx_h5_remove(hid_t file, const char *path, dtx_error *err);

/* The names of every link in the group at path, in HDF5's name order (the
 * lister that inspect, validate and the layout readers share).  Returns 0,
 * or -1 when the group cannot be listed: l is then empty and l->oom is 1
 * when it was for want of memory.  Free l with dtx_h5_names_free. */
typedef struct {
    char **names;
    size_t n, cap;
    int oom;
} dtx_h5_names;
int dtx_h5_list_names(hid_t file, const char *path, dtx_h5_names *l);

/* Frees the names and empties l (oom is cleared too). */
void dtx_h5_names_free(dtx_h5_names *l);

/* The names of the groups directly under the group at path (a soft link
 * that resolves to a group counts; objects under a temporary name are
 * skipped), sorted by strcmp.  *names receives a
 * malloc'ed array of *n malloc'ed strings (free with dtx_h5_free_strings),
 * NULL when there are none.  DTX_EFORMAT when path is not a group. */
dtx_status dtx_h5_list_groups(hid_t file, const char *path, char ***names, int64_t *n,
                              dtx_error *err);

/* ------------------------------------------------------------- attributes */

/* Attributes of the object at obj (a path relative to loc, "." for loc
 * itself).  Strings are written as scalar variable-length UTF-8; integers
 * as scalar int32 (DTX_ERANGE when value does not fit).  Writing replaces
 * an existing attribute of the same name.  Readers accept variable- and
 * fixed-length strings and any integer type; read_attr_str returns a
 * malloc'ed copy in *value (caller frees).  A missing attribute is
 * DTX_EFORMAT ("... has no attribute NAME"). */
dtx_status dtx_h5_write_attr_str(hid_t loc, const char *obj, const char *name,
                                 const char *value, dtx_error *err);
dtx_status dtx_h5_write_attr_int(hid_t loc, const char *obj, const char *name, int64_t value,
                                 dtx_error *err);
dtx_status dtx_h5_read_attr_str(hid_t loc, const char *obj, const char *name, char **value,
                                dtx_error *err);
dtx_status dtx_h5_read_attr_int(hid_t loc, const char *obj, const char *name, int64_t *value,
                                dtx_error *err);

/* Frees n strings and the array (NULL accepted) and sets *strs = NULL. */
void dtx_h5_free_strings(char ***strs, int64_t n);

/* ----------------------------------------------------------------- meshes */

/* Writes the mesh m as the group `group` (vertices f64 nv x 3, faces i32
 * nf x 3, attrs source, nv, nf, content_hash = dtx_mesh_hash).  source may
 * be NULL (stored as "").  Fails if group exists.  Collective in parallel. */
dtx_status dtx_h5_write_mesh(hid_t file, const char *group, const dtx_mesh *m,
                             const char *source, dtx_error *err);

/* Reads the mesh group into *m (allocated here; free with dtx_mesh_free).
 * Checks before allocating: both datasets exist, vertices are floats and
 * faces integers, rank 2 with a second dimension of 3, counts at most
 * 2^31-1, and the stored bytes can hold the data (an unwritten or
 * impossible-to-fill dataset is rejected); then dtx_mesh_validate.  On
 * failure *m is left empty.  The group may be reached through a soft link
 * ("/results/lion/target"). */
dtx_status dtx_h5_read_mesh(hid_t file, const char *group, dtx_mesh *m, dtx_error *err);

/* The vertex and face counts of a mesh group from the dataset shapes (no
 * data read); for cheap compatibility checks. */
dtx_status dtx_h5_mesh_size(hid_t file, const char *group, int32_t *nv, int32_t *nf,
                            dtx_error *err);

/* -------------------------------------------------------------- sequences */

/* An open positions dataset of a sequence (T x nv x 3).  Fields are
 * read-only for callers. */
typedef struct {
    hid_t file;       /* not owned */
    hid_t group;      /* owned */
    hid_t dset;       /* owned: the positions dataset */
    int64_t nframes;  /* T */
    int32_t nv;
    int is_f64;       /* file dtype: 1 float64, 0 float32 */
    int chunk_frames; /* frames per chunk (0 when not chunked) */
    int parallel;     /* the file uses MPI-IO */
    int committed;    /* 0 while under its temporary name */
    char path[DTX_H5_PATH_MAX];       /* where the group is now */
    char final_path[DTX_H5_PATH_MAX]; /* where it goes on commit */
    float *scratch;   /* float32 conversion buffer (owned) */
    size_t scratch_n; /* its length in floats */
} dtx_h5_seq;

/* Creates a sequence group under its temporary name with an (unwritten)
 * positions dataset of nframes x nv x 3, float64 when f64 else float32,
 * chunked by chunk_frames frames (0 = min(T, 16); clamped to [1, T] and to
 * HDF5's 4 GiB chunk limit), gzip level 4 + shuffle when gzip != 0 (serial
 * files only).  The rest mesh group must exist in file with nv vertices;
 * attr rest_mesh and soft link "rest" point to it.  Write frames with
 * dtx_h5_seq_write, optionally names with dtx_h5_write_frame_names, then
 * dtx_h5_seq_commit, then dtx_h5_seq_close.  Collective in parallel. */
dtx_status dtx_h5_seq_create(hid_t file, const char *group, const char *rest_mesh_group,
                             int64_t nframes, int32_t nv, int f64, int chunk_frames, int gzip,
                             dtx_h5_seq *seq, dtx_error *err);

/* Opens an existing sequence group: checks positions is a float dataset of
 * rank 3 with dims[2] == 3 and nv <= 2^31-1, and that nframes (when
 * present) agrees.  Sets a chunk cache large enough for one chunk so that
 * reading frame by frame decompresses each chunk once. */
dtx_status dtx_h5_seq_open(hid_t file, const char *group, dtx_h5_seq *seq, dtx_error *err);

/* Reads frames [first, first+count) as doubles into out (count x nv x 3,
 * caller-allocated).  Independent: any rank alone may call. */
dtx_status dtx_h5_seq_read(const dtx_h5_seq *seq, int64_t first, int64_t count, double *out,
                           dtx_error *err);

/* Writes frames [first, first+count) from data (count x nv x 3 doubles),
 * converted to the file dtype.  collective != 0 on a parallel file uses a
 * collective transfer: every rank of the file's communicator must call,
 * ranks without frames with count == 0 (data may then be NULL).  The
 * sequence is not const because the float32 buffer is kept for reuse. */
dtx_status dtx_h5_seq_write(dtx_h5_seq *seq, int64_t first, int64_t count, const double *data,
                            int collective, dtx_error *err);

/* Writes frame_names: n == seq->nframes strings (NULL entries stored as
 * "").  Serial files only (variable-length data). */
dtx_status dtx_h5_write_frame_names(dtx_h5_seq *seq, const char *const *names, int64_t n,
                                    dtx_error *err);

/* Reads frame_names into *names (nframes malloc'ed strings; free with
 * dtx_h5_free_strings(names, seq->nframes)).  *names = NULL and DTX_OK when
 * the sequence has none. */
dtx_status dtx_h5_read_frame_names(const dtx_h5_seq *seq, char ***names, dtx_error *err);

/* Moves a sequence created by dtx_h5_seq_create to its final name
 * (collective in parallel).  A no-op for an opened sequence. */
dtx_status dtx_h5_seq_commit(dtx_h5_seq *seq, dtx_error *err);

/* Closes the handles and frees the buffer; an uncommitted sequence stays
 * under its temporary name (the next create of that name removes it).
 * Accepts a zeroed or already closed struct. */
void dtx_h5_seq_close(dtx_h5_seq *seq);

/* ---------------------------------------------------------------- markers */

/* Writes a marker set (source_vertex, target_vertex, label; index_base = 0
 * always; labels NULL or NULL entries are stored as "").  src_mesh and
 * tgt_mesh are HDF5 paths of the meshes or NULL/"" when unknown.  Serial
 * files only (labels are variable-length strings). */
dtx_status dtx_h5_write_markers(hid_t file, const char *group, const dtx_markers *mk,
                                const char *src_mesh, const char *tgt_mesh, dtx_error *err);

/* Reads a marker set into *mk (allocated here, free with
 * dtx_markers_free); labels are always allocated (""-filled when the group
 * has no label dataset).  Checks the three datasets have one equal length,
 * integer indices >= 0 and index_base == 0; ranges against the meshes are
 * the caller's dtx_markers_validate. */
dtx_status dtx_h5_read_markers(hid_t file, const char *group, dtx_markers *mk, dtx_error *err);

/* -------------------------------------------------------------- key points */

/* A key-point set selected on a source mesh (`dtx keypoints`, keypoints.h).
 * Read back, every pointer is owned (free with dtx_h5_keypoints_free);
 * written, nothing is taken over. */
typedef struct {
    int32_t n;              /* key points, >= 1 */
    int32_t *vertex;        /* n source vertices, 0-based, in the order chosen */
    double *position;       /* n x 3: their rest positions */
    char **label;           /* n labels (nearest marker label, or ""); NULL: all "" */
    int32_t nerror;         /* steps, >= 1 */
    double *error;          /* nerror: the error after each step (the first key
                               points alone, each addition, each accepted
                               replacement) */
    char *source_mesh;      /* HDF5 path (or FILE:PATH) of the source mesh */
    char *source_sequences; /* the frames selected on (text, e.g. paths joined by ", ") */
    int32_t candidates;     /* candidates evaluated */
    double eps;             /* the error aimed at */
    double final_error;     /* the final set's error (attribute "error") */
    char *dtx_version;      /* read back only (written as DTX_VERSION) */
} dtx_h5_keypoints;

/* Writes the key-point group `group` (datasets vertex i32 n, position f64
 * n x 3, label str n, error f64 nerror; attributes source_mesh,
 * source_sequences, candidates, eps, error (f64 scalars for eps and error),
 * dtx_version).  Fails if group exists.  Serial files only (labels are
 * variable-length strings). */
dtx_status dtx_h5_write_keypoints(hid_t file, const char *group, const dtx_h5_keypoints *kp,
                                  dtx_error *err);

/* Reads a key-point group into *kp (allocated here; zeroed on failure).
 * Checks the shapes agree (n >= 1, nerror >= 1), vertices >= 0 and values
 * finite; the vertex range against the source mesh is the caller's. */
dtx_status dtx_h5_read_keypoints(hid_t file, const char *group, dtx_h5_keypoints *kp,
                                 dtx_error *err);

/* Frees what a read key-point set owns and zeroes it.  Accepts NULL. */
void dtx_h5_keypoints_free(dtx_h5_keypoints *kp);

/* -------------------------------------------------------- correspondences */

/* Provenance of a correspondence (all strings; NULL stored as ""). */
typedef struct {
    const char *key;         /* hex hash of the inputs, computed by the caller */
    const char *source_mesh; /* HDF5 path or "FILE:PATH" */
    const char *target_mesh;
    const char *markers;
    const char *parameters;  /* JSON text */
} dtx_h5_corr_meta;

/* A correspondence read back (everything owned; free with dtx_h5_corr_free). */
typedef struct {
    int64_t npairs;
    int32_t *pairs;        /* npairs x 2: source triangle, target triangle */
    int32_t nv_s;
    double *deformed_src;  /* nv_s x 3, or NULL (multicomponent's) */
    char *key, *source_mesh, *target_mesh, *markers, *parameters, *dtx_version;
} dtx_h5_corr;

/* Writes pairs (npairs x 2 int32) and deformed_src (nv_s x 3 doubles; NULL
 * for a multicomponent correspondence, which has none: no deformed_source
 * is written) and the attributes key, source_mesh, target_mesh, markers,
 * parameters, dtx_version (= DTX_VERSION).  Collective in parallel. */
dtx_status dtx_h5_write_corr(hid_t file, const char *group, const int32_t *pairs,
                             int64_t npairs, const double *deformed_src, int32_t nv_s,
                             const dtx_h5_corr_meta *meta, dtx_error *err);

/* Reads a correspondence into *c.  Checks shapes and, for each of src_nv,
 * src_nf, tgt_nf that is >= 0, that deformed_source has src_nv rows and
 * pair triangles are in [0, src_nf) / [0, tgt_nf).  Pass -1 to skip.  A
 * group without deformed_source (multicomponent's) gives
 * c->deformed_src == NULL and c->nv_s == 0: callers that need it check. */
dtx_status dtx_h5_read_corr(hid_t file, const char *group, int32_t src_nv, int32_t src_nf,
                            int32_t tgt_nf, dtx_h5_corr *c, dtx_error *err);

/* Frees everything *c owns and zeroes it.  Accepts NULL. */
void dtx_h5_corr_free(dtx_h5_corr *c);

/* Looks through the groups /correspondences/<name> for a group whose attribute key equals
 * key.  *group_out receives a malloc'ed path, or NULL (and DTX_OK) when
 * none matches or the file has no /correspondences. */
dtx_status dtx_h5_find_corr_by_key(hid_t file, const char *key, char **group_out,
                                   dtx_error *err);

/* -------------------------------------------------------- weights (cache) */

/* Skinning weights of handles on a mesh (method biharmonic's bounded
 * biharmonic weights), cached like correspondences: found again by key. */
typedef struct {
    int32_t m;        /* handles, >= 1 */
    int32_t *handles; /* m vertices of the mesh */
    int32_t nv;
    double *weights;  /* nv x m, row-major: weights[i * m + k] */
    char *key, *mesh, *dtx_version;
} dtx_h5_weights;

/* Writes handles (m int32) and weights (nv x m doubles) and the attributes
 * key (hex hash of what determines them, computed by the caller), mesh
 * (HDF5 path of the mesh in this file, or text) and dtx_version.  Fails if
 * group exists.  Collective in parallel. */
dtx_status dtx_h5_write_weights(hid_t file, const char *group, const int32_t *handles, int32_t m,
                                const double *weights, int32_t nv, const char *key,
                                const char *mesh, dtx_error *err);

/* Reads a weight group into *w (zeroed on failure).  Checks the shapes
 * (handles m >= 1, weights nv x m, with nv the given count when >= 0),
 * handles in [0, nv) and every weight finite and in [0, 1]. */
dtx_status dtx_h5_read_weights(hid_t file, const char *group, int32_t nv, dtx_h5_weights *w,
                               dtx_error *err);

/* Frees everything *w owns and zeroes it.  Accepts NULL. */
void dtx_h5_weights_free(dtx_h5_weights *w);

/* As dtx_h5_find_corr_by_key, over the groups /weights/<name>. */
dtx_status dtx_h5_find_weights_by_key(hid_t file, const char *key, char **group_out,
                                      dtx_error *err);

/* ---------------------------------------------------------------- results */

/* Provenance attributes of a result (all strings; NULL stored as ""). */
typedef struct {
    const char *method;          /* "sp04", ... */
    const char *job;             /* the job JSON text */
    const char *parameters;      /* method parameters, JSON text */
    const char *source_sequence; /* "FILE:PATH" of the source sequence */
    const char *target_mesh;     /* HDF5 path, in this file, of the target mesh */
    const char *correspondence;  /* "FILE:PATH" or PATH of the correspondence, or "" */
} dtx_h5_provenance;

/* An open result group.  Fields are read-only for callers. */
typedef struct {
    hid_t file;                    /* not owned */
    hid_t group, positions, residual, frame_done; /* owned */
    hid_t frame_stats;             /* owned; H5I_INVALID_HID when the result has none */
    hid_t frame_grad_norm;         /* owned; H5I_INVALID_HID when the result has none */
    int64_t nframes;               /* T */
    int32_t nv;
    int is_f64;
    int chunk_frames;              /* frames per positions chunk */
    int parallel;
    int committed;                 /* 0 while under its temporary name */
    char path[DTX_H5_PATH_MAX];
    char final_path[DTX_H5_PATH_MAX];
    float *scratch;
    size_t scratch_n;
    uint8_t *ones;                 /* frame_done buffer (owned) */
    size_t ones_n;
} dtx_h5_result;

/* Creates a result group under its temporary name: positions (T x nv x 3,
 * float64 when f64 else float32, chunked by chunk_frames frames as for
 * sequences, gzip + shuffle when gzip != 0: serial files only), residual
 * (f64 T, fill NaN), frame_done (u8 T, fill 0), soft link "target" ->
 * prov->target_mesh (which must exist in file with nv vertices), the
 * provenance attributes, dtx_version and complete = 0.  Collective in
 * parallel: every rank calls with the same arguments.  Chunks never span
 * two ranks' frames when each rank's frame range starts at a multiple of
 * res->chunk_frames. */
dtx_status dtx_h5_result_create(hid_t file, const char *group, const dtx_h5_provenance *prov,
                                int64_t nframes, int32_t nv, int f64, int chunk_frames, int gzip,
                                dtx_h5_result *res, dtx_error *err);

/* Opens an existing result: resume == 0 opens the committed group `group`
 * (for reading); resume != 0 opens the in-progress group under its
 * temporary name (to continue writing frames whose frame_done is 0 and
 * then dtx_h5_result_finish).  Checks shapes as dtx_h5_seq_open does, and
 * that residual and frame_done have T entries. */
dtx_status dtx_h5_result_open(hid_t file, const char *group, int resume, dtx_h5_result *res,
                              dtx_error *err);

/* Writes frames [first, first+count): positions (count x nv x 3 doubles,
 * converted to the file dtype), residual (count doubles; NULL leaves NaN),
 * then frame_done[first..first+count) = 1, in that order.  collective as
 * for dtx_h5_seq_write (count == 0 ranks join with an empty selection).
 * frame_done is only as durable as the file: trust it after a normal close
 * or flush (HDF5 1.10 has no journal). */
dtx_status dtx_h5_result_write(dtx_h5_result *res, int64_t first, int64_t count,
                               const double *positions, const double *residual, int collective,
                               dtx_error *err);

/* Optional per-frame solver figures of a result (methods springs and
 * multicomponent): the dataset frame_stats, int32 T x DTX_H5_FRAME_STATS,
 * fill -1 (not yet written), columns in this order (also in its attribute
 * "columns"): iterations (Newton steps on the mesh itself, or Gauss-Newton
 * solves), converged (1 when the solve met its stopping test, 0 when it ran
 * out of iterations), inverted (triangles of the result turned over against
 * the source's rotation; -1 where the method does not count them). */
#define DTX_H5_FRAME_STATS 3
#define DTX_H5_FRAME_STATS_COLUMNS "iterations converged inverted"

/* Adds frame_stats to a result just created (collective in parallel, as
 * dtx_h5_result_create).  dtx_h5_result_open opens it when present. */
dtx_status dtx_h5_result_add_frame_stats(dtx_h5_result *res, dtx_error *err);

/* Writes rows [first, first+count) of frame_stats (count x
 * DTX_H5_FRAME_STATS int32); call before dtx_h5_result_write of the same
 * frames, which marks them done.  collective as for dtx_h5_result_write.
 * DTX_EINVAL when the result has no frame_stats. */
dtx_status dtx_h5_result_write_frame_stats(dtx_h5_result *res, int64_t first, int64_t count,
                                           const int32_t *stats, int collective,
                                           dtx_error *err);

/* Reads rows [first, first+count) of frame_stats (caller-allocated count x
 * DTX_H5_FRAME_STATS); DTX_EINVAL when the result has none. */
dtx_status dtx_h5_result_read_frame_stats(const dtx_h5_result *res, int64_t first,
                                          int64_t count, int32_t *stats, dtx_error *err);

/* Optional final gradient norm per frame of a result (method springs, the
 * methods whose table says reports_grad_norm): the dataset frame_grad_norm,
 * float64 T, fill NaN (not yet written), the Euclidean norm of the
 * gradient of the method's energy at the frame's result.  Added, written
 * and read as frame_stats: add after dtx_h5_result_create (collective in
 * parallel; DTX_EINVAL when it exists), write entries [first, first+count)
 * before dtx_h5_result_write marks them done (collective as for it), read
 * into count caller-allocated doubles; DTX_EINVAL when the result has
 * none.  dtx_h5_result_open opens it when present and checks it has T
 * entries. */
dtx_status dtx_h5_result_add_frame_grad_norm(dtx_h5_result *res, dtx_error *err);
dtx_status dtx_h5_result_write_frame_grad_norm(dtx_h5_result *res, int64_t first, int64_t count,
                                               const double *grad_norm, int collective,
                                               dtx_error *err);
dtx_status dtx_h5_result_read_frame_grad_norm(const dtx_h5_result *res, int64_t first,
                                              int64_t count, double *grad_norm, dtx_error *err);

/* The frame with the largest of T final gradient norms gn, among the
 * frames done (done[t] != 0) whose frame_stats row was written (fs NULL,
 * or fs[DTX_H5_FRAME_STATS * t] >= 0): the lowest frame on ties, a NaN
 * counting as larger than any number (a damaged file, which dtx validate
 * names).  -1 when there is no such frame. */
int64_t dtx_h5_grad_norm_max_frame(const double *gn, const int32_t *fs, const uint8_t *done,
                                   int64_t T);

/* Reads frames [first, first+count) of positions (count x nv x 3 doubles,
 * caller-allocated) and, when residual != NULL, the residuals (count). */
dtx_status dtx_h5_result_read(const dtx_h5_result *res, int64_t first, int64_t count,
                              double *positions, double *residual, dtx_error *err);

/* Reads frame_done into done (T bytes, caller-allocated). */
dtx_status dtx_h5_result_read_done(const dtx_h5_result *res, uint8_t *done, dtx_error *err);

/* Finishes a result: checks every frame_done is 1 (DTX_EINVAL naming the
 * first missing frame otherwise), sets complete = 1, moves the group to its
 * final name (replacing an existing result there when replace != 0) and
 * flushes the file.  Collective in parallel. */
dtx_status dtx_h5_result_finish(dtx_h5_result *res, int replace, dtx_error *err);

/* As dtx_h5_result_finish for n results of one file at once, with no
 * flush (closing the file, or a flush, writes the marks out): nothing is
 * marked or moved unless every result has all its frames.  In parallel
 * each rank reads frame_done after a barrier and the readings are combined
 * (a frame is done when any rank, such as the one that wrote it, reads it
 * as done), so no fsync is needed to see other ranks' writes.  Collective
 * in parallel (same results, same order on every rank). */
dtx_status dtx_h5_results_finish(dtx_h5_result *const *res, int n, int replace,
                                 dtx_error *err);

/* Closes the handles and frees the buffers.  Accepts a zeroed or already
 * closed struct. */
void dtx_h5_result_close(dtx_h5_result *res);

/* ---------------------------------------------------- layout description */

/* The machine-readable layout description (schemas/hdf5-layout-v1.json),
 * compiled into the library: a malloc'ed NUL-terminated copy (caller
 * frees), or NULL when out of memory. */
char *dtx_h5_layout_json(void);

/* Validates the file at path against the layout description and the cross
 * checks (face and pair indices in range, sizes agreeing with the linked
 * meshes, links resolving, frame_done all 1 in complete results, content
 * hashes).  *report receives a malloc'ed text, one line per object ("PATH:
 * ok") or per problem ("PATH: problem"), then a summary line.  Returns
 * DTX_OK when no problem was found, DTX_EFORMAT with the first problem in
 * err otherwise, DTX_EIO when the file cannot be opened as HDF5 (then
 * *report may be NULL). */
dtx_status dtx_h5_validate(const char *path, char **report, dtx_error *err);

/* ------------------------------------------------------------ frame rate */

/* The frame rate of a sequence or a result: attribute "fps" (scalar
 * float64, frames per second, > 0 and <= DTX_H5_FPS_MAX) on its group.
 * Optional (files written before it existed have none): a reader then
 * assumes DTX_H5_DEFAULT_FPS. */
#define DTX_H5_DEFAULT_FPS 24.0
#define DTX_H5_FPS_MAX 1e6

/* Writes (replaces) the attribute fps on the object at obj (relative to
 * loc).  DTX_EINVAL when fps is out of range. */
dtx_status dtx_h5_write_fps(hid_t loc, const char *obj, double fps, dtx_error *err);

/* Reads attribute fps of obj into *fps and sets *stored = 1; when the
 * attribute is absent, *fps = DTX_H5_DEFAULT_FPS, *stored = 0 and DTX_OK.
 * A stored value that is not a float or out of range is DTX_EFORMAT. */
dtx_status dtx_h5_read_fps(hid_t loc, const char *obj, double *fps, int *stored, dtx_error *err);

/* Copies attribute fps from the object `from` to the object `to` (open
 * groups) when `from` has one; nothing otherwise.  On a parallel file,
 * collective: every rank calls. */
dtx_status dtx_h5_copy_fps(hid_t from, hid_t to, dtx_error *err);

#endif /* DTX_H5LAYOUT_H */
