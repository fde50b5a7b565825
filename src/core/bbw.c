/*
 * bbw.c: bounded biharmonic weights by a primal-dual active-set method, one
 * box-constrained quadratic programme per handle (bbw.h).
 *
 * For handle k the programme is: minimise 1/2 x' Q x over x in R^nv with
 * x(h_j) = delta_jk and 0 <= x <= 1 elsewhere.  Its KKT conditions at a free
 * vertex i, with the multiplier lambda_i = (Q x)_i (the gradient), are
 *   0 < x_i < 1 and lambda_i = 0,  or  x_i = 0 and lambda_i >= 0,
 *   or  x_i = 1 and lambda_i <= 0.
 * The primal-dual active-set iteration (Hintermueller, Ito & Kunisch 2002)
 * guesses which vertices sit at a bound, solves the equality-constrained
 * problem on the others, and revises the guess: a free vertex that left [0,
 * 1] is fixed at the bound it crossed, a fixed vertex whose multiplier has
 * the wrong sign is freed.  When the guess stops changing the KKT
 * conditions hold (up to the tolerances below) and x is the exact minimiser.
 * Q is not an M-matrix, so convergence is not guaranteed in theory; the
 * iteration count is capped (dtx_bbw_params.max_iter).
 *
 * Two changes to the plain iteration, neither of which changes the answer
 * (the last iteration is always a plain one that changes nothing):
 *  - Expansion.  Starting from the unconstrained minimiser, the first step
 *    fixes every vertex where it is negative, which is too many: the
 *    bounded weight's support is wider.  Plain PDAS then frees them only
 *    about two rings per iteration, since a fixed vertex gets a non-zero
 *    multiplier only within the stencil of Q (the 2-ring) of the free
 *    region.  So a vertex freed by its multiplier also frees its fixed
 *    Q-neighbours, each vertex at most once (a vertex freed this way and
 *    fixed again is left to the plain rule), which bounds the extra work.
 *  - Islands.  A free vertex whose solution is exactly 0 (cut off from the
 *    handle by fixed vertices) is fixed at 0: same x, smaller systems.
 *  - Local steps.  The bounded weight has a tail of tiny positive values
 *    (down to the tolerances, 1e-12 and below) reaching far from the
 *    handle, and the boundary of the support moves out by about one
 *    2-ring per iteration while it resolves that tail: on the cat and the
 *    lion 46 to over 100 iterations per handle, each a factorisation of a
 *    block of thousands of vertices that changes by tens of vertices.  So
 *    after a (global) iteration that changed the sets, up to LOCAL_STEPS
 *    local iterations follow, each solving only on the free vertices
 *    within LOCAL_RINGS Q-rings of the vertices the last update changed,
 *    every other vertex held at its current value (a small block), then
 *    updating the sets by the same rules.  A local iteration that changes
 *    nothing, or the last of the LOCAL_STEPS, hands over to a global one.
 *    Only a global iteration that changes nothing ends the method, so the
 *    result satisfies the same KKT conditions to the same tolerances.
 *    max_iter counts the global iterations.
 * On the cactus (5, 10 and 20 handles) the expansion and islands took 946
 * factorisations instead of 1,276, of 40% smaller systems on average, for
 * bitwise the same energies; 11 to 18 iterations per handle.  The local
 * steps take the cat's 6 programmes of the cat -> lion job from 463
 * global iterations (one stopped at the cap of 100) to 71 (at most 17),
 * plus 536 local ones, and the lion's from 413 (two at the cap) to 69 (at
 * most 19) plus 493: about a third of the CPU time (README, Biharmonic
 * transfer).  Every programme now converges; the weights are within 5e-9
 * (cat) and 1.7e-8 (lion) of those of a run with a cap of 1,000 (which
 * the old capped ones were within 2.4e-7 of): the tolerances decide how far
 * the tail reaches, and with it the last digits.
 *
 * Each iteration factors Q on the free vertices from scratch: the free
 * block changes by a few hundred vertices per iteration, and updating a
 * factorisation of the whole mesh row by row (cholmod_rowadd / rowdel) was
 * measured slower than a fresh one of the block.  The block is not
 * ordered afresh, though: the fill-reducing ordering (AMD) of the whole
 * mesh, computed once per call, restricted to the free vertices, orders
 * every block.  Ordering each block took about a fifth of the time; with
 * the shared ordering the iterations and active sets on the cat and the
 * lion are the same and the weights differ by rounding (< 2e-10).
 */
