/*
 * transfer_mc.c: deformation transfer onto targets made of several
 * components (Zhou, Xu, Tong & Desbrun 2010, section 2.3).  For deformed
 * target vertices x (vertex-only gradients, T_t = sum_j x_j g_tj^T, as in
 * transfer_sp04.c) the energy
 *
 *     E = w1 E1 + w2 E2 + w3 E3 + w4 E4
 *     E1 = sum over pairs (s, t)         || S_s - T_t ||^2      matched gradients
 *     E2 = sum over orphan triangles t_i,
 *          t_j in the one-ring of t_i    || T_ti - T_tj ||^2    orphan smoothness
 *     E3 = sum over proximity pairs (i, j)  (|x_i - x_j| - l_ij)^2 / h^2
 *     E4 = sum over vertices of orphan components
 *                                        | L x - dhat(x) |^2 / h^2
 *
 * is minimised (paper: w1 = w2 = w4 = 1, w3 = 0.1).  An orphan triangle is a
 * target triangle in no pair; an orphan component one with no paired
 * triangle; the one-ring of a triangle is every triangle sharing a vertex
 * with it; L is the uniform Laplacian of the component and dhat(x) = L x
 * |L v| / |L x| keeps the rest Laplacian coordinates' lengths (Huang et al.
 * 2006).  Lengths in E3 and E4 are divided by h, the target's mean edge
 * length, so that the weights mean the same at any model scale (E1 and E2
 * are scale-free).
 *
 * Gauss-Newton with the usual linearisation: in iteration k, E3's pairs
 * aim at l_ij d_ij and E4's rows at dhat, with the directions d_ij = (x_i -
 * x_j) / |x_i - x_j| and dhat taken from the previous iterate (the rest pose
 * for the first).  Each iteration is then a linear least-squares problem
 * whose matrix
 *     A = w1 sum G_t^T G_t + w2 sum (G_ti - G_tj)^T (G_ti - G_tj)
 *       + w3/h^2 sum (e_i - e_j)(e_i - e_j)^T + w4/h^2 sum L^T L
 * does not depend on the iterate or the frame: it is factored once (CHOLMOD,
 * simplicial, so that no BLAS threads run inside the OpenMP loop), and an
 * iteration is one back-substitution with 3 right-hand sides.  A frame
 * iterates until no vertex moves by more than tol x the target diagonal,
 * or max_iter times.  Without E3 and E4 terms (one component, every
 * triangle paired) one solve is exact, and the result is sp04's.
 *
 * The global translation is fixed as in sp04: pinned vertices, or one
 * anchor vertex solved at 0 and the frame shifted afterwards so that its
 * centroid is the rest centroid (or follows the source's centroid).  Every
 * frame starts from the rest pose and is solved by one thread with its own
 * workspace, in a fixed order, so a frame's result does not depend on the
 * thread count or on how the sequence is split.
 */
#include "dtx_core.h"
#include "proximity.h"

#include <cholmod.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#endif

void dtx_mc_params_default(dtx_mc_params *p)
{
    memset(p, 0, sizeof *p);
    p->w_match = 1.0;
    p->w_orphan = 1.0;
    p->w_proximity = 0.1;
    p->w_laplacian = 1.0;
    p->eps_factor = 1.5;
    p->max_iter = 30;
    p->tol = 1e-6;
}

/* ------------------------------------------------------------------ */
/* Plan                                                                */
/* ------------------------------------------------------------------ */

typedef struct {
    cholmod_common cc;
    cholmod_dense *B, *X, *Y, *E;
    double *S;   /* nf_s x 9: the frame's source gradients */
    double *b1;  /* nfree x 3 (column-major): frame part of the right-hand side */
    double *x;   /* nv_t x 3: current iterate (anchored) */
    double *lx;  /* nlap x 3: L x of the current iterate */
} mc_worker;

struct dtx_mc_plan {
    int32_t nv_s, nf_s, nv_t, nf_t;
    int32_t *Fs, *Ft;      /* copies of the faces */
    double *Vt;            /* nv_t x 3 target rest positions */
    double *Vinv;          /* nf_s x 9 source rest-frame inverses */
    double *G;             /* nf_t x 9 target gradient operator */
    double *N;             /* nf_t x 3 target unit normals */
    int64_t npairs;
    int32_t *pairs;        /* npairs x 2 (source, target triangle) */
    int64_t nsmooth;
    int32_t *smooth;       /* nsmooth x 2 (orphan triangle, one-ring triangle) */
    dtx_proximity prox;
    int32_t *prox_src;     /* prox.npairs x 2: a source triangle paired with a target
                              triangle at i (at j), or -1: rotates the first iterate */
    int32_t nlap;          /* Laplacian rows (vertices of orphan components) */
    int32_t *lap_vertex;   /* nlap */
    int64_t *lap_ptr;      /* nlap + 1 */
    int32_t *lap_col;      /* lap_ptr[nlap]: vertex of each coefficient */
    double *lap_coef;
    double *lap_mag;       /* nlap: |L v| at rest */
    double *lap_rest;      /* nlap x 3: L v at rest */
    double w1, w2, w3, w4; /* w3, w4 divided by h^2 */
    int max_iter;
    double tol_abs;
    int nonlinear;         /* E3 or E4 present */

    int32_t nfree;
    int32_t *freeidx;      /* nv_t: free index or -1 */
    double *fixedval;      /* nv_t x 3: pins at their positions, anchor at 0 */
    double *bconst;        /* nfree x 3 (column-major): pins' share of the rhs */
    int32_t nunref;
    unsigned char *used;   /* nv_t: vertex in a face */
    double rest_centroid_ref[3], rest_centroid_t[3], rest_centroid_s[3], scale;
    dtx_anchor anchor;
    int32_t npins;

