/*
 * test_skinning.c: the clustered ARAP skinning fit and its parts.
 *  - 3x3 signed SVD and polar decomposition: orthonormal factors with
 *    det +1, reconstruction, the reflection fix, rank-deficient and zero
 *    matrices, and the nearest rotation equal to LAPACK's (dgesvd) Kabsch;
 *  - so(3) log/exp round trips at 0, tiny, moderate and near-pi angles;
 *  - k-means: separated blobs found, deterministic, bitwise equal with 1
 *    and 2 threads;
 *  - skinning: identity transforms give the rest mesh bit for bit; the
 *    evaluation equals the textbook formula; features of the rest pose and
 *    of a rigid motion;
 *  - the fit, on a generated bending tube (always) and on the cactus
 *    sequence (when /work/shared/data/cactus is there): a rigid motion is
 *    fitted with ~0 energy and every T_k equal to it, a general affine map
 *    with lambda = 0 likewise; the energy never increases over the
 *    local/global steps; the reported energy and E_diff equal a direct
 *    evaluation on the mesh; translating a frame only moves the
 *    translations; 1 and 2 threads and batch vs single-frame calls give
 *    bitwise equal results;
 *  - the batched fit error (dtx_skin_eval_error) equals the mean vertex
 *    distance of the reference path (dtx_skin_fit_create, _fit_frames,
 *    dtx_skin_apply) to 1e-9 relative, for several handle counts and
 *    clusterings; is bitwise repeatable with one workspace reused; is 0 for
 *    a rigid motion; refuses a workspace too small and non-unit row sums;
 *  - bad inputs are refused with their status.
 */
#include "check.h"
#include "dtx_core.h"
#include "mat3.h"
#include "meshfile.h"
#include "skinning.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

extern void dgesvd_(const char *jobu, const char *jobvt, const int *m, const int *n, double *a,
                    const int *lda, double *s, double *u, const int *ldu, double *vt,
                    const int *ldvt, double *work, const int *lwork, int *info);

static const double PI = 3.14159265358979323846;

static uint64_t rng_state = 12345;
static double urand(void) /* [0, 1) */
{
    rng_state = rng_state * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(rng_state >> 11) * (1.0 / 9007199254740992.0);
}

static void matmul3(const double *A, const double *B, double *C)
{
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++)
            C[3 * r + c] = A[3 * r] * B[c] + A[3 * r + 1] * B[3 + c] + A[3 * r + 2] * B[6 + c];
}

static double det3(const double *A)
{
    return A[0] * (A[4] * A[8] - A[5] * A[7]) - A[1] * (A[3] * A[8] - A[5] * A[6]) +
           A[2] * (A[3] * A[7] - A[4] * A[6]);
}

static double max_abs_diff(const double *a, const double *b, size_t n)
{
    double m = 0.0;
    for (size_t i = 0; i < n; i++)
        m = fmax(m, fabs(a[i] - b[i]));
    return m;
}

/* |Q^T Q - I|_max */
static double orth_err(const double *Q)
{
    double e = 0.0;
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++) {
            double s = Q[a] * Q[b] + Q[3 + a] * Q[3 + b] + Q[6 + a] * Q[6 + b];
            e = fmax(e, fabs(s - (a == b)));
        }
    return e;
}

static void random_rotation(double angle, double *R)
{
    double w[3] = {urand() - 0.5, urand() - 0.5, urand() - 0.5}, n;
    n = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    for (int k = 0; k < 3; k++)
        w[k] *= angle / n;
    dtx_so3_exp(w, R);
}

/* The rotation nearest A by LAPACK: U diag(1, 1, det(U V^T)) V^T. */
static void kabsch_lapack(const double *A, double *R)
{
    double a[9], s[3], U[9], VT[9], work[64], Ur[9], Vt[9], D;
    int three = 3, lwork = 64, info = 0;
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++)
            a[r + 3 * c] = A[3 * r + c];
    dgesvd_("A", "A", &three, &three, a, &three, s, U, &three, VT, &three, work, &lwork, &info);
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) {
            Ur[3 * r + c] = U[r + 3 * c];
            Vt[3 * r + c] = VT[r + 3 * c];
        }
    D = det3(Ur) * det3(Vt) < 0 ? -1.0 : 1.0;
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++)
            R[3 * r + c] =
                Ur[3 * r] * Vt[c] + Ur[3 * r + 1] * Vt[3 + c] + D * Ur[3 * r + 2] * Vt[6 + c];
}

static void check_svd(const double *A, double tol)
{
    double U[9], s[3], V[9], US[9], B[9], Vt[9], R[9], S[9], RS[9], Rl[9], scale = 0.0;
    for (int k = 0; k < 9; k++)
        scale = fmax(scale, fabs(A[k]));
    dtx_svd3(A, U, s, V);
    CHECK_DBL(orth_err(U), <, 1e-14);
    CHECK_DBL(orth_err(V), <, 1e-14);
    CHECK_NEAR(det3(U), 1.0, 1e-14);
    CHECK_NEAR(det3(V), 1.0, 1e-14);
    CHECK(s[0] >= s[1] && s[1] >= fabs(s[2]) - 4e-16 * s[0]);
    CHECK(det3(A) * s[2] >= -tol * scale * scale * scale);
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) {
            US[3 * r + c] = U[3 * r + c] * s[c];
            Vt[3 * r + c] = V[3 * c + r];
        }
    matmul3(US, Vt, B);
    CHECK_DBL(max_abs_diff(A, B, 9), <=, tol * fmax(scale, 1e-300));
    dtx_polar3(A, R, S);
    matmul3(R, S, RS);
    CHECK_DBL(orth_err(R), <, 1e-14);
    CHECK_NEAR(det3(R), 1.0, 1e-14);
    CHECK_DBL(max_abs_diff(A, RS, 9), <=, tol * fmax(scale, 1e-300));
    CHECK(S[1] == S[3] && S[2] == S[6] && S[5] == S[7]);
    /* Against LAPACK, where the nearest rotation is unique (sigma2 + sigma3
     * well away from 0). */
    if (s[1] + s[2] > 1e-3 * scale) {
        kabsch_lapack(A, Rl);
        CHECK_DBL(max_abs_diff(R, Rl, 9), <, 1e-9);
    }
}

