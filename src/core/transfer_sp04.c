/*
 * transfer_sp04.c: Sumner & Popovic 2004, section 4, in the vertex-only form
 * of Botsch et al. 2006.  For deformed target vertices x the transformation
 * of target triangle t is T_t = sum_j x_j g_tj^T (dtx_gradient_operator), and
 *     E(x) = sum over pairs (s, t) || S_s - T_t ||_F^2
 * is minimised.  Eliminating Sumner's free fourth vertices gives exactly this
 * energy plus a constant, so both formulations have the same minimiser (the
 * unit test test_sp04_fourth_vertex compares them).  The normal equations
 * L x_c = b_c (c = x, y, z) share one matrix L = sum G_t^T G_t, which depends
 * only on the target: it is factored once; each frame is one back-substitution.
 *
 * Frames are processed in groups of DTX_SOLVE_GROUP (aligned to the frame
 * index the caller passes), each group solved with one multi-column call by
 * one thread with its own CHOLMOD workspace, so the arithmetic done for a
 * frame is the same whatever the thread count.
 */
#include "dtx_core.h"

#include <cholmod.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#define DTX_SOLVE_GROUP DTX_SP04_SOLVE_GROUP

typedef struct {
    cholmod_common cc;
    cholmod_dense *B, *X, *Y, *E;
    double *S;     /* nf_s x 9 deformation gradients of one frame */
    double *bfull; /* nv_t x 3 x GROUP right-hand sides over all vertices */
    int started;
} worker;

struct dtx_sp04_plan {
    int32_t nv_s, nf_s, nv_t, nf_t;
    int32_t *F_s, *F_t;
    double *Vinv_s; /* nf_s x 9 */
    double *G_t;    /* nf_t x 9 */
    double *n_t;    /* nf_t x 3 unit normals of the rest target */
    int32_t *tptr;  /* nf_t + 1: pairs of target triangle t are src[tptr[t] .. tptr[t+1]) */
    int32_t *tsrc;
    int64_t npairs;

    dtx_anchor anchor;
    int32_t npins;
    int32_t nfree;
    int32_t *freeidx;   /* nv_t: free index or -1 */
    double *fixedval;   /* nv_t x 3: values of removed vertices (pins, rest for the others) */
    unsigned char *pinned;
    double *pin_rhs;    /* nfree x 3 column-major: - L_fp x_p for pinned p */
    double rest_centroid_t[3], rest_centroid_s[3], scale;

    cholmod_common cc;  /* owns L and Lfull */
    cholmod_factor *L;
    cholmod_sparse *Lfull; /* full symmetric L (both triangles), for the residual */
    double factor_seconds;

    int nworkers;
    worker *workers;
};

static double now_seconds(void)
{
#ifdef _OPENMP
    return omp_get_wtime();
#else
    return 0.0;
#endif
}

int32_t dtx_sp04_plan_nv_src(const dtx_sp04_plan *p) { return p->nv_s; }
int32_t dtx_sp04_plan_nv_tgt(const dtx_sp04_plan *p) { return p->nv_t; }
double dtx_sp04_plan_factor_seconds(const dtx_sp04_plan *p) { return p->factor_seconds; }

static void free_workers(dtx_sp04_plan *p)
{
    for (int w = 0; w < p->nworkers; w++) {
        worker *k = &p->workers[w];
        if (k->started) {
            cholmod_free_dense(&k->B, &k->cc);
            cholmod_free_dense(&k->X, &k->cc);
            cholmod_free_dense(&k->Y, &k->cc);
            cholmod_free_dense(&k->E, &k->cc);
            cholmod_finish(&k->cc);
        }
        free(k->S);
        free(k->bfull);
    }
    free(p->workers);
    p->workers = NULL;
    p->nworkers = 0;
}

void dtx_sp04_plan_free(dtx_sp04_plan **pp)
{
    dtx_sp04_plan *p;
    if (!pp || !*pp)
        return;
    p = *pp;
    free_workers(p);
    cholmod_free_factor(&p->L, &p->cc);
    cholmod_free_sparse(&p->Lfull, &p->cc);
    cholmod_finish(&p->cc);
    free(p->F_s);
    free(p->F_t);
    free(p->Vinv_s);
    free(p->G_t);
    free(p->n_t);
    free(p->tptr);
    free(p->tsrc);
    free(p->freeidx);
    free(p->fixedval);
    free(p->pinned);
    free(p->pin_rhs);
    free(p);
    *pp = NULL;
}

