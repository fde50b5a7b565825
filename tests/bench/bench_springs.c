/*
 * bench_springs.c: figures for the springs method (Yang, Ma & Ouhyoung;
 * src/core/springs.h), printed, never asserted.
 *
 *   dtx_bench_springs DATA_DIR [options]
 *
 * DATA_DIR holds source/<src>-reference.obj with poses source/<src>-01.obj,
 * -02.obj, ..., target/<tgt>-reference.obj and markers.csv (0-based), as the
 * shared sumner-cat-lion and sumner-horse-camel sets do (and, optionally,
 * paper-results/<tgt>-01.obj, ...: sp04's published results).
 *
 * Two runs:
 *   same   the paper's setting on a mesh of the target's size: the source
 *          poses are first carried onto the target with sp04, which gives a
 *          deformed target sequence S~ (same connectivity as the target);
 *          springs then transfer S = target rest -> S~ onto T = the target
 *          made thicker and longer by a smooth non-rigid map (each axis
 *          scaled about the centroid: the longest by 1 + a/2, the others by
 *          1 + a, plus a bend of a/2 rad along the longest axis).  Single
 *          level and multigrid, each timed; Newton iterations, energies,
 *          inverted triangles; the RMS distance between the two results.
 *   proxy  source -> target through the proxy (sp04 correspondence's
 *          deformed source); timed; with paper-results, the RMS distance to
 *          them per pose (mean offset removed, % of the target diagonal)
 *          next to sp04's.
 * Options (defaults in brackets):
 *   --run same|proxy|both  [both]
 *   --frames N             frames (poses repeated) [all poses]
 *   --threads LIST         thread counts of the timed runs [1]
 *   --levels L             coarse levels of the multigrid runs [springs default]
 *   --amount A             the target deformation of the same run [0.15]
 *   --no-internal          no internal springs
 *   --corr-weights W       the sp04 correspondence's weights, area or element
 *                          [its default]
 * The machine is shared: compare CPU seconds, or runs made one after the
 * other.
 */
#include "bench_data.h"
#include "dtx_core.h"
#include "springs.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_THREAD_RUNS 8

typedef struct {
    int same, proxy, frames, levels, internal, max_iter, barrier, proxy_starts;
    int starts; /* bit 0: linear, bit 1: rest */
    double amount;
    int nthreads, threads[MAX_THREAD_RUNS];
    int corr_weights; /* the sp04 correspondence's weights; -1: its default */
} options;

/* RMS distance of a and b (n x 3) after removing the mean offset. */
static double rms_centered(const double *a, const double *b, int32_t n)
{
    double ma[3] = {0, 0, 0}, mb[3] = {0, 0, 0}, s2 = 0.0;
    for (int32_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            ma[k] += a[3 * (size_t)i + k] / n;
            mb[k] += b[3 * (size_t)i + k] / n;
        }
    for (int32_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            double d = (a[3 * (size_t)i + k] - ma[k]) - (b[3 * (size_t)i + k] - mb[k]);
            s2 += d * d;
        }
    return sqrt(s2 / n);
}

/* The smooth non-rigid "thicker, longer" map of the same run (see the file
 * comment). */
