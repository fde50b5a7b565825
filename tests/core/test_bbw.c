/*
 * test_bbw.c: the cotangent Laplacian and mass matrix (laplacian.h), bounded
 * and incremental unbounded biharmonic weights and farthest point sampling
 * (bbw.h), on small generated meshes (always runs; the cactus is in
 * test_bbw_cactus.c).
 */
#include "bbw.h"
#include "laplacian.h"
#include "meshgen.h"

#include "check.h"
#include "bbw_checks.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------ */
/* Helpers                                                             */
/* ------------------------------------------------------------------ */

/* Unbounded weights sum to 1 up to the conditioning of Q restricted to the
 * free vertices (the solves' forward error, ~1e-11 here). */
#define UNBOUNDED_SUM_TOL 1e-10

static double csr_get(const dtx_csr *A, int32_t i, int32_t j)
{
    for (int64_t p = A->rowptr[i]; p < A->rowptr[i + 1]; p++)
        if (A->col[p] == j)
            return A->val[p];
    return 0.0;
}

static void csr_mul(const dtx_csr *A, const double *x, double *y)
{
    for (int32_t i = 0; i < A->n; i++) {
        double s = 0.0;
        for (int64_t p = A->rowptr[i]; p < A->rowptr[i + 1]; p++)
            s += A->val[p] * x[A->col[p]];
        y[i] = s;
    }
}

/* y = L M^-1 L x. */
static void q_mul(const dtx_csr *L, const double *M, const double *x, double *t, double *y)
{
    csr_mul(L, x, t);
    for (int32_t i = 0; i < L->n; i++)
        t[i] /= M[i];
    csr_mul(L, t, y);
}

static double face_area(const dtx_mesh *m, int32_t f)
{
    const double *a = m->V + 3 * m->F[3 * f], *b = m->V + 3 * m->F[3 * f + 1],
                 *c = m->V + 3 * m->F[3 * f + 2];
    double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    double e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                   e1[0] * e2[1] - e1[1] * e2[0]};
    return 0.5 * sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
}

/* A flat n x n grid in z = 0 with jittered vertices (no symmetry, so no
 * exact ties in distances), alternating diagonals. */
static void gen_grid(int n, dtx_mesh *m)
{
    int32_t f = 0;
    dtx_mesh_alloc(m, n * n, 2 * (n - 1) * (n - 1), NULL);
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++) {
            double *x = m->V + 3 * (j * n + i);
            x[0] = i + 0.3 * sin(12.9898 * i + 78.233 * j);
            x[1] = j + 0.3 * cos(39.3468 * i + 11.135 * j);
            x[2] = 0.0;
        }
    for (int j = 0; j + 1 < n; j++)
        for (int i = 0; i + 1 < n; i++) {
            int32_t a = j * n + i, b = a + 1, c = a + n, d = c + 1;
            int32_t *t = m->F + 3 * f;
            if ((i + j) % 2) {
                t[0] = a, t[1] = b, t[2] = d, t[3] = a, t[4] = d, t[5] = c;
            } else {
                t[0] = a, t[1] = b, t[2] = c, t[3] = b, t[4] = d, t[5] = c;
            }
            f += 2;
        }
}

/* Two capsules side by side (two components). */
static void gen_two_capsules(dtx_mesh *m)
{
    dtx_mesh a = {0};
    gen_capsule(12, 8, 1.5, &a);
    dtx_mesh_alloc(m, 2 * a.nv, 2 * a.nf, NULL);
    memcpy(m->V, a.V, (size_t)a.nv * 3 * sizeof *a.V);
    memcpy(m->F, a.F, (size_t)a.nf * 3 * sizeof *a.F);
    for (int32_t i = 0; i < a.nv; i++) {
        m->V[3 * (a.nv + i)] = a.V[3 * i] + 5.0;
        m->V[3 * (a.nv + i) + 1] = a.V[3 * i + 1];
        m->V[3 * (a.nv + i) + 2] = a.V[3 * i + 2];
    }
    for (int32_t k = 0; k < 3 * a.nf; k++)
        m->F[3 * a.nf + k] = a.F[k] + a.nv;
    dtx_mesh_free(&a);
}

/* ------------------------------------------------------------------ */
/* Laplacian and mass                                                  */
/* ------------------------------------------------------------------ */

