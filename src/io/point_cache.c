/* point_cache.c: what the MDD and PC2 writers share (see point_cache.h). */
#include "point_cache.h"
#include "byteorder.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

dtx_status dtx_point_cache_check(const char *path, int32_t num_points, int32_t num_samples,
                                 dtx_error *err)
{
    if (num_points < 1 || num_samples < 1)
        return dtx_seterr(err, DTX_EINVAL,
                          "%s: a point cache needs at least one point and one sample (got %d "
                          "points, %d samples)",
                          path, (int)num_points, (int)num_samples);
    return DTX_OK;
}

dtx_status dtx_point_cache_open(dtx_point_cache *w, const char *path, int32_t num_points,
                                int32_t num_samples, int big_endian, dtx_error *err)
{
    dtx_status st;
    memset(w, 0, sizeof *w);
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
    w->big_endian = big_endian;
    return DTX_OK;
}

void dtx_point_cache_abort(dtx_point_cache *w)
{
    dtx_atomic_abort(&w->af);
    free(w->buf);
    memset(w, 0, sizeof *w);
}

dtx_status dtx_point_cache_write(dtx_point_cache *w, const double *Xd, const float *Xf,
                                 dtx_error *err)
{
    if (!w->af.fp)
        return dtx_seterr(err, DTX_EINVAL, "point cache writer is not open");
    if (w->written >= w->num_samples) {
        dtx_status st = dtx_seterr(err, DTX_EINVAL, "%s: more than the %d samples announced",
                                   w->af.path, (int)w->num_samples);
        dtx_point_cache_abort(w);
        return st;
    }
    for (int64_t i = 0; i < 3 * (int64_t)w->num_points; i++) {
        /* Out-of-range double -> float conversion is undefined: test first. */
        int ok = Xd ? isfinite(Xd[i]) && fabs(Xd[i]) <= FLT_MAX : isfinite(Xf[i]);
        float f = ok ? (Xd ? (float)Xd[i] : Xf[i]) : 0.0f;
        if (!ok) {
            dtx_status st = dtx_seterr(
                err, DTX_ENONFINITE,
                "%s: sample %d, point %lld (0-based): coordinate %g is not a finite float32",
                w->af.path, (int)w->written, (long long)(i / 3), Xd ? Xd[i] : (double)Xf[i]);
            dtx_point_cache_abort(w);
            return st;
        }
        if (w->big_endian)
            dtx_put_bef32(w->buf + 4 * i, f);
        else
            dtx_put_lef32(w->buf + 4 * i, f);
    }
    fwrite(w->buf, 12, (size_t)w->num_points, w->af.fp); /* errors: caught by the commit */
    w->written++;
    return DTX_OK;
}

dtx_status dtx_point_cache_finish(dtx_point_cache *w, dtx_error *err)
{
    dtx_status st;
    if (!w->af.fp)
        return dtx_seterr(err, DTX_EINVAL, "point cache writer is not open");
    if (w->written != w->num_samples) {
        st = dtx_seterr(err, DTX_EINVAL, "%s: %d of the %d samples announced were written",
                        w->af.path, (int)w->written, (int)w->num_samples);
        dtx_point_cache_abort(w);
        return st;
    }
    st = dtx_atomic_commit(&w->af, err);
    free(w->buf);
    memset(w, 0, sizeof *w);
    return st;
}
