/*
 * test_multicomponent.c: the multicomponent method (Zhou et al. 2010) on
 * the bundled cat -> lion data.
 *
 *  - One component: with sp04's pairs (every target triangle paired, no
 *    proximity pairs, no orphans) the Gauss-Newton transfer is sp04's
 *    linear solve, whatever the translation mode: results within 1e-6 of
 *    the lion's diagonal (they differ only by rounding).
 *  - The whole method on the one-component lion (its own correspondence,
 *    the target deformed into the source) lands close to sp04's result.
 *  - Results do not depend on the thread count or on how frames are split.
 *  - Pebble lion (the lion shattered into 240 pieces by dtx_gen_pebbles,
 *    markers moved to the pebble vertices): every pebble vertex within 2% of
 *    the diagonal (RMS) of where sp04 puts its lion vertex, proximity-pair
 *    lengths kept (median change <= 5%), no piece left behind; its
 *    correspondence with low-rank phases (dtx_corr_params.lowrank_max) and
 *    with a factorisation at every changed phase agree (same pairs,
 *    deformed targets within 1e-12 of the diagonal).
 *  - Lion + garment shell: the shell follows the body.
 */
#include "check.h"
#include "dtx_core.h"
#include "generate.h"
#include "meshfile.h"
#include "proximity.h"

#include <omp.h>
#include <stdlib.h>
#include <string.h>

#define DATA DTX_BUILD "/data/sumner-cat-lion"
#define NPOSE 9

/* The pebble lion's proximity threshold.  The paper's 1.5 x the longest
 * edge assumes evenly sized edges; the lion's longest edges are 5% of its
 * diagonal (7x the median), so with 1.5 a piece is tied to every piece
 * within up to 8% of the diagonal, across legs and chest, and those ties
 * hold the legs back (worst pose 2.6% from sp04; 4.4% with the paper's
 * absolute E3).  0.5 keeps the ties to neighbouring pieces.
 *
 * The bound on the median length change of the pairs per pose.
 * With E3 in relative lengths (the default) it is 1-4%; with the paper's
 * absolute lengths (DTX_MC_LENGTHS_DIAGONAL) 3-12%: pieces turned by their
 * own gradients open and close the cracks, 0.4% of the diagonal wide, and
 * a change of a tenth of that weighs nothing against E1. */
#define PEBBLE_EPS 0.5
#define PEBBLE_MEDIAN 0.05

static dtx_status load(const char *rel, dtx_mesh *m, dtx_error *err)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", DATA, rel);
    return dtx_obj_read(path, m, NULL, err);
}

static double max_diff(const double *a, const double *b, size_t n)
{
    double m = 0.0;
    for (size_t i = 0; i < n; i++) {
        double d = fabs(a[i] - b[i]);
        if (!(d <= m))
            m = d;
    }
    return m;
}

static int cmp_dbl(const void *x, const void *y)
{
    double a = *(const double *)x, b = *(const double *)y;
    return (a > b) - (a < b);
}

/* RMS over the vertices of frame a (na vertices) of |a_v - b_map[v]|, after
 * removing the mean offset, divided by diag. */
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

static dtx_mesh cat, lion;
static dtx_markers mk;
static double *Xs;         /* NPOSE cat poses */
static double *sp04_res;   /* NPOSE lion frames from sp04 */
static double lion_diag;

