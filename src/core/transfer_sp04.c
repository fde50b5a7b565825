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
 * Everything that depends only on the rest meshes and the pairs is computed
 * once, in the plan, so that a frame costs one pass over the pairs and one
 * back-substitution:
 *
 *  - Right-hand side.  With E_s = [e1 e2 e3] the deformed source edges and
 *    Sumner's fourth edge e3 = (e1 x e2) / sqrt|e1 x e2|, and Vinv_s the
 *    rest-frame inverse, S_s = E_s Vinv_s, and the row of target vertex
 *    v_tj gets, for every pair (s, t), S_s g_tj = E_s (Vinv_s g_tj).  The
 *    3-vectors w_j = Vinv_s g_tj are precomputed per pair (j = 1, 2; g_t0 =
 *    -(g_t1 + g_t2), so v_t0 gets minus the sum), so no gradient S_s is
 *    formed: per frame the edges and e3 of each paired source triangle are
 *    computed once and applied to its pairs.  Source triangles are visited
 *    along a Morton curve, and source vertices numbered in order of first
 *    use, to keep the working set in cache.
 *  - Energy constant.  The minimised energy is E = cst - b.x (plus pin
 *    terms, see group_residual) with cst = sum over pairs ||S_s P_t||_F^2,
 *    P_t = I - n_t n_t^T.  ||S_s P_t||^2 = tr(Gram(E_s) K) with K = Vinv_s
 *    P_t Vinv_s^T, and Gram(E_s) has only four distinct non-zero entries
 *    (e3 is orthogonal to e1 and e2, |e3|^2 = |e1 x e2|), so four
 *    coefficients per source triangle (summed over its pairs) give cst.
 *  - Solve.  CHOLMOD analyses and factors the free block of L once (kept as
 *    a simplicial L D L^T); the back-substitutions are done here on all the
 *    right-hand sides of a group at once: one row of 3 x 8 values per
 *    vertex, rows in the factor's elimination order, so each entry of the
 *    factor is read once per group and applied to 24 values with SIMD, and
 *    the right-hand side buffer is solved in place (no copies, no
 *    transposes).  CHOLMOD's cholmod_solve2 takes at most 4 columns per
 *    sweep over the factor, with a permuted, transposed copy per sweep.
 *  - Residual.  With B the solved right-hand side, w = L^-1 P B and u =
 *    D^-1 w, B . x = w . u: a sum of positive terms taken during the solve.
 *
 * Frames are processed in groups of DTX_SOLVE_GROUP (aligned to the frame
 * index the caller passes), each group by one thread with its own scratch.
 * Inside a group the frames are the SIMD lanes: the source positions are
 * transposed to vertex-major, frame-minor order, every formula is evaluated
 * for all lanes at once, and a group with fewer frames repeats its last
 * frame in the unused lanes.  Every lane does the same IEEE operations in
 * the same order, and every sum runs in a fixed order, so a frame's result
 * does not depend on its lane, on the thread count, on the kernel variant
 * or on how the calls split the sequence.
 */
#include "cholmod_util.h"
#include "dtx_core.h"
#include "plan_util.h"
#include "transfer.h"
#include "vec3.h"

#include <assert.h>
#include <cholmod.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#endif

/* Kernel variants.  The per-group kernels only use IEEE add, subtract,
 * multiply, divide and square root, which round the same whatever the SIMD
 * width (and target("avx2") does not enable FMA), so they can be compiled
 * twice and picked at run time with the same results: for the baseline ISA
 * and, on x86-64 with GCC or Clang when the baseline lacks it, for AVX2
 * (twice the lanes per instruction). */
#if defined(__GNUC__) && defined(__x86_64__) && !defined(__AVX2__)
#define DTX_SP04_AVX2_VARIANT 1
#endif
#if defined(__GNUC__)
/* The kernels are inlined into each variant's entry point. */
#define KERNEL static inline __attribute__((always_inline))
#else
#define KERNEL static
#endif
#if defined(__AVX__) || defined(DTX_SP04_AVX2_VARIANT)
#include <immintrin.h>
#elif defined(__SSE2__)
#include <emmintrin.h>
#endif

/* Full unrolling of the short fixed-length row loops, so that a row's
 * partial sums stay in registers. */
#define DTX_PRAGMA(x) _Pragma(#x)
#if defined(__clang__)
#define UNROLL(n) DTX_PRAGMA(clang loop unroll_count(n))
#elif defined(__GNUC__)
#define UNROLL(n) DTX_PRAGMA(GCC unroll n)
#else
#define UNROLL(n)
#endif

/* Rows read in an order the hardware cannot guess are prefetched this many
 * iterations ahead. */
#define PREFETCH_AHEAD 8
#if defined(__GNUC__)
#define prefetch_line(addr) __builtin_prefetch(addr)
#else
#define prefetch_line(addr) ((void)(addr))
#endif

#define DTX_SOLVE_GROUP DTX_SP04_SOLVE_GROUP
#define LANES DTX_SOLVE_GROUP   /* frames evaluated together, one per lane */
#define VSTRIDE (3 * LANES)     /* doubles per vertex in lane-major buffers */
_Static_assert(LANES % 4 == 0, "the SIMD kernels take the lanes 4 (AVX) or 2 (SSE2) at a time");

static const double zero_row[VSTRIDE];

/* nrows lane-buffer rows, zeroed, aligned to cache lines (a row is three
 * lines); NULL on overflow or failure.  Free with free(). */
static double *alloc_rows(int32_t nrows)
{
    size_t n = (size_t)(nrows > 0 ? nrows : 1), bytes = VSTRIDE * sizeof(double);
    double *rows;
    if (n > SIZE_MAX / bytes)
        return NULL;
    rows = aligned_alloc(64, n * bytes);
    if (rows)
        memset(rows, 0, n * bytes);
    return rows;
}

/* Prefetches the three cache lines of one lane-buffer row. */
static inline void prefetch_row(const double *row)
{
    prefetch_line(row);
    prefetch_line(row + 8);
    prefetch_line(row + 16);
}

/* A source triangle that has pairs.  Its pair terms are
 * pterm[previous pair_end .. pair_end). */
typedef struct {
    int32_t v[3];
    int32_t pair_end;
    /* Its share of the energy constant: k0 |e1|^2 + k1 e1.e2 + k2 |e2|^2 +
     * k3 |e1 x e2| (see src_energy_coefficients). */
    double k[4];
} src_term;

/* A (source, target) pair: the bg rows tv of the target triangle's
 * vertices; row tv[1] gets E_s w[0], tv[2] gets E_s w[1] and tv[0] minus
 * their sum (64 bytes, one cache line). */
typedef struct {
    double w[2][3];
    int32_t tv[3];
    int32_t unused;
} pair_term;

/* Per-thread scratch, allocated once (dtx__workers_ensure). */
typedef struct {
    double *xg; /* nv_s rows of 3 x LANES: the group's source positions */
    double *bg; /* nv_t rows of 3 x LANES: right-hand sides, solved in place;
                   all zero between groups */
} worker;

struct dtx_sp04_plan {
    int32_t nv_s, nv_t;
    int64_t npairs;
    int32_t nsrc;       /* source triangles with pairs */
    src_term *sterm;    /* nsrc, in a spatially coherent order */
    pair_term *pterm;   /* npairs, grouped by source triangle */
    int32_t *srow;      /* nv_s: row of each source vertex in xg */
    int32_t *trow;      /* nv_t: row of each target vertex in bg: free vertices
                           first, in the factor's elimination order */

