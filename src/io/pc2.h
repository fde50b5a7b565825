/*
 * pc2.h: PC2 point caches (".pc2", "Point Cache 2"), the vertex animation
 * format of 3ds Max's PointCache2 modifier that Blender's Mesh Cache
 * modifier, Maya (after conversion) and other tools read onto a rest mesh
 * with the same vertices in the same order.
 *
 * Format (John Burnett's PointCache2 README, "PC2 File Format",
 * http://www.footools.com/plugins/docs/PointCache2_README.html; the Blender
 * manual's "Pointcache (pc2)" add-on page; Blender's MOD_meshcache_pc2.c
 * reads the same fields), all little-endian:
 *
 *   offset  size  field
 *        0    12  char  signature[12]  "POINTCACHE2" and a NUL
 *       12     4  int32 version        1
 *       16     4  int32 num_points     vertices per sample
 *       20     4  float start_frame    frame of the first sample
 *       24     4  float sample_rate    frames between samples (1 = every frame)
 *       28     4  int32 num_samples
 *       32     -  float32 x, y, z per point per sample:
 *                 sample s, point i at byte 32 + 12 * (s * num_points + i)
 *
 * The file is exactly 32 + 12 * num_points * num_samples bytes.
 *
 * Writing streams one sample at a time (memory O(num_points), whatever the
 * number of samples) into a temporary file that is renamed over the final
 * path only when every sample has been written (src/io/atomic_file.h): an
 * error or an abort leaves no partial file and an existing file untouched.
 *
 * Thread-safety: reentrant; distinct writers may run concurrently.
 */
#ifndef DTX_PC2_H
#define DTX_PC2_H

#include "point_cache.h"
#include "status.h"

#include <stddef.h>
#include <stdint.h>

#define DTX_PC2_SIGNATURE "POINTCACHE2" /* 11 characters, then a NUL in the file */
#define DTX_PC2_VERSION 1
#define DTX_PC2_HEADER_BYTES 32

/* The header fields. */
typedef struct {
    int32_t version;     /* DTX_PC2_VERSION */
    int32_t num_points;  /* >= 1 */
    float start_frame;   /* finite */
    float sample_rate;   /* finite, > 0 */
    int32_t num_samples; /* >= 1 */
} dtx_pc2_header;

/* A PC2 file being written.  Fields are private. */
typedef struct {
    dtx_point_cache pc; /* little-endian */
    dtx_pc2_header h;
} dtx_pc2_writer;

/* Starts writing the cache at path: checks the header (num_points >= 1,
 * num_samples >= 1, 32 + 12 * num_points * num_samples fits in 63 bits,
 * start_frame finite, sample_rate finite and > 0; DTX_EINVAL otherwise, no
 * file created), creates the temporary file and writes the header.  On
 * failure *w is zeroed and nothing is left on disk. */
dtx_status dtx_pc2_begin(dtx_pc2_writer *w, const char *path, int32_t num_points,
                         int32_t num_samples, float start_frame, float sample_rate, dtx_error *err);

/* Appends one sample: X is num_points x 3 doubles (row-major), rounded to
 * float32 (round to nearest).  A coordinate that is not finite, or not
 * finite once rounded to float32, is DTX_ENONFINITE; more samples than
 * num_samples is DTX_EINVAL.  On any failure the writer is aborted (the
 * temporary file removed); the caller need not call dtx_pc2_abort, but
 * may. */
dtx_status dtx_pc2_write_sample(dtx_pc2_writer *w, const double *X, dtx_error *err);

/* As dtx_pc2_write_sample for float32 positions (num_points x 3). */
dtx_status dtx_pc2_write_sample_f32(dtx_pc2_writer *w, const float *X, dtx_error *err);

/* Checks that num_samples samples were written (DTX_EINVAL otherwise, and
 * the file is removed), then commits: flush, fsync, rename over path.  *w
 * is zeroed in every case. */
dtx_status dtx_pc2_finish(dtx_pc2_writer *w, dtx_error *err);

/* Removes the temporary file and frees the buffer; *w is zeroed.  Accepts
 * a zeroed (finished or aborted) writer. */
void dtx_pc2_abort(dtx_pc2_writer *w);

/* Parses a PC2 file held in the len bytes at buf (name is used in
 * messages).  Checks the signature, version 1, num_points >= 1,
 * num_samples >= 1, finite start_frame and sample_rate > 0, and that len
 * is exactly 32 + 12 * num_points * num_samples (checked before
 * allocating); DTX_EPARSE otherwise, with a message naming the field.
 * *P receives num_samples x num_points x 3 floats (malloc'ed, caller
 * frees; coordinates are returned as stored, NaN included).  On failure
 * *P is NULL. */
dtx_status dtx_pc2_parse(const char *name, const unsigned char *buf, size_t len, dtx_pc2_header *h,
                         float **P, dtx_error *err);

/* Reads the file at path and parses it as dtx_pc2_parse does; DTX_EIO when
 * it cannot be read. */
dtx_status dtx_pc2_read(const char *path, dtx_pc2_header *h, float **P, dtx_error *err);

#endif /* DTX_PC2_H */
