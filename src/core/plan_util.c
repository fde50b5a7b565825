/* plan_util.c: building blocks the transfer plans share (see plan_util.h). */
#include "plan_util.h"

#include <stdlib.h>

#ifdef _OPENMP
#include <omp.h>
#endif

dtx_status dtx__check_pins(dtx_anchor anchor, const int32_t *pins, int32_t npins, int32_t nv,
                           dtx_error *err)
{
    if (anchor == DTX_ANCHOR_PINS && npins < 1)
        return dtx_seterr(err, DTX_EINVAL, "translation \"pins\" needs at least one pinned vertex");
    for (int32_t i = 0; i < npins; i++)
        if (pins[i] < 0 || pins[i] >= nv)
            return dtx_seterr(err, DTX_ERANGE, "pin %d: vertex %d out of range [0, %d)", (int)i,
                              (int)pins[i], (int)nv);
    return DTX_OK;
}

dtx_status dtx__check_pairs(const int32_t *pairs, int64_t npairs, int32_t nf_src, int32_t nf_tgt,
                            dtx_error *err)
{
    for (int64_t i = 0; i < npairs; i++)
        if (pairs[2 * i] < 0 || pairs[2 * i] >= nf_src || pairs[2 * i + 1] < 0 ||
            pairs[2 * i + 1] >= nf_tgt)
            return dtx_seterr(err, DTX_ERANGE,
                              "correspondence pair %lld (%d, %d) out of range (%d source, %d "
                              "target triangles)",
                              (long long)i, (int)pairs[2 * i], (int)pairs[2 * i + 1], (int)nf_src,
                              (int)nf_tgt);
    return DTX_OK;
}

void dtx__centroid(const double *X, int32_t n, double *c)
{
    c[0] = c[1] = c[2] = 0.0;
    for (int32_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++)
            c[k] += X[3 * (size_t)i + k];
    for (int k = 0; k < 3; k++)
        c[k] /= n;
}

double dtx__now_seconds(void)
{
#ifdef _OPENMP
    return omp_get_wtime();
#else
    return 0.0;
#endif
}

void dtx__workers_free(dtx__workers *ws, void *plan, void (*fini)(void *plan, void *workspace))
{
    for (int w = 0; w < ws->n; w++)
        fini(plan, dtx__worker(ws, w));
    free(ws->set);
    ws->set = NULL;
    ws->n = 0;
}

dtx_status dtx__workers_ensure(dtx__workers *ws, size_t size, void *plan,
                               int (*init)(void *plan, void *workspace),
                               void (*fini)(void *plan, void *workspace), const char *what,
                               dtx_error *err)
{
    int n = 1;
#ifdef _OPENMP
    n = omp_get_max_threads();
#endif
    if (ws->n >= n)
        return DTX_OK;
    dtx__workers_free(ws, plan, fini);
    ws->set = calloc((size_t)n, size);
    if (!ws->set)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory for %s", what);
    ws->n = n;
    ws->size = size;
    for (int w = 0; w < n; w++)
        if (!init(plan, dtx__worker(ws, w))) {
            dtx__workers_free(ws, plan, fini);
            return dtx_seterr(err, DTX_ENOMEM, "out of memory for %s", what);
        }
    return DTX_OK;
}
