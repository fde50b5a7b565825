/*
 * bbw_incremental.c: unbounded biharmonic weights of a handle set, and
 * exact rank-one updates for one more handle or one handle moved (bbw.h).
 *
 * Notation: H the handles, f the other (free) vertices, A = Q(f, f) (positive
 * definite when every component holds a handle).  The weight of handle k is
 * w_k = delta at the handles and A w_k(f) = -Q(f, h_k), so (Q w_k)(i) = 0 at
 * every free vertex i; the w_k sum to 1 because Q 1 = 0.
 *
 * One more handle c (free): let g = 0 on H and A g(f) = e_c (the Green's
 * function of c; g(c) = e_c' A^-1 e_c > 0).  For an old handle, d = w'_k -
 * w_k must vanish on H, be -w_k(c) at c and satisfy (Q d)(i) = 0 at every
 * other free vertex, so A d(f) is a multiple of e_c: d = -(w_k(c) / g(c)) g.
 * The new weight is 0 on H, 1 at c and harmonic elsewhere: g / g(c).
 *
 * Handle j dropped (made free): w^-_k = w_k + beta w_j keeps the conditions
 * everywhere but at h_j, where (Q w^-_k)(h_j) = 0 fixes beta = -E_jk / E_jj,
 * E_jk = (Q w_k)(h_j).  E_jj = w_j' Q w_j is w_j's energy, > 0 unless w_j is
 * constant on its component (h_j alone there).  The Green's function of c
 * for the smaller set is likewise g^- = g + gamma w_j with gamma = -(Q
 * g)(h_j) / E_jj.  Moving h_j to c is dropping j, then adding c.
 */
#include "bbw.h"

#include "bbw_internal.h"

#include <omp.h>
#include <stdlib.h>
#include <string.h>

/* Everything that depends on the handle set; rebuilt whole on a commit. */
typedef struct {
    int32_t m;
    int32_t *handles; /* m */
    int32_t *idx;     /* nv: index among the free vertices, -1 for a handle */
    int32_t *fvert;   /* nfree: vertex of each free index */
    int32_t nfree;
    int32_t *hcount;  /* ncomp: handles in each component */
    cholmod_factor *L; /* of Q(f, f); NULL when nothing is free or not yet
                        * factored (a carried commit: dtx_bbw_incr_factor) */
    double *W;        /* nv x m */
    double *E;        /* m x m, E[j*m + k] = (Q w_k)(h_j) */
} hset;

struct dtx_bbw_incr {
    dtx__biharmonic sys;
    cholmod_common cc;
    hset s;
};

struct dtx_bbw_work {
    cholmod_common cc;
    cholmod_dense *X, *Y, *E; /* cholmod_solve2's result and workspace, reused */
    double *b;                /* nv: right-hand side on the free vertices */
    double *g;                /* nv: Green's function on all vertices */
    double *coef;             /* 2 nv: per-handle coefficients (m < nv) */
};

static void hset_free(hset *s, cholmod_common *cc)
{
    free(s->handles);
    free(s->idx);
    free(s->fvert);
    free(s->hcount);
    cholmod_free_factor(&s->L, cc);
    free(s->W);
    free(s->E);
    memset(s, 0, sizeof *s);
}

/* Win (nv x m): the set's weights when the caller has them (a carried
 * commit): no factorisation, no solve.  NULL: factored and solved here. */