#include "bbw.h"

#include "bbw_internal.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

enum { FREE = 0, AT_LO = 1, AT_HI = 2, HANDLE = 3 };

/* A free vertex leaves the box when it is beyond a bound by more than
 * TOL_X; a fixed vertex is freed when its multiplier has the wrong sign by
 * more than TOL_LAMBDA times the largest row sum of |Q| (a bound on
 * |lambda| for x in [0, 1]).  Both keep rounding noise from cycling a
 * vertex in and out of the active set. */
#define TOL_X 1e-12
#define TOL_LAMBDA 1e-13

/* Local steps (see the file comment): at most LOCAL_STEPS local iterations
 * after each global one, on the free vertices within LOCAL_RINGS Q-rings
 * (2 LOCAL_RINGS mesh rings) of the vertices the last update changed.
 * Measured on the cat and the lion: 10 and 3 need the least time (5 and
 * 2, 10 and 2, 10 and 4, 30 and 4 all take 1.0x to 1.3x of it). */
#define LOCAL_STEPS 10
#define LOCAL_RINGS 3

void dtx_bbw_params_default(dtx_bbw_params *prm)
{
    prm->max_iter = 100;
    prm->normalise = 1;
}

/* Per-thread scratch, allocated once for all the handles a thread does. */
typedef struct {
    cholmod_common cc;
    int started;
    cholmod_dense *X, *Y, *E; /* cholmod_solve2's result and workspace, reused */
    int32_t *idx;             /* nv: index among the free vertices, -1 if fixed */
    int32_t *fvert;           /* nv: vertex of each free index */
    unsigned char *state;     /* nv: FREE, AT_LO, AT_HI, HANDLE */
    double *x;                /* nv: the iterate */
    double *b;                /* nv: right-hand side on the free vertices */
    unsigned char *expanded;  /* nv: already freed once by the expansion */
    unsigned char *mark;      /* nv: to be freed by the expansion */
    int32_t *fperm;           /* nv: the free block's ordering (the mesh's, restricted) */
    unsigned char *wasfree;   /* nv: free in the solve just done (before the update) */
    unsigned char *band;      /* nv: a local solve's vertices (with the changed ones first) */
    int32_t *queue;           /* nv: the band's breadth-first search */
    int local;                /* the next solve is local: only the band's free vertices */
    int first;                /* the next solve is a programme's first (see L0) */
    cholmod_factor *L0;       /* the first solve's factor, kept for the thread's next handles */
    dtx_error err;
} thread_ws;

static void ws_free(thread_ws *w)
{
    if (w->started) {
        cholmod_free_factor(&w->L0, &w->cc);
        cholmod_free_dense(&w->X, &w->cc);
        cholmod_free_dense(&w->Y, &w->cc);
        cholmod_free_dense(&w->E, &w->cc);
        cholmod_finish(&w->cc);
    }
    free(w->idx);
    free(w->fvert);
    free(w->state);
    free(w->x);
    free(w->b);
    free(w->expanded);
    free(w->mark);
    free(w->fperm);
    free(w->wasfree);
    free(w->band);
    free(w->queue);
    memset(w, 0, sizeof *w);
}

static int ws_alloc(thread_ws *w, int32_t nv)
{
    memset(w, 0, sizeof *w);
    dtx__bbw_chol_start(&w->cc);
    /* Every free block is ordered by the mesh's ordering (see solve_free). */
    w->cc.nmethods = 1;
    w->cc.method[0].ordering = CHOLMOD_GIVEN;
    w->started = 1;
    w->idx = dtx_alloc((size_t)nv, sizeof *w->idx, 0);
    w->fvert = dtx_alloc((size_t)nv, sizeof *w->fvert, 0);
    w->state = dtx_alloc((size_t)nv, 1, 0);
    w->x = dtx_alloc((size_t)nv, sizeof *w->x, 0);
    w->b = dtx_alloc((size_t)nv, sizeof *w->b, 0);
    w->expanded = dtx_alloc((size_t)nv, 1, 0);
    w->mark = dtx_alloc((size_t)nv, 1, 0);
    w->fperm = dtx_alloc((size_t)nv, sizeof *w->fperm, 0);
    w->wasfree = dtx_alloc((size_t)nv, 1, 0);
    w->band = dtx_alloc((size_t)nv, 1, 0);
    w->queue = dtx_alloc((size_t)nv, sizeof *w->queue, 0);
    return w->idx && w->fvert && w->state && w->x && w->b && w->expanded && w->mark &&
           w->fperm && w->wasfree && w->band && w->queue;
}