static void test_svd_polar(void)
{
    double A[9], R[9], Z[9] = {0};
    for (int t = 0; t < 2000; t++) {
        for (int k = 0; k < 9; k++)
            A[k] = 2.0 * urand() - 1.0;
        check_svd(A, 1e-14);
    }
    /* A rotation is its own polar factor; a reflection gets the fix. */
    random_rotation(2.0, R);
    check_svd(R, 1e-14);
    {
        double U[9], s[3], V[9], M[9];
        memcpy(M, R, sizeof M);
        for (int r = 0; r < 3; r++)
            M[3 * r + 2] = -M[3 * r + 2];
        dtx_svd3(M, U, s, V);
        CHECK_NEAR(s[0], 1.0, 1e-14);
        CHECK_NEAR(s[2], -1.0, 1e-14);
        check_svd(M, 1e-14);
    }
    /* Rank 2, rank 1, zero, and badly scaled matrices. */
    for (int t = 0; t < 200; t++) {
        double a[3], b[3], c[3];
        for (int k = 0; k < 3; k++) {
            a[k] = urand() - 0.5;
            b[k] = urand() - 0.5;
            c[k] = urand() - 0.5;
        }
        for (int r = 0; r < 3; r++)
            for (int k = 0; k < 3; k++)
                A[3 * r + k] = a[r] * b[k] + (t % 2 ? c[r] * a[k] : 0.0);
        check_svd(A, 1e-14);
        for (int k = 0; k < 9; k++)
            A[k] *= 1e-200;
        check_svd(A, 1e-14);
    }
    check_svd(Z, 0.0);
    {
        double U[9], s[3], V[9];
        dtx_svd3(Z, U, s, V);
        CHECK(s[0] == 0.0 && s[1] == 0.0 && s[2] == 0.0);
        CHECK(U[0] == 1.0 && U[4] == 1.0 && V[8] == 1.0);
    }
    /* Polar of a known R S. */
    {
        double S0[9] = {2.0, 0.3, -0.1, 0.3, 1.5, 0.2, -0.1, 0.2, 0.7}, RS[9], R2[9], S2[9];
        random_rotation(1.2, R);
        matmul3(R, S0, RS);
        dtx_polar3(RS, R2, S2);
        CHECK_DBL(max_abs_diff(R, R2, 9), <, 1e-14);
        CHECK_DBL(max_abs_diff(S0, S2, 9), <, 1e-14);
    }
}

static void test_so3(void)
{
    const double angles[] = {0.0,        1e-12,
                             1e-8,       1e-5,
                             1e-3,       0.5,
                             PI / 2,     2 * PI / 3 - 1e-9,
                             2 * PI / 3, 2 * PI / 3 + 1e-9,
                             3.0,        PI - 1e-4,
                             PI - 1e-7,  PI - 1e-10,
                             PI};
    double worst_rt = 0.0, worst_w = 0.0, worst_ang = 0.0;
    for (size_t a = 0; a < sizeof angles / sizeof angles[0]; a++)
        for (int t = 0; t < 50; t++) {
            double w[3], R[9], w2[3], R2[9], n, ang = angles[a];
            random_rotation(ang, R);
            dtx_so3_log(R, w);
            dtx_so3_exp(w, R2);
            worst_rt = fmax(worst_rt, max_abs_diff(R, R2, 9));
            n = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
            worst_ang = fmax(worst_ang, fabs(n - ang));
            /* log(exp(w)) = w for |w| < pi */
            if (ang < PI - 1e-6) {
                double w0[3] = {urand() - 0.5, urand() - 0.5, urand() - 0.5}, nn;
                nn = sqrt(w0[0] * w0[0] + w0[1] * w0[1] + w0[2] * w0[2]);
                for (int k = 0; k < 3; k++)
                    w0[k] *= ang / nn;
                dtx_so3_exp(w0, R);
                dtx_so3_log(R, w2);
                worst_w = fmax(worst_w, max_abs_diff(w0, w2, 3) / fmax(1.0, 1e-6 / (PI - ang)));
            }
        }
    CHECK_DBL(worst_rt, <, 1e-14);
    CHECK_DBL(worst_ang, <, 1e-13);
    CHECK_DBL(worst_w, <, 1e-13);
    /* Exactly pi about a coordinate axis, and the identity. */
    {
        double R[9] = {1, 0, 0, 0, -1, 0, 0, 0, -1}, w[3], I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
        dtx_so3_log(R, w);
        CHECK_NEAR(fabs(w[0]), PI, 1e-15);
        CHECK(w[1] == 0.0 && w[2] == 0.0);
        dtx_so3_log(I, w);
        CHECK(w[0] == 0.0 && w[1] == 0.0 && w[2] == 0.0);
    }
}

