/*
 * mdd.h: MDD point caches (".mdd", LightWave's Motion Designer point
 * cache), the other vertex animation format Blender's Mesh Cache modifier
 * reads (besides PC2), also read by Houdini, Maya plug-ins and LightWave.
 * It is applied to a rest mesh with the same vertices in the same order.
 *
 * Format (as Blender's MOD_meshcache_mdd.c reads it), all big-endian:
 *
 *   offset         size      field
 *        0            4      int32 frame_tot   samples (>= 1)
 *        4            4      int32 verts_tot   points per sample (>= 1)
 *        8  4*frame_tot      float32 time[frame_tot]  seconds of each sample,
 *                            increasing (Blender looks them up when the
 *                            modifier's time mode is "Seconds")
 *        -  12*verts_tot     float32 x, y, z per point, per sample:
 *                            sample s, point i at byte
 *                            8 + 4 * frame_tot + 12 * (s * verts_tot + i)
 *
 * The file is exactly 8 + 4 * frame_tot + 12 * verts_tot * frame_tot
 * bytes.  There is no signature: a reader checks the counts against the
 * mesh and the file size.
 *
 * Writing streams one sample at a time (memory O(verts_tot)) into a
 * temporary file renamed over the path only when every sample has been
 * written (src/io/atomic_file.h): an error leaves no partial file and an
 * existing file untouched.
 *
 * Thread-safety: reentrant; distinct writers may run concurrently.
 */
#ifndef DTX_MDD_H
#define DTX_MDD_H

#include "point_cache.h"
#include "status.h"

#include <stddef.h>
#include <stdint.h>

/* An MDD file being written.  Fields are private. */
typedef struct {
    dtx_point_cache pc; /* big-endian */
} dtx_mdd_writer;

/* Starts writing the cache at path: checks num_points >= 1, num_samples
 * >= 1, and times (num_samples floats, seconds) finite and strictly
 * increasing (DTX_EINVAL otherwise, no file created), creates the
 * temporary file and writes the header and the times.  On failure *w is
 * zeroed and nothing is left on disk. */
dtx_status dtx_mdd_begin(dtx_mdd_writer *w, const char *path, int32_t num_points,
                         int32_t num_samples, const float *times, dtx_error *err);

/* Appends one sample: X is num_points x 3 doubles (row-major), rounded to
 * float32.  A coordinate that is not a finite float32 once rounded is
 * DTX_ENONFINITE; more samples than announced is DTX_EINVAL.  On failure
 * the writer is aborted (temporary file removed). */
dtx_status dtx_mdd_write_sample(dtx_mdd_writer *w, const double *X, dtx_error *err);

/* Checks that every sample was written (DTX_EINVAL otherwise, file
 * removed), then commits (flush, fsync, rename).  *w is zeroed. */
dtx_status dtx_mdd_finish(dtx_mdd_writer *w, dtx_error *err);

/* Removes the temporary file and frees the buffer; *w is zeroed.  Accepts
 * a zeroed writer. */
void dtx_mdd_abort(dtx_mdd_writer *w);

/* Parses an MDD held in the len bytes at buf (name used in messages):
 * frame_tot >= 1, verts_tot >= 1, len exactly as above (checked before
 * allocating); DTX_EPARSE otherwise.  *times receives frame_tot floats and
 * *P frame_tot x verts_tot x 3 floats (malloc'ed, caller frees; NULL on
 * failure). */
dtx_status dtx_mdd_parse(const char *name, const unsigned char *buf, size_t len,
                         int32_t *num_samples, int32_t *num_points, float **times, float **P,
                         dtx_error *err);

/* Reads the file at path and parses it as dtx_mdd_parse does; DTX_EIO
 * when it cannot be read. */
dtx_status dtx_mdd_read(const char *path, int32_t *num_samples, int32_t *num_points, float **times,
                        float **P, dtx_error *err);

#endif /* DTX_MDD_H */