    dtx_anchor anchor;
    int32_t npins;
    int32_t nfree;
    int32_t *freeidx;   /* nv_t: free index (vertex order) or -1 */
    int32_t nremoved;
    int32_t *removed;   /* nremoved: removed vertices that are in a face (pins, anchor) */
    int32_t *fixedrows; /* nv_t - nfree: the vertex of each bg row past the free ones */
    int32_t nunref;
    int32_t *unrefrows; /* nunref: bg rows of the vertices in no face */
    double rest_centroid_ref[3]; /* rest centroid of the vertices in faces */
    double *fixedval;   /* nv_t x 3: values of removed vertices (pins, rest for the others) */
    double *pin_rhs;    /* nfree x 3, by bg row: - L_fp x_p for pinned p */
    double pin_energy;  /* x_p^T L_pp x_p over the three coordinates */
    double rest_centroid_t[3], rest_centroid_s[3], scale;

    /* The factor P L_ff P^T = L D L^T in bg row numbering: the strictly
     * lower part of the unit L both by rows (for L w = b) and by columns
     * (for L^T y = u), each sorted, and D. */
    int32_t *lrowptr;   /* nfree + 1 */
    int32_t *lrowcol;
    double *lrowval;
    int32_t *lcolptr;   /* nfree + 1 */
    int32_t *lcolrow;
    double *lcolval;
    double *ldiag;      /* nfree */

    int avx2;           /* run the AVX2 variant of the kernels */

    cholmod_common cc;  /* owns L (kept for the bare-solve benchmark hooks) */
    cholmod_factor *L;
    double factor_seconds;

    dtx__workers workers; /* a worker per thread */
};

static int cpu_has_avx2(void)
{
#ifdef DTX_SP04_AVX2_VARIANT
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2") != 0;
#else
    return 0;
#endif
}

int32_t dtx_sp04_plan_nv_src(const dtx_sp04_plan *p) { return p->nv_s; }
int32_t dtx_sp04_plan_nv_tgt(const dtx_sp04_plan *p) { return p->nv_t; }
double dtx_sp04_plan_factor_seconds(const dtx_sp04_plan *p) { return p->factor_seconds; }

static void fini_worker(void *plan, void *workspace)
{
    worker *k = workspace;
    free(k->xg);
    free(k->bg);
}

void dtx_sp04_plan_free(dtx_sp04_plan **pp)
{
    dtx_sp04_plan *p;
    if (!pp || !*pp)
        return;
    p = *pp;
    dtx__workers_free(&p->workers, p, fini_worker);
    cholmod_free_factor(&p->L, &p->cc);
    cholmod_finish(&p->cc);
    free(p->sterm);
    free(p->pterm);
    free(p->srow);
    free(p->trow);
    free(p->freeidx);
    free(p->removed);
    free(p->fixedrows);
    free(p->unrefrows);
    free(p->fixedval);
    free(p->pin_rhs);
    free(p->lrowptr);
    free(p->lrowcol);
    free(p->lrowval);
    free(p->lcolptr);
    free(p->lcolrow);
    free(p->lcolval);
    free(p->ldiag);
    free(p);
    *pp = NULL;
}

/* ------------------------------------------------------------------ */
/* Plan: per-pair operators                                             */
/* ------------------------------------------------------------------ */

/* Adds pair (s, t)'s share of the energy constant to k.  With R = Vinv_s
 * (rows r_0, r_1, r_2) and P = I - n n^T, ||E R P||^2 = tr(Gram(E) R P R^T)
 * and (R P R^T)_kl = r_k.r_l - (r_k.n)(r_l.n), written as (r_k x n).(r_l x
 * n) + r_k.r_l (1 - n.n): the same value, without cancellation for a unit n
 * (and still right for the zero normal of a degenerate target triangle).
 * Gram(E) = [a b 0; b c 0; 0 0 |e1 x e2|] with a = |e1|^2, b = e1.e2,
 * c = |e2|^2, so four coefficients suffice. */
static void src_energy_coefficients(const double *inv, const double *n, double *k)
{
    double rn[3][3], one_minus_nn = 1.0 - dot3(n, n);
    double K[3][3];
    for (int i = 0; i < 3; i++)
        cross3(inv + 3 * i, n, rn[i]);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            K[i][j] = dot3(rn[i], rn[j]) + dot3(inv + 3 * i, inv + 3 * j) * one_minus_nn;
    k[0] += K[0][0];
    k[1] += 2.0 * K[0][1];
    k[2] += K[1][1];
    k[3] += K[2][2];
}

/* Morton code of x in the cube [lo, lo + ext]^3: 21 bits per axis,
 * interleaved, so that points close in space tend to be close in order. */
static uint64_t morton_code(const double *x, const double *lo, double ext)
{
    uint64_t code = 0;
    uint32_t q[3];
    for (int c = 0; c < 3; c++) {
        double u = ext > 0.0 ? (x[c] - lo[c]) / ext : 0.0;
        u = u > 0.0 ? (u < 1.0 ? u : 1.0) : 0.0; /* also maps NaN to 0 */
        q[c] = (uint32_t)(u * 2097151.0);
    }
    for (int b = 20; b >= 0; b--)
        for (int c = 0; c < 3; c++)
            code = (code << 1) | ((q[c] >> b) & 1u);
    return code;
}

typedef struct {
    uint64_t key;
    int32_t idx;
} keyed_index;

static int compare_keyed(const void *a, const void *b)
{
    const keyed_index *x = a, *y = b;
    if (x->key != y->key)
        return x->key < y->key ? -1 : 1;
    return (x->idx > y->idx) - (x->idx < y->idx);
}

/* The source triangles that have pairs (sstart[s] < sstart[s + 1]), sorted
 * along a Morton curve through their rest centroids: consecutive triangles
 * then touch nearby source vertices, and (the pairs being spatial) nearby
 * target vertices, which keeps the lane buffers' working set in cache. */
static keyed_index *spatial_source_order(const dtx_mesh *src, const int32_t *sstart, int32_t nsrc)
{
    keyed_index *ord = dtx_alloc((size_t)nsrc, sizeof *ord, 0);
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    double ext = 0.0;
    if (!ord)
        return NULL;
    for (int32_t v = 0; v < src->nv; v++)
        for (int c = 0; c < 3; c++) {
            lo[c] = fmin(lo[c], src->V[3 * (size_t)v + c]);
            hi[c] = fmax(hi[c], src->V[3 * (size_t)v + c]);
        }
    for (int c = 0; c < 3; c++)
        ext = fmax(ext, hi[c] - lo[c]);
    for (int32_t s = 0, a = 0; s < src->nf; s++) {
        const int32_t *t = src->F + 3 * (size_t)s;
        double cen[3];
        if (sstart[s] == sstart[s + 1])
            continue;
        for (int c = 0; c < 3; c++)
            cen[c] = (src->V[3 * (size_t)t[0] + c] + src->V[3 * (size_t)t[1] + c] +
                      src->V[3 * (size_t)t[2] + c]) / 3.0;
        ord[a].key = morton_code(cen, lo, ext);
        ord[a++].idx = s;
    }
    qsort(ord, (size_t)nsrc, sizeof *ord, compare_keyed);
    return ord;
}

/* Row of source vertex v in xg: rows are handed out in order of first use,
 * so the traversal in group_rhs walks xg nearly in order. */
static int32_t lane_row(int32_t *row, int32_t *nrows, int32_t v)
{
    if (row[v] < 0)
        row[v] = (*nrows)++;
    return row[v];
}

/* Builds the source terms and pair terms (grouped by source triangle, the
 * triangles in spatial order, each one's pairs in target order), the xg
 * rows srow, and the number of pairs of each target triangle (tmult, nf_t),
 * from the source frame inverses Vinv (nf_s x 9), the target gradient
 * operator G (nf_t x 9) and unit normals N (nf_t x 3).  The pair terms hold
 * target vertex numbers until number_bg_rows. */
