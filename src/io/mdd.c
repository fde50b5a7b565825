/*
 * mdd.c: MDD point cache writer and parser (format in mdd.h).
 *
 * Bytes are packed explicitly in big-endian order, so the files are the
 * same on any host.
 */
#include "mdd.h"
#include "byteorder.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---------------------------------------------------------------- writing */

dtx_status dtx_mdd_begin(dtx_mdd_writer *w, const char *path, int32_t num_points,
                         int32_t num_samples, const float *times, dtx_error *err)
{
    unsigned char b[8];
    dtx_status st;
    memset(w, 0, sizeof *w);
    if (num_points < 1 || num_samples < 1 || !times)
        return dtx_seterr(err, DTX_EINVAL,
                          "%s: a point cache needs at least one point and one sample (got %d "
                          "points, %d samples)",
                          path, (int)num_points, (int)num_samples);
    for (int32_t k = 0; k < num_samples; k++)
        if (!isfinite(times[k]) || (k > 0 && !(times[k] > times[k - 1])))
            return dtx_seterr(err, DTX_EINVAL,
                              "%s: sample %d (0-based): time %g s is not finite or not after "
                              "the previous sample's",
                              path, (int)k, (double)times[k]);
    w->buf = dtx_alloc((size_t)num_points, 12, 0);
    if (!w->buf)
        return dtx_seterr(err, DTX_ENOMEM, "%s: out of memory for %d points", path,
                          (int)num_points);
    st = dtx_atomic_open(&w->af, path, err);
    if (st != DTX_OK) {
        free(w->buf);
        memset(w, 0, sizeof *w);
        return st;
    }
    w->num_points = num_points;
    w->num_samples = num_samples;
    dtx_put_be32(b, (uint32_t)num_samples);
    dtx_put_be32(b + 4, (uint32_t)num_points);
    fwrite(b, 1, 8, w->af.fp); /* errors: caught by the commit */
    for (int32_t k = 0; k < num_samples; k++) {
        dtx_put_bef32(b, times[k]);
        fwrite(b, 1, 4, w->af.fp);
    }
    return DTX_OK;
}

void dtx_mdd_abort(dtx_mdd_writer *w)
{
    dtx_atomic_abort(&w->af);
    free(w->buf);
    memset(w, 0, sizeof *w);
}

dtx_status dtx_mdd_write_sample(dtx_mdd_writer *w, const double *X, dtx_error *err)
{
    if (!w->af.fp)
        return dtx_seterr(err, DTX_EINVAL, "point cache writer is not open");
    if (w->written >= w->num_samples) {
        dtx_status st = dtx_seterr(err, DTX_EINVAL, "%s: more than the %d samples announced",
                                   w->af.path, (int)w->num_samples);
        dtx_mdd_abort(w);
        return st;
    }
    for (int64_t i = 0; i < 3 * (int64_t)w->num_points; i++) {
        /* Out-of-range double -> float conversion is undefined: test first. */
        if (!(isfinite(X[i]) && fabs(X[i]) <= FLT_MAX)) {
            dtx_status st = dtx_seterr(
                err, DTX_ENONFINITE,
                "%s: sample %d, point %lld (0-based): coordinate %g is not a finite float32",
                w->af.path, (int)w->written, (long long)(i / 3), X[i]);
            dtx_mdd_abort(w);
            return st;
        }
        dtx_put_bef32(w->buf + 4 * i, (float)X[i]);
    }
    fwrite(w->buf, 12, (size_t)w->num_points, w->af.fp);
    w->written++;
    return DTX_OK;
}

dtx_status dtx_mdd_finish(dtx_mdd_writer *w, dtx_error *err)
{
    dtx_status st;
    if (!w->af.fp)
        return dtx_seterr(err, DTX_EINVAL, "point cache writer is not open");
    if (w->written != w->num_samples) {
        st = dtx_seterr(err, DTX_EINVAL, "%s: %d of the %d samples announced were written",
                        w->af.path, (int)w->written, (int)w->num_samples);
        dtx_mdd_abort(w);
        return st;
    }
    st = dtx_atomic_commit(&w->af, err);
    free(w->buf);
    memset(w, 0, sizeof *w);
    return st;
}

/* ---------------------------------------------------------------- reading */

dtx_status dtx_mdd_parse(const char *name, const unsigned char *buf, size_t len,
                         int32_t *num_samples, int32_t *num_points, float **times, float **P,
                         dtx_error *err)
{
    int32_t T, n;
    uint64_t want;
    size_t np;
    *times = NULL;
    *P = NULL;
    *num_samples = *num_points = 0;
    if (len < 8)
        return dtx_seterr(err, DTX_EPARSE, "%s: %zu bytes, shorter than the 8-byte MDD header",
                          name, len);
    T = dtx_get_bei32(buf);
    n = dtx_get_bei32(buf + 4);
    if (T < 1 || n < 1)
        return dtx_seterr(err, DTX_EPARSE, "%s: %d samples and %d points (both must be >= 1)", name,
                          (int)T, (int)n);
    want = 8u + 4u * (uint64_t)T + 12u * (uint64_t)n * (uint64_t)T;
    if ((uint64_t)len != want)
        return dtx_seterr(err, DTX_EPARSE,
                          "%s: %zu bytes, but %d samples x %d points need %llu (%s)", name, len,
                          (int)T, (int)n, (unsigned long long)want,
                          (uint64_t)len < want ? "truncated" : "trailing bytes");
    np = 3 * (size_t)n * (size_t)T;
    *times = dtx_alloc((size_t)T, sizeof **times, 0);
    *P = dtx_alloc(np, sizeof **P, 0);
    if (!*times || !*P) {
        free(*times);
        free(*P);
        *times = *P = NULL;
        return dtx_seterr(err, DTX_ENOMEM, "%s: out of memory for %zu floats", name, np);
    }
    for (int32_t k = 0; k < T; k++)
        (*times)[k] = dtx_get_bef32(buf + 8 + 4 * (size_t)k);
    for (size_t i = 0; i < np; i++)
        (*P)[i] = dtx_get_bef32(buf + 8 + 4 * (size_t)T + 4 * i);
    *num_samples = T;
    *num_points = n;
    return DTX_OK;
}
