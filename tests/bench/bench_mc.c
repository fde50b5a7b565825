/*
 * bench_mc.c: figures for scripts/bench-multicomponent.sh (printed, never
 * asserted): the multicomponent method (Zhou, Xu, Tong & Desbrun 2010) on a
 * shattered target the size of the paper's pebble camel (750 stones, 51,000
 * vertices, 99,000 triangles; 54.6 s correspondence and 14.7 s per frame).
 *
 *   dtx_bench_mc DATA_DIR [options]
 *
 * DATA_DIR holds source/<src>-reference.obj with poses source/<src>-01.obj,
 * -02.obj, ..., target/<tgt>-reference.obj and markers.csv (0-based), as the
 * shared sumner-horse-camel set does.  The target is shattered with
 * dtx_gen_pebbles and the markers moved to the pebbles (dtx_gen_remap).
 * Options (defaults in brackets):
 *   --pieces N       pebbles [750]
 *   --gap G          crack width, fraction of the diagonal [0.003]
 *   --thickness T    stone thickness, fraction of the diagonal (0: open
 *                    patches) [0.005]
 *   --subdivide L    subdivision levels before shattering [0]
 *   --eps E          proximity threshold factor [1.5, the paper's]
 *   --frames N       frames transferred (poses repeated) [all poses]
 *   --threads LIST   thread counts of the transfer runs, e.g. 1,2 [1,2]
 *   --max-iter N     iterations per frame at most [the solver's default: 30
 *                    fixed-point iterations, 100 for Newton]
 *   --tol T          stopping tolerance, fraction of the diagonal [the default, 1e-6]
 *   --solver S       fixed-point or newton [the default, fixed-point]
 *   --no-check       skip the comparison with sp04 on the unbroken target
 *   --lowrank-max N  correspondence phases solved from the old factor when
 *                    at most N vertices gained or lost their closest point
 *                    (dtx_corr_params.lowrank_max) [200; 0: refactorise]
 *   --dump FILE      write the correspondence (deformed target and pairs) to
 *                    FILE: "DTXMCDMP", int64 nv, int64 npairs, nv x 3
 *                    float64, npairs x 2 int32 (native byte order)
 *   --compare FILE   print how far this run's correspondence lies from the
 *                    one dumped in FILE: max |coordinate difference| over
 *                    the deformed target's bounding-box diagonal, and the
 *                    pairs found in one only
 *
 * Prints: sizes; proximity graph; correspondence seconds (wall and CPU;
 * the proximity graph and the E_R triangle pairs, which it builds first,
 * also timed apart on the target as given); plan seconds (and the
 * factorisation alone); per-frame transfer seconds (wall and CPU of all
 * threads) and iterations at each thread count, and whether
 * the results are bitwise identical across thread counts; ratios to the
 * paper's figures; and, unless --no-check, per frame the RMS distance of
 * each pebble vertex from sp04's result on the unbroken target at its
 * mapped vertex (mean offset removed, % of the diagonal) and the median
 * relative change of the proximity-pair lengths.  The machine is shared:
 * compare CPU seconds, or runs made one after the other.  The correspondence
 * runs on OMP_NUM_THREADS threads (all by default), whatever --threads says;
 * BLAS on one.
 */
#include "bench_data.h"
#include "dtx_core.h"
#include "generate.h"
#include "proximity.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PAPER_CORR_S 54.56
#define PAPER_FRAME_S 14.72
#define MAX_THREAD_RUNS 8

/* OpenBLAS's own call, when that is the BLAS we run on.  The bench keeps
 * BLAS single-threaded as the dtx command does (src/driver/run.c): OpenBLAS
 * otherwise takes its thread count from OMP_NUM_THREADS, and its threads
 * change the supernodal factorisations' rounding (the correspondence's
 * deformed target moved by 1.6e-10 of the diagonal between
 * OMP_NUM_THREADS=1 and 2) and fight with OpenMP for the cores. */
extern void openblas_set_num_threads(int n) __attribute__((weak));
#define DUMP_MAGIC "DTXMCDMP"

typedef struct {
    int pieces, subdivide, frames, check, max_iter, newton, lowrank_max;
    double gap, thickness, eps, tol;
    int nthreads, threads[MAX_THREAD_RUNS];
    const char *dump, *compare;
} options;

static int cmp_dbl(const void *x, const void *y)
{
    double a = *(const double *)x, b = *(const double *)y;
    return (a > b) - (a < b);
}