static void test_kmeans(void)
{
    enum { N = 6000, D = 8, K = 10 };
    double *X = malloc(sizeof(double) * N * D), *C1 = malloc(sizeof(double) * K * D),
           *C2 = malloc(sizeof(double) * K * D);
    int32_t *l1 = malloc(sizeof(int32_t) * N), *l2 = malloc(sizeof(int32_t) * N);
    int it1 = 0, it2 = 0, ok = 1;
    dtx_error e = {0};
    /* K well-separated blobs; point i in blob i % K. */
    for (int i = 0; i < N; i++)
        for (int d = 0; d < D; d++)
            X[i * D + d] = (d == 0 ? 10.0 * (i % K) : 0.0) + 0.3 * (urand() - 0.5);
    CHECK_OK(dtx_kmeans(X, N, D, K, 100, 7, 1, l1, C1, &it1, &e), &e);
    CHECK_OK(dtx_kmeans(X, N, D, K, 100, 7, 2, l2, C2, &it2, &e), &e);
    CHECK(memcmp(l1, l2, sizeof(int32_t) * N) == 0);
    CHECK(memcmp(C1, C2, sizeof(double) * K * D) == 0);
    CHECK_EQ_INT(it1, it2);
    /* Blobs recovered: points of one blob share a label, labels distinct. */
    for (int i = K; i < N; i++)
        ok &= l1[i] == l1[i % K];
    for (int a = 0; a < K; a++)
        for (int b = a + 1; b < K; b++)
            ok &= l1[a] != l1[b];
    CHECK(ok);
    CHECK_INT(it1, <=, 10);
    /* Same seed, same answer; more clusters than distinct points still
     * fills every cluster. */
    CHECK_OK(dtx_kmeans(X, N, D, K, 100, 7, 2, l2, NULL, NULL, &e), &e);
    CHECK(memcmp(l1, l2, sizeof(int32_t) * N) == 0);
    {
        double P[5 * 2] = {0, 0, 0, 0, 1, 1, 1, 1, 2, 2};
        int32_t lab[5], cnt[4] = {0};
        CHECK_OK(dtx_kmeans(P, 5, 2, 4, 50, 1, 1, lab, NULL, NULL, &e), &e);
        for (int i = 0; i < 5; i++)
            cnt[lab[i]]++;
        CHECK(cnt[0] > 0 && cnt[1] > 0 && cnt[2] > 0 && cnt[3] > 0);
    }
    /* Uniform random points (no structure, so many rounds and many label
     * changes): the result is a Lloyd fixed point, i.e. the bounds skipped
     * no point whose nearest centre changed, and the incrementally updated
     * centres are the means. */
    for (int i = 0; i < N * D; i++)
        X[i] = urand();
    CHECK_OK(dtx_kmeans(X, N, D, K, 1000, 3, 2, l1, C1, &it1, &e), &e);
    CHECK_INT(it1, <, 1000);
    {
        double *mean = calloc(K * D, sizeof(double)), worst = 0.0;
        int cnt[K] = {0}, nearest_ok = 1;
        for (int i = 0; i < N; i++) {
            int32_t bj = 0;
            double bd = INFINITY;
            for (int j = 0; j < K; j++) {
                double t = 0.0;
                for (int d = 0; d < D; d++)
                    t += (X[i * D + d] - C1[j * D + d]) * (X[i * D + d] - C1[j * D + d]);
                if (t < bd - 1e-12) {
                    bd = t;
                    bj = j;
                }
            }
            nearest_ok &= bj == l1[i];
            cnt[l1[i]]++;
            for (int d = 0; d < D; d++)
                mean[l1[i] * D + d] += X[i * D + d];
        }
        for (int j = 0; j < K; j++)
            for (int d = 0; d < D; d++)
                worst = fmax(worst, fabs(mean[j * D + d] / cnt[j] - C1[j * D + d]));
        CHECK(nearest_ok);
        CHECK_DBL(worst, <, 1e-12);
        printf("k-means on %d uniform points in %d-D, k = %d: %d rounds\n", N, D, K, it1);
        free(mean);
    }
    CHECK_EQ_INT(dtx_kmeans(X, 3, D, 4, 10, 1, 1, l1, NULL, NULL, &e), DTX_EINVAL);
    X[5] = NAN;
    CHECK_EQ_INT(dtx_kmeans(X, N, D, K, 10, 1, 1, l1, NULL, NULL, &e), DTX_ENONFINITE);
    free(X);
    free(C1);
    free(C2);
    free(l1);
    free(l2);
}

/* ------------------------------------------------------------------ */
/* Meshes, weights and frames                                          */
/* ------------------------------------------------------------------ */

/* An open tube along z: nr rings of nu vertices, radius 0.25, z in [0, 2]. */
static void make_tube(int nu, int nr, dtx_mesh *m)
{
    int32_t f = 0;
    dtx_mesh_alloc(m, nu * nr, 2 * nu * (nr - 1), NULL);
    for (int j = 0; j < nr; j++)
        for (int i = 0; i < nu; i++) {
            double ph = 2 * PI * (i + 0.5 * (j % 2)) / nu, *x = m->V + 3 * (j * nu + i);
            x[0] = 0.25 * cos(ph);
            x[1] = 0.25 * sin(ph);
            x[2] = 2.0 * j / (nr - 1);
        }
    for (int j = 0; j + 1 < nr; j++)
        for (int i = 0; i < nu; i++) {
            int32_t a = j * nu + i, b = j * nu + (i + 1) % nu, c = (j + 1) * nu + i,
                    d = (j + 1) * nu + (i + 1) % nu, *t = m->F + 3 * f;
            t[0] = a, t[1] = b, t[2] = c;
            t[3] = b, t[4] = d, t[5] = c;
            f += 2;
        }
}

/* Bends the part of the tube above z = 1 about the y axis with curvature
 * kappa (a knee), and twists it a little. */
static void bend_tube(const double *V, int32_t nv, double kappa, double *X)
{
    for (int32_t i = 0; i < nv; i++) {
        double x = V[3 * i], y = V[3 * i + 1], z = V[3 * i + 2];
        if (z <= 1.0 || kappa == 0.0) {
            X[3 * i] = x, X[3 * i + 1] = y, X[3 * i + 2] = z;
        } else {
            double s = z - 1.0, ph = kappa * s, r = 1.0 / kappa, tw = 0.3 * kappa * s;
            double xt = x * cos(tw) - y * sin(tw), yt = x * sin(tw) + y * cos(tw);
            X[3 * i] = r - (r - xt) * cos(ph);
            X[3 * i + 1] = yt;
            X[3 * i + 2] = 1.0 + (r - xt) * sin(ph);
        }
    }
}

/* m handles by farthest point sampling from vertex 0; weights the softmax
 * of -d^2 / sigma^2 (a partition of unity, every entry positive). */