static void centroid(const double *X, int32_t n, double *c)
{
    c[0] = c[1] = c[2] = 0.0;
    for (int32_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++)
            c[k] += X[3 * (size_t)i + k];
    for (int k = 0; k < 3; k++)
        c[k] /= n;
}

dtx_status dtx_sp04_plan_create(const dtx_mesh *src, const dtx_mesh *tgt, const int32_t *pairs,
                                int64_t npairs, dtx_anchor anchor, const int32_t *pins,
                                const double *pin_pos, int32_t npins, dtx_sp04_plan **out,
                                dtx_error *err)
{
    dtx_sp04_plan *p = NULL;
    dtx_status st = DTX_OK;
    cholmod_triplet *T = NULL, *Tf = NULL;
    cholmod_sparse *K = NULL;
    int32_t *comp = NULL;
    unsigned char *used = NULL;
    double diag_s, diag_t, t0;
    const int32_t nv = tgt->nv, nf = tgt->nf;

    *out = NULL;
    if (anchor == DTX_ANCHOR_PINS && npins < 1)
        return dtx_seterr(err, DTX_EINVAL, "translation \"pins\" needs at least one pinned vertex");
    for (int32_t i = 0; i < npins; i++)
        if (pins[i] < 0 || pins[i] >= nv)
            return dtx_seterr(err, DTX_ERANGE, "pin %d: vertex %d out of range [0, %d)", (int)i,
                              (int)pins[i], (int)nv);
    for (int64_t i = 0; i < npairs; i++)
        if (pairs[2 * i] < 0 || pairs[2 * i] >= src->nf || pairs[2 * i + 1] < 0 ||
            pairs[2 * i + 1] >= nf)
            return dtx_seterr(err, DTX_ERANGE,
                              "correspondence pair %lld (%d, %d) out of range (%d source, %d "
                              "target triangles)",
                              (long long)i, (int)pairs[2 * i], (int)pairs[2 * i + 1],
                              (int)src->nf, (int)nf);

    p = calloc(1, sizeof *p);
    if (!p)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory creating the transfer plan");
    cholmod_start(&p->cc);
    p->cc.print = 0;
    p->nv_s = src->nv;
    p->nf_s = src->nf;
    p->nv_t = nv;
    p->nf_t = nf;
    p->anchor = anchor;
    p->npins = npins;
    p->npairs = npairs;
    p->F_s = dtx_alloc((size_t)src->nf, 3 * sizeof *p->F_s, 0);
    p->F_t = dtx_alloc((size_t)nf, 3 * sizeof *p->F_t, 0);
    p->Vinv_s = dtx_alloc((size_t)src->nf, 9 * sizeof *p->Vinv_s, 0);
    p->G_t = dtx_alloc((size_t)nf, 9 * sizeof *p->G_t, 0);
    p->n_t = dtx_alloc((size_t)nf, 3 * sizeof *p->n_t, 0);
    p->tptr = dtx_alloc((size_t)nf + 1, sizeof *p->tptr, 1);
    p->tsrc = dtx_alloc((size_t)npairs, sizeof *p->tsrc, 0);
    p->freeidx = dtx_alloc((size_t)nv, sizeof *p->freeidx, 0);
    p->fixedval = dtx_alloc((size_t)nv, 3 * sizeof *p->fixedval, 1);
    p->pinned = dtx_alloc((size_t)nv, 1, 1);
    comp = dtx_alloc((size_t)nv, sizeof *comp, 0);
    used = dtx_alloc((size_t)nv, 1, 1);
    if (!p->F_s || !p->F_t || !p->Vinv_s || !p->G_t || !p->n_t || !p->tptr || !p->tsrc ||
        !p->freeidx || !p->fixedval || !p->pinned || !comp || !used)
        goto nomem;
    memcpy(p->F_s, src->F, (size_t)src->nf * 3 * sizeof *p->F_s);
    memcpy(p->F_t, tgt->F, (size_t)nf * 3 * sizeof *p->F_t);

    /* One connected component (vertices in no face aside): sp04 has a
     * single translation to fix. */
    {
        int32_t ncomp = dtx_mesh_components(tgt, comp), nunref = 0;
        for (int64_t i = 0; i < 3 * (int64_t)nf; i++)
            used[tgt->F[i]] = 1;
        for (int32_t v = 0; v < nv; v++)
            nunref += !used[v];
        if (ncomp < 0)
            goto nomem;
        if (ncomp - nunref > 1) {
            st = dtx_seterr(err, DTX_EMESH,
                            "the target mesh has %d connected components; method sp04 needs "
                            "one (use method \"multicomponent\" for targets made of separate "
                            "pieces)",
                            (int)(ncomp - nunref));
            goto fail;
        }
    }

    /* Operators. */
    {
        double diag = dtx_bbox_diagonal(tgt->V, nv), ds = dtx_bbox_diagonal(src->V, src->nv);
        double eps_t = 1e-14 * diag * diag, eps_s = 1e-14 * ds * ds;
        dtx_frame_inverses(src->V, src->F, src->nf, eps_s, p->Vinv_s);
        dtx_gradient_operator(tgt->V, tgt->F, nf, eps_t, p->G_t);
        dtx_face_normals(tgt->V, tgt->F, nf, p->n_t);
    }
    for (int64_t i = 0; i < npairs; i++)
        p->tptr[pairs[2 * i + 1] + 1]++;
    for (int32_t t = 0; t < nf; t++)
        p->tptr[t + 1] += p->tptr[t];
    {
        int32_t *fill = dtx_alloc((size_t)nf, sizeof *fill, 0);
        if (!fill)
            goto nomem;
        memcpy(fill, p->tptr, (size_t)nf * sizeof *fill);
        for (int64_t i = 0; i < npairs; i++)
            p->tsrc[fill[pairs[2 * i + 1]]++] = pairs[2 * i];
        free(fill);
    }

    /* Removed unknowns: pins, unreferenced vertices, and (without pins) one
     * anchor vertex whose value is fixed by the centroid afterwards. */
    centroid(tgt->V, nv, p->rest_centroid_t);
    centroid(src->V, src->nv, p->rest_centroid_s);
    diag_s = dtx_bbox_diagonal(src->V, src->nv);
    diag_t = dtx_bbox_diagonal(tgt->V, nv);
    p->scale = diag_s > 0 ? diag_t / diag_s : 1.0;
    for (int32_t v = 0; v < nv; v++) {
        p->freeidx[v] = used[v] ? 0 : -1;
        memcpy(p->fixedval + 3 * (size_t)v, tgt->V + 3 * (size_t)v, 3 * sizeof(double));
    }
    for (int32_t i = 0; i < npins; i++) {
        p->freeidx[pins[i]] = -1;
        p->pinned[pins[i]] = 1;
        memcpy(p->fixedval + 3 * (size_t)pins[i], pin_pos + 3 * (size_t)i, 3 * sizeof(double));
    }
    if (npins == 0) {
        for (int32_t v = 0; v < nv; v++)
            if (used[v]) {
                p->freeidx[v] = -1; /* the anchor: solved at 0, shifted later */
                memset(p->fixedval + 3 * (size_t)v, 0, 3 * sizeof(double));
                break;
            }
    }
    for (int32_t v = 0; v < nv; v++)
        if (p->freeidx[v] == 0)
            p->freeidx[v] = p->nfree++;
        else
            p->freeidx[v] = -1;
    if (p->nfree == 0) {
        st = dtx_seterr(err, DTX_EMESH, "every target vertex is pinned: nothing to solve");
        goto fail;
    }

    /* L = sum over pairs G_t^T G_t, as a full matrix and as the free block. */
    T = cholmod_allocate_triplet((size_t)nv, (size_t)nv, (size_t)npairs * 9, 0, CHOLMOD_REAL,
                                 &p->cc);
    Tf = cholmod_allocate_triplet((size_t)p->nfree, (size_t)p->nfree,
                                  (size_t)npairs * 6 + (size_t)p->nfree, -1, CHOLMOD_REAL, &p->cc);
    if (!T || !Tf)
        goto nomem;
    for (int32_t t = 0; t < nf; t++) {
        int32_t mult = p->tptr[t + 1] - p->tptr[t];
        const double *g = p->G_t + 9 * (size_t)t;
        if (mult == 0)
            continue;
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++) {
                int32_t va = tgt->F[3 * t + a], vb = tgt->F[3 * t + b];
                double val = mult * (g[3 * a] * g[3 * b] + g[3 * a + 1] * g[3 * b + 1] +
                                     g[3 * a + 2] * g[3 * b + 2]);
                size_t k = T->nnz++;
                ((int32_t *)T->i)[k] = va;
                ((int32_t *)T->j)[k] = vb;
                ((double *)T->x)[k] = val;
                if (p->freeidx[va] >= 0 && p->freeidx[vb] >= 0 &&
                    p->freeidx[va] >= p->freeidx[vb]) {
                    k = Tf->nnz++;
                    ((int32_t *)Tf->i)[k] = p->freeidx[va];
                    ((int32_t *)Tf->j)[k] = p->freeidx[vb];
                    ((double *)Tf->x)[k] = val;
                }
            }
    }
    p->Lfull = cholmod_triplet_to_sparse(T, T->nnz, &p->cc);
    K = cholmod_triplet_to_sparse(Tf, Tf->nnz, &p->cc);
    if (!p->Lfull || !K)
        goto nomem;

    /* Coupling of pinned vertices into the right-hand side: -L_fp x_p. */
    p->pin_rhs = dtx_alloc((size_t)p->nfree, 3 * sizeof *p->pin_rhs, 1);
    if (!p->pin_rhs)
        goto nomem;
    {
        const int32_t *Lp = p->Lfull->p, *Li = p->Lfull->i;
        const double *Lx = p->Lfull->x;
        for (int32_t q = 0; q < nv; q++) {
            if (!p->pinned[q])
                continue;
            for (int32_t k = Lp[q]; k < Lp[q + 1]; k++) {
                int32_t fr = p->freeidx[Li[k]];
                if (fr < 0)
                    continue;
                for (int c = 0; c < 3; c++)
                    p->pin_rhs[(size_t)c * p->nfree + fr] -=
                        Lx[k] * p->fixedval[3 * (size_t)q + c];
            }
        }
    }

    t0 = now_seconds();
    p->L = cholmod_analyze(K, &p->cc);
    if (!p->L)
        goto nomem;
    if (!cholmod_factorize(K, p->L, &p->cc) || p->cc.status != CHOLMOD_OK) {
        st = dtx_seterr(err, DTX_ESOLVE,
                        "the transfer system could not be factored (CHOLMOD status %d): the "
                        "target may have degenerate triangles only, or a vertex no pair "
                        "reaches",
                        p->cc.status);
        goto fail;
    }
    p->factor_seconds = now_seconds() - t0;
    cholmod_free_triplet(&T, &p->cc);
    cholmod_free_triplet(&Tf, &p->cc);
    cholmod_free_sparse(&K, &p->cc);
    free(comp);
    free(used);
    *out = p;
    return DTX_OK;

