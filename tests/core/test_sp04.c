/*
 * test_sp04.c: properties of the Sumner-Popovic transfer and its parts.
 *  - deformation gradients: identity and rigid motions;
 *  - the vertex-only formulation equals Sumner's fourth-vertex formulation;
 *  - identity transfer (source onto itself, identity markers) reproduces
 *    every frame; a rigid motion of the source frames moves the result
 *    rigidly; scaling the target scales the result;
 *  - results are bitwise the same whatever the thread count, the grouping
 *    of frames into calls and the kernel variant (baseline or AVX2); a
 *    non-finite frame gets a NaN residual and does not touch the others;
 *  - the reported residual equals the RMS over pairs of ||S_s P_t - T_t||
 *    evaluated directly, for every anchor mode;
 *  - a vertex in no face keeps its rest position (moved with the frame);
 *  - a multi-component target and impossible pair counts are refused.
 */
#include "check.h"
#include "dtx_core.h"
#include "meshgen.h"

#include <cholmod.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

static double max_abs_diff(const double *a, const double *b, size_t n)
{
    double m = 0.0;
    for (size_t i = 0; i < n; i++)
        m = fabs(a[i] - b[i]) > m ? fabs(a[i] - b[i]) : m;
    return m;
}

static void test_gradients(const dtx_mesh *m)
{
    double *Vinv = malloc(sizeof(double) * 9 * m->nf), *S = malloc(sizeof(double) * 9 * m->nf);
    double *X = malloc(sizeof(double) * 3 * m->nv), R[9], err_id = 0, err_rot = 0;
    CHECK_EQ_INT(dtx_frame_inverses(m->V, m->F, m->nf, 0.0, Vinv), 0);
    dtx_deformation_gradients(Vinv, m->F, m->nf, m->V, S);
    for (int32_t f = 0; f < m->nf; f++)
        for (int k = 0; k < 9; k++)
            err_id = fmax(err_id, fabs(S[9 * f + k] - (k % 4 == 0)));
    CHECK_DBL(err_id, <, 1e-12);
    rotation(0.7, R);
    for (int32_t i = 0; i < m->nv; i++)
        for (int r = 0; r < 3; r++)
            X[3 * i + r] = R[3 * r] * m->V[3 * i] + R[3 * r + 1] * m->V[3 * i + 1] +
                           R[3 * r + 2] * m->V[3 * i + 2] + 5.0;
    dtx_deformation_gradients(Vinv, m->F, m->nf, X, S);
    for (int32_t f = 0; f < m->nf; f++)
        for (int k = 0; k < 9; k++)
            err_rot = fmax(err_rot, fabs(S[9 * f + k] - R[k]));
    CHECK_DBL(err_rot, <, 1e-11);
    free(Vinv);
    free(S);
    free(X);
}

/* Sumner's original formulation: unknowns are the target vertices and one
 * free fourth vertex per triangle; vertex 0 fixed at the origin. */