static dtx_status hset_build(const dtx__biharmonic *sys, const int32_t *handles, int32_t m,
                             const double *Win, cholmod_common *cc, hset *s, dtx_error *err)
{
    const dtx_csr *Q = &sys->Q;
    int32_t nv = sys->nv;
    cholmod_sparse *A = NULL;
    cholmod_dense *B = NULL, *X = NULL;
    dtx_status st;

    memset(s, 0, sizeof *s);
    st = dtx__check_handles(sys, handles, m, err);
    if (st != DTX_OK)
        return st;
    s->m = m;
    s->handles = dtx_alloc((size_t)m, sizeof *s->handles, 0);
    s->idx = dtx_alloc((size_t)nv, sizeof *s->idx, 0);
    s->fvert = dtx_alloc((size_t)nv, sizeof *s->fvert, 0);
    s->hcount = dtx_alloc((size_t)sys->ncomp, sizeof *s->hcount, 1);
    s->W = dtx_alloc((size_t)nv * (size_t)m, sizeof *s->W, 1);
    s->E = dtx_alloc((size_t)m * (size_t)m, sizeof *s->E, 0);
    if (!s->handles || !s->idx || !s->fvert || !s->hcount || !s->W || !s->E)
        goto nomem;
    memcpy(s->handles, handles, (size_t)m * sizeof *handles);
    for (int32_t i = 0; i < nv; i++)
        s->idx[i] = 0;
    for (int32_t k = 0; k < m; k++) {
        s->idx[handles[k]] = -1;
        s->hcount[sys->comp[handles[k]]]++;
    }
    for (int32_t i = 0; i < nv; i++)
        if (s->idx[i] == 0) {
            s->idx[i] = s->nfree;
            s->fvert[s->nfree++] = i;
        }
    for (int32_t k = 0; k < m; k++)
        s->W[(size_t)handles[k] * m + k] = 1.0;

    if (Win)
        memcpy(s->W, Win, (size_t)nv * (size_t)m * sizeof *s->W);
    else if (s->nfree > 0) {
        double *Bx;
        const double *Xx;
        size_t nf = (size_t)s->nfree;
        A = dtx__block(Q, s->idx, s->fvert, s->nfree, cc);
        if (!A)
            goto nomem;
        st = dtx__bbw_factor(A, "biharmonic weights", &s->L, cc, err);
        if (st != DTX_OK)
            goto fail;
        /* Column k of B is -Q(f, h_k). */
        B = cholmod_zeros(nf, (size_t)m, CHOLMOD_REAL, cc);
        if (!B)
            goto nomem;
        Bx = B->x;
        for (int32_t k = 0; k < m; k++) {
            int32_t h = handles[k];
            for (int64_t p = Q->rowptr[h]; p < Q->rowptr[h + 1]; p++) {
                int32_t r = s->idx[Q->col[p]];
                if (r >= 0)
                    Bx[(size_t)k * nf + (size_t)r] = -Q->val[p];
            }
        }
        X = cholmod_solve(CHOLMOD_A, s->L, B, cc);
        if (!X)
            goto nomem;
        Xx = X->x;
        for (int32_t r = 0; r < s->nfree; r++)
            for (int32_t k = 0; k < m; k++)
                s->W[(size_t)s->fvert[r] * m + k] = Xx[(size_t)k * nf + (size_t)r];
    }
    for (int32_t j = 0; j < m; j++) {
        int32_t h = handles[j];
        for (int32_t k = 0; k < m; k++) {
            double e = 0.0;
            for (int64_t p = Q->rowptr[h]; p < Q->rowptr[h + 1]; p++)
                e += Q->val[p] * s->W[(size_t)Q->col[p] * m + k];
            s->E[(size_t)j * m + k] = e;
        }
    }
    cholmod_free_dense(&X, cc);
    cholmod_free_dense(&B, cc);
    cholmod_free_sparse(&A, cc);
    return DTX_OK;

nomem:
    st = dtx_seterr(err, DTX_ENOMEM, "out of memory for the biharmonic weights of %d handles on "
                    "%d vertices", (int)m, (int)nv);
fail:
    cholmod_free_dense(&X, cc);
    cholmod_free_dense(&B, cc);
    cholmod_free_sparse(&A, cc);
    hset_free(s, cc);
    return st;
}

dtx_status dtx_bbw_incr_create(const dtx_mesh *mesh, const int32_t *handles, int32_t m,
                               dtx_bbw_incr **out, dtx_error *err)
{
    dtx_bbw_incr *ctx;
    dtx_status st;

    if (!out)
        return dtx_seterr(err, DTX_EINVAL, "biharmonic weights: no output context");
    *out = NULL;
    ctx = calloc(1, sizeof *ctx);
    if (!ctx)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory for a biharmonic weight context");
    st = dtx__biharmonic_build(mesh, &ctx->sys, err);
    if (st != DTX_OK) {
        free(ctx);
        return st;
    }
    dtx__bbw_chol_start(&ctx->cc);
    st = hset_build(&ctx->sys, handles, m, NULL, &ctx->cc, &ctx->s, err);
    if (st != DTX_OK) {
        dtx_bbw_incr_free(&ctx);
        return st;
    }
    *out = ctx;
    return DTX_OK;
}

