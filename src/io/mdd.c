/*
 * mdd.c: MDD point cache writer and parser (format in mdd.h).
 *
 * Bytes are packed explicitly in big-endian order, so the files are the
 * same on any host.
 */
#include "mdd.h"
#include "byteorder.h"

#include "meshfile_util.h"

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
    if ((st = dtx_point_cache_check(path, num_points, num_samples, err)) != DTX_OK)
        return st;
    if (!times)
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
    if ((st = dtx_point_cache_open(&w->pc, path, num_points, num_samples, 1, err)) != DTX_OK)
        return st;
    dtx_put_be32(b, (uint32_t)num_samples);
    dtx_put_be32(b + 4, (uint32_t)num_points);
    fwrite(b, 1, 8, w->pc.af.fp); /* errors: caught by the commit */
    for (int32_t k = 0; k < num_samples; k++) {
        dtx_put_bef32(b, times[k]);
        fwrite(b, 1, 4, w->pc.af.fp);
    }
    return DTX_OK;
}

void dtx_mdd_abort(dtx_mdd_writer *w) { dtx_point_cache_abort(&w->pc); }

dtx_status dtx_mdd_write_sample(dtx_mdd_writer *w, const double *X, dtx_error *err)
{
    return dtx_point_cache_write(&w->pc, X, NULL, err);
}

dtx_status dtx_mdd_finish(dtx_mdd_writer *w, dtx_error *err)
{
    return dtx_point_cache_finish(&w->pc, err);
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

dtx_status dtx_mdd_read(const char *path, int32_t *num_samples, int32_t *num_points, float **times,
                        float **P, dtx_error *err)
{
    char *buf = NULL;
    size_t len = 0;
    dtx_status st;
    *times = NULL;
    *P = NULL;
    *num_samples = *num_points = 0;
    if ((st = dtx_file_read_all(path, &buf, &len, err)) != DTX_OK)
        return st;
    st = dtx_mdd_parse(path, (const unsigned char *)buf, len, num_samples, num_points, times, P,
                       err);
    free(buf);
    return st;
}
