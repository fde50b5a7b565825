/* test_h5keypoints.c: key-point groups of the HDF5 layout (/keypoints/NAME):
 * a round trip of every member and attribute, `dtx validate` accepting
 * them and the file, its range check against the source mesh in the same
 * file, its float attribute check, and the reader rejecting malformed
 * groups (missing members, mismatched lengths, negative vertices, parallel
 * files refused by the writer's argument checks). */
#include "check.h"
#include "h5check.h"
#include "h5layout.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#define SCRATCH DTX_TEST_SCRATCH "/"

/* A tetrahedron as the source mesh. */
static void write_tet(hid_t f)
{
    static const double V[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    static const int32_t F[12] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
    dtx_mesh m = {0};
    dtx_error e;
    CHECK_OK(dtx_mesh_alloc(&m, 4, 4, &e), &e);
    memcpy(m.V, V, sizeof V);
    memcpy(m.F, F, sizeof F);
    CHECK_OK(dtx_h5_write_mesh(f, "/meshes/tet", &m, "tet.obj", &e), &e);
    dtx_mesh_free(&m);
}

/* Three key points of the tetrahedron (vertices as given). */
static void fill(dtx_h5_keypoints *kp, int32_t *vertex, double *pos, char **label, double *error)
{
    memset(kp, 0, sizeof *kp);
    kp->n = 3;
    kp->vertex = vertex;
    kp->position = pos;
    kp->label = label;
    kp->nerror = 4;
    kp->error = error;
    kp->source_mesh = "/meshes/tet";
    kp->source_sequences = "/sequences/a, /sequences/b";
    kp->candidates = 4;
    kp->eps = 0.03;
    kp->final_error = error[3];
}

static void validate(const char *path, int want_ok, const char *want)
{
    char *report = NULL;
    dtx_error e;
    dtx_status st = dtx_h5_validate(path, &report, &e);
    if (want_ok) {
        CHECK_OK(st, &e);
    } else {
        CHECK_EQ_INT(st, DTX_EFORMAT);
        CHECK(check_contains(report, want));
    }
    if ((want_ok && st != DTX_OK) || (!want_ok && st == DTX_OK))
        fprintf(stderr, "%s", report ? report : "(no report)\n");
    free(report);
}

static void test_round_trip(void)
{
    int32_t vertex[3] = {3, 0, 2};
    double pos[9] = {0, 0, 1, 0, 0, 0, 0, 1, 0}, error[4] = {0.2, 0.1, 0.05, 0.04};
    char l0[] = "left ear", l1[] = "", l2[] = "tail", *label[3] = {l0, l1, l2};
    dtx_h5_keypoints kp, r;
    dtx_error e;
    hid_t f = h5check_new_file(SCRATCH "kp.h5");
    write_tet(f);
    fill(&kp, vertex, pos, label, error);
    CHECK_OK(dtx_h5_write_keypoints(f, "/keypoints/tet", &kp, &e), &e);
    CHECK_EQ_INT(dtx_h5_path_exists(f, "/keypoints/.dtx-tmp-tet"), 0);
    CHECK_OK(dtx_h5_read_keypoints(f, "/keypoints/tet", &r, &e), &e);
    CHECK_EQ_INT(r.n, 3);
    CHECK_EQ_INT(r.nerror, 4);
    for (int i = 0; i < 3 && r.n == 3; i++) {
        CHECK_EQ_INT(r.vertex[i], vertex[i]);
        for (int k = 0; k < 3; k++)
            CHECK_DBL(r.position[3 * i + k], ==, pos[3 * i + k]);
        CHECK(strcmp(r.label[i], label[i]) == 0);
    }
    for (int i = 0; i < 4 && r.nerror == 4; i++)
        CHECK_DBL(r.error[i], ==, error[i]);
    CHECK(r.source_mesh && strcmp(r.source_mesh, "/meshes/tet") == 0);
    CHECK(r.source_sequences && strcmp(r.source_sequences, "/sequences/a, /sequences/b") == 0);
    CHECK_EQ_INT(r.candidates, 4);
    CHECK_DBL(r.eps, ==, 0.03);
    CHECK_DBL(r.final_error, ==, 0.04);
    CHECK(r.dtx_version && r.dtx_version[0]);
    dtx_h5_keypoints_free(&r);
    CHECK(r.vertex == NULL && r.n == 0);
    dtx_h5_keypoints_free(NULL);

    /* No labels given: stored as "". */
    kp.label = NULL;
    CHECK_OK(dtx_h5_write_keypoints(f, "/keypoints/nolabel", &kp, &e), &e);
    CHECK_OK(dtx_h5_read_keypoints(f, "/keypoints/nolabel", &r, &e), &e);
    CHECK(r.n == 3 && r.label && strcmp(r.label[0], "") == 0);
    dtx_h5_keypoints_free(&r);

    /* Not over an existing group; not empty. */
    CHECK_EQ_INT(dtx_h5_write_keypoints(f, "/keypoints/tet", &kp, &e), DTX_EINVAL);
    CHECK(check_contains(e.msg, "/keypoints/tet: already exists"));
    kp.n = 0;
    CHECK_EQ_INT(dtx_h5_write_keypoints(f, "/keypoints/none", &kp, &e), DTX_EINVAL);
    CHECK(check_contains(e.msg, "at least one point"));
    CHECK_EQ_INT(dtx_h5_read_keypoints(f, "/keypoints/missing", &r, &e), DTX_EFORMAT);
    CHECK(check_contains(e.msg, "/keypoints/missing: missing"));
    CHECK(r.vertex == NULL);
    dtx_h5_close(&f, NULL);
    validate(SCRATCH "kp.h5", 1, NULL);
}

/* Malformed groups: the reader names the member, the validator reports. */
static void test_bad(void)
{
    int32_t vertex[3] = {3, 0, 9};
    double pos[9] = {0, 0, 1, 0, 0, 0, 0, 1, 0}, error[4] = {0.2, 0.1, 0.05, 0.04};
    dtx_h5_keypoints kp, r;
    dtx_error e;
    hid_t f = h5check_new_file(SCRATCH "bad.h5");
    write_tet(f);
    fill(&kp, vertex, pos, NULL, error);
    /* Vertex 9 of a 4-vertex source: readable, the validator objects. */
    CHECK_OK(dtx_h5_write_keypoints(f, "/keypoints/range", &kp, &e), &e);
    dtx_h5_close(&f, NULL);
    validate(SCRATCH "bad.h5", 0, "/keypoints/range/vertex");

    f = h5check_new_file(SCRATCH "bad2.h5");
    write_tet(f);
    vertex[2] = -1;
    CHECK_OK(dtx_h5_write_keypoints(f, "/keypoints/neg", &kp, &e), &e);
    CHECK_EQ_INT(dtx_h5_read_keypoints(f, "/keypoints/neg", &r, &e), DTX_ERANGE);
    CHECK(check_contains(e.msg, "/keypoints/neg/vertex: entry 2 is -1"));
    vertex[2] = 2;
    CHECK_OK(dtx_h5_write_keypoints(f, "/keypoints/nopos", &kp, &e), &e);
    CHECK_OK(dtx_h5_remove(f, "/keypoints/nopos/position", &e), &e);
    CHECK_EQ_INT(dtx_h5_read_keypoints(f, "/keypoints/nopos", &r, &e), DTX_EFORMAT);
    CHECK(check_contains(e.msg, "/keypoints/nopos/position: missing"));
    /* A non-finite error value, and eps stored as a string. */
    error[1] = NAN;
    CHECK_OK(dtx_h5_write_keypoints(f, "/keypoints/nan", &kp, &e), &e);
    CHECK_EQ_INT(dtx_h5_read_keypoints(f, "/keypoints/nan", &r, &e), DTX_ENONFINITE);
    CHECK(check_contains(e.msg, "/keypoints/nan/error: value 1 is not finite"));
    error[1] = 0.1;
    CHECK_OK(dtx_h5_write_keypoints(f, "/keypoints/streps", &kp, &e), &e);
    CHECK_OK(dtx_h5_write_attr_str(f, "/keypoints/streps", "eps", "0.03", &e), &e);
    CHECK_EQ_INT(dtx_h5_read_keypoints(f, "/keypoints/streps", &r, &e), DTX_EFORMAT);
    CHECK(check_contains(e.msg, "attribute eps: expected a float"));
    dtx_h5_close(&f, NULL);
    validate(SCRATCH "bad2.h5", 0, "attribute eps: expected a single floating-point value");
}

int main(void)
{
    dtx_h5_init();
    test_round_trip();
    test_bad();
    return check_report();
}