    cholmod_common cc;
    cholmod_factor *L;
    double factor_seconds;
    dtx_mc_info info;

    int nworkers;
    mc_worker *workers;
};

static double dot3(const double *a, const double *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void free_workers(dtx_mc_plan *p)
{
    for (int w = 0; w < p->nworkers; w++) {
        mc_worker *k = &p->workers[w];
        cholmod_free_dense(&k->B, &k->cc);
        cholmod_free_dense(&k->X, &k->cc);
        cholmod_free_dense(&k->Y, &k->cc);
        cholmod_free_dense(&k->E, &k->cc);
        cholmod_finish(&k->cc);
        free(k->S);
        free(k->b1);
        free(k->x);
        free(k->lx);
    }
    free(p->workers);
    p->workers = NULL;
    p->nworkers = 0;
}

void dtx_mc_plan_free(dtx_mc_plan **pp)
{
    dtx_mc_plan *p;
    if (!pp || !*pp)
        return;
    p = *pp;
    free_workers(p);
    cholmod_free_factor(&p->L, &p->cc);
    cholmod_finish(&p->cc);
    dtx_proximity_free(&p->prox);
    free(p->prox_src);
    free(p->Fs);
    free(p->Ft);
    free(p->Vt);
    free(p->Vinv);
    free(p->G);
    free(p->N);
    free(p->pairs);
    free(p->smooth);
    free(p->lap_vertex);
    free(p->lap_ptr);
    free(p->lap_col);
    free(p->lap_coef);
    free(p->lap_mag);
    free(p->lap_rest);
    free(p->freeidx);
    free(p->fixedval);
    free(p->bconst);
    free(p->used);
    free(p);
    *pp = NULL;
}

/* ------------------------------------------------------------------ */
/* Assembly                                                            */
/* ------------------------------------------------------------------ */

/* Lower-triangle triplets of the free-free block, grown as needed. */
typedef struct {
    int64_t n, cap;
    int32_t *i, *j;
    double *x;
} coo;

static int coo_push(coo *c, int32_t i, int32_t j, double x)
{
    if (c->n == c->cap) {
        int64_t ncap = c->cap ? 2 * c->cap : 1 << 16;
        int32_t *ni = realloc(c->i, (size_t)ncap * sizeof *ni);
        int32_t *nj;
        double *nx;
        if (!ni)
            return 0;
        c->i = ni;
        nj = realloc(c->j, (size_t)ncap * sizeof *nj);
        if (!nj)
            return 0;
        c->j = nj;
        nx = realloc(c->x, (size_t)ncap * sizeof *nx);
        if (!nx)
            return 0;
        c->x = nx;
        c->cap = ncap;
    }
    c->i[c->n] = i;
    c->j[c->n] = j;
    c->x[c->n] = x;
    c->n++;
    return 1;
}

/* A term w sum_c |sum_p x_{var_p, c} a_p - t_c|^2 (3-vector coefficients
 * a_p; scalar terms use (a, 0, 0)).  Its matrix goes to the triplets and
 * the fixed unknowns' share of the right-hand side to bconst; the targets
 * t_c are the frame's business. */
typedef struct {
    int n;
    int32_t var[16];
    double a[16][3];
} term;

static void term_add(term *t, int32_t var, const double *a, double sign)
{
    for (int i = 0; i < t->n; i++)
        if (t->var[i] == var) {
            for (int k = 0; k < 3; k++)
                t->a[i][k] += sign * a[k];
            return;
        }
    t->var[t->n] = var;
    for (int k = 0; k < 3; k++)
        t->a[t->n][k] = sign * a[k];
    t->n++;
}

static void term_triangle(term *t, const dtx_mc_plan *p, int32_t f, double sign)
{
    for (int j = 0; j < 3; j++)
        term_add(t, p->Ft[3 * f + j], p->G + 9 * (size_t)f + 3 * j, sign);
}

static int emit(const dtx_mc_plan *p, coo *c, const term *t, double w)
{
    for (int a = 0; a < t->n; a++) {
        int32_t fa = p->freeidx[t->var[a]];
        if (fa < 0)
            continue;
        for (int b = 0; b < t->n; b++) {
            int32_t fb = p->freeidx[t->var[b]];
            double v = w * dot3(t->a[a], t->a[b]);
            if (fb < 0) {
                for (int k = 0; k < 3; k++)
                    p->bconst[(size_t)k * p->nfree + fa] -=
                        v * p->fixedval[3 * (size_t)t->var[b] + k];
            } else if (fb <= fa) {
                if (!coo_push(c, fa, fb, v))
                    return 0;
            }
        }
    }
    return 1;
}

/* Orphan triangles' one-ring pairs (t_i orphan, t_j sharing a vertex). */
static dtx_status build_smooth(dtx_mc_plan *p, const unsigned char *paired, dtx_error *err)
{
    const int32_t nv = p->nv_t, nf = p->nf_t;
    int64_t *vptr = dtx_alloc((size_t)nv + 1, sizeof *vptr, 1);
    int32_t *vfaces = dtx_alloc((size_t)nf, 3 * sizeof *vfaces, 0);
    int32_t *mark = dtx_alloc((size_t)nf, sizeof *mark, 0);
    int64_t n = 0, cap = 0;
    dtx_status st = DTX_OK;
    if (!vptr || !vfaces || !mark)
        goto nomem;
    for (int64_t i = 0; i < 3 * (int64_t)nf; i++)
        vptr[p->Ft[i] + 1]++;
    for (int32_t v = 0; v < nv; v++)
        vptr[v + 1] += vptr[v];
    {
        int64_t *fill = dtx_alloc((size_t)nv, sizeof *fill, 0);
        if (!fill)
            goto nomem;
        memcpy(fill, vptr, (size_t)nv * sizeof *fill);
        for (int32_t f = 0; f < nf; f++)
            for (int k = 0; k < 3; k++)
                vfaces[fill[p->Ft[3 * f + k]]++] = f;
        free(fill);
    }
    for (int32_t f = 0; f < nf; f++)
        mark[f] = -1;
    for (int32_t f = 0; f < nf; f++) {
        if (paired[f])
            continue;
        mark[f] = f;
        /* Faces around each vertex are in increasing order: the one-ring
         * is visited vertex by vertex, each face once. */
        for (int k = 0; k < 3; k++) {
            int32_t v = p->Ft[3 * f + k];
            for (int64_t q = vptr[v]; q < vptr[v + 1]; q++) {
                int32_t g = vfaces[q];
                if (mark[g] == f)
                    continue;
                mark[g] = f;
                if (n == cap) {
                    int64_t ncap = cap ? 2 * cap : 1024;
                    int32_t *ns = realloc(p->smooth, (size_t)ncap * 2 * sizeof *ns);
                    if (!ns)
                        goto nomem;
                    p->smooth = ns;
                    cap = ncap;
                }
                p->smooth[2 * n] = f;
                p->smooth[2 * n + 1] = g;
                n++;
            }
        }
    }
    p->nsmooth = n;
    goto done;
nomem:
    st = dtx_seterr(err, DTX_ENOMEM, "out of memory building the orphan-triangle terms");
done:
    free(vptr);
    free(vfaces);
    free(mark);
    return st;
}

typedef struct {
    int32_t a, b;
} vpair;

static int cmp_vpair(const void *x, const void *y)
{
    const vpair *p = x, *q = y;
    if (p->a != q->a)
        return p->a < q->a ? -1 : 1;
    return (p->b > q->b) - (p->b < q->b);
}

/* Uniform Laplacian rows of the vertices of orphan components. */
static dtx_status build_laplacian(dtx_mc_plan *p, const unsigned char *orphan_comp,
                                  dtx_error *err)
{
    const int32_t nf = p->nf_t;
    const int32_t *comp = p->prox.comp;
    vpair *e = dtx_alloc((size_t)nf, 6 * sizeof *e, 0);
    int64_t ne = 0, w = 0;
    int32_t *rowof = NULL;
    dtx_status st = DTX_OK;
    if (!e)
        goto nomem;
    for (int32_t f = 0; f < nf; f++) {
        int32_t c = comp[p->Ft[3 * f]];
        if (c < 0 || !orphan_comp[c])
            continue;
        for (int k = 0; k < 3; k++) {
            int32_t a = p->Ft[3 * f + k], b = p->Ft[3 * f + (k + 1) % 3];
            e[ne].a = a;
            e[ne++].b = b;
            e[ne].a = b;
            e[ne++].b = a;
        }
    }
    qsort(e, (size_t)ne, sizeof *e, cmp_vpair);
    for (int64_t i = 0; i < ne; i++)
        if (w == 0 || e[i].a != e[w - 1].a || e[i].b != e[w - 1].b)
            e[w++] = e[i];
    ne = w;
    /* Rows: one per distinct vertex a, coefficients 1 on a and -1/deg on
     * its neighbours. */
    p->nlap = 0;
    for (int64_t i = 0; i < ne; i++)
        if (i == 0 || e[i].a != e[i - 1].a)
            p->nlap++;
    p->lap_vertex = dtx_alloc((size_t)p->nlap, sizeof *p->lap_vertex, 0);
    p->lap_ptr = dtx_alloc((size_t)p->nlap + 1, sizeof *p->lap_ptr, 0);
    p->lap_col = dtx_alloc((size_t)(ne + p->nlap), sizeof *p->lap_col, 0);
    p->lap_coef = dtx_alloc((size_t)(ne + p->nlap), sizeof *p->lap_coef, 0);
    p->lap_mag = dtx_alloc((size_t)p->nlap, sizeof *p->lap_mag, 0);
    p->lap_rest = dtx_alloc((size_t)p->nlap, 3 * sizeof *p->lap_rest, 0);
    if (!p->lap_vertex || !p->lap_ptr || !p->lap_col || !p->lap_coef || !p->lap_mag ||
        !p->lap_rest)
        goto nomem;
    {
        int32_t r = 0;
        int64_t k = 0;
        for (int64_t i = 0; i < ne;) {
            int64_t j = i;
            while (j < ne && e[j].a == e[i].a)
                j++;
            p->lap_vertex[r] = e[i].a;
            p->lap_ptr[r] = k;
            p->lap_col[k] = e[i].a;
            p->lap_coef[k++] = 1.0;
            for (int64_t q = i; q < j; q++) {
                p->lap_col[k] = e[q].b;
                p->lap_coef[k++] = -1.0 / (double)(j - i);
            }
            r++;
            i = j;
        }
        p->lap_ptr[r] = k;
    }
    for (int32_t r = 0; r < p->nlap; r++) {
        double d[3] = {0, 0, 0};
        for (int64_t q = p->lap_ptr[r]; q < p->lap_ptr[r + 1]; q++)
            for (int c = 0; c < 3; c++)
                d[c] += p->lap_coef[q] * p->Vt[3 * (size_t)p->lap_col[q] + c];
        memcpy(p->lap_rest + 3 * (size_t)r, d, sizeof d);
        p->lap_mag[r] = sqrt(dot3(d, d));
    }
    goto done;
nomem:
    st = dtx_seterr(err, DTX_ENOMEM, "out of memory building the Laplacian terms");
done:
    free(e);
    free(rowof);
    return st;
}

/* For each proximity pair, a source triangle deforming each end's
 * neighbourhood: the first pair of the lowest paired target triangle
 * around the vertex. */
static dtx_status build_prox_src(dtx_mc_plan *p, dtx_error *err)
{
    int32_t *tsrc = dtx_alloc((size_t)p->nf_t, sizeof *tsrc, 0);
    int32_t *vsrc = dtx_alloc((size_t)p->nv_t, sizeof *vsrc, 0);
    p->prox_src = dtx_alloc((size_t)p->prox.npairs, 2 * sizeof *p->prox_src, 0);
    if (!tsrc || !vsrc || !p->prox_src) {
        free(tsrc);
        free(vsrc);
        return dtx_seterr(err, DTX_ENOMEM, "out of memory building the proximity terms");
    }
    for (int32_t f = 0; f < p->nf_t; f++)
        tsrc[f] = -1;
    for (int64_t i = 0; i < p->npairs; i++)
        if (tsrc[p->pairs[2 * i + 1]] < 0)
            tsrc[p->pairs[2 * i + 1]] = p->pairs[2 * i];
    for (int32_t v = 0; v < p->nv_t; v++)
        vsrc[v] = -1;
    for (int32_t f = p->nf_t - 1; f >= 0; f--)
        if (tsrc[f] >= 0)
            for (int k = 0; k < 3; k++)
                vsrc[p->Ft[3 * f + k]] = tsrc[f];
    for (int64_t i = 0; i < p->prox.npairs; i++) {
        p->prox_src[2 * i] = vsrc[p->prox.pairs[2 * i]];
        p->prox_src[2 * i + 1] = vsrc[p->prox.pairs[2 * i + 1]];
    }
    free(tsrc);
    free(vsrc);
    return DTX_OK;
}

static double now_seconds(void)
{
#ifdef _OPENMP
    return omp_get_wtime();
#else
    return 0.0;
#endif
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

dtx_status dtx_mc_plan_create(const dtx_mesh *src, const dtx_mesh *tgt, const int32_t *pairs,
                              int64_t npairs, const dtx_mc_params *prm, dtx_anchor anchor,
                              const int32_t *pins, const double *pin_pos, int32_t npins,
                              dtx_mc_plan **out, dtx_error *err)
{
    dtx_mc_plan *p = NULL;
    dtx_status st = DTX_OK;
    const int32_t nv = tgt->nv, nf = tgt->nf;
    unsigned char *paired = NULL, *orphan_comp = NULL;
    cholmod_triplet *T = NULL;
    cholmod_sparse *K = NULL;
    coo c = {0, 0, NULL, NULL, NULL};
    double h = 0.0, diag_t, diag_s, t0;

    *out = NULL;
    if (!(prm->w_match > 0.0) || !(prm->w_orphan >= 0.0) || !(prm->w_proximity >= 0.0) ||
        !(prm->w_laplacian >= 0.0) || prm->max_iter < 1 || !(prm->tol >= 0.0) ||
        !(prm->eps_factor >= 0.0))
        return dtx_seterr(err, DTX_EINVAL,
                          "multicomponent parameters out of range (w_match > 0, other weights, "
                          "tol and eps_factor >= 0, max_iter >= 1)");
    if (anchor == DTX_ANCHOR_PINS && npins < 1)
        return dtx_seterr(err, DTX_EINVAL, "translation \"pins\" needs at least one pinned vertex");
    for (int32_t i = 0; i < npins; i++)
        if (pins[i] < 0 || pins[i] >= nv)
            return dtx_seterr(err, DTX_ERANGE, "pin %d: vertex %d out of range [0, %d)", (int)i,
                              (int)pins[i], (int)nv);
    if (npairs < 0 || npairs > INT32_MAX)
        return dtx_seterr(err, DTX_ERANGE, "%lld correspondence pairs: 0 to %d supported",
                          (long long)npairs, (int)INT32_MAX);
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
    p->cc.supernodal = CHOLMOD_SIMPLICIAL;
    p->nv_s = src->nv;
    p->nf_s = src->nf;
    p->nv_t = nv;
    p->nf_t = nf;
    p->npairs = npairs;
    p->anchor = anchor;
    p->npins = npins;
    p->max_iter = prm->max_iter;
    p->Fs = dtx_alloc((size_t)src->nf, 3 * sizeof *p->Fs, 0);
    p->Ft = dtx_alloc((size_t)nf, 3 * sizeof *p->Ft, 0);
    p->Vt = dtx_alloc((size_t)nv, 3 * sizeof *p->Vt, 0);
    p->Vinv = dtx_alloc((size_t)src->nf, 9 * sizeof *p->Vinv, 0);
    p->G = dtx_alloc((size_t)nf, 9 * sizeof *p->G, 0);
    p->N = dtx_alloc((size_t)nf, 3 * sizeof *p->N, 0);
    p->pairs = dtx_alloc((size_t)npairs, 2 * sizeof *p->pairs, 0);
    p->freeidx = dtx_alloc((size_t)nv, sizeof *p->freeidx, 0);
    p->fixedval = dtx_alloc((size_t)nv, 3 * sizeof *p->fixedval, 1);
    p->used = dtx_alloc((size_t)nv, 1, 1);
    paired = dtx_alloc((size_t)nf, 1, 1);
    if (!p->Fs || !p->Ft || !p->Vt || !p->Vinv || !p->G || !p->N || !p->pairs ||
        !p->freeidx || !p->fixedval || !p->used || !paired)
        goto nomem;
    memcpy(p->Fs, src->F, (size_t)src->nf * 3 * sizeof *p->Fs);
    memcpy(p->Ft, tgt->F, (size_t)nf * 3 * sizeof *p->Ft);
    memcpy(p->Vt, tgt->V, (size_t)nv * 3 * sizeof *p->Vt);
    memcpy(p->pairs, pairs, (size_t)npairs * 2 * sizeof *p->pairs);

    /* Operators, as sp04's. */
    diag_s = dtx_bbox_diagonal(src->V, src->nv);
    diag_t = dtx_bbox_diagonal(tgt->V, nv);
    if (!(diag_t > 0.0)) {
        st = dtx_seterr(err, DTX_EMESH, "the target mesh has zero extent");
        goto fail;
    }
    dtx_frame_inverses(src->V, src->F, src->nf, 1e-14 * diag_s * diag_s, p->Vinv);
    dtx_gradient_operator(tgt->V, tgt->F, nf, 1e-14 * diag_t * diag_t, p->G);
    dtx_face_normals(tgt->V, tgt->F, nf, p->N);
    p->tol_abs = prm->tol * diag_t;

    /* Components, proximity pairs, orphans. */
    st = dtx_proximity_build(tgt, prm->eps_factor, &p->prox, err);
    if (st != DTX_OK)
        goto fail;
    for (int64_t i = 0; i < npairs; i++)
        paired[pairs[2 * i + 1]] = 1;
    orphan_comp = dtx_alloc((size_t)p->prox.ncomp, 1, 0);
    if (!orphan_comp)
        goto nomem;
    memset(orphan_comp, 1, (size_t)p->prox.ncomp);
    for (int32_t f = 0; f < nf; f++)
        if (paired[f])
            orphan_comp[p->prox.comp[tgt->F[3 * f]]] = 0;
    p->info.components = p->prox.ncomp;
    p->info.proximity_pairs = p->prox.npairs;
    p->info.proximity_edges = p->prox.nedges;
    for (int32_t f = 0; f < nf; f++)
        p->info.orphan_triangles += !paired[f];
    for (int32_t k = 0; k < p->prox.ncomp; k++)
        p->info.orphan_components += orphan_comp[k];
    st = build_smooth(p, paired, err);
    if (st != DTX_OK)
        goto fail;
    st = build_laplacian(p, orphan_comp, err);
    if (st != DTX_OK)
        goto fail;
    st = build_prox_src(p, err);
    if (st != DTX_OK)
        goto fail;
    p->nonlinear = (p->prox.npairs > 0 && prm->w_proximity > 0.0) ||
                   (p->nlap > 0 && prm->w_laplacian > 0.0);

    /* Length unit: the target's bounding-box diagonal. */
    h = diag_t;
    p->w1 = prm->w_match;
    p->w2 = prm->w_orphan;
    p->w3 = prm->w_proximity / (h * h);
    p->w4 = prm->w_laplacian / (h * h);

    /* Unknowns: as sp04 (pins and, without pins, one anchor removed;
     * vertices in no face keep their rest offset from the centroid). */
    for (int64_t i = 0; i < 3 * (int64_t)nf; i++)
        p->used[tgt->F[i]] = 1;
    centroid(tgt->V, nv, p->rest_centroid_t);
    centroid(src->V, src->nv, p->rest_centroid_s);
    p->scale = diag_s > 0 ? diag_t / diag_s : 1.0;
    for (int32_t v = 0; v < nv; v++)
        p->freeidx[v] = p->used[v] ? 0 : -1;
    for (int32_t i = 0; i < npins; i++) {
        p->freeidx[pins[i]] = -1;
        memcpy(p->fixedval + 3 * (size_t)pins[i], pin_pos + 3 * (size_t)i, 3 * sizeof(double));
    }
    if (npins == 0)
        for (int32_t v = 0; v < nv; v++)
            if (p->used[v]) {
                p->freeidx[v] = -1;
                break;
            }
    for (int32_t v = 0; v < nv; v++)
        if (p->freeidx[v] == 0)
            p->freeidx[v] = p->nfree++;
        else
            p->freeidx[v] = -1;
    for (int32_t v = 0; v < nv; v++)
        p->nunref += !p->used[v];
    if (p->nunref > 0) {
        for (int32_t v = 0; v < nv; v++)
            if (p->used[v])
                for (int k = 0; k < 3; k++)
                    p->rest_centroid_ref[k] += tgt->V[3 * (size_t)v + k] / (nv - p->nunref);
    }
    if (p->nfree == 0) {
        st = dtx_seterr(err, DTX_EMESH, "every target vertex is pinned: nothing to solve");
        goto fail;
    }
    p->bconst = dtx_alloc((size_t)p->nfree, 3 * sizeof *p->bconst, 1);
    if (!p->bconst)
        goto nomem;

    /* The matrix, term by term. */
    for (int64_t i = 0; i < npairs; i++) {
        term t = {0};
        term_triangle(&t, p, pairs[2 * i + 1], 1.0);
        if (!emit(p, &c, &t, p->w1))
            goto nomem;
    }
    if (p->w2 > 0.0)
        for (int64_t i = 0; i < p->nsmooth; i++) {
            term t = {0};
            term_triangle(&t, p, p->smooth[2 * i], 1.0);
            term_triangle(&t, p, p->smooth[2 * i + 1], -1.0);
            if (!emit(p, &c, &t, p->w2))
                goto nomem;
        }
    if (p->w3 > 0.0)
        for (int64_t i = 0; i < p->prox.npairs; i++) {
            static const double one[3] = {1, 0, 0};
            term t = {0};
            term_add(&t, p->prox.pairs[2 * i], one, 1.0);
            term_add(&t, p->prox.pairs[2 * i + 1], one, -1.0);
            if (!emit(p, &c, &t, p->w3))
                goto nomem;
        }
    if (p->w4 > 0.0)
        for (int32_t r = 0; r < p->nlap; r++) {
            /* A row has 1 + degree coefficients; rows of very high degree
             * are emitted pairwise without the term's fixed capacity. */
            int64_t q0 = p->lap_ptr[r], q1 = p->lap_ptr[r + 1];
            for (int64_t a = q0; a < q1; a++) {
                int32_t fa = p->freeidx[p->lap_col[a]];
                if (fa < 0)
                    continue;
                for (int64_t b = q0; b < q1; b++) {
                    int32_t fb = p->freeidx[p->lap_col[b]];
                    double v = p->w4 * p->lap_coef[a] * p->lap_coef[b];
                    if (fb < 0) {
                        for (int k = 0; k < 3; k++)
                            p->bconst[(size_t)k * p->nfree + fa] -=
                                v * p->fixedval[3 * (size_t)p->lap_col[b] + k];
                    } else if (fb <= fa && !coo_push(&c, fa, fb, v)) {
                        goto nomem;
                    }
                }
            }
        }
    T = cholmod_allocate_triplet((size_t)p->nfree, (size_t)p->nfree, (size_t)c.n, -1,
                                 CHOLMOD_REAL, &p->cc);
    if (!T)
        goto nomem;
    memcpy(T->i, c.i, (size_t)c.n * sizeof *c.i);
    memcpy(T->j, c.j, (size_t)c.n * sizeof *c.j);
    memcpy(T->x, c.x, (size_t)c.n * sizeof *c.x);
    T->nnz = (size_t)c.n;
    free(c.i);
    free(c.j);
    free(c.x);
    c.i = c.j = NULL;
    c.x = NULL;
    K = cholmod_triplet_to_sparse(T, T->nnz, &p->cc);
    cholmod_free_triplet(&T, &p->cc);
    if (!K)
        goto nomem;

    t0 = now_seconds();
    p->L = cholmod_analyze(K, &p->cc);
    if (!p->L)
        goto nomem;
    if (!cholmod_factorize(K, p->L, &p->cc) || p->cc.status != CHOLMOD_OK) {
        st = dtx_seterr(err, DTX_ESOLVE,
                        "the multicomponent transfer system could not be factored (CHOLMOD "
                        "status %d): some vertex is reached by no term (a component with "
                        "neither pairs, proximity pairs nor orphan terms?)",
                        p->cc.status);
        goto fail;
    }
    p->factor_seconds = now_seconds() - t0;
    p->info.factor_seconds = p->factor_seconds;
    cholmod_free_sparse(&K, &p->cc);
    free(paired);
    free(orphan_comp);
    *out = p;
    return DTX_OK;

nomem:
    st = dtx_seterr(err, DTX_ENOMEM, "out of memory creating the multicomponent transfer plan");
fail:
    if (p) {
        cholmod_free_sparse(&K, &p->cc);
        cholmod_free_triplet(&T, &p->cc);
    }
    free(c.i);
    free(c.j);
    free(c.x);
    free(paired);
    free(orphan_comp);
    dtx_mc_plan_free(&p);
    return st;
}

void dtx_mc_plan_info(const dtx_mc_plan *p, dtx_mc_info *info)
{
    *info = p->info;
}

int32_t dtx_mc_plan_nv_src(const dtx_mc_plan *p) { return p->nv_s; }
int32_t dtx_mc_plan_nv_tgt(const dtx_mc_plan *p) { return p->nv_t; }

/* ------------------------------------------------------------------ */
/* Apply                                                               */
/* ------------------------------------------------------------------ */

static dtx_status ensure_workers(dtx_mc_plan *p, dtx_error *err)
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
        mc_worker *k = &p->workers[w];
        cholmod_start(&k->cc);
        k->cc.print = 0;
        k->B = cholmod_zeros((size_t)p->nfree, 3, CHOLMOD_REAL, &k->cc);
        k->S = dtx_alloc((size_t)p->nf_s, 9 * sizeof *k->S, 0);
        k->b1 = dtx_alloc((size_t)p->nfree, 3 * sizeof *k->b1, 0);
        k->x = dtx_alloc((size_t)p->nv_t, 3 * sizeof *k->x, 0);
        k->lx = dtx_alloc((size_t)p->nlap, 3 * sizeof *k->lx, 0);
        if (!k->B || !k->S || !k->b1 || !k->x || !k->lx) {
            free_workers(p);
            return dtx_seterr(err, DTX_ENOMEM, "out of memory for solver workspaces");
        }
    }
    return DTX_OK;
}