/* Solves for x on the FREE vertices (only those in w->band when w->local)
 * with every other vertex held at its current value, the block ordered by
 * order (nv vertices, the mesh's fill-reducing ordering: mesh_order)
 * restricted to them.  A programme's first solve (w->first) has every
 * vertex but the handles free, whichever handle it is for: the same block
 * for all the handles of a call, so its factor is kept in w->L0 and the
 * thread's later programmes only solve with it (the same factor, so the
 * same bits as factoring it again).  Returns DTX_OK or an error in
 * w->err. */
static dtx_status solve_free(const dtx_csr *Q, int32_t nv, const int32_t *order, thread_ws *w)
{
    int32_t nfree = 0;
    cholmod_sparse *A = NULL;
    cholmod_factor *L = NULL;
    cholmod_dense B;
    dtx_status st = DTX_OK;

    for (int32_t i = 0; i < nv; i++) {
        int unknown = w->state[i] == FREE && (!w->local || w->band[i]);
        w->idx[i] = unknown ? nfree : -1;
        if (unknown)
            w->fvert[nfree++] = i;
    }
    if (nfree == 0)
        return DTX_OK;
    /* b = -Q(free, fixed) x(fixed). */
    for (int32_t k = 0; k < nfree; k++) {
        int32_t v = w->fvert[k];
        double s = 0.0;
        for (int64_t p = Q->rowptr[v]; p < Q->rowptr[v + 1]; p++) {
            int32_t c = Q->col[p];
            if (w->idx[c] < 0 && w->x[c] != 0.0)
                s += Q->val[p] * w->x[c];
        }
        w->b[k] = -s;
    }
    if (w->first && w->L0) {
        L = w->L0;
        goto solve;
    }
    A = dtx__block(Q, w->idx, w->fvert, nfree, &w->cc);
    if (!A)
        return dtx_seterr(&w->err, DTX_ENOMEM, "bounded biharmonic weights: out of memory for "
                          "a %d x %d system", (int)nfree, (int)nfree);
    /* The fill-reducing ordering of the whole mesh restricted to the free
     * vertices: a subset of a good elimination order is a good one for the
     * subset's block, and ordering every block afresh (AMD) took a fifth
     * of the time. */
    for (int32_t p = 0, n = 0; p < nv; p++)
        if (w->idx[order[p]] >= 0)
            w->fperm[n++] = w->idx[order[p]];
    L = cholmod_analyze_p(A, w->fperm, NULL, 0, &w->cc);
    if (!L)
        st = dtx__chol_error(NULL, "analysed", "bounded biharmonic weights: the biharmonic system",
                             NULL, &w->cc, &w->err);
    else
        st = dtx__chol_factorize(A, DTX__CHOL_TEAMS,
                                 "bounded biharmonic weights: the biharmonic system",
                                 "; the mesh may have degenerate triangles", L, &w->cc, &w->err);
    if (st != DTX_OK)
        goto done;
    if (w->first)
        w->L0 = L;
solve:
    memset(&B, 0, sizeof B);
    B.nrow = B.nzmax = B.d = (size_t)nfree;
    B.ncol = 1;
    B.x = w->b;
    B.xtype = CHOLMOD_REAL;
    B.dtype = CHOLMOD_DOUBLE;
    if (!cholmod_solve2(CHOLMOD_A, L, &B, NULL, &w->X, NULL, &w->Y, &w->E, &w->cc)) {
        st = dtx_seterr(&w->err, DTX_ENOMEM, "bounded biharmonic weights: out of memory "
                        "solving a %d x %d system", (int)nfree, (int)nfree);
        goto done;
    }
    for (int32_t k = 0; k < nfree; k++)
        w->x[w->fvert[k]] = ((const double *)w->X->x)[k];
done:
    if (L != w->L0)
        cholmod_free_factor(&L, &w->cc);
    cholmod_free_sparse(&A, &w->cc);
    return st;
}

/* w->band: the vertices marked in w->band on entry (those the update
 * changed) and everything within rings Q-rings of them. */
