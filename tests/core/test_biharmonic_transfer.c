/*
 * test_biharmonic_transfer.c: biharmonic deformation transfer
 * (transfer_bh.h).
 *  - Onto the source itself with key points chosen by keypoints.h, the
 *    frames come back closely (the figure is printed; bound 2% of the
 *    diagonal RMS on the capsule).
 *  - Onto a rotated, scaled and moved copy of the source with the same key
 *    points, the result is the same similarity of the first result.
 *  - 1 and 2 threads, and one call vs frame by frame, give the same bits.
 *  - cat -> lion with the 55 markers as key points: RMS distance to the
 *    paper's results per pose, next to sp04's (printed; the methods
 *    differ, the bound only catches a broken transfer: 5% of the diagonal).
 *  - Bad key points are refused with a message naming them.
 */
#include "check.h"
#include "dtx_core.h"
#include "keypoints.h"
#include "meshfile.h"
#include "meshgen.h"
#include "transfer_bh.h"

#include <omp.h>
#include <string.h>

#define DATA DTX_BUILD "/data/sumner-cat-lion"

/* RMS distance of a and b (n x 3) after removing the mean offset, / diag. */
static double rms_centered(const double *a, const double *b, int32_t n, double diag)
{
    double mo[3] = {0, 0, 0}, s2 = 0;
    for (int32_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++)
            mo[k] += (a[3 * i + k] - b[3 * i + k]) / n;
    for (int32_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            double d = a[3 * i + k] - b[3 * i + k] - mo[k];
            s2 += d * d;
        }
    return sqrt(s2 / n) / diag;
}

static void test_capsule(void)
{
    enum { NF = 6 };
    dtx_mesh m = {0}, moved = {0};
    dtx_kp_params kp;
    dtx_kp_result kr;
    dtx_bh_plan *plan = NULL, *plan2 = NULL;
    dtx_error err;
    double *X, *Y, *Y2, *Z, *res, worst = 0, R[9], t[3] = {0.3, -1.2, 2.0}, s = 1.7, dmax = 0;
    double diag;
    CHECK_OK(gen_capsule(24, 18, 2.0, &m), &err);
    diag = dtx_bbox_diagonal(m.V, m.nv);
    X = malloc(sizeof *X * (size_t)NF * 3 * m.nv);
    Y = malloc(sizeof *Y * (size_t)NF * 3 * m.nv);
    Y2 = malloc(sizeof *Y2 * (size_t)NF * 3 * m.nv);
    Z = malloc(sizeof *Z * (size_t)NF * 3 * m.nv);
    res = malloc(sizeof *res * NF);
    for (int f = 0; f < NF; f++)
        deform(m.V, m.nv, (f + 1) / (double)NF, X + (size_t)f * 3 * m.nv);
    dtx_kp_params_default(&kp);
    kp.candidates = 20;
    kp.eps = 0.01;
    CHECK_OK(dtx_keypoints_select(&m, NF, X, &kp, &kr, &err), &err);
    if (kr.count < 1)
        goto done;

    /* Onto itself. */
    CHECK_OK(dtx_bh_plan_create(&m, &m, kr.keys, kr.keys, kr.count, NULL, NF, X, &plan, &err),
             &err);
    if (!plan)
        goto done;
    CHECK_OK(dtx_bh_apply(plan, NF, X, Y, res, &err), &err);
    for (int f = 0; f < NF; f++) {
        double r = rms_centered(Y + (size_t)f * 3 * m.nv, X + (size_t)f * 3 * m.nv, m.nv, diag);
        worst = r > worst ? r : worst;
        CHECK_DBL(res[f], >=, 0.0);
        CHECK_DBL(res[f], <=, 0.05);
    }
    printf("capsule onto itself, %d key points: worst frame %.3f%% of the diagonal (RMS)\n",
           (int)kr.count, 100 * worst);
    CHECK_DBL(worst, <=, 0.02);

    /* Thread counts and frame-by-frame calls. */
    omp_set_num_threads(1);
    CHECK_OK(dtx_bh_apply(plan, NF, X, Y2, NULL, &err), &err);
    omp_set_num_threads(2);
    CHECK(memcmp(Y, Y2, sizeof *Y * (size_t)NF * 3 * m.nv) == 0);
    for (int f = 0; f < NF; f++)
        CHECK_OK(dtx_bh_apply(plan, 1, X + (size_t)f * 3 * m.nv, Y2 + (size_t)f * 3 * m.nv, NULL,
                              &err),
                 &err);
    CHECK(memcmp(Y, Y2, sizeof *Y * (size_t)NF * 3 * m.nv) == 0);

    /* Onto a moved copy: the same motion of the result. */
    rotation(0.7, R);
    CHECK_OK(dtx_mesh_copy(&m, &moved, &err), &err);
    dtx_similarity_apply(R, t, s, moved.V, moved.nv);
    CHECK_OK(dtx_bh_plan_create(&m, &moved, kr.keys, kr.keys, kr.count, NULL, NF, X, &plan2, &err),
             &err);
    if (plan2) {
        CHECK_OK(dtx_bh_apply(plan2, NF, X, Z, NULL, &err), &err);
        dtx_similarity_apply(R, t, s, Y, NF * m.nv);
        for (int64_t i = 0; i < (int64_t)NF * 3 * m.nv; i++)
            dmax = fabs(Y[i] - Z[i]) > dmax ? fabs(Y[i] - Z[i]) : dmax;
        printf("capsule onto a moved copy: max difference from the moved result %.3g of the "
               "diagonal\n", dmax / (s * diag));
        CHECK_DBL(dmax / (s * diag), <=, 1e-9);
    }

    /* Bad key points. */
    {
        int32_t bad[2] = {0, 0}, out[1] = {m.nv};
        dtx_bh_plan *q = NULL;
        CHECK_INT(dtx_bh_plan_create(&m, &m, bad, bad, 2, NULL, 0, NULL, &q, &err), ==,
                  DTX_EINVAL);
        CHECK(strstr(err.msg, "same vertex 0") != NULL);
        CHECK_INT(dtx_bh_plan_create(&m, &m, out, out, 1, NULL, 0, NULL, &q, &err), ==,
                  DTX_ERANGE);
        CHECK(strstr(err.msg, "out of range") != NULL);
        CHECK(q == NULL);
    }
done:
    dtx_bh_plan_free(&plan);
    dtx_bh_plan_free(&plan2);
    dtx_kp_result_free(&kr);
    dtx_mesh_free(&m);
    dtx_mesh_free(&moved);
    free(X);
    free(Y);
    free(Y2);
    free(Z);
    free(res);
}

