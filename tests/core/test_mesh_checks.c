/*
 * test_mesh_checks.c: dtx_mesh_inspect and dtx_mesh_report_notes (what a
 * valid mesh can still hold: components, vertices in no face, zero-area and
 * needle triangles, duplicate positions, non-manifold edges, duplicate
 * faces), dtx_mesh_validate's rejections, and the marker checks
 * (dtx_markers_validate, dtx_markers_check_referenced); dtx_vertex_normals
 * where a vertex's face normals cancel.
 */
#include "check.h"
#include "meshgen.h"

#include "dtx_core.h"

#include <stdlib.h>
#include <string.h>

/* A mesh from literal arrays (nv x 3 doubles, nf x 3 ints). */
static void make(dtx_mesh *m, int32_t nv, const double *V, int32_t nf, const int32_t *F)
{
    dtx_error err;
    CHECK_OK(dtx_mesh_alloc(m, nv, nf, &err), &err);
    memcpy(m->V, V, sizeof(double) * 3 * (size_t)nv);
    memcpy(m->F, F, sizeof(int32_t) * 3 * (size_t)nf);
}

/* A closed tetrahedron: the clean reference. */
static const double tet_V[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
static const int32_t tet_F[] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};

static void inspect(const dtx_mesh *m, dtx_mesh_report *rep)
{
    dtx_error err;
    CHECK_OK(dtx_mesh_validate(m, "m", &err), &err);
    CHECK_OK(dtx_mesh_inspect(m, rep, &err), &err);
}

static void test_clean(void)
{
    dtx_mesh m, cap;
    dtx_mesh_report rep;
    dtx_error err;
    char notes[512];
    make(&m, 4, tet_V, 4, tet_F);
    inspect(&m, &rep);
    CHECK_EQ_INT(rep.components, 1);
    CHECK_EQ_INT(rep.other_component, -1);
    CHECK_EQ_INT(rep.unreferenced, 0);
    CHECK_EQ_INT(rep.first_unreferenced, -1);
    CHECK_EQ_INT(rep.degenerate, 0);
    CHECK_EQ_INT(rep.first_degenerate, -1);
    CHECK_EQ_INT(rep.duplicate_positions, 0);
    CHECK_EQ_INT(rep.nonmanifold_edges, 0);
    CHECK_EQ_INT(rep.duplicate_faces, 0);
    /* The thinnest tet faces: the right-angled ones, |n| = 1, longest^2 = 2. */
    CHECK_NEAR(rep.thinnest, 0.5, 1e-15);
    CHECK_EQ_INT(dtx_mesh_report_notes(&rep, notes, sizeof notes), 0);
    CHECK(notes[0] == '\0');
    dtx_mesh_free(&m);

    /* A bigger closed surface is just as clean. */
    CHECK_OK(gen_capsule(16, 10, 1.5, &cap), &err);
    inspect(&cap, &rep);
    CHECK_EQ_INT(rep.components, 1);
    CHECK_EQ_INT(rep.unreferenced + rep.degenerate + rep.duplicate_positions +
                     rep.nonmanifold_edges + rep.duplicate_faces,
                 0);
    dtx_mesh_free(&cap);
}

static void test_unreferenced_and_components(void)
{
    /* Two tets (vertices 0-3 and 5-8) and two vertices in no face (4, 9). */
    double V[30];
    int32_t F[24];
    dtx_mesh m;
    dtx_mesh_report rep;
    char notes[512];
    for (int i = 0; i < 4; i++)
        for (int k = 0; k < 3; k++) {
            V[3 * i + k] = tet_V[3 * i + k];
            V[3 * (5 + i) + k] = tet_V[3 * i + k] + (k == 0 ? 5.0 : 0.0);
        }
    V[12] = 9, V[13] = 9, V[14] = 9;
    V[27] = -9, V[28] = 9, V[29] = 9;
    for (int i = 0; i < 12; i++) {
        F[i] = tet_F[i];
        F[12 + i] = tet_F[i] + 5;
    }
    make(&m, 10, V, 8, F);
    inspect(&m, &rep);
    CHECK_EQ_INT(rep.components, 2);      /* vertices in no face do not count */
    CHECK_EQ_INT(rep.other_component, 5); /* the lowest vertex away from F[0] */
    CHECK_EQ_INT(rep.unreferenced, 2);
    CHECK_EQ_INT(rep.first_unreferenced, 4);
    CHECK_EQ_INT(dtx_mesh_report_notes(&rep, notes, sizeof notes), 1);
    CHECK(check_contains(notes, "2 vertices in no triangle (vertex 4 first)"));
    dtx_mesh_free(&m);

    /* One vertex in no face: singular wording. */
    make(&m, 5, V, 4, F);
    inspect(&m, &rep);
    CHECK_EQ_INT(rep.components, 1);
    CHECK_EQ_INT(dtx_mesh_report_notes(&rep, notes, sizeof notes), 1);
    CHECK(check_contains(notes, "1 vertex in no triangle (vertex 4 first)"));
    dtx_mesh_free(&m);
}