static void grow_band(const dtx_csr *Q, int32_t nv, int rings, thread_ws *w)
{
    int32_t head = 0, tail = 0;
    for (int32_t i = 0; i < nv; i++)
        if (w->band[i])
            w->queue[tail++] = i;
    for (int r = 0; r < rings; r++) {
        int32_t end = tail;
        for (; head < end; head++) {
            int32_t v = w->queue[head];
            for (int64_t p = Q->rowptr[v]; p < Q->rowptr[v + 1]; p++) {
                int32_t c = Q->col[p];
                if (!w->band[c]) {
                    w->band[c] = 1;
                    w->queue[tail++] = c;
                }
            }
        }
    }
}

/* The programme of handle k (see the file comment), its blocks ordered by
 * order (solve_free).  Writes x, clamped to [0, 1], into wk (nv).
 * *iterations counts the global iterations, *local the local ones. */
static dtx_status solve_handle(const dtx_csr *Q, int32_t nv, const int32_t *order,
                               const int32_t *handles, int32_t m, int32_t k, int max_iter,
                               double tol_lambda, thread_ws *w, double *wk, int *iterations,
                               int *local, int *converged)
{
    int it = 0, nlocal = 0;
    dtx_status st;

    for (int32_t i = 0; i < nv; i++) {
        w->state[i] = FREE;
        w->x[i] = 0.0;
        w->expanded[i] = 0;
        w->mark[i] = 0;
    }
    for (int32_t j = 0; j < m; j++)
        w->state[handles[j]] = HANDLE;
    w->x[handles[k]] = 1.0;
    *converged = 0;
    *local = 0;
    w->local = 0;
    w->first = 1;
    while (it < max_iter) {
        int32_t changed = 0;
        st = solve_free(Q, nv, order, w);
        w->first = 0;
        if (st != DTX_OK)
            return st;
        if (w->local)
            ++*local;
        else
            it++;

        /* The primal-dual update.  wasfree tells which vertices were free
         * before it; band marks the ones it changes, around which the next
         * local solve is. */
        for (int32_t i = 0; i < nv; i++) {
            w->wasfree[i] = w->state[i] == FREE;
            w->band[i] = 0;
        }
        for (int32_t i = 0; i < nv; i++) {
            unsigned char s = w->state[i], t = s;
            if (s == FREE) {
                if (w->x[i] < -TOL_X || w->x[i] == 0.0)
                    t = AT_LO;
                else if (w->x[i] > 1.0 + TOL_X)
                    t = AT_HI;
            } else if (s == AT_LO) {
                if (dtx__row_dot(Q, i, w->x) < -tol_lambda)
                    t = FREE;
            } else if (s == AT_HI) {
                if (dtx__row_dot(Q, i, w->x) > tol_lambda)
                    t = FREE;
            }
            if (t != s) {
                changed++;
                w->state[i] = t;
                w->band[i] = 1;
            }
        }

        /* The expansion: the fixed Q-neighbours of the vertices freed by
         * their multiplier, once per vertex. */
        for (int32_t i = 0; i < nv; i++) {
            if (w->state[i] != FREE || w->wasfree[i])
                continue;
            for (int64_t p = Q->rowptr[i]; p < Q->rowptr[i + 1]; p++) {
                int32_t c = Q->col[p];
                if ((w->state[c] == AT_LO || w->state[c] == AT_HI) && !w->wasfree[c] &&
                    !w->expanded[c])
                    w->mark[c] = 1;
            }
        }
        for (int32_t i = 0; i < nv; i++)
            if (w->mark[i]) {
                w->mark[i] = 0;
                w->expanded[i] = 1;
                w->state[i] = FREE;
                w->band[i] = 1;
                changed++;
            }

        /* The fixed vertices take their bounds now, so that a converged
         * iterate is exactly on them and the next solve sees them. */
        for (int32_t i = 0; i < nv; i++) {
            if (w->state[i] == AT_LO)
                w->x[i] = 0.0;
            else if (w->state[i] == AT_HI)
                w->x[i] = 1.0;
        }
        if (changed == 0 && !w->local) {
            *converged = 1;
            break;
        }
        /* Local steps while they change something, LOCAL_STEPS at most,
         * then a global one. */
        if (changed == 0 || nlocal == LOCAL_STEPS) {
            w->local = 0;
            nlocal = 0;
        } else {
            grow_band(Q, nv, LOCAL_RINGS, w);
            w->local = 1;
            nlocal++;
        }
    }
    *iterations = it;
    for (int32_t i = 0; i < nv; i++)
        wk[i] = w->x[i] < 0.0 ? 0.0 : w->x[i] > 1.0 ? 1.0 : w->x[i];
    return DTX_OK;
}

