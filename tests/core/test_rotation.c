/*
 * test_rotation.c: turning the source, its poses and the target together by
 * a rotation R (and moving them by t) turns the result by the same R: the
 * correspondence and the sp04 transfer of Sumner's cat -> lion (two poses)
 * agree with R x + t of the unturned result to 1e-9 of the lion's size, in
 * both anchor modes ("fixed" and "follow").  The rotations are chosen so
 * that the lion's bounding-box diagonal changes (by more than 2%): the box
 * is not rotation-invariant, and before dtx_rms_extent the correspondence
 * normalised by it, which moved results by up to 0.4% of the diagonal.
 * Uses the bundled data unpacked into the build tree (tests' data.unpack).
 */
#include "check.h"
#include "dtx_core.h"
#include "meshfile.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define DATA DTX_BUILD "/data/sumner-cat-lion"
#define NPOSES 2

static dtx_status load(const char *rel, dtx_mesh *m, dtx_error *err)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", DATA, rel);
    return dtx_obj_read(path, m, NULL, err);
}

/* R: the rotation by angle a about the unit axis u (Rodrigues). */
static void rotation(const double u0[3], double a, double R[9])
{
    double n = sqrt(u0[0] * u0[0] + u0[1] * u0[1] + u0[2] * u0[2]);
    double u[3] = {u0[0] / n, u0[1] / n, u0[2] / n}, c = cos(a), s = sin(a);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            R[3 * i + j] = (i == j ? c : 0.0) + (1 - c) * u[i] * u[j];
    R[1] -= s * u[2];
    R[2] += s * u[1];
    R[3] += s * u[2];
    R[5] -= s * u[0];
    R[6] -= s * u[1];
    R[7] += s * u[0];
}

/* Y = R X + t for n points (Y may be X). */
static void turn(const double R[9], const double t[3], const double *X, int32_t n, double *Y)
{
    for (int32_t i = 0; i < n; i++) {
        double x[3] = {X[3 * (size_t)i], X[3 * (size_t)i + 1], X[3 * (size_t)i + 2]};
        for (int r = 0; r < 3; r++)
            Y[3 * (size_t)i + r] = R[3 * r] * x[0] + R[3 * r + 1] * x[1] + R[3 * r + 2] * x[2] + t[r];
    }
}

/* The sp04 transfer of the poses Xs (NPOSES frames of src) onto tgt into Xt,
 * through a correspondence computed here. */
static dtx_status transfer(const dtx_mesh *src, const dtx_mesh *tgt, const dtx_markers *mk,
                           dtx_anchor anchor, const double *Xs, double *Xt, dtx_error *err)
{
    dtx_corr corr;
    dtx_corr_params prm;
    dtx_sp04_plan *plan = NULL;
    double res[NPOSES];
    dtx_status st;
    dtx_corr_params_default(&prm);
    st = dtx_sp04_correspond(src, tgt, mk, &prm, &corr, err);
    if (st != DTX_OK)
        return st;
    st = dtx_sp04_plan_create(src, tgt, corr.pairs, corr.npairs, anchor, NULL, NULL, 0, &plan, err);
    if (st == DTX_OK)
        st = dtx_sp04_apply(plan, NPOSES, Xs, Xt, res, err);
    dtx_sp04_plan_free(&plan);
    dtx_corr_free(&corr);
    return st;
}

int main(void)
{
    dtx_mesh cat, lion, pose, rcat, rlion;
    dtx_markers mk;
    dtx_error err;
    double *Xs, *Xt, *RXs, *RXt, size;
    char rel[64];
    const double axes[2][3] = {{1, 2, 3}, {0, 1, 0}}, angles[2] = {0.7, 0.25 * 3.14159265358979};
    const double t[3] = {0.3, -1.7, 2.2};
    const dtx_anchor anchors[2] = {DTX_ANCHOR_FIXED, DTX_ANCHOR_FOLLOW};

    CHECK_OK(load("source/cat-reference.obj", &cat, &err), &err);
    CHECK_OK(load("target/lion-reference.obj", &lion, &err), &err);
    CHECK_OK(dtx_markers_read_csv(DATA "/markers.csv", 0, &mk, &err), &err);
    if (check_failed_)
        return check_report();
    Xs = malloc(sizeof(double) * 3 * cat.nv * NPOSES);
    RXs = malloc(sizeof(double) * 3 * cat.nv * NPOSES);
    Xt = malloc(sizeof(double) * 3 * lion.nv * NPOSES);
    RXt = malloc(sizeof(double) * 3 * lion.nv * NPOSES);
    for (int k = 0; k < NPOSES; k++) {
        snprintf(rel, sizeof rel, "source/cat-%02d.obj", 2 + 3 * k);
        CHECK_OK(load(rel, &pose, &err), &err);
        memcpy(Xs + (size_t)k * 3 * cat.nv, pose.V, sizeof(double) * 3 * cat.nv);
        dtx_mesh_free(&pose);
    }
    size = dtx_rms_extent(lion.V, lion.nv);
    printf("lion: size %.6g, bounding-box diagonal %.6g\n", size,
           dtx_bbox_diagonal(lion.V, lion.nv));

    for (int q = 0; q < 2; q++) {
        double R[9], worst = 0.0, d0, d1;
        dtx_anchor anchor = anchors[q];
        rotation(axes[q], angles[q], R);
        CHECK_OK(dtx_mesh_copy(&cat, &rcat, &err), &err);
        CHECK_OK(dtx_mesh_copy(&lion, &rlion, &err), &err);
        if (check_failed_)
            break;
        turn(R, t, cat.V, cat.nv, rcat.V);
        turn(R, t, lion.V, lion.nv, rlion.V);
        turn(R, t, Xs, cat.nv * NPOSES, RXs);
        /* The rotation must change the box, or this test could not tell a
         * box-based size from an invariant one. */
        d0 = dtx_bbox_diagonal(lion.V, lion.nv);
        d1 = dtx_bbox_diagonal(rlion.V, rlion.nv);
        printf("rotation %d: lion's bounding-box diagonal %.6g -> %.6g (%+.1f%%)\n", q, d0, d1,
               100.0 * (d1 - d0) / d0);
        CHECK_DBL(fabs(d1 - d0) / d0, >, 0.02);
        CHECK_NEAR(dtx_rms_extent(rlion.V, rlion.nv) / size, 1.0, 1e-12);

        CHECK_OK(transfer(&cat, &lion, &mk, anchor, Xs, Xt, &err), &err);
        CHECK_OK(transfer(&rcat, &rlion, &mk, anchor, RXs, RXt, &err), &err);
        if (check_failed_)
            break;
        /* Turn the first result and compare. */
        turn(R, t, Xt, lion.nv * NPOSES, Xt);
        for (size_t i = 0; i < (size_t)3 * lion.nv * NPOSES; i++) {
            double d = fabs(Xt[i] - RXt[i]);
            worst = d > worst || d != d ? d : worst;
        }
        printf("rotation %d (anchor %s): largest difference from the turned result %.3g of the "
               "size\n",
               q, anchor == DTX_ANCHOR_FIXED ? "fixed" : "follow", worst / size);
        CHECK_DBL(worst / size, <=, 1e-9);
        dtx_mesh_free(&rcat);
        dtx_mesh_free(&rlion);
    }

    free(Xs);
    free(RXs);
    free(Xt);
    free(RXt);
    dtx_mesh_free(&cat);
    dtx_mesh_free(&lion);
    dtx_markers_free(&mk);
    return check_report();
}
