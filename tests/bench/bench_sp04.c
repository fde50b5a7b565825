/*
 * bench_sp04.c: figures for scripts/bench.sh (printed, never asserted).
 *
 *   dtx_bench sp04 DATA_DIR [NFRAMES]
 *       source -> target in memory: correspondence, factorisation, transfer
 *       time per frame (current OMP_NUM_THREADS) and, on the same factor, a
 *       bare CHOLMOD back-substitution per frame with 3 right-hand sides per
 *       call and with a whole group's (3 x DTX_SP04_SOLVE_GROUP) per call.
 *   dtx_bench make-sequence DATA_DIR OUT.h5 NFRAMES [--gzip]
 *   dtx_bench spin
 *       a fixed amount of pure arithmetic over OMP_NUM_THREADS threads: at 1
 *       and 2 threads, what the machine's cores deliver (the ceiling of any
 *       parallel efficiency measured in the same run)
 *       a long source sequence (blends of consecutive poses) plus the rest
 *       meshes and the markers, for end-to-end runs; positions stored
 *       uncompressed unless --gzip.
 *
 * DATA_DIR holds source/<src>-reference.obj with poses source/<src>-01.obj,
 * -02.obj, ..., target/<tgt>-reference.obj and markers.csv (0-based), as
 * the bundled sumner-cat-lion and sumner-horse-camel sets do.
 */
#include "bench_data.h"
#include "dtx_core.h"
#include "h5layout.h"

#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Frames held in memory by the sp04 benchmark; longer runs repeat them. */
#define BENCH_BLOCK 512

/* Frame t of the long sequence: a smooth blend of two consecutive poses. */
static void blend(const bench_dataset *ds, int64_t t, double *out)
{
    const size_t n = 3 * (size_t)ds->src.nv;
    double u = (double)(t % 50) / 50.0;
    int a = (int)((t / 50) % ds->nposes), b = (a + 1) % ds->nposes;
    for (size_t i = 0; i < n; i++)
        out[i] = (1 - u) * ds->poses[(size_t)a * n + i] + u * ds->poses[(size_t)b * n + i];
}

static int make_sequence(const bench_dataset *ds, const char *out, int64_t n, int gzip)
{
    char msrc[300], mtgt[300], mark[600];
    const int64_t chunk = 16;
    double *buf = bench_xmalloc((size_t)chunk * 3 * ds->src.nv, sizeof *buf);
    hid_t f;
    dtx_h5_seq seq;
    dtx_error e;
    snprintf(msrc, sizeof msrc, "/meshes/%s", ds->src_name);
    snprintf(mtgt, sizeof mtgt, "/meshes/%s", ds->tgt_name);
    snprintf(mark, sizeof mark, "/markers/%s-%s", ds->src_name, ds->tgt_name);
    {
        char rs[300], rt[300];
        snprintf(rs, sizeof rs, "%s-reference.obj", ds->src_name);
        snprintf(rt, sizeof rt, "%s-reference.obj", ds->tgt_name);
        if (dtx_h5_create(out, MPI_COMM_NULL, &f, &e) != DTX_OK ||
            dtx_h5_write_mesh(f, msrc, &ds->src, rs, &e) != DTX_OK ||
            dtx_h5_write_mesh(f, mtgt, &ds->tgt, rt, &e) != DTX_OK ||
            dtx_h5_write_markers(f, mark, &ds->mk, msrc, mtgt, &e) != DTX_OK ||
            dtx_h5_seq_create(f, "/sequences/long", msrc, n, ds->src.nv, 0, (int)chunk, gzip,
                              &seq, &e) != DTX_OK)
            bench_die(&e);
    }
    for (int64_t t0 = 0; t0 < n; t0 += chunk) {
        int64_t c = n - t0 < chunk ? n - t0 : chunk;
        for (int64_t i = 0; i < c; i++)
            blend(ds, t0 + i, buf + (size_t)i * 3 * ds->src.nv);
        if (dtx_h5_seq_write(&seq, t0, c, buf, 0, &e) != DTX_OK)
            bench_die(&e);
    }
    if (dtx_h5_seq_commit(&seq, &e) != DTX_OK)
        bench_die(&e);
    dtx_h5_seq_close(&seq);
    dtx_h5_close(&f, NULL);
    free(buf);
    printf("wrote %lld frames (blends of %d poses, %s) to %s\n", (long long)n, ds->nposes,
           gzip ? "gzip" : "uncompressed", out);
    printf("  meshes    %s (%d vertices), %s (%d vertices)\n", msrc, (int)ds->src.nv, mtgt,
           (int)ds->tgt.nv);
    printf("  markers   %s (%d)\n", mark, (int)ds->mk.n);
    printf("  sequence  /sequences/long (float32, rest %s)\n", msrc);
    return 0;
}

