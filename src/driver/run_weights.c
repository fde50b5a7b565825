/*
 * run_weights.c: the bounded biharmonic weights of method biharmonic, once
 * per run and shared out over the ranks.
 *
 * A target's plan needs the weights of its key points on the source and on
 * the target (bbw.h), the slow part of building it.  Here the m handles of
 * a mesh are split into contiguous blocks, one per rank (rank q solves
 * handles [m q / P, m (q + 1) / P)), each rank's rows are broadcast to the
 * others, and every rank normalises the gathered rows alike
 * (dtx_bbw_handles, dtx_bbw_normalise): the result is bitwise what one
 * rank computing everything would get, at any number of ranks and
 * threads.  Source weights are computed once for a set of source key
 * points: the key-point selection's closing evaluation already holds them
 * for the selected set, and targets sharing the source key points of the
 * previous target share its weights.
 */
#include "run_internal.h"

#include "bbw.h"

#include <stdlib.h>
#include <string.h>

/* The weights (nv x m) of handles on mesh, computed by the ranks
 * together.  Collective; every rank gets the same bits or the same error. */
static dtx_status shared_bbw(run_state *r, const dtx_mesh *mesh, const int32_t *handles,
                             int32_t m, double **W, dtx_error *err)
{
    size_t nv = (size_t)mesh->nv;
    int32_t k0 = (int32_t)((int64_t)m * r->rank / r->nranks);
    int32_t k1 = (int32_t)((int64_t)m * (r->rank + 1) / r->nranks);
    double *Wk = dtx_alloc(nv, (size_t)m * sizeof *Wk, 0);
    dtx_status st;

    *W = dtx_alloc(nv, (size_t)m * sizeof **W, 0);
    st = Wk && *W ? DTX_OK : dtx_seterr(err, DTX_ENOMEM, "out of memory");
    if (st == DTX_OK)
        st = dtx_bbw_handles(mesh, handles, m, k0, k1, NULL, Wk + (size_t)k0 * nv, NULL, err);
    if ((st = run_agree(r->comm, st, err)) != DTX_OK)
        goto fail;
    /* Handle k's row from the rank that solved it (nv doubles per call,
     * below MPI's int count for any mesh dtx reads). */
    for (int q = 0; q < r->nranks; q++) {
        int32_t a = (int32_t)((int64_t)m * q / r->nranks);
        int32_t b = (int32_t)((int64_t)m * (q + 1) / r->nranks);
        for (int32_t k = a; k < b; k++)
            MPI_Bcast(Wk + (size_t)k * nv, (int)nv, MPI_DOUBLE, q, r->comm);
    }
    st = dtx_bbw_normalise(mesh, handles, m, Wk, NULL, *W, NULL, err);
    if ((st = run_agree(r->comm, st, err)) != DTX_OK)
        goto fail;
    free(Wk);
    return DTX_OK;
fail:
    free(Wk);
    free(*W);
    *W = NULL;
    return st;
}

static int same_keys(const int32_t *a, int32_t na, const int32_t *b, int32_t nb)
{
    return a && b && na == nb && memcmp(a, b, (size_t)na * sizeof *a) == 0;
}

dtx_status run_bh_weights(run_state *r, const target_ctx *tc, const double **Ws,
                          const double **Wt, dtx_error *err)
{
    int32_t m = tc->keys.n;
    double t0 = run_wtime(), *W = NULL;
    const char *src_from = "computed";
    dtx_status st;

    *Ws = *Wt = NULL;
    free(r->bh_Wt);
    r->bh_Wt = NULL;
    if (same_keys(tc->keys.src, m, r->kp.keys, r->kp.count) && r->kp.weights) {
        *Ws = r->kp.weights;
        src_from = "from the key-point selection";
    } else if (same_keys(tc->keys.src, m, r->bh_src_keys, r->bh_src_m)) {
        *Ws = r->bh_Ws;
        src_from = "as for the previous target";
    } else {
        free(r->bh_Ws);
        free(r->bh_src_keys);
        r->bh_Ws = NULL;
        r->bh_src_m = 0;
        r->bh_src_keys = dtx_alloc((size_t)m, sizeof *r->bh_src_keys, 0);
        st = r->bh_src_keys ? DTX_OK : dtx_seterr(err, DTX_ENOMEM, "out of memory");
        if ((st = run_agree(r->comm, st, err)) != DTX_OK)
            return st;
        if ((st = shared_bbw(r, &r->src, tc->keys.src, m, &W, err)) != DTX_OK) {
            dtx_error_prefix(err, "biharmonic: source weights");
            return st;
        }
        memcpy(r->bh_src_keys, tc->keys.src, (size_t)m * sizeof *r->bh_src_keys);
        r->bh_src_m = m;
        *Ws = r->bh_Ws = W;
    }
    if ((st = shared_bbw(r, &tc->mesh, tc->keys.tgt, m, &W, err)) != DTX_OK) {
        dtx_error_prefix(err, "biharmonic: target weights");
        *Ws = NULL;
        return st;
    }
    *Wt = r->bh_Wt = W;
    run_say(r,
            "dtx: target %s: bounded biharmonic weights of %d key points in %.2f s (source %s; "
            "handles shared over %d rank(s) x %d thread(s))",
            tc->tj->name, (int)m, run_wtime() - t0, src_from, r->nranks, r->nthreads);
    return DTX_OK;
}

void run_bh_weights_free(run_state *r)
{
    free(r->bh_Ws);
    free(r->bh_Wt);
    free(r->bh_src_keys);
    r->bh_Ws = r->bh_Wt = NULL;
    r->bh_src_keys = NULL;
    r->bh_src_m = 0;
}