static void test_degenerate(void)
{
    /* Tet 0-3 plus three triangles on new vertices 4, 5, 6: face 4 (0 1 4)
     * has zero area (4 on the edge 0-1), face 5 (1 2 5) is a needle of
     * height 1e-6 on an edge of length sqrt(2), face 6 (2 0 6) is thin but
     * above the threshold (height 1e-2 on an edge of length 1). */
    const double V[] = {0,   0,   0,      /* 0 */
                        1,   0,   0,      /* 1 */
                        0,   1,   0,      /* 2 */
                        0,   0,   1,      /* 3 */
                        0.5, 0,   0,      /* 4 */
                        0.5, 0.5, 1e-6,   /* 5 */
                        0,   0.5, -1e-2}; /* 6 */
    const int32_t F[] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3, 0, 1, 4, 1, 2, 5, 2, 0, 6};
    dtx_mesh m;
    dtx_mesh_report rep;
    char notes[512];
    make(&m, 7, V, 7, F);
    inspect(&m, &rep);
    CHECK_EQ_INT(rep.degenerate, 2);
    CHECK_EQ_INT(rep.first_degenerate, 4);
    CHECK_DBL(rep.thinnest, ==, 0.0);
    /* Edges 0-1, 1-2 and 2-0 are shared by three faces each. */
    CHECK_EQ_INT(rep.nonmanifold_edges, 3);
    CHECK_EQ_INT(dtx_mesh_report_notes(&rep, notes, sizeof notes), 2);
    CHECK(check_contains(notes, "2 triangles of zero area or thinner than 0.0001 of the longest edge "
                          "(face 4 first"));
    dtx_mesh_free(&m);

    /* Only the needle: its ratio is height / longest edge. */
    {
        const int32_t F2[] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3, 1, 2, 5};
        make(&m, 7, V, 5, F2);
        inspect(&m, &rep);
        CHECK_EQ_INT(rep.degenerate, 1);
        CHECK_EQ_INT(rep.first_degenerate, 4);
        CHECK_DBL(rep.thinnest, >, 0.0);
        CHECK_DBL(rep.thinnest, <, 1e-5);
        dtx_mesh_free(&m);
    }
}