/* A fill-reducing ordering (AMD) of the whole mesh's Q: *order (nv,
 * allocated here) lists the vertices in elimination order. */
static dtx_status mesh_order(const dtx_csr *Q, int32_t nv, int32_t **order, dtx_error *err)
{
    cholmod_common cc;
    cholmod_sparse *A;
    int32_t *all = NULL;
    dtx_status st = DTX_OK;
    *order = NULL;
    dtx__bbw_chol_start(&cc);
    all = dtx_alloc((size_t)nv, sizeof *all, 0);
    *order = dtx_alloc((size_t)nv, sizeof **order, 0);
    if (!all || !*order) {
        st = dtx_seterr(err, DTX_ENOMEM, "bounded biharmonic weights: out of memory");
        goto done;
    }
    for (int32_t i = 0; i < nv; i++)
        all[i] = i;
    A = dtx__block(Q, all, all, nv, &cc);
    if (!A || !cholmod_amd(A, NULL, 0, *order, &cc))
        st = dtx_seterr(err, DTX_ENOMEM, "bounded biharmonic weights: out of memory ordering "
                        "the %d x %d system", (int)nv, (int)nv);
    cholmod_free_sparse(&A, &cc);
done:
    free(all);
    if (st != DTX_OK) {
        free(*order);
        *order = NULL;
    }
    cholmod_finish(&cc);
    return st;
}

/* dtx_bbw_handles (claim NULL: handles k0..k1-1, row k - k0 of Wk) and
 * dtx_bbw_handles_claim (k0 = 0, k1 = m: the handles claim hands out, row
 * k of Wk). */
