/*
 * bench_sp04.c: figures for scripts/bench.sh (printed, never asserted).
 *
 *   dtx_bench sp04 DATA_DIR [NFRAMES]
 *       source -> target in memory: correspondence, factorisation, transfer
 *       time per frame (current OMP_NUM_THREADS) and, on the same factor, a
 *       bare CHOLMOD back-substitution per frame with 3 right-hand sides per
 *       call and with a whole group's (3 x DTX_SP04_SOLVE_GROUP) per call.
 *   dtx_bench corr DATA_DIR [OPTION=VALUE ...]
 *       the sp04 correspondence alone with the default parameters changed
 *       by the options (w_smooth=, w_identity=, w_closest=A,B,C,...,
 *       max_distance=, max_angle_deg=, closest_on=surface|vertices,
 *       closest_normals=0|1, weights=element|area), the source (and its
 *       poses) first refined by subdivide=N levels of midpoint subdivision
 *       (the same surface at 4^N times the triangles): its time, pairs and fit;
 *       with paper-results/ in DATA_DIR, the transfer of every pose against
 *       the paper's (core.cat_lion_accuracy's measure: RMS per pose after
 *       removing the mean translation, over the target's bounding-box
 *       diagonal); also the source's area and density in the normalised
 *       frame (the reference of weights=area).
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
#include "correspondence_internal.h"
#include "dtx_core.h"
#include "generate.h"
#include "h5layout.h"

#include <math.h>
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

/* One OPTION=VALUE of `dtx_bench corr`; 0 when it is not one. */
static int corr_option(const char *arg, dtx_corr_params *p, int *subdivide)
{
    const char *eq = strchr(arg, '=');
    const char *v = eq ? eq + 1 : NULL;
    size_t n = eq ? (size_t)(eq - arg) : 0;
    char *end;
    if (!v)
        return 0;
#define KEY(k) (n == strlen(k) && strncmp(arg, k, n) == 0)
    if (KEY("subdivide"))
        *subdivide = (int)strtol(v, &end, 10);
    else if (KEY("w_smooth"))
        p->w_smooth = strtod(v, &end);
    else if (KEY("w_identity"))
        p->w_identity = strtod(v, &end);
    else if (KEY("max_distance"))
        p->max_distance = strtod(v, &end);
    else if (KEY("max_angle_deg"))
        p->max_angle_deg = strtod(v, &end);
    else if (KEY("closest_normals"))
        p->closest_normals = (int)strtol(v, &end, 10);
    else if (KEY("closest_on") && (!strcmp(v, "surface") || !strcmp(v, "vertices"))) {
        p->closest_on = !strcmp(v, "surface") ? DTX_CORR_ON_SURFACE : DTX_CORR_ON_VERTICES;
        end = (char *)v + strlen(v);
    } else if (KEY("weights") && (!strcmp(v, "element") || !strcmp(v, "area"))) {
        p->weights = !strcmp(v, "element") ? DTX_CORR_WEIGHTS_ELEMENT : DTX_CORR_WEIGHTS_AREA;
        end = (char *)v + strlen(v);
    } else if (KEY("w_closest")) {
        p->n_closest = 0;
        end = (char *)v;
        do {
            if (p->n_closest == 16)
                return 0;
            p->w_closest[p->n_closest++] = strtod(end + (*end == ','), &end);
        } while (*end == ',');
    } else
        return 0;
#undef KEY
    return end != v && *end == '\0';
}

/* The source of ds and its poses refined by `levels` of midpoint
 * subdivision (same surface, same markers: the old vertices keep their
 * indices). */