nomem:
    st = dtx_seterr(err, DTX_ENOMEM, "out of memory creating the transfer plan");
fail:
    if (p) {
        cholmod_free_triplet(&T, &p->cc);
        cholmod_free_triplet(&Tf, &p->cc);
        cholmod_free_sparse(&K, &p->cc);
    }
    free(comp);
    free(used);
    dtx_sp04_plan_free(&p);
    return st;
}

static dtx_status ensure_workers(dtx_sp04_plan *p, dtx_error *err)
{
    int n = 1;
#ifdef _OPENMP
    n = omp_get_max_threads();
#endif
    if (p->nworkers >= n)
        return DTX_OK;
    free_workers(p);
    p->workers = calloc((size_t)n, sizeof *p->workers);
    if (!p->workers)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory for solver workspaces");
    p->nworkers = n;
    for (int w = 0; w < n; w++) {
        worker *k = &p->workers[w];
        cholmod_start(&k->cc);
        k->cc.print = 0;
        k->started = 1;
        k->S = dtx_alloc((size_t)p->nf_s, 9 * sizeof *k->S, 0);
        k->bfull = dtx_alloc((size_t)p->nv_t * 3, DTX_SOLVE_GROUP * sizeof *k->bfull, 0);
        k->B = cholmod_zeros((size_t)p->nfree, 3 * DTX_SOLVE_GROUP, CHOLMOD_REAL, &k->cc);
        if (!k->S || !k->bfull || !k->B) {
            free_workers(p);
            return dtx_seterr(err, DTX_ENOMEM, "out of memory for solver workspaces");
        }
    }
    return DTX_OK;
}