static void test_single_component_transfer(const dtx_corr *corr)
{
    static const dtx_anchor modes[3] = {DTX_ANCHOR_FIXED, DTX_ANCHOR_FOLLOW, DTX_ANCHOR_PINS};
    size_t n = (size_t)NPOSE * 3 * lion.nv;
    double *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b), ra[NPOSE], rb[NPOSE];
    int32_t pins[2] = {17, 2500};
    dtx_mc_frame_info iters[NPOSE];
    double pin_pos[6];
    dtx_error err;
    dtx_mc_params prm;
    dtx_mc_info info;
    dtx_mc_params_default(&prm);
    for (int i = 0; i < 2; i++)
        for (int k = 0; k < 3; k++)
            pin_pos[3 * i + k] = lion.V[3 * (size_t)pins[i] + k] + 0.01 * (k + 1);
    for (int m = 0; m < 3; m++) {
        dtx_sp04_plan *sp = NULL;
        dtx_mc_plan *mc = NULL;
        int np = modes[m] == DTX_ANCHOR_PINS ? 2 : 0;
        double d, rd = 0.0;
        CHECK_OK(dtx_sp04_plan_create(&cat, &lion, corr->pairs, corr->npairs, modes[m], pins,
                                      pin_pos, np, &sp, &err),
                 &err);
        CHECK_OK(dtx_mc_plan_create(&cat, &lion, corr->pairs, corr->npairs, &prm, modes[m],
                                    pins, pin_pos, np, &mc, &err),
                 &err);
        if (!sp || !mc)
            break;
        dtx_mc_plan_info(mc, &info);
        CHECK_EQ_INT(info.components, 1);
        CHECK_EQ_INT(info.proximity_pairs, 0);
        CHECK_EQ_INT(info.orphan_triangles, 0);
        CHECK_OK(dtx_sp04_apply(sp, NPOSE, Xs, a, ra, &err), &err);
        CHECK_OK(dtx_mc_apply(mc, NPOSE, Xs, b, rb, iters, &err), &err);
        d = max_diff(a, b, n) / lion_diag;
        for (int f = 0; f < NPOSE; f++) {
            double r = fabs(ra[f] - rb[f]) / ra[f];
            rd = r > rd ? r : rd;
            CHECK_EQ_INT(iters[f].iterations, 1); /* linear: one solve, exact */
            CHECK_EQ_INT(iters[f].converged, 1);
        }
        printf("one component, translation mode %d: max |mc - sp04| = %.3g of the diagonal, "
               "residuals differ by %.3g (relative)\n",
               m, d, rd);
        CHECK_DBL(d, <=, 1e-6);
        CHECK_DBL(rd, <=, 1e-6);
        if (m == 0)
            memcpy(sp04_res, a, n * sizeof *a);
        dtx_sp04_plan_free(&sp);
        dtx_mc_plan_free(&mc);
    }
    free(a);
    free(b);
}

/* The whole method on the one-component lion, and thread invariance. */
static void test_single_component_method(void)
{
    dtx_corr corr;
    dtx_corr_params cp;
    dtx_mc_params prm;
    dtx_mc_plan *mc = NULL;
    dtx_error err;
    size_t n = (size_t)NPOSE * 3 * lion.nv;
    double *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b), worst = 0.0;
    int32_t *ident = malloc(sizeof *ident * (size_t)lion.nv);
    for (int32_t v = 0; v < lion.nv; v++)
        ident[v] = v;
    dtx_corr_params_default(&cp);
    dtx_mc_params_default(&prm);
    CHECK_OK(dtx_mc_correspond(&cat, &lion, &mk, &cp, prm.eps_factor, &corr, &err), &err);
    if (check_failed_)
        goto done;
    printf("mc correspondence on the lion: %lld pairs, %d orphan triangles, fit %.3g\n",
           (long long)corr.npairs, corr.unmatched_tgt, corr.fit_rms);
    CHECK(corr.deformed_tgt != NULL && corr.deformed_src == NULL);
    CHECK_DBL((double)corr.unmatched_tgt, <=, 0.02 * lion.nf);
    CHECK_OK(dtx_mc_plan_create(&cat, &lion, corr.pairs, corr.npairs, &prm, DTX_ANCHOR_FIXED,
                                NULL, NULL, 0, &mc, &err),
             &err);
    if (!mc)
        goto done;
    omp_set_num_threads(2);
    CHECK_OK(dtx_mc_apply(mc, NPOSE, Xs, a, NULL, NULL, &err), &err);
    omp_set_num_threads(1);
    /* Split differently: frames one by one. */
    for (int f = 0; f < NPOSE; f++)
        CHECK_OK(dtx_mc_apply(mc, 1, Xs + (size_t)f * 3 * cat.nv, b + (size_t)f * 3 * lion.nv,
                              NULL, NULL, &err),
                 &err);
    omp_set_num_threads(2);
    CHECK(memcmp(a, b, n * sizeof *a) == 0);
    for (int f = 0; f < NPOSE; f++) {
        double r = rms_mapped(a + (size_t)f * 3 * lion.nv, lion.nv,
                              sp04_res + (size_t)f * 3 * lion.nv, ident, lion_diag);
        worst = r > worst ? r : worst;
    }
    printf("whole method on the one-component lion: worst pose RMS %.3f%% of the diagonal "
           "from sp04's\n",
           100.0 * worst);
    CHECK_DBL(worst, <=, 0.02);