/* L x for every Laplacian row into lx. */
static void laplacian_apply(const dtx_mc_plan *p, const double *x, double *lx)
{
    for (int32_t r = 0; r < p->nlap; r++) {
        double d[3] = {0, 0, 0};
        for (int64_t q = p->lap_ptr[r]; q < p->lap_ptr[r + 1]; q++)
            for (int c = 0; c < 3; c++)
                d[c] += p->lap_coef[q] * x[3 * (size_t)p->lap_col[q] + c];
        memcpy(lx + 3 * (size_t)r, d, sizeof d);
    }
}

/* The Laplacian target of row r: L x scaled to the rest length (the rest
 * vector itself while L x vanishes). */
static void lap_target(const dtx_mc_plan *p, int32_t r, const double *lx, double *t)
{
    const double *d = lx + 3 * (size_t)r;
    double n = sqrt(dot3(d, d));
    if (n > 1e-12 * p->lap_mag[r] && n > 0.0)
        for (int c = 0; c < 3; c++)
            t[c] = d[c] * (p->lap_mag[r] / n);
    else
        memcpy(t, p->lap_rest + 3 * (size_t)r, 3 * sizeof *t);
}

/* The proximity pair's target vector l d (rest direction while the pair
 * has collapsed). */
static void prox_target(const dtx_mc_plan *p, int64_t i, const double *x, double *t)
{
    int32_t a = p->prox.pairs[2 * i], b = p->prox.pairs[2 * i + 1];
    double d[3], n, l = p->prox.rest_len[i];
    for (int c = 0; c < 3; c++)
        d[c] = x[3 * (size_t)a + c] - x[3 * (size_t)b + c];
    n = sqrt(dot3(d, d));
    if (!(n > 0.0)) {
        for (int c = 0; c < 3; c++)
            d[c] = p->Vt[3 * (size_t)a + c] - p->Vt[3 * (size_t)b + c];
        n = sqrt(dot3(d, d));
    }
    for (int c = 0; c < 3; c++)
        t[c] = n > 0.0 ? d[c] * (l / n) : 0.0;
}