static void make_weights(const dtx_mesh *mesh, int32_t m, double sigma, double *W, int32_t *handles)
{
    int32_t nv = mesh->nv;
    double *dmin = malloc(sizeof(double) * nv);
    handles[0] = 0;
    for (int32_t i = 0; i < nv; i++)
        dmin[i] = INFINITY;
    for (int32_t k = 0; k < m; k++) {
        int32_t best = 0;
        if (k > 0) {
            for (int32_t i = 1; i < nv; i++)
                if (dmin[i] > dmin[best])
                    best = i;
            handles[k] = best;
        }
        for (int32_t i = 0; i < nv; i++) {
            double d[3];
            for (int c = 0; c < 3; c++)
                d[c] = mesh->V[3 * i + c] - mesh->V[3 * handles[k] + c];
            dmin[i] = fmin(dmin[i], d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        }
    }
    for (int32_t i = 0; i < nv; i++) {
        double lo = INFINITY, s = 0.0, *w = W + (size_t)i * m;
        for (int32_t k = 0; k < m; k++) {
            double d[3];
            for (int c = 0; c < 3; c++)
                d[c] = mesh->V[3 * i + c] - mesh->V[3 * handles[k] + c];
            w[k] = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) / (sigma * sigma);
            lo = fmin(lo, w[k]);
        }
        for (int32_t k = 0; k < m; k++) {
            w[k] = exp(-(w[k] - lo));
            s += w[k];
        }
        for (int32_t k = 0; k < m; k++)
            w[k] /= s;
    }
    free(dmin);
}

static void rigid(const double *V, int32_t nv, const double *R, const double *t, double *X)
{
    for (int32_t i = 0; i < nv; i++)
        for (int r = 0; r < 3; r++)
            X[3 * i + r] = R[3 * r] * V[3 * i] + R[3 * r + 1] * V[3 * i + 1] +
                           R[3 * r + 2] * V[3 * i + 2] + t[r];
}

static void test_apply(const dtx_mesh *mesh, int32_t m, const double *W)
{
    int32_t nv = mesh->nv;
    double *T = malloc(sizeof(double) * 2 * m * 12), *Q = malloc(sizeof(double) * 2 * nv * 3),
           worst = 0.0;
    for (int32_t k = 0; k < 2 * m; k++)
        for (int j = 0; j < 12; j++)
            T[12 * k + j] = (j % 4 == j / 4) ? 1.0 : 0.0;
    dtx_skin_apply(nv, m, mesh->V, W, 2, T, 2, Q);
    CHECK(memcmp(Q, mesh->V, sizeof(double) * nv * 3) == 0);
    CHECK(memcmp(Q + 3 * nv, mesh->V, sizeof(double) * nv * 3) == 0);
    for (int32_t k = 0; k < 2 * m; k++)
        for (int j = 0; j < 12; j++)
            T[12 * k + j] = urand() - 0.5;
    dtx_skin_apply(nv, m, mesh->V, W, 2, T, 1, Q);
    for (int32_t f = 0; f < 2; f++)
        for (int32_t i = 0; i < nv; i++)
            for (int r = 0; r < 3; r++) {
                double q = 0.0;
                const double *p = mesh->V + 3 * i;
                for (int32_t k = 0; k < m; k++) {
                    const double *t = T + 12 * ((size_t)f * m + k) + 4 * r;
                    q += W[(size_t)i * m + k] * (t[0] * p[0] + t[1] * p[1] + t[2] * p[2] + t[3]);
                }
                worst = fmax(worst, fabs(q - Q[3 * ((size_t)f * nv + i) + r]));
            }
    CHECK_DBL(worst, <, 1e-13);
    free(T);
    free(Q);
}

static void test_features(const dtx_skin_mesh *sm, const dtx_mesh *mesh)
{
    int32_t nv = mesh->nv;
    double *X = malloc(sizeof(double) * 2 * nv * 3), *feat = malloc(sizeof(double) * nv * 18), R[9],
           t[3] = {1, -2, 3}, w[3], e0 = 0.0, e1 = 0.0;
    dtx_skin_params p;
    dtx_error e = {0};
    dtx_skin_params_default(&p);
    random_rotation(2.5, R);
    dtx_so3_log(R, w);
    memcpy(X, mesh->V, sizeof(double) * nv * 3);
    rigid(mesh->V, nv, R, t, X + 3 * nv);
    CHECK_OK(dtx_skin_features(sm, 2, X, &p, feat, &e), &e);
    for (int32_t i = 0; i < nv; i++) {
        const double *f0 = feat + 18 * (size_t)i, *f1 = f0 + 9;
        const double s_id[6] = {1, 1, 1, 0, 0, 0};
        e0 = fmax(e0, fmax(max_abs_diff(f0, (const double[3]){0, 0, 0}, 3),
                           max_abs_diff(f0 + 3, s_id, 6)));
        e1 = fmax(e1, fmax(max_abs_diff(f1, w, 3), max_abs_diff(f1 + 3, s_id, 6)));
    }
    CHECK_DBL(e0, <, 1e-12);
    CHECK_DBL(e1, <, 1e-11);
    free(X);
    free(feat);
}

/* Everything about fitting nframes frames X on one mesh with m handles.
 * label: for the messages. */