/* RMS over the vertices v of a (na vertices, map[v] >= 0) of |a_v -
 * b_map[v]| after removing the mean offset, over diag. */
static double rms_mapped(const double *a, int32_t na, const double *b, const int32_t *map,
                         double diag)
{
    double ma[3] = {0, 0, 0}, mb[3] = {0, 0, 0}, s2 = 0.0;
    int32_t n = 0;
    for (int32_t v = 0; v < na; v++) {
        if (map[v] < 0)
            continue;
        for (int k = 0; k < 3; k++) {
            ma[k] += a[3 * (size_t)v + k];
            mb[k] += b[3 * (size_t)map[v] + k];
        }
        n++;
    }
    if (n == 0)
        return 0.0;
    for (int k = 0; k < 3; k++) {
        ma[k] /= n;
        mb[k] /= n;
    }
    for (int32_t v = 0; v < na; v++) {
        if (map[v] < 0)
            continue;
        for (int k = 0; k < 3; k++) {
            double d = (a[3 * (size_t)v + k] - ma[k]) - (b[3 * (size_t)map[v] + k] - mb[k]);
            s2 += d * d;
        }
    }
    return sqrt(s2 / n) / diag;
}

/* Writes the correspondence to path as --dump describes, aside then by
 * rename, so that path is never half-written. */
static void dump_corr(const char *path, const dtx_corr *c)
{
    char tmp[4096];
    int64_t hdr[2] = {c->nv_tgt, c->npairs};
    FILE *f;
    int ok;
    if (snprintf(tmp, sizeof tmp, "%s.tmp", path) >= (int)sizeof tmp)
        bench_die_msg("path too long", path);
    f = fopen(tmp, "wb");
    if (!f)
        bench_die_msg("cannot create", tmp);
    ok = fwrite(DUMP_MAGIC, 1, 8, f) == 8 && fwrite(hdr, sizeof *hdr, 2, f) == 2 &&
         fwrite(c->deformed_tgt, 3 * sizeof(double), (size_t)c->nv_tgt, f) == (size_t)c->nv_tgt &&
         fwrite(c->pairs, 2 * sizeof(int32_t), (size_t)c->npairs, f) == (size_t)c->npairs;
    if (fclose(f) != 0 || !ok) {
        remove(tmp);
        bench_die_msg("write failed", tmp);
    }
    if (rename(tmp, path) != 0) {
        remove(tmp);
        bench_die_msg("cannot rename the temporary file onto it", path);
    }
}

/* Pairs ordered by target triangle, then source triangle. */
static int cmp_pair(const void *x, const void *y)
{
    const int32_t *a = x, *b = y;
    if (a[1] != b[1])
        return (a[1] > b[1]) - (a[1] < b[1]);
    return (a[0] > b[0]) - (a[0] < b[0]);
}