static void solve_fourth_vertex(const dtx_mesh *src, const double *Xs, const dtx_mesh *tgt,
                                double *out)
{
    int32_t nv = tgt->nv, nf = tgt->nf, n = nv + nf - 1;
    cholmod_common cc;
    cholmod_triplet *T;
    cholmod_sparse *K;
    cholmod_factor *L;
    cholmod_dense *B, *X;
    double *Vs = malloc(sizeof(double) * 9 * src->nf), *S = malloc(sizeof(double) * 9 * src->nf);
    double *Vt = malloc(sizeof(double) * 9 * nf);
    cholmod_start(&cc);
    dtx_frame_inverses(src->V, src->F, src->nf, 0.0, Vs);
    dtx_deformation_gradients(Vs, src->F, src->nf, Xs, S);
    dtx_frame_inverses(tgt->V, tgt->F, nf, 0.0, Vt);
    T = cholmod_allocate_triplet(n, n, (size_t)nf * 16, -1, CHOLMOD_REAL, &cc);
    B = cholmod_zeros(n, 3, CHOLMOD_REAL, &cc);
    for (int32_t t = 0; t < nf; t++) { /* pairs: (t, t) */
        const double *r = Vt + 9 * t;
        int32_t var[4] = {tgt->F[3 * t] - 1, tgt->F[3 * t + 1] - 1, tgt->F[3 * t + 2] - 1,
                          nv + t - 1};
        double coef[4][3] = {{-(r[0] + r[3] + r[6]), -(r[1] + r[4] + r[7]), -(r[2] + r[5] + r[8])},
                             {r[0], r[1], r[2]},
                             {r[3], r[4], r[5]},
                             {r[6], r[7], r[8]}};
        for (int p = 0; p < 4; p++) {
            if (var[p] < 0)
                continue;
            for (int q = 0; q < 4; q++) {
                if (var[q] < 0 || var[q] > var[p])
                    continue;
                size_t k = T->nnz++;
                ((int *)T->i)[k] = var[p];
                ((int *)T->j)[k] = var[q];
                ((double *)T->x)[k] =
                    coef[p][0] * coef[q][0] + coef[p][1] * coef[q][1] + coef[p][2] * coef[q][2];
            }
            for (int c = 0; c < 3; c++)
                ((double *)B->x)[(size_t)c * n + var[p]] +=
                    coef[p][0] * S[9 * t + 3 * c] + coef[p][1] * S[9 * t + 3 * c + 1] +
                    coef[p][2] * S[9 * t + 3 * c + 2];
        }
    }
    K = cholmod_triplet_to_sparse(T, T->nnz, &cc);
    L = cholmod_analyze(K, &cc);
    cholmod_factorize(K, L, &cc);
    X = cholmod_solve(CHOLMOD_A, L, B, &cc);
    for (int c = 0; c < 3; c++) {
        out[c] = 0.0;
        for (int32_t v = 1; v < nv; v++)
            out[3 * v + c] = ((double *)X->x)[(size_t)c * n + v - 1];
    }
    cholmod_free_dense(&X, &cc);
    cholmod_free_dense(&B, &cc);
    cholmod_free_factor(&L, &cc);
    cholmod_free_sparse(&K, &cc);
    cholmod_free_triplet(&T, &cc);
    cholmod_finish(&cc);
    free(Vs);
    free(S);
    free(Vt);
}

/* The residual by its definition: RMS over pairs of || S_s P_t - T_t ||_F
 * with S_s the source gradient, P_t the projection on the rest target
 * triangle's plane and T_t = sum_j x_j g_tj^T (long double sums). */
static double direct_residual(const dtx_mesh *src, const double *Xs, const dtx_mesh *tgt,
                              const double *Xt, const int32_t *pairs, int64_t npairs)
{
    double *Vinv = malloc(sizeof(double) * 9 * src->nf), *S = malloc(sizeof(double) * 9 * src->nf);
    double *G = malloc(sizeof(double) * 9 * tgt->nf), *N = malloc(sizeof(double) * 3 * tgt->nf);
    double ds = dtx_bbox_diagonal(src->V, src->nv), dt = dtx_bbox_diagonal(tgt->V, tgt->nv);
    long double e = 0.0L;
    dtx_frame_inverses(src->V, src->F, src->nf, 1e-14 * ds * ds, Vinv);
    dtx_deformation_gradients(Vinv, src->F, src->nf, Xs, S);
    dtx_gradient_operator(tgt->V, tgt->F, tgt->nf, 1e-14 * dt * dt, G);
    dtx_face_normals(tgt->V, tgt->F, tgt->nf, N);
    for (int64_t k = 0; k < npairs; k++) {
        const double *s = S + 9 * pairs[2 * k], *g = G + 9 * pairs[2 * k + 1];
        const double *n = N + 3 * pairs[2 * k + 1];
        const int32_t *tv = tgt->F + 3 * pairs[2 * k + 1];
        for (int r = 0; r < 3; r++) {
            double sn = s[3 * r] * n[0] + s[3 * r + 1] * n[1] + s[3 * r + 2] * n[2];
            for (int c = 0; c < 3; c++) {
                double t = 0.0, d;
                for (int j = 0; j < 3; j++)
                    t += Xt[3 * tv[j] + r] * g[3 * j + c];
                d = s[3 * r + c] - sn * n[c] - t;
                e += (long double)d * d;
            }
        }
    }
    free(Vinv);
    free(S);
    free(G);
    free(N);
    return (double)sqrtl(e / (long double)npairs);
}