static void check_fit_sequence(const char *label, const dtx_mesh *mesh, const dtx_skin_mesh *sm,
                               int32_t m, const double *W, int32_t nframes, const double *X)
{
    int32_t nv = mesh->nv, *labels = malloc(sizeof(int32_t) * nv),
            *labels2 = malloc(sizeof(int32_t) * nv), ncl, *it1, *it2;
    double *feat = malloc(sizeof(double) * nv * 9 * nframes), *feat2,
           *T1 = malloc(sizeof(double) * nframes * m * 12),
           *T2 = malloc(sizeof(double) * nframes * m * 12), *E1 = malloc(sizeof(double) * nframes),
           *E2 = malloc(sizeof(double) * nframes), *D1 = malloc(sizeof(double) * nframes), *R1, *R2,
           *tr1, *tr2, worst_up = 0.0, worst_e = 0.0, worst_d = 0.0;
    dtx_skin_params p;
    dtx_skin_fit *fit = NULL;
    dtx_skin_out o1, o2;
    dtx_error e = {0};
    int ntr;

    printf("%s: %d vertices, %d handles, %d frames\n", label, (int)nv, (int)m, (int)nframes);
    dtx_skin_params_default(&p);
    ncl = m;
    ntr = 2 * p.max_iters + 1;
    feat2 = malloc(sizeof(double) * nv * 9 * nframes);
    R1 = malloc(sizeof(double) * nframes * ncl * 9);
    R2 = malloc(sizeof(double) * nframes * ncl * 9);
    tr1 = malloc(sizeof(double) * nframes * ntr);
    tr2 = malloc(sizeof(double) * nframes * ntr);
    it1 = malloc(sizeof(int32_t) * nframes);
    it2 = malloc(sizeof(int32_t) * nframes);

    /* ---- features and clusters: 1 vs 2 threads bitwise */
    p.threads = 1;
    CHECK_OK(dtx_skin_features(sm, nframes, X, &p, feat, &e), &e);
    CHECK_OK(dtx_skin_cluster(nv, m, W, nframes, feat, &p, labels, &e), &e);
    p.threads = 2;
    CHECK_OK(dtx_skin_features(sm, nframes, X, &p, feat2, &e), &e);
    CHECK(memcmp(feat, feat2, sizeof(double) * nv * 9 * nframes) == 0);
    CHECK_OK(dtx_skin_cluster(nv, m, W, nframes, feat2, &p, labels2, &e), &e);
    CHECK(memcmp(labels, labels2, sizeof(int32_t) * nv) == 0);
    {
        int32_t *count = calloc((size_t)ncl, sizeof(int32_t)), nonempty = 0;
        for (int32_t i = 0; i < nv; i++)
            count[labels[i]]++;
        for (int32_t g = 0; g < ncl; g++)
            nonempty += count[g] > 0;
        CHECK_EQ_INT(nonempty, ncl);
        free(count);
    }

    /* ---- the fit: 1 vs 2 threads bitwise, the trace, direct energies */
    CHECK_OK(dtx_skin_fit_create(sm, m, W, labels, ncl, &p, &fit, &e), &e);
    if (!fit)
        goto done;
    o1 = (dtx_skin_out){T1, E1, D1, it1, R1, tr1};
    o2 = (dtx_skin_out){T2, E2, NULL, it2, R2, tr2};
    p.threads = 1;
    CHECK_OK(dtx_skin_fit_frames(fit, nframes, X, &p, &o1, &e), &e);
    p.threads = 2;
    CHECK_OK(dtx_skin_fit_frames(fit, nframes, X, &p, &o2, &e), &e);
    CHECK(memcmp(T1, T2, sizeof(double) * nframes * m * 12) == 0);
    CHECK(memcmp(E1, E2, sizeof(double) * nframes) == 0);
    CHECK(memcmp(R1, R2, sizeof(double) * nframes * ncl * 9) == 0);
    CHECK(memcmp(it1, it2, sizeof(int32_t) * nframes) == 0);
    CHECK(memcmp(tr1, tr2, sizeof(double) * nframes * ntr) == 0);
    {
        double sumit = 0.0, maxE = 0.0;
        for (int32_t f = 0; f < nframes; f++) {
            const double *tr = tr1 + (size_t)f * ntr;
            double Ed, Dd;
            int n = 1 + 2 * it1[f];
            sumit += it1[f];
            maxE = fmax(maxE, E1[f]);
            CHECK(n <= ntr && (n == ntr || isnan(tr[n])));
            for (int k = 1; k < n; k++)
                worst_up = fmax(worst_up, (tr[k] - tr[k - 1]) / tr[0]);
            CHECK(tr[n - 1] == E1[f]);
            CHECK_OK(dtx_skin_energy(fit, X + (size_t)f * nv * 3, T1 + (size_t)f * m * 12,
                                     R1 + (size_t)f * ncl * 9, &Ed, &Dd, &e),
                     &e);
            worst_e = fmax(worst_e, fabs(Ed - E1[f]) / Ed);
            worst_d = fmax(worst_d, fabs(Dd - D1[f]) / Dd);
            CHECK(E1[f] < tr[0] || it1[f] <= 1);
        }
        printf("%s: mean %.1f local/global iterations per frame; energies up to %.4g; "
               "largest rise %.2g of E0; reduced vs direct energy %.2g, E_diff %.2g\n",
               label, sumit / nframes, maxE, worst_up, worst_e, worst_d);
    }
    CHECK_DBL(worst_up, <=, 1e-12);
    CHECK_DBL(worst_e, <, 1e-9);
    CHECK_DBL(worst_d, <, 1e-9);

    /* ---- the same monotonicity seen from outside: stop after k pairs
     * (tol 0) and evaluate E directly on the mesh from the returned T and
     * R; it must not rise with k and must equal the trace */
    {
        int32_t f = nframes - 1, itx;
        double Tx[12 * 64], *Rx = malloc(sizeof(double) * ncl * 9), Ex, Ed, prev = INFINITY,
                            rise = 0.0, mism = 0.0;
        double *trx = malloc(sizeof(double) * (2 * 8 + 1));
        dtx_skin_params q = p;
        dtx_skin_out ox = {Tx, &Ex, NULL, &itx, Rx, NULL}, ot = {Tx, NULL, NULL, NULL, NULL, trx};
        q.tol = 0.0;
        q.max_iters = 8;
        CHECK_OK(dtx_skin_fit_frames(fit, 1, X + (size_t)f * nv * 3, &q, &ot, &e), &e);
        for (int k = 0; k <= 8; k++) {
            q.max_iters = k;
            CHECK_OK(dtx_skin_fit_frames(fit, 1, X + (size_t)f * nv * 3, &q, &ox, &e), &e);
            CHECK_INT(itx, <=, k); /* fewer once converged to the last ulps */
            CHECK_OK(dtx_skin_energy(fit, X + (size_t)f * nv * 3, Tx, Rx, &Ed, NULL, &e), &e);
            rise = fmax(rise, (Ed - prev) / Ed);
            mism = fmax(mism, fabs(Ed - trx[2 * itx]) / Ed);
            prev = Ed;
        }
        CHECK_DBL(rise, <=, 1e-10);
        CHECK_DBL(mism, <, 1e-9);
        free(Rx);
        free(trx);
    }

    /* ---- a fit set up on one thread gives the same bits */
    {
        dtx_skin_fit *fit1 = NULL;
        p.threads = 1;
        CHECK_OK(dtx_skin_fit_create(sm, m, W, labels, ncl, &p, &fit1, &e), &e);
        if (fit1) {
            o2.energy = E2;
            CHECK_OK(dtx_skin_fit_frames(fit1, nframes, X, &p, &o2, &e), &e);
            CHECK(memcmp(T1, T2, sizeof(double) * nframes * m * 12) == 0);
            CHECK(memcmp(E1, E2, sizeof(double) * nframes) == 0);
        }
        dtx_skin_fit_free(&fit1);
    }

    /* ---- one frame alone gives the same bits as inside the batch */
    {
        int32_t f = nframes / 2, itx;
        double Tx[12 * 64], Ex;
        dtx_skin_out ox = {Tx, &Ex, NULL, &itx, NULL, NULL};
        p.threads = 1;
        CHECK_OK(dtx_skin_fit_frames(fit, 1, X + (size_t)f * nv * 3, &p, &ox, &e), &e);
        CHECK(memcmp(Tx, T1 + (size_t)f * m * 12, sizeof(double) * m * 12) == 0);
        CHECK(Ex == E1[f]);
    }

    /* ---- a rigid motion of the rest: E ~ 0, every T_k the motion, every
     * R_g its rotation; then a translated frame moves only t */
    {
        double R[9], t[3] = {0.3, -1.0, 2.0}, *Y = malloc(sizeof(double) * nv * 3), Ex, Dx,
                     werr = 0.0, rerr = 0.0, terr = 0.0;
        double *Tx = malloc(sizeof(double) * m * 12), *Rx = malloc(sizeof(double) * ncl * 9),
               *Ty = malloc(sizeof(double) * m * 12), Ey;
        int32_t itx;
        dtx_skin_out ox = {Tx, &Ex, &Dx, &itx, Rx, NULL}, oy = {Ty, &Ey, NULL, NULL, NULL, NULL};
        random_rotation(1.9, R);
        rigid(mesh->V, nv, R, t, Y);
        CHECK_OK(dtx_skin_fit_frames(fit, 1, Y, &p, &ox, &e), &e);
        for (int32_t k = 0; k < m; k++)
            for (int r = 0; r < 3; r++) {
                for (int c = 0; c < 3; c++)
                    werr = fmax(werr, fabs(Tx[12 * k + 4 * r + c] - R[3 * r + c]));
                werr = fmax(werr, fabs(Tx[12 * k + 4 * r + 3] - t[r]));
            }
        for (int32_t g = 0; g < ncl; g++)
            rerr = fmax(rerr, max_abs_diff(Rx + 9 * g, R, 9));
        CHECK_DBL(werr, <, 1e-9);
        CHECK_DBL(rerr, <, 1e-9);
        CHECK_DBL(fabs(Ex), <, 1e-12 * nv);
        CHECK_DBL(Dx, <, 1e-14 * nv); /* cancellation: a few ulps of |q'|^2 */
        CHECK_EQ_INT(itx, 1);
        /* translate one bent frame */
        for (int32_t i = 0; i < nv; i++)
            for (int r = 0; r < 3; r++)
                Y[3 * i + r] = X[(size_t)(nframes - 1) * nv * 3 + 3 * i + r] + t[r];
        CHECK_OK(dtx_skin_fit_frames(fit, 1, Y, &p, &oy, &e), &e);
        CHECK_NEAR(Ey, E1[nframes - 1], 1e-9 * E1[nframes - 1]);
        for (int32_t k = 0; k < m; k++)
            for (int j = 0; j < 12; j++)
                terr = fmax(terr,
                            fabs(Ty[12 * k + j] - T1[(size_t)(nframes - 1) * m * 12 + 12 * k + j] -
                                 (j % 4 == 3 ? t[j / 4] : 0.0)));
        CHECK_DBL(terr, <, 1e-8);
        free(Y);
        free(Tx);
        free(Rx);
        free(Ty);
    }
    dtx_skin_fit_free(&fit);
    CHECK(fit == NULL);

    /* ---- lambda = 0: any affine map is fitted exactly */
    {
        double A[12] = {1.2, 0.3, -0.2, 0.5, -0.1, 0.8, 0.4, -1.0, 0.25, 0.1, 1.5, 2.0};
        double *Y = malloc(sizeof(double) * nv * 3), *Tx = malloc(sizeof(double) * m * 12), Ex,
               werr = 0.0;
        dtx_skin_out ox = {Tx, &Ex, NULL, NULL, NULL, NULL};
        for (int32_t i = 0; i < nv; i++)
            for (int r = 0; r < 3; r++)
                Y[3 * i + r] = A[4 * r] * mesh->V[3 * i] + A[4 * r + 1] * mesh->V[3 * i + 1] +
                               A[4 * r + 2] * mesh->V[3 * i + 2] + A[4 * r + 3];
        p.lambda = 0.0;
        CHECK_OK(dtx_skin_fit_create(sm, m, W, labels, ncl, &p, &fit, &e), &e);
        if (fit) {
            CHECK_OK(dtx_skin_fit_frames(fit, 1, Y, &p, &ox, &e), &e);
            for (int32_t k = 0; k < m; k++)
                werr = fmax(werr, max_abs_diff(Tx + 12 * k, A, 12));
            CHECK_DBL(werr, <, 1e-8);
            CHECK_DBL(fabs(Ex), <, 1e-12 * nv);
        }
        dtx_skin_fit_free(&fit);
        p.lambda = 0.5;
        free(Y);
        free(Tx);
    }

done:
    free(labels);
    free(labels2);
    free(feat);
    free(feat2);
    free(T1);
    free(T2);
    free(E1);
    free(E2);
    free(D1);
    free(R1);
    free(R2);
    free(tr1);
    free(tr2);
    free(it1);
    free(it2);
}