/* Prints how far c lies from the correspondence dumped in path. */
static void compare_corr(const char *path, const dtx_corr *c)
{
    char magic[8];
    int64_t hdr[2], only_here = 0, only_there = 0, i = 0, j = 0;
    double *X, diag, dmax = 0.0;
    int32_t *P, *Q;
    FILE *f = fopen(path, "rb");
    if (!f)
        bench_die_msg("cannot open", path);
    if (fread(magic, 1, 8, f) != 8 || memcmp(magic, DUMP_MAGIC, 8) != 0 ||
        fread(hdr, sizeof *hdr, 2, f) != 2)
        bench_die_msg("not a dtx_bench_mc --dump file", path);
    if (hdr[0] != c->nv_tgt || hdr[1] < 0 || hdr[1] > INT32_MAX)
        bench_die_msg("vertex count differs from this run's (or bad pair count)", path);
    X = bench_xmalloc((size_t)hdr[0], 3 * sizeof *X);
    P = bench_xmalloc((size_t)hdr[1] + 1, 2 * sizeof *P);
    if (fread(X, 3 * sizeof *X, (size_t)hdr[0], f) != (size_t)hdr[0] ||
        fread(P, 2 * sizeof *P, (size_t)hdr[1], f) != (size_t)hdr[1] || fgetc(f) != EOF)
        bench_die_msg("truncated, or longer than its header says", path);
    fclose(f);
    diag = dtx_bbox_diagonal(c->deformed_tgt, c->nv_tgt);
    /* Written so that a NaN on either side becomes the maximum. */
    for (size_t k = 0; k < 3 * (size_t)c->nv_tgt; k++) {
        double d = fabs(c->deformed_tgt[k] - X[k]);
        if (!(d <= dmax))
            dmax = d;
    }
    /* The pairs as multisets: both sorted, then merged. */
    Q = bench_xmalloc((size_t)c->npairs + 1, 2 * sizeof *Q);
    memcpy(Q, c->pairs, (size_t)c->npairs * 2 * sizeof *Q);
    qsort(P, (size_t)hdr[1], 2 * sizeof *P, cmp_pair);
    qsort(Q, (size_t)c->npairs, 2 * sizeof *Q, cmp_pair);
    while (i < c->npairs || j < hdr[1]) {
        int o = i == c->npairs ? 1 : j == hdr[1] ? -1 : cmp_pair(Q + 2 * i, P + 2 * j);
        if (o < 0) {
            only_here++;
            i++;
        } else if (o > 0) {
            only_there++;
            j++;
        } else {
            i++;
            j++;
        }
    }
    printf("  against %s: deformed target bitwise identical: %s; max |difference| %.3g "
           "(%.3g of the diagonal %.4g); pairs %lld here, %lld there, %lld only here, "
           "%lld only there\n",
           path, memcmp(X, c->deformed_tgt, 3 * (size_t)c->nv_tgt * sizeof *X) == 0 ? "yes" : "no",
           dmax, dmax / diag, diag, (long long)c->npairs, (long long)hdr[1], (long long)only_here,
           (long long)only_there);
    free(X);
    free(P);
    free(Q);
}

/* Median over the proximity pairs of |l - l0| / l0 in frame x. */
static double median_pair_change(const dtx_proximity *prox, const double *x, double *scratch)
{
    if (prox->npairs == 0)
        return 0.0;
    for (int64_t i = 0; i < prox->npairs; i++) {
        const double *a = x + 3 * (size_t)prox->pairs[2 * i];
        const double *b = x + 3 * (size_t)prox->pairs[2 * i + 1];
        double d = sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                        (a[2] - b[2]) * (a[2] - b[2]));
        double l0 = prox->rest_len[i] > 0 ? prox->rest_len[i] : 1.0;
        scratch[i] = fabs(d - prox->rest_len[i]) / l0;
    }
    qsort(scratch, (size_t)prox->npairs, sizeof *scratch, cmp_dbl);
    return scratch[prox->npairs / 2];
}

static void usage(void)
{
    fprintf(stderr,
            "usage: dtx_bench_mc DATA_DIR [--pieces N] [--gap G] [--thickness T] "
            "[--subdivide L]\n"
            "                    [--eps E] [--frames N] [--threads 1,2] [--max-iter N] [--tol T]\n"
            "                    [--solver fixed-point|newton] [--no-check] [--lowrank-max N]\n"
            "                    [--dump FILE] [--compare FILE]\n");
    exit(2);
}

static void parse(int argc, char **argv, options *o)
{
    o->pieces = 750;
    o->gap = 0.003;
    o->thickness = 0.005;
    o->subdivide = 0;
    o->eps = 1.5;
    o->frames = 0;
    o->check = 1;
    o->max_iter = 0;
    o->newton = 0;
    o->tol = -1.0;
    o->lowrank_max = -1;
    o->dump = NULL;
    o->compare = NULL;
    o->nthreads = 2;
    o->threads[0] = 1;
    o->threads[1] = 2;
    for (int i = 2; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(a, "--no-check") == 0) {
            o->check = 0;
            continue;
        }
        if (!v)
            usage();
        i++;
        if (strcmp(a, "--pieces") == 0)
            o->pieces = atoi(v);
        else if (strcmp(a, "--gap") == 0)
            o->gap = atof(v);
        else if (strcmp(a, "--thickness") == 0)
            o->thickness = atof(v);
        else if (strcmp(a, "--subdivide") == 0)
            o->subdivide = atoi(v);
        else if (strcmp(a, "--eps") == 0)
            o->eps = atof(v);
        else if (strcmp(a, "--frames") == 0)
            o->frames = atoi(v);
        else if (strcmp(a, "--max-iter") == 0)
            o->max_iter = atoi(v);
        else if (strcmp(a, "--solver") == 0 && v &&
                 (strcmp(v, "newton") == 0 || strcmp(v, "fixed-point") == 0))
            o->newton = strcmp(v, "newton") == 0;
        else if (strcmp(a, "--tol") == 0)
            o->tol = atof(v);
        else if (strcmp(a, "--lowrank-max") == 0) {
            char *end;
            long n = strtol(v, &end, 10);
            if (end == v || *end || n < 0 || n > INT32_MAX)
                usage();
            o->lowrank_max = (int)n;
        } else if (strcmp(a, "--dump") == 0)
            o->dump = v;
        else if (strcmp(a, "--compare") == 0)
            o->compare = v;
        else if (strcmp(a, "--threads") == 0) {
            char *end;
            const char *s = v;
            o->nthreads = 0;
            while (*s && o->nthreads < MAX_THREAD_RUNS) {
                long t = strtol(s, &end, 10);
                if (end == s || t < 1 || t > 64)
                    usage();
                o->threads[o->nthreads++] = (int)t;
                s = *end == ',' ? end + 1 : end;
                if (*end && *end != ',')
                    usage();
            }
            if (o->nthreads == 0)
                usage();
        } else
            usage();
    }
    if (o->pieces < 1 || o->frames < 0)
        usage();
}

