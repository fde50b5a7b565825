/*
 * correspondence.c: Sumner & Popovic 2004, section 5.  The source mesh is
 * deformed toward the target under the user's markers, minimising
 *     w_S E_S + w_I E_I + w_C E_C
 * (E_S: adjacent triangles' transformations agree; E_I: transformations
 * stay near the identity; E_C: vertices near their closest valid point on
 * the target surface), first with w_C = 0, then with w_C raised phase by
 * phase.  Unknowns are the source vertices and one fourth vertex per
 * triangle; marker vertices are fixed at their target positions.  The three
 * coordinates share one matrix, so each phase is one numeric factorisation
 * (the symbolic analysis is done once) and one solve with 3 columns.  A
 * phase at the previous weight whose set of vertices with a valid closest
 * point is the factored one's reuses the factor; when that set changed by
 * a few vertices (the last phases, once the fit has settled), the matrix
 * differs from the factored one by those vertices' diagonal entries, and
 * the phase is solved from the old factor by a low-rank correction refined
 * to a direct solve's backward error (chol_lowrank.c; on the pebble camel
 * within 4e-13 of a fresh factorisation's answer).
 *
 * Then triangles are paired: each deformed source triangle with the nearest
 * compatible target triangle (centroids closer than a threshold, normals
 * within max_angle), and each target triangle with the nearest compatible
 * source triangle.  A target triangle with no compatible partner falls back
 * to the nearest one regardless of the threshold, so every target triangle
 * ends in at least one pair and the transfer system stays non-singular.
 *
 * All geometry is first mapped so that the target's size (dtx_rms_extent,
 * about its bounding-box diagonal, but unchanged by rotations) is 1 (and, by
 * default, the source is aligned on the markers by a similarity transform),
 * which makes the weights and thresholds invariant to scale and rotation.
 */
#include "cholmod_util.h"
#include "correspondence_internal.h"
#include "dtx_core.h"
#include "vec3.h"

#include <cholmod.h>
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#define DTX_PI 3.14159265358979323846

/* A phase whose matrix differs from the factored one by at most
 * prm->lowrank_max diagonal entries (vertices that gained or lost their
 * closest point at the same weight; LOWRANK_MAX_K by default) is solved from
 * the old factor by a low-rank correction (cholmod_util.h) instead of
 * refactorising; it must reach a direct solve's backward error within
 * LOWRANK_STEPS refinement steps, or the phase refactorises after all. */
#define LOWRANK_MAX_K 200
#define LOWRANK_MAX_K_LIMIT 100000
#define LOWRANK_STEPS 3
#define LOWRANK_TOL 1e-15

void dtx_corr_params_default(dtx_corr_params *p)
{
    memset(p, 0, sizeof *p);
    /* The paper uses w_I = 0.001 and raises w_C from 1 to 5000 in four
     * steps.  With the shared cat/lion markers a stiffer identity term and
     * a few more phases at the final weight fit the paper's own results
     * better (mean RMS 0.86% of the diagonal instead of 0.99%; see the
     * README), so those are the defaults; the paper's values remain one job
     * setting away. */
    p->w_smooth = 1.0;
    p->w_identity = 0.3;
    p->n_closest = 6;
    p->w_closest[0] = 1.0;
    p->w_closest[1] = 100.0;
    p->w_closest[2] = 5000.0;
    p->w_closest[3] = 5000.0;
    p->w_closest[4] = 5000.0;
    p->w_closest[5] = 5000.0;
    p->max_distance = 0.1;
    p->max_angle_deg = 90.0;
    p->align = 1;
    p->closest_on = DTX_CORR_ON_SURFACE;
    p->closest_normals = 1;
    p->weights = DTX_CORR_WEIGHTS_AREA;
    p->lowrank_max = LOWRANK_MAX_K;
}

void dtx_corr_free(dtx_corr *c)
{
    if (!c)
        return;
    free(c->pairs);
    free(c->deformed_src);
    free(c->deformed_tgt);
    memset(c, 0, sizeof *c);
}

/* ------------------------------------------------------------------ */
/* Assembly of the quadratic energy over the free unknowns             */
/* ------------------------------------------------------------------ */

/* One term of the energy is w * sum_c || sum_p x_{var_p, c} a_p - t_c ||^2
 * with 3-vector coefficients a_p and 3-vector targets t_c (c = x, y, z). */
typedef struct {
    int32_t n;          /* number of unknowns the term touches */
    int32_t var[8];
    double coef[8][3];
} term;

typedef struct {
    int32_t nvar;        /* all unknowns (vertices + fourth vertices) */
    int32_t nfree;
    const int32_t *freeidx; /* nvar: index among free unknowns or -1 (fixed) */
    const double *fixed;    /* nvar x 3: values of fixed unknowns */
    cholmod_triplet *T;     /* lower triangle of the free-free matrix */
    double *rhs;            /* nfree x 3, column-major (one column per coordinate) */
} assembler;

/* Adds a coefficient to the term, merging repeated unknowns. */
static void term_add(term *t, int32_t var, const double *a, double sign)
{
    for (int32_t i = 0; i < t->n; i++)
        if (t->var[i] == var) {
            for (int k = 0; k < 3; k++)
                t->coef[i][k] += sign * a[k];
            return;
        }
    t->var[t->n] = var;
    for (int k = 0; k < 3; k++)
        t->coef[t->n][k] = sign * a[k];
    t->n++;
}

/* target: 3 x 3 (row c = t_c) or NULL for zero targets. */
static void assemble_term(assembler *as, const term *t, const double *target, double w)
{
    int32_t *ti = as->T->i, *tj = as->T->j;
    double *tx = as->T->x;
    for (int32_t p = 0; p < t->n; p++) {
        int32_t fp = as->freeidx[t->var[p]];
        if (fp < 0)
            continue;
        for (int32_t q = 0; q < t->n; q++) {
            int32_t fq = as->freeidx[t->var[q]];
            if (fq < 0 || fq > fp)
                continue;
            {
                size_t k = as->T->nnz++;
                ti[k] = fp;
                tj[k] = fq;
                tx[k] = w * (t->coef[p][0] * t->coef[q][0] + t->coef[p][1] * t->coef[q][1] +
                             t->coef[p][2] * t->coef[q][2]);
            }
        }
        for (int c = 0; c < 3; c++) {
            /* r_c = t_c - sum over fixed q of a_q x_{q,c}; rhs_p += w a_p . r_c */
            double r[3] = {0, 0, 0};
            if (target)
                for (int k = 0; k < 3; k++)
                    r[k] = target[3 * c + k];
            for (int32_t q = 0; q < t->n; q++)
                if (as->freeidx[t->var[q]] < 0)
                    for (int k = 0; k < 3; k++)
                        r[k] -= t->coef[q][k] * as->fixed[3 * (size_t)t->var[q] + c];
            as->rhs[(size_t)c * as->nfree + fp] +=
                w * (t->coef[p][0] * r[0] + t->coef[p][1] * r[1] + t->coef[p][2] * r[2]);
        }
    }
}

/* The four (unknown, coefficient) pairs of triangle f's transformation:
 * T_f[c, :] = sum_j x_{var_j, c} g_j (rows of Vinv, see dtx_frame_inverses). */