/* Applies the plan to T frames in several ways and checks every result
 * (positions and residuals) is bitwise the one of a single call: frames
 * group by group and one by one at 1 thread, all at once at 2 threads, and
 * with the baseline kernels. */
static void test_bitwise_invariance(dtx_sp04_plan *plan, int T, const double *Xs)
{
    const int32_t ns = dtx_sp04_plan_nv_src(plan), nt = dtx_sp04_plan_nv_tgt(plan);
    const size_t fs = 3 * (size_t)ns, ft = 3 * (size_t)nt;
    double *ref = malloc(sizeof(double) * ft * T), *out = malloc(sizeof(double) * ft * T);
    double *rref = malloc(sizeof(double) * T), *rout = malloc(sizeof(double) * T);
    int nthreads = omp_get_max_threads(), avx2 = dtx_sp04_plan_use_avx2(plan, 1);
    dtx_error err;

    omp_set_num_threads(2);
    CHECK_OK(dtx_sp04_apply(plan, T, Xs, ref, rref, &err), &err);

    omp_set_num_threads(1);
    for (int f0 = 0; f0 < T; f0 += DTX_SP04_SOLVE_GROUP) {
        int n = T - f0 < DTX_SP04_SOLVE_GROUP ? T - f0 : DTX_SP04_SOLVE_GROUP;
        CHECK_OK(dtx_sp04_apply(plan, n, Xs + f0 * fs, out + f0 * ft, rout + f0, &err), &err);
    }
    CHECK(memcmp(ref, out, sizeof(double) * ft * T) == 0);
    CHECK(memcmp(rref, rout, sizeof(double) * T) == 0);

    for (int f = 0; f < T; f++)
        CHECK_OK(dtx_sp04_apply(plan, 1, Xs + f * fs, out + f * ft, rout + f, &err), &err);
    CHECK(memcmp(ref, out, sizeof(double) * ft * T) == 0);
    CHECK(memcmp(rref, rout, sizeof(double) * T) == 0);

    /* A call starting in the middle of a group (frames 3.., one call). */
    CHECK_OK(dtx_sp04_apply(plan, T - 3, Xs + 3 * fs, out + 3 * ft, rout + 3, &err), &err);
    CHECK(memcmp(ref + 3 * ft, out + 3 * ft, sizeof(double) * ft * (T - 3)) == 0);

    omp_set_num_threads(2);
    CHECK_EQ_INT(dtx_sp04_plan_use_avx2(plan, 0), 0);
    CHECK_OK(dtx_sp04_apply(plan, T, Xs, out, rout, &err), &err);
    CHECK(memcmp(ref, out, sizeof(double) * ft * T) == 0);
    CHECK(memcmp(rref, rout, sizeof(double) * T) == 0);
    printf("bitwise: one call at 2 threads = by groups = one by one at 1 thread = %s kernels\n",
           avx2 ? "baseline vs AVX2" : "baseline (no AVX2 here)");

    /* A non-finite frame shows in its residual and leaves the others of
     * its group alone. */
    {
        double *bad = malloc(sizeof(double) * fs * T);
        memcpy(bad, Xs, sizeof(double) * fs * T);
        bad[2 * fs + 7] = NAN;
        CHECK_OK(dtx_sp04_apply(plan, T, bad, out, rout, &err), &err);
        CHECK(isnan(rout[2]));
        CHECK(memcmp(ref, out, sizeof(double) * ft * 2) == 0);
        CHECK(memcmp(ref + 3 * ft, out + 3 * ft, sizeof(double) * ft * (T - 3)) == 0);
        CHECK(rout[1] == rref[1] && rout[3] == rref[3]);
        free(bad);
    }

    dtx_sp04_plan_use_avx2(plan, 1);
    omp_set_num_threads(nthreads);
    free(ref);
    free(out);
    free(rref);
    free(rout);
}