static void test_duplicates_and_nonmanifold(void)
{
    /* Tet 0-3; vertices 4 and 5 are copies of vertex 1 (-0.0 and 0.0 are
     * the same position), each used by one more triangle with vertex 6;
     * face 4 is a fin on edge 0-1 and face 5 repeats face 0's vertices in
     * another order. */
    const double V[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, -0.0, 0, 1, 0, -0.0, 0.3, 0.3, -1};
    const int32_t F[] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3, 0, 1, 6, 2, 1, 0, 4, 2, 6, 5, 6, 3};
    dtx_mesh m;
    dtx_mesh_report rep;
    char notes[1024];
    make(&m, 7, V, 8, F);
    inspect(&m, &rep);
    CHECK_EQ_INT(rep.duplicate_positions, 2); /* 4 and 5, both copies of 1 */
    CHECK_EQ_INT(rep.dup_vertex[0], 1);
    CHECK_EQ_INT(rep.dup_vertex[1], 4);
    /* Edge 0-1 is in faces 0, 1, 4 and 5; edges 0-2 and 1-2 in three. */
    CHECK_EQ_INT(rep.nonmanifold_edges, 3);
    CHECK_EQ_INT(rep.nonmanifold_edge[0], 0);
    CHECK_EQ_INT(rep.nonmanifold_edge[1], 1);
    CHECK_EQ_INT(rep.nonmanifold_faces, 4);
    CHECK_EQ_INT(rep.duplicate_faces, 1);
    CHECK_EQ_INT(rep.dup_face[0], 0);
    CHECK_EQ_INT(rep.dup_face[1], 5);
    CHECK_EQ_INT(rep.components, 1);
    CHECK_EQ_INT(rep.degenerate, 0);
    CHECK_EQ_INT(dtx_mesh_report_notes(&rep, notes, sizeof notes), 3);
    CHECK(check_contains(notes, "2 vertices at exactly the position of another vertex (vertices 1 and "
                          "4 first)"));
    CHECK(check_contains(notes, "3 non-manifold edges (edge 0-1 first, shared by 4 triangles)"));
    CHECK(check_contains(notes, "1 triangle on the same three vertices as another (faces 0 and 5 "
                          "first)"));
    /* Notes are separated by "; " and truncated safely. */
    CHECK(check_contains(notes, "); 3 non-manifold"));
    {
        char small[40];
        memset(small, 'x', sizeof small);
        CHECK_EQ_INT(dtx_mesh_report_notes(&rep, small, sizeof small), 3);
        CHECK_EQ_INT(strlen(small), sizeof small - 1);
        CHECK_EQ_INT(dtx_mesh_report_notes(&rep, small, 0), 0);
    }
    dtx_mesh_free(&m);

    /* A seam: the tet's vertex 3 split into 3 and 4 at the same position,
     * with faces 1 and 2 on different copies: still one component and no
     * non-manifold edge, but a duplicate position. */
    {
        const double V2[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 1};
        const int32_t F2[] = {0, 2, 1, 0, 1, 3, 0, 4, 2, 1, 2, 3};
        make(&m, 5, V2, 4, F2);
        inspect(&m, &rep);
        CHECK_EQ_INT(rep.components, 1);
        CHECK_EQ_INT(rep.duplicate_positions, 1);
        CHECK_EQ_INT(rep.dup_vertex[0], 3);
        CHECK_EQ_INT(rep.dup_vertex[1], 4);
        CHECK_EQ_INT(rep.nonmanifold_edges, 0);
        dtx_mesh_free(&m);
    }
}

static void test_validate(void)
{
    dtx_mesh m;
    dtx_error err;
    make(&m, 4, tet_V, 4, tet_F);
    m.F[7] = 4;
    CHECK_EQ_INT(dtx_mesh_validate(&m, "t.h5: /meshes/x", &err), DTX_ERANGE);
    CHECK(check_contains(err.msg, "t.h5: /meshes/x: face 2 (0-based) has vertex index 4 out of range "
                            "[0, 4)"));
    m.F[7] = 3;
    m.F[4] = 0;
    CHECK_EQ_INT(dtx_mesh_validate(&m, "x", &err), DTX_EMESH);
    CHECK(check_contains(err.msg, "x: face 1 (0-based) repeats a vertex (0 0 3)"));
    m.F[4] = 1;
    m.V[5] = NAN;
    CHECK_EQ_INT(dtx_mesh_validate(&m, "x", &err), DTX_ENONFINITE);
    CHECK(check_contains(err.msg, "x: vertex 1 (0-based) has a non-finite coordinate"));
    m.V[5] = 0;
    CHECK_OK(dtx_mesh_validate(&m, "x", &err), &err);
    m.nf = 0;
    CHECK_EQ_INT(dtx_mesh_validate(&m, "x", &err), DTX_EMESH);
    CHECK(check_contains(err.msg, "x: mesh has no faces"));
    m.nf = 4;
    dtx_mesh_free(&m);
}

static void set_marker(dtx_markers *mk, int i, int32_t s, int32_t t, const char *label)
{
    mk->src[i] = s;
    mk->tgt[i] = t;
    mk->labels[i] = label ? strdup(label) : NULL;
}

