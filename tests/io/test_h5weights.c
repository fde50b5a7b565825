/* test_h5weights.c: weight groups of the HDF5 layout (/weights/NAME, the
 * cache of method biharmonic's bounded biharmonic weights): a round trip of
 * every member and attribute, lookup by key (temporaries and other keys
 * skipped), `dtx validate` accepting the file and reporting a handle out of
 * range, and the reader rejecting malformed groups (missing members, shapes
 * that disagree, a vertex count other than the caller's, handles out of
 * range, weights outside [0, 1] or NaN) with the member named. */
#include "check.h"
#include "h5check.h"
#include "h5layout.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define SCRATCH DTX_TEST_SCRATCH "/"

/* Weights of 2 handles (vertices 3 and 0) on 4 vertices, rows summing to 1. */
static const int32_t H[2] = {3, 0};
static const double W[8] = {0, 1, 0.25, 0.75, 0.5, 0.5, 1, 0};

static void test_round_trip(void)
{
    dtx_h5_weights w;
    dtx_error e;
    char *g = NULL;
    hid_t f = h5check_new_file(SCRATCH "w.h5");
    CHECK_OK(dtx_h5_write_weights(f, "/weights/a", H, 2, W, 4, "00000000000000aa", "x.h5:/m", &e),
             &e);
    CHECK_OK(dtx_h5_write_weights(f, "/weights/b", H, 2, W, 4, "00000000000000bb", "x.h5:/m", &e),
             &e);
    CHECK_EQ_INT(dtx_h5_path_exists(f, "/weights/.dtx-tmp-a"), 0);
    CHECK_OK(dtx_h5_read_weights(f, "/weights/b", 4, &w, &e), &e);
    CHECK_EQ_INT(w.m, 2);
    CHECK_EQ_INT(w.nv, 4);
    for (int k = 0; k < 2 && w.m == 2; k++)
        CHECK_EQ_INT(w.handles[k], H[k]);
    for (int i = 0; i < 8 && w.nv == 4; i++)
        CHECK_DBL(w.weights[i], ==, W[i]);
    CHECK(w.key && strcmp(w.key, "00000000000000bb") == 0);
    CHECK(w.mesh && strcmp(w.mesh, "x.h5:/m") == 0);
    CHECK(w.dtx_version && w.dtx_version[0]);
    dtx_h5_weights_free(&w);
    CHECK(w.weights == NULL && w.m == 0);
    dtx_h5_weights_free(NULL);

    /* Found by key; another key finds nothing. */
    CHECK_OK(dtx_h5_find_weights_by_key(f, "00000000000000bb", &g, &e), &e);
    CHECK(g && strcmp(g, "/weights/b") == 0);
    free(g);
    CHECK_OK(dtx_h5_find_weights_by_key(f, "00000000000000cc", &g, &e), &e);
    CHECK(g == NULL);

    /* Not over an existing group; not empty. */
    CHECK_EQ_INT(dtx_h5_write_weights(f, "/weights/a", H, 2, W, 4, "k", "m", &e), DTX_EINVAL);
    CHECK(check_contains(e.msg, "/weights/a: already exists"));
    CHECK_EQ_INT(dtx_h5_write_weights(f, "/weights/z", H, 0, W, 4, "k", "m", &e), DTX_EINVAL);
    CHECK(check_contains(e.msg, "0 handles"));
    CHECK_EQ_INT(dtx_h5_read_weights(f, "/weights/missing", 4, &w, &e), DTX_EFORMAT);
    CHECK(check_contains(e.msg, "/weights/missing: missing"));
    dtx_h5_close(&f, NULL);

    /* A file without /weights: no match, no error. */
    f = h5check_new_file(SCRATCH "none.h5");
    CHECK_OK(dtx_h5_find_weights_by_key(f, "00000000000000bb", &g, &e), &e);
    CHECK(g == NULL);
    dtx_h5_close(&f, NULL);
    {
        char *report = NULL;
        CHECK_OK(dtx_h5_validate(SCRATCH "w.h5", &report, &e), &e);
        free(report);
    }
}

static void bad_read(hid_t f, const char *group, int32_t nv, dtx_status want, const char *msg)
{
    dtx_h5_weights w;
    dtx_error e;
    CHECK_EQ_INT(dtx_h5_read_weights(f, group, nv, &w, &e), want);
    CHECK(check_contains(e.msg, msg));
    CHECK(w.weights == NULL && w.handles == NULL);
}

static void test_bad(void)
{
    int32_t h[2] = {3, 0};
    double v[8];
    dtx_error e;
    char *report = NULL;
    hid_t f = h5check_new_file(SCRATCH "bad.h5");
    memcpy(v, W, sizeof v);
    CHECK_OK(dtx_h5_write_weights(f, "/weights/ok", h, 2, v, 4, "k", "m", &e), &e);
    bad_read(f, "/weights/ok", 5, DTX_EFORMAT, "/weights/ok/weights: is 4 x 2, expected 5 x 2");
    h[0] = 4;
    CHECK_OK(dtx_h5_write_weights(f, "/weights/range", h, 2, v, 4, "k", "m", &e), &e);
    bad_read(f, "/weights/range", 4, DTX_ERANGE, "/weights/range/handles: handle 0 is vertex 4");
    h[0] = 3;
    v[3] = 1.5;
    CHECK_OK(dtx_h5_write_weights(f, "/weights/big", h, 2, v, 4, "k", "m", &e), &e);
    bad_read(f, "/weights/big", -1, DTX_ERANGE, "vertex 1, handle 1: weight 1.5 is not in [0, 1]");
    v[3] = NAN;
    CHECK_OK(dtx_h5_write_weights(f, "/weights/nan", h, 2, v, 4, "k", "m", &e), &e);
    bad_read(f, "/weights/nan", -1, DTX_ERANGE, "vertex 1, handle 1: weight nan is not in [0, 1]");
    v[3] = 0.75;
    /* 3 handles against 2 weight columns; a missing member. */
    CHECK_OK(dtx_h5_write_weights(f, "/weights/cols", h, 2, v, 4, "k", "m", &e), &e);
    CHECK_OK(dtx_h5_remove(f, "/weights/cols/handles", &e), &e);
    bad_read(f, "/weights/cols", -1, DTX_EFORMAT, "/weights/cols/handles: missing");
    {
        static const int32_t h3[3] = {0, 1, 2};
        static const double w6[6] = {1, 0, 0, 0, 1, 0};
        CHECK_OK(dtx_h5_write_weights(f, "/weights/shape", h3, 3, w6, 2, "k", "m", &e), &e);
        CHECK_OK(dtx_h5_remove(f, "/weights/shape/weights", &e), &e);
        CHECK_OK(dtx_h5_write_weights(f, "/weights/two", h, 2, v, 4, "k", "m", &e), &e);
        /* Put a 4 x 2 weights dataset beside 3 handles by moving one in. */
        CHECK(H5Lmove(f, "/weights/two/weights", f, "/weights/shape/weights", H5P_DEFAULT,
                      H5P_DEFAULT) >= 0);
        bad_read(f, "/weights/shape", -1, DTX_EFORMAT,
                 "/weights/shape/weights: is 4 x 2, expected one column per handle (3)");
    }
    dtx_h5_close(&f, NULL);
    /* The validator reports the handle out of range. */
    CHECK_EQ_INT(dtx_h5_validate(SCRATCH "bad.h5", &report, &e), DTX_EFORMAT);
    CHECK(check_contains(report, "/weights/range/handles"));
    free(report);
}

int main(void)
{
    dtx_h5_init();
    test_round_trip();
    test_bad();
    return check_report();
}