void dtx_bbw_incr_free(dtx_bbw_incr **ctx)
{
    if (!ctx || !*ctx)
        return;
    hset_free(&(*ctx)->s, &(*ctx)->cc);
    cholmod_finish(&(*ctx)->cc);
    dtx__biharmonic_free(&(*ctx)->sys);
    free(*ctx);
    *ctx = NULL;
}

int32_t dtx_bbw_incr_count(const dtx_bbw_incr *ctx) { return ctx->s.m; }
int32_t dtx_bbw_incr_nv(const dtx_bbw_incr *ctx) { return ctx->sys.nv; }
const int32_t *dtx_bbw_incr_handles(const dtx_bbw_incr *ctx) { return ctx->s.handles; }
const double *dtx_bbw_incr_weights(const dtx_bbw_incr *ctx) { return ctx->s.W; }

dtx_bbw_work *dtx_bbw_work_new(const dtx_bbw_incr *ctx)
{
    dtx_bbw_work *w = calloc(1, sizeof *w);
    size_t nv = (size_t)ctx->sys.nv;
    if (!w)
        return NULL;
    dtx__bbw_chol_start(&w->cc);
    w->b = dtx_alloc(nv, sizeof *w->b, 1);
    w->g = dtx_alloc(nv, sizeof *w->g, 1);
    w->coef = dtx_alloc(2 * nv, sizeof *w->coef, 1);
    if (!w->b || !w->g || !w->coef)
        dtx_bbw_work_free(&w);
    return w;
}

void dtx_bbw_work_free(dtx_bbw_work **work)
{
    dtx_bbw_work *w;
    if (!work || !*work)
        return;
    w = *work;
    cholmod_free_dense(&w->X, &w->cc);
    cholmod_free_dense(&w->Y, &w->cc);
    cholmod_free_dense(&w->E, &w->cc);
    cholmod_finish(&w->cc);
    free(w->b);
    free(w->g);
    free(w->coef);
    free(w);
    *work = NULL;
}

/* ------------------------------------------------------------------ */
/* Evaluation                                                          */
/* ------------------------------------------------------------------ */

static dtx_status check_candidate(const dtx_bbw_incr *ctx, int32_t c, const double *W_out,
                                  const dtx_bbw_work *work, dtx_error *err)
{
    if (!W_out || !work)
        return dtx_seterr(err, DTX_EINVAL, "biharmonic weights: %s",
                          W_out ? "no workspace" : "no output array");
    if (c < 0 || c >= ctx->sys.nv)
        return dtx_seterr(err, DTX_ERANGE,
                          "biharmonic weights: candidate vertex %d out of range [0, %d)", (int)c,
                          (int)ctx->sys.nv);
    if (ctx->s.idx[c] < 0) {
        int32_t k = 0;
        while (ctx->s.handles[k] != c)
            k++;
        return dtx_seterr(err, DTX_EINVAL,
                          "biharmonic weights: candidate vertex %d is already handle %d", (int)c,
                          (int)k);
    }
    return DTX_OK;
}

/* g = 0 on the handles, Q(f, f) g(f) = e_c, into work->g. */
static dtx_status green(const dtx_bbw_incr *ctx, int32_t c, dtx_bbw_work *w, dtx_error *err)
{
    const hset *s = &ctx->s;
    cholmod_dense B;
    const double *x;

    memset(&B, 0, sizeof B);
    B.nrow = B.nzmax = B.d = (size_t)s->nfree;
    B.ncol = 1;
    B.x = w->b;
    B.xtype = CHOLMOD_REAL;
    B.dtype = CHOLMOD_DOUBLE;
    if (!s->L)
        return dtx_seterr(err, DTX_EINVAL,
                          "biharmonic weights: the set is not factored after a carried commit "
                          "(dtx_bbw_incr_factor)");
    memset(w->b, 0, (size_t)s->nfree * sizeof *w->b);
    w->b[s->idx[c]] = 1.0;
    if (!cholmod_solve2(CHOLMOD_A, s->L, &B, NULL, &w->X, NULL, &w->Y, &w->E, &w->cc))
        return dtx_seterr(err, DTX_ENOMEM, "biharmonic weights: out of memory in a solve");
    x = w->X->x;
    for (int32_t i = 0; i < ctx->sys.nv; i++)
        w->g[i] = s->idx[i] >= 0 ? x[s->idx[i]] : 0.0;
    return DTX_OK;
}

