/* test_graph.c: union-find and mesh components (core/graph.h). */
#include "check.h"
#include "graph.h"

#include <string.h>

/* A union hangs the higher root under the lower whichever argument comes
 * first, and says whether it joined anything. */
static void unions(void)
{
    int32_t parent[6];
    dtx__uf_init(parent, 6);
    for (int32_t i = 0; i < 6; i++)
        CHECK_EQ_INT(parent[i], i);
    CHECK_EQ_INT(dtx__uf_union(parent, 4, 2), 1);
    CHECK_EQ_INT(parent[4], 2);
    CHECK_EQ_INT(parent[2], 2);
    CHECK_EQ_INT(dtx__uf_union(parent, 2, 4), 0);
    CHECK_EQ_INT(dtx__uf_union(parent, 4, 4), 0);
    CHECK_EQ_INT(dtx__uf_union(parent, 1, 5), 1);
    CHECK_EQ_INT(parent[5], 1);
    /* Joining two classes through non-roots: root 1 is lower than root 2. */
    CHECK_EQ_INT(dtx__uf_union(parent, 4, 5), 1);
    CHECK_EQ_INT(parent[2], 1);
    CHECK_EQ_INT(parent[1], 1);
    CHECK_EQ_INT(parent[0], 0);
    CHECK_EQ_INT(parent[3], 3);
}

/* find gives the lowest index of the class, halving paths as it goes
 * without changing any class. */
static void find_after_unions(void)
{
    enum { N = 9 };
    int32_t parent[N];
    dtx__uf_init(parent, N);
    /* A chain 8 -> 7 -> ... -> 1 built from the top, so the paths are long. */
    for (int32_t i = N - 1; i > 1; i--)
        CHECK_EQ_INT(dtx__uf_union(parent, i, i - 1), 1);
    CHECK_EQ_INT(parent[8], 7);
    CHECK_EQ_INT(dtx__uf_find(parent, 8), 1);
    CHECK(parent[8] < 7); /* the path from 8 was shortened */
    for (int32_t i = 1; i < N; i++)
        CHECK_EQ_INT(dtx__uf_find(parent, i), 1);
    CHECK_EQ_INT(dtx__uf_find(parent, 0), 0);
    for (int32_t i = 1; i < N; i++)
        CHECK(parent[i] >= 1 && parent[i] <= i);
}

/* Labels number the classes in order of their lowest index; non-members
 * get -1 and lowest lists each class's root. */
static void labels(void)
{
    int32_t parent[7], label[7], lowest[7];
    int32_t want[7] = {-1, 0, 1, 0, -1, 1, 2}, want_lowest[3] = {1, 2, 6};
    dtx__uf_init(parent, 7);
    dtx__uf_union(parent, 5, 2);
    dtx__uf_union(parent, 3, 1);
    for (int i = 0; i < 7; i++)
        label[i] = 0;
    label[0] = -1; /* left out */
    label[4] = -7; /* any negative value leaves out */
    CHECK_EQ_INT(dtx__uf_label(parent, 7, label, lowest), 3);
    for (int i = 0; i < 7; i++)
        CHECK_EQ_INT(label[i], want[i]);
    for (int c = 0; c < 3; c++)
        CHECK_EQ_INT(lowest[c], want_lowest[c]);
    /* Without lowest the labels are the same. */
    for (int i = 0; i < 7; i++)
        label[i] = i == 0 || i == 4 ? -1 : 0;
    CHECK_EQ_INT(dtx__uf_label(parent, 7, label, NULL), 3);
    for (int i = 0; i < 7; i++)
        CHECK_EQ_INT(label[i], want[i]);
}

/* Two separate triangles with interleaved indices and an isolated vertex:
 * components are numbered by their lowest vertex, the isolated one gets -1
 * or a component of its own. */