/* The first iterate's target for proximity pair i: the rest vector
 * turned by the source gradients at its two ends (the rest vector where
 * neither end is paired), at the rest length. */
static void prox_target_first(const dtx_mc_plan *p, int64_t i, const double *S, double *t)
{
    int32_t a = p->prox.pairs[2 * i], b = p->prox.pairs[2 * i + 1];
    double u[3], d[3] = {0, 0, 0}, n, l = p->prox.rest_len[i];
    int used = 0;
    for (int c = 0; c < 3; c++)
        u[c] = p->Vt[3 * (size_t)a + c] - p->Vt[3 * (size_t)b + c];
    for (int e = 0; e < 2; e++) {
        int32_t s = p->prox_src[2 * i + e];
        if (s < 0)
            continue;
        for (int c = 0; c < 3; c++)
            d[c] += dot3(S + 9 * (size_t)s + 3 * c, u);
        used = 1;
    }
    if (!used)
        memcpy(d, u, sizeof d);
    n = sqrt(dot3(d, d));
    if (!(n > 0.0) || !isfinite(n)) {
        memcpy(d, u, sizeof d);
        n = sqrt(dot3(d, d));
    }
    for (int c = 0; c < 3; c++)
        t[c] = n > 0.0 ? d[c] * (l / n) : 0.0;
}