static void thicken(const dtx_mesh *m, double a, double *X)
{
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    double c[3], s[3];
    int ax = 0;
    for (int32_t v = 0; v < m->nv; v++)
        for (int k = 0; k < 3; k++) {
            lo[k] = fmin(lo[k], m->V[3 * (size_t)v + k]);
            hi[k] = fmax(hi[k], m->V[3 * (size_t)v + k]);
        }
    for (int k = 0; k < 3; k++) {
        c[k] = 0.5 * (lo[k] + hi[k]);
        if (hi[k] - lo[k] > hi[ax] - lo[ax])
            ax = k;
    }
    for (int k = 0; k < 3; k++)
        s[k] = k == ax ? 1.0 + 0.5 * a : 1.0 + a;
    for (int32_t v = 0; v < m->nv; v++) {
        double p[3], u, ang, b = (ax + 1) % 3;
        for (int k = 0; k < 3; k++)
            p[k] = s[k] * (m->V[3 * (size_t)v + k] - c[k]);
        /* Bend: rotate about the third axis by an angle growing along ax. */
        u = (m->V[3 * (size_t)v + ax] - c[ax]) / (hi[ax] - lo[ax]);
        ang = 0.5 * a * u;
        {
            int ib = (int)b;
            double pa = p[ax], pb = p[ib];
            p[ax] = cos(ang) * pa - sin(ang) * pb;
            p[ib] = sin(ang) * pa + cos(ang) * pb;
        }
        for (int k = 0; k < 3; k++)
            X[3 * (size_t)v + k] = p[k] + c[k];
    }
}

/* One timed springs run over nf frames at each thread count; results of the
 * first run into Xt, info into fi.  Returns the seconds per frame of the
 * first run (wall) and prints a line per run. */
static double timed_runs(const char *label, dtx_springs_plan *plan, const options *o, int nf,
                         const double *Xs, double *Xt, dtx_springs_frame_info *fi, int32_t nv_t)
{
    double first = 0.0;
    int max_threads = omp_get_max_threads();
    double *tmp = NULL;
    for (int r = 0; r < o->nthreads; r++) {
        dtx_error e;
        double t0, c0, wall, cpu;
        double *out =
            r == 0 ? Xt : (tmp ? tmp : (tmp = bench_xmalloc((size_t)nf * 3 * nv_t, sizeof *tmp)));
        omp_set_num_threads(o->threads[r]);
        t0 = omp_get_wtime();
        c0 = bench_cpu_seconds();
        if (dtx_springs_apply(plan, nf, Xs, out, fi, &e) != DTX_OK)
            bench_die(&e);
        wall = (omp_get_wtime() - t0) / nf;
        cpu = (bench_cpu_seconds() - c0) / nf;
        if (r == 0)
            first = wall;
        printf("  %-12s %d thread(s): %8.3f s per frame (CPU %.3f s per frame)%s\n", label,
               o->threads[r], wall, cpu,
               r > 0 ? (memcmp(out, Xt, (size_t)nf * 3 * nv_t * sizeof *out) == 0
                            ? ", bitwise equal to the first run"
                            : ", DIFFERS from the first run")
                     : "");
    }
    omp_set_num_threads(max_threads);
    free(tmp);
    return first;
}

static void frame_figures(const dtx_springs_frame_info *fi, int nf)
{
    double *v = bench_xmalloc((size_t)nf, sizeof *v);
    int conv = 0;
    long inv = 0;
    for (int f = 0; f < nf; f++)
        v[f] = fi[f].iterations;
    bench_summary3(BENCH_SUMMARY_G4, "Newton iterations (fine level)", v, nf, 1.0, "");
    for (int f = 0; f < nf; f++)
        v[f] = fi[f].factorizations;
    bench_summary3(BENCH_SUMMARY_G4, "numeric factorisations (fine level)", v, nf, 1.0, "");
    for (int f = 0; f < nf; f++)
        v[f] = fi[f].coarse_iterations;
    bench_summary3(BENCH_SUMMARY_G4, "Newton iterations (coarse levels)", v, nf, 1.0, "");
    for (int f = 0; f < nf; f++)
        v[f] = fi[f].energy_start;
    bench_summary3(BENCH_SUMMARY_G4, "energy at the fine start", v, nf, 1.0, "");
    for (int f = 0; f < nf; f++)
        v[f] = fi[f].residual;
    bench_summary3(BENCH_SUMMARY_G4, "residual (RMS relative length error)", v, nf, 1.0, "");
    for (int f = 0; f < nf; f++) {
        v[f] = fi[f].inverted;
        conv += fi[f].converged;
        inv += fi[f].inverted;
    }
    bench_summary3(BENCH_SUMMARY_G4, "inverted triangles", v, nf, 1.0, "");
    for (int f = 0; f < nf; f++)
        v[f] = fi[f].grad_norm;
    bench_summary3(BENCH_SUMMARY_G4, "final gradient norm", v, nf, 1.0, "");
    for (int f = 0; f < nf; f++)
        v[f] = fi[f].barrier_skipped;
    bench_summary3(BENCH_SUMMARY_G4, "triangles folded at the start", v, nf, 1.0, "");
    printf("    per frame (iterations, converged, gradient norm, inverted):");
    for (int f = 0; f < nf; f++)
        printf(" (%d, %d, %.2g, %d)", (int)fi[f].iterations, (int)fi[f].converged, fi[f].grad_norm,
               (int)fi[f].inverted);
    printf("\n");
    printf("    converged %d of %d frames; %ld inverted triangles in all\n", conv, nf, inv);
    free(v);
}