done:
    dtx_mc_plan_free(&mc);
    dtx_corr_free(&corr);
    free(a);
    free(b);
    free(ident);
}

/* Markers moved to the generated mesh: each target vertex to the lowest
 * generated vertex that maps to it. */
static int remap_markers(const dtx_markers *in, const int32_t *map, int32_t nv, dtx_markers *out)
{
    dtx_error err;
    if (dtx_markers_alloc(out, in->n, &err) != DTX_OK)
        return 0;
    for (int32_t m = 0; m < in->n; m++) {
        out->src[m] = in->src[m];
        out->tgt[m] = -1;
        for (int32_t v = 0; v < nv; v++)
            if (map[v] == in->tgt[m]) {
                out->tgt[m] = v;
                break;
            }
        if (out->tgt[m] < 0)
            return 0;
    }
    return 1;
}

/* The solver run_mc uses. */
static dtx_mc_solver run_solver = DTX_MC_SOLVER_FIXED_POINT;

/* run_mc's last correspondence, reused while the target, markers and
 * eps_factor stay (it does not depend on the transfer's settings);
 * run_mc_forget drops it before the target goes. */
static struct {
    const dtx_mesh *tgt;
    const dtx_markers *m;
    double eps;
    dtx_corr corr;
    double seconds;
} corr_cache;

static void run_mc_forget(void)
{
    if (corr_cache.tgt)
        dtx_corr_free(&corr_cache.corr);
    corr_cache.tgt = NULL;
}

/* Runs the method onto tgt; res gets NPOSE frames. */
static int run_mc(const dtx_mesh *tgt, const dtx_markers *m, double eps_factor,
                  dtx_mc_lengths lengths, int max_iter, int *nconv, double *res,
                  dtx_mc_info *info, double *corr_s, double *frame_s, int *iters_max)
{
    dtx_corr corr;
    dtx_corr_params cp;
    dtx_mc_params prm;
    dtx_mc_plan *mc = NULL;
    dtx_error err;
    dtx_mc_frame_info iters[NPOSE];
    double t0;
    int ok = 0;
    dtx_corr_params_default(&cp);
    dtx_mc_params_default(&prm);
    prm.eps_factor = eps_factor;
    prm.solver = run_solver;
    if (max_iter > 0)
        prm.max_iter = max_iter;
    if (lengths == DTX_MC_LENGTHS_DIAGONAL) {
        prm.lengths = lengths;
        prm.w_proximity = DTX_MC_W_PROXIMITY_DIAGONAL;
    }
    if (corr_cache.tgt != tgt || corr_cache.m != m || corr_cache.eps != eps_factor) {
        run_mc_forget();
        t0 = omp_get_wtime();
        if (dtx_mc_correspond(&cat, tgt, m, &cp, prm.eps_factor, &corr_cache.corr, &err) !=
            DTX_OK) {
            CHECK_OK(err.code, &err);
            return 0;
        }
        corr_cache.seconds = omp_get_wtime() - t0;
        corr_cache.tgt = tgt;
        corr_cache.m = m;
        corr_cache.eps = eps_factor;
    }
    corr = corr_cache.corr;
    *corr_s = corr_cache.seconds;
    CHECK_OK(dtx_mc_plan_create(&cat, tgt, corr.pairs, corr.npairs, &prm, DTX_ANCHOR_FIXED, NULL,
                                NULL, 0, &mc, &err),
             &err);
    if (mc) {
        dtx_mc_plan_info(mc, info);
        t0 = omp_get_wtime();
        CHECK_OK(dtx_mc_apply(mc, NPOSE, Xs, res, NULL, iters, &err), &err);
        *frame_s = (omp_get_wtime() - t0) / NPOSE;
        const int cap = prm.max_iter > 0 ? prm.max_iter
                        : run_solver == DTX_MC_SOLVER_NEWTON ? DTX_MC_MAX_ITER_NEWTON
                                                             : DTX_MC_MAX_ITER_FIXED_POINT;
        *iters_max = *nconv = 0;
        for (int f = 0; f < NPOSE; f++) {
            *iters_max = iters[f].iterations > *iters_max ? iters[f].iterations : *iters_max;
            *nconv += iters[f].converged;
            /* A frame stops when it converges or when max_iter runs out. */
            CHECK(iters[f].iterations >= 1 && iters[f].iterations <= cap);
            CHECK(iters[f].converged || iters[f].iterations == cap);
        }
        ok = 1;
    }
    dtx_mc_plan_free(&mc);
    return ok;
}

