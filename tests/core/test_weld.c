/* test_weld.c: the weld map of seam-split vertices (core/weld.h). */
#include "check.h"
#include "weld.h"

#include <string.h>

/* A mesh with no twins maps to itself. */
static void identity_on_welded(void)
{
    double V[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    int32_t map[4], rep[4], nw = -1;
    CHECK_EQ_INT(dtx_weld_map(V, 4, 0, map, rep, &nw, NULL), DTX_OK);
    CHECK_EQ_INT(nw, 4);
    for (int i = 0; i < 4; i++) {
        CHECK_EQ_INT(map[i], i);
        CHECK_EQ_INT(rep[i], i);
    }
}

/* Twins map to one welded vertex, numbered by the lowest original index;
 * the welded vertex order follows the first occurrence. */
static void twins_and_order(void)
{
    /* 0:A 1:B 2:A 3:C 4:B 5:A(-0) */
    double V[18] = {1, 2, 3, 4, 5, 6, 1, 2, 3, 7, 8, 9, 4, 5, 6, 1, 2, 3};
    int32_t map[6], rep[6], nw = -1, want_map[6] = {0, 1, 0, 2, 1, 0}, want_rep[3] = {0, 1, 3};
    CHECK_EQ_INT(dtx_weld_map(V, 6, 0, map, rep, &nw, NULL), DTX_OK);
    CHECK_EQ_INT(nw, 3);
    for (int i = 0; i < 6; i++)
        CHECK_EQ_INT(map[i], want_map[i]);
    for (int w = 0; w < 3; w++)
        CHECK_EQ_INT(rep[w], want_rep[w]);
    /* -0 and +0 are the same position. */
    {
        double Z[6] = {0.0, 1, 1, -0.0, 1, 1};
        CHECK_EQ_INT(dtx_weld_map(Z, 2, 0, map, rep, &nw, NULL), DTX_OK);
        CHECK_EQ_INT(nw, 1);
    }
}

/* Exact by default: a vertex 1e-12 away is not a twin; with a tolerance it
 * is, and chains within tolerance join (the classes are transitive). */
static void tolerance(void)
{
    double V[12] = {0, 0, 0, 1e-12, 0, 0, 2e-12, 0, 0, 5, 0, 0};
    int32_t map[4], rep[4], nw = -1;
    CHECK_EQ_INT(dtx_weld_map(V, 4, 0, map, rep, &nw, NULL), DTX_OK);
    CHECK_EQ_INT(nw, 4);
    CHECK_EQ_INT(dtx_weld_map(V, 4, 1.5e-12, map, rep, &nw, NULL), DTX_OK);
    CHECK_EQ_INT(nw, 2);
    CHECK_EQ_INT(map[2], 0);
    CHECK_EQ_INT(map[3], 1);
    /* Bad tolerances and non-finite vertices. */
    CHECK_EQ_INT(dtx_weld_map(V, 4, -1, map, rep, &nw, NULL), DTX_EINVAL);
    CHECK_EQ_INT(dtx_weld_map(V, 4, NAN, map, rep, &nw, NULL), DTX_EINVAL);
    {
        double W[6] = {NAN, 0, 0, NAN, 0, 0};
        CHECK_EQ_INT(dtx_weld_map(W, 2, 0, map, rep, &nw, NULL), DTX_OK);
        CHECK_EQ_INT(nw, 2);
    }
}

/* Welding a split square (two triangles with the diagonal duplicated) gives
 * the shared-vertex square; compact then expand round-trips the frames and
 * makes twins identical. */
static void apply_compact_expand(void)
{
    /* 0 1 2 | 3(=0) 4(=2) 5 */
    double V[18] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 0, 0, 1, 1, 0, 0, 1, 0};
    int32_t F[6] = {0, 1, 2, 3, 4, 5}, map[6], rep[6], nw = 0, Fw[6];
    double Vw[18], X[2 * 18];
    CHECK_EQ_INT(dtx_weld_map(V, 6, 0, map, rep, &nw, NULL), DTX_OK);
    CHECK_EQ_INT(nw, 4);
    dtx_weld_apply(V, F, 2, map, rep, nw, Vw, Fw);
    CHECK_EQ_INT(Fw[3], 0);
    CHECK_EQ_INT(Fw[4], 2);
    CHECK_EQ_INT(Fw[5], 3);
    CHECK(memcmp(Vw + 9, V + 15, 3 * sizeof *V) == 0);
    /* Two frames of the asset, the second with the twin of vertex 0 moved
     * (a torn seam: compaction keeps the lowest index's position). */
    memcpy(X, V, sizeof V);
    memcpy(X + 18, V, sizeof V);
    X[18 + 9] = 42;
    dtx_weld_compact_frames(X, 2, 6, rep, nw);
    CHECK(memcmp(X, Vw, 12 * sizeof *X) == 0);
    CHECK(memcmp(X + 12, Vw, 12 * sizeof *X) == 0);
    X[12] = 7; /* frame 1, welded vertex 0 */
    dtx_weld_expand_frames(X, 2, nw, map, 6);
    CHECK(memcmp(X, V, sizeof V) == 0);
    CHECK_DBL(X[18 + 0], ==, 7);
    CHECK_DBL(X[18 + 9], ==, 7);
    CHECK(memcmp(X + 18 + 3, V + 3, 6 * sizeof *X) == 0);
}

int main(void)
{
    identity_on_welded();
    twins_and_order();
    tolerance();
    apply_compact_expand();
    return check_report();
}