static dtx_status build_pair_terms(dtx_sp04_plan *p, const dtx_mesh *src, const dtx_mesh *tgt,
                                   const int32_t *pairs, int64_t npairs, const double *Vinv,
                                   const double *G, const double *N, int32_t *tmult,
                                   dtx_error *err)
{
    dtx_status st = DTX_OK;
    int32_t *sstart = dtx_alloc((size_t)src->nf + 1, sizeof *sstart, 1);
    int32_t *fill = dtx_alloc((size_t)src->nf, sizeof *fill, 0);
    int32_t *order = dtx_alloc((size_t)npairs, sizeof *order, 0);
    keyed_index *sord = NULL;
    int32_t nsrows = 0, k = 0;
    p->srow = dtx_alloc((size_t)src->nv, sizeof *p->srow, 0);
    if (!sstart || !fill || !order || !p->srow)
        goto nomem;

    /* Counting sort of the pairs by source triangle (stable: the input is
     * sorted by target, so each source's pairs stay in target order). */
    memset(tmult, 0, (size_t)tgt->nf * sizeof *tmult);
    for (int64_t i = 0; i < npairs; i++) {
        sstart[pairs[2 * i] + 1]++;
        tmult[pairs[2 * i + 1]]++;
    }
    p->nsrc = 0;
    for (int32_t s = 0; s < src->nf; s++) {
        p->nsrc += sstart[s + 1] > 0;
        sstart[s + 1] += sstart[s];
    }
    memcpy(fill, sstart, (size_t)src->nf * sizeof *fill);
    for (int64_t i = 0; i < npairs; i++)
        order[fill[pairs[2 * i]]++] = (int32_t)i;

    sord = spatial_source_order(src, sstart, p->nsrc);
    p->sterm = dtx_alloc((size_t)p->nsrc, sizeof *p->sterm, 1);
    p->pterm = dtx_alloc((size_t)npairs, sizeof *p->pterm, 1);
    if (!sord || !p->sterm || !p->pterm)
        goto nomem;
    for (int32_t v = 0; v < src->nv; v++)
        p->srow[v] = -1;
    for (int32_t a = 0; a < p->nsrc; a++) {
        int32_t s = sord[a].idx;
        const double *inv = Vinv + 9 * (size_t)s;
        src_term *sd = &p->sterm[a];
        for (int j = 0; j < 3; j++)
            sd->v[j] = lane_row(p->srow, &nsrows, src->F[3 * (size_t)s + j]);
        for (int32_t q = sstart[s]; q < sstart[s + 1]; q++, k++) {
            int32_t t = pairs[2 * (size_t)order[q] + 1];
            const double *g = G + 9 * (size_t)t;
            pair_term *pt = &p->pterm[k];
            /* w_j = Vinv_s g_tj: row i of Vinv dotted with g_tj. */
            for (int j = 0; j < 2; j++)
                for (int i = 0; i < 3; i++)
                    pt->w[j][i] = dot3(inv + 3 * i, g + 3 * (j + 1));
            memcpy(pt->tv, tgt->F + 3 * (size_t)t, sizeof pt->tv);
            src_energy_coefficients(inv, N + 3 * (size_t)t, sd->k);
        }
        sd->pair_end = k;
    }
    /* Vertices no pair reaches still get rows (srow is a permutation). */
    for (int32_t v = 0; v < src->nv; v++)
        lane_row(p->srow, &nsrows, v);
    goto done;

nomem:
    st = dtx_seterr(err, DTX_ENOMEM, "out of memory creating the transfer plan");
done:
    free(sstart);
    free(fill);
    free(order);
    free(sord);
    return st;
}

/* L = sum over pairs G_t^T G_t as the full matrix (for the pin terms) and as
 * the free block (factored): target triangle t counts tmult[t] times. */