/* The median relative change of the proximity pairs' lengths in each of
 * the NPOSE frames of res (nv vertices each), printed on one line;
 * returns the largest. */
static double pair_medians(const dtx_proximity *prox, const double *res, int32_t nv,
                           const char *what)
{
    double *ch = malloc(sizeof *ch * (size_t)prox->npairs), worst = 0.0;
    if (!ch || prox->npairs == 0) {
        free(ch);
        return NAN;
    }
    printf("pebble lion, %s: median pair-length change per pose", what);
    for (int f = 0; f < NPOSE; f++) {
        const double *x = res + (size_t)f * 3 * nv;
        for (int64_t i = 0; i < prox->npairs; i++) {
            const double *a = x + 3 * (size_t)prox->pairs[2 * i];
            const double *b = x + 3 * (size_t)prox->pairs[2 * i + 1];
            double d = sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                            (a[2] - b[2]) * (a[2] - b[2]));
            ch[i] = fabs(d - prox->rest_len[i]) / (prox->rest_len[i] > 0 ? prox->rest_len[i] : 1);
        }
        qsort(ch, (size_t)prox->npairs, sizeof *ch, cmp_dbl);
        printf(" %.2f%%", 100.0 * ch[prox->npairs / 2]);
        worst = ch[prox->npairs / 2] > worst ? ch[prox->npairs / 2] : worst;
    }
    printf("\n");
    free(ch);
    return worst;
}