/* Right-hand side b (nv_t x 3, column c at b + c*nv_t) of one frame and the
 * constant of its energy, sum over pairs of ||S_s P_t||^2. */
static double frame_rhs(const dtx_sp04_plan *p, const double *S, double *b)
{
    double cst = 0.0;
    memset(b, 0, (size_t)p->nv_t * 3 * sizeof *b);
    for (int32_t t = 0; t < p->nf_t; t++) {
        double M[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
        const double *g = p->G_t + 9 * (size_t)t, *n = p->n_t + 3 * (size_t)t;
        const int32_t *tv = p->F_t + 3 * (size_t)t;
        if (p->tptr[t] == p->tptr[t + 1])
            continue;
        for (int32_t k = p->tptr[t]; k < p->tptr[t + 1]; k++) {
            const double *s = S + 9 * (size_t)p->tsrc[k];
            double sn[3];
            for (int i = 0; i < 9; i++) {
                M[i] += s[i];
                cst += s[i] * s[i];
            }
            /* ||S P||^2 = ||S||^2 - ||S n||^2 with P = I - n n^T. */
            for (int r = 0; r < 3; r++)
                sn[r] = s[3 * r] * n[0] + s[3 * r + 1] * n[1] + s[3 * r + 2] * n[2];
            cst -= sn[0] * sn[0] + sn[1] * sn[1] + sn[2] * sn[2];
        }
        for (int j = 0; j < 3; j++)
            for (int c = 0; c < 3; c++)
                b[(size_t)c * p->nv_t + tv[j]] +=
                    g[3 * j] * M[3 * c] + g[3 * j + 1] * M[3 * c + 1] + g[3 * j + 2] * M[3 * c + 2];
    }
    return cst;
}

/* Energy x^T L x - 2 b^T x + cst over the three coordinates (x: nv x 3
 * row-major, b column-major). */
static double frame_energy(const dtx_sp04_plan *p, const double *x, const double *b, double cst)
{
    const int32_t *Lp = p->Lfull->p, *Li = p->Lfull->i;
    const double *Lx = p->Lfull->x;
    double e = cst;
    for (int32_t j = 0; j < p->nv_t; j++) {
        double lx[3] = {0, 0, 0};
        for (int32_t k = Lp[j]; k < Lp[j + 1]; k++)
            for (int c = 0; c < 3; c++)
                lx[c] += Lx[k] * x[3 * (size_t)Li[k] + c];
        for (int c = 0; c < 3; c++)
            e += x[3 * (size_t)j + c] * lx[c] - 2.0 * b[(size_t)c * p->nv_t + j] * x[3 * (size_t)j + c];
    }
    return e;
}

/* Transfers frames [f0, f0 + nf) of the call, using worker w. */
static dtx_status solve_group(dtx_sp04_plan *p, worker *w, int64_t nfr, const double *Xs,
                              double *Xt, double *residual, dtx_error *err)
{
    const int32_t nv = p->nv_t, nfree = p->nfree;
    double cst[DTX_SOLVE_GROUP];
    double *Bx;
    if ((int64_t)w->B->ncol != 3 * nfr) {
        cholmod_free_dense(&w->B, &w->cc);
        w->B = cholmod_zeros((size_t)nfree, (size_t)(3 * nfr), CHOLMOD_REAL, &w->cc);
        if (!w->B)
            return dtx_seterr(err, DTX_ENOMEM, "out of memory for a solve");
    }
    Bx = w->B->x;
    for (int64_t f = 0; f < nfr; f++) {
        double *b = w->bfull + (size_t)f * 3 * nv;
        dtx_deformation_gradients(p->Vinv_s, p->F_s, p->nf_s, Xs + (size_t)f * 3 * p->nv_s, w->S);
        cst[f] = frame_rhs(p, w->S, b);
        for (int c = 0; c < 3; c++) {
            double *col = Bx + (size_t)(3 * f + c) * nfree;
            const double *pr = p->pin_rhs + (size_t)c * nfree;
            for (int32_t v = 0; v < nv; v++)
                if (p->freeidx[v] >= 0)
                    col[p->freeidx[v]] = b[(size_t)c * nv + v] + pr[p->freeidx[v]];
        }
    }
    if (!cholmod_solve2(CHOLMOD_A, p->L, w->B, NULL, &w->X, NULL, &w->Y, &w->E, &w->cc))
        return dtx_seterr(err, DTX_ESOLVE, "back-substitution failed (CHOLMOD status %d)",
                          w->cc.status);
    for (int64_t f = 0; f < nfr; f++) {
        double *x = Xt + (size_t)f * 3 * nv;
        const double *sol = (const double *)w->X->x + (size_t)3 * f * nfree;
        for (int32_t v = 0; v < nv; v++)
            for (int c = 0; c < 3; c++)
                x[3 * (size_t)v + c] = p->freeidx[v] >= 0
                                           ? sol[(size_t)c * nfree + p->freeidx[v]]
                                           : p->fixedval[3 * (size_t)v + c];
        if (residual) {
            double e = frame_energy(p, x, w->bfull + (size_t)f * 3 * nv, cst[f]);
            residual[f] = sqrt((e > 0.0 ? e : 0.0) / (double)(p->npairs > 0 ? p->npairs : 1));
        }
        if (p->npins == 0) {
            /* The solution is unique up to a translation: place the centroid. */
            double cen[3], want[3];
            centroid(x, nv, cen);
            memcpy(want, p->rest_centroid_t, sizeof want);
            if (p->anchor == DTX_ANCHOR_FOLLOW) {
                double cs[3];
                centroid(Xs + (size_t)f * 3 * p->nv_s, p->nv_s, cs);
                for (int k = 0; k < 3; k++)
                    want[k] += p->scale * (cs[k] - p->rest_centroid_s[k]);
            }
            for (int32_t v = 0; v < nv; v++)
                for (int k = 0; k < 3; k++)
                    x[3 * (size_t)v + k] += want[k] - cen[k];
        }
    }
    return DTX_OK;
}

dtx_status dtx_sp04_apply(dtx_sp04_plan *p, int64_t nframes, const double *Xs, double *Xt,
                          double *residual, dtx_error *err)
{
    int64_t ngroups = (nframes + DTX_SOLVE_GROUP - 1) / DTX_SOLVE_GROUP;
    dtx_status st = ensure_workers(p, err);
    int failed = 0;
    dtx_error first_err;
    if (st != DTX_OK)
        return st;
    first_err.code = DTX_OK;
    first_err.msg[0] = '\0';
#pragma omp parallel for schedule(dynamic, 1)
    for (int64_t g = 0; g < ngroups; g++) {
        int tid = 0;
        int64_t f0 = g * DTX_SOLVE_GROUP;
        int64_t nfr = nframes - f0 < DTX_SOLVE_GROUP ? nframes - f0 : DTX_SOLVE_GROUP;
        dtx_error e;
        dtx_status s;
#ifdef _OPENMP
        tid = omp_get_thread_num();
#endif
        s = solve_group(p, &p->workers[tid], nfr, Xs + (size_t)f0 * 3 * p->nv_s,
                        Xt + (size_t)f0 * 3 * p->nv_t, residual ? residual + f0 : NULL, &e);
        if (s != DTX_OK) {
#pragma omp critical(dtx_sp04_err)
            {
                if (!failed) {
                    failed = 1;
                    first_err = e;
                }
            }
        }
    }
    if (failed) {
        if (err)
            *err = first_err;
        return first_err.code;
    }
    return DTX_OK;
}

double dtx_sp04_plan_bare_solve_seconds(dtx_sp04_plan *p, int nrep)
{
    cholmod_common cc;
    cholmod_dense *B, *X = NULL, *Y = NULL, *E = NULL;
    double t0, t;
    cholmod_start(&cc);
    cc.print = 0;
    B = cholmod_ones((size_t)p->nfree, 3, CHOLMOD_REAL, &cc);
    if (!B) {
        cholmod_finish(&cc);
        return -1.0;
    }
    cholmod_solve2(CHOLMOD_A, p->L, B, NULL, &X, NULL, &Y, &E, &cc); /* warm-up */
    t0 = now_seconds();
    for (int r = 0; r < nrep; r++)
        cholmod_solve2(CHOLMOD_A, p->L, B, NULL, &X, NULL, &Y, &E, &cc);
    t = (now_seconds() - t0) / (nrep > 0 ? nrep : 1);
    cholmod_free_dense(&B, &cc);
    cholmod_free_dense(&X, &cc);
    cholmod_free_dense(&Y, &cc);
    cholmod_free_dense(&E, &cc);
    cholmod_finish(&cc);
    return t;
}