static dtx_status load(const char *rel, dtx_mesh *m, dtx_error *err)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", DATA, rel);
    return dtx_obj_read(path, m, NULL, err);
}

static void test_cat_lion(void)
{
    enum { NP = 9 };
    dtx_mesh cat = {0}, lion = {0}, pose = {0};
    dtx_markers mk = {0};
    dtx_error err;
    dtx_bh_plan *plan = NULL;
    dtx_bh_info info;
    double *X = NULL, *Y = NULL, diag, mean = 0, worst = 0, t0;
    char rel[64];
    if (load("source/cat-reference.obj", &cat, &err) != DTX_OK ||
        load("target/lion-reference.obj", &lion, &err) != DTX_OK ||
        dtx_markers_read_csv(DATA "/markers.csv", 0, &mk, &err) != DTX_OK) {
        CHECK_OK(err.code, &err);
        goto done;
    }
    X = malloc(sizeof *X * NP * 3 * (size_t)cat.nv);
    Y = malloc(sizeof *Y * NP * 3 * (size_t)lion.nv);
    for (int f = 0; f < NP; f++) {
        snprintf(rel, sizeof rel, "source/cat-%02d.obj", f + 1);
        CHECK_OK(load(rel, &pose, &err), &err);
        if (pose.nv == cat.nv)
            memcpy(X + (size_t)f * 3 * cat.nv, pose.V, sizeof *X * 3 * (size_t)cat.nv);
        dtx_mesh_free(&pose);
    }
    t0 = omp_get_wtime();
    CHECK_OK(dtx_bh_plan_create(&cat, &lion, mk.src, mk.tgt, mk.n, NULL, NP, X, &plan, &err),
             &err);
    if (!plan)
        goto done;
    dtx_bh_plan_info(plan, &info);
    printf("cat -> lion, %d markers as key points: plan %.2f s (weights %.2f s), %d clusters, "
           "alignment scale %.3f, key points %.2f%% apart after alignment\n",
           (int)info.keys, omp_get_wtime() - t0, info.weights_seconds, (int)info.clusters,
           info.align_scale, 100 * info.align_rms);
    t0 = omp_get_wtime();
    CHECK_OK(dtx_bh_apply(plan, NP, X, Y, NULL, &err), &err);
    printf("cat -> lion: %.3f s per frame\n", (omp_get_wtime() - t0) / NP);
    diag = dtx_bbox_diagonal(lion.V, lion.nv);
    printf("cat -> lion, RMS distance to the paper's results (%% of the diagonal):");
    for (int f = 0; f < NP; f++) {
        double r;
        snprintf(rel, sizeof rel, "paper-results/lion-%02d.obj", f + 1);
        CHECK_OK(load(rel, &pose, &err), &err);
        if (pose.nv != lion.nv) {
            dtx_mesh_free(&pose);
            continue;
        }
        r = rms_centered(Y + (size_t)f * 3 * lion.nv, pose.V, lion.nv, diag);
        printf(" %.3f", 100 * r);
        mean += r / NP;
        worst = r > worst ? r : worst;
        dtx_mesh_free(&pose);
    }
    printf("; mean %.3f%%, worst %.3f%%\n", 100 * mean, 100 * worst);
    CHECK_DBL(worst, <=, 0.05);
done:
    dtx_bh_plan_free(&plan);
    dtx_markers_free(&mk);
    dtx_mesh_free(&cat);
    dtx_mesh_free(&lion);
    free(X);
    free(Y);
}

int main(void)
{
    test_capsule();
    test_cat_lion();
    return check_report();
}
