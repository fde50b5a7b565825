/* test_frame_normals.c: per-frame normals that keep the asset's smoothing
 * (core/frame_normals.c): a cube with hard edges (a normal per face) keeps
 * them, rotated with the frame; a smooth per-vertex indexing is kept as
 * is; twins split along a seam get one normal; a degenerate frame falls
 * back to the asset's normal. */
#include "check.h"
#include "frame_normals.h"

#include <math.h>
#include <string.h>

/* Unit cube, 8 vertices, 12 triangles (outward, counter-clockwise). */
static const double CV[24] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0,
                              0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1};
static const int32_t CF[36] = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                               2, 3, 7, 2, 7, 6, 1, 2, 6, 1, 6, 5, 0, 4, 7, 0, 7, 3};
static const double FACE_N[18] = {0, 0, -1, 0, 0, 1, 0, -1, 0, 0, 1, 0, 1, 0, 0, -1, 0, 0};

static void test_hard_edges(void)
{
    /* Flat shading: face pair s uses normal s. */
    int32_t nf[36];
    dtx_frame_normals p;
    dtx_error e;
    double X[24], N[3 * 48];
    for (int c = 0; c < 36; c++)
        nf[c] = c / 6;
    CHECK_OK(dtx_frame_normals_plan(CV, 8, CF, 12, FACE_N, 6, nf, &p, &e), &e);
    CHECK_EQ_INT(p.nout, 24); /* 8 corners x 3 sides */
    CHECK_EQ_INT(p.ngroup, 24);
    CHECK_EQ_INT(p.start[p.ngroup], 36); /* one entry per face corner: no k^2 lists */
    /* Rotate 90 degrees about z: (x, y, z) -> (-y, x, z). */
    for (int i = 0; i < 8; i++) {
        X[3 * i] = -CV[3 * i + 1];
        X[3 * i + 1] = CV[3 * i];
        X[3 * i + 2] = CV[3 * i + 2];
    }
    dtx_frame_normals_apply(&p, X, NULL, CF, N);
    for (int c = 0; c < 36; c++) {
        const double *n = N + 3 * p.out_faces[c], *r = FACE_N + 3 * (c / 6);
        CHECK_NEAR(n[0], -r[1], 1e-15);
        CHECK_NEAR(n[1], r[0], 1e-15);
        CHECK_NEAR(n[2], r[2], 1e-15);
    }
    dtx_frame_normals_free(&p);
}

static void test_smooth_and_twins(void)
{
    /* Smooth per-vertex normals (normal_faces == faces): the indexing is
     * kept.  Then vertex 0 split into a twin 8 for the faces of the -z
     * side (a UV seam), with the same normal: both get one normal. */
    double V[27], Nrest[27], N1[27], N2[27];
    int32_t F[36];
    dtx_frame_normals p;
    dtx_error e;
    memcpy(V, CV, sizeof CV);
    memcpy(F, CF, sizeof CF);
    for (int i = 0; i < 8; i++)
        for (int k = 0; k < 3; k++)
            Nrest[3 * i + k] = CV[3 * i + k] - 0.5;
    CHECK_OK(dtx_frame_normals_plan(V, 8, F, 12, Nrest, 8, F, &p, &e), &e);
    CHECK_EQ_INT(p.nout, 8);
    CHECK(memcmp(p.out_faces, F, sizeof F) == 0);
    dtx_frame_normals_apply(&p, V, NULL, F, N1);
    dtx_frame_normals_free(&p);
    /* Unit normals pointing out of the corner: vertex 6 = (1,1,1) has 2
     * triangles on +x, 1 on +y and 2 on +z around it (area-weighted sum
     * (1/2)(2, 1, 2)), vertex 0 has 2, 2, 2 on -x, -y, -z. */
    CHECK_NEAR(N1[3 * 6], 2.0 / 3.0, 1e-15);
    CHECK_NEAR(N1[3 * 6 + 1], 1.0 / 3.0, 1e-15);
    CHECK_NEAR(N1[3 * 6 + 2], 2.0 / 3.0, 1e-15);
    CHECK_NEAR(N1[3 * 0 + 2], -1 / sqrt(3.0), 1e-15);

    memcpy(V + 24, V, 3 * sizeof *V);
    memcpy(Nrest + 24, Nrest, 3 * sizeof *Nrest);
    F[0] = F[3] = 8;
    CHECK_OK(dtx_frame_normals_plan(V, 9, F, 12, Nrest, 9, F, &p, &e), &e);
    CHECK_EQ_INT(p.nout, 9);
    dtx_frame_normals_apply(&p, V, NULL, F, N2);
    for (int k = 0; k < 3; k++) {
        CHECK_NEAR(N2[3 * 8 + k], N2[k], 0);
        CHECK_NEAR(N2[k], N1[k], 1e-15);
    }
    dtx_frame_normals_free(&p);
}

static void test_degenerate(void)
{
    /* Every vertex at the origin: the asset's (normalised) normal. */
    double X[24] = {0}, N[24];
    float Xf[24] = {0};
    double Nrest[24];
    dtx_frame_normals p;
    dtx_error e;
    for (int i = 0; i < 24; i++)
        Nrest[i] = 2.0 * (CV[i] - 0.5);
    CHECK_OK(dtx_frame_normals_plan(CV, 8, CF, 12, Nrest, 8, CF, &p, &e), &e);
    dtx_frame_normals_apply(&p, X, NULL, CF, N);
    CHECK_NEAR(N[18], 1 / sqrt(3.0), 1e-15);
    dtx_frame_normals_apply(&p, NULL, Xf, CF, N);
    CHECK_NEAR(N[20], 1 / sqrt(3.0), 1e-15);
    dtx_frame_normals_free(&p);
}

int main(void)
{
    test_hard_edges();
    test_smooth_and_twins();
    test_degenerate();
    return check_report();
}