/* Energy of the iterate x (see the file comment), for the residual. */
static double energy(const dtx_mc_plan *p, const double *S, const double *x, const double *lx)
{
    double e1 = 0.0, e2 = 0.0, e3 = 0.0, e4 = 0.0;
    for (int64_t i = 0; i < p->npairs; i++) {
        int32_t s = p->pairs[2 * i], t = p->pairs[2 * i + 1];
        const double *g = p->G + 9 * (size_t)t, *n = p->N + 3 * (size_t)t;
        for (int c = 0; c < 3; c++) {
            const double *srow = S + 9 * (size_t)s + 3 * c;
            double sn = dot3(srow, n), r[3];
            for (int k = 0; k < 3; k++)
                r[k] = srow[k] - sn * n[k];
            for (int j = 0; j < 3; j++) {
                double xv = x[3 * (size_t)p->Ft[3 * t + j] + c];
                for (int k = 0; k < 3; k++)
                    r[k] -= xv * g[3 * j + k];
            }
            e1 += dot3(r, r);
        }
    }
    for (int64_t i = 0; i < p->nsmooth; i++) {
        int32_t a = p->smooth[2 * i], b = p->smooth[2 * i + 1];
        for (int c = 0; c < 3; c++) {
            double r[3] = {0, 0, 0};
            for (int j = 0; j < 3; j++) {
                double xa = x[3 * (size_t)p->Ft[3 * a + j] + c];
                double xb = x[3 * (size_t)p->Ft[3 * b + j] + c];
                for (int k = 0; k < 3; k++)
                    r[k] += xa * p->G[9 * (size_t)a + 3 * j + k] -
                            xb * p->G[9 * (size_t)b + 3 * j + k];
            }
            e2 += dot3(r, r);
        }
    }
    for (int64_t i = 0; i < p->prox.npairs; i++) {
        int32_t a = p->prox.pairs[2 * i], b = p->prox.pairs[2 * i + 1];
        double d[3];
        for (int c = 0; c < 3; c++)
            d[c] = x[3 * (size_t)a + c] - x[3 * (size_t)b + c];
        d[0] = sqrt(dot3(d, d)) - p->prox.rest_len[i];
        e3 += d[0] * d[0];
    }
    for (int32_t r = 0; r < p->nlap; r++) {
        const double *l = lx + 3 * (size_t)r;
        double n = sqrt(dot3(l, l)) - p->lap_mag[r];
        e4 += n * n;
    }
    return p->w1 * e1 + p->w2 * e2 + p->w3 * e3 + p->w4 * e4;
}