static void print_plan(const char *label, const dtx_springs_plan *plan)
{
    dtx_springs_info in;
    dtx_springs_plan_info(plan, &in);
    printf("  plan %-10s %7.3f s: springs %d edge, %d bending, %d internal (%d dropped); levels",
           label, in.setup_seconds, (int)in.springs[0], (int)in.springs[1], (int)in.springs[2],
           (int)in.dropped);
    for (int l = 0; l < in.levels; l++)
        printf(" %d", (int)in.level_vertices[l]);
    printf("; fine factor %.2fM entries (%s)\n", in.factor_nnz / 1e6,
           in.supernodal ? "supernodal" : "simplicial");
    if (in.proxy)
        printf("    target vertices from the proxy surface: RMS %.3f%% of the diagonal\n",
               100.0 * in.proxy_rms);
}

static void usage(void)
{
    fprintf(stderr, "usage: dtx_bench_springs DATA_DIR [--run same|proxy|both] [--frames N] "
                    "[--threads 1,2] [--levels L] [--amount A] [--no-internal]\n"
                    "                         [--start linear|rest|both|sp04|all] [--max-iter N] "
                    "[--barrier 0|1]\n"
                    "                         [--proxy-start sp04|linear|both] "
                    "[--corr-weights area|element]\n");
    exit(2);
}

static void parse(int argc, char **argv, options *o)
{
    o->same = o->proxy = 1;
    o->frames = 0;
    o->levels = -1;
    o->max_iter = -1;
    o->barrier = -1;
    o->internal = 1;
    o->amount = 0.15;
    o->starts = 7;
    o->proxy_starts = 3;
    o->nthreads = 1;
    o->threads[0] = 1;
    o->corr_weights = -1;
    for (int i = 2; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(a, "--no-internal") == 0) {
            o->internal = 0;
            continue;
        }
        if (!v)
            usage();
        i++;
        if (strcmp(a, "--run") == 0) {
            o->same = strcmp(v, "same") == 0 || strcmp(v, "both") == 0;
            o->proxy = strcmp(v, "proxy") == 0 || strcmp(v, "both") == 0;
            if (!o->same && !o->proxy)
                usage();
        } else if (strcmp(a, "--start") == 0) {
            o->starts = strcmp(v, "linear") == 0 ? 1
                        : strcmp(v, "rest") == 0 ? 2
                        : strcmp(v, "both") == 0 ? 3
                        : strcmp(v, "sp04") == 0 ? 4
                        : strcmp(v, "all") == 0  ? 7
                                                 : 0;
            if (!o->starts)
                usage();
        } else if (strcmp(a, "--proxy-start") == 0) {
            o->proxy_starts = strcmp(v, "sp04") == 0     ? 1
                              : strcmp(v, "linear") == 0 ? 2
                              : strcmp(v, "both") == 0   ? 3
                                                         : 0;
            if (!o->proxy_starts)
                usage();
        } else if (strcmp(a, "--corr-weights") == 0) {
            o->corr_weights = strcmp(v, "area") == 0      ? DTX_CORR_WEIGHTS_AREA
                              : strcmp(v, "element") == 0 ? DTX_CORR_WEIGHTS_ELEMENT
                                                          : -1;
            if (o->corr_weights < 0)
                usage();
        } else if (strcmp(a, "--max-iter") == 0)
            o->max_iter = atoi(v);
        else if (strcmp(a, "--barrier") == 0)
            o->barrier = atoi(v);
        else if (strcmp(a, "--frames") == 0)
            o->frames = atoi(v);
        else if (strcmp(a, "--levels") == 0)
            o->levels = atoi(v);
        else if (strcmp(a, "--amount") == 0)
            o->amount = atof(v);
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
    if (o->frames < 0)
        usage();
}

