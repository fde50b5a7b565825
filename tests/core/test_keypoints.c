/*
 * test_keypoints.c: greedy key-point selection (keypoints.h).
 *
 * On a capsule bent, twisted and bulged over six frames (always runs) and
 * on three cat poses (the bundled data; not in the sanitizer build):
 *  - the recorded error never increases, as points are added or replaced,
 *    and ends below the error of the first point alone;
 *  - key points are distinct candidates;
 *  - 1 and 2 OpenMP threads, and two 1-thread parts combined by a reduce
 *    function (as MPI ranks would), choose the same points with bitwise the
 *    same errors; the parts share the candidates' Green's-function solves
 *    (as many in all as one part alone does);
 *  - a bigger threshold stops earlier (fewer points, error <= eps or no
 *    improving candidate);
 *  - the fast evaluation's final set, re-evaluated exactly, is within a
 *    factor of the exact mode's (capsule; figures printed);
 *  - bad parameters and frames are refused with a message.
 */
#include "check.h"
#include "dtx_core.h"
#include "keypoints.h"
#include "meshfile.h"
#include "meshgen.h"

#include <omp.h>
#include <string.h>

#define DATA DTX_BUILD "/data/sumner-cat-lion"

static void check_result(const dtx_kp_result *r, const char *what)
{
    CHECK_INT(r->count, >=, 1);
    for (int32_t i = 0; i < r->ntrace; i++)
        CHECK_DBL(r->trace[i], <=, i ? r->trace[i - 1] : r->error_first);
    CHECK_DBL(r->error, <=, r->error_first);
    CHECK(r->ntrace == 0 || r->trace[r->ntrace - 1] == r->error);
    for (int32_t i = 0; i < r->count; i++) {
        int found = 0;
        for (int32_t j = 0; j < r->ncand; j++)
            found += r->candidates[j] == r->keys[i];
        CHECK_EQ_INT(found, 1);
        for (int32_t j = 0; j < i; j++)
            CHECK(r->keys[j] != r->keys[i]);
    }
    printf("%s: %d key points from %d candidates, error %.4f (first point alone %.4f, exact "
           "weights %.4f), %d replacements in %d sweeps, %lld evaluations, %lld failed\n",
           what, (int)r->count, (int)r->ncand, r->error, r->error_first, r->error_exact,
           (int)r->replacements, r->sweeps, (long long)r->evaluations, (long long)r->failed);
}

static int same(const dtx_kp_result *a, const dtx_kp_result *b)
{
    if (a->count != b->count || a->ntrace != b->ntrace || a->error != b->error ||
        a->error_exact != b->error_exact)
        return 0;
    for (int32_t i = 0; i < a->count; i++)
        if (a->keys[i] != b->keys[i])
            return 0;
    for (int32_t i = 0; i < a->ntrace; i++)
        if (a->trace[i] != b->trace[i])
            return 0;
    return 1;
}

/* Two parts in two OpenMP threads: each leaves its errors in a slot, and
 * both take the element-wise minimum. */
typedef struct {
    double *slot[2];
    int32_t n, cap[2]; /* slot sizes: the final weights are nv x m, more than n */
    int ok[2], calls[2];
} two_parts;

static dtx_status reduce_two(void *ctx, double *errs, int32_t n, int local_ok, dtx_error *e)
{
    two_parts *tp = ctx;
    int me = omp_get_thread_num(), ok;
    tp->ok[me] = local_ok;
    tp->calls[me]++;
#pragma omp barrier
    ok = tp->ok[0] && tp->ok[1];
#pragma omp barrier
    if (!ok)
        return dtx_seterr(e, DTX_EMPI, "another part failed");
    if (n > tp->cap[me]) {
        double *g = realloc(tp->slot[me], (size_t)n * sizeof *g);
        CHECK(g != NULL);
        if (!g)
            abort();
        tp->slot[me] = g;
        tp->cap[me] = n;
    }
    if (n > 0)
        memcpy(tp->slot[me], errs, (size_t)n * sizeof *errs);
#pragma omp barrier
    for (int32_t i = 0; i < n; i++) {
        double a = tp->slot[0][i], b = tp->slot[1][i];
        errs[i] = a < b ? a : b;
    }
#pragma omp barrier
    return DTX_OK;
}

/* full: also 1 vs 2 threads in one process, and a bigger threshold (the
 * cat runs 2 threads against two 1-thread parts only, to keep CI short). */