static void triangle_term(const int32_t *F, int32_t nv, int32_t f, const double *Vinv, term *t,
                          double sign)
{
    const double *r = Vinv + 9 * f;
    double g0[3] = {-(r[0] + r[3] + r[6]), -(r[1] + r[4] + r[7]), -(r[2] + r[5] + r[8])};
    term_add(t, F[3 * f], g0, sign);
    term_add(t, F[3 * f + 1], r, sign);
    term_add(t, F[3 * f + 2], r + 3, sign);
    term_add(t, nv + f, r + 6, sign);
}

/* The same for a tetrahedron: T[c, :] = sum_k (x_{var_k+1, c} - x_{var_0, c})
 * inv[k, :]. */
static void tet_term(const dtx__tet *q, term *t, double sign)
{
    const double *r = q->inv;
    double g0[3] = {-(r[0] + r[3] + r[6]), -(r[1] + r[4] + r[7]), -(r[2] + r[5] + r[8])};
    term_add(t, q->var[0], g0, sign);
    term_add(t, q->var[1], r, sign);
    term_add(t, q->var[2], r + 3, sign);
    term_add(t, q->var[3], r + 6, sign);
}

/* What cholmod_triplet_to_sparse(T, T->nnz) makes of T (square, stype
 * -1, every entry in the lower triangle), on two threads: the entries of
 * each column, rows sorted, duplicates summed in T's order (the first one's
 * value, then each later one added), so the same matrix bit for bit.  The
 * triplets are put in column buckets in their order (two halves counted
 * apart, the first half's entries first), then each column is summed and
 * sorted on its own.  NULL when out of memory. */
static cholmod_sparse *lower_triplet_to_csc(const cholmod_triplet *T, cholmod_common *cc)
{
    const int32_t n = (int32_t)T->ncol, *Ti = T->i, *Tj = T->j;
    const double *Tx = T->x;
    const int64_t nz = (int64_t)T->nnz, half = nz / 2;
    int64_t *start = dtx_alloc((size_t)n + 1, 2 * sizeof *start, 1);
    int32_t *bi = dtx_alloc((size_t)nz + 1, sizeof *bi, 0), *cnt = NULL;
    double *bx = dtx_alloc((size_t)nz + 1, sizeof *bx, 0);
    cholmod_sparse *A = NULL;
    int32_t *Ap, *Ai;
    double *Ax;
    int failed = 0;

    if (!start || !bi || !bx)
        goto done;
    /* start[2 j + h]: where half h's entries of column j begin. */
    for (int64_t k = 0; k < nz; k++)
        start[2 * (size_t)Tj[k] + (k >= half) + 1]++;
    for (size_t q = 1; q < 2 * (size_t)n + 2; q++)
        start[q] += start[q - 1];
#pragma omp parallel for schedule(static)
    for (int h = 0; h < 2; h++)
        for (int64_t k = h ? half : 0; k < (h ? nz : half); k++) {
            int64_t p = start[2 * (size_t)Tj[k] + h]++;
            bi[p] = Ti[k];
            bx[p] = Tx[k];
        }
    /* Now start[2 j + 1] is the end of column j (and start[2 j - 1] its
     * beginning).  Sum duplicates and sort each column where it lies. */
    cnt = dtx_alloc((size_t)n + 1, sizeof *cnt, 1);
    if (!cnt)
        goto done;
#pragma omp parallel
    {
        int32_t *slot = dtx_alloc((size_t)n, sizeof *slot, 0);
        if (!slot) {
#pragma omp atomic write
            failed = 1;
        } else {
            for (int32_t i = 0; i < n; i++)
                slot[i] = -1;
#pragma omp for schedule(dynamic, 1024)
            for (int32_t j = 0; j < n; j++) {
                const int64_t p0 = j ? start[2 * (size_t)j - 1] : 0, p1 = start[2 * (size_t)j + 1];
                int64_t w = p0;
                for (int64_t p = p0; p < p1; p++) {
                    const int32_t i = bi[p];
                    if (slot[i] >= 0) {
                        bx[p0 + slot[i]] += bx[p];
                    } else {
                        slot[i] = (int32_t)(w - p0);
                        bi[w] = i;
                        bx[w] = bx[p];
                        w++;
                    }
                }
                for (int64_t p = p0; p < w; p++)
                    slot[bi[p]] = -1;
                /* Insertion sort by row: columns hold a few dozen entries. */
                for (int64_t p = p0 + 1; p < w; p++) {
                    const int32_t i = bi[p];
                    const double x = bx[p];
                    int64_t q = p;
                    for (; q > p0 && bi[q - 1] > i; q--) {
                        bi[q] = bi[q - 1];
                        bx[q] = bx[q - 1];
                    }
                    bi[q] = i;
                    bx[q] = x;
                }
                cnt[j + 1] = (int32_t)(w - p0);
            }
            free(slot);
        }
    }
    if (failed)
        goto done;
    for (int32_t j = 0; j < n; j++)
        cnt[j + 1] += cnt[j];
    A = cholmod_allocate_sparse((size_t)n, (size_t)n, (size_t)cnt[n], 1, 1, -1, CHOLMOD_REAL, cc);
    if (!A)
        goto done;
    Ap = A->p;
    Ai = A->i;
    Ax = A->x;
    memcpy(Ap, cnt, ((size_t)n + 1) * sizeof *Ap);
#pragma omp parallel for schedule(static)
    for (int32_t j = 0; j < n; j++) {
        const int64_t p0 = j ? start[2 * (size_t)j - 1] : 0;
        memcpy(Ai + Ap[j], bi + p0, (size_t)(Ap[j + 1] - Ap[j]) * sizeof *Ai);
        memcpy(Ax + Ap[j], bx + p0, (size_t)(Ap[j + 1] - Ap[j]) * sizeof *Ax);
    }
done:
    free(start);
    free(bi);
    free(bx);
    free(cnt);
    return A;
}

/* ------------------------------------------------------------------ */
/* Triangle adjacency                                                  */
/* ------------------------------------------------------------------ */

typedef struct {
    int32_t a, b, f;
} edge_rec;

static int cmp_edge(const void *x, const void *y)
{
    const edge_rec *p = x, *q = y;
    if (p->a != q->a)
        return p->a < q->a ? -1 : 1;
    if (p->b != q->b)
        return p->b < q->b ? -1 : 1;
    return (p->f > q->f) - (p->f < q->f);
}

/* Pairs of faces sharing an edge (for a non-manifold edge, every pair of its
 * faces).  Returns the count, the pairs in *out (2 per pair, allocated), or
 * -1 on allocation failure. */