static void test_bad_inputs(const dtx_skin_mesh *sm, const dtx_mesh *mesh, int32_t m,
                            const double *W)
{
    int32_t nv = mesh->nv, *labels = calloc((size_t)nv, sizeof(int32_t));
    double *W2 = malloc(sizeof(double) * nv * m), *X = malloc(sizeof(double) * nv * 3), T[12 * 64];
    dtx_skin_params p;
    dtx_skin_fit *fit = NULL;
    dtx_skin_mesh *bad = NULL;
    dtx_skin_out o = {T, NULL, NULL, NULL, NULL, NULL};
    dtx_error e = {0};
    dtx_skin_params_default(&p);
    memcpy(W2, W, sizeof(double) * nv * m);
    W2[5 * m] += 0.01;
    CHECK_EQ_INT(dtx_skin_fit_create(sm, m, W2, labels, 1, &p, &fit, &e), DTX_EINVAL);
    CHECK(strstr(e.msg, "vertex 5") != NULL);
    labels[7] = 3;
    CHECK_EQ_INT(dtx_skin_fit_create(sm, m, W, labels, 3, &p, &fit, &e), DTX_ERANGE);
    labels[7] = 0;
    /* Two equal weight columns: a singular normal matrix. */
    for (int32_t i = 0; i < nv; i++) {
        double s = W[(size_t)i * m] + W[(size_t)i * m + 1];
        memcpy(W2 + (size_t)i * m, W + (size_t)i * m, sizeof(double) * m);
        W2[(size_t)i * m] = W2[(size_t)i * m + 1] = 0.5 * s;
    }
    CHECK_EQ_INT(dtx_skin_fit_create(sm, m, W2, labels, 1, &p, &fit, &e), DTX_ESOLVE);
    CHECK(fit == NULL);
    CHECK_OK(dtx_skin_fit_create(sm, m, W, labels, 1, &p, &fit, &e), &e);
    memcpy(X, mesh->V, sizeof(double) * nv * 3);
    X[3 * 11 + 1] = NAN;
    CHECK_EQ_INT(dtx_skin_fit_frames(fit, 1, X, &p, &o, &e), DTX_ENONFINITE);
    CHECK(strstr(e.msg, "vertex 11") != NULL);
    CHECK_EQ_INT(dtx_skin_features(sm, 1, X, &p, W2, &e), DTX_ENONFINITE);
    dtx_skin_fit_free(&fit);
    dtx_skin_fit_free(&fit); /* NULL is fine */
    {
        int32_t F[6] = {0, 1, 2, 0, 2, 9};
        CHECK_EQ_INT(dtx_skin_mesh_create(mesh->V, nv, F, 2, DTX_SKIN_COTAN, &bad, &e), DTX_EMESH);
        F[5] = nv;
        CHECK_EQ_INT(dtx_skin_mesh_create(mesh->V, nv, F, 2, DTX_SKIN_COTAN, &bad, &e), DTX_ERANGE);
        CHECK(bad == NULL);
    }
    free(labels);
    free(W2);
    free(X);
}

