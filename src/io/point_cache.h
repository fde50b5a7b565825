/*
 * point_cache.h: what the MDD and PC2 writers share (internal to the I/O
 * layer): a file of num_samples samples of num_points float32 points,
 * written aside and committed by rename (atomic_file.h), each sample
 * checked for coordinates a float32 holds, in big- or little-endian order.
 * The header is each format's own (mdd.c, pc2.c).
 */
#ifndef DTX_POINT_CACHE_H
#define DTX_POINT_CACHE_H

#include "atomic_file.h"
#include "status.h"

#include <stdint.h>

/* A point cache being written.  Fields are private to mdd.c, pc2.c and
 * point_cache.c. */
typedef struct {
    dtx_atomic_file af;
    int32_t num_points, num_samples;
    int32_t written;    /* samples written so far */
    int big_endian;     /* MDD: 1, PC2: 0 */
    unsigned char *buf; /* one sample, in the file's order (12 * num_points bytes) */
} dtx_point_cache;

/* DTX_EINVAL naming path unless num_points >= 1 and num_samples >= 1. */
dtx_status dtx_point_cache_check(const char *path, int32_t num_points, int32_t num_samples,
                                 dtx_error *err);

/* Allocates the sample buffer and creates the temporary file; the caller
 * then writes its header to w->af.fp.  On failure *w is zeroed and no file
 * is left. */
dtx_status dtx_point_cache_open(dtx_point_cache *w, const char *path, int32_t num_points,
                                int32_t num_samples, int big_endian, dtx_error *err);

/* Appends one sample: exactly one of Xd, Xf (num_points x 3) is non-NULL.
 * A coordinate that is not a finite float32, a sample beyond num_samples or
 * a writer that is not open is an error; the first two abort the file. */
dtx_status dtx_point_cache_write(dtx_point_cache *w, const double *Xd, const float *Xf,
                                 dtx_error *err);

/* Commits the file when all num_samples samples were written (else
 * aborts it); *w is zeroed either way. */
dtx_status dtx_point_cache_finish(dtx_point_cache *w, dtx_error *err);

/* Removes the temporary file and zeroes *w. */
void dtx_point_cache_abort(dtx_point_cache *w);

#endif /* DTX_POINT_CACHE_H */