static dtx_status handles_run(const dtx_mesh *mesh, const int32_t *handles, int32_t m, int32_t k0,
                              int32_t k1, dtx_bbw_claim_fn claim, void *claim_ctx,
                              const dtx_bbw_params *prm, double *Wk, dtx_bbw_info *info,
                              dtx_error *err)
{
    dtx__biharmonic sys;
    dtx_bbw_params defaults;
    dtx_bbw_info inf;
    thread_ws *ws = NULL;
    double tol_lambda = 0.0;
    int32_t *order = NULL;
    int *iters = NULL, *locals = NULL, *conv = NULL;
    unsigned char *mine = NULL;
    int nthreads = omp_get_max_threads();
    int32_t failed = -1, nv, n = k1 - k0, b0 = k0, b1 = k1;
    dtx_status st;

    memset(&inf, 0, sizeof inf);
    if (info)
        *info = inf;
    if (!prm) {
        dtx_bbw_params_default(&defaults);
        prm = &defaults;
    }
    if (prm->max_iter < 1)
        return dtx_seterr(err, DTX_EINVAL, "bounded biharmonic weights: max_iter %d (must be "
                          ">= 1)", prm->max_iter);
    if (!Wk)
        return dtx_seterr(err, DTX_EINVAL, "bounded biharmonic weights: no output array");
    if (k0 < 0 || k1 < k0 || k1 > m)
        return dtx_seterr(err, DTX_ERANGE, "bounded biharmonic weights: handles %d to %d of %d",
                          (int)k0, (int)k1, (int)m);
    st = dtx__biharmonic_build(mesh, &sys, err);
    if (st != DTX_OK)
        return st;
    st = dtx__check_handles(&sys, handles, m, err);
    if (st != DTX_OK || n == 0)
        goto done;
    nv = sys.nv;
    inf.thin_triangles = sys.nthin;
    for (int32_t i = 0; i < nv; i++) {
        double s = 0.0;
        for (int64_t p = sys.Q.rowptr[i]; p < sys.Q.rowptr[i + 1]; p++)
            s += fabs(sys.Q.val[p]);
        tol_lambda = fmax(tol_lambda, s);
    }
    tol_lambda *= TOL_LAMBDA;

    if (nthreads > n)
        nthreads = n;
    ws = dtx_alloc((size_t)nthreads, sizeof *ws, 1);
    iters = dtx_alloc((size_t)n, sizeof *iters, 1);
    locals = dtx_alloc((size_t)n, sizeof *locals, 1);
    conv = dtx_alloc((size_t)n, sizeof *conv, 1);
    mine = dtx_alloc((size_t)n, 1, 1);
    if (!ws || !iters || !locals || !conv || !mine)
        goto nomem;
    for (int t = 0; t < nthreads; t++)
        if (!ws_alloc(&ws[t], nv))
            goto nomem;
    if ((st = mesh_order(&sys.Q, nv, &order, err)) != DTX_OK)
        goto done;

    /* Batches of handles: [k0, k1) at once, or what claim hands out (at
     * most one per thread at a time) until it has none left. */
    while (failed < 0) {
        if (claim) {
            int32_t got = claim(claim_ctx, m, nthreads, &b0);
            if (got <= 0)
                break;
            b1 = b0 + got;
            if (b0 < 0 || b1 > m) {
                st = dtx_seterr(err, DTX_ERANGE, "bounded biharmonic weights: claimed handles "
                                "%d to %d of %d", (int)b0, (int)b1, (int)m);
                goto done;
            }
        }
        /* One handle per iteration; each thread uses its own CHOLMOD
         * workspace, and nothing else is shared but the read-only Q and
         * disjoint rows of Wk. */
#pragma omp parallel for schedule(dynamic, 1) num_threads(nthreads)
        for (int32_t k = b0; k < b1; k++) {
            thread_ws *w = &ws[omp_get_thread_num()];
            dtx_status s = solve_handle(&sys.Q, nv, order, handles, m, k, prm->max_iter,
                                        tol_lambda, w, Wk + (size_t)(k - k0) * nv,
                                        &iters[k - k0], &locals[k - k0], &conv[k - k0]);
            mine[k - k0] = 1;
            if (s != DTX_OK) {
#pragma omp critical(dtx_bbw_error)
                if (failed < 0 || k < failed) {
                    failed = k;
                    st = dtx_seterr(err, s, "handle %d (vertex %d): %s", (int)k,
                                    (int)handles[k], w->err.msg);
                }
            }
        }
        if (!claim)
            break;
    }
    if (failed >= 0)
        goto done;
    for (int32_t k = 0; k < n; k++) {
        if (!mine[k])
            continue;
        inf.iterations_max = iters[k] > inf.iterations_max ? iters[k] : inf.iterations_max;
        inf.iterations_total += iters[k];
        inf.local_total += locals[k];
        inf.not_converged += !conv[k];
    }
    if (info)
        *info = inf;
    st = DTX_OK;
    goto done;

nomem:
    st = dtx_seterr(err, DTX_ENOMEM, "out of memory for the bounded biharmonic weights of %d "
                    "handles on %d vertices", (int)n, (int)sys.nv);
done:
    if (ws)
        for (int t = 0; t < nthreads; t++)
            ws_free(&ws[t]);
    free(ws);
    free(iters);
    free(locals);
    free(conv);
    free(mine);
    free(order);
    dtx__biharmonic_free(&sys);
    return st;
}

dtx_status dtx_bbw_handles(const dtx_mesh *mesh, const int32_t *handles, int32_t m, int32_t k0,
                           int32_t k1, const dtx_bbw_params *prm, double *Wk, dtx_bbw_info *info,
                           dtx_error *err)
{
    return handles_run(mesh, handles, m, k0, k1, NULL, NULL, prm, Wk, info, err);
}

dtx_status dtx_bbw_handles_claim(const dtx_mesh *mesh, const int32_t *handles, int32_t m,
                                 dtx_bbw_claim_fn claim, void *claim_ctx,
                                 const dtx_bbw_params *prm, double *Wk, dtx_bbw_info *info,
                                 dtx_error *err)
{
    if (!claim)
        return dtx_seterr(err, DTX_EINVAL, "bounded biharmonic weights: no claim function");
    return handles_run(mesh, handles, m, 0, m < 0 ? 0 : m, claim, claim_ctx, prm, Wk, info, err);
}