/* dtx_skin_eval_error against the reference path on the same weights,
 * clustering and frames. */
static void test_eval_error(const dtx_skin_mesh *sm, const dtx_mesh *mesh, int32_t mmax,
                            const double *Wmax, int32_t nfr, const double *X)
{
    int32_t nv = mesh->nv;
    dtx_skin_params p;
    dtx_error e = {0};
    double *W = malloc(sizeof(double) * nv * mmax), *T = malloc(sizeof(double) * nfr * mmax * 12);
    double *Q = malloc(sizeof(double) * nv * 3), *Xr = malloc(sizeof(double) * nv * 3);
    int32_t *labels = malloc(sizeof(int32_t) * nv);
    dtx_skin_eval_work *w = dtx_skin_eval_work_new(sm, nfr, mmax, mmax + 1);
    dtx_skin_params_default(&p);
    p.threads = 1;
    CHECK(w != NULL);
    for (int32_t m = 2; w && m <= mmax; m += 2)
        for (int32_t ncl = m - 1; ncl <= m + 1; ncl++) {
            dtx_skin_eval *ev = NULL;
            dtx_skin_fit *fit = NULL;
            dtx_skin_out o;
            double ref = 0.0, got = NAN, again = NAN;
            /* The first m handles' weights, renormalised; clusters by the
             * largest weight folded into ncl. */
            for (int32_t i = 0; i < nv; i++) {
                double s = 0.0;
                int32_t best = 0;
                for (int32_t k = 0; k < m; k++)
                    s += Wmax[(size_t)i * mmax + k];
                for (int32_t k = 0; k < m; k++) {
                    W[(size_t)i * m + k] = Wmax[(size_t)i * mmax + k] / s;
                    if (W[(size_t)i * m + k] > W[(size_t)i * m + best])
                        best = k;
                }
                labels[i] = best % ncl;
            }
            p.nclusters = ncl;
            CHECK_OK(dtx_skin_fit_create(sm, m, W, labels, ncl, &p, &fit, &e), &e);
            memset(&o, 0, sizeof o);
            o.T = T;
            CHECK_OK(dtx_skin_fit_frames(fit, nfr, X, &p, &o, &e), &e);
            for (int32_t f = 0; f < nfr; f++) {
                dtx_skin_apply(nv, m, mesh->V, W, 1, T + (size_t)f * m * 12, 1, Q);
                for (int32_t i = 0; i < nv; i++) {
                    const double *q = Q + 3 * i, *y = X + ((size_t)f * nv + i) * 3;
                    ref += sqrt((q[0] - y[0]) * (q[0] - y[0]) + (q[1] - y[1]) * (q[1] - y[1]) +
                                (q[2] - y[2]) * (q[2] - y[2]));
                }
            }
            ref /= (double)nfr * nv;
            CHECK_OK(dtx_skin_eval_create(sm, labels, ncl, nfr, X, &p, &ev, &e), &e);
            CHECK_OK(dtx_skin_eval_error(ev, m, W, w, &got, &e), &e);
            CHECK_OK(dtx_skin_eval_error(ev, m, W, w, &again, &e), &e);
            CHECK_DBL(ref, >, 1e-4); /* the bends are not fitted exactly */
            CHECK_DBL(fabs(got - ref), <=, 1e-9 * ref);
            CHECK(memcmp(&got, &again, sizeof got) == 0);
            dtx_skin_eval_free(&ev);
            dtx_skin_fit_free(&fit);
        }
    /* A rigid motion of the rest mesh is fitted exactly. */
    {
        dtx_skin_eval *ev = NULL;
        double R[9], t[3] = {0.3, -1.0, 2.0}, got = NAN;
        int32_t m = 2;
        random_rotation(0.7, R);
        rigid(mesh->V, nv, R, t, Xr);
        for (int32_t i = 0; i < nv; i++) {
            labels[i] = i % 2;
            W[2 * i] = (double)i / (nv - 1);
            W[2 * i + 1] = 1.0 - W[2 * i];
        }
        CHECK_OK(dtx_skin_eval_create(sm, labels, 2, 1, Xr, &p, &ev, &e), &e);
        CHECK_OK(dtx_skin_eval_error(ev, m, W, w, &got, &e), &e);
        CHECK_DBL(got, <=, 1e-9);
        /* Too many handles for the workspace; rows not summing to 1. */
        CHECK_EQ_INT(dtx_skin_eval_error(ev, mmax + 1, Wmax, w, &got, &e), DTX_EINVAL);
        W[0] += 0.01;
        CHECK_EQ_INT(dtx_skin_eval_error(ev, m, W, w, &got, &e), DTX_EINVAL);
        labels[0] = 2;
        dtx_skin_eval_free(&ev);
        CHECK_EQ_INT(dtx_skin_eval_create(sm, labels, 2, 1, Xr, &p, &ev, &e), DTX_ERANGE);
        CHECK(ev == NULL);
    }
    dtx_skin_eval_work_free(&w);
    CHECK(w == NULL);
    free(W);
    free(T);
    free(Q);
    free(Xr);
    free(labels);
}