static int64_t face_adjacency(const int32_t *F, int32_t nf, int32_t **out)
{
    edge_rec *e = dtx_alloc((size_t)nf * 3, sizeof *e, 0);
    int32_t *pairs = NULL;
    int64_t n = 0, cap = 0;
    if (!e)
        return -1;
    for (int32_t f = 0; f < nf; f++)
        for (int k = 0; k < 3; k++) {
            int32_t a = F[3 * f + k], b = F[3 * f + (k + 1) % 3];
            edge_rec *r = &e[3 * (size_t)f + k];
            r->a = a < b ? a : b;
            r->b = a < b ? b : a;
            r->f = f;
        }
    qsort(e, (size_t)nf * 3, sizeof *e, cmp_edge);
    for (int64_t i = 0; i < 3 * (int64_t)nf;) {
        int64_t j = i + 1;
        while (j < 3 * (int64_t)nf && e[j].a == e[i].a && e[j].b == e[i].b)
            j++;
        for (int64_t p = i; p < j; p++)
            for (int64_t q = p + 1; q < j; q++) {
                if (e[p].f == e[q].f)
                    continue;
                if (n == cap) {
                    int64_t ncap = cap ? 2 * cap : 4 * (int64_t)nf + 16;
                    int32_t *np = realloc(pairs, (size_t)ncap * 2 * sizeof *pairs);
                    if (!np) {
                        free(pairs);
                        free(e);
                        return -1;
                    }
                    pairs = np;
                    cap = ncap;
                }
                pairs[2 * n] = e[p].f;
                pairs[2 * n + 1] = e[q].f;
                n++;
            }
        i = j;
    }
    free(e);
    *out = pairs;
    return n;
}

/* ------------------------------------------------------------------ */
/* Closest valid points                                                */
/* ------------------------------------------------------------------ */

typedef struct {
    const double *tnormals; /* target face normals */
    const double *n;        /* query normal */
    double cosmax;
} normal_filter_ctx;

static int normal_filter(const void *ctx, int32_t prim)
{
    const normal_filter_ctx *c = ctx;
    const double *m = c->tnormals + 3 * prim;
    return m[0] * c->n[0] + m[1] * c->n[1] + m[2] * c->n[2] > c->cosmax;
}

int32_t dtx__closest_valid(const dtx_bvh *tbvh, const double *tnormals, const double p[3],
                           const double n[3], double cosmax, double max_dist, int normal_rule,
                           int32_t hint, double cp[3])
{
    normal_filter_ctx ctx;
    ctx.tnormals = tnormals;
    ctx.n = n;
    ctx.cosmax = cosmax;
    /* The filter runs inside the search, so a rejected primitive never
     * hides a farther valid one: the answer is the closest valid point,
     * not the closest point if valid. */
    return dtx_bvh_closest_from(tbvh, p, max_dist, normal_rule ? normal_filter : NULL, &ctx,
                                hint, cp, NULL);
}

/* ------------------------------------------------------------------ */
/* Per-area weights                                                    */
/* ------------------------------------------------------------------ */

/* The paper writes E_I as a sum over triangles and E_C as a sum over
 * vertices, so refining a mesh (4x the elements) makes both 4x heavier
 * against E_S, whose adjacent-transformation differences shrink with the
 * edge length as the pairs multiply (a sum of squared differences over
 * neighbours approximates an integral of the squared gradient of T whatever
 * the spacing): the same weights mean a stiffer identity and a stronger
 * pull at a finer resolution, and on a mesh of uneven density they favour
 * its dense parts.  Weighing each triangle's E_I term by its area and each
 * vertex's E_C term by its area (a third of its triangles') turns both sums
 * into integrals over the surface, which do not depend on the resolution;
 * times DTX_CORR_REF_DENSITY (in the normalised frame, the target's size
 * 1), the weights keep the meaning the paper gave them on meshes of that
 * density.  wtri (nf) and wvert (nv) get the factors; areas are the rest
 * source's S0 (in the normalised frame). */
static void area_weights(const double *S0, const int32_t *F, int32_t nv, int32_t nf,
                         double *wtri, double *wvert)
{
    const double rho_v = DTX_CORR_REF_DENSITY;
    /* A closed triangle mesh has about twice as many triangles as vertices,
     * so at the reference density a triangle's mean area is 1 / (2 rho_v)
     * and a vertex's 1 / rho_v. */
    for (int32_t v = 0; v < nv; v++)
        wvert[v] = 0.0;
    for (int32_t f = 0; f < nf; f++) {
        const double area = tri_area3(S0 + 3 * (size_t)F[3 * f], S0 + 3 * (size_t)F[3 * f + 1],
                                      S0 + 3 * (size_t)F[3 * f + 2]);
        wtri[f] = area * 2.0 * rho_v;
        for (int k = 0; k < 3; k++)
            wvert[F[3 * f + k]] += area / 3.0 * rho_v;
    }
}

/* ------------------------------------------------------------------ */
/* The deformation phases                                              */
/* ------------------------------------------------------------------ */