static void test_pebbles(void)
{
    dtx_mesh peb = {0};
    int32_t *map = NULL;
    dtx_markers pm = {0};
    dtx_error err;
    dtx_mc_info info;
    dtx_proximity prox = {0};
    double *res = NULL, worst = 0.0, worst_rel = 0.0, cs, fs;
    int itmax, nconv;
    if (dtx_gen_pebbles(&lion, 240, 0.004, 0.0, 0, &peb, &map, &err) != DTX_OK) {
        CHECK_OK(err.code, &err);
        return;
    }
    CHECK(remap_markers(&mk, map, peb.nv, &pm));
    res = malloc(sizeof *res * (size_t)NPOSE * 3 * peb.nv);
    if (!run_mc(&peb, &pm, PEBBLE_EPS, DTX_MC_LENGTHS_RELATIVE, 0, &nconv, res, &info, &cs, &fs,
                &itmax))
        goto done;
    printf("pebble lion: %d vertices, %d components, %lld proximity pairs, %d orphan "
           "triangles, %d orphan components; correspondence %.2f s, %.3f s/frame, <= %d "
           "iterations\n",
           peb.nv, info.components, (long long)info.proximity_pairs, info.orphan_triangles,
           info.orphan_components, cs, fs, itmax);
    CHECK_EQ_INT(info.components, 240);
    /* The correspondence's low-rank phases (dtx_corr_params.lowrank_max,
     * default) against refactorising every phase whose matrix changed (0):
     * fewer factorisations, the same pairs, deformed targets within 1e-12
     * of the diagonal.  The default weights leave no such phase on this
     * small target; a tight max_distance and three phases at one weight make
     * a few vertices gain or lose their closest point between phases. */
    {
        dtx_corr a = {0}, b = {0};
        dtx_corr_params cp;
        double dmax = 0.0, dg;
        dtx_corr_params_default(&cp);
        cp.n_closest = 4;
        cp.w_closest[0] = 1.0;
        cp.w_closest[1] = cp.w_closest[2] = cp.w_closest[3] = 100.0;
        cp.max_distance = 0.01;
        CHECK_OK(dtx_mc_correspond(&cat, &peb, &pm, &cp, PEBBLE_EPS, &a, &err), &err);
        cp.lowrank_max = 0;
        CHECK_OK(dtx_mc_correspond(&cat, &peb, &pm, &cp, PEBBLE_EPS, &b, &err), &err);
        if (a.deformed_tgt && b.deformed_tgt) {
            dg = dtx_bbox_diagonal(a.deformed_tgt, a.nv_tgt);
            for (size_t i = 0; i < 3 * (size_t)peb.nv; i++) {
                double d = fabs(a.deformed_tgt[i] - b.deformed_tgt[i]);
                if (!(d <= dmax)) /* NaN becomes the maximum */
                    dmax = d;
            }
            printf("pebble lion, correspondence: %d factorisations with low-rank phases, %d "
                   "without (%d solves); deformed targets %.3g of the diagonal apart\n",
                   a.factorizations, b.factorizations, a.solves, dmax / dg);
            CHECK_INT(a.factorizations, <, b.factorizations);
            CHECK_EQ_INT(a.solves, b.solves);
            CHECK_DBL(dmax, <=, 1e-12 * dg);
            CHECK_EQ_INT(a.npairs, b.npairs);
            if (a.npairs == b.npairs)
                CHECK_EQ_INT(memcmp(a.pairs, b.pairs, 2 * sizeof(int32_t) * (size_t)a.npairs), 0);
        }
        dtx_corr_free(&a);
        dtx_corr_free(&b);
        cp.lowrank_max = -1;
        CHECK_EQ_INT(dtx_mc_correspond(&cat, &peb, &pm, &cp, PEBBLE_EPS, &a, &err), DTX_EINVAL);
        CHECK(strstr(err.msg, "lowrank_max") != NULL);
        dtx_corr_free(&a);
    }
    for (int f = 0; f < NPOSE; f++) {
        double r = rms_mapped(res + (size_t)f * 3 * peb.nv, peb.nv,
                              sp04_res + (size_t)f * 3 * lion.nv, map, lion_diag);
        worst = r > worst ? r : worst;
    }
    printf("pebble lion: worst pose RMS %.3f%% of the diagonal from sp04's lion\n",
           100.0 * worst);
    CHECK_DBL(worst, <=, 0.02);
    /* Proximity-pair lengths: median relative change per pose, and no
     * piece left behind (each piece's centroid near its lion vertices'). */
    CHECK_OK(dtx_proximity_build(&peb, PEBBLE_EPS, &prox, &err), &err);
    CHECK(prox.npairs > 0);
    worst_rel = pair_medians(&prox, res, peb.nv, "relative lengths (default)");
    CHECK_DBL(worst_rel, <=, PEBBLE_MEDIAN);
    {
        /* Each piece: centroid distance to the centroid of sp04's result
         * at its mapped vertices, at most 2% of the diagonal (mean offset
         * removed as in rms_mapped). */
        double far = 0.0;
        for (int f = 0; f < NPOSE; f++) {
            const double *x = res + (size_t)f * 3 * peb.nv, *y = sp04_res + (size_t)f * 3 * lion.nv;
            double *acc = calloc((size_t)info.components, 7 * sizeof *acc), mo[3] = {0, 0, 0};
            for (int32_t v = 0; v < peb.nv; v++)
                for (int k = 0; k < 3; k++)
                    mo[k] += (x[3 * (size_t)v + k] - y[3 * (size_t)map[v] + k]) / peb.nv;
            for (int32_t v = 0; v < peb.nv; v++) {
                double *c = acc + 7 * (size_t)prox.comp[v];
                if (map[v] < 0 || prox.comp[v] < 0)
                    continue;
                for (int k = 0; k < 3; k++) {
                    c[k] += x[3 * (size_t)v + k] - mo[k];
                    c[3 + k] += y[3 * (size_t)map[v] + k];
                }
                c[6] += 1;
            }
            for (int32_t c = 0; c < info.components; c++) {
                double *a = acc + 7 * (size_t)c, d2 = 0.0;
                for (int k = 0; k < 3; k++) {
                    double d = (a[k] - a[3 + k]) / a[6];
                    d2 += d * d;
                }
                far = sqrt(d2) > far ? sqrt(d2) : far;
            }
            free(acc);
        }
        printf("pebble lion: farthest piece centroid %.3f%% of the diagonal from sp04's\n",
               100.0 * far / lion_diag);
        CHECK_DBL(far / lion_diag, <=, 0.04);
    }
    /* Newton converges where the fixed-point iteration stops at max_iter:
     * every frame within the default max_iter, as close to sp04 and with
     * the cracks kept as well (the plain pass only, on the first pose:
     * about 50 steps, 0.7 s; dtx_bench_mc measures all nine; the sanitizer
     * pass runs the solver on the shirt). */
    if (!(getenv("DTX_SANITIZED") && strcmp(getenv("DTX_SANITIZED"), "1") == 0)) {
        enum { NF = 1 };
        dtx_mc_params prm;
        dtx_mc_plan *mc = NULL;
        dtx_mc_frame_info it[NF];
        double wn = 0.0, med = 0.0;
        int conv = 0, steps = 0;
        dtx_mc_params_default(&prm);
        prm.eps_factor = PEBBLE_EPS;
        prm.solver = DTX_MC_SOLVER_NEWTON;
        CHECK_OK(dtx_mc_plan_create(&cat, &peb, corr_cache.corr.pairs, corr_cache.corr.npairs, &prm,
                                    DTX_ANCHOR_FIXED, NULL, NULL, 0, &mc, &err),
                 &err);
        if (mc)
            CHECK_OK(dtx_mc_apply(mc, NF, Xs, res, NULL, it, &err), &err);
        for (int f = 0; mc && f < NF; f++) {
            double r = rms_mapped(res + (size_t)f * 3 * peb.nv, peb.nv,
                                  sp04_res + (size_t)f * 3 * lion.nv, map, lion_diag);
            double *ch = malloc(sizeof *ch * (size_t)prox.npairs);
            const double *x = res + (size_t)f * 3 * peb.nv;
            wn = r > wn ? r : wn;
            conv += it[f].converged;
            steps = it[f].iterations > steps ? it[f].iterations : steps;
            for (int64_t i = 0; ch && i < prox.npairs; i++) {
                const double *a = x + 3 * (size_t)prox.pairs[2 * i];
                const double *b = x + 3 * (size_t)prox.pairs[2 * i + 1];
                double d = sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                                (a[2] - b[2]) * (a[2] - b[2]));
                ch[i] = fabs(d - prox.rest_len[i]) / (prox.rest_len[i] > 0 ? prox.rest_len[i] : 1);
            }
            if (ch) {
                qsort(ch, (size_t)prox.npairs, sizeof *ch, cmp_dbl);
                med = ch[prox.npairs / 2] > med ? ch[prox.npairs / 2] : med;
            }
            free(ch);
        }
        printf("pebble lion, Newton: %d of %d frames converged, <= %d Newton steps; worst RMS "
               "%.3f%% of the diagonal from sp04's, median pair change <= %.2f%%\n",
               conv, NF, steps - 1, 100.0 * wn, 100.0 * med);
        CHECK_EQ_INT(conv, NF);
        CHECK(steps <= DTX_MC_MAX_ITER_NEWTON);
        CHECK_DBL(wn, <=, 0.02);
        CHECK_DBL(med, <=, PEBBLE_MEDIAN);
        dtx_mc_plan_free(&mc);
    }
    /* The paper's absolute E3 holds the cracks more loosely. */
    if (run_mc(&peb, &pm, PEBBLE_EPS, DTX_MC_LENGTHS_DIAGONAL, 0, &nconv, res, &info, &cs, &fs,
               &itmax)) {
        double worst_diag = pair_medians(&prox, res, peb.nv, "the paper's absolute lengths");
        CHECK_DBL(worst_diag, >, 2.0 * worst_rel);
    }