/* The reported residual against its definition, for one anchor mode. */
static void test_residual(const dtx_mesh *src, const dtx_mesh *tgt, const int32_t *pairs,
                          int64_t npairs, dtx_anchor anchor, int T, const double *Xs)
{
    dtx_sp04_plan *plan = NULL;
    dtx_error err;
    int32_t pin = 5;
    double pos[3] = {0.1, 0.2, 0.3}, worst = 0.0;
    double *Xt = malloc(sizeof(double) * 3 * tgt->nv * T), *res = malloc(sizeof(double) * T);
    int pinned = anchor == DTX_ANCHOR_PINS;
    CHECK_OK(dtx_sp04_plan_create(src, tgt, pairs, npairs, anchor, pinned ? &pin : NULL,
                                  pinned ? pos : NULL, pinned, &plan, &err),
             &err);
    if (!plan)
        return;
    CHECK_OK(dtx_sp04_apply(plan, T, Xs, Xt, res, &err), &err);
    for (int t = 0; t < T; t++) {
        double d = direct_residual(src, Xs + (size_t)t * 3 * src->nv, tgt,
                                   Xt + (size_t)t * 3 * tgt->nv, pairs, npairs);
        /* Relative, with an absolute floor for the exact fit of frame 0. */
        worst = fmax(worst, fabs(d - res[t]) / (d + 1e-3));
    }
    printf("anchor %d: residual %.6g (last frame), worst relative difference to the direct "
           "evaluation %.3g\n",
           (int)anchor, res[T - 1], worst);
    CHECK(res[T - 1] > 1e-3); /* the shapes differ: a real residual */
    CHECK_DBL(worst, <, 1e-9);
    dtx_sp04_plan_free(&plan);
    free(Xt);
    free(res);
}

/* A target vertex in no face is not an unknown and does not change the
 * solved shape (the rest moves by one translation per frame), but it counts
 * in the centroid that the fixed anchor places at the rest centroid. */
static void test_unreferenced_vertex(const dtx_mesh *src, const dtx_mesh *tgt,
                                     const int32_t *pairs, int64_t npairs, int T,
                                     const double *Xs)
{
    dtx_mesh big;
    dtx_sp04_plan *plan = NULL;
    dtx_error err;
    const int32_t nv = tgt->nv;
    double *A = malloc(sizeof(double) * 3 * nv * T), *B = malloc(sizeof(double) * 3 * (nv + 1) * T);
    double worst = 0.0, worst_cen = 0.0, diag = dtx_bbox_diagonal(tgt->V, nv), rest_cen[3] = {0};
    CHECK_OK(dtx_mesh_alloc(&big, nv + 1, tgt->nf, &err), &err);
    memcpy(big.V, tgt->V, sizeof(double) * 3 * nv);
    memcpy(big.F, tgt->F, sizeof(int32_t) * 3 * tgt->nf);
    big.V[3 * nv] = 3.0, big.V[3 * nv + 1] = -1.0, big.V[3 * nv + 2] = 0.5;
    for (int32_t i = 0; i <= nv; i++)
        for (int c = 0; c < 3; c++)
            rest_cen[c] += big.V[3 * i + c] / (nv + 1);
    CHECK_OK(dtx_sp04_plan_create(src, tgt, pairs, npairs, DTX_ANCHOR_FIXED, NULL, NULL, 0,
                                  &plan, &err),
             &err);
    CHECK_OK(dtx_sp04_apply(plan, T, Xs, A, NULL, &err), &err);
    dtx_sp04_plan_free(&plan);
    CHECK_OK(dtx_sp04_plan_create(src, &big, pairs, npairs, DTX_ANCHOR_FIXED, NULL, NULL, 0,
                                  &plan, &err),
             &err);
    CHECK_OK(dtx_sp04_apply(plan, T, Xs, B, NULL, &err), &err);
    dtx_sp04_plan_free(&plan);
    for (int t = 0; t < T; t++) {
        const double *a = A + (size_t)t * 3 * nv, *b = B + (size_t)t * 3 * (nv + 1);
        for (int c = 0; c < 3; c++) {
            double shift = b[c] - a[c], cen = 0.0;
            for (int32_t i = 0; i < nv; i++)
                worst = fmax(worst, fabs(b[3 * i + c] - a[3 * i + c] - shift));
            for (int32_t i = 0; i <= nv; i++)
                cen += b[3 * i + c];
            worst_cen = fmax(worst_cen, fabs(cen / (nv + 1) - rest_cen[c]));
        }
    }
    printf("unreferenced vertex: shape change %.3g, centroid error %.3g of the diagonal\n",
           worst / diag, worst_cen / diag);
    CHECK_DBL(worst, <, 1e-9 * diag);
    CHECK_DBL(worst_cen, <, 1e-12 * diag);
    dtx_mesh_free(&big);
    free(A);
    free(B);
}