dtx_status dtx_bbw_incr_green(const dtx_bbw_incr *ctx, int32_t c, double *g, dtx_bbw_work *work,
                              dtx_error *err)
{
    dtx_status st = check_candidate(ctx, c, g, work, err);
    if (st == DTX_OK && (st = green(ctx, c, work, err)) == DTX_OK)
        memcpy(g, work->g, (size_t)ctx->sys.nv * sizeof *g);
    return st;
}

dtx_status dtx_bbw_incr_weights_add(const dtx_bbw_incr *ctx, int32_t c, double *W_out,
                                    dtx_bbw_work *work, dtx_error *err)
{
    return dtx_bbw_incr_weights_add_g(ctx, c, NULL, W_out, work, err);
}

dtx_status dtx_bbw_incr_weights_add_g(const dtx_bbw_incr *ctx, int32_t c, const double *gin,
                                      double *W_out, dtx_bbw_work *work, dtx_error *err)
{
    const hset *s = &ctx->s;
    int32_t nv = ctx->sys.nv, m = s->m, m1 = m + 1;
    const double *g = gin ? gin : work ? work->g : NULL;
    double *coef = work ? work->coef : NULL, gc;
    dtx_status st = check_candidate(ctx, c, W_out, work, err);

    if (st != DTX_OK)
        return st;
    if (!gin && (st = green(ctx, c, work, err)) != DTX_OK)
        return st;
    gc = g[c];
    for (int32_t k = 0; k < m; k++)
        coef[k] = s->W[(size_t)c * m + k] / gc;
    for (int32_t i = 0; i < nv; i++) {
        const double *w = s->W + (size_t)i * m;
        double *o = W_out + (size_t)i * m1, gi = g[i];
        for (int32_t k = 0; k < m; k++)
            o[k] = w[k] - coef[k] * gi;
        o[m] = gi / gc;
    }
    for (int32_t k = 0; k < m; k++)
        W_out[(size_t)c * m1 + k] = 0.0;
    W_out[(size_t)c * m1 + m] = 1.0;
    return DTX_OK;
}

dtx_status dtx_bbw_incr_weights_replace(const dtx_bbw_incr *ctx, int32_t j, int32_t c,
                                        double *W_out, dtx_bbw_work *work, dtx_error *err)
{
    return dtx_bbw_incr_weights_replace_g(ctx, j, c, NULL, W_out, work, err);
}

dtx_status dtx_bbw_incr_weights_replace_g(const dtx_bbw_incr *ctx, int32_t j, int32_t c,
                                          const double *gin, double *W_out, dtx_bbw_work *work,
                                          dtx_error *err)
{
    const hset *s = &ctx->s;
    const dtx__biharmonic *sys = &ctx->sys;
    int32_t nv = sys->nv, m = s->m, hj, cj;
    double *g = work ? work->g : NULL, *coef = work ? work->coef : NULL;
    const double *wc;
    double ejj, gamma, gc;
    dtx_status st;

    if (j < 0 || j >= m)
        return dtx_seterr(err, DTX_ERANGE, "biharmonic weights: handle %d out of range [0, %d)",
                          (int)j, (int)m);
    hj = s->handles[j];
    cj = sys->comp[hj];
    if (c == hj && W_out && work) {
        memcpy(W_out, s->W, (size_t)nv * (size_t)m * sizeof *W_out);
        return DTX_OK;
    }
    st = check_candidate(ctx, c, W_out, work, err);
    if (st != DTX_OK)
        return st;
    if (s->hcount[cj] == 1) {
        if (sys->comp[c] != cj)
            return dtx_seterr(err, DTX_EINVAL,
                              "biharmonic weights: moving handle %d (vertex %d) to vertex %d "
                              "would leave component %d (the one of vertex %d) without a handle",
                              (int)j, (int)hj, (int)c, (int)cj, (int)sys->lowest[cj]);
        /* h_j alone in its component, c in the same one: there w_j = 1 and
         * every other weight is 0, before and after. */
        memcpy(W_out, s->W, (size_t)nv * (size_t)m * sizeof *W_out);
        return DTX_OK;
    }
    if (gin)
        memcpy(g, gin, (size_t)nv * sizeof *g); /* changed below */
    else if ((st = green(ctx, c, work, err)) != DTX_OK)
        return st;

    /* Drop h_j: g^- = g + gamma w_j, and w^-_k = w_k - coef[k] w_j with
     * coef[k] = E_jk / E_jj (coef[j] = 1 makes w^-_j = 0, unused). */
    ejj = s->E[(size_t)j * m + j];
    gamma = -dtx__row_dot(&sys->Q, hj, g) / ejj;
    for (int32_t i = 0; i < nv; i++)
        g[i] += gamma * s->W[(size_t)i * m + j];
    for (int32_t k = 0; k < m; k++)
        coef[k] = s->E[(size_t)j * m + k] / ejj;
    /* Add c: w''_k = w^-_k - (w^-_k(c) / g^-(c)) g^-, w''_c = g^- / g^-(c);
     * coef[m + k] = w^-_k(c) / g^-(c). */
    gc = g[c];
    wc = s->W + (size_t)c * m;
    for (int32_t k = 0; k < m; k++)
        coef[m + k] = (wc[k] - coef[k] * wc[j]) / gc;
    for (int32_t i = 0; i < nv; i++) {
        const double *w = s->W + (size_t)i * m;
        double *o = W_out + (size_t)i * m, gi = g[i], wj = w[j];
        for (int32_t k = 0; k < m; k++)
            o[k] = w[k] - coef[k] * wj - coef[m + k] * gi;
        o[j] = gi / gc;
    }
    for (int32_t k = 0; k < m; k++)
        W_out[(size_t)c * m + k] = k == j ? 1.0 : 0.0;
    return DTX_OK;
}