/* Transfers one frame with worker w. */
static void solve_frame(dtx_mc_plan *p, mc_worker *w, const double *Xs, double *Xt,
                        double *residual, int32_t *iters)
{
    const int32_t nv = p->nv_t, nfree = p->nfree;
    double *b = w->B->x;
    int it, ok = 1;
    double want[3];

    for (int64_t i = 0; i < 3 * (int64_t)p->nv_s; i++)
        if (!isfinite(Xs[i])) {
            ok = 0;
            break;
        }
    if (!ok) {
        for (int64_t i = 0; i < 3 * (int64_t)nv; i++)
            Xt[i] = NAN;
        if (residual)
            *residual = NAN;
        if (iters)
            *iters = 0;
        return;
    }

    /* E1's right-hand side (the frame's source gradients) plus the pins'. */
    dtx_deformation_gradients(p->Vinv, p->Fs, p->nf_s, Xs, w->S);
    memcpy(w->b1, p->bconst, (size_t)nfree * 3 * sizeof *w->b1);
    for (int64_t i = 0; i < p->npairs; i++) {
        int32_t s = p->pairs[2 * i], t = p->pairs[2 * i + 1];
        const double *S = w->S + 9 * (size_t)s;
        for (int j = 0; j < 3; j++) {
            int32_t fv = p->freeidx[p->Ft[3 * t + j]];
            const double *g = p->G + 9 * (size_t)t + 3 * j;
            if (fv < 0)
                continue;
            for (int c = 0; c < 3; c++)
                w->b1[(size_t)c * nfree + fv] += p->w1 * dot3(g, S + 3 * c);
        }
    }

    /* Gauss-Newton from the rest pose. */
    memcpy(w->x, p->Vt, (size_t)nv * 3 * sizeof *w->x);
    for (int32_t v = 0; v < nv; v++)
        if (p->freeidx[v] < 0 && p->used[v])
            memcpy(w->x + 3 * (size_t)v, p->fixedval + 3 * (size_t)v, 3 * sizeof(double));
    laplacian_apply(p, p->Vt, w->lx);
    for (it = 1;; it++) {
        double move = 0.0;
        memcpy(b, w->b1, (size_t)nfree * 3 * sizeof *b);
        if (p->w3 > 0.0)
            for (int64_t i = 0; i < p->prox.npairs; i++) {
                /* Directions from the previous iterate; at the start the
                 * rest directions turned by the source's gradients. */
                double t[3];
                int32_t fa = p->freeidx[p->prox.pairs[2 * i]];
                int32_t fb = p->freeidx[p->prox.pairs[2 * i + 1]];
                if (it == 1)
                    prox_target_first(p, i, w->S, t);
                else
                    prox_target(p, i, w->x, t);
                for (int c = 0; c < 3; c++) {
                    if (fa >= 0)
                        b[(size_t)c * nfree + fa] += p->w3 * t[c];
                    if (fb >= 0)
                        b[(size_t)c * nfree + fb] -= p->w3 * t[c];
                }
            }
        if (p->w4 > 0.0)
            for (int32_t r = 0; r < p->nlap; r++) {
                double t[3];
                lap_target(p, r, w->lx, t);
                for (int64_t q = p->lap_ptr[r]; q < p->lap_ptr[r + 1]; q++) {
                    int32_t fv = p->freeidx[p->lap_col[q]];
                    if (fv < 0)
                        continue;
                    for (int c = 0; c < 3; c++)
                        b[(size_t)c * nfree + fv] += p->w4 * p->lap_coef[q] * t[c];
                }
            }
        if (!cholmod_solve2(CHOLMOD_A, p->L, w->B, NULL, &w->X, NULL, &w->Y, &w->E, &w->cc)) {
            /* Out of memory for the solve's workspace: report the frame as
             * failed rather than stop the others. */
            for (int64_t i = 0; i < 3 * (int64_t)nv; i++)
                Xt[i] = NAN;
            if (residual)
                *residual = NAN;
            if (iters)
                *iters = it;
            return;
        }
        {
            const double *xs = w->X->x;
            for (int32_t v = 0; v < nv; v++) {
                int32_t fv = p->freeidx[v];
                if (fv < 0)
                    continue;
                for (int c = 0; c < 3; c++) {
                    double nx = xs[(size_t)c * nfree + fv], d = fabs(nx - w->x[3 * (size_t)v + c]);
                    move = d > move ? d : move;
                    w->x[3 * (size_t)v + c] = nx;
                }
            }
        }
        laplacian_apply(p, w->x, w->lx);
        if (!p->nonlinear || it >= p->max_iter || !(move > p->tol_abs))
            break;
    }
    if (iters)
        *iters = it;
    if (residual) {
        double e = energy(p, w->S, w->x, w->lx);
        *residual = sqrt((e > 0.0 ? e : 0.0) / (double)(p->npairs > 0 ? p->npairs : 1));
    }

    /* Vertices in no face, then the translation (as sp04). */
    if (p->nunref > 0) {
        double cref[3] = {0, 0, 0};
        for (int32_t v = 0; v < nv; v++)
            if (p->used[v])
                for (int c = 0; c < 3; c++)
                    cref[c] += w->x[3 * (size_t)v + c];
        for (int c = 0; c < 3; c++)
            cref[c] = cref[c] / (nv - p->nunref) - p->rest_centroid_ref[c];
        for (int32_t v = 0; v < nv; v++)
            if (!p->used[v])
                for (int c = 0; c < 3; c++)
                    w->x[3 * (size_t)v + c] = p->Vt[3 * (size_t)v + c] + cref[c];
    }
    if (p->npins == 0) {
        double cs[3], cx[3];
        centroid(w->x, nv, cx);
        if (p->anchor == DTX_ANCHOR_FOLLOW)
            centroid(Xs, p->nv_s, cs);
        for (int c = 0; c < 3; c++) {
            want[c] = p->rest_centroid_t[c] +
                      (p->anchor == DTX_ANCHOR_FOLLOW ? p->scale * (cs[c] - p->rest_centroid_s[c])
                                                      : 0.0);
            want[c] -= cx[c];
        }
        for (int32_t v = 0; v < nv; v++)
            for (int c = 0; c < 3; c++)
                Xt[3 * (size_t)v + c] = w->x[3 * (size_t)v + c] + want[c];
    } else {
        memcpy(Xt, w->x, (size_t)nv * 3 * sizeof *Xt);
    }
}

dtx_status dtx_mc_apply(dtx_mc_plan *p, int64_t nframes, const double *Xs, double *Xt,
                        double *residual, int32_t *iterations, dtx_error *err)
{
    dtx_status st = ensure_workers(p, err);
    if (st != DTX_OK)
        return st;
#pragma omp parallel for schedule(dynamic, 1)
    for (int64_t f = 0; f < nframes; f++) {
        int t = 0;
#ifdef _OPENMP
        t = omp_get_thread_num();
#endif
        solve_frame(p, &p->workers[t], Xs + (size_t)f * 3 * p->nv_s, Xt + (size_t)f * 3 * p->nv_t,
                    residual ? residual + f : NULL, iterations ? iterations + f : NULL);
    }
    return DTX_OK;
}