static void center(double *X, int32_t n)
{
    double c[3] = {0, 0, 0};
    for (int32_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++)
            c[k] += X[3 * i + k] / n;
    for (int32_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++)
            X[3 * i + k] -= c[k];
}

int main(void)
{
    dtx_mesh src, tgt, big;
    dtx_error err;
    dtx_markers mk;
    dtx_corr corr;
    dtx_corr_params prm;
    dtx_sp04_plan *plan = NULL;
    const int T = 11;
    double *Xs, *Xt, *Xt2, *res, diag;
    int32_t *ident;

    CHECK_OK(gen_capsule(24, 16, 1.6, &src), &err);
    test_gradients(&src);

    /* A target with the same connectivity but another shape. */
    CHECK_OK(dtx_mesh_copy(&src, &tgt, &err), &err);
    for (int32_t i = 0; i < tgt.nv; i++) {
        tgt.V[3 * i] *= 1.3 + 0.2 * tgt.V[3 * i + 2];
        tgt.V[3 * i + 2] *= 0.8;
    }
    Xs = malloc(sizeof(double) * 3 * src.nv * T);
    Xt = malloc(sizeof(double) * 3 * tgt.nv * T);
    Xt2 = malloc(sizeof(double) * 3 * tgt.nv * T);
    res = malloc(sizeof(double) * T);
    ident = malloc(sizeof(int32_t) * 2 * tgt.nf);
    for (int t = 0; t < T; t++)
        deform(src.V, src.nv, (double)t / (T - 1), Xs + (size_t)t * 3 * src.nv);
    for (int32_t f = 0; f < tgt.nf; f++)
        ident[2 * f] = ident[2 * f + 1] = f;

    /* Vertex-only (ours) == fourth-vertex (Sumner's) formulation. */
    {
        double *ref = malloc(sizeof(double) * 3 * tgt.nv);
        CHECK_OK(dtx_sp04_plan_create(&src, &tgt, ident, tgt.nf, DTX_ANCHOR_FIXED, NULL, NULL, 0,
                                      &plan, &err),
                 &err);
        CHECK_OK(dtx_sp04_apply(plan, T, Xs, Xt, res, &err), &err);
        solve_fourth_vertex(&src, Xs + (size_t)(T - 1) * 3 * src.nv, &tgt, ref);
        center(ref, tgt.nv);
        memcpy(Xt2, Xt + (size_t)(T - 1) * 3 * tgt.nv, sizeof(double) * 3 * tgt.nv);
        center(Xt2, tgt.nv);
        diag = dtx_bbox_diagonal(tgt.V, tgt.nv);
        printf("fourth-vertex vs vertex-only: max diff %.3g of the diagonal\n",
               max_abs_diff(ref, Xt2, 3 * (size_t)tgt.nv) / diag);
        CHECK_DBL(max_abs_diff(ref, Xt2, 3 * (size_t)tgt.nv), <, 1e-9 * diag);
        free(ref);
    }

    /* Thread count, grouping and kernel variant do not change the results. */
    test_bitwise_invariance(plan, T, Xs);

    /* Rigid motion of the source frames moves the result rigidly. */
    {
        double R[9];
        double *Xr = malloc(sizeof(double) * 3 * src.nv * T), *Yr = malloc(sizeof(double) * 3 *
                                                                              tgt.nv * T);
        double worst = 0.0;
        rotation(1.1, R);
        for (int32_t i = 0; i < src.nv * T; i++)
            for (int r = 0; r < 3; r++)
                Xr[3 * i + r] = R[3 * r] * Xs[3 * i] + R[3 * r + 1] * Xs[3 * i + 1] +
                                R[3 * r + 2] * Xs[3 * i + 2] + 0.5 * r;
        CHECK_OK(dtx_sp04_apply(plan, T, Xr, Yr, NULL, &err), &err);
        for (int t = 0; t < T; t++) {
            double *a = Xt + (size_t)t * 3 * tgt.nv, *b = Yr + (size_t)t * 3 * tgt.nv;
            center(a, tgt.nv);
            center(b, tgt.nv);
            for (int32_t i = 0; i < tgt.nv; i++)
                for (int r = 0; r < 3; r++) {
                    double ra = R[3 * r] * a[3 * i] + R[3 * r + 1] * a[3 * i + 1] +
                                R[3 * r + 2] * a[3 * i + 2];
                    worst = fmax(worst, fabs(ra - b[3 * i + r]));
                }
        }
        CHECK_DBL(worst, <, 1e-9 * diag);
        free(Xr);
        free(Yr);
    }
    dtx_sp04_plan_free(&plan);

    /* Scaling the target by s scales the result by s. */
    {
        dtx_mesh ts;
        double s = 2.5, worst = 0.0;
        CHECK_OK(dtx_mesh_copy(&tgt, &ts, &err), &err);
        for (int32_t i = 0; i < 3 * ts.nv; i++)
            ts.V[i] *= s;
        CHECK_OK(dtx_sp04_plan_create(&src, &tgt, ident, tgt.nf, DTX_ANCHOR_FIXED, NULL, NULL, 0,
                                      &plan, &err),
                 &err);
        CHECK_OK(dtx_sp04_apply(plan, T, Xs, Xt, NULL, &err), &err);
        dtx_sp04_plan_free(&plan);
        CHECK_OK(dtx_sp04_plan_create(&src, &ts, ident, tgt.nf, DTX_ANCHOR_FIXED, NULL, NULL, 0,
                                      &plan, &err),
                 &err);
        CHECK_OK(dtx_sp04_apply(plan, T, Xs, Xt2, NULL, &err), &err);
        dtx_sp04_plan_free(&plan);
        for (size_t i = 0; i < 3 * (size_t)tgt.nv * T; i++)
            worst = fmax(worst, fabs(s * Xt[i] - Xt2[i]));
        CHECK_DBL(worst, <, 1e-9 * s * diag);
        dtx_mesh_free(&ts);
    }

    /* Identity: the source onto itself with identity markers reproduces
     * every source frame (translation following the source). */
    {
        int32_t nm = 12;
        double worst = 0.0, dg = dtx_bbox_diagonal(src.V, src.nv);
        CHECK_OK(dtx_markers_alloc(&mk, nm, &err), &err);
        for (int32_t i = 0; i < nm; i++)
            mk.src[i] = mk.tgt[i] = (int32_t)((int64_t)i * src.nv / nm);
        dtx_corr_params_default(&prm);
        CHECK_OK(dtx_sp04_correspond(&src, &src, &mk, &prm, &corr, &err), &err);
        CHECK_EQ_INT(corr.npairs, src.nf);
        CHECK_DBL(max_abs_diff(corr.deformed_src, src.V, 3 * (size_t)src.nv), <, 1e-9 * dg);
        CHECK_OK(dtx_sp04_plan_create(&src, &src, corr.pairs, corr.npairs, DTX_ANCHOR_FOLLOW,
                                      NULL, NULL, 0, &plan, &err),
                 &err);
        CHECK_OK(dtx_sp04_apply(plan, T, Xs, Xt, res, &err), &err);
        worst = max_abs_diff(Xt, Xs, 3 * (size_t)src.nv * T);
        printf("identity transfer: max error %.3g of the diagonal, residual %.3g\n", worst / dg,
               res[T - 1]);
        CHECK_DBL(worst, <, 1e-9 * dg);
        CHECK_DBL(res[T - 1], <, 1e-6);
        dtx_sp04_plan_free(&plan);
        dtx_corr_free(&corr);
        dtx_markers_free(&mk);
    }

    /* Pins hold their vertices. */
    {
        int32_t pin = 5;
        double pos[3] = {0.1, 0.2, 0.3};
        CHECK_OK(dtx_sp04_plan_create(&src, &tgt, ident, tgt.nf, DTX_ANCHOR_PINS, &pin, pos, 1,
                                      &plan, &err),
                 &err);
        CHECK_OK(dtx_sp04_apply(plan, T, Xs, Xt, NULL, &err), &err);
        for (int t = 0; t < T; t++)
            for (int k = 0; k < 3; k++)
                CHECK_DBL(Xt[(size_t)t * 3 * tgt.nv + 3 * pin + k], ==, pos[k]);
        dtx_sp04_plan_free(&plan);
    }

    /* The residual is the minimised energy, for every anchor mode. */
    test_residual(&src, &tgt, ident, tgt.nf, DTX_ANCHOR_FIXED, T, Xs);
    test_residual(&src, &tgt, ident, tgt.nf, DTX_ANCHOR_FOLLOW, T, Xs);
    test_residual(&src, &tgt, ident, tgt.nf, DTX_ANCHOR_PINS, T, Xs);

    test_unreferenced_vertex(&src, &tgt, ident, tgt.nf, T, Xs);

    /* Pair counts the plan cannot index are refused before any is read. */
    {
        dtx_status st = dtx_sp04_plan_create(&src, &tgt, ident, (int64_t)INT32_MAX + 1,
                                             DTX_ANCHOR_FIXED, NULL, NULL, 0, &plan, &err);
        CHECK_EQ_INT(st, DTX_ERANGE);
        CHECK(strstr(err.msg, "pairs") != NULL);
        CHECK(plan == NULL);
        st = dtx_sp04_plan_create(&src, &tgt, ident, -1, DTX_ANCHOR_FIXED, NULL, NULL, 0, &plan,
                                  &err);
        CHECK_EQ_INT(st, DTX_ERANGE);
    }

    /* Two components: refused, pointing at the multicomponent method. */
    {
        CHECK_OK(dtx_mesh_alloc(&big, 2 * tgt.nv, 2 * tgt.nf, &err), &err);
        memcpy(big.V, tgt.V, sizeof(double) * 3 * tgt.nv);
        for (int32_t i = 0; i < tgt.nv; i++) {
            big.V[3 * (tgt.nv + i)] = tgt.V[3 * i] + 10.0;
            big.V[3 * (tgt.nv + i) + 1] = tgt.V[3 * i + 1];
            big.V[3 * (tgt.nv + i) + 2] = tgt.V[3 * i + 2];
        }
        for (int32_t f = 0; f < 3 * tgt.nf; f++) {
            big.F[f] = tgt.F[f];
            big.F[3 * tgt.nf + f] = tgt.F[f] + tgt.nv;
        }
        {
            dtx_status st = dtx_sp04_plan_create(&src, &big, ident, tgt.nf, DTX_ANCHOR_FIXED,
                                                 NULL, NULL, 0, &plan, &err);
            CHECK_EQ_INT(st, DTX_EMESH);
            CHECK(strstr(err.msg, "multicomponent") != NULL);
            CHECK(plan == NULL);
        }
        dtx_mesh_free(&big);
    }

    free(Xs);
    free(Xt);
    free(Xt2);
    free(res);
    free(ident);
    dtx_mesh_free(&src);
    dtx_mesh_free(&tgt);
    return check_report();
}