static void test_markers(void)
{
    dtx_markers mk;
    dtx_error err;
    dtx_mesh src;
    const double V[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 5, 5, 5};

    CHECK_OK(dtx_markers_alloc(&mk, 3, &err), &err);
    set_marker(&mk, 0, 0, 1, "nose");
    set_marker(&mk, 1, 2, 3, NULL);
    set_marker(&mk, 2, 3, 0, "tail");
    CHECK_OK(dtx_markers_validate(&mk, 5, 4, "mk", &err), &err);

    /* Out of range, naming the marker, its label and the base question. */
    CHECK_EQ_INT(dtx_markers_validate(&mk, 5, 3, "mk", &err), DTX_ERANGE);
    CHECK(check_contains(err.msg, "mk: marker 1: target vertex 3 out of range [0, 3) (0-based; is the "
                            "index base right?)"));
    mk.src[2] = 5;
    CHECK_EQ_INT(dtx_markers_validate(&mk, 5, 4, "mk", &err), DTX_ERANGE);
    CHECK(check_contains(err.msg, "mk: marker 2 (\"tail\"): source vertex 5 out of range [0, 5)"));
    mk.src[2] = -1;
    CHECK_EQ_INT(dtx_markers_validate(&mk, 5, 4, "mk", &err), DTX_ERANGE);

    /* A vertex used twice: both markers named. */
    mk.src[2] = 0;
    CHECK_EQ_INT(dtx_markers_validate(&mk, 5, 4, "mk", &err), DTX_EINVAL);
    CHECK(check_contains(err.msg, "mk: source vertex 0 is used by two markers, 0 (\"nose\") and 2 "
                            "(\"tail\")"));
    mk.src[2] = 3;
    mk.tgt[1] = 1;
    CHECK_EQ_INT(dtx_markers_validate(&mk, 5, 4, "mk", &err), DTX_EINVAL);
    CHECK(check_contains(err.msg, "mk: target vertex 1 is used by two markers, 0 (\"nose\") and 1 "
                            "(0-based"));
    mk.tgt[1] = 3;

    /* A source vertex in no face constrains nothing: vertex 4 of a tet
     * with one extra vertex. */
    make(&src, 5, V, 4, tet_F);
    CHECK_OK(dtx_markers_check_referenced(&mk, &src, "mk", &err), &err);
    mk.src[1] = 4;
    CHECK_EQ_INT(dtx_markers_check_referenced(&mk, &src, "mk", &err), DTX_EINVAL);
    CHECK(check_contains(err.msg, "mk: marker 1: source vertex 4 is in no triangle of the source mesh"));
    dtx_mesh_free(&src);
    dtx_markers_free(&mk);

    /* No markers at all. */
    CHECK_OK(dtx_markers_alloc(&mk, 0, &err), &err);
    CHECK_EQ_INT(dtx_markers_validate(&mk, 5, 4, "mk", &err), DTX_EINVAL);
    CHECK(check_contains(err.msg, "mk: no markers"));
    dtx_markers_free(&mk);
}

/* Two triangles meeting at vertex 0 with opposite normals of the same size
 * in exact arithmetic: 0.7 * 0.1 and 0.07 * 1 round apart, so the sum at
 * vertex 0 is 1.4e-17 along z, noise with no direction.  It must give no
 * normal (zero), not a unit normal pointing by chance; the other vertices
 * keep their faces' unit normals. */
static void test_vertex_normals_cancel(void)
{
    const double V[] = {0, 0, 0, 0.7, 0, 0, 0, 0.1, 0, -0.07, 0, 0, 0, -1.0, 0};
    const int32_t F[] = {0, 1, 2, 0, 4, 3};
    double N[15];
    /* The premise: the sum really is nonzero noise. */
    volatile double a = 0.7, b = 0.1, c = 0.07;
    CHECK(a * b - c != 0);
    dtx_vertex_normals(V, 5, F, 2, N);
    for (int k = 0; k < 3; k++)
        CHECK(N[k] == 0);
    CHECK_NEAR(N[3 * 1 + 2], 1.0, 1e-15);
    CHECK_NEAR(N[3 * 2 + 2], 1.0, 1e-15);
    CHECK_NEAR(N[3 * 3 + 2], -1.0, 1e-15);
    CHECK_NEAR(N[3 * 4 + 2], -1.0, 1e-15);
    /* A real normal far smaller than the threshold's absolute value still
     * counts: the floor is relative to the mesh's largest face. */
    const double W[] = {0, 0, 0, 1e-9, 0, 0, 0, 1e-9, 0};
    const int32_t G[] = {0, 1, 2};
    dtx_vertex_normals(W, 3, G, 1, N);
    for (int i = 0; i < 3; i++)
        CHECK_NEAR(N[3 * i + 2], 1.0, 1e-15);
}

int main(void)
{
    test_clean();
    test_unreferenced_and_components();
    test_degenerate();
    test_duplicates_and_nonmanifold();
    test_validate();
    test_markers();
    test_vertex_normals_cancel();
    return check_report();
}