int main(int argc, char **argv)
{
    options o;
    bench_dataset ds;
    dtx_corr corr;
    dtx_corr_params cp;
    dtx_springs_params prm;
    dtx_sp04_plan *sp = NULL;
    dtx_error e;
    double t0, t_corr, diag_t, *Xs, *Yt;
    int nf;

    bench_set_name("dtx_bench_springs");
    if (argc < 2 || argv[1][0] == '-')
        usage();
    parse(argc, argv, &o);
    bench_load_dataset(argv[1], &ds);
    bench_load_paper_results(argv[1], &ds);
    nf = o.frames > 0 ? o.frames : ds.nposes;
    dtx_springs_params_default(&prm);
    prm.internal = o.internal;
    if (o.levels >= 0)
        prm.levels = o.levels;
    if (o.max_iter >= 0)
        prm.max_iter = o.max_iter;
    if (o.barrier >= 0)
        prm.barrier = o.barrier;
    diag_t = dtx_bbox_diagonal(ds.tgt.V, ds.tgt.nv);
    printf("%s -> %s: source %d vertices, target %d vertices, %d frames (%d poses)\n", ds.src_name,
           ds.tgt_name, (int)ds.src.nv, (int)ds.tgt.nv, nf, ds.nposes);

    /* sp04 (needed by both runs). */
    dtx_corr_params_default(&cp);
    if (o.corr_weights >= 0)
        cp.weights = o.corr_weights;
    t0 = omp_get_wtime();
    if (dtx_sp04_correspond(&ds.src, &ds.tgt, &ds.mk, &cp, &corr, &e) != DTX_OK)
        bench_die(&e);
    t_corr = omp_get_wtime() - t0;
    printf("  sp04 correspondence %.3f s (fit %.3g%% of the diagonal)\n", t_corr,
           100.0 * corr.fit_rms);
    if (dtx_sp04_plan_create(&ds.src, &ds.tgt, corr.pairs, corr.npairs, DTX_ANCHOR_FIXED, NULL,
                             NULL, 0, &sp, &e) != DTX_OK)
        bench_die(&e);
    Xs = bench_xmalloc((size_t)nf, 3 * (size_t)ds.src.nv * sizeof *Xs);
    for (int f = 0; f < nf; f++)
        memcpy(Xs + (size_t)f * 3 * ds.src.nv, ds.poses + (size_t)(f % ds.nposes) * 3 * ds.src.nv,
               3 * (size_t)ds.src.nv * sizeof *Xs);
    Yt = bench_xmalloc((size_t)nf, 3 * (size_t)ds.tgt.nv * sizeof *Yt);
    t0 = omp_get_wtime();
    if (dtx_sp04_apply(sp, nf, Xs, Yt, NULL, &e) != DTX_OK)
        bench_die(&e);
    printf("  sp04 transfer %.4f s per frame\n", (omp_get_wtime() - t0) / nf);

    if (o.same) {
        dtx_mesh T = {0};
        if (dtx_mesh_copy(&ds.tgt, &T, &e) != DTX_OK)
            bench_die(&e);
        thicken(&ds.tgt, o.amount, T.V);
        printf("same connectivity (%s rest -> sp04 %s poses, onto %s thickened by %g): %d "
               "vertices\n",
               ds.tgt_name, ds.tgt_name, ds.tgt_name, o.amount, (int)T.nv);
        if (o.starts & 4) {
            /* The sp04 start (with the barrier unless --barrier 0): one
             * level. */
            dtx_springs_plan *p1 = NULL;
            dtx_springs_params p0 = prm;
            double *X1 = bench_xmalloc((size_t)nf, 3 * (size_t)T.nv * sizeof *X1);
            dtx_springs_frame_info *f1 = bench_xmalloc((size_t)nf, sizeof *f1);
            p0.start = DTX_SPRINGS_START_SP04;
            printf(" start sp04, barrier %s:\n", p0.barrier ? "on" : "off");
            if (dtx_springs_plan_create(&ds.tgt, &T, NULL, &p0, DTX_ANCHOR_FIXED, NULL, NULL, 0,
                                        &p1, &e) != DTX_OK)
                bench_die(&e);
            print_plan("sp04", p1);
            timed_runs("sp04 start", p1, &o, nf, Yt, X1, f1, T.nv);
            frame_figures(f1, nf);
            dtx_springs_plan_free(&p1);
            free(X1);
            free(f1);
        }
        for (int sm = 0; sm < 2; sm++) {
            dtx_springs_plan *p1 = NULL, *pm = NULL;
            dtx_springs_params p0 = prm, pg = prm;
            double *X1, *Xm, *d, s1, s2;
            dtx_springs_frame_info *f1, *fm;
            if (!(o.starts & (1 << sm)))
                continue;
            X1 = bench_xmalloc((size_t)nf, 3 * (size_t)T.nv * sizeof *X1);
            Xm = bench_xmalloc((size_t)nf, 3 * (size_t)T.nv * sizeof *Xm);
            d = bench_xmalloc((size_t)nf, sizeof *d);
            f1 = bench_xmalloc((size_t)nf, sizeof *f1);
            fm = bench_xmalloc((size_t)nf, sizeof *fm);
            p0.start = pg.start = sm == 0 ? DTX_SPRINGS_START_LINEAR : DTX_SPRINGS_START_REST;
            p0.barrier = pg.barrier = 0; /* used with the sp04 start only */
            p0.levels = 0;
            printf(" start %s:\n", sm == 0 ? "linear" : "rest (the paper's)");
            if (dtx_springs_plan_create(&ds.tgt, &T, NULL, &p0, DTX_ANCHOR_FIXED, NULL, NULL, 0,
                                        &p1, &e) != DTX_OK)
                bench_die(&e);
            print_plan("single", p1);
            if (dtx_springs_plan_create(&ds.tgt, &T, NULL, &pg, DTX_ANCHOR_FIXED, NULL, NULL, 0,
                                        &pm, &e) != DTX_OK)
                bench_die(&e);
            print_plan("multigrid", pm);
            s1 = timed_runs("single level", p1, &o, nf, Yt, X1, f1, T.nv);
            frame_figures(f1, nf);
            s2 = timed_runs("multigrid", pm, &o, nf, Yt, Xm, fm, T.nv);
            frame_figures(fm, nf);
            printf("  multigrid / single level time per frame: %.2f\n", s2 / s1);
            for (int f = 0; f < nf; f++)
                d[f] = rms_centered(X1 + (size_t)f * 3 * T.nv, Xm + (size_t)f * 3 * T.nv, T.nv) /
                       diag_t;
            bench_summary3(BENCH_SUMMARY_G4, "RMS single - multigrid", d, nf, 100.0,
                           "% of the diagonal");
            dtx_springs_plan_free(&p1);
            dtx_springs_plan_free(&pm);
            free(X1);
            free(Xm);
            free(d);
            free(f1);
            free(fm);
        }
        dtx_mesh_free(&T);
    }

    for (int ps = 0; ps < 2 && o.proxy; ps++) {
        dtx_springs_plan *pp = NULL;
        dtx_springs_params pr = prm;
        double *X = bench_xmalloc((size_t)nf, 3 * (size_t)ds.tgt.nv * sizeof *X);
        dtx_springs_frame_info *fi = bench_xmalloc((size_t)nf, sizeof *fi);
        if (!(o.proxy_starts & (1 << ps))) {
            free(X);
            free(fi);
            continue;
        }
        /* sp04 start with the barrier (the default), or the linear
         * multigrid start without it (the default before them). */
        pr.start = ps == 0 ? DTX_SPRINGS_START_SP04 : DTX_SPRINGS_START_LINEAR;
        if (ps == 1)
            pr.barrier = 0;
        printf("proxy (%s -> %s, different connectivity), start %s, barrier %s: solve mesh %d "
               "vertices\n",
               ds.src_name, ds.tgt_name, ps == 0 ? "sp04" : "linear",
               pr.barrier && ps == 0 ? "on" : "off", (int)ds.src.nv);
        if (dtx_springs_plan_create(&ds.src, &ds.tgt, corr.deformed_src, &pr, DTX_ANCHOR_FIXED,
                                    NULL, NULL, 0, &pp, &e) != DTX_OK)
            bench_die(&e);
        print_plan("proxy", pp);
        timed_runs("proxy", pp, &o, nf, Xs, X, fi, ds.tgt.nv);
        frame_figures(fi, nf);
        {
            /* The same count on sp04's own results (the reference). */
            long inv = 0;
            printf("    sp04's own results, inverted triangles per frame:");
            for (int f = 0; f < nf; f++) {
                int32_t c = dtx_springs_count_inverted(pp, Xs + (size_t)f * 3 * ds.src.nv,
                                                       Yt + (size_t)f * 3 * ds.tgt.nv);
                printf(" %d", (int)c);
                inv += c;
            }
            printf(" (%ld in all)\n", inv);
        }
        if (ds.results) {
            int np = nf < ds.nposes ? nf : ds.nposes;
            double sum_s = 0.0, sum_p = 0.0, worst_s = 0.0, worst_p = 0.0, sum_x = 0.0;
            printf("  RMS distance to the paper's results (%% of the diagonal), per pose:\n");
            printf("    pose   springs     sp04   springs-sp04\n");
            for (int k = 0; k < np; k++) {
                const double *ref = ds.results + (size_t)k * 3 * ds.tgt.nv;
                double rs =
                    100.0 * rms_centered(X + (size_t)k * 3 * ds.tgt.nv, ref, ds.tgt.nv) / diag_t;
                double rp =
                    100.0 * rms_centered(Yt + (size_t)k * 3 * ds.tgt.nv, ref, ds.tgt.nv) / diag_t;
                double rx = 100.0 *
                            rms_centered(X + (size_t)k * 3 * ds.tgt.nv,
                                         Yt + (size_t)k * 3 * ds.tgt.nv, ds.tgt.nv) /
                            diag_t;
                printf("    %4d  %7.3f%%  %7.3f%%  %7.3f%%\n", k + 1, rs, rp, rx);
                sum_s += rs;
                sum_p += rp;
                sum_x += rx;
                worst_s = fmax(worst_s, rs);
                worst_p = fmax(worst_p, rp);
            }
            printf("    mean  %7.3f%%  %7.3f%%  %7.3f%%  (worst %.3f%% vs %.3f%%)\n", sum_s / np,
                   sum_p / np, sum_x / np, worst_s, worst_p);
        }
        dtx_springs_plan_free(&pp);
        free(X);
        free(fi);
    }

    dtx_sp04_plan_free(&sp);
    dtx_corr_free(&corr);
    free(Xs);
    free(Yt);
    bench_free_dataset(&ds);
    return 0;
}