static void test_small_triangles(void)
{
    dtx_error err = {0};
    dtx_csr L = {0};
    double M[3];
    int32_t F[3] = {0, 1, 2}, thin = -1;
    double eq[9] = {0, 0, 0, 1, 0, 0, 0.5, sqrt(3.0) / 2, 0};
    double right[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    double obtuse[9] = {0, 0, 0, 2, 0, 0, 1, 0.2, 0};

    /* Equilateral, side 1: every cotangent is 1/sqrt(3). */
    CHECK_OK(dtx_cotan_laplacian(eq, 3, F, 1, &L, &thin, &err), &err);
    CHECK_EQ_INT(L.nnz, 9);
    CHECK_EQ_INT(thin, 0);
    CHECK_NEAR(csr_get(&L, 0, 1), -0.5 / sqrt(3.0), 1e-15);
    CHECK_NEAR(csr_get(&L, 1, 2), -0.5 / sqrt(3.0), 1e-15);
    CHECK_NEAR(csr_get(&L, 2, 2), 1.0 / sqrt(3.0), 1e-15);
    dtx_csr_free(&L);
    CHECK_OK(dtx_mass_voronoi(eq, 3, F, 1, M, NULL, &err), &err);
    for (int k = 0; k < 3; k++)
        CHECK_NEAR(M[k], sqrt(3.0) / 12, 1e-15);

    /* Right angle at vertex 0: the hypotenuse gets cot 90 = 0, the legs
     * cot 45 / 2; Voronoi areas 1/4 at the right angle, 1/8 elsewhere. */
    CHECK_OK(dtx_cotan_laplacian(right, 3, F, 1, &L, NULL, &err), &err);
    CHECK_NEAR(csr_get(&L, 1, 2), 0.0, 1e-15);
    CHECK_NEAR(csr_get(&L, 0, 1), -0.5, 1e-15);
    CHECK_NEAR(csr_get(&L, 0, 2), -0.5, 1e-15);
    CHECK_NEAR(csr_get(&L, 0, 0), 1.0, 1e-15);
    dtx_csr_free(&L);
    CHECK_OK(dtx_mass_voronoi(right, 3, F, 1, M, NULL, &err), &err);
    CHECK_NEAR(M[0], 0.25, 1e-15);
    CHECK_NEAR(M[1], 0.125, 1e-15);
    CHECK_NEAR(M[2], 0.125, 1e-15);

    /* Obtuse at vertex 2 (area 0.2): A/2 there, A/4 at the others; its
     * cotangent is negative and kept. */
    CHECK_OK(dtx_mass_voronoi(obtuse, 3, F, 1, M, NULL, &err), &err);
    CHECK_NEAR(M[2], 0.1, 1e-15);
    CHECK_NEAR(M[0], 0.05, 1e-15);
    CHECK_NEAR(M[1], 0.05, 1e-15);
    CHECK_OK(dtx_cotan_laplacian(obtuse, 3, F, 1, &L, NULL, &err), &err);
    /* cot at vertex 2 = (e20 . e21) / |e20 x e21| = (-1*1 + -0.2*-0.2) / 0.4. */
    CHECK_NEAR(csr_get(&L, 0, 1), -0.5 * (-1.0 + 0.04) / 0.4, 1e-14);
    CHECK_DBL(csr_get(&L, 0, 1), >, 0.0);
    dtx_csr_free(&L);

    /* Bad arguments. */
    CHECK_EQ_INT(dtx_cotan_laplacian(eq, 0, F, 1, &L, NULL, &err), DTX_EINVAL);
    CHECK(check_contains(err.msg, "cotangent Laplacian"));
    CHECK_EQ_INT(dtx_mass_voronoi(NULL, 3, F, 1, M, NULL, &err), DTX_EINVAL);
}

/* L symmetric bitwise, rows summing to 0, M > 0 adding up to the area,
 * u' L u >= 0. */
static void check_operators(const dtx_mesh *m, const char *name)
{
    dtx_error err = {0};
    dtx_csr L = {0};
    double *M = malloc((size_t)m->nv * sizeof *M), *u = calloc((size_t)m->nv, sizeof *u);
    double *Lu = malloc((size_t)m->nv * sizeof *Lu), area = 0.0, msum = 0.0, worst = 0.0, uLu;
    int symmetric = 1;
    int32_t nonpos = 0;

    printf("operators on %s (%d vertices)\n", name, (int)m->nv);
    CHECK_OK(dtx_cotan_laplacian(m->V, m->nv, m->F, m->nf, &L, NULL, &err), &err);
    CHECK_OK(dtx_mass_voronoi(m->V, m->nv, m->F, m->nf, M, NULL, &err), &err);
    for (int32_t i = 0; i < m->nv; i++) {
        double s = 0.0;
        for (int64_t p = L.rowptr[i]; p < L.rowptr[i + 1]; p++) {
            s += L.val[p];
            symmetric &= csr_get(&L, L.col[p], i) == L.val[p];
            if (p > L.rowptr[i])
                CHECK(L.col[p] > L.col[p - 1]);
        }
        worst = fmax(worst, fabs(s) / csr_get(&L, i, i));
        nonpos += !(M[i] > 0.0);
        msum += M[i];
    }
    CHECK(symmetric);
    CHECK_DBL(worst, <=, 1e-13);
    CHECK_EQ_INT(nonpos, 0);
    for (int32_t f = 0; f < m->nf; f++)
        area += face_area(m, f);
    CHECK_NEAR(msum / area, 1.0, 1e-12);
    for (int32_t i = 0; i < m->nv; i++)
        u[i] = sin(3.0 * m->V[3 * i]) + m->V[3 * i + 1] * m->V[3 * i + 2];
    csr_mul(&L, u, Lu);
    uLu = 0.0;
    for (int32_t i = 0; i < m->nv; i++)
        uLu += u[i] * Lu[i];
    CHECK_DBL(uLu, >, 0.0);
    dtx_csr_free(&L);
    free(M);
    free(u);
    free(Lu);
}

static void test_operators(void)
{
    dtx_mesh cap = {0}, grid = {0};
    dtx_error err = {0};
    dtx_csr L = {0};
    double *lin, *Llin;
    double worst = 0.0;
    int n = 9;

    gen_capsule(24, 16, 1.5, &cap);
    check_operators(&cap, "a capsule");

    /* Linear precision: L u = 0 at the interior vertices of a flat mesh
     * for any linear u, obtuse triangles included. */
    gen_grid(n, &grid);
    check_operators(&grid, "a jittered grid");
    CHECK_OK(dtx_cotan_laplacian(grid.V, grid.nv, grid.F, grid.nf, &L, NULL, &err), &err);
    lin = malloc((size_t)grid.nv * sizeof *lin);
    Llin = malloc((size_t)grid.nv * sizeof *Llin);
    for (int32_t i = 0; i < grid.nv; i++)
        lin[i] = 2.0 * grid.V[3 * i] - 3.0 * grid.V[3 * i + 1] + 1.0;
    csr_mul(&L, lin, Llin);
    for (int j = 1; j < n - 1; j++)
        for (int i = 1; i < n - 1; i++)
            worst = fmax(worst, fabs(Llin[j * n + i]));
    CHECK_DBL(worst, <=, 1e-12);
    dtx_csr_free(&L);
    free(lin);
    free(Llin);
    dtx_mesh_free(&cap);
    dtx_mesh_free(&grid);
}

static void test_degenerate(void)
{
    /* A square split into two triangles, plus a zero-area triangle (three
     * collinear points on the edge 0-1) and a needle. */
    double V[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0.5, 0, 0, 0.5, -1e-9, 0};
    int32_t F[] = {0, 1, 2, 0, 2, 3, 0, 4, 1, 0, 5, 1};
    dtx_error err = {0};
    dtx_csr L = {0};
    double M[6];
    int32_t thin = 0, zero = -1, finite = 1;

    CHECK_OK(dtx_cotan_laplacian(V, 6, F, 4, &L, &thin, &err), &err);
    CHECK_EQ_INT(thin, 2);
    for (int64_t p = 0; p < L.nnz; p++)
        finite &= isfinite(L.val[p]);
    CHECK(finite);
    CHECK_OK(dtx_mass_voronoi(V, 6, F, 4, M, &zero, &err), &err);
    CHECK_EQ_INT(zero, 0);
    for (int k = 0; k < 6; k++)
        CHECK_DBL(M[k], >, 0.0);
    dtx_csr_free(&L);

    /* A vertex in no face gets the smallest mass and an empty row. */
    CHECK_OK(dtx_cotan_laplacian(V, 6, F, 2, &L, NULL, &err), &err);
    CHECK_EQ_INT(L.rowptr[5] - L.rowptr[4], 1);
    CHECK_DBL(L.val[L.rowptr[4]], ==, 0.0);
    CHECK_OK(dtx_mass_voronoi(V, 6, F, 2, M, &zero, &err), &err);
    CHECK_EQ_INT(zero, 2);
    CHECK_DBL(M[4], >, 0.0);
    dtx_csr_free(&L);
}

/* ------------------------------------------------------------------ */
/* Bounded weights                                                     */
/* ------------------------------------------------------------------ */

/* A claim function (dtx_bbw_claim_fn) handing out the handles of a list,
 * one at a time. */
typedef struct {
    const int32_t *order;
    int32_t n, next;
} claim_list;

static int32_t claim_next(void *ctx, int32_t m, int32_t want, int32_t *k0)
{
    claim_list *l = ctx;
    (void)m;
    if (want < 1 || l->next >= l->n)
        return 0;
    *k0 = l->order[l->next++];
    return 1;
}

/* KKT conditions of each handle's programme (normalise = 0). */
static void check_kkt(const dtx_mesh *m, const double *W, const int32_t *h, int32_t mh)
{
    dtx_error err = {0};
    dtx_csr L = {0};
    int32_t nv = m->nv;
    double *M = malloc((size_t)nv * sizeof *M), *x = malloc((size_t)nv * sizeof *x);
    double *t = malloc((size_t)nv * sizeof *t), *g = malloc((size_t)nv * sizeof *g);
    unsigned char *is_h = calloc((size_t)nv, 1);
    double bad_free = 0.0, bad_lo = 0.0, bad_hi = 0.0;

    CHECK_OK(dtx_cotan_laplacian(m->V, nv, m->F, m->nf, &L, NULL, &err), &err);
    CHECK_OK(dtx_mass_voronoi(m->V, nv, m->F, m->nf, M, NULL, &err), &err);
    for (int32_t k = 0; k < mh; k++)
        is_h[h[k]] = 1;
    for (int32_t k = 0; k < mh; k++) {
        double scale = 0.0;
        for (int32_t i = 0; i < nv; i++)
            x[i] = W[(size_t)i * mh + k];
        q_mul(&L, M, x, t, g);
        for (int32_t i = 0; i < nv; i++)
            scale = fmax(scale, fabs(g[i]));
        for (int32_t i = 0; i < nv; i++) {
            double r = g[i] / scale;
            if (is_h[i])
                continue;
            if (x[i] == 0.0)
                bad_lo = fmax(bad_lo, -r);
            else if (x[i] == 1.0)
                bad_hi = fmax(bad_hi, r);
            else
                bad_free = fmax(bad_free, fabs(r));
        }
    }
    /* Multipliers relative to the largest gradient (at the handles). */
    CHECK_DBL(bad_free, <=, 1e-9);
    CHECK_DBL(bad_lo, <=, 1e-9);
    CHECK_DBL(bad_hi, <=, 1e-9);
    dtx_csr_free(&L);
    free(M);
    free(x);
    free(t);
    free(g);
    free(is_h);
}

static void test_bbw(void)
{
    dtx_mesh cap = {0};
    dtx_error err = {0};
    dtx_bbw_params prm;
    dtx_bbw_info info;
    int32_t h[5] = {0, 100, 200, 300, 385};
    int32_t m = 5, nv;
    double *W, *W1, *Wraw, *U;
    dtx_bbw_incr *ctx = NULL;
    int32_t viol;

    gen_capsule(24, 16, 1.5, &cap);
    nv = cap.nv;
    W = malloc((size_t)nv * m * sizeof *W);
    W1 = malloc((size_t)nv * m * sizeof *W1);
    Wraw = malloc((size_t)nv * m * sizeof *Wraw);
    U = malloc((size_t)nv * m * sizeof *U);

    omp_set_num_threads(2);
    CHECK_OK(dtx_bbw(&cap, h, m, NULL, W, &info, &err), &err);
    check_weights(W, nv, h, m, 1e-12, 0.0, 1.0);
    CHECK_EQ_INT(info.not_converged, 0);
    CHECK_EQ_INT(info.low_sum, 0);
    CHECK_INT(info.iterations_max, >=, 2);
    printf("bbw on the capsule: %d iterations at most, %lld in all, row sums before "
           "normalising in [%.4f, %.4f]\n",
           info.iterations_max, (long long)info.iterations_total, info.sum_min, info.sum_max);
    /* The same bits on one thread. */
    omp_set_num_threads(1);
    CHECK_OK(dtx_bbw(&cap, h, m, NULL, W1, NULL, &err), &err);
    CHECK(memcmp(W, W1, (size_t)nv * m * sizeof *W) == 0);
    omp_set_num_threads(2);

    /* Handles dealt out by a claim function, in any order and any batch
     * size, give the rows of dtx_bbw_handles bit for bit, and leave the
     * rows they were not handed alone. */
    {
        double *Wk = malloc((size_t)nv * m * sizeof *Wk), *Wc = malloc((size_t)nv * m * sizeof *Wc);
        static const int32_t order_a[] = {4, 1, 3, 0, 2}, order_b[] = {3, 1};
        claim_list la = {order_a, 5, 0}, lb = {order_b, 2, 0}, lbad = {order_a, 5, 0};
        static const int32_t bad[] = {5};
        CHECK_OK(dtx_bbw_handles(&cap, h, m, 0, m, NULL, Wk, NULL, &err), &err);
        /* A thread keeps its first factorisation for its next handles:
         * each handle alone (a factorisation of its own) gives the same
         * bits. */
        for (size_t i = 0; i < (size_t)nv * m; i++)
            Wc[i] = -7.0;
        for (int32_t k = 0; k < m; k++)
            CHECK_OK(dtx_bbw_handles(&cap, h, m, k, k + 1, NULL, Wc + (size_t)k * nv, NULL, &err),
                     &err);
        CHECK(memcmp(Wk, Wc, (size_t)nv * m * sizeof *Wk) == 0);
        CHECK_OK(dtx_bbw_handles_claim(&cap, h, m, claim_next, &la, NULL, Wc, NULL, &err), &err);
        CHECK(memcmp(Wk, Wc, (size_t)nv * m * sizeof *Wk) == 0);
        CHECK_EQ_INT(la.next, 5);
        for (size_t i = 0; i < (size_t)nv * m; i++)
            Wc[i] = -7.0;
        CHECK_OK(dtx_bbw_handles_claim(&cap, h, m, claim_next, &lb, NULL, Wc, &info, &err), &err);
        for (int32_t k = 0; k < m; k++) {
            int handed = k == 1 || k == 3;
            for (int32_t i = 0; i < nv; i++) {
                double v = Wc[(size_t)k * nv + i];
                if (handed ? v != Wk[(size_t)k * nv + i] : v != -7.0) {
                    fprintf(stderr, "claimed rows: handle %d vertex %d: %.17g\n", (int)k,
                            (int)i, v);
                    CHECK(0);
                    k = m;
                    break;
                }
            }
        }
        CHECK_INT(info.iterations_max, >=, 2);
        lbad.order = bad;
        lbad.n = 1;
        CHECK_EQ_INT(dtx_bbw_handles_claim(&cap, h, m, claim_next, &lbad, NULL, Wc, NULL, &err),
                     DTX_ERANGE);
        CHECK_EQ_INT(dtx_bbw_handles_claim(&cap, h, m, NULL, NULL, NULL, Wc, NULL, &err),
                     DTX_EINVAL);
        free(Wk);
        free(Wc);
    }

    /* Without normalisation: each column is its programme's exact
     * minimiser. */
    dtx_bbw_params_default(&prm);
    prm.normalise = 0;
    CHECK_OK(dtx_bbw(&cap, h, m, &prm, Wraw, NULL, &err), &err);
    check_kkt(&cap, Wraw, h, m);
    /* Normalising is all that separates the two. */
    for (int32_t i = 0; i < nv; i++) {
        double s = 0.0;
        for (int32_t k = 0; k < m; k++)
            s += Wraw[(size_t)i * m + k];
        for (int32_t k = 0; k < m; k++)
            Wraw[(size_t)i * m + k] /= s;
    }
    CHECK_DBL(max_abs_diff(Wraw, W, (size_t)nv * m), <=, 1e-15);

    /* The unbounded weights leave [0, 1] here (otherwise the test would
     * not exercise the active set); clamped and renormalised they are an
     * approximation of the bounded ones. */
    CHECK_OK(dtx_bbw_incr_create(&cap, h, m, &ctx, &err), &err);
    memcpy(U, dtx_bbw_incr_weights(ctx), (size_t)nv * m * sizeof *U);
    check_weights(U, nv, h, m, UNBOUNDED_SUM_TOL, -INFINITY, INFINITY);
    viol = dtx_bbw_clamp_normalise(U, nv, m, NULL);
    CHECK_INT(viol, >, 0);
    check_weights(U, nv, h, m, 1e-12, 0.0, 1.0);
    printf("unbounded weights on the capsule: %d of %d vertices out of [0, 1]; clamped, "
           "max |W - W_bbw| = %.3g\n",
           (int)viol, (int)nv, max_abs_diff(U, W, (size_t)nv * m));
    dtx_bbw_incr_free(&ctx);

    /* One handle: w = 1 everywhere. */
    CHECK_OK(dtx_bbw(&cap, h, 1, NULL, W, NULL, &err), &err);
    check_weights(W, nv, h, 1, 0.0, 1.0, 1.0);

    free(W);
    free(W1);
    free(Wraw);
    free(U);
    dtx_mesh_free(&cap);
}

/* ------------------------------------------------------------------ */
/* Incremental unbounded weights                                       */
/* ------------------------------------------------------------------ */

/* Weights of handles h from scratch (a fresh context). */
static void scratch(const dtx_mesh *mesh, const int32_t *h, int32_t m, double *W)
{
    dtx_error err = {0};
    dtx_bbw_incr *c = NULL;
    CHECK_OK(dtx_bbw_incr_create(mesh, h, m, &c, &err), &err);
    if (c)
        memcpy(W, dtx_bbw_incr_weights(c), (size_t)mesh->nv * m * sizeof *W);
    dtx_bbw_incr_free(&c);
}

static void test_incremental(void)
{
    dtx_mesh cap = {0};
    dtx_error err = {0};
    int32_t h[4] = {7, 150, 290, 384}, m = 4, nv;
    int32_t cands[6] = {0, 40, 99, 222, 300, 385};
    int32_t hh[5];
    double *Wc, *Ws, worst_add = 0.0, worst_rep = 0.0;
    dtx_bbw_incr *ctx = NULL;
    dtx_bbw_work *work = NULL;

    gen_capsule(24, 16, 1.5, &cap);
    nv = cap.nv;
    Wc = malloc((size_t)nv * (m + 2) * sizeof *Wc);
    Ws = malloc((size_t)nv * (m + 2) * sizeof *Ws);
    CHECK_OK(dtx_bbw_incr_create(&cap, h, m, &ctx, &err), &err);
    work = dtx_bbw_work_new(ctx);
    CHECK(work != NULL);
    CHECK_EQ_INT(dtx_bbw_incr_count(ctx), m);
    CHECK_EQ_INT(dtx_bbw_incr_nv(ctx), nv);
    CHECK(memcmp(dtx_bbw_incr_handles(ctx), h, sizeof h) == 0);
    check_weights(dtx_bbw_incr_weights(ctx), nv, h, m, UNBOUNDED_SUM_TOL, -INFINITY, INFINITY);

    for (int t = 0; t < 6; t++) {
        int32_t c = cands[t];
        double *g = malloc((size_t)nv * sizeof *g);
        /* The _g variants with c's Green's function computed beforehand
         * give the bits of the plain ones, and leave g alone. */
        CHECK_OK(dtx_bbw_incr_green(ctx, c, g, work, &err), &err);
        CHECK_NEAR(g[h[0]], 0.0, 0.0);
        CHECK_DBL(g[c], >, 0.0);
        CHECK_OK(dtx_bbw_incr_weights_add_g(ctx, c, g, Ws, work, &err), &err);
        CHECK_OK(dtx_bbw_incr_weights_add(ctx, c, Wc, work, &err), &err);
        CHECK(memcmp(Wc, Ws, (size_t)nv * (m + 1) * sizeof *Wc) == 0);
        for (int32_t j = 0; j < m; j++) {
            CHECK_OK(dtx_bbw_incr_weights_replace_g(ctx, j, c, g, Ws, work, &err), &err);
            CHECK_OK(dtx_bbw_incr_weights_replace(ctx, j, c, Wc, work, &err), &err);
            CHECK(memcmp(Wc, Ws, (size_t)nv * m * sizeof *Wc) == 0);
        }
        CHECK_OK(dtx_bbw_incr_green(ctx, c, Ws, work, &err), &err);
        CHECK(memcmp(g, Ws, (size_t)nv * sizeof *g) == 0);
        free(g);
        /* One more handle. */
        CHECK_OK(dtx_bbw_incr_weights_add(ctx, c, Wc, work, &err), &err);
        memcpy(hh, h, sizeof h);
        hh[m] = c;
        scratch(&cap, hh, m + 1, Ws);
        worst_add = fmax(worst_add, max_abs_diff(Wc, Ws, (size_t)nv * (m + 1)));
        check_weights(Wc, nv, hh, m + 1, UNBOUNDED_SUM_TOL, -INFINITY, INFINITY);
        /* Handle j moved to c. */
        for (int32_t j = 0; j < m; j++) {
            CHECK_OK(dtx_bbw_incr_weights_replace(ctx, j, c, Wc, work, &err), &err);
            memcpy(hh, h, sizeof h);
            hh[j] = c;
            scratch(&cap, hh, m, Ws);
            worst_rep = fmax(worst_rep, max_abs_diff(Wc, Ws, (size_t)nv * m));
            check_weights(Wc, nv, hh, m, UNBOUNDED_SUM_TOL, -INFINITY, INFINITY);
        }
    }
    printf("incremental vs from scratch on the capsule: add %.3g, replace %.3g\n", worst_add,
           worst_rep);
    CHECK_DBL(worst_add, <=, 1e-10);
    CHECK_DBL(worst_rep, <=, 1e-10);
    /* Moving a handle onto itself: the current weights. */
    CHECK_OK(dtx_bbw_incr_weights_replace(ctx, 2, h[2], Wc, work, &err), &err);
    CHECK(memcmp(Wc, dtx_bbw_incr_weights(ctx), (size_t)nv * m * sizeof *Wc) == 0);

    /* Concurrent evaluations (one workspace per thread) give the serial
     * answers. */
    {
        double *par = malloc((size_t)6 * nv * (m + 1) * sizeof *par);
        double *ser = malloc((size_t)nv * (m + 1) * sizeof *ser);
        int same = 1;
#pragma omp parallel num_threads(2)
        {
            dtx_error e = {0};
            dtx_bbw_work *w = dtx_bbw_work_new(ctx);
#pragma omp for schedule(dynamic, 1)
            for (int t = 0; t < 6; t++)
                if (!w || dtx_bbw_incr_weights_add(ctx, cands[t], par + (size_t)t * nv * (m + 1),
                                                   w, &e) != DTX_OK)
                    par[(size_t)t * nv * (m + 1)] = NAN;
            dtx_bbw_work_free(&w);
        }
        for (int t = 0; t < 6; t++) {
            CHECK_OK(dtx_bbw_incr_weights_add(ctx, cands[t], ser, work, &err), &err);
            same &= memcmp(ser, par + (size_t)t * nv * (m + 1),
                           (size_t)nv * (m + 1) * sizeof *ser) == 0;
        }
        CHECK(same);
        free(par);
        free(ser);
    }

    /* Commits: the context's weights equal a fresh context's. */
    CHECK_OK(dtx_bbw_incr_add(ctx, 222, &err), &err);
    CHECK_EQ_INT(dtx_bbw_incr_count(ctx), m + 1);
    memcpy(hh, h, sizeof h);
    hh[m] = 222;
    scratch(&cap, hh, m + 1, Ws);
    CHECK(memcmp(Ws, dtx_bbw_incr_weights(ctx), (size_t)nv * (m + 1) * sizeof *Ws) == 0);
    CHECK_OK(dtx_bbw_incr_replace(ctx, 1, 99, &err), &err);
    hh[1] = 99;
    scratch(&cap, hh, m + 1, Ws);
    CHECK(memcmp(Ws, dtx_bbw_incr_weights(ctx), (size_t)nv * (m + 1) * sizeof *Ws) == 0);
    CHECK(memcmp(dtx_bbw_incr_handles(ctx), hh, sizeof hh) == 0);
    /* The old workspace still works after the commits. */
    CHECK_OK(dtx_bbw_incr_weights_add(ctx, 5, Wc, work, &err), &err);
    {
        int32_t h6[6];
        memcpy(h6, hh, sizeof hh);
        h6[5] = 5;
        scratch(&cap, h6, 6, Ws);
        CHECK_DBL(max_abs_diff(Wc, Ws, (size_t)nv * 6), <=, 1e-10);
    }

    /* Bad candidates and commits leave the context as it was. */
    scratch(&cap, hh, m + 1, Ws);
    CHECK_EQ_INT(dtx_bbw_incr_weights_add(ctx, 290, Wc, work, &err), DTX_EINVAL);
    CHECK(check_contains(err.msg, "candidate vertex 290 is already handle 2"));
    CHECK_EQ_INT(dtx_bbw_incr_weights_add(ctx, nv, Wc, work, &err), DTX_ERANGE);
    CHECK(check_contains(err.msg, "out of range"));
    CHECK_EQ_INT(dtx_bbw_incr_weights_add(ctx, 3, Wc, NULL, &err), DTX_EINVAL);
    CHECK_EQ_INT(dtx_bbw_incr_weights_replace(ctx, 5, 3, Wc, work, &err), DTX_ERANGE);
    CHECK_EQ_INT(dtx_bbw_incr_weights_replace(ctx, 0, 384, Wc, work, &err), DTX_EINVAL);
    CHECK_EQ_INT(dtx_bbw_incr_add(ctx, 7, &err), DTX_EINVAL);
    CHECK(check_contains(err.msg, "same vertex 7"));
    CHECK_EQ_INT(dtx_bbw_incr_add(ctx, -1, &err), DTX_ERANGE);
    CHECK_EQ_INT(dtx_bbw_incr_replace(ctx, 0, nv + 3, &err), DTX_ERANGE);
    CHECK_EQ_INT(dtx_bbw_incr_count(ctx), m + 1);
    CHECK(memcmp(Ws, dtx_bbw_incr_weights(ctx), (size_t)nv * (m + 1) * sizeof *Ws) == 0);

    dtx_bbw_work_free(&work);
    dtx_bbw_work_free(&work); /* NULL is fine */
    dtx_bbw_incr_free(&ctx);
    dtx_bbw_incr_free(&ctx);
    free(Wc);
    free(Ws);
    dtx_mesh_free(&cap);
}

/* Green's functions carried across a commit (dtx_bbw_incr_green_move)
 * equal those solved afresh for the new set, for an added handle and for
 * every handle moved, the leaving handle's own included; the bits do not
 * depend on the thread count; a row marked -1 is left alone. */
static void test_green_move(void)
{
    dtx_mesh cap = {0};
    dtx_error err = {0};
    int32_t h[4] = {7, 150, 290, 384}, m = 4, nv;
    int32_t others[4] = {0, 99, 222, 300}, c = 40;
    double worst = 0.0, scale = 0.0, worst_w = 0.0;
    dtx_bbw_work *work = NULL;
    dtx_bbw_incr *ctx = NULL;

    gen_capsule(24, 16, 1.5, &cap);
    nv = cap.nv;
    CHECK_OK(dtx_bbw_incr_create(&cap, h, m, &ctx, &err), &err);
    work = dtx_bbw_work_new(ctx);
    CHECK(work != NULL);
    for (int32_t j = -1; j < m && ctx && work; j++) {
        /* Rows: the four others, then (when moving) h_j, then a row left
         * alone. */
        int32_t verts[6], nh = j < 0 ? m + 1 : m, hh[5];
        double *gc = malloc((size_t)nv * sizeof *gc);
        double *G = malloc((size_t)6 * nv * sizeof *G), *G2 = malloc((size_t)6 * nv * sizeof *G2);
        double *fresh = malloc((size_t)nv * sizeof *fresh);
        dtx_bbw_incr *nctx = NULL;
        dtx_bbw_work *nwork = NULL;
        CHECK_OK(dtx_bbw_incr_green(ctx, c, gc, work, &err), &err);
        for (int t = 0; t < 4; t++) {
            verts[t] = others[t];
            CHECK_OK(dtx_bbw_incr_green(ctx, others[t], G + (size_t)t * nv, work, &err), &err);
        }
        verts[4] = j < 0 ? -1 : h[j];
        for (int32_t i = 0; i < nv; i++)
            G[(size_t)4 * nv + i] = j < 0 ? 1.0 : NAN; /* unused, or only written */
        verts[5] = -1;
        for (int32_t i = 0; i < nv; i++)
            G[(size_t)5 * nv + i] = 2.0;
        memcpy(G2, G, (size_t)6 * nv * sizeof *G);
        CHECK_OK(dtx_bbw_incr_green_move(ctx, j, c, gc, 6, verts, G, 1, &err), &err);
        CHECK_OK(dtx_bbw_incr_green_move(ctx, j, c, gc, 6, verts, G2, 2, &err), &err);
        CHECK(memcmp(G, G2, (size_t)6 * nv * sizeof *G) == 0);
        for (int32_t i = 0; i < nv; i++)
            CHECK(G[(size_t)5 * nv + i] == 2.0 && (j >= 0 || G[(size_t)4 * nv + i] == 1.0));
        /* Afresh for the new set. */
        memcpy(hh, h, sizeof h);
        hh[j < 0 ? m : j] = c;
        CHECK_OK(dtx_bbw_incr_create(&cap, hh, nh, &nctx, &err), &err);
        nwork = nctx ? dtx_bbw_work_new(nctx) : NULL;
        CHECK(nwork != NULL);
        for (int t = 0; t < 5 && nwork; t++) {
            if (verts[t] < 0)
                continue;
            CHECK_OK(dtx_bbw_incr_green(nctx, verts[t], fresh, nwork, &err), &err);
            for (int32_t i = 0; i < nv; i++)
                scale = fmax(scale, fabs(fresh[i]));
            worst = fmax(worst, max_abs_diff(G + (size_t)t * nv, fresh, (size_t)nv));
            CHECK(G[(size_t)t * nv + c] == 0.0);
        }
        /* A carried commit of the same move: the new set's weights without
         * a factorisation, which dtx_bbw_incr_factor makes when asked. */
        if (nctx) {
            dtx_bbw_incr *cctx = NULL;
            dtx_bbw_work *cwork = NULL;
            CHECK_OK(dtx_bbw_incr_create(&cap, h, m, &cctx, &err), &err);
            cwork = cctx ? dtx_bbw_work_new(cctx) : NULL;
            CHECK(cwork != NULL);
            if (cwork) {
                CHECK_OK(dtx_bbw_incr_commit_g(cctx, j, c, gc, cwork, &err), &err);
                CHECK_EQ_INT(dtx_bbw_incr_count(cctx), nh);
                CHECK(memcmp(dtx_bbw_incr_handles(cctx), hh, (size_t)nh * sizeof *hh) == 0);
                worst_w = fmax(worst_w, max_abs_diff(dtx_bbw_incr_weights(cctx),
                                                     dtx_bbw_incr_weights(nctx),
                                                     (size_t)nv * nh));
                CHECK_EQ_INT(dtx_bbw_incr_green(cctx, others[1], fresh, cwork, &err), DTX_EINVAL);
                CHECK(check_contains(err.msg, "not factored"));
                CHECK_OK(dtx_bbw_incr_factor(cctx, &err), &err);
                CHECK_OK(dtx_bbw_incr_green(cctx, others[1], fresh, cwork, &err), &err);
                worst = fmax(worst, max_abs_diff(G + (size_t)nv, fresh, (size_t)nv));
            }
            dtx_bbw_work_free(&cwork);
            dtx_bbw_incr_free(&cctx);
        }
        dtx_bbw_work_free(&nwork);
        dtx_bbw_incr_free(&nctx);
        free(gc);
        free(G);
        free(G2);
        free(fresh);
    }
    printf("Green's functions carried across a commit vs solved afresh: %.3g (largest %.3g)\n",
           worst, scale);
    CHECK_DBL(scale, >, 0.0);
    CHECK_DBL(worst, <=, 1e-10 * scale);
    printf("weights of a carried commit vs factored afresh: %.3g\n", worst_w);
    CHECK_DBL(worst_w, <=, 1e-10);
    /* c must be free now; j in range. */
    if (ctx && work) {
        double *g = malloc((size_t)nv * sizeof *g);
        int32_t v = 0;
        CHECK_EQ_INT(dtx_bbw_incr_green_move(ctx, -1, h[1], g, 1, &v, g, 1, &err), DTX_EINVAL);
        CHECK_EQ_INT(dtx_bbw_incr_green_move(ctx, m, c, g, 1, &v, g, 1, &err), DTX_EINVAL);
        free(g);
    }
    dtx_bbw_work_free(&work);
    dtx_bbw_incr_free(&ctx);
    dtx_mesh_free(&cap);
}

/* Two components: every one needs a handle; a handle alone in its
 * component may only move within it. */
static void test_components(void)
{
    dtx_mesh two = {0};
    dtx_error err = {0};
    int32_t half, nv;
    double *W, *Ws;
    dtx_bbw_incr *ctx = NULL;
    dtx_bbw_work *work = NULL;

    gen_two_capsules(&two);
    nv = two.nv;
    half = nv / 2;
    W = malloc((size_t)nv * 4 * sizeof *W);
    Ws = malloc((size_t)nv * 4 * sizeof *Ws);
    {
        int32_t h1[2] = {3, 40};
        CHECK_EQ_INT(dtx_bbw(&two, h1, 2, NULL, W, NULL, &err), DTX_EMESH);
        CHECK(check_contains(err.msg, "2 connected components"));
        CHECK(check_contains(err.msg, "has no handle"));
        CHECK_EQ_INT(dtx_bbw_incr_create(&two, h1, 2, &ctx, &err), DTX_EMESH);
        CHECK(ctx == NULL);
    }
    {
        int32_t h[3] = {3, 40, half + 10}, hs[3] = {3, 40, half + 20};
        CHECK_OK(dtx_bbw(&two, h, 3, NULL, W, NULL, &err), &err);
        check_weights(W, nv, h, 3, 1e-12, 0.0, 1.0);
        /* The second component has one handle: weight 1 there. */
        CHECK_DBL(W[(size_t)(half + 50) * 3 + 2], ==, 1.0);
        CHECK_OK(dtx_bbw_incr_create(&two, h, 3, &ctx, &err), &err);
        work = dtx_bbw_work_new(ctx);
        CHECK_OK(dtx_bbw_incr_weights_replace(ctx, 2, half + 20, W, work, &err), &err);
        scratch(&two, hs, 3, Ws);
        CHECK_DBL(max_abs_diff(W, Ws, (size_t)nv * 3), <=, 1e-10);
        CHECK_EQ_INT(dtx_bbw_incr_weights_replace(ctx, 2, 20, W, work, &err), DTX_EINVAL);
        CHECK(check_contains(err.msg, "without a handle"));
        /* Its Green's functions are not carried across such a move. */
        {
            int32_t v = 60;
            CHECK_OK(dtx_bbw_incr_green(ctx, half + 20, Ws, work, &err), &err);
            CHECK_EQ_INT(dtx_bbw_incr_green_move(ctx, 2, half + 20, Ws, 1, &v, W, 1, &err),
                         DTX_EINVAL);
            CHECK(check_contains(err.msg, "alone in its component"));
        }
        /* Moving a handle of the first component into the second is fine. */
        CHECK_OK(dtx_bbw_incr_weights_replace(ctx, 1, half + 30, W, work, &err), &err);
        hs[1] = half + 30;
        hs[2] = half + 10;
        scratch(&two, hs, 3, Ws);
        CHECK_DBL(max_abs_diff(W, Ws, (size_t)nv * 3), <=, 1e-10);
        CHECK_OK(dtx_bbw_incr_weights_add(ctx, half + 60, W, work, &err), &err);
        {
            int32_t h4[4] = {3, 40, half + 10, half + 60};
            scratch(&two, h4, 4, Ws);
            CHECK_DBL(max_abs_diff(W, Ws, (size_t)nv * 4), <=, 1e-10);
        }
        dtx_bbw_work_free(&work);
        dtx_bbw_incr_free(&ctx);
    }
    free(W);
    free(Ws);
    dtx_mesh_free(&two);
}

static void test_bad_input(void)
{
    dtx_mesh cap = {0}, extra = {0};
    dtx_error err = {0};
    double *W;
    dtx_bbw_params prm;
    dtx_bbw_incr *ctx = NULL;

    gen_capsule(12, 8, 1.5, &cap);
    W = malloc((size_t)cap.nv * 4 * sizeof *W);
    {
        int32_t h[3] = {0, 5, cap.nv};
        CHECK_EQ_INT(dtx_bbw(&cap, h, 3, NULL, W, NULL, &err), DTX_ERANGE);
        CHECK(check_contains(err.msg, "handle 2 is vertex"));
        CHECK(check_contains(err.msg, "out of range"));
        h[2] = -1;
        CHECK_EQ_INT(dtx_bbw_incr_create(&cap, h, 3, &ctx, &err), DTX_ERANGE);
    }
    {
        int32_t h[3] = {4, 9, 4};
        CHECK_EQ_INT(dtx_bbw(&cap, h, 3, NULL, W, NULL, &err), DTX_EINVAL);
        CHECK(check_contains(err.msg, "handles 0 and 2 are the same vertex 4"));
        CHECK_EQ_INT(dtx_bbw(&cap, h, 0, NULL, W, NULL, &err), DTX_EINVAL);
        CHECK(check_contains(err.msg, "no handles"));
        CHECK_EQ_INT(dtx_bbw(&cap, NULL, 2, NULL, W, NULL, &err), DTX_EINVAL);
        CHECK_EQ_INT(dtx_bbw(&cap, h, 2, NULL, NULL, NULL, &err), DTX_EINVAL);
        CHECK_EQ_INT(dtx_bbw(NULL, h, 2, NULL, W, NULL, &err), DTX_EINVAL);
        CHECK_EQ_INT(dtx_bbw_incr_create(&cap, h, 0, &ctx, &err), DTX_EINVAL);
        dtx_bbw_params_default(&prm);
        prm.max_iter = 0;
        CHECK_EQ_INT(dtx_bbw(&cap, h, 2, &prm, W, NULL, &err), DTX_EINVAL);
        CHECK(check_contains(err.msg, "max_iter"));
    }
    /* A vertex in no face. */
    dtx_mesh_alloc(&extra, cap.nv + 1, cap.nf, NULL);
    memcpy(extra.V, cap.V, (size_t)cap.nv * 3 * sizeof *cap.V);
    memcpy(extra.F, cap.F, (size_t)cap.nf * 3 * sizeof *cap.F);
    {
        int32_t h[2] = {0, 5};
        CHECK_EQ_INT(dtx_bbw(&extra, h, 2, NULL, W, NULL, &err), DTX_EMESH);
        CHECK(check_contains(err.msg, "is in no triangle"));
    }
    /* A broken mesh is reported by the mesh check. */
    extra.F[4] = extra.nv + 7;
    {
        int32_t h[2] = {0, 5};
        CHECK_EQ_INT(dtx_bbw(&extra, h, 2, NULL, W, NULL, &err), DTX_ERANGE);
    }
    /* A row that clamps to zero. */
    {
        double bad[4] = {-1.0, -2.0, 0.5, 0.5};
        CHECK_EQ_INT(dtx_bbw_clamp_normalise(bad, 2, 2, NULL), -1);
        CHECK_DBL(bad[0], ==, 0.0);
        CHECK_DBL(bad[2], ==, 0.5);
    }
    free(W);
    dtx_mesh_free(&cap);
    dtx_mesh_free(&extra);
}

/* ------------------------------------------------------------------ */
/* Farthest point sampling                                             */
/* ------------------------------------------------------------------ */

/* All-pairs edge-graph distances by Floyd-Warshall (small meshes only). */
static double *all_pairs(const dtx_mesh *m)
{
    int32_t n = m->nv;
    double *D = malloc((size_t)n * n * sizeof *D);
    for (size_t i = 0; i < (size_t)n * n; i++)
        D[i] = INFINITY;
    for (int32_t i = 0; i < n; i++)
        D[(size_t)i * n + i] = 0.0;
    for (int32_t f = 0; f < m->nf; f++)
        for (int k = 0; k < 3; k++) {
            int32_t a = m->F[3 * f + k], b = m->F[3 * f + (k + 1) % 3];
            const double *p = m->V + 3 * a, *q = m->V + 3 * b;
            double d = sqrt((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) +
                            (p[2] - q[2]) * (p[2] - q[2]));
            D[(size_t)a * n + b] = D[(size_t)b * n + a] = d;
        }
    for (int32_t k = 0; k < n; k++)
        for (int32_t i = 0; i < n; i++)
            for (int32_t j = 0; j < n; j++)
                if (D[(size_t)i * n + k] + D[(size_t)k * n + j] < D[(size_t)i * n + j])
                    D[(size_t)i * n + j] = D[(size_t)i * n + k] + D[(size_t)k * n + j];
    return D;
}

static void test_fps(void)
{
    dtx_mesh cap = {0}, two = {0};
    dtx_error err = {0};
    int32_t s1[40], s2[40], nc = 40, n;
    /* cap: a jittered grid, whose distances have no exact ties. */
    double r[40], r2[40], *D, cen[3] = {0, 0, 0}, best = -1.0;
    int32_t first = -1, distinct = 1, monotone = 1, same_as_ref = 1;

    gen_grid(10, &cap);
    n = cap.nv;
    CHECK_OK(dtx_farthest_points(&cap, nc, s1, r, &err), &err);
    CHECK_OK(dtx_farthest_points(&cap, nc, s2, r2, &err), &err);
    CHECK(memcmp(s1, s2, sizeof s1) == 0);
    CHECK(memcmp(r, r2, sizeof r) == 0);
    for (int32_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++)
            cen[k] += cap.V[3 * i + k] / n;
    for (int32_t i = 0; i < n; i++) {
        const double *p = cap.V + 3 * i;
        double d2 = (p[0] - cen[0]) * (p[0] - cen[0]) + (p[1] - cen[1]) * (p[1] - cen[1]) +
                    (p[2] - cen[2]) * (p[2] - cen[2]);
        if (d2 > best) {
            best = d2;
            first = i;
        }
    }
    CHECK_EQ_INT(s1[0], first);
    CHECK(isinf(r[0]));
    for (int a = 0; a < nc; a++)
        for (int b = a + 1; b < nc; b++)
            distinct &= s1[a] != s1[b];
    CHECK(distinct);
    for (int a = 2; a < nc; a++)
        monotone &= r[a] <= r[a - 1];
    CHECK(monotone);

    /* The same sequence from all-pairs distances. */
    D = all_pairs(&cap);
    {
        double *dmin = malloc((size_t)n * sizeof *dmin);
        for (int32_t i = 0; i < n; i++)
            dmin[i] = D[(size_t)first * n + i];
        for (int a = 1; a < nc; a++) {
            int32_t s = -1;
            for (int32_t i = 0; i < n; i++)
                if (dmin[i] > 0.0 && (s < 0 || dmin[i] > dmin[s]))
                    s = i;
            same_as_ref &= s == s1[a];
            if (s != s1[a])
                fprintf(stderr, "sample %d: %d, reference %d\n", a, (int)s1[a], (int)s);
            same_as_ref &= fabs(dmin[s] - r[a]) <= 1e-12;
            for (int32_t i = 0; i < n; i++)
                dmin[i] = fmin(dmin[i], D[(size_t)s * n + i]);
        }
        free(dmin);
    }
    CHECK(same_as_ref);
    free(D);

    /* Every vertex. */
    {
        int32_t *all = malloc((size_t)n * sizeof *all);
        unsigned char *seen = calloc((size_t)n, 1);
        int32_t count = 0;
        CHECK_OK(dtx_farthest_points(&cap, n, all, NULL, &err), &err);
        for (int32_t i = 0; i < n; i++)
            if (all[i] >= 0 && all[i] < n && !seen[all[i]]) {
                seen[all[i]] = 1;
                count++;
            }
        CHECK_EQ_INT(count, n);
        free(all);
        free(seen);
    }

    /* Two components: the second sample opens the other one. */
    gen_two_capsules(&two);
    CHECK_OK(dtx_farthest_points(&two, 4, s1, r, &err), &err);
    CHECK(isinf(r[0]) && isinf(r[1]) && isfinite(r[2]));
    CHECK((s1[0] < two.nv / 2) != (s1[1] < two.nv / 2));

    /* Bad input. */
    CHECK_EQ_INT(dtx_farthest_points(&cap, 0, s1, NULL, &err), DTX_EINVAL);
    CHECK(check_contains(err.msg, "0 samples"));
    CHECK_EQ_INT(dtx_farthest_points(&cap, n + 1, s1, NULL, &err), DTX_ERANGE);
    CHECK(check_contains(err.msg, "vertices are in a face"));
    CHECK_EQ_INT(dtx_farthest_points(&cap, 3, NULL, NULL, &err), DTX_EINVAL);
    dtx_mesh_free(&cap);
    dtx_mesh_free(&two);
}

int main(void)
{
    test_small_triangles();
    test_operators();
    test_degenerate();
    test_bbw();
    test_incremental();
    test_green_move();
    test_components();
    test_bad_input();
    test_fps();
    return check_report();
}