static dtx_status assemble_normal_matrix(const dtx_sp04_plan *p, const dtx_mesh *tgt,
                                         const double *G, const int32_t *tmult,
                                         cholmod_sparse **full, cholmod_sparse **freeblock,
                                         cholmod_common *cc, dtx_error *err)
{
    const int32_t nv = tgt->nv, nf = tgt->nf;
    dtx_status st = DTX_OK;
    cholmod_triplet *T = NULL, *Tf = NULL;
    int64_t nused = 0;
    *full = *freeblock = NULL;
    for (int32_t t = 0; t < nf; t++)
        nused += tmult[t] > 0;
    T = cholmod_allocate_triplet((size_t)nv, (size_t)nv, (size_t)nused * 9, 0, CHOLMOD_REAL, cc);
    Tf = cholmod_allocate_triplet((size_t)p->nfree, (size_t)p->nfree,
                                  (size_t)nused * 6 + (size_t)p->nfree, -1, CHOLMOD_REAL, cc);
    if (!T || !Tf)
        goto nomem;
    for (int32_t t = 0; t < nf; t++) {
        int32_t mult = tmult[t];
        const double *g = G + 9 * (size_t)t;
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
    *full = cholmod_triplet_to_sparse(T, T->nnz, cc);
    *freeblock = cholmod_triplet_to_sparse(Tf, Tf->nnz, cc);
    if (!*full || !*freeblock)
        goto nomem;
    goto done;

nomem:
    st = dtx_seterr(err, DTX_ENOMEM, "out of memory creating the transfer plan");
    cholmod_free_sparse(full, cc);
    cholmod_free_sparse(freeblock, cc);
done:
    cholmod_free_triplet(&T, cc);
    cholmod_free_triplet(&Tf, cc);
    return st;
}

/* Pin terms from the full L: pin_rhs = -L_fp x_p (added to every right-hand
 * side; nfree x 3 by free index here, by bg row after number_bg_rows) and
 * pin_energy = x_p^T L_pp x_p (a constant of the energy). */
static dtx_status pin_terms(dtx_sp04_plan *p, const cholmod_sparse *Lfull, dtx_error *err)
{
    const int32_t *Lp = Lfull->p, *Li = Lfull->i;
    const double *Lx = Lfull->x;
    p->pin_rhs = dtx_alloc((size_t)p->nfree, 3 * sizeof *p->pin_rhs, 1);
    if (!p->pin_rhs)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory creating the transfer plan");
    p->pin_energy = 0.0;
    for (int32_t r = 0; r < p->nremoved; r++) {
        int32_t q = p->removed[r];
        const double *xq = p->fixedval + 3 * (size_t)q;
        for (int32_t k = Lp[q]; k < Lp[q + 1]; k++) {
            int32_t row = Li[k], fr = p->freeidx[row];
            if (fr >= 0) {
                for (int c = 0; c < 3; c++)
                    p->pin_rhs[3 * (size_t)fr + c] -= Lx[k] * xq[c];
            } else {
                p->pin_energy += Lx[k] * dot3(p->fixedval + 3 * (size_t)row, xq);
            }
        }
    }
    return DTX_OK;
}

/* Takes the factor as a simplicial L D L^T (a supernodal one is converted)
 * and numbers the bg rows: a free vertex gets the position of its unknown
 * in the elimination order, removed and unreferenced vertices the rows
 * after.  Copies the factor's columns in that numbering, and maps the pair
 * terms' target vertices and the pin coupling to rows. */
static dtx_status number_bg_rows(dtx_sp04_plan *p, dtx_error *err)
{
    const int32_t n = p->nfree;
    const int32_t *Lp, *Li, *Lnz, *Perm;
    const double *Lx;
    int32_t *pinv = NULL, next = n;
    double *pin = NULL;
    int64_t nnz = 0;
    if (!cholmod_change_factor(CHOLMOD_REAL, 0, 0, 1, 1, p->L, &p->cc))
        return dtx_seterr(err, DTX_ENOMEM, "out of memory converting the transfer factor");
    Lp = p->L->p;
    Li = p->L->i;
    Lnz = p->L->nz;
    Lx = p->L->x;
    Perm = p->L->Perm;
    for (int32_t j = 0; j < n; j++) {
        if (Lnz[j] < 1 || Li[Lp[j]] != j)
            return dtx_seterr(err, DTX_ESOLVE,
                              "unexpected factor layout from CHOLMOD (column %d does not "
                              "start with its diagonal)",
                              (int)j);
        nnz += Lnz[j] - 1;
    }
    pinv = dtx_alloc((size_t)n, sizeof *pinv, 0);
    pin = dtx_alloc((size_t)n, 3 * sizeof *pin, 0);
    p->trow = dtx_alloc((size_t)p->nv_t, sizeof *p->trow, 0);
    p->fixedrows = dtx_alloc((size_t)(p->nv_t - n), sizeof *p->fixedrows, 0);
    p->lrowptr = dtx_alloc((size_t)n + 1, sizeof *p->lrowptr, 1);
    p->lrowcol = dtx_alloc((size_t)nnz, sizeof *p->lrowcol, 0);
    p->lrowval = dtx_alloc((size_t)nnz, sizeof *p->lrowval, 0);
    p->lcolptr = dtx_alloc((size_t)n + 1, sizeof *p->lcolptr, 0);
    p->lcolrow = dtx_alloc((size_t)nnz, sizeof *p->lcolrow, 0);
    p->lcolval = dtx_alloc((size_t)nnz, sizeof *p->lcolval, 0);
    p->ldiag = dtx_alloc((size_t)n, sizeof *p->ldiag, 0);
    if (!pinv || !pin || !p->trow || !p->fixedrows || !p->lrowptr || !p->lrowcol || !p->lrowval ||
        !p->lcolptr || !p->lcolrow || !p->lcolval || !p->ldiag) {
        free(pinv);
        free(pin);
        return dtx_seterr(err, DTX_ENOMEM, "out of memory creating the transfer plan");
    }
    for (int32_t k = 0; k < n; k++)
        pinv[Perm[k]] = k;
    for (int32_t v = 0; v < p->nv_t; v++) {
        if (p->freeidx[v] >= 0) {
            p->trow[v] = pinv[p->freeidx[v]];
        } else {
            p->fixedrows[next - n] = v;
            p->trow[v] = next++;
        }
    }

    /* Columns (the factor's own, sorted by row) and, transposed by a
     * counting sort over the columns in order, rows sorted by column. */
    p->lcolptr[0] = 0;
    for (int32_t j = 0; j < n; j++) {
        int32_t q = p->lcolptr[j];
        p->ldiag[j] = Lx[Lp[j]];
        for (int32_t k = Lp[j] + 1; k < Lp[j] + Lnz[j]; k++, q++) {
            p->lcolrow[q] = Li[k];
            p->lcolval[q] = Lx[k];
            p->lrowptr[Li[k] + 1]++;
        }
        p->lcolptr[j + 1] = q;
    }
    for (int32_t i = 0; i < n; i++)
        p->lrowptr[i + 1] += p->lrowptr[i];
    memcpy(pinv, p->lrowptr, (size_t)n * sizeof *pinv); /* pinv reused: fill positions */
    for (int32_t j = 0; j < n; j++)
        for (int32_t q = p->lcolptr[j]; q < p->lcolptr[j + 1]; q++) {
            int32_t at = pinv[p->lcolrow[q]]++;
            p->lrowcol[at] = j;
            p->lrowval[at] = p->lcolval[q];
        }
    for (int32_t k = 0; k < n; k++)
        pinv[Perm[k]] = k;
    for (int64_t k = 0; k < p->npairs; k++)
        for (int j = 0; j < 3; j++)
            p->pterm[k].tv[j] = p->trow[p->pterm[k].tv[j]];
    for (int32_t fr = 0; fr < n; fr++)
        memcpy(pin + 3 * (size_t)pinv[fr], p->pin_rhs + 3 * (size_t)fr, 3 * sizeof *pin);
    free(p->pin_rhs);
    p->pin_rhs = pin;
    free(pinv);
    return DTX_OK;
}

dtx_status dtx_sp04_plan_create(const dtx_mesh *src, const dtx_mesh *tgt, const int32_t *pairs,
                                int64_t npairs, dtx_anchor anchor, const int32_t *pins,
                                const double *pin_pos, int32_t npins, dtx_sp04_plan **out,
                                dtx_error *err)
{
    dtx_sp04_plan *p = NULL;
    dtx_status st = DTX_OK;
    cholmod_sparse *K = NULL, *Lfull = NULL;
    int32_t *comp = NULL, *tmult = NULL;
    double *Vinv = NULL, *G = NULL, *N = NULL;
    unsigned char *used = NULL;
    double t0;
    const int32_t nv = tgt->nv, nf = tgt->nf;

    *out = NULL;
    st = dtx__check_pins(anchor, pins, npins, nv, err);
    if (st != DTX_OK)
        return st;
    if (npairs < 0 || npairs > INT32_MAX)
        return dtx_seterr(err, DTX_ERANGE,
                          "%lld correspondence pairs: the transfer handles 0 to %d pairs",
                          (long long)npairs, (int)INT32_MAX);
    st = dtx__check_pairs(pairs, npairs, src->nf, nf, err);
    if (st != DTX_OK)
        return st;

    p = calloc(1, sizeof *p);
    if (!p)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory creating the transfer plan");
    dtx__chol_start(&p->cc, DTX__CHOL_AUTO, DTX__CHOL_ORDER_DEFAULT);
    p->nv_s = src->nv;
    p->nv_t = nv;
    p->anchor = anchor;
    p->npins = npins;
    p->npairs = npairs;
    p->avx2 = cpu_has_avx2();
    p->freeidx = dtx_alloc((size_t)nv, sizeof *p->freeidx, 0);
    p->fixedval = dtx_alloc((size_t)nv, 3 * sizeof *p->fixedval, 1);
    comp = dtx_alloc((size_t)nv, sizeof *comp, 0);
    tmult = dtx_alloc((size_t)nf, sizeof *tmult, 0);
    used = dtx_alloc((size_t)nv, 1, 1);
    Vinv = dtx_alloc((size_t)src->nf, 9 * sizeof *Vinv, 0);
    G = dtx_alloc((size_t)nf, 9 * sizeof *G, 0);
    N = dtx_alloc((size_t)nf, 3 * sizeof *N, 0);
    if (!p->freeidx || !p->fixedval || !comp || !tmult || !used || !Vinv || !G || !N)
        goto nomem;

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

    /* Operators: source frame inverses, target gradients and normals. */
    {
        double ds = dtx_bbox_diagonal(src->V, src->nv), dt = dtx_bbox_diagonal(tgt->V, nv);
        dtx_frame_inverses(src->V, src->F, src->nf, 1e-14 * ds * ds, Vinv);
        dtx_gradient_operator(tgt->V, tgt->F, nf, 1e-14 * dt * dt, G);
        dtx_face_normals(tgt->V, tgt->F, nf, N);
    }
    st = build_pair_terms(p, src, tgt, pairs, npairs, Vinv, G, N, tmult, err);
    if (st != DTX_OK)
        goto fail;

    /* Removed unknowns: pins, unreferenced vertices, and (without pins) one
     * anchor vertex whose value is fixed by the centroid afterwards. */
    dtx__centroid(tgt->V, nv, p->rest_centroid_t);
    dtx__centroid(src->V, src->nv, p->rest_centroid_s);
    /* "follow": the source's centroid motion scaled by the meshes' size
     * ratio (dtx_rms_extent: the same however both are turned). */
    {
        double es = dtx_rms_extent(src->V, src->nv), et = dtx_rms_extent(tgt->V, nv);
        p->scale = es > 0 ? et / es : 1.0;
    }
    for (int32_t v = 0; v < nv; v++) {
        p->freeidx[v] = used[v] ? 0 : -1;
        memcpy(p->fixedval + 3 * (size_t)v, tgt->V + 3 * (size_t)v, 3 * sizeof(double));
    }
    for (int32_t i = 0; i < npins; i++) {
        p->freeidx[pins[i]] = -1;
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
    /* Free unknowns are numbered in vertex order: the fill-reducing
     * ordering CHOLMOD picks, hence the rounding of the solve, depends on
     * it. */
    p->nremoved = 0;
    for (int32_t v = 0; v < nv; v++) {
        if (p->freeidx[v] == 0)
            p->freeidx[v] = p->nfree++;
        else {
            p->freeidx[v] = -1;
            p->nremoved += used[v];
        }
    }
    if (p->nfree == 0) {
        st = dtx_seterr(err, DTX_EMESH, "every target vertex is pinned: nothing to solve");
        goto fail;
    }
    p->removed = dtx_alloc((size_t)p->nremoved, sizeof *p->removed, 0);
    if (!p->removed)
        goto nomem;
    for (int32_t v = 0, r = 0; v < nv; v++)
        if (p->freeidx[v] < 0 && used[v])
            p->removed[r++] = v;
    /* Vertices in no face keep their rest offset from the centroid of the
     * vertices in faces (write_frames). */
    p->nunref = 0;
    for (int32_t v = 0; v < nv; v++)
        p->nunref += !used[v];
    if (p->nunref > 0) {
        int32_t nused = nv - p->nunref;
        p->unrefrows = dtx_alloc((size_t)p->nunref, sizeof *p->unrefrows, 0);
        if (!p->unrefrows)
            goto nomem;
        for (int c = 0; c < 3; c++)
            p->rest_centroid_ref[c] = 0.0;
        for (int32_t v = 0; v < nv; v++)
            if (used[v])
                for (int c = 0; c < 3; c++)
                    p->rest_centroid_ref[c] += tgt->V[3 * (size_t)v + c] / nused;
    }

    st = assemble_normal_matrix(p, tgt, G, tmult, &Lfull, &K, &p->cc, err);
    if (st != DTX_OK)
        goto fail;
    st = pin_terms(p, Lfull, err);
    if (st != DTX_OK)
        goto fail;

    t0 = dtx__now_seconds();
    st = dtx__chol_analyze_factorize(K, DTX__CHOL_TEAMS, "the transfer system",
                                     ": the target may have degenerate triangles only, or a "
                                     "vertex no pair reaches",
                                     &p->L, &p->cc, err);
    if (st != DTX_OK)
        goto fail;
    p->factor_seconds = dtx__now_seconds() - t0;
    st = number_bg_rows(p, err);
    if (st != DTX_OK)
        goto fail;
    for (int32_t v = 0, k = 0; v < nv; v++)
        if (!used[v])
            p->unrefrows[k++] = p->trow[v];
    cholmod_free_sparse(&K, &p->cc);
    cholmod_free_sparse(&Lfull, &p->cc);
    *out = p;
    p = NULL; /* the caller's now */
    goto done;

nomem:
    st = dtx_seterr(err, DTX_ENOMEM, "out of memory creating the transfer plan");
fail:
    if (p) {
        cholmod_free_sparse(&K, &p->cc);
        cholmod_free_sparse(&Lfull, &p->cc);
    }
done:
    free(comp);
    free(tmult);
    free(used);
    free(Vinv);
    free(G);
    free(N);
    dtx_sp04_plan_free(&p);
    return st;
}

/* ------------------------------------------------------------------ */
/* Apply: per-thread scratch                                            */
/* ------------------------------------------------------------------ */

static int init_worker(void *plan, void *workspace)
{
    dtx_sp04_plan *p = plan;
    worker *k = workspace;
    k->xg = alloc_rows(p->nv_s);
    k->bg = alloc_rows(p->nv_t);
    return k->xg && k->bg;
}

/* ------------------------------------------------------------------ */
/* Apply: one group of frames, the frames as SIMD lanes                 */
/* ------------------------------------------------------------------ */

/* Transposes the group's nfr source frames (nfr x nv x 3) into xg (row
 * srow[v] of nv rows of 3 x LANES); lanes past nfr repeat the last frame.
 * With cs non-NULL, also each lane's source centroid (the same sums in the
 * same order as dtx__centroid() on the frame). */
KERNEL void load_source_lanes(const dtx_sp04_plan *p, const double *Xs, int64_t nfr,
                              double *restrict xg, double (*cs)[LANES])
{
    const int32_t nv = p->nv_s;
    const double *frame[LANES];
    for (int f = 0; f < LANES; f++)
        frame[f] = Xs + (size_t)(f < nfr ? f : nfr - 1) * 3 * nv;
    for (int32_t v = 0; v < nv; v++) {
        double *row = xg + (size_t)p->srow[v] * VSTRIDE;
        for (int c = 0; c < 3; c++)
            for (int f = 0; f < LANES; f++)
                row[c * LANES + f] = frame[f][3 * (size_t)v + c];
    }
    if (!cs)
        return;
    for (int c = 0; c < 3; c++)
        for (int f = 0; f < LANES; f++)
            cs[c][f] = 0.0;
    for (int32_t v = 0; v < nv; v++) {
        const double *row = xg + (size_t)p->srow[v] * VSTRIDE;
        for (int c = 0; c < 3; c++)
#pragma omp simd
            for (int f = 0; f < LANES; f++)
                cs[c][f] += row[c * LANES + f];
    }
    for (int c = 0; c < 3; c++)
        for (int f = 0; f < LANES; f++)
            cs[c][f] /= nv;
}

/* len = sqrt(q) = |e1 x e2| and h = 1 / sqrt(len), the scale of Sumner's
 * fourth edge e3 = (e1 x e2) h (0 where len is not > 0, as in
 * dtx_deformation_gradients), for n values (n a multiple of 4).  With SIMD
 * intrinsics where available: C's errno rules keep the compiler from
 * vectorising sqrt itself.  Every form is correctly rounded, so the values
 * are the same. */
typedef void (*edge_scale_fn)(const double *q, double *len, double *h, int n);

#if defined(__AVX__) || defined(DTX_SP04_AVX2_VARIANT)
#if !defined(__AVX__)
__attribute__((target("avx")))
#endif
static void fourth_edge_scale_avx(const double *q, double *len, double *h, int n)
{
    const __m256d one = _mm256_set1_pd(1.0), zero = _mm256_setzero_pd();
    for (int i = 0; i < n; i += 4) {
        __m256d l = _mm256_sqrt_pd(_mm256_loadu_pd(q + i));
        __m256d s = _mm256_div_pd(one, _mm256_sqrt_pd(l));
        _mm256_storeu_pd(len + i, l);
        _mm256_storeu_pd(h + i, _mm256_and_pd(_mm256_cmp_pd(l, zero, _CMP_GT_OQ), s));
    }
}
#endif

static void fourth_edge_scale(const double *q, double *len, double *h, int n)
{
#if defined(__AVX__)
    fourth_edge_scale_avx(q, len, h, n);
#elif defined(__SSE2__)
    const __m128d one = _mm_set1_pd(1.0), zero = _mm_setzero_pd();
    for (int i = 0; i < n; i += 2) {
        __m128d l = _mm_sqrt_pd(_mm_loadu_pd(q + i));
        __m128d s = _mm_div_pd(one, _mm_sqrt_pd(l));
        _mm_storeu_pd(len + i, l);
        _mm_storeu_pd(h + i, _mm_and_pd(_mm_cmpgt_pd(l, zero), s));
    }
#else
    for (int i = 0; i < n; i++) {
        len[i] = sqrt(q[i]);
        h[i] = len[i] > 0.0 ? 1.0 / sqrt(len[i]) : 0.0;
    }
#endif
}

/* Source triangles are taken in blocks of this many: edges of the block,
 * then the square roots of the block in one call, then the pairs. */
#define SRC_BLOCK 16

/* Right-hand sides of the group: bg (all zero on entry) gets, per lane, the
 * sum over pairs of S_s g_tj at the row of each target vertex v_tj, plus the
 * pin coupling; cst (LANES, may be NULL) gets the energy constant. */
KERNEL void group_rhs(const dtx_sp04_plan *p, const double *restrict xg, double *restrict bg,
                      double *restrict cst, edge_scale_fn edge_scale)
{
    /* e[b][i][c][f]: coordinate c of edge i (e1, e2, e3) of the block's
     * source triangle b in lane f; q = |e1 x e2|^2, len = |e1 x e2|. */
    double e[SRC_BLOCK][3][3][LANES], q[SRC_BLOCK][LANES], len[SRC_BLOCK][LANES],
        h[SRC_BLOCK][LANES];
    int32_t k = 0;
    if (cst)
        for (int f = 0; f < LANES; f++)
            cst[f] = 0.0;
    for (int32_t a0 = 0; a0 < p->nsrc; a0 += SRC_BLOCK) {
        const int nb = p->nsrc - a0 < SRC_BLOCK ? (int)(p->nsrc - a0) : SRC_BLOCK;

        /* Edges and the normal n = e1 x e2 (kept in e[b][2] until scaled). */
        for (int b = 0; b < nb; b++) {
            const src_term *sd = &p->sterm[a0 + b];
            const double *x0 = xg + (size_t)sd->v[0] * VSTRIDE;
            const double *x1 = xg + (size_t)sd->v[1] * VSTRIDE;
            const double *x2 = xg + (size_t)sd->v[2] * VSTRIDE;
            double(*eb)[3][LANES] = e[b];
#pragma omp simd
            for (int f = 0; f < LANES; f++) {
                for (int c = 0; c < 3; c++) {
                    eb[0][c][f] = x1[c * LANES + f] - x0[c * LANES + f];
                    eb[1][c][f] = x2[c * LANES + f] - x0[c * LANES + f];
                }
                eb[2][0][f] = eb[0][1][f] * eb[1][2][f] - eb[0][2][f] * eb[1][1][f];
                eb[2][1][f] = eb[0][2][f] * eb[1][0][f] - eb[0][0][f] * eb[1][2][f];
                eb[2][2][f] = eb[0][0][f] * eb[1][1][f] - eb[0][1][f] * eb[1][0][f];
                q[b][f] = eb[2][0][f] * eb[2][0][f] + eb[2][1][f] * eb[2][1][f] +
                          eb[2][2][f] * eb[2][2][f];
            }
        }
        edge_scale(q[0], len[0], h[0], nb * LANES);

        for (int b = 0; b < nb; b++) {
            const src_term *sd = &p->sterm[a0 + b];
            double(*eb)[3][LANES] = e[b];
#pragma omp simd
            for (int f = 0; f < LANES; f++)
                for (int c = 0; c < 3; c++)
                    eb[2][c][f] *= h[b][f];

            if (cst) {
                const double *kk = sd->k;
#pragma omp simd
                for (int f = 0; f < LANES; f++) {
                    double aa = eb[0][0][f] * eb[0][0][f] + eb[0][1][f] * eb[0][1][f] +
                                eb[0][2][f] * eb[0][2][f];
                    double ab = eb[0][0][f] * eb[1][0][f] + eb[0][1][f] * eb[1][1][f] +
                                eb[0][2][f] * eb[1][2][f];
                    double bb = eb[1][0][f] * eb[1][0][f] + eb[1][1][f] * eb[1][1][f] +
                                eb[1][2][f] * eb[1][2][f];
                    cst[f] += kk[0] * aa + kk[1] * ab + kk[2] * bb + kk[3] * len[b][f];
                }
            }

            /* Each pair: E_s w_1 to tv[1], E_s w_2 to tv[2], minus both to tv[0]. */
            for (; k < sd->pair_end; k++) {
                const pair_term *pt = &p->pterm[k];
                const double *w1 = pt->w[0], *w2 = pt->w[1];
                double *b0 = bg + (size_t)pt->tv[0] * VSTRIDE;
                double *b1 = bg + (size_t)pt->tv[1] * VSTRIDE;
                double *b2 = bg + (size_t)pt->tv[2] * VSTRIDE;
UNROLL(3)
                for (int c = 0; c < 3; c++) {
#pragma omp simd
                    for (int f = 0; f < LANES; f++) {
                        double r1 = eb[0][c][f] * w1[0] + eb[1][c][f] * w1[1] +
                                    eb[2][c][f] * w1[2];
                        double r2 = eb[0][c][f] * w2[0] + eb[1][c][f] * w2[1] +
                                    eb[2][c][f] * w2[2];
                        b1[c * LANES + f] += r1;
                        b2[c * LANES + f] += r2;
                        b0[c * LANES + f] -= r1 + r2;
                    }
                }
            }
        }
    }

    if (p->npins > 0)
        for (int32_t r = 0; r < p->nfree; r++)
            for (int c = 0; c < 3; c++)
#pragma omp simd
                for (int f = 0; f < LANES; f++)
                    bg[(size_t)r * VSTRIDE + c * LANES + f] += p->pin_rhs[3 * (size_t)r + c];
}

/* Solves P L_ff P^T y = L D L^T y = b in place for the free rows of bg (all
 * lanes and coordinates at once).  wu (LANES, may be NULL) gets b . y = w . u
 * with w = L^-1 b and u = D^-1 w (see the file comment).  Both triangular
 * solves run over rows with the row kept in registers; the forward one does
 * the same operations in the same order as the column-oriented form. */
KERNEL void lanes_ldl_solve(const dtx_sp04_plan *p, double *restrict bg, double *restrict wu)
{
    const int32_t n = p->nfree;
    double acc[3][LANES];
    for (int c = 0; c < 3; c++)
        for (int f = 0; f < LANES; f++)
            acc[c][f] = 0.0;

    /* L w = b by rows: w_i = b_i - sum_j L_ij w_j. */
    for (int32_t i = 0; i < n; i++) {
        double *row = bg + (size_t)i * VSTRIDE;
        double w[VSTRIDE];
        memcpy(w, row, sizeof w);
        for (int32_t k = p->lrowptr[i]; k < p->lrowptr[i + 1]; k++) {
            const double *wj = bg + (size_t)p->lrowcol[k] * VSTRIDE;
            const double l = p->lrowval[k];
UNROLL(24)
            for (int m = 0; m < VSTRIDE; m++)
                w[m] -= l * wj[m];
        }
        memcpy(row, w, sizeof w);
    }

    /* L^T y = D^-1 w by rows of L^T from the last: y_j = u_j - sum_i L_ij
     * y_i with u_j = w_j / D_j, which also gives the energy term w_j u_j. */
    for (int32_t j = n - 1; j >= 0; j--) {
        double *row = bg + (size_t)j * VSTRIDE;
        double y[VSTRIDE];
        const double d = p->ldiag[j];
        for (int c = 0; c < 3; c++)
#pragma omp simd
            for (int f = 0; f < LANES; f++) {
                y[c * LANES + f] = row[c * LANES + f] / d;
                acc[c][f] += row[c * LANES + f] * y[c * LANES + f];
            }
        for (int32_t k = p->lcolptr[j]; k < p->lcolptr[j + 1]; k++) {
            const double *yi = bg + (size_t)p->lcolrow[k] * VSTRIDE;
            const double l = p->lcolval[k];
UNROLL(24)
            for (int m = 0; m < VSTRIDE; m++)
                y[m] -= l * yi[m];
        }
        memcpy(row, y, sizeof y);
    }
    if (wu)
        for (int f = 0; f < LANES; f++)
            wu[f] = acc[0][f] + acc[1][f] + acc[2][f];
}

/* Minimised energy of each frame of the group from the solve's w . u (see
 * the file comment): with the removed values x_p (pins; the anchor is 0 and
 * unreferenced vertices have no terms),
 *     E = cst + x_p^T L_pp x_p - 2 b_p . x_p - w . u,
 * and residual = sqrt(E / npairs) (NaN for a non-finite frame). */
KERNEL void group_residual(const dtx_sp04_plan *p, int64_t nfr, const double *cst,
                           const double *wu, const double *bg, double *residual)
{
    for (int64_t f = 0; f < nfr; f++) {
        double e = cst[f] + p->pin_energy, bp = 0.0;
        for (int32_t r = 0; r < p->nremoved; r++) {
            int32_t v = p->removed[r];
            for (int c = 0; c < 3; c++)
                bp += bg[(size_t)p->trow[v] * VSTRIDE + c * LANES + f] *
                      p->fixedval[3 * (size_t)v + c];
        }
        e -= 2.0 * bp + wu[f];
        /* Rounding can leave an exact fit slightly negative; a NaN (from a
         * non-finite frame) stays NaN so that callers can see it. */
        if (e < 0.0)
            e = 0.0;
        residual[f] = sqrt(e / (double)(p->npairs > 0 ? p->npairs : 1));
    }
}

/* Writes the group's nfr solved frames from bg into Xt (nfr x nv_t x 3),
 * zeroing bg for the next group.  Without pins (want non-NULL) each frame is
 * translated so that its centroid is want[f]: the solution is unique up to a
 * translation. */
KERNEL void write_frames(const dtx_sp04_plan *p, int64_t nfr, double *restrict bg,
                         const double (*want)[3], double *restrict Xt)
{
    const int32_t nv = p->nv_t;
    double d[3][LANES];

    /* The rows past the free ones get their vertices' fixed values (pins,
     * the anchor, unreferenced vertices' rest positions). */
    for (int32_t r = p->nfree; r < nv; r++) {
        const double *x = p->fixedval + 3 * (size_t)p->fixedrows[r - p->nfree];
        for (int c = 0; c < 3; c++)
            for (int f = 0; f < LANES; f++)
                bg[(size_t)r * VSTRIDE + c * LANES + f] = x[c];
    }
    /* Vertices in no face: their rest offset from the centroid of the
     * vertices in faces, added to that centroid in this frame. */
    if (p->nunref > 0) {
        double cref[3][LANES];
        for (int c = 0; c < 3; c++)
            for (int f = 0; f < LANES; f++)
                cref[c][f] = 0.0;
        for (int32_t r = 0; r < nv; r++)
            for (int c = 0; c < 3; c++)
                for (int f = 0; f < LANES; f++)
                    cref[c][f] += bg[(size_t)r * VSTRIDE + c * LANES + f];
        for (int32_t k = 0; k < p->nunref; k++)
            for (int c = 0; c < 3; c++)
                for (int f = 0; f < LANES; f++)
                    cref[c][f] -= bg[(size_t)p->unrefrows[k] * VSTRIDE + c * LANES + f];
        for (int c = 0; c < 3; c++)
            for (int f = 0; f < LANES; f++)
                cref[c][f] = cref[c][f] / (nv - p->nunref) - p->rest_centroid_ref[c];
        for (int32_t k = 0; k < p->nunref; k++)
            for (int c = 0; c < 3; c++)
                for (int f = 0; f < LANES; f++)
                    bg[(size_t)p->unrefrows[k] * VSTRIDE + c * LANES + f] += cref[c][f];
    }

    /* The translation d = want - centroid, the centroid summed in row order. */
    for (int c = 0; c < 3; c++)
        for (int f = 0; f < LANES; f++)
            d[c][f] = 0.0;
    if (want) {
        for (int32_t r = 0; r < nv; r++)
            for (int c = 0; c < 3; c++)
#pragma omp simd
                for (int f = 0; f < LANES; f++)
                    d[c][f] += bg[(size_t)r * VSTRIDE + c * LANES + f];
        for (int c = 0; c < 3; c++)
            for (int f = 0; f < nfr; f++)
                d[c][f] = want[f][c] - d[c][f] / nv;
    }

    for (int32_t v = 0; v < nv; v++) {
        double *row = bg + (size_t)p->trow[v] * VSTRIDE;
        if (v + PREFETCH_AHEAD < nv)
            prefetch_row(bg + (size_t)p->trow[v + PREFETCH_AHEAD] * VSTRIDE);
        if (want) {
            for (int64_t f = 0; f < nfr; f++)
                for (int c = 0; c < 3; c++)
                    Xt[(size_t)f * 3 * nv + 3 * (size_t)v + c] = row[c * LANES + f] + d[c][f];
        } else {
            for (int64_t f = 0; f < nfr; f++)
                for (int c = 0; c < 3; c++)
                    Xt[(size_t)f * 3 * nv + 3 * (size_t)v + c] = row[c * LANES + f];
        }
        /* A copy compiles to plain vector stores, where a loop or memset of
         * zeros becomes "rep stos" with its start-up cost on every row. */
        memcpy(row, zero_row, sizeof zero_row);
    }
}

/* Transfers the nfr (<= LANES) frames of one group, using worker w. */
KERNEL void solve_group(const dtx_sp04_plan *p, worker *w, int64_t nfr, const double *Xs,
                        double *Xt, double *residual, edge_scale_fn edge_scale)
{
    double cst[LANES], wu[LANES], cs[3][LANES], want[LANES][3];
    const int follow = p->npins == 0 && p->anchor == DTX_ANCHOR_FOLLOW;
    load_source_lanes(p, Xs, nfr, w->xg, follow ? cs : NULL);
    group_rhs(p, w->xg, w->bg, residual ? cst : NULL, edge_scale);
    lanes_ldl_solve(p, w->bg, residual ? wu : NULL);
    if (residual)
        group_residual(p, nfr, cst, wu, w->bg, residual);
    for (int64_t f = 0; f < nfr; f++)
        for (int k = 0; k < 3; k++)
            want[f][k] = p->rest_centroid_t[k] +
                         (follow ? p->scale * (cs[k][f] - p->rest_centroid_s[k]) : 0.0);
    write_frames(p, nfr, w->bg, p->npins == 0 ? (const double(*)[3])want : NULL, Xt);
}

/* The two variants' entry points (see "Kernel variants"). */
static void solve_group_baseline(const dtx_sp04_plan *p, worker *w, int64_t nfr,
                                 const double *Xs, double *Xt, double *residual)
{
    solve_group(p, w, nfr, Xs, Xt, residual, fourth_edge_scale);
}

#ifdef DTX_SP04_AVX2_VARIANT
__attribute__((target("avx2"))) static void solve_group_avx2(const dtx_sp04_plan *p, worker *w,
                                                             int64_t nfr, const double *Xs,
                                                             double *Xt, double *residual)
{
    solve_group(p, w, nfr, Xs, Xt, residual, fourth_edge_scale_avx);
}
#endif

int dtx_sp04_plan_use_avx2(dtx_sp04_plan *p, int on)
{
    p->avx2 = on && cpu_has_avx2();
    return p->avx2;
}

dtx_status dtx_sp04_plan_workers(dtx_sp04_plan *p, dtx_error *err)
{
    return dtx__workers_ensure(&p->workers, sizeof(worker), p, init_worker, fini_worker,
                               "solver workspaces", err);
}

void dtx_sp04_apply_group(dtx_sp04_plan *p, int wk, int64_t nfr, const double *Xs, double *Xt,
                          double *residual)
{
    worker *w;
    assert(wk >= 0 && wk < p->workers.n && nfr >= 1 && nfr <= DTX_SOLVE_GROUP);
    w = dtx__worker(&p->workers, wk);
#ifdef DTX_SP04_AVX2_VARIANT
    if (p->avx2)
        solve_group_avx2(p, w, nfr, Xs, Xt, residual);
    else
#endif
        solve_group_baseline(p, w, nfr, Xs, Xt, residual);
}

dtx_status dtx_sp04_apply(dtx_sp04_plan *p, int64_t nframes, const double *Xs, double *Xt,
                          double *residual, dtx_error *err)
{
    int64_t ngroups = (nframes + DTX_SOLVE_GROUP - 1) / DTX_SOLVE_GROUP;
    dtx_status st = dtx_sp04_plan_workers(p, err);
    if (st != DTX_OK)
        return st;
#pragma omp parallel for schedule(dynamic, 1)
    for (int64_t g = 0; g < ngroups; g++) {
        int tid = 0;
        int64_t f0 = g * DTX_SOLVE_GROUP;
        int64_t nfr = nframes - f0 < DTX_SOLVE_GROUP ? nframes - f0 : DTX_SOLVE_GROUP;
#ifdef _OPENMP
        tid = omp_get_thread_num();
#endif
        dtx_sp04_apply_group(p, tid, nfr, Xs + (size_t)f0 * 3 * p->nv_s,
                             Xt + (size_t)f0 * 3 * p->nv_t, residual ? residual + f0 : NULL);
    }
    return DTX_OK;
}

/* ------------------------------------------------------------------ */
/* Benchmark hooks                                                      */
/* ------------------------------------------------------------------ */

double dtx_sp04_plan_bare_solve_seconds_group(dtx_sp04_plan *p, int frames_per_solve, int nrep)
{
    cholmod_common cc;
    cholmod_dense *B, *X = NULL, *Y = NULL, *E = NULL;
    double t0, t;
    if (frames_per_solve < 1)
        return -1.0;
    dtx__chol_start(&cc, DTX__CHOL_AUTO, DTX__CHOL_ORDER_DEFAULT);
    B = cholmod_ones((size_t)p->nfree, 3 * (size_t)frames_per_solve, CHOLMOD_REAL, &cc);
    if (!B) {
        cholmod_finish(&cc);
        return -1.0;
    }
    cholmod_solve2(CHOLMOD_A, p->L, B, NULL, &X, NULL, &Y, &E, &cc); /* warm-up */
    t0 = dtx__now_seconds();
    for (int r = 0; r < nrep; r++)
        cholmod_solve2(CHOLMOD_A, p->L, B, NULL, &X, NULL, &Y, &E, &cc);
    t = (dtx__now_seconds() - t0) / (nrep > 0 ? nrep : 1) / frames_per_solve;
    cholmod_free_dense(&B, &cc);
    cholmod_free_dense(&X, &cc);
    cholmod_free_dense(&Y, &cc);
    cholmod_free_dense(&E, &cc);
    cholmod_finish(&cc);
    return t;
}

double dtx_sp04_plan_bare_solve_seconds(dtx_sp04_plan *p, int nrep)
{
    return dtx_sp04_plan_bare_solve_seconds_group(p, 1, nrep);
}

/* ------------------------------------------------------------------ */
/* The method table (transfer.h)                                       */
/* ------------------------------------------------------------------ */

/* The table's plan: the sp04 plan and the residuals of the last apply. */
typedef struct {
    dtx_sp04_plan *plan;
    void *res; /* res_cap doubles */
    int64_t res_cap;
} sp04_method_plan;

static void sp04_method_free(void **plan)
{
    sp04_method_plan *p = *plan;
    if (!p)
        return;
    dtx_sp04_plan_free(&p->plan);
    free(p->res);
    free(p);
    *plan = NULL;
}

static dtx_status sp04_method_create(const dtx_transfer_inputs *in, const dtx_transfer_params *prm,
                                     void **plan, dtx_error *err)
{
    sp04_method_plan *p = dtx_alloc(1, sizeof *p, 1);
    dtx_status st;
    (void)prm;
    *plan = NULL;
    if (!p)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory");
    st = dtx_sp04_plan_create(in->src, in->tgt, in->pairs, in->npairs, in->anchor, in->pins,
                              in->pin_pos, in->npins, &p->plan, err);
    *plan = p;
    if (st != DTX_OK)
        sp04_method_free(plan);
    return st;
}

/* What sp04 reports of n frames: the residuals res; it does not iterate. */
static void sp04_frame_info(dtx_frame_info *info, const double *res, int64_t n)
{
    for (int64_t i = 0; i < n; i++) {
        info[i].residual = res[i];
        info[i].iterations = info[i].converged = info[i].inverted = -1;
        info[i].grad_norm = NAN;
    }
}

static dtx_status sp04_method_apply(void *plan, int64_t nframes, const double *Xs, double *Xt,
                                    dtx_frame_info *info, dtx_error *err)
{
    sp04_method_plan *p = plan;
    dtx_status st = dtx_transfer_scratch(&p->res, &p->res_cap, nframes, sizeof(double), err);
    if (st == DTX_OK)
        st = dtx_sp04_apply(p->plan, nframes, Xs, Xt, p->res, err);
    if (st == DTX_OK)
        sp04_frame_info(info, p->res, nframes);
    return st;
}

static dtx_status sp04_method_team_prepare(void *plan, dtx_error *err)
{
    sp04_method_plan *p = plan;
    return dtx_sp04_plan_workers(p->plan, err);
}

static void sp04_method_team_apply(void *plan, int64_t nframes, const double *Xs, double *Xt,
                                   dtx_frame_info *info, int64_t *next)
{
    sp04_method_plan *p = plan;
    const int64_t ngroups = (nframes + DTX_SOLVE_GROUP - 1) / DTX_SOLVE_GROUP;
    const int32_t nv_s = p->plan->nv_s, nv_t = p->plan->nv_t;
    int tid = 0;
#ifdef _OPENMP
    tid = omp_get_thread_num();
#endif
    for (;;) {
        double res[DTX_SOLVE_GROUP];
        int64_t g, f0, nfr;
#ifdef _OPENMP
#pragma omp atomic capture
#endif
        g = (*next)++;
        if (g >= ngroups)
            return;
        f0 = g * DTX_SOLVE_GROUP;
        nfr = nframes - f0 < DTX_SOLVE_GROUP ? nframes - f0 : DTX_SOLVE_GROUP;
        dtx_sp04_apply_group(p->plan, tid, nfr, Xs + (size_t)f0 * 3 * nv_s,
                             Xt + (size_t)f0 * 3 * nv_t, res);
        sp04_frame_info(info + f0, res, nfr);
    }
}

static void sp04_method_describe(const void *plan, char *buf, size_t size)
{
    (void)plan;
    if (size > 0)
        buf[0] = '\0';
}

const dtx_transfer_method dtx_method_sp04 = {
    .name = "sp04",
    .kind = DTX_TRANSFER_SP04,
    .iterative = 0,
    .solve_group = DTX_SP04_SOLVE_GROUP,
    .correspondence = DTX_TRANSFER_CORR_SP04,
    .uses_pairs = 1,
    .plan_create = sp04_method_create,
    .apply = sp04_method_apply,
    .team_prepare = sp04_method_team_prepare,
    .team_apply = sp04_method_team_apply,
    .plan_free = sp04_method_free,
    .describe = sp04_method_describe,
};
