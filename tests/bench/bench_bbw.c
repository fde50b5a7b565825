/*
 * bench_bbw.c: timings of the biharmonic-weight building blocks (bbw.h,
 * laplacian.h) on one mesh, by default the shared cactus.
 *
 *   dtx_bench_bbw [MESH] [NCAND]
 *
 * Prints, for 1 and 2 OpenMP threads: the cotangent Laplacian, the mass
 * matrix, farthest point sampling of NCAND (default 100) candidates,
 * bounded biharmonic weights with 5, 10 and 20 handles (the first FPS
 * candidates), the incremental context (create, one candidate added, one
 * handle replaced, all candidates in parallel, a commit), and how far the
 * clamped unbounded weights are from the bounded ones.  Wall-clock times
 * (omp_get_wtime), best of a few runs for the short ones.  Never part of
 * ctest; the machine is shared, so the figures are indicative.
 */
#include "bbw.h"
#include "laplacian.h"
#include "meshfile.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define CACTUS DTX_SRC "/../shared/data/cactus/cactus0.ply"

static void die(const dtx_error *err)
{
    fprintf(stderr, "bench_bbw: %s: %s\n", dtx_status_name(err->code), err->msg);
    exit(1);
}

int main(int argc, char **argv)
{
    const char *path = argc > 1 ? argv[1] : CACTUS;
    int32_t nc = argc > 2 ? atoi(argv[2]) : 100;
    dtx_mesh mesh = {0};
    dtx_error err = {0};
    int32_t *cand, nv;
    double *M, *W, *Wb, t;
    static const int32_t sizes[3] = {5, 10, 20};

    if (dtx_mesh_read(path, &mesh, NULL, &err) != DTX_OK)
        die(&err);
    nv = mesh.nv;
    cand = malloc((size_t)nc * sizeof *cand);
    M = malloc((size_t)nv * sizeof *M);
    W = malloc((size_t)nv * (nc + 1) * sizeof *W);
    Wb = malloc((size_t)nv * 20 * sizeof *Wb);
    printf("mesh %s: %d vertices, %d triangles\n", path, (int)nv, (int)mesh.nf);

    /* Operators (serial code; best of 5). */
    {
        double tl = INFINITY, tm = INFINITY, tf = INFINITY;
        for (int r = 0; r < 5; r++) {
            dtx_csr L = {0};
            t = omp_get_wtime();
            if (dtx_cotan_laplacian(mesh.V, nv, mesh.F, mesh.nf, &L, NULL, &err) != DTX_OK)
                die(&err);
            tl = fmin(tl, omp_get_wtime() - t);
            t = omp_get_wtime();
            if (dtx_mass_voronoi(mesh.V, nv, mesh.F, mesh.nf, M, NULL, &err) != DTX_OK)
                die(&err);
            tm = fmin(tm, omp_get_wtime() - t);
            dtx_csr_free(&L);
            t = omp_get_wtime();
            if (dtx_farthest_points(&mesh, nc, cand, NULL, &err) != DTX_OK)
                die(&err);
            tf = fmin(tf, omp_get_wtime() - t);
        }
        printf("cotangent Laplacian %.2f ms, mass matrix %.2f ms, FPS of %d candidates %.1f ms\n",
               1e3 * tl, 1e3 * tm, (int)nc, 1e3 * tf);
    }

    for (int threads = 1; threads <= 2; threads++) {
        omp_set_num_threads(threads);
        printf("--- %d thread%s\n", threads, threads > 1 ? "s" : "");
        for (int si = 0; si < 3; si++) {
            int32_t m = sizes[si];
            dtx_bbw_info info;
            dtx_bbw_incr *ctx = NULL;
            dtx_bbw_work **works;
            double tc, ta = INFINITY, tr = INFINITY, tall, tcommit, viol;
            int32_t nbad, big = 0;
            if (m + 1 > nc)
                continue;
            t = omp_get_wtime();
            if (dtx_bbw(&mesh, cand, m, NULL, Wb, &info, &err) != DTX_OK)
                die(&err);
            t = omp_get_wtime() - t;
            printf("bbw %2d handles: %.3f s (%d active-set iterations at most, %lld in all, "
                   "%d not converged; row sums before normalising %.4f..%.4f)\n",
                   (int)m, t, info.iterations_max, (long long)info.iterations_total,
                   (int)info.not_converged, info.sum_min, info.sum_max);

            t = omp_get_wtime();
            if (dtx_bbw_incr_create(&mesh, cand, m, &ctx, &err) != DTX_OK)
                die(&err);
            tc = omp_get_wtime() - t;
            works = calloc((size_t)threads, sizeof *works);
            for (int k = 0; k < threads; k++)
                works[k] = dtx_bbw_work_new(ctx);
            for (int r = 0; r < 5; r++) {
                t = omp_get_wtime();
                if (dtx_bbw_incr_weights_add(ctx, cand[m], W, works[0], &err) != DTX_OK)
                    die(&err);
                ta = fmin(ta, omp_get_wtime() - t);
                t = omp_get_wtime();
                if (dtx_bbw_incr_weights_replace(ctx, 0, cand[m], W, works[0], &err) != DTX_OK)
                    die(&err);
                tr = fmin(tr, omp_get_wtime() - t);
            }
            /* Every other candidate, as a greedy round does: one output
             * array per thread. */
            {
                double *Wt = malloc((size_t)threads * nv * (m + 1) * sizeof *Wt);
                t = omp_get_wtime();
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
                for (int32_t c = m; c < nc; c++) {
                    int tid = omp_get_thread_num();
                    dtx_error e;
                    if (dtx_bbw_incr_weights_add(ctx, cand[c], Wt + (size_t)tid * nv * (m + 1),
                                                 works[tid], &e) != DTX_OK)
                        die(&e);
                }
                tall = omp_get_wtime() - t;
                free(Wt);
            }
            /* Bound violations of the unbounded weights, and the clamped
             * ones against the bounded weights. */
            memcpy(W, dtx_bbw_incr_weights(ctx), (size_t)nv * m * sizeof *W);
            for (int32_t i = 0; i < nv; i++) {
                int out = 0;
                for (int32_t k = 0; k < m; k++) {
                    double w = W[(size_t)i * m + k];
                    out |= w < -1e-3 || w > 1.0 + 1e-3;
                }
                big += out;
            }
            nbad = dtx_bbw_clamp_normalise(W, nv, m, &viol);
            {
                double d = 0.0, rms = 0.0;
                for (size_t i = 0; i < (size_t)nv * m; i++) {
                    double e = W[i] - Wb[i];
                    d = fmax(d, fabs(e));
                    rms += e * e;
                }
                rms = sqrt(rms / ((double)nv * m));
                printf("  incremental: create %.1f ms, +1 candidate %.2f ms, replace %.2f ms, "
                       "%d candidates %.1f ms (%.2f ms each)\n",
                       1e3 * tc, 1e3 * ta, 1e3 * tr, (int)(nc - m), 1e3 * tall,
                       1e3 * tall / (nc - m));
                printf("  unbounded: %d of %d vertices outside [0, 1] (%d by more than 1e-3), "
                       "worst by %.3g; clamped+renormalised vs bbw: max |dW| %.3g, rms %.3g\n",
                       (int)nbad, (int)nv, (int)big, viol, d, rms);
            }
            t = omp_get_wtime();
            if (dtx_bbw_incr_add(ctx, cand[m], &err) != DTX_OK)
                die(&err);
            tcommit = omp_get_wtime() - t;
            printf("  commit (add + refactor + %d solves) %.1f ms\n", (int)m + 1, 1e3 * tcommit);
            for (int k = 0; k < threads; k++)
                dtx_bbw_work_free(&works[k]);
            free(works);
            dtx_bbw_incr_free(&ctx);
        }
    }
    free(cand);
    free(M);
    free(W);
    free(Wb);
    dtx_mesh_free(&mesh);
    return 0;
}