static void two_triangles_and_a_vertex(void)
{
    const int32_t F[6] = {5, 1, 3, 6, 2, 0};
    int32_t comp[7];
    int32_t want_none[7] = {0, 1, 0, 1, -1, 1, 0}, want_own[7] = {0, 1, 0, 1, 2, 1, 0};
    CHECK_EQ_INT(dtx__tri_components(F, 2, 7, DTX__ISOLATED_UNLABELLED, comp), 2);
    for (int i = 0; i < 7; i++)
        CHECK_EQ_INT(comp[i], want_none[i]);
    CHECK_EQ_INT(dtx__tri_components(F, 2, 7, DTX__ISOLATED_OWN, comp), 3);
    for (int i = 0; i < 7; i++)
        CHECK_EQ_INT(comp[i], want_own[i]);
    /* No faces: every vertex alone, or none labelled; no vertices at all. */
    CHECK_EQ_INT(dtx__tri_components(F, 0, 3, DTX__ISOLATED_OWN, comp), 3);
    for (int i = 0; i < 3; i++)
        CHECK_EQ_INT(comp[i], i);
    CHECK_EQ_INT(dtx__tri_components(F, 0, 3, DTX__ISOLATED_UNLABELLED, comp), 0);
    for (int i = 0; i < 3; i++)
        CHECK_EQ_INT(comp[i], -1);
    CHECK_EQ_INT(dtx__tri_components(NULL, 0, 0, DTX__ISOLATED_OWN, comp), 0);
}

static uint32_t lcg(uint32_t *s)
{
    *s = *s * 1664525u + 1013904223u;
    return *s >> 8;
}

/* The labels depend on the classes only: the same faces in any order, with
 * their corners rotated, give the same bits. */
static void determinism(void)
{
    enum { NV = 200, NF = 120 };
    int32_t F[3 * NF], G[3 * NF], perm[NF], comp0[NV], comp1[NV], parent[NV], label[NV];
    uint32_t s = 12345u;
    int32_t n0, n1;
    for (int f = 0; f < NF; f++)
        for (int k = 0; k < 3; k++)
            F[3 * f + k] = (int32_t)(lcg(&s) % NV);
    n0 = dtx__tri_components(F, NF, NV, DTX__ISOLATED_OWN, comp0);
    CHECK(n0 > 1 && n0 < NV);
    for (int trial = 0; trial < 20; trial++) {
        for (int f = 0; f < NF; f++)
            perm[f] = f;
        for (int f = NF - 1; f > 0; f--) {
            int g = (int)(lcg(&s) % (uint32_t)(f + 1)), tmp = perm[f];
            perm[f] = perm[g];
            perm[g] = tmp;
        }
        for (int f = 0; f < NF; f++) {
            int r = (int)(lcg(&s) % 3);
            for (int k = 0; k < 3; k++)
                G[3 * f + k] = F[3 * perm[f] + (k + r) % 3];
        }
        n1 = dtx__tri_components(G, NF, NV, DTX__ISOLATED_OWN, comp1);
        CHECK_EQ_INT(n1, n0);
        CHECK(memcmp(comp0, comp1, sizeof comp0) == 0);
    }
    /* The same through the union-find calls, edges in reverse order. */
    dtx__uf_init(parent, NV);
    for (int f = NF - 1; f >= 0; f--)
        for (int k = 2; k >= 0; k--)
            dtx__uf_union(parent, F[3 * f + (k + 1) % 3], F[3 * f + k]);
    memset(label, 0, sizeof label);
    CHECK_EQ_INT(dtx__uf_label(parent, NV, label, NULL), n0);
    CHECK(memcmp(comp0, label, sizeof comp0) == 0);
    /* Numbered by lowest vertex: the first vertex of each new number is
     * the next number, and every vertex's root is the lowest of its class. */
    {
        int32_t next = 0;
        for (int32_t v = 0; v < NV; v++) {
            CHECK(comp0[v] <= next);
            if (comp0[v] == next)
                next++;
            CHECK_EQ_INT(comp0[dtx__uf_find(parent, v)], comp0[v]);
            CHECK(dtx__uf_find(parent, v) <= v);
        }
        CHECK_EQ_INT(next, n0);
    }
}

int main(void)
{
    unions();
    find_after_unions();
    labels();
    two_triangles_and_a_vertex();
    determinism();
    return check_report();
}
