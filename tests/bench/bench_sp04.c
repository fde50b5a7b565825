/*
 * bench_sp04.c: figures for scripts/bench.sh (printed, never asserted).
 *
 *   dtx_bench sp04 DATA_DIR [NFRAMES]
 *       cat -> lion in memory: correspondence, factorisation, transfer time
 *       per frame (batched, current OMP_NUM_THREADS) and a bare CHOLMOD
 *       back-substitution on the same factor, measured in the same run.
 *   dtx_bench make-sequence DATA_DIR OUT.h5 NFRAMES
 *       a long cat sequence (blends of the 9 poses) plus the cat, the lion
 *       and the markers, for end-to-end runs.
 */
#include "dtx_core.h"
#include "h5layout.h"
#include "meshfile.h"

#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void die(const dtx_error *e)
{
    fprintf(stderr, "dtx_bench: %s\n", e->msg);
    exit(1);
}

static void load(const char *dir, const char *rel, dtx_mesh *m)
{
    char p[2048];
    dtx_error e;
    snprintf(p, sizeof p, "%s/%s", dir, rel);
    if (dtx_obj_read(p, m, NULL, &e) != DTX_OK)
        die(&e);
}

/* Frame t of the long sequence: a smooth blend of two consecutive poses. */
static void blend(const double *poses, int32_t nv, int64_t t, double *out)
{
    double u = (double)(t % 50) / 50.0;
    int a = (int)((t / 50) % 9), b = (a + 1) % 9;
    for (size_t i = 0; i < 3 * (size_t)nv; i++)
        out[i] = (1 - u) * poses[(size_t)a * 3 * nv + i] + u * poses[(size_t)b * 3 * nv + i];
}

static double *load_poses(const char *dir, int32_t nv)
{
    double *poses = malloc(sizeof(double) * 3 * nv * 9);
    for (int k = 1; k <= 9; k++) {
        char rel[64];
        dtx_mesh m;
        snprintf(rel, sizeof rel, "source/cat-%02d.obj", k);
        load(dir, rel, &m);
        memcpy(poses + (size_t)(k - 1) * 3 * nv, m.V, sizeof(double) * 3 * nv);
        dtx_mesh_free(&m);
    }
    return poses;
}

int main(int argc, char **argv)
{
    dtx_mesh cat, lion;
    dtx_markers mk;
    dtx_error e;
    char p[2048];
    if (argc < 3) {
        fprintf(stderr, "usage: dtx_bench sp04 DATA_DIR [NFRAMES] | make-sequence DATA_DIR OUT.h5 N\n");
        return 2;
    }
    load(argv[2], "source/cat-reference.obj", &cat);
    load(argv[2], "target/lion-reference.obj", &lion);
    snprintf(p, sizeof p, "%s/markers.csv", argv[2]);
    if (dtx_markers_read_csv(p, 0, &mk, &e) != DTX_OK)
        die(&e);

    if (strcmp(argv[1], "make-sequence") == 0 && argc >= 5) {
        int64_t n = atoll(argv[4]), chunk = 16;
        double *poses = load_poses(argv[2], cat.nv), *buf;
        hid_t f;
        dtx_h5_seq seq;
        if (dtx_h5_create(argv[3], MPI_COMM_NULL, &f, &e) != DTX_OK ||
            dtx_h5_write_mesh(f, "/meshes/cat", &cat, "cat-reference.obj", &e) != DTX_OK ||
            dtx_h5_write_mesh(f, "/meshes/lion", &lion, "lion-reference.obj", &e) != DTX_OK ||
            dtx_h5_write_markers(f, "/markers/cat-lion", &mk, "/meshes/cat", "/meshes/lion",
                                 &e) != DTX_OK ||
            dtx_h5_seq_create(f, "/sequences/long", "/meshes/cat", n, cat.nv, 0, 16, 1, &seq,
                              &e) != DTX_OK)
            die(&e);
        buf = malloc(sizeof(double) * 3 * cat.nv * chunk);
        for (int64_t t0 = 0; t0 < n; t0 += chunk) {
            int64_t c = n - t0 < chunk ? n - t0 : chunk;
            for (int64_t i = 0; i < c; i++)
                blend(poses, cat.nv, t0 + i, buf + (size_t)i * 3 * cat.nv);
            if (dtx_h5_seq_write(&seq, t0, c, buf, 0, &e) != DTX_OK)
                die(&e);
        }
        if (dtx_h5_seq_commit(&seq, &e) != DTX_OK)
            die(&e);
        dtx_h5_seq_close(&seq);
        dtx_h5_close(&f, NULL);
        free(buf);
        free(poses);
        printf("wrote %lld frames to %s\n", (long long)n, argv[3]);
    } else if (strcmp(argv[1], "sp04") == 0) {
        int64_t n = argc > 3 ? atoll(argv[3]) : 512;
        double *poses = load_poses(argv[2], cat.nv), *Xs, *Xt, *res, t0, tc, tf, tt, tb;
        dtx_corr corr;
        dtx_corr_params prm;
        dtx_sp04_plan *plan;
        dtx_corr_params_default(&prm);
        t0 = omp_get_wtime();
        if (dtx_sp04_correspond(&cat, &lion, &mk, &prm, &corr, &e) != DTX_OK)
            die(&e);
        tc = omp_get_wtime() - t0;
        t0 = omp_get_wtime();
        if (dtx_sp04_plan_create(&cat, &lion, corr.pairs, corr.npairs, DTX_ANCHOR_FIXED, NULL,
                                 NULL, 0, &plan, &e) != DTX_OK)
            die(&e);
        tf = omp_get_wtime() - t0;
        Xs = malloc(sizeof(double) * 3 * cat.nv * n);
        Xt = malloc(sizeof(double) * 3 * lion.nv * n);
        res = malloc(sizeof(double) * n);
        for (int64_t t = 0; t < n; t++)
            blend(poses, cat.nv, t, Xs + (size_t)t * 3 * cat.nv);
        dtx_sp04_apply(plan, n < 16 ? n : 16, Xs, Xt, res, &e); /* warm-up */
        t0 = omp_get_wtime();
        if (dtx_sp04_apply(plan, n, Xs, Xt, res, &e) != DTX_OK)
            die(&e);
        tt = (omp_get_wtime() - t0) / n;
        tb = dtx_sp04_plan_bare_solve_seconds(plan, 200);
        printf("cat -> lion, %d thread(s), %lld frames in memory\n", omp_get_max_threads(),
               (long long)n);
        printf("  correspondence          %8.3f s   (%lld pairs)\n", tc, (long long)corr.npairs);
        printf("  plan + factorisation    %8.3f s   (factor alone %.4f s)\n", tf,
               dtx_sp04_plan_factor_seconds(plan));
        printf("  transfer per frame      %8.3f ms  (gradients, right-hand side, solve, residual)\n",
               tt * 1e3);
        printf("  bare back-substitution  %8.3f ms  per frame (cholmod_solve2, 3 columns, 1 thread)\n",
               tb * 1e3);
        printf("  ratio transfer / bare   %8.2f\n", tt / tb);
        dtx_sp04_plan_free(&plan);
        dtx_corr_free(&corr);
        free(Xs);
        free(Xt);
        free(res);
        free(poses);
    } else {
        fprintf(stderr, "dtx_bench: unknown command %s\n", argv[1]);
        return 2;
    }
    dtx_markers_free(&mk);
    dtx_mesh_free(&cat);
    dtx_mesh_free(&lion);
    return 0;
}