dtx_status dtx_bbw_normalise(const dtx_mesh *mesh, const int32_t *handles, int32_t m,
                             const double *Wk, const dtx_bbw_params *prm, double *W,
                             dtx_bbw_info *info, dtx_error *err)
{
    dtx_bbw_params defaults;
    dtx_bbw_incr *unb = NULL;
    int32_t nv = mesh ? mesh->nv : 0, low = 0;
    double smin = INFINITY, smax = -INFINITY;
    dtx_status st = DTX_OK;

    if (!prm) {
        dtx_bbw_params_default(&defaults);
        prm = &defaults;
    }
    if (!mesh || !handles || !Wk || !W || m < 1)
        return dtx_seterr(err, DTX_EINVAL, "bounded biharmonic weights: missing arguments");
    for (int32_t i = 0; i < nv; i++) {
        double s = 0.0;
        for (int32_t k = 0; k < m; k++)
            s += Wk[(size_t)k * nv + i];
        smin = fmin(smin, s);
        smax = fmax(smax, s);
        low += s < DTX_BBW_MIN_SUM;
    }
    /* Rows whose sum is (nearly) 0 take the clamped unbounded weights,
     * which sum to >= max_k u_k >= 1/m: one more factorisation, only when
     * such a row exists. */
    if (low > 0 && (st = dtx_bbw_incr_create(mesh, handles, m, &unb, err)) != DTX_OK)
        return st;
    for (int32_t i = 0; i < nv; i++) {
        double *row = W + (size_t)i * m, s = 0.0;
        for (int32_t k = 0; k < m; k++) {
            row[k] = Wk[(size_t)k * nv + i];
            s += row[k];
        }
        if (s < DTX_BBW_MIN_SUM) {
            const double *u = dtx_bbw_incr_weights(unb) + (size_t)i * m;
            s = 0.0;
            for (int32_t k = 0; k < m; k++) {
                row[k] = u[k] < 0.0 ? 0.0 : u[k] > 1.0 ? 1.0 : u[k];
                s += row[k];
            }
        }
        if (prm->normalise)
            for (int32_t k = 0; k < m; k++)
                row[k] /= s;
    }
    /* Exact at the handles whatever the rounding of the sums. */
    for (int32_t j = 0; j < m; j++)
        for (int32_t k = 0; k < m; k++)
            W[(size_t)handles[j] * m + k] = j == k ? 1.0 : 0.0;
    dtx_bbw_incr_free(&unb);
    if (info) {
        info->low_sum = low;
        info->sum_min = smin;
        info->sum_max = smax;
    }
    return DTX_OK;
}

dtx_status dtx_bbw(const dtx_mesh *mesh, const int32_t *handles, int32_t m,
                   const dtx_bbw_params *prm, double *W, dtx_bbw_info *info, dtx_error *err)
{
    double *Wk;
    dtx_status st;
    if (info)
        memset(info, 0, sizeof *info);
    if (!W)
        return dtx_seterr(err, DTX_EINVAL, "bounded biharmonic weights: no output array");
    if (!mesh || m < 1 || !handles)
        return dtx_bbw_handles(mesh, handles, m, 0, m < 0 ? 0 : m, prm, W, info, err);
    Wk = dtx_alloc((size_t)mesh->nv, (size_t)m * sizeof *Wk, 0);
    if (!Wk)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory for the bounded biharmonic weights of "
                          "%d handles on %d vertices", (int)m, (int)mesh->nv);
    st = dtx_bbw_handles(mesh, handles, m, 0, m, prm, Wk, info, err);
    if (st == DTX_OK)
        st = dtx_bbw_normalise(mesh, handles, m, Wk, prm, W, info, err);
    free(Wk);
    return st;
}

int32_t dtx_bbw_clamp_normalise(double *W, int32_t nv, int32_t m, double *max_violation)
{
    int32_t bad = 0, zero = 0;
    double worst = 0.0;
    for (int32_t i = 0; i < nv; i++) {
        double *row = W + (size_t)i * m, s = 0.0;
        int out = 0;
        for (int32_t k = 0; k < m; k++) {
            double v = row[k];
            if (v < 0.0) {
                worst = fmax(worst, -v);
                out = 1;
                v = 0.0;
            } else if (v > 1.0) {
                worst = fmax(worst, v - 1.0);
                out = 1;
                v = 1.0;
            }
            row[k] = v;
            s += v;
        }
        bad += out;
        if (s > 0.0) {
            for (int32_t k = 0; k < m; k++)
                row[k] /= s;
        } else {
            for (int32_t k = 0; k < m; k++)
                row[k] = 0.0;
            zero = 1;
        }
    }
    if (max_violation)
        *max_violation = worst;
    return zero ? -1 : bad;
}
