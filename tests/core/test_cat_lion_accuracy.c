/*
 * test_cat_lion_accuracy.c: sp04 on Sumner's cat -> lion with the shared
 * markers, against the paper's own results (paper-results/lion-0k.obj).
 * Per pose: RMS vertex distance after removing the mean translation,
 * divided by the lion's bounding-box diagonal.  Asserts a mean <= 0.85%
 * and a worst pose <= 1.5%: today's defaults give 0.834% and 1.437%, the
 * best public implementation 0.96% and 1.62%, so a change that loses what
 * the correspondence's choices won (README "Accuracy: cat -> lion") fails here.
 * Uses the bundled data unpacked into the build tree (tests' data.unpack).
 */
#include "check.h"
#include "dtx_core.h"
#include "meshfile.h"

#include <stdlib.h>
#include <string.h>

#define DATA DTX_BUILD "/data/sumner-cat-lion"

static dtx_status load(const char *rel, dtx_mesh *m, dtx_error *err)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", DATA, rel);
    return dtx_obj_read(path, m, NULL, err);
}

int main(void)
{
    dtx_mesh cat, lion, pose;
    dtx_markers mk;
    dtx_corr corr;
    dtx_corr_params prm;
    dtx_sp04_plan *plan = NULL;
    dtx_error err;
    double *Xs, *Xt, res[9], diag, sum = 0.0, worst = 0.0;
    char rel[64];

    CHECK_OK(load("source/cat-reference.obj", &cat, &err), &err);
    CHECK_OK(load("target/lion-reference.obj", &lion, &err), &err);
    CHECK_OK(dtx_markers_read_csv(DATA "/markers.csv", 0, &mk, &err), &err);
    if (check_failed_)
        return check_report();
    CHECK_EQ_INT(cat.nv, 7207);
    CHECK_EQ_INT(lion.nv, 5000);
    CHECK_EQ_INT(mk.n, 55);

    dtx_corr_params_default(&prm);
    CHECK_OK(dtx_sp04_correspond(&cat, &lion, &mk, &prm, &corr, &err), &err);
    printf("correspondence: %lld pairs, fit RMS %.3g of the diagonal, %d solves, %d "
           "factorisations\n",
           (long long)corr.npairs, corr.fit_rms, corr.solves, corr.factorizations);
    CHECK_OK(dtx_sp04_plan_create(&cat, &lion, corr.pairs, corr.npairs, DTX_ANCHOR_FIXED, NULL,
                                  NULL, 0, &plan, &err),
             &err);
    Xs = malloc(sizeof(double) * 3 * cat.nv * 9);
    Xt = malloc(sizeof(double) * 3 * lion.nv * 9);
    for (int k = 1; k <= 9; k++) {
        snprintf(rel, sizeof rel, "source/cat-%02d.obj", k);
        CHECK_OK(load(rel, &pose, &err), &err);
        memcpy(Xs + (size_t)(k - 1) * 3 * cat.nv, pose.V, sizeof(double) * 3 * cat.nv);
        dtx_mesh_free(&pose);
    }
    CHECK_OK(dtx_sp04_apply(plan, 9, Xs, Xt, res, &err), &err);
    diag = dtx_bbox_diagonal(lion.V, lion.nv);
    printf("pose  RMS/diagonal  residual\n");
    for (int k = 1; k <= 9; k++) {
        double *x = Xt + (size_t)(k - 1) * 3 * lion.nv, ma[3] = {0, 0, 0}, mb[3] = {0, 0, 0},
               s2 = 0.0, r;
        snprintf(rel, sizeof rel, "paper-results/lion-%02d.obj", k);
        CHECK_OK(load(rel, &pose, &err), &err);
        CHECK_EQ_INT(pose.nv, lion.nv);
        for (int32_t v = 0; v < lion.nv; v++)
            for (int j = 0; j < 3; j++) {
                ma[j] += x[3 * v + j] / lion.nv;
                mb[j] += pose.V[3 * v + j] / lion.nv;
            }
        for (int32_t v = 0; v < lion.nv; v++)
            for (int j = 0; j < 3; j++) {
                double d = (x[3 * v + j] - ma[j]) - (pose.V[3 * v + j] - mb[j]);
                s2 += d * d;
            }
        r = 100.0 * sqrt(s2 / lion.nv) / diag;
        sum += r;
        worst = r > worst ? r : worst;
        printf("%4d  %10.3f%%  %9.4f\n", k, r, res[k - 1]);
        dtx_mesh_free(&pose);
    }
    printf("mean %.3f%%, worst %.3f%% (best public implementation: mean 0.96%%, worst 1.62%%)\n",
           sum / 9, worst);
    CHECK_DBL(sum / 9, <=, 0.85);
    CHECK_DBL(worst, <=, 1.5);

    free(Xs);
    free(Xt);
    dtx_sp04_plan_free(&plan);
    dtx_corr_free(&corr);
    dtx_markers_free(&mk);
    dtx_mesh_free(&cat);
    dtx_mesh_free(&lion);
    return check_report();
}