dtx_status dtx_bbw_incr_green_move(const dtx_bbw_incr *ctx, int32_t j, int32_t c, const double *gc,
                                   int32_t n, const int32_t *verts, double *G, int threads,
                                   dtx_error *err)
{
    const hset *s = ctx ? &ctx->s : NULL;
    const dtx__biharmonic *sys = ctx ? &ctx->sys : NULL;
    int32_t nv, m, hj = -1;
    double ejj = 0.0, gbb, *gb;

    if (!ctx || !gc || n < 0 || (n > 0 && (!verts || !G)))
        return dtx_seterr(err, DTX_EINVAL, "biharmonic weights: Green's functions: bad arguments");
    nv = sys->nv;
    m = s->m;
    if (j >= m || c < 0 || c >= nv || s->idx[c] < 0)
        return dtx_seterr(err, DTX_EINVAL,
                          "biharmonic weights: Green's functions: handle %d or vertex %d not "
                          "a move of the current set",
                          (int)j, (int)c);
    if (j >= 0) {
        hj = s->handles[j];
        if (s->hcount[sys->comp[hj]] == 1)
            return dtx_seterr(err, DTX_EINVAL,
                              "biharmonic weights: Green's functions: handle %d (vertex %d) is "
                              "alone in its component",
                              (int)j, (int)hj);
        ejj = s->E[(size_t)j * m + j];
        if (!(ejj > 0.0))
            return dtx_seterr(err, DTX_ESOLVE,
                              "biharmonic weights: handle %d (vertex %d) has energy %g", (int)j,
                              (int)hj, ejj);
    }
    gb = dtx_alloc((size_t)nv, sizeof *gb, 0);
    if (!gb)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory");
    memcpy(gb, gc, (size_t)nv * sizeof *gb);
    if (j >= 0) {
        double gam = -dtx__row_dot(&sys->Q, hj, gb) / ejj;
        for (int32_t i = 0; i < nv; i++)
            gb[i] += gam * s->W[(size_t)i * m + j];
    }
    gbb = gb[c];
    if (!(gbb > 0.0)) {
        free(gb);
        return dtx_seterr(err, DTX_ESOLVE,
                          "biharmonic weights: Green's function of vertex %d is %g there", (int)c,
                          gbb);
    }
#pragma omp parallel for num_threads(threads > 0 ? threads : omp_get_max_threads()) schedule(static)
    for (int32_t t = 0; t < n; t++) {
        double *g = G + (size_t)t * nv, a;
        if (verts[t] < 0)
            continue;
        /* ---- drop h_j */
        if (j >= 0 && verts[t] == hj) {
            for (int32_t i = 0; i < nv; i++)
                g[i] = s->W[(size_t)i * m + j] / ejj;
        } else if (j >= 0) {
            double gam = -dtx__row_dot(&sys->Q, hj, g) / ejj;
            for (int32_t i = 0; i < nv; i++)
                g[i] += gam * s->W[(size_t)i * m + j];
        }
        /* ---- add c */
        a = g[c] / gbb;
        for (int32_t i = 0; i < nv; i++)
            g[i] -= a * gb[i];
        g[c] = 0.0;
    }
    free(gb);
    return DTX_OK;
}