/* Emits the terms of E_R's tetrahedron pairs (dtx__tet, see the header). */
static void assemble_tets(assembler *as, const dtx__tet *tets, int64_t ntetpairs,
                          const dtx_corr_params *prm)
{
    static const double I3[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    for (int64_t p = 0; p < ntetpairs; p++) {
        term ta, tb, td;
        ta.n = tb.n = td.n = 0;
        tet_term(&tets[2 * p], &ta, 1.0);
        tet_term(&tets[2 * p + 1], &tb, 1.0);
        tet_term(&tets[2 * p], &td, 1.0);
        tet_term(&tets[2 * p + 1], &td, -1.0);
        assemble_term(as, &td, NULL, prm->w_smooth);
        assemble_term(as, &ta, I3, prm->w_identity);
        assemble_term(as, &tb, I3, prm->w_identity);
    }
}

/* What the phases share that does not depend on E_R: the closest-point
 * queries' order, the weights, the unknowns, the rest inverses, and E_S
 * and E_I assembled as triplets with their right-hand side. */
typedef struct {
    int32_t *qorder, *freeidx, *adj;
    double *fixed, *Vinv, *wtri, *wvert, *rhs;
    int64_t nadj;
    int32_t nfree;
    cholmod_triplet *T;
} base_terms;

static void base_terms_free(base_terms *b, cholmod_common *cc)
{
    cholmod_free_triplet(&b->T, cc);
    free(b->qorder);
    free(b->freeidx);
    free(b->adj);
    free(b->fixed);
    free(b->Vinv);
    free(b->wtri);
    free(b->wvert);
    free(b->rhs);
    memset(b, 0, sizeof *b);
}

/* Fills b (zeroed by the caller; freed by the caller with base_terms_free
 * whatever the outcome).  T has room for extra more entries. */
static dtx_status base_terms_build(const int32_t *F, int32_t nv, int32_t nf, const double *S0,
                                   const int32_t *fixv, const double *fixpos, int32_t nfix,
                                   const dtx_corr_params *prm, base_terms *b, cholmod_common *cc,
                                   dtx_error *err)
{
    const int32_t nvar = nv + nf;
    int32_t *freeidx, nfree = 0;
    double *fixed, *Vinv, *wtri = NULL, eps_area;

    b->freeidx = freeidx = dtx_alloc((size_t)nvar, sizeof *freeidx, 0);
    b->fixed = fixed = dtx_alloc((size_t)nvar, 3 * sizeof *fixed, 1);
    b->Vinv = Vinv = dtx_alloc((size_t)nf, 9 * sizeof *Vinv, 0);
    b->qorder = dtx_alloc((size_t)nv, sizeof *b->qorder, 0);
    if (!freeidx || !fixed || !Vinv || !b->qorder)
        goto nomem;
    /* The closest-point queries go in the leaf order of a tree over the
     * rest source: nearby vertices one after the other, so consecutive
     * searches walk the same parts of the target's tree (the mesh's own
     * numbering need not be spatial at all: a subdivided mesh numbers its
     * edge midpoints after every old vertex). */
    {
        dtx_bvh *sb = dtx_bvh_build(S0, NULL, nv);
        if (!sb)
            goto nomem;
        memcpy(b->qorder, dtx_bvh_leaf_order(sb), (size_t)nv * sizeof *b->qorder);
        dtx_bvh_free(&sb);
    }
    if (prm->weights == DTX_CORR_WEIGHTS_AREA) {
        b->wtri = wtri = dtx_alloc((size_t)nf, sizeof *wtri, 0);
        b->wvert = dtx_alloc((size_t)nv, sizeof *b->wvert, 0);
        if (!wtri || !b->wvert)
            goto nomem;
        area_weights(S0, F, nv, nf, wtri, b->wvert);
    }

    /* Unknowns: markers are fixed at their target positions, and vertices
     * in no triangle (no term reaches them) stay where they are. */
    for (int32_t v = 0; v < nvar; v++)
        freeidx[v] = v < nv ? -1 : 0;
    for (int64_t i = 0; i < 3 * (int64_t)nf; i++)
        freeidx[F[i]] = 0;
    for (int32_t v = 0; v < nv; v++)
        if (freeidx[v] < 0)
            memcpy(fixed + 3 * (size_t)v, S0 + 3 * (size_t)v, 3 * sizeof(double));
    for (int32_t m = 0; m < nfix; m++) {
        freeidx[fixv[m]] = -1;
        memcpy(fixed + 3 * (size_t)fixv[m], fixpos + 3 * (size_t)m, 3 * sizeof(double));
    }
    /* The fourth vertex of a zero-area triangle has no normal to stand on:
     * its column of the system is zero up to rounding, and the
     * factorisation would fail or not depending on that rounding.  Nothing
     * else depends on it (its face's regularised inverse ignores the normal
     * direction), so it stays at its rest position.  (A needle keeps it: its
     * normal, though short, still carries the regularised gradient.) */
    eps_area = 1e-14; /* geometry is normalised to a unit target size */
    for (int32_t f = 0; f < nf; f++) {
        if (!(tri_area3(S0 + 3 * (size_t)F[3 * f], S0 + 3 * (size_t)F[3 * f + 1],
                        S0 + 3 * (size_t)F[3 * f + 2]) > eps_area) &&
            freeidx[nv + f] == 0) {
            freeidx[nv + f] = -1;
            memcpy(fixed + 3 * (size_t)(nv + f), S0 + 3 * (size_t)F[3 * f], 3 * sizeof(double));
        }
    }
    for (int32_t v = 0; v < nvar; v++)
        if (freeidx[v] == 0)
            freeidx[v] = nfree++;
    b->nfree = nfree;

    dtx_frame_inverses(S0, F, nf, eps_area, Vinv);
    b->nadj = face_adjacency(F, nf, &b->adj);
    if (b->nadj < 0)
        goto nomem;

    /* Base matrix (E_S + E_I) and its right-hand side. */
    {
        size_t maxnz = (size_t)b->nadj * 36 + (size_t)nf * 10 + (size_t)nfree;
        assembler as;
        b->T = cholmod_allocate_triplet((size_t)nfree, (size_t)nfree, maxnz, -1, CHOLMOD_REAL, cc);
        b->rhs = dtx_alloc((size_t)nfree, 3 * sizeof *b->rhs, 1);
        if (!b->T || !b->rhs)
            goto nomem;
        as.nvar = nvar;
        as.nfree = nfree;
        as.freeidx = freeidx;
        as.fixed = fixed;
        as.T = b->T;
        as.rhs = b->rhs;
        for (int64_t p = 0; p < b->nadj; p++) {
            term t;
            t.n = 0;
            triangle_term(F, nv, b->adj[2 * p], Vinv, &t, 1.0);
            triangle_term(F, nv, b->adj[2 * p + 1], Vinv, &t, -1.0);
            assemble_term(&as, &t, NULL, prm->w_smooth);
        }
        for (int32_t f = 0; f < nf; f++) {
            static const double I3[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
            term t;
            t.n = 0;
            triangle_term(F, nv, f, Vinv, &t, 1.0);
            assemble_term(&as, &t, I3, prm->w_identity * (wtri ? wtri[f] : 1.0));
        }
    }
    return DTX_OK;
nomem:
    return dtx_seterr(err, DTX_ENOMEM, "out of memory in the correspondence phase");
}

/* dtx__deform_mesh, and when closest_out (nv) is not NULL, each vertex's
 * last closest valid primitive of tbvh (-1: none in any phase). */
static dtx_status deform_mesh(const int32_t *F, int32_t nv, int32_t nf, const double *S0,
                              const int32_t *fixv, const double *fixpos, int32_t nfix,
                              dtx__tet_maker make_tets, void *tets_ctx, const dtx_bvh *tbvh,
                              const double *tnormals, const dtx_corr_params *prm, double *X,
                              unsigned char *valid_out, int32_t *closest_out, int *solves,
                              int *factorizations, dtx_error *err)
{
    const double cosmax = cos(prm->max_angle_deg * DTX_PI / 180.0);
    dtx_status st = DTX_OK, st_tets = DTX_OK;
    cholmod_common cc;
    cholmod_triplet *T = NULL;
    cholmod_sparse *K = NULL;
    cholmod_factor *L = NULL;
    cholmod_dense *B = NULL, *Xs = NULL, *Ys = NULL, *Es = NULL;
    dtx__chol_refactor R = {NULL, NULL};
    dtx__chol_lowrank lr;
    base_terms base;
    const dtx__tet *tets = NULL;
    int64_t ntetpairs = 0;
    int32_t *freeidx, *diagpos = NULL, *hit = NULL, *qorder, *lr_idx = NULL;
    double *fixed, *rhs_base, *kx_base = NULL, *vn = NULL, *cp = NULL, *wvert;
    double *diag_fact = NULL, *lr_c = NULL;
    unsigned char *valid = NULL, *valid_prev = NULL;
    double wc_prev = -1.0;
    int32_t nfree;
    char system[64];
    dtx_error err_tets;

    memset(&base, 0, sizeof base);
    memset(&lr, 0, sizeof lr);
    memset(&err_tets, 0, sizeof err_tets);
    dtx__chol_start(&cc, DTX__CHOL_AUTO, DTX__CHOL_ORDER_DEFAULT);
    /* E_R's terms are made on a second thread while E_S and E_I are
     * assembled: they only join the matrix after them, in the same order
     * whoever made them. */
#pragma omp parallel sections if (make_tets != NULL)
    {
#pragma omp section
        if (make_tets)
            st_tets = make_tets(tets_ctx, &tets, &ntetpairs, &err_tets);
#pragma omp section
        st = base_terms_build(F, nv, nf, S0, fixv, fixpos, nfix, prm, &base, &cc, err);
    }
    if (st == DTX_OK && st_tets != DTX_OK) {
        if (err)
            *err = err_tets;
        st = st_tets;
    }
    if (st != DTX_OK)
        goto fail;
    freeidx = base.freeidx;
    fixed = base.fixed;
    qorder = base.qorder;
    wvert = base.wvert;
    rhs_base = base.rhs;
    nfree = base.nfree;
    T = base.T;
    base.T = NULL;

    vn = dtx_alloc((size_t)nv, 3 * sizeof *vn, 0);
    cp = dtx_alloc((size_t)nv, 3 * sizeof *cp, 0);
    valid = dtx_alloc((size_t)nv, 1, 1);
    valid_prev = dtx_alloc((size_t)nv, 1, 1);
    hit = dtx_alloc((size_t)nv, sizeof *hit, 0);
    if (!vn || !cp || !valid || !valid_prev || !hit)
        goto nomem;
    for (int32_t v = 0; v < nv; v++)
        hit[v] = -1;

    /* E_R, then the closest-point diagonal, after E_S and E_I. */
    {
        assembler as;
        if (!cholmod_reallocate_triplet(T->nnz + (size_t)ntetpairs * 3 * 36 + (size_t)nfree, T,
                                        &cc))
            goto nomem;
        as.nvar = nv + nf;
        as.nfree = nfree;
        as.freeidx = freeidx;
        as.fixed = fixed;
        as.T = T;
        as.rhs = rhs_base;
        assemble_tets(&as, tets, ntetpairs, prm);
        /* Explicit zero diagonal entries for vertex unknowns, so the pattern
         * already holds the closest-point term's diagonal. */
        for (int32_t v = 0; v < nv; v++)
            if (freeidx[v] >= 0) {
                size_t k = T->nnz++;
                ((int32_t *)T->i)[k] = freeidx[v];
                ((int32_t *)T->j)[k] = freeidx[v];
                ((double *)T->x)[k] = 0.0;
            }
        K = lower_triplet_to_csc(T, &cc);
        cholmod_free_triplet(&T, &cc);
        if (!K)
            goto nomem;
    }
    /* Remember the base values and where each column's diagonal sits (the
     * first entry of a sorted lower-triangular column). */
    {
        int32_t *Kp = K->p, *Ki = K->i;
        kx_base = dtx_alloc((size_t)Kp[nfree], sizeof *kx_base, 0);
        diagpos = dtx_alloc((size_t)nfree, sizeof *diagpos, 0);
        diag_fact = dtx_alloc((size_t)nfree, sizeof *diag_fact, 0);
        lr_idx = dtx_alloc((size_t)prm->lowrank_max + 1, sizeof *lr_idx, 0);
        lr_c = dtx_alloc((size_t)prm->lowrank_max + 1, sizeof *lr_c, 0);
        if (!kx_base || !diagpos || !diag_fact || !lr_idx || !lr_c)
            goto nomem;
        memcpy(kx_base, K->x, (size_t)Kp[nfree] * sizeof *kx_base);
        for (int32_t j = 0; j < nfree; j++) {
            if (Kp[j] >= Kp[j + 1] || Ki[Kp[j]] != j) {
                st = dtx_seterr(err, DTX_ESOLVE, "correspondence matrix lacks a diagonal entry");
                goto fail;
            }
            diagpos[j] = Kp[j];
        }
    }
    st = dtx__chol_analyze(K, "the correspondence system", &L, &cc, err);
    if (st != DTX_OK)
        goto fail;
    /* A supernodal factor's values are allocated here as its first
     * factorisation would allocate them (which then reuses them: it clears
     * each supernode before filling it, so the bits are the same), and
     * paged in by a second thread while this one prepares the
     * refactorisations, instead of by the first factorisation. */
    if (L->is_super && !cholmod_change_factor(CHOLMOD_REAL, 1, 1, 1, 1, L, &cc))
        goto nomem;
#pragma omp parallel sections
    {
#pragma omp section
        st = dtx__chol_refactor_start(K, L, &R, &cc, err);
#pragma omp section
        if (L->is_super)
            memset(L->x, 0, L->xsize * sizeof(double));
    }
    if (st != DTX_OK)
        goto fail;
    B = cholmod_zeros((size_t)nfree, 3, CHOLMOD_REAL, &cc);
    if (!B)
        goto nomem;

    for (int phase = 0; phase <= prm->n_closest; phase++) {
        double wc = phase == 0 ? 0.0 : prm->w_closest[phase - 1];
        double *Bx = B->x, *Kx = K->x;
        memcpy(Kx, kx_base, (size_t)((int32_t *)K->p)[nfree] * sizeof *Kx);
        memcpy(Bx, rhs_base, (size_t)nfree * 3 * sizeof *Bx);
        if (wc > 0.0) {
            /* Closest valid points of the current deformed source. */
            dtx_vertex_normals(X, nv, F, nf, vn);
            /* Each query writes its own vertex's entries only, so the
             * schedule (dynamic: the searches' costs vary) leaves no trace
             * in the results. */
#pragma omp parallel for schedule(dynamic, 256)
            for (int32_t i = 0; i < nv; i++) {
                const int32_t v = qorder[i];
                int32_t t;
                valid[v] = 0;
                if (freeidx[v] < 0)
                    continue;
                /* The previous phase's closest triangle is the search's
                 * first bound: the same answer, found sooner. */
                t = dtx__closest_valid(tbvh, tnormals, X + 3 * (size_t)v, vn + 3 * (size_t)v,
                                       cosmax, prm->max_distance, prm->closest_normals, hit[v],
                                       cp + 3 * (size_t)v);
                if (t >= 0) {
                    valid[v] = 1;
                    hit[v] = t;
                }
            }
            for (int32_t v = 0; v < nv; v++) {
                int32_t fv = freeidx[v];
                double w = wvert ? wc * wvert[v] : wc;
                if (!valid[v])
                    continue;
                Kx[diagpos[fv]] += w;
                for (int c = 0; c < 3; c++)
                    Bx[(size_t)c * nfree + fv] += w * cp[3 * (size_t)v + c];
            }
        }
        /* The matrix is the base plus wc on the diagonal of the vertices
         * with a valid closest point: when the weight and that set are those
         * of the factored matrix, so is the matrix, bit for bit, and so its
         * factor (the later phases at the final weight once the fit has
         * settled).  When only a few vertices gained or lost their closest
         * point, the factor still serves: the matrix differs from the
         * factored one by those vertices' diagonal entries, a low-rank
         * change (the changed matrix is positive definite like every
         * phase's: phase 0's, factored, plus a nonnegative diagonal). */
        {
            int refactor = phase == 0 || wc != wc_prev, lowrank = 0;
            int32_t k = 0;
            for (int32_t v = 0; v < nv && !refactor; v++)
                if (valid[v] != valid_prev[v]) {
                    int32_t fv = freeidx[v];
                    double c = Kx[diagpos[fv]] - diag_fact[fv];
                    if (c == 0.0)
                        continue;
                    if (k == prm->lowrank_max)
                        refactor = 1;
                    else {
                        lr_idx[k] = fv;
                        lr_c[k++] = c;
                    }
                }
            if (!refactor && k > 0) {
                int steps;
                dtx_status lst = dtx__chol_lowrank_set(L, k, lr_idx, lr_c, &lr, &cc, NULL);
                if (lst == DTX_OK)
                    lst = dtx__chol_lowrank_solve(&lr, L, K, B, LOWRANK_STEPS, LOWRANK_TOL, &Xs,
                                                  &steps, &cc, NULL);
                dtx__chol_lowrank_free(&lr, &cc);
                if (lst == DTX_ENOMEM)
                    goto nomem;
                lowrank = lst == DTX_OK;
                refactor = !lowrank;
            }
            if (refactor) {
                snprintf(system, sizeof system, "the correspondence system of phase %d", phase);
                st = dtx__chol_factorize_again(K, &R, DTX__CHOL_NO_TEAMS, system,
                                               "; are the markers spread over the whole mesh?",
                                               L, &cc, err);
                if (st != DTX_OK)
                    goto fail;
                (*factorizations)++;
                wc_prev = wc;
                memcpy(valid_prev, valid, (size_t)nv);
                for (int32_t j = 0; j < nfree; j++)
                    diag_fact[j] = Kx[diagpos[j]];
            }
            if (!lowrank) {
                if (!cholmod_solve2(CHOLMOD_A, L, B, NULL, &Xs, NULL, &Ys, &Es, &cc))
                    goto nomem;
            }
        }
        (*solves)++;
        if (valid_out)
            memcpy(valid_out, valid, (size_t)nv);
        for (int32_t v = 0; v < nv; v++)
            for (int c = 0; c < 3; c++)
                X[3 * (size_t)v + c] = freeidx[v] >= 0
                                           ? ((double *)Xs->x)[(size_t)c * nfree + freeidx[v]]
                                           : fixed[3 * (size_t)v + c];
    }
    if (closest_out)
        memcpy(closest_out, hit, (size_t)nv * sizeof *hit);
    goto fail; /* success: shared cleanup */

nomem:
    st = dtx_seterr(err, DTX_ENOMEM, "out of memory in the correspondence phase");
fail:
    dtx__chol_lowrank_free(&lr, &cc);
    cholmod_free_dense(&Xs, &cc);
    cholmod_free_dense(&Ys, &cc);
    cholmod_free_dense(&Es, &cc);
    cholmod_free_dense(&B, &cc);
    dtx__chol_refactor_free(&R, &cc);
    cholmod_free_factor(&L, &cc);
    cholmod_free_sparse(&K, &cc);
    cholmod_free_triplet(&T, &cc);
    base_terms_free(&base, &cc);
    cholmod_finish(&cc);
    free(vn);
    free(cp);
    free(valid);
    free(valid_prev);
    free(hit);
    free(kx_base);
    free(diagpos);
    free(diag_fact);
    free(lr_idx);
    free(lr_c);
    return st;
}

dtx_status dtx__deform_mesh(const int32_t *F, int32_t nv, int32_t nf, const double *S0,
                            const int32_t *fixv, const double *fixpos, int32_t nfix,
                            dtx__tet_maker make_tets, void *tets_ctx, const dtx_bvh *tbvh,
                            const double *tnormals, const dtx_corr_params *prm, double *X,
                            unsigned char *valid_out, int32_t *closest_out, int *solves,
                            int *factorizations, dtx_error *err)
{
    return deform_mesh(F, nv, nf, S0, fixv, fixpos, nfix, make_tets, tets_ctx, tbvh, tnormals, prm,
                       X, valid_out, closest_out, solves, factorizations, err);
}

/* ------------------------------------------------------------------ */
/* Triangle pairing                                                    */
/* ------------------------------------------------------------------ */

typedef struct {
    const double *normals; /* normals of the indexed triangles */
    const double *n;       /* query normal */
    double cosmax;
    const unsigned char *usable; /* may be NULL */
} pair_filter_ctx;

static int pair_filter(const void *ctx, int32_t prim)
{
    const pair_filter_ctx *c = ctx;
    const double *m = c->normals + 3 * prim;
    if (c->usable && !c->usable[prim])
        return 0;
    return m[0] * c->n[0] + m[1] * c->n[1] + m[2] * c->n[2] > c->cosmax;
}

static int usable_filter(const void *ctx, int32_t prim)
{
    const pair_filter_ctx *c = ctx;
    return !c->usable || c->usable[prim];
}

static void centroids(const double *X, const int32_t *F, int32_t nf, double *C)
{
    for (int32_t f = 0; f < nf; f++)
        for (int k = 0; k < 3; k++)
            C[3 * f + k] =
                (X[3 * F[3 * f] + k] + X[3 * F[3 * f + 1] + k] + X[3 * F[3 * f + 2] + k]) / 3.0;
}

static int cmp_pair(const void *x, const void *y)
{
    const int32_t *p = x, *q = y;
    if (p[1] != q[1])
        return p[1] < q[1] ? -1 : 1;
    return (p[0] > q[0]) - (p[0] < q[0]);
}

/* vhint (src->nv, may be NULL): a target triangle near each deformed
 * source vertex (the last closest points), or -1; only a starting bound for
 * the searches, which give the same pairs with or without it. */
static dtx_status pair_triangles(const dtx_mesh *src, const double *X, const dtx_mesh *tgt,
                                 const double *Tn, const int32_t *vhint,
                                 const dtx_corr_params *prm, dtx_corr *out, dtx_error *err)
{
    const int32_t nfs = src->nf, nft = tgt->nf;
    const double cosmax = cos(prm->max_angle_deg * DTX_PI / 180.0);
    double *cs = NULL, *ct = NULL, *ns = NULL, *nt = NULL;
    int32_t *bys = NULL, *byt = NULL, *pairs = NULL, *thint = NULL;
    const int32_t *ords, *ordt;
    unsigned char *src_ok = NULL;
    dtx_bvh *bs = NULL, *bt = NULL;
    int32_t unmatched = 0;
    int64_t np = 0;
    dtx_status st = DTX_OK;

    cs = dtx_alloc((size_t)nfs, 3 * sizeof *cs, 0);
    ns = dtx_alloc((size_t)nfs, 3 * sizeof *ns, 0);
    ct = dtx_alloc((size_t)nft, 3 * sizeof *ct, 0);
    nt = dtx_alloc((size_t)nft, 3 * sizeof *nt, 0);
    bys = dtx_alloc((size_t)nfs, sizeof *bys, 0);
    byt = dtx_alloc((size_t)nft, sizeof *byt, 0);
    src_ok = dtx_alloc((size_t)nfs, 1, 0);
    pairs = dtx_alloc((size_t)nfs + (size_t)nft, 2 * sizeof *pairs, 0);
    thint = dtx_alloc((size_t)nft, sizeof *thint, 0);
    if (!cs || !ns || !ct || !nt || !bys || !byt || !src_ok || !pairs || !thint)
        goto nomem;
    centroids(X, src->F, nfs, cs);
    centroids(Tn, tgt->F, nft, ct);
    dtx_face_normals(X, src->F, nfs, ns);
    dtx_face_normals(Tn, tgt->F, nft, nt);
    /* Source triangles that collapsed (zero normal) carry no usable gradient. */
    for (int32_t f = 0; f < nfs; f++)
        src_ok[f] = ns[3 * f] != 0.0 || ns[3 * f + 1] != 0.0 || ns[3 * f + 2] != 0.0;
    bs = dtx_bvh_build(cs, NULL, nfs);
    bt = dtx_bvh_build(ct, NULL, nft);
    if (!bs || !bt)
        goto nomem;

    /* The searches go in the leaf order of the queries' own trees (nearby
     * centroids one after the other), each starting from a nearby guess:
     * for a source triangle, the target triangle its first vertex was last
     * drawn to; for a target triangle, a source triangle that chose it.
     * Each writes its own entry only, so neither the order, the schedule
     * nor the guesses change the pairs. */
    ords = dtx_bvh_leaf_order(bs);
    ordt = dtx_bvh_leaf_order(bt);
#pragma omp parallel for schedule(dynamic, 256)
    for (int32_t i = 0; i < nfs; i++) {
        const int32_t f = ords[i];
        pair_filter_ctx c = {nt, ns + 3 * (size_t)f, cosmax, NULL};
        int32_t h = vhint ? vhint[src->F[3 * (size_t)f]] : -1;
        bys[f] = src_ok[f] ? dtx_bvh_closest_from(bt, cs + 3 * (size_t)f, prm->max_distance,
                                                  pair_filter, &c, h, NULL, NULL)
                           : -1;
    }
    for (int32_t f = 0; f < nft; f++)
        thint[f] = -1;
    for (int32_t f = 0; f < nfs; f++)
        if (bys[f] >= 0 && thint[bys[f]] < 0)
            thint[bys[f]] = f;
#pragma omp parallel for schedule(dynamic, 256) reduction(+ : unmatched)
    for (int32_t i = 0; i < nft; i++) {
        const int32_t f = ordt[i];
        pair_filter_ctx c = {ns, nt + 3 * (size_t)f, cosmax, src_ok};
        int32_t s = dtx_bvh_closest_from(bs, ct + 3 * (size_t)f, prm->max_distance, pair_filter,
                                         &c, thint[f], NULL, NULL);
        if (s < 0) {
            int32_t s2;
            unmatched++;
            s2 = dtx_bvh_closest(bs, ct + 3 * (size_t)f, INFINITY, pair_filter, &c, NULL, NULL);
            if (s2 < 0)
                s2 = dtx_bvh_closest(bs, ct + 3 * (size_t)f, INFINITY, usable_filter, &c, NULL,
                                     NULL);
            s = s2;
        }
        byt[f] = s;
    }
    for (int32_t f = 0; f < nfs; f++)
        if (bys[f] >= 0) {
            pairs[2 * np] = f;
            pairs[2 * np + 1] = bys[f];
            np++;
        }
    for (int32_t f = 0; f < nft; f++)
        if (byt[f] >= 0) {
            pairs[2 * np] = byt[f];
            pairs[2 * np + 1] = f;
            np++;
        }
    qsort(pairs, (size_t)np, 2 * sizeof *pairs, cmp_pair);
    {
        int64_t w = 0;
        for (int64_t i = 0; i < np; i++)
            if (w == 0 || pairs[2 * i] != pairs[2 * (w - 1)] ||
                pairs[2 * i + 1] != pairs[2 * (w - 1) + 1]) {
                pairs[2 * w] = pairs[2 * i];
                pairs[2 * w + 1] = pairs[2 * i + 1];
                w++;
            }
        np = w;
    }
    for (int32_t f = 0; f < nft; f++)
        if (byt[f] < 0) {
            st = dtx_seterr(err, DTX_EMESH,
                            "target triangle %d has no source triangle to pair with (is every "
                            "source triangle degenerate?)",
                            (int)f);
            goto fail;
        }
    out->pairs = pairs;
    out->npairs = np;
    out->unmatched_tgt = unmatched;
    pairs = NULL;
    goto fail;

nomem:
    st = dtx_seterr(err, DTX_ENOMEM, "out of memory while pairing triangles");
fail:
    dtx_bvh_free(&bs);
    dtx_bvh_free(&bt);
    free(cs);
    free(ct);
    free(ns);
    free(nt);
    free(bys);
    free(byt);
    free(src_ok);
    free(pairs);
    free(thint);
    return st;
}

/* ------------------------------------------------------------------ */
/* Common frame of both meshes                                         */
/* ------------------------------------------------------------------ */

dtx_status dtx__corr_check(const dtx_mesh *src, const dtx_mesh *tgt,
                           const dtx_markers *markers, const dtx_corr_params *prm,
                           dtx_error *err)
{
    if (prm->n_closest < 0 || prm->n_closest > 16)
        return dtx_seterr(err, DTX_EINVAL, "n_closest must be in [0, 16], got %d",
                          prm->n_closest);
    if (prm->lowrank_max < 0 || prm->lowrank_max > LOWRANK_MAX_K_LIMIT)
        return dtx_seterr(err, DTX_EINVAL, "lowrank_max must be in [0, %d], got %d",
                          LOWRANK_MAX_K_LIMIT, prm->lowrank_max);
    return dtx_markers_validate(markers, src->nv, tgt->nv, "markers", err);
}

double dtx__fit_rms(const dtx_bvh *bvh, const double *X, int32_t n, const int32_t *comp)
{
    return dtx__fit_rms_from(bvh, X, n, comp, NULL);
}

double dtx__fit_rms_from(const dtx_bvh *bvh, const double *X, int32_t n, const int32_t *comp,
                         const int32_t *hint)
{
    /* Per-vertex distances first, then a serial sum: the figure must not
     * depend on the thread count. */
    double sum = 0.0;
    int32_t used = 0;
    double *d2v = dtx_alloc((size_t)n, sizeof *d2v, 1);
    if (!d2v)
        return -1.0;
#pragma omp parallel for schedule(static)
    for (int32_t v = 0; v < n; v++)
        if (!comp || comp[v] >= 0)
            dtx_bvh_closest_from(bvh, X + 3 * (size_t)v, INFINITY, NULL, NULL,
                                 hint ? hint[v] : -1, NULL, d2v + v);
    for (int32_t v = 0; v < n; v++)
        if (!comp || comp[v] >= 0) {
            sum += d2v[v];
            used++;
        }
    free(d2v);
    return used > 0 ? sqrt(sum / used) : 0.0;
}

dtx_status dtx__corr_normalise(const dtx_mesh *src, const dtx_mesh *tgt,
                               const dtx_markers *markers, int align, double *S0, double *Tn,
                               double center[3], double *diag_out, dtx_error *err)
{
    double lo[3], hi[3], diag;
    memcpy(S0, src->V, (size_t)src->nv * 3 * sizeof *S0);
    /* Similarity pre-alignment on the markers (needs 3 non-collinear ones). */
    if (align && markers->n >= 3) {
        double R[9], t[3], s;
        double *P = dtx_alloc((size_t)markers->n, 3 * sizeof *P, 0);
        double *Q = dtx_alloc((size_t)markers->n, 3 * sizeof *Q, 0);
        if (!P || !Q) {
            free(P);
            free(Q);
            return dtx_seterr(err, DTX_ENOMEM, "out of memory in the correspondence phase");
        }
        for (int32_t m = 0; m < markers->n; m++) {
            memcpy(P + 3 * m, src->V + 3 * (size_t)markers->src[m], 3 * sizeof *P);
            memcpy(Q + 3 * m, tgt->V + 3 * (size_t)markers->tgt[m], 3 * sizeof *Q);
        }
        if (dtx_similarity_fit(P, Q, markers->n, R, t, &s, NULL) == DTX_OK && s > 0.0)
            dtx_similarity_apply(R, t, s, S0, src->nv);
        free(P);
        free(Q);
    }

    /* Normalise: the target's bounding box centred at the origin, and its
     * size (dtx_rms_extent: unlike the box's diagonal, the same however the
     * meshes are turned) 1. */
    for (int k = 0; k < 3; k++) {
        lo[k] = INFINITY;
        hi[k] = -INFINITY;
    }
    for (int32_t i = 0; i < tgt->nv; i++)
        for (int k = 0; k < 3; k++) {
            double x = tgt->V[3 * (size_t)i + k];
            lo[k] = x < lo[k] ? x : lo[k];
            hi[k] = x > hi[k] ? x : hi[k];
        }
    for (int k = 0; k < 3; k++)
        center[k] = 0.5 * (lo[k] + hi[k]);
    diag = dtx_rms_extent(tgt->V, tgt->nv);
    if (!(diag > 0.0))
        return dtx_seterr(err, DTX_EMESH, "target mesh has zero extent");
    for (int32_t i = 0; i < tgt->nv; i++)
        for (int k = 0; k < 3; k++)
            Tn[3 * (size_t)i + k] = (tgt->V[3 * (size_t)i + k] - center[k]) / diag;
    for (int32_t i = 0; i < src->nv; i++)
        for (int k = 0; k < 3; k++)
            S0[3 * (size_t)i + k] = (S0[3 * (size_t)i + k] - center[k]) / diag;
    *diag_out = diag;
    return DTX_OK;
}

/* ------------------------------------------------------------------ */
/* Entry point                                                         */
/* ------------------------------------------------------------------ */

dtx_status dtx_sp04_correspond(const dtx_mesh *src, const dtx_mesh *tgt,
                               const dtx_markers *markers, const dtx_corr_params *prm,
                               dtx_corr *out, dtx_error *err)
{
    dtx_status st;
    double *S0 = NULL, *Tn = NULL, *X = NULL, *tnormals = NULL, *vnormals = NULL;
    int32_t *closest = NULL;
    double center[3] = {0, 0, 0}, diag = 1.0;
    dtx_bvh *tbvh = NULL, *vbvh = NULL;
    memset(out, 0, sizeof *out);

    st = dtx__corr_check(src, tgt, markers, prm, err);
    if (st != DTX_OK)
        return st;

    S0 = dtx_alloc((size_t)src->nv, 3 * sizeof *S0, 0);
    X = dtx_alloc((size_t)src->nv, 3 * sizeof *X, 0);
    Tn = dtx_alloc((size_t)tgt->nv, 3 * sizeof *Tn, 0);
    tnormals = dtx_alloc((size_t)tgt->nf, 3 * sizeof *tnormals, 0);
    closest = dtx_alloc((size_t)src->nv, sizeof *closest, 0);
    if (!S0 || !X || !Tn || !tnormals || !closest) {
        st = dtx_seterr(err, DTX_ENOMEM, "out of memory in the correspondence phase");
        goto fail;
    }
    st = dtx__corr_normalise(src, tgt, markers, prm->align, S0, Tn, center, &diag, err);
    if (st != DTX_OK)
        goto fail;
    memcpy(X, S0, (size_t)src->nv * 3 * sizeof *X);

    dtx_face_normals(Tn, tgt->F, tgt->nf, tnormals);
    tbvh = dtx_bvh_build(Tn, tgt->F, tgt->nf);
    if (!tbvh) {
        st = dtx_seterr(err, DTX_ENOMEM, "out of memory building the target's spatial index");
        goto fail;
    }
    if (prm->closest_on == DTX_CORR_ON_VERTICES) {
        /* Closest points among the target's vertices only (with vertex
         * normals for the normal rule): what many implementations do, kept
         * to measure what the projection onto the triangles gains. */
        vnormals = dtx_alloc((size_t)tgt->nv, 3 * sizeof *vnormals, 0);
        vbvh = dtx_bvh_build(Tn, NULL, tgt->nv);
        if (!vnormals || !vbvh) {
            st = dtx_seterr(err, DTX_ENOMEM, "out of memory building the target's spatial index");
            goto fail;
        }
        dtx_vertex_normals(Tn, tgt->nv, tgt->F, tgt->nf, vnormals);
    }
    {
        /* Marker vertices are fixed at their target positions. */
        int32_t *fixv = dtx_alloc((size_t)markers->n, sizeof *fixv, 0);
        double *fixpos = dtx_alloc((size_t)markers->n, 3 * sizeof *fixpos, 0);
        if (!fixv || !fixpos) {
            free(fixv);
            free(fixpos);
            st = dtx_seterr(err, DTX_ENOMEM, "out of memory in the correspondence phase");
            goto fail;
        }
        for (int32_t m = 0; m < markers->n; m++) {
            fixv[m] = markers->src[m];
            memcpy(fixpos + 3 * (size_t)m, Tn + 3 * (size_t)markers->tgt[m], 3 * sizeof *fixpos);
        }
        st = deform_mesh(src->F, src->nv, src->nf, S0, fixv, fixpos, markers->n, NULL, NULL,
                         vbvh ? vbvh : tbvh, vbvh ? vnormals : tnormals, prm, X, NULL, closest,
                         &out->solves, &out->factorizations, err);
        free(fixv);
        free(fixpos);
    }
    if (st != DTX_OK)
        goto fail;
    /* The last closest points are target triangles only when they were
     * searched on the surface (else target vertices); they are the
     * pairing's and the fit's first guesses. */
    if (vbvh)
        for (int32_t v = 0; v < src->nv; v++)
            closest[v] = -1;
    st = pair_triangles(src, X, tgt, Tn, closest, prm, out, err);
    if (st != DTX_OK)
        goto fail;

    /* Fit quality: RMS distance of the deformed source to the target surface. */
    out->fit_rms = dtx__fit_rms_from(tbvh, X, src->nv, NULL, closest);
    if (out->fit_rms < 0.0) {
        st = dtx_seterr(err, DTX_ENOMEM, "out of memory in the correspondence phase");
        goto fail;
    }
    /* Back to the target's coordinates. */
    for (int32_t i = 0; i < src->nv; i++)
        for (int k = 0; k < 3; k++)
            X[3 * (size_t)i + k] = X[3 * (size_t)i + k] * diag + center[k];
    out->deformed_src = X;
    out->nv_src = src->nv;
    X = NULL;

fail:
    if (st != DTX_OK)
        dtx_corr_free(out);
    dtx_bvh_free(&tbvh);
    dtx_bvh_free(&vbvh);
    free(S0);
    free(Tn);
    free(X);
    free(tnormals);
    free(vnormals);
    free(closest);
    return st;
}