int main(int argc, char **argv)
{
    options o;
    bench_dataset ds;
    dtx_mesh peb = {0};
    int32_t *map = NULL, bad;
    dtx_markers pm = {0};
    dtx_corr corr, scorr;
    dtx_corr_params cp;
    dtx_mc_params prm;
    dtx_mc_plan *plan = NULL;
    dtx_mc_info info;
    dtx_proximity prox = {0};
    dtx_error e;
    double t0, c0, t_gen, t_corr, c_corr, t_prox, t_tri, t_plan, diag;
    double frame_s[MAX_THREAD_RUNS], frame_cpu[MAX_THREAD_RUNS];
    double *Xs, *Xt[MAX_THREAD_RUNS], *res;
    dtx_mc_frame_info *iters;
    int nf, max_threads;
    int identical = 1;
    int32_t *tri;

    bench_set_name("dtx_bench_mc");
    if (openblas_set_num_threads)
        openblas_set_num_threads(1);
    if (argc < 2 || argv[1][0] == '-')
        usage();
    parse(argc, argv, &o);
    dtx_corr_params_default(&cp);
    if (o.lowrank_max >= 0)
        cp.lowrank_max = o.lowrank_max;
    dtx_mc_params_default(&prm);
    prm.eps_factor = o.eps;
    if (o.max_iter > 0)
        prm.max_iter = o.max_iter;
    if (o.newton)
        prm.solver = DTX_MC_SOLVER_NEWTON;
    if (o.tol >= 0.0)
        prm.tol = o.tol;
    max_threads = omp_get_max_threads();
    bench_load_dataset(argv[1], &ds);
    nf = o.frames > 0 ? o.frames : ds.nposes;

    /* The shattered target and its markers. */
    t0 = omp_get_wtime();
    if (dtx_gen_pebbles(&ds.tgt, o.pieces, o.gap, o.thickness, o.subdivide, &peb, &map, &e) !=
        DTX_OK)
        bench_die(&e);
    t_gen = omp_get_wtime() - t0;
    if (dtx_markers_alloc(&pm, ds.mk.n, &e) != DTX_OK)
        bench_die(&e);
    memcpy(pm.src, ds.mk.src, (size_t)ds.mk.n * sizeof *pm.src);
    memcpy(pm.tgt, ds.mk.tgt, (size_t)ds.mk.n * sizeof *pm.tgt);
    if (dtx_gen_remap(map, peb.nv, ds.tgt.nv, pm.n, pm.tgt, &bad, &e) != DTX_OK)
        bench_die(&e);
    diag = dtx_bbox_diagonal(peb.V, peb.nv);

    printf("%s -> pebble %s: %d pieces, gap %g, thickness %g, subdivide %d, eps %g, max_iter %d, "
           "tol %g, solver %s\n",
           ds.src_name, ds.tgt_name, o.pieces, o.gap, o.thickness, o.subdivide, o.eps,
           prm.max_iter > 0 ? prm.max_iter
           : o.newton       ? DTX_MC_MAX_ITER_NEWTON
                            : DTX_MC_MAX_ITER_FIXED_POINT,
           prm.tol, o.newton ? "newton" : "fixed-point");
    printf("  source %d vertices, %d triangles, %d frames (%d poses)\n", (int)ds.src.nv,
           (int)ds.src.nf, nf, ds.nposes);
    printf("  target %d vertices, %d triangles (unbroken: %d, %d), %d markers; "
           "generated in %.2f s\n",
           (int)peb.nv, (int)peb.nf, (int)ds.tgt.nv, (int)ds.tgt.nf, (int)pm.n, t_gen);

    /* Parts of the correspondence, timed apart (on the target as given: the
     * correspondence builds them on the normalised target, the same up to
     * rounding). */
    t0 = omp_get_wtime();
    if (dtx_proximity_build(&peb, o.eps, &prox, &e) != DTX_OK)
        bench_die(&e);
    t_prox = omp_get_wtime() - t0;
    tri = bench_xmalloc((size_t)prox.npairs + 1, 2 * sizeof *tri);
    t0 = omp_get_wtime();
    if (dtx_proximity_triangle_pairs(&peb, &prox, tri, &e) != DTX_OK)
        bench_die(&e);
    t_tri = omp_get_wtime() - t0;
    free(tri);
    printf("  components %d, proximity edges %d, proximity pairs %lld\n", (int)prox.ncomp,
           (int)prox.nedges, (long long)prox.npairs);

    t0 = omp_get_wtime();
    c0 = bench_cpu_seconds();
    if (dtx_mc_correspond(&ds.src, &peb, &pm, &cp, o.eps, &corr, &e) != DTX_OK)
        bench_die(&e);
    t_corr = omp_get_wtime() - t0;
    c_corr = bench_cpu_seconds() - c0;
    printf("  correspondence          %8.3f s  (%d threads; CPU %.3f s; %d solves; %lld pairs, "
           "%d orphan triangles, fit %.3g%% of the diagonal)\n",
           t_corr, max_threads, c_corr, corr.solves, (long long)corr.npairs,
           (int)corr.unmatched_tgt, 100.0 * corr.fit_rms);
    printf("    of which proximity graph ~%.3f s, E_R triangle pairs ~%.3f s (timed apart); "
           "%d factorisations (low-rank phases up to %d vertices)\n",
           t_prox, t_tri, corr.factorizations, cp.lowrank_max);
    if (o.compare)
        compare_corr(o.compare, &corr);
    if (o.dump)
        dump_corr(o.dump, &corr);

    t0 = omp_get_wtime();
    if (dtx_mc_plan_create(&ds.src, &peb, corr.pairs, corr.npairs, &prm, DTX_ANCHOR_FIXED, NULL,
                           NULL, 0, &plan, &e) != DTX_OK)
        bench_die(&e);
    t_plan = omp_get_wtime() - t0;
    dtx_mc_plan_info(plan, &info);
    printf("  plan                    %8.3f s  (factorisation %.3f s); %d orphan triangles, "
           "%d orphan components\n",
           t_plan, info.factor_seconds, (int)info.orphan_triangles, (int)info.orphan_components);

    Xs = bench_xmalloc((size_t)nf, 3 * (size_t)ds.src.nv * sizeof *Xs);
    for (int f = 0; f < nf; f++)
        memcpy(Xs + (size_t)f * 3 * ds.src.nv, ds.poses + (size_t)(f % ds.nposes) * 3 * ds.src.nv,
               3 * (size_t)ds.src.nv * sizeof *Xs);
    res = bench_xmalloc((size_t)nf, sizeof *res);
    iters = bench_xmalloc((size_t)nf, sizeof *iters);
    for (int r = 0; r < o.nthreads; r++) {
        double *it = bench_xmalloc((size_t)nf, sizeof *it);
        Xt[r] = bench_xmalloc((size_t)nf, 3 * (size_t)peb.nv * sizeof **Xt);
        memset(Xt[r], 0, (size_t)nf * 3 * peb.nv * sizeof **Xt);
        omp_set_num_threads(o.threads[r]);
        t0 = omp_get_wtime();
        c0 = bench_cpu_seconds();
        if (dtx_mc_apply(plan, nf, Xs, Xt[r], res, iters, &e) != DTX_OK)
            bench_die(&e);
        frame_s[r] = (omp_get_wtime() - t0) / nf;
        frame_cpu[r] = (bench_cpu_seconds() - c0) / nf;
        printf("  transfer, %d thread(s)    %8.3f s per frame  (CPU %.3f s per frame; "
               "%.2f frames/s)\n",
               o.threads[r], frame_s[r], frame_cpu[r], 1.0 / frame_s[r]);
        for (int f = 0; f < nf; f++)
            it[f] = iters[f].iterations;
        bench_summary3(BENCH_SUMMARY_F3,
                       o.newton ? "Newton steps + 1 per frame" : "iterations per frame", it, nf,
                       1.0, "");
        {
            int nconv = 0;
            for (int f = 0; f < nf; f++)
                nconv += iters[f].converged;
            printf("  frames that met tol                %d of %d\n", nconv, nf);
        }
        for (int f = 0; f < nf; f++)
            it[f] = res[f];
        bench_summary3(BENCH_SUMMARY_F3, "residual sqrt(E / pairs)", it, nf, 1.0, "");
        free(it);
        if (r > 0 && memcmp(Xt[r], Xt[0], (size_t)nf * 3 * peb.nv * sizeof **Xt) != 0)
            identical = 0;
    }
    omp_set_num_threads(max_threads);
    if (o.nthreads > 1)
        printf("  results bitwise identical across thread counts: %s\n", identical ? "yes" : "NO");
    for (int r = 0; r < o.nthreads; r++)
        if (o.threads[r] == 2 || o.nthreads == 1)
            printf("  against the paper (54.6 s, 14.7 s/frame): correspondence %.1fx faster, "
                   "transfer (%d threads) %.1fx faster; targets 10 s: %s, 0.5 s/frame: %s\n",
                   PAPER_CORR_S / t_corr, o.threads[r], PAPER_FRAME_S / frame_s[r],
                   t_corr <= 10.0 ? "met" : "NOT met", frame_s[r] <= 0.5 ? "met" : "NOT met");

    if (o.check) {
        /* sp04 on the unbroken target, each pebble vertex against its
         * original vertex. */
        dtx_sp04_plan *sp = NULL;
        double *Yt = bench_xmalloc((size_t)nf, 3 * (size_t)ds.tgt.nv * sizeof *Yt);
        double *scratch = bench_xmalloc((size_t)prox.npairs + 1, sizeof *scratch);
        double *rms = bench_xmalloc((size_t)nf, sizeof *rms),
               *med = bench_xmalloc((size_t)nf, sizeof *med);
        if (dtx_sp04_correspond(&ds.src, &ds.tgt, &ds.mk, &cp, &scorr, &e) != DTX_OK)
            bench_die(&e);
        if (dtx_sp04_plan_create(&ds.src, &ds.tgt, scorr.pairs, scorr.npairs, DTX_ANCHOR_FIXED,
                                 NULL, NULL, 0, &sp, &e) != DTX_OK)
            bench_die(&e);
        if (dtx_sp04_apply(sp, nf, Xs, Yt, NULL, &e) != DTX_OK)
            bench_die(&e);
        for (int f = 0; f < nf; f++) {
            rms[f] = rms_mapped(Xt[0] + (size_t)f * 3 * peb.nv, peb.nv,
                                Yt + (size_t)f * 3 * ds.tgt.nv, map, diag);
            med[f] = median_pair_change(&prox, Xt[0] + (size_t)f * 3 * peb.nv, scratch);
        }
        printf("  check against sp04 on the unbroken %s (same markers), per frame:\n", ds.tgt_name);
        bench_summary3(BENCH_SUMMARY_F3, "RMS pebble vertex - sp04 vertex", rms, nf, 100.0,
                       "% of the diagonal");
        bench_summary3(BENCH_SUMMARY_F3, "median proximity-pair change", med, nf, 100.0, "%");
        {
            double w = 0.0;
            int wf = 0;
            for (int f = 0; f < nf; f++)
                if (rms[f] > w) {
                    w = rms[f];
                    wf = f;
                }
            printf("  worst frame %d: RMS %.3f%%, median pair change %.2f%%\n", wf + 1, 100.0 * w,
                   100.0 * med[wf]);
        }
        dtx_sp04_plan_free(&sp);
        dtx_corr_free(&scorr);
        free(Yt);
        free(scratch);
        free(rms);
        free(med);
    }

    for (int r = 0; r < o.nthreads; r++)
        free(Xt[r]);
    free(Xs);
    free(res);
    free(iters);
    dtx_mc_plan_free(&plan);
    dtx_corr_free(&corr);
    dtx_proximity_free(&prox);
    dtx_markers_free(&pm);
    dtx_mesh_free(&peb);
    free(map);
    bench_free_dataset(&ds);
    return 0;
}