/* ------------------------------------------------------------------ */
/* Commits                                                             */
/* ------------------------------------------------------------------ */

static dtx_status commit(dtx_bbw_incr *ctx, const int32_t *handles, int32_t m, const double *W,
                         dtx_error *err)
{
    hset fresh;
    dtx_status st = hset_build(&ctx->sys, handles, m, W, &ctx->cc, &fresh, err);
    if (st != DTX_OK)
        return st;
    hset_free(&ctx->s, &ctx->cc);
    ctx->s = fresh;
    return DTX_OK;
}

dtx_status dtx_bbw_incr_add(dtx_bbw_incr *ctx, int32_t c, dtx_error *err)
{
    int32_t m = ctx->s.m, *h;
    dtx_status st;
    if (c < 0 || c >= ctx->sys.nv)
        return dtx_seterr(err, DTX_ERANGE,
                          "biharmonic weights: new handle vertex %d out of range [0, %d)", (int)c,
                          (int)ctx->sys.nv);
    h = dtx_alloc((size_t)m + 1, sizeof *h, 0);
    if (!h)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory adding a handle");
    memcpy(h, ctx->s.handles, (size_t)m * sizeof *h);
    h[m] = c;
    st = commit(ctx, h, m + 1, NULL, err);
    free(h);
    return st;
}

dtx_status dtx_bbw_incr_replace(dtx_bbw_incr *ctx, int32_t j, int32_t c, dtx_error *err)
{
    int32_t m = ctx->s.m, *h;
    dtx_status st;
    if (j < 0 || j >= m)
        return dtx_seterr(err, DTX_ERANGE, "biharmonic weights: handle %d out of range [0, %d)",
                          (int)j, (int)m);
    h = dtx_alloc((size_t)m, sizeof *h, 0);
    if (!h)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory moving a handle");
    memcpy(h, ctx->s.handles, (size_t)m * sizeof *h);
    h[j] = c;
    st = commit(ctx, h, m, NULL, err);
    free(h);
    return st;
}

dtx_status dtx_bbw_incr_commit_g(dtx_bbw_incr *ctx, int32_t j, int32_t c, const double *g,
                                 dtx_bbw_work *work, dtx_error *err)
{
    int32_t m = ctx ? ctx->s.m : 0, mn = j < 0 ? m + 1 : m, *h;
    double *W;
    dtx_status st;
    if (!ctx || !g || !work)
        return dtx_seterr(err, DTX_EINVAL, "biharmonic weights: carried commit: bad arguments");
    if (j >= m)
        return dtx_seterr(err, DTX_ERANGE, "biharmonic weights: handle %d out of range [0, %d)",
                          (int)j, (int)m);
    h = dtx_alloc((size_t)mn, sizeof *h, 0);
    W = dtx_alloc((size_t)ctx->sys.nv, (size_t)mn * sizeof *W, 0);
    if (!h || !W) {
        free(h);
        free(W);
        return dtx_seterr(err, DTX_ENOMEM, "out of memory committing a handle");
    }
    st = j < 0 ? dtx_bbw_incr_weights_add_g(ctx, c, g, W, work, err)
               : dtx_bbw_incr_weights_replace_g(ctx, j, c, g, W, work, err);
    if (st == DTX_OK) {
        memcpy(h, ctx->s.handles, (size_t)m * sizeof *h);
        h[j < 0 ? m : j] = c;
        st = commit(ctx, h, mn, W, err);
    }
    free(h);
    free(W);
    return st;
}

dtx_status dtx_bbw_incr_factor(dtx_bbw_incr *ctx, dtx_error *err)
{
    hset *s;
    cholmod_sparse *A;
    dtx_status st;
    if (!ctx)
        return dtx_seterr(err, DTX_EINVAL, "biharmonic weights: no context");
    s = &ctx->s;
    if (s->L || s->nfree == 0)
        return DTX_OK;
    A = dtx__block(&ctx->sys.Q, s->idx, s->fvert, s->nfree, &ctx->cc);
    if (!A)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory for the biharmonic weights of %d "
                          "handles on %d vertices", (int)s->m, (int)ctx->sys.nv);
    st = dtx__bbw_factor(A, "biharmonic weights", &s->L, &ctx->cc, err);
    cholmod_free_sparse(&A, &ctx->cc);
    return st;
}
