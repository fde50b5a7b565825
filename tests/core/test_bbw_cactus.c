/*
 * test_bbw_cactus.c: the operators and weights of bbw.h on a real mesh, the
 * shared cactus (5,261 vertices).  The cactus is not part of the
 * repository: it is read from $DTX_CACTUS or ../shared/data/cactus/
 * cactus0.ply beside the source tree, and the test is skipped (exit 77)
 * when it is absent.  test_bbw.c covers the same ground on generated meshes
 * and always runs.
 */
#include "bbw.h"
#include "laplacian.h"
#include "meshfile.h"

#include "check.h"
#include "bbw_checks.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define CACTUS_DEFAULT DTX_SRC "/../shared/data/cactus/cactus0.ply"

/* KKT conditions of each handle's programme (W from normalise = 0):
 * gradient g = Q w_k, relative to its largest entry, ~0 where 0 < w < 1,
 * >= 0 where w = 0, <= 0 where w = 1. */
static void check_kkt(const dtx_mesh *m, const dtx_csr *L, const double *M, const double *W,
                      const int32_t *h, int32_t mh)
{
    int32_t nv = m->nv;
    double *x = malloc((size_t)nv * sizeof *x), *t = malloc((size_t)nv * sizeof *t);
    double *g = malloc((size_t)nv * sizeof *g);
    unsigned char *is_h = calloc((size_t)nv, 1);
    double bad_free = 0.0, bad_lo = 0.0, bad_hi = 0.0;

    for (int32_t k = 0; k < mh; k++)
        is_h[h[k]] = 1;
    for (int32_t k = 0; k < mh; k++) {
        double scale = 0.0;
        for (int32_t i = 0; i < nv; i++)
            x[i] = W[(size_t)i * mh + k];
        for (int pass = 0; pass < 2; pass++) {
            const double *in = pass ? t : x;
            double *out = pass ? g : t;
            for (int32_t i = 0; i < nv; i++) {
                double s = 0.0;
                for (int64_t p = L->rowptr[i]; p < L->rowptr[i + 1]; p++)
                    s += L->val[p] * in[L->col[p]];
                out[i] = pass ? s : s / M[i];
            }
        }
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
    printf("KKT residuals, 5 handles (relative to the largest gradient): free %.3g, at 0 "
           "%.3g, at 1 %.3g\n", bad_free, bad_lo, bad_hi);
    CHECK_DBL(bad_free, <=, 1e-9);
    CHECK_DBL(bad_lo, <=, 1e-9);
    CHECK_DBL(bad_hi, <=, 1e-9);
    free(x);
    free(t);
    free(g);
    free(is_h);
}

int main(void)
{
    const char *path = getenv("DTX_CACTUS") ? getenv("DTX_CACTUS") : CACTUS_DEFAULT;
    dtx_mesh mesh = {0};
    dtx_error err = {0};
    dtx_csr L = {0};
    double *M, *W, *Wc, *U, worst = 0.0, msum = 0.0;
    int32_t nv, cand[20], m = 10, symmetric = 1, nonpos = 0, thin = -1;
    dtx_bbw_info info;
    dtx_bbw_incr *ctx = NULL;
    dtx_bbw_work *work = NULL;

    if (access(path, R_OK) != 0) {
        printf("SKIP: the cactus (%s) is not there; set DTX_CACTUS to its cactus0.ply\n", path);
        return 77;
    }
    CHECK_OK(dtx_mesh_read(path, &mesh, NULL, &err), &err);
    if (mesh.nv == 0)
        return check_report();
    nv = mesh.nv;
    CHECK_EQ_INT(nv, 5261);

    /* Operators. */
    M = malloc((size_t)nv * sizeof *M);
    CHECK_OK(dtx_cotan_laplacian(mesh.V, nv, mesh.F, mesh.nf, &L, &thin, &err), &err);
    CHECK_OK(dtx_mass_voronoi(mesh.V, nv, mesh.F, mesh.nf, M, NULL, &err), &err);
    for (int32_t i = 0; i < nv; i++) {
        double s = 0.0, d = 0.0;
        for (int64_t p = L.rowptr[i]; p < L.rowptr[i + 1]; p++) {
            int32_t j = L.col[p];
            s += L.val[p];
            if (j == i)
                d = L.val[p];
            else {
                int found = 0;
                for (int64_t q = L.rowptr[j]; q < L.rowptr[j + 1]; q++)
                    found |= L.col[q] == i && L.val[q] == L.val[p];
                symmetric &= found;
            }
        }
        worst = fmax(worst, fabs(s) / d);
        nonpos += !(M[i] > 0.0);
        msum += M[i];
    }
    CHECK(symmetric);
    CHECK_DBL(worst, <=, 1e-13);
    CHECK_EQ_INT(nonpos, 0);
    printf("cactus: %d vertices, %d thin triangles, max |row sum| / diagonal %.3g, area %.6g\n",
           (int)nv, (int)thin, worst, msum);

    /* Candidates, and 10 handles among them. */
    CHECK_OK(dtx_farthest_points(&mesh, 20, cand, NULL, &err), &err);
    W = malloc((size_t)nv * (m + 1) * sizeof *W);

    /* The per-handle programmes are solved exactly (5 handles, not
     * normalised). */
    {
        dtx_bbw_params prm;
        dtx_bbw_params_default(&prm);
        prm.normalise = 0;
        CHECK_OK(dtx_bbw(&mesh, cand, 5, &prm, W, NULL, &err), &err);
        check_kkt(&mesh, &L, M, W, cand, 5);
    }
    dtx_csr_free(&L);

    Wc = malloc((size_t)nv * (m + 1) * sizeof *Wc);
    U = malloc((size_t)nv * m * sizeof *U);

    CHECK_OK(dtx_bbw(&mesh, cand, m, NULL, W, &info, &err), &err);
    check_weights(W, nv, cand, m, 1e-12, 0.0, 1.0);
    CHECK_EQ_INT(info.not_converged, 0);
    CHECK_EQ_INT(info.low_sum, 0);
    /* The local steps ran (they are what the KKT check above covers
     * besides the global iterations). */
    CHECK(info.local_total > 0);
    printf("bbw, 10 handles: %d active-set iterations at most (%lld in all, and %lld local "
           "ones), row sums before normalising in [%.4f, %.4f]\n",
           info.iterations_max, (long long)info.iterations_total, (long long)info.local_total,
           info.sum_min, info.sum_max);

    /* Unbounded weights: bound violations, and how far their clamped
     * version is from the bounded weights. */
    CHECK_OK(dtx_bbw_incr_create(&mesh, cand, m, &ctx, &err), &err);
    if (ctx) {
        double viol = 0.0;
        int32_t nbad;
        work = dtx_bbw_work_new(ctx);
        memcpy(U, dtx_bbw_incr_weights(ctx), (size_t)nv * m * sizeof *U);
        check_weights(U, nv, cand, m, 1e-9, -INFINITY, INFINITY);
        nbad = dtx_bbw_clamp_normalise(U, nv, m, &viol);
        CHECK_INT(nbad, >=, 0);
        check_weights(U, nv, cand, m, 1e-12, 0.0, 1.0);
        printf("unbounded, 10 handles: %d of %d vertices out of [0, 1] (by up to %.3g); "
               "clamped and renormalised, max |W - W_bbw| = %.3g\n",
               (int)nbad, (int)nv, viol, max_abs_diff(U, W, (size_t)nv * m));

        /* Incremental against from scratch. */
        {
            double worst_add = 0.0, worst_rep = 0.0;
            int32_t hh[11];
            for (int t = m; t < 14; t++) {
                dtx_bbw_incr *fresh = NULL;
                CHECK_OK(dtx_bbw_incr_weights_add(ctx, cand[t], Wc, work, &err), &err);
                memcpy(hh, cand, (size_t)m * sizeof *hh);
                hh[m] = cand[t];
                CHECK_OK(dtx_bbw_incr_create(&mesh, hh, m + 1, &fresh, &err), &err);
                if (fresh)
                    worst_add = fmax(worst_add, max_abs_diff(Wc, dtx_bbw_incr_weights(fresh),
                                                             (size_t)nv * (m + 1)));
                dtx_bbw_incr_free(&fresh);
                CHECK_OK(dtx_bbw_incr_weights_replace(ctx, t - m, cand[t], Wc, work, &err),
                         &err);
                memcpy(hh, cand, (size_t)m * sizeof *hh);
                hh[t - m] = cand[t];
                CHECK_OK(dtx_bbw_incr_create(&mesh, hh, m, &fresh, &err), &err);
                if (fresh)
                    worst_rep = fmax(worst_rep, max_abs_diff(Wc, dtx_bbw_incr_weights(fresh),
                                                             (size_t)nv * m));
                dtx_bbw_incr_free(&fresh);
            }
            printf("incremental vs from scratch on the cactus: add %.3g, replace %.3g\n",
                   worst_add, worst_rep);
            CHECK_DBL(worst_add, <=, 1e-9);
            CHECK_DBL(worst_rep, <=, 1e-9);
        }
        dtx_bbw_work_free(&work);
        dtx_bbw_incr_free(&ctx);
    }
    free(M);
    free(W);
    free(Wc);
    free(U);
    dtx_mesh_free(&mesh);
    return check_report();
}