done:
    dtx_proximity_free(&prox);
    run_mc_forget();
    dtx_mesh_free(&peb);
    dtx_markers_free(&pm);
    free(map);
    free(res);
}

static void test_garment(void)
{
    dtx_mesh gar = {0};
    int32_t *map = NULL;
    dtx_error err;
    dtx_mc_info info;
    double *res = NULL, *res2 = NULL, worst = 0.0, cs, fs;
    int itmax, nconv, sanitized;
    if (dtx_gen_garment(&lion, 2, 0.45, 0.72, 0.01, &gar, &map, &err) != DTX_OK) {
        CHECK_OK(err.code, &err);
        return;
    }
    res = malloc(sizeof *res * (size_t)NPOSE * 3 * gar.nv);
    if (!run_mc(&gar, &mk, 1.5, DTX_MC_LENGTHS_RELATIVE, 0, &nconv, res, &info, &cs, &fs, &itmax))
        goto done;
    printf("lion + garment: %d vertices, %d components, %lld proximity pairs, %d orphan "
           "triangles; correspondence %.2f s, %.3f s/frame, <= %d iterations\n",
           gar.nv, info.components, (long long)info.proximity_pairs, info.orphan_triangles, cs,
           fs, itmax);
    CHECK_EQ_INT(info.components, 2);
    /* The shell follows the body: each shell vertex stays near its body
     * vertex, at its rest offset (1% of the diagonal) give or take (0.7%
     * RMS measured at the worst pose). */
    for (int f = 0; f < NPOSE; f++) {
        const double *x = res + (size_t)f * 3 * gar.nv;
        double s2 = 0.0;
        int32_t n = 0;
        for (int32_t v = lion.nv; v < gar.nv; v++) {
            const double *a = x + 3 * (size_t)v, *b = x + 3 * (size_t)map[v];
            const double *a0 = gar.V + 3 * (size_t)v, *b0 = gar.V + 3 * (size_t)map[v];
            double d = 0.0, d0 = 0.0;
            for (int k = 0; k < 3; k++) {
                d += (a[k] - b[k]) * (a[k] - b[k]);
                d0 += (a0[k] - b0[k]) * (a0[k] - b0[k]);
            }
            s2 += (sqrt(d) - sqrt(d0)) * (sqrt(d) - sqrt(d0));
            n++;
        }
        s2 = sqrt(s2 / n) / lion_diag;
        worst = s2 > worst ? s2 : worst;
    }
    printf("lion + garment: shell-to-body distance changes by %.3f%% of the diagonal (RMS, "
           "worst pose)\n",
           100.0 * worst);
    CHECK_DBL(worst, <=, 0.02);
    /* The body itself still moves like sp04's lion. */
    {
        int32_t *ident = malloc(sizeof *ident * (size_t)gar.nv);
        double wb = 0.0;
        for (int32_t v = 0; v < gar.nv; v++)
            ident[v] = v < lion.nv ? v : -1;
        for (int f = 0; f < NPOSE; f++) {
            double r = rms_mapped(res + (size_t)f * 3 * gar.nv, gar.nv,
                                  sp04_res + (size_t)f * 3 * lion.nv, ident, lion_diag);
            wb = r > wb ? r : wb;
        }
        printf("lion + garment: body RMS %.3f%% of the diagonal from sp04's lion\n", 100.0 * wb);
        CHECK_DBL(wb, <=, 0.02);
        free(ident);
    }
    /* With room, every frame meets tol and says so (the plain pass only: the
     * sanitizer pass compares Newton with the result at max_iter 30, which
     * is as close). */
    sanitized = getenv("DTX_SANITIZED") && strcmp(getenv("DTX_SANITIZED"), "1") == 0;
    if (!sanitized && run_mc(&gar, &mk, 1.5, DTX_MC_LENGTHS_RELATIVE, 200, &nconv, res, &info,
                             &cs, &fs, &itmax)) {
        printf("lion + garment, max_iter 200: %d of %d frames converged, <= %d iterations\n",
               nconv, NPOSE, itmax);
        CHECK_EQ_INT(nconv, NPOSE);
        CHECK(itmax < 200);
    }
    /* Newton converges within the default max_iter (30), every frame, to
     * the same poses: the fixed-point iteration's at max_iter 200 stopped
     * within 1e-6 x the diagonal a step (9.4e-6 apart measured; 1.1e-5 from
     * the result at max_iter 30), Newton's within 1e-6 of its estimated
     * minimiser. */
    res2 = malloc(sizeof *res2 * (size_t)NPOSE * 3 * gar.nv);
    run_solver = DTX_MC_SOLVER_NEWTON;
    if (res2 && run_mc(&gar, &mk, 1.5, DTX_MC_LENGTHS_RELATIVE, 0, &nconv, res2, &info, &cs,
                       &fs, &itmax)) {
        double dmax = 0.0;
        for (size_t i = 0; i < (size_t)NPOSE * 3 * gar.nv; i++)
            dmax = fabs(res2[i] - res[i]) > dmax ? fabs(res2[i] - res[i]) : dmax;
        printf("lion + garment, Newton: %d of %d frames converged, <= %d Newton steps, %.3f "
               "s/frame; max |newton - fixed point at max_iter %d| = %.2e of the diagonal\n",
               nconv, NPOSE, itmax - 1, fs, sanitized ? 30 : 200, dmax / lion_diag);
        CHECK_EQ_INT(nconv, NPOSE);
        CHECK_DBL(dmax / lion_diag, <=, 1e-3);
    }
    run_solver = DTX_MC_SOLVER_FIXED_POINT;
done:
    run_mc_forget();
    dtx_mesh_free(&gar);
    free(map);
    free(res);
    free(res2);
}