static void run_all(const char *what, const dtx_mesh *m, int32_t nframes, const double *X,
                    int32_t nc, int full)
{
    dtx_kp_params p;
    dtx_kp_result r1, r2, rp[2], rx, rbig;
    dtx_error err, e2[2];
    dtx_status s2[2];
    two_parts tp;
    char name[128];

    dtx_kp_params_default(&p);
    p.candidates = nc;
    p.eps = 0.0; /* add while a candidate helps, up to max_keys */
    p.max_keys = 8;
    p.threads = full ? 1 : 2;
    CHECK_OK(dtx_keypoints_select(m, nframes, X, &p, &r1, &err), &err);
    snprintf(name, sizeof name, "%s, %d thread(s)", what, p.threads);
    check_result(&r1, name);
    memset(&r2, 0, sizeof r2);
    memset(&rbig, 0, sizeof rbig);
    if (full) {
        p.threads = 2;
        CHECK_OK(dtx_keypoints_select(m, nframes, X, &p, &r2, &err), &err);
        CHECK(same(&r1, &r2));
    }

    /* Two parts. */
    tp.n = nc;
    tp.cap[0] = tp.cap[1] = nc;
    tp.slot[0] = calloc((size_t)nc, sizeof(double));
    tp.slot[1] = calloc((size_t)nc, sizeof(double));
#pragma omp parallel num_threads(2)
    {
        int me = omp_get_thread_num();
        dtx_kp_params q = p;
        q.threads = 1;
        q.part_index = me;
        q.part_count = 2;
        q.reduce = reduce_two;
        q.reduce_ctx = &tp;
        s2[me] = dtx_keypoints_select(m, nframes, X, &q, &rp[me], &e2[me]);
    }
    CHECK_OK(s2[0], &e2[0]);
    CHECK_OK(s2[1], &e2[1]);
    if (s2[0] == DTX_OK && s2[1] == DTX_OK) {
        CHECK(same(&r1, &rp[0]));
        CHECK(same(&r1, &rp[1]));
        CHECK_INT(rp[0].evaluations + rp[1].evaluations, ==, r1.evaluations);
        /* The candidates' Green's functions are solved once over the
         * parts, shared out in turn (part 0 first), not once on each. */
        CHECK_INT(r1.solves, >=, r1.ncand - r1.count);
        CHECK_INT(rp[0].solves + rp[1].solves, ==, r1.solves);
        CHECK_INT(rp[1].solves, >=, 1);
        CHECK_INT(rp[0].solves - rp[1].solves, >=, 0);
        CHECK_INT(rp[0].solves - rp[1].solves, <=, r1.solves - rp[0].solves);
        /* The round's candidates are dealt in turn, part 0 first: in each
         * round part 0 has as many as part 1 or one more, and a round
         * evaluates at least ncand - count candidates. */
        CHECK_INT(rp[0].evaluations - rp[1].evaluations, >=, 0);
        CHECK_INT(rp[0].evaluations - rp[1].evaluations, <=,
                  r1.ncand > r1.count ? r1.evaluations / (r1.ncand - r1.count) : 0);
    }

    /* A threshold between the first and the last error stops earlier. */
    if (full) {
        p.eps = 0.5 * (r1.error_first + r1.error);
        CHECK_OK(dtx_keypoints_select(m, nframes, X, &p, &rbig, &err), &err);
        CHECK_INT(rbig.count, <=, r1.count);
        CHECK_DBL(rbig.trace && rbig.count > 1 ? rbig.trace[rbig.count - 2] : rbig.error, <=,
                  p.eps);
    }

    if (full) {
        p.eps = 0.0;
        p.exact = 1;
        CHECK_OK(dtx_keypoints_select(m, nframes, X, &p, &rx, &err), &err);
        snprintf(name, sizeof name, "%s, exact", what);
        check_result(&rx, name);
        CHECK_DBL(rx.error, ==, rx.error_exact);
        /* The fast path's set is a good set by the exact measure too. */
        CHECK_DBL(r1.error_exact, <=, 1.5 * rx.error);
        {
            int common = 0;
            for (int32_t i = 0; i < r1.count; i++)
                for (int32_t j = 0; j < rx.count; j++)
                    common += r1.keys[i] == rx.keys[j];
            printf("%s: fast vs exact: %d and %d points, %d in common; exact error of the "
                   "fast set %.4f vs the exact set %.4f\n",
                   what, (int)r1.count, (int)rx.count, common, r1.error_exact, rx.error);
        }
        dtx_kp_result_free(&rx);
    }
    free(tp.slot[0]);
    free(tp.slot[1]);
    dtx_kp_result_free(&r1);
    dtx_kp_result_free(&r2);
    dtx_kp_result_free(&rp[0]);
    dtx_kp_result_free(&rp[1]);
    dtx_kp_result_free(&rbig);
}

/* A part failing on its own (here: too few key points allowed for the two
 * components of a doubled capsule, found before the first round) tells the
 * other part through the reduce and stops; the other part, waiting in its
 * first round's reduce, stops too (without the protocol it would wait at
 * the barrier forever and the test would time out). */