static void test_tube(void)
{
    enum { NFR = 6 };
    dtx_mesh mesh = {0};
    dtx_skin_mesh *sm = NULL, *smu = NULL;
    dtx_error e = {0};
    int32_t m = 6, handles[6], nv;
    double *W, *X;
    make_tube(24, 33, &mesh);
    nv = mesh.nv;
    W = malloc(sizeof(double) * nv * m);
    X = malloc(sizeof(double) * NFR * nv * 3);
    make_weights(&mesh, m, 0.4, W, handles);
    for (int f = 0; f < NFR; f++)
        bend_tube(mesh.V, nv, 0.4 * (f + 1), X + (size_t)f * nv * 3);
    CHECK_OK(dtx_skin_mesh_create(mesh.V, nv, mesh.F, mesh.nf, DTX_SKIN_COTAN, &sm, &e), &e);
    CHECK_OK(dtx_skin_mesh_create(mesh.V, nv, mesh.F, mesh.nf, DTX_SKIN_UNIFORM, &smu, &e), &e);
    if (sm && smu) {
        test_apply(&mesh, m, W);
        test_features(sm, &mesh);
        check_fit_sequence("tube (cotangent)", &mesh, sm, m, W, NFR, X);
        check_fit_sequence("tube (uniform)", &mesh, smu, m, W, NFR, X);
        test_bad_inputs(sm, &mesh, m, W);
        test_eval_error(sm, &mesh, m, W, NFR, X);
    }
    dtx_skin_mesh_free(&sm);
    dtx_skin_mesh_free(&smu);
    dtx_skin_mesh_free(&sm);
    free(W);
    free(X);
    dtx_mesh_free(&mesh);
}

/* The cactus: rest cactus0.ply and a few of its bending frames. */
static void test_cactus(void)
{
    const int frames[] = {3, 6, 9, 12, 15, 18};
    enum { NFR = sizeof frames / sizeof frames[0] };
    char dir[4096], path[4200];
    const char *env = getenv("DTX_CACTUS_DIR");
    dtx_mesh rest = {0};
    dtx_skin_mesh *sm = NULL;
    dtx_error e = {0};
    int32_t m = 10, handles[10], nv;
    double *W = NULL, *X = NULL, diag;
    FILE *probe;
    snprintf(dir, sizeof dir, "%s", env ? env : DTX_SRC "/../shared/data/cactus");
    snprintf(path, sizeof path, "%s/cactus0.ply", dir);
    probe = fopen(path, "rb");
    if (!probe) {
        printf("cactus: %s not found, cactus checks skipped (set DTX_CACTUS_DIR)\n", path);
        return;
    }
    fclose(probe);
    CHECK_OK(dtx_ply_read(path, &rest, NULL, &e), &e);
    nv = rest.nv;
    W = malloc(sizeof(double) * nv * m);
    X = malloc(sizeof(double) * NFR * nv * 3);
    {
        double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (int32_t i = 0; i < nv; i++)
            for (int c = 0; c < 3; c++) {
                lo[c] = fmin(lo[c], rest.V[3 * i + c]);
                hi[c] = fmax(hi[c], rest.V[3 * i + c]);
            }
        diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                    (hi[2] - lo[2]) * (hi[2] - lo[2]));
    }
    make_weights(&rest, m, 0.15 * diag, W, handles);
    for (int f = 0; f < NFR; f++) {
        dtx_mesh fr = {0};
        snprintf(path, sizeof path, "%s/cactus%d.ply", dir, frames[f]);
        CHECK_OK(dtx_ply_read(path, &fr, NULL, &e), &e);
        CHECK_EQ_INT(fr.nv, nv);
        if (fr.nv == nv)
            memcpy(X + (size_t)f * nv * 3, fr.V, sizeof(double) * nv * 3);
        dtx_mesh_free(&fr);
    }
    CHECK_OK(dtx_skin_mesh_create(rest.V, nv, rest.F, rest.nf, DTX_SKIN_COTAN, &sm, &e), &e);
    if (sm)
        check_fit_sequence("cactus", &rest, sm, m, W, NFR, X);
    dtx_skin_mesh_free(&sm);
    free(W);
    free(X);
    dtx_mesh_free(&rest);
}

int main(void)
{
    test_svd_polar();
    test_so3();
    test_kmeans();
    test_tube();
    test_cactus();
    return check_report();
}