static int bench_sp04(const bench_dataset *ds, int64_t n)
{
    const int64_t block = n < BENCH_BLOCK ? n : BENCH_BLOCK;
    const size_t fs = 3 * (size_t)ds->src.nv, ft = 3 * (size_t)ds->tgt.nv;
    double *Xs = bench_xmalloc((size_t)block, fs * sizeof *Xs);
    double *Xt = bench_xmalloc((size_t)block, ft * sizeof *Xt);
    double *res = bench_xmalloc((size_t)block, sizeof *res);
    double t0, c0, tc, tf, tt, ct, tb3, tb24;
    dtx_corr corr;
    dtx_corr_params prm;
    dtx_sp04_plan *plan;
    dtx_error e;
    int avx2;

    dtx_corr_params_default(&prm);
    t0 = omp_get_wtime();
    if (dtx_sp04_correspond(&ds->src, &ds->tgt, &ds->mk, &prm, &corr, &e) != DTX_OK)
        bench_die(&e);
    tc = omp_get_wtime() - t0;
    t0 = omp_get_wtime();
    if (dtx_sp04_plan_create(&ds->src, &ds->tgt, corr.pairs, corr.npairs, DTX_ANCHOR_FIXED, NULL,
                             NULL, 0, &plan, &e) != DTX_OK)
        bench_die(&e);
    tf = omp_get_wtime() - t0;
    avx2 = dtx_sp04_plan_use_avx2(plan, 1);

    /* Everything the timed loop touches is written once before it, so that
     * page faults of the big arrays stay out of the figure. */
    for (int64_t t = 0; t < block; t++)
        blend(ds, t, Xs + (size_t)t * fs);
    memset(Xt, 0, (size_t)block * ft * sizeof *Xt);
    if (dtx_sp04_apply(plan, block, Xs, Xt, res, &e) != DTX_OK) /* warm-up */
        bench_die(&e);

    t0 = omp_get_wtime();
    c0 = bench_cpu_seconds();
    for (int64_t done = 0; done < n; done += block) {
        int64_t m = n - done < block ? n - done : block;
        if (dtx_sp04_apply(plan, m, Xs, Xt, res, &e) != DTX_OK)
            bench_die(&e);
    }
    tt = (omp_get_wtime() - t0) / n;
    ct = (bench_cpu_seconds() - c0) / n;
    tb3 = dtx_sp04_plan_bare_solve_seconds_group(plan, 1, 200);
    tb24 = dtx_sp04_plan_bare_solve_seconds_group(plan, DTX_SP04_SOLVE_GROUP, 50);

    printf("%s -> %s, %d thread(s), %lld frames (%lld in memory), %s kernels\n", ds->src_name,
           ds->tgt_name, omp_get_max_threads(), (long long)n, (long long)block,
           avx2 ? "AVX2" : "baseline");
    printf("  source %d vertices, target %d vertices, %lld pairs\n", (int)ds->src.nv,
           (int)ds->tgt.nv, (long long)corr.npairs);
    printf("  correspondence          %8.3f s   (%d solves, %d factorisations)\n", tc, corr.solves,
           corr.factorizations);
    printf("  plan + factorisation    %8.3f s   (factor alone %.4f s)\n", tf,
           dtx_sp04_plan_factor_seconds(plan));
    printf("  transfer per frame      %8.3f ms  (right-hand side, solve, residual, output)\n",
           tt * 1e3);
    printf("  transfer CPU per frame  %8.3f ms  (all threads; wall x threads when the cores "
           "are ours)\n",
           ct * 1e3);
    printf("  bare back-substitution  %8.3f ms  per frame, cholmod_solve2, 3 columns per call\n",
           tb3 * 1e3);
    printf("  bare back-substitution  %8.3f ms  per frame, cholmod_solve2, %d columns per call\n",
           tb24 * 1e3, 3 * DTX_SP04_SOLVE_GROUP);
    printf("  ratio transfer / bare   %8.2f   (3 columns)   %.2f (%d columns)\n", tt / tb3,
           tt / tb24, 3 * DTX_SP04_SOLVE_GROUP);
    dtx_sp04_plan_free(&plan);
    dtx_corr_free(&corr);
    free(Xs);
    free(Xt);
    free(res);
    return 0;
}

/* What the cores deliver: a fixed amount of pure arithmetic (no memory
 * traffic) split over the OpenMP threads; seconds of wall time.  Run at 1
 * and 2 threads, the ratio is the machine's own speed-up, the ceiling for
 * any program (on a VM it can be well below 2). */
static int spin(void)
{
    const long total = 800000000L;
    double t0 = omp_get_wtime(), sink = 0;
#pragma omp parallel reduction(+ : sink)
    {
        long n = total / omp_get_num_threads();
        double x = 1.0;
        for (long i = 0; i < n; i++)
            x = x * 1.0000001 + 1e-9;
        sink += x;
    }
    printf("spin: %d thread(s) %.3f s (checksum %.3f)\n", omp_get_max_threads(),
           omp_get_wtime() - t0, sink > 0 ? 1.0 : 0.0);
    return 0;
}

int main(int argc, char **argv)
{
    bench_dataset ds;
    int rc;
    bench_set_name("dtx_bench");
    if (argc == 2 && strcmp(argv[1], "spin") == 0)
        return spin();
    if (argc >= 3 && strcmp(argv[1], "sp04") == 0) {
        int64_t n = argc > 3 ? atoll(argv[3]) : 512;
        if (n < 1) {
            fprintf(stderr, "dtx_bench: NFRAMES must be at least 1\n");
            return 2;
        }
        bench_load_dataset(argv[2], &ds);
        rc = bench_sp04(&ds, n);
    } else if (argc >= 5 && strcmp(argv[1], "make-sequence") == 0) {
        int64_t n = atoll(argv[4]);
        int gzip = argc > 5 && strcmp(argv[5], "--gzip") == 0;
        if (n < 1 || (argc > 5 && !gzip) || argc > 6) {
            fprintf(stderr, "usage: dtx_bench make-sequence DATA_DIR OUT.h5 N [--gzip]\n");
            return 2;
        }
        bench_load_dataset(argv[2], &ds);
        rc = make_sequence(&ds, argv[3], n, gzip);
    } else {
        fprintf(stderr, "usage: dtx_bench sp04 DATA_DIR [NFRAMES]\n"
                        "       dtx_bench spin\n"
                        "       dtx_bench make-sequence DATA_DIR OUT.h5 N [--gzip]\n");
        return 2;
    }
    bench_free_dataset(&ds);
    return rc;
}