static void test_part_failure(const dtx_mesh *m, int32_t nframes, const double *X)
{
    dtx_mesh d = {0};
    double *Y = malloc(sizeof *Y * (size_t)nframes * 6 * m->nv);
    two_parts tp;
    dtx_kp_result r[2];
    dtx_error e[2];
    dtx_status s[2];
    int32_t nc = 10;
    d.nv = 2 * m->nv;
    d.nf = 2 * m->nf;
    d.V = malloc(sizeof *d.V * 3 * (size_t)d.nv);
    d.F = malloc(sizeof *d.F * 3 * (size_t)d.nf);
    for (int32_t i = 0; i < 3 * m->nv; i++) {
        d.V[i] = m->V[i];
        d.V[3 * m->nv + i] = m->V[i] + (i % 3 == 0 ? 10.0 : 0.0);
    }
    for (int32_t i = 0; i < 3 * m->nf; i++) {
        d.F[i] = m->F[i];
        d.F[3 * m->nf + i] = m->F[i] + m->nv;
    }
    for (int32_t f = 0; f < nframes; f++)
        for (int32_t i = 0; i < 3 * m->nv; i++) {
            const double x = X[(size_t)f * 3 * m->nv + i];
            Y[(size_t)f * 6 * m->nv + i] = x;
            Y[(size_t)f * 6 * m->nv + 3 * m->nv + i] = x + (i % 3 == 0 ? 10.0 : 0.0);
        }
    memset(&tp, 0, sizeof tp);
    tp.n = nc;
    tp.cap[0] = tp.cap[1] = nc;
    tp.slot[0] = calloc((size_t)nc, sizeof(double));
    tp.slot[1] = calloc((size_t)nc, sizeof(double));
#pragma omp parallel num_threads(2)
    {
        int me = omp_get_thread_num();
        dtx_kp_params q;
        dtx_kp_params_default(&q);
        q.candidates = nc;
        q.eps = 0.0;
        q.max_keys = me == 1 ? 1 : 4;
        q.threads = 1;
        q.part_index = me;
        q.part_count = 2;
        q.reduce = reduce_two;
        q.reduce_ctx = &tp;
        s[me] = dtx_keypoints_select(&d, nframes, Y, &q, &r[me], &e[me]);
    }
    CHECK_INT(s[1], ==, DTX_EINVAL);
    CHECK(strstr(e[1].msg, "more components than max_keys") != NULL);
    CHECK_INT(s[0], ==, DTX_EMPI);
    CHECK(strstr(e[0].msg, "another part failed") != NULL);
    CHECK_INT(tp.calls[0], ==, 1);
    CHECK_INT(tp.calls[1], ==, 1);
    CHECK(r[0].keys == NULL && r[1].keys == NULL);
    free(tp.slot[0]);
    free(tp.slot[1]);
    free(Y);
    dtx_mesh_free(&d);
}

static void test_capsule(void)
{
    dtx_mesh m = {0};
    enum { NF = 6 };
    double *X;
    CHECK_OK(gen_capsule(24, 18, 2.0, &m), &(dtx_error){0});
    X = malloc(sizeof *X * (size_t)NF * 3 * m.nv);
    for (int f = 0; f < NF; f++)
        deform(m.V, m.nv, (f + 1) / (double)NF, X + (size_t)f * 3 * m.nv);
    run_all("capsule", &m, NF, X, 14, 1);
    test_part_failure(&m, NF, X);

    /* Bad input. */
    {
        dtx_kp_params p;
        dtx_kp_result r;
        dtx_error err;
        dtx_kp_params_default(&p);
        p.candidates = 0;
        CHECK_INT(dtx_keypoints_select(&m, NF, X, &p, &r, &err), ==, DTX_EINVAL);
        CHECK(strstr(err.msg, "candidates") != NULL);
        dtx_kp_params_default(&p);
        p.part_count = 2;
        CHECK_INT(dtx_keypoints_select(&m, NF, X, &p, &r, &err), ==, DTX_EINVAL);
        dtx_kp_params_default(&p);
        X[3 * 7 + 1] = NAN;
        CHECK_INT(dtx_keypoints_select(&m, NF, X, &p, &r, &err), ==, DTX_ENONFINITE);
        CHECK(strstr(err.msg, "vertex 7") != NULL);
        CHECK(r.keys == NULL && r.count == 0);
    }
    free(X);
    dtx_mesh_free(&m);
}

#ifndef __SANITIZE_ADDRESS__ /* the plain build only (see main) */
static void test_cat(void)
{
    dtx_mesh cat = {0}, pose = {0};
    dtx_error err;
    static const char *poses[] = {"cat-01.obj", "cat-04.obj", "cat-05.obj"};
    double *X;
    char path[1024];
    CHECK_OK(dtx_obj_read(DATA "/source/cat-reference.obj", &cat, NULL, &err), &err);
    if (cat.nv == 0)
        return;
    X = malloc(sizeof *X * 3 * 3 * (size_t)cat.nv);
    for (int f = 0; f < 3; f++) {
        snprintf(path, sizeof path, "%s/source/%s", DATA, poses[f]);
        CHECK_OK(dtx_obj_read(path, &pose, NULL, &err), &err);
        if (pose.nv == cat.nv)
            memcpy(X + (size_t)f * 3 * cat.nv, pose.V, sizeof *X * 3 * (size_t)cat.nv);
        dtx_mesh_free(&pose);
    }
    run_all("cat, 3 poses", &cat, 3, X, 20, 0);
    free(X);
    dtx_mesh_free(&cat);
}
#endif

int main(void)
{
    test_capsule();
#ifdef __SANITIZE_ADDRESS__
    /* The sanitizer pass checks memory on the capsule, which runs every
     * path above; the plain pass adds the cat's full size. */
    printf("cat: skipped in the sanitizer build (the plain build runs it)\n");
#else
    test_cat();
#endif
    return check_report();
}