int main(void)
{
    dtx_mesh pose;
    dtx_corr corr;
    dtx_corr_params prm;
    dtx_error err;
    char rel[64];

    CHECK_OK(load("source/cat-reference.obj", &cat, &err), &err);
    CHECK_OK(load("target/lion-reference.obj", &lion, &err), &err);
    CHECK_OK(dtx_markers_read_csv(DATA "/markers.csv", 0, &mk, &err), &err);
    if (check_failed_)
        return check_report();
    lion_diag = dtx_bbox_diagonal(lion.V, lion.nv);
    Xs = malloc(sizeof(double) * 3 * cat.nv * NPOSE);
    sp04_res = malloc(sizeof(double) * 3 * lion.nv * NPOSE);
    for (int k = 1; k <= NPOSE; k++) {
        snprintf(rel, sizeof rel, "source/cat-%02d.obj", k);
        CHECK_OK(load(rel, &pose, &err), &err);
        memcpy(Xs + (size_t)(k - 1) * 3 * cat.nv, pose.V, sizeof(double) * 3 * cat.nv);
        dtx_mesh_free(&pose);
    }
    dtx_corr_params_default(&prm);
    CHECK_OK(dtx_sp04_correspond(&cat, &lion, &mk, &prm, &corr, &err), &err);
    if (check_failed_)
        return check_report();
    test_single_component_transfer(&corr);
    dtx_corr_free(&corr);
    test_single_component_method();
    test_pebbles();
    test_garment();

    free(Xs);
    free(sp04_res);
    dtx_mesh_free(&cat);
    dtx_mesh_free(&lion);
    dtx_markers_free(&mk);
    return check_report();
}