static void subdivide_source(bench_dataset *ds, int levels)
{
    dtx_mesh fine;
    dtx_error e;
    int32_t *map = NULL;
    double *poses;
    if (levels < 1 || levels > 3) {
        fprintf(stderr, "dtx_bench: corr: subdivide must be 1, 2 or 3\n");
        exit(2);
    }
    if (dtx_gen_subdivide(&ds->src, levels, &fine, &map, &e) != DTX_OK)
        bench_die(&e);
    free(map);
    poses = bench_xmalloc((size_t)ds->nposes, 3 * (size_t)fine.nv * sizeof *poses);
    for (int k = 0; k < ds->nposes; k++) {
        dtx_mesh p = ds->src, out;
        p.V = ds->poses + (size_t)k * 3 * ds->src.nv;
        if (dtx_gen_subdivide(&p, levels, &out, &map, &e) != DTX_OK)
            bench_die(&e);
        free(map);
        memcpy(poses + (size_t)k * 3 * fine.nv, out.V, 3 * (size_t)fine.nv * sizeof *poses);
        dtx_mesh_free(&out);
    }
    free(ds->poses);
    ds->poses = poses;
    dtx_mesh_free(&ds->src);
    ds->src = fine;
}

static int bench_corr(bench_dataset *ds, int nopt, char **opt)
{
    dtx_corr_params prm;
    dtx_corr corr;
    dtx_error e;
    double t0, tc, area = 0.0, *S0, *Tn, center[3], size;
    int subdivide = 0;
    dtx_corr coarse;

    memset(&coarse, 0, sizeof coarse);
    dtx_corr_params_default(&prm);
    for (int i = 0; i < nopt; i++)
        if (!corr_option(opt[i], &prm, &subdivide)) {
            fprintf(stderr, "dtx_bench: corr: bad option '%s'\n", opt[i]);
            return 2;
        }
    if (subdivide > 0) {
        /* The unrefined source's correspondence, to compare the deformed
         * positions of the vertices both have. */
        if (dtx_sp04_correspond(&ds->src, &ds->tgt, &ds->mk, &prm, &coarse, &e) != DTX_OK)
            bench_die(&e);
        subdivide_source(ds, subdivide);
    }
    printf("%s -> %s, %d thread(s): w_smooth %g, w_identity %g, w_closest [", ds->src_name,
           ds->tgt_name, omp_get_max_threads(), prm.w_smooth, prm.w_identity);
    for (int i = 0; i < prm.n_closest; i++)
        printf("%s%g", i ? ", " : "", prm.w_closest[i]);
    printf("], closest on %s, normal rule %s, weights per %s\n",
           prm.closest_on == DTX_CORR_ON_SURFACE ? "surface" : "vertices",
           prm.closest_normals ? "on" : "off",
           prm.weights == DTX_CORR_WEIGHTS_AREA ? "area" : "element");

    /* The source's area in the normalised frame (the correspondence's). */
    S0 = bench_xmalloc((size_t)ds->src.nv, 3 * sizeof *S0);
    Tn = bench_xmalloc((size_t)ds->tgt.nv, 3 * sizeof *Tn);
    if (dtx__corr_normalise(&ds->src, &ds->tgt, &ds->mk, prm.align, S0, Tn, center, &size,
                            &e) != DTX_OK)
        bench_die(&e);
    for (int32_t f = 0; f < ds->src.nf; f++) {
        const int32_t *t = ds->src.F + 3 * (size_t)f;
        const double *a = S0 + 3 * (size_t)t[0], *b = S0 + 3 * (size_t)t[1],
                     *c = S0 + 3 * (size_t)t[2];
        double u[3], w[3];
        for (int k = 0; k < 3; k++) {
            u[k] = b[k] - a[k];
            w[k] = c[k] - a[k];
        }
        area += 0.5 * sqrt((u[1] * w[2] - u[2] * w[1]) * (u[1] * w[2] - u[2] * w[1]) +
                           (u[2] * w[0] - u[0] * w[2]) * (u[2] * w[0] - u[0] * w[2]) +
                           (u[0] * w[1] - u[1] * w[0]) * (u[0] * w[1] - u[1] * w[0]));
    }
    printf("  source %d vertices, %d triangles, area %.4f in the normalised frame: %.0f "
           "vertices per unit area (reference %.0f)\n",
           (int)ds->src.nv, (int)ds->src.nf, area, ds->src.nv / area, DTX_CORR_REF_DENSITY);
    free(S0);
    free(Tn);

    t0 = omp_get_wtime();
    if (dtx_sp04_correspond(&ds->src, &ds->tgt, &ds->mk, &prm, &corr, &e) != DTX_OK)
        bench_die(&e);
    tc = omp_get_wtime() - t0;
    printf("  correspondence %.3f s (%d solves, %d factorisations), %lld pairs, %d target "
           "triangles by fallback, fit RMS %.3g of the size\n",
           tc, corr.solves, corr.factorizations, (long long)corr.npairs, (int)corr.unmatched_tgt,
           corr.fit_rms);
    if (coarse.deformed_src) {
        double s2 = 0.0, d = dtx_rms_extent(ds->tgt.V, ds->tgt.nv);
        for (int32_t i = 0; i < 3 * coarse.nv_src; i++) {
            double x = corr.deformed_src[i] - coarse.deformed_src[i];
            s2 += x * x;
        }
        printf("  deformed source, refined vs unrefined at the %d unrefined vertices: RMS "
               "distance %.3g of the size\n",
               (int)coarse.nv_src, sqrt(s2 / coarse.nv_src) / d);
        dtx_corr_free(&coarse);
    }
    if (ds->results) {
        const size_t fs = 3 * (size_t)ds->src.nv, ft = 3 * (size_t)ds->tgt.nv;
        double *Xt = bench_xmalloc((size_t)ds->nposes, ft * sizeof *Xt);
        double *res = bench_xmalloc((size_t)ds->nposes, sizeof *res);
        double diag = dtx_bbox_diagonal(ds->tgt.V, ds->tgt.nv), sum = 0.0, worst = 0.0;
        dtx_sp04_plan *plan;
        (void)fs;
        if (dtx_sp04_plan_create(&ds->src, &ds->tgt, corr.pairs, corr.npairs, DTX_ANCHOR_FIXED,
                                 NULL, NULL, 0, &plan, &e) != DTX_OK ||
            dtx_sp04_apply(plan, ds->nposes, ds->poses, Xt, res, &e) != DTX_OK)
            bench_die(&e);
        printf("  RMS / diagonal against the paper's results, per pose:");
        for (int k = 0; k < ds->nposes; k++) {
            const double *x = Xt + (size_t)k * ft, *y = ds->results + (size_t)k * ft;
            double ma[3] = {0, 0, 0}, mb[3] = {0, 0, 0}, s2 = 0.0, r;
            for (int32_t v = 0; v < ds->tgt.nv; v++)
                for (int j = 0; j < 3; j++) {
                    ma[j] += x[3 * v + j] / ds->tgt.nv;
                    mb[j] += y[3 * v + j] / ds->tgt.nv;
                }
            for (int32_t v = 0; v < ds->tgt.nv; v++)
                for (int j = 0; j < 3; j++) {
                    double d = (x[3 * v + j] - ma[j]) - (y[3 * v + j] - mb[j]);
                    s2 += d * d;
                }
            r = 100.0 * sqrt(s2 / ds->tgt.nv) / diag;
            sum += r;
            worst = r > worst ? r : worst;
            printf(" %.3f%%", r);
        }
        printf("\n  mean %.3f%%, worst %.3f%%\n", sum / ds->nposes, worst);
        dtx_sp04_plan_free(&plan);
        free(Xt);
        free(res);
    }
    dtx_corr_free(&corr);
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
    } else if (argc >= 3 && strcmp(argv[1], "corr") == 0) {
        bench_load_dataset(argv[2], &ds);
        bench_load_paper_results(argv[2], &ds);
        rc = bench_corr(&ds, argc - 3, argv + 3);
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
                        "       dtx_bench corr DATA_DIR [OPTION=VALUE ...]\n"
                        "       dtx_bench spin\n"
                        "       dtx_bench make-sequence DATA_DIR OUT.h5 N [--gzip]\n");
        return 2;
    }
    bench_free_dataset(&ds);
    return rc;
}
