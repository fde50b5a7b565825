/*
 * test_generate.c: the multi-component target generators (generate.h) on
 * small procedural meshes and on the bundled lion: subdivision and the
 * icosphere (counts, Euler characteristic, closed and outward), pebbles
 * (exactly npieces connected pieces sharing no vertex, every input face in
 * exactly one piece, every vertex near the vertex it maps to, cracks that
 * open, closed outward stones with thickness, determinism), garment (body
 * unchanged, shell at the offset from the vertices it copies, two
 * components), eyes (one component per sphere, spheres clear of the body,
 * of the right radius), marker remapping, and the parameter errors.
 */
#include "check.h"
#include "core/meshgen.h"

#include "dtx_core.h"
#include "generate.h"
#include "meshfile.h"

#include <stdlib.h>
#include <string.h>

#define LION DTX_BUILD "/data/sumner-cat-lion/target/lion-reference.obj"
#define MARKERS DTX_BUILD "/data/sumner-cat-lion/markers.csv"

/* ------------------------------------------------------------ helpers */

static int32_t ncomp(const dtx_mesh *m)
{
    int32_t *c = malloc(sizeof *c * (size_t)(m->nv ? m->nv : 1));
    int32_t n = c ? dtx_mesh_components(m, c) : -1;
    free(c);
    return n;
}

static int cmp_i64(const void *a, const void *b)
{
    int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
    return (x > y) - (x < y);
}

/* Every directed edge appears exactly once and so does its reverse:
 * a closed, consistently oriented, edge-manifold surface. */
static int closed_oriented(const dtx_mesh *m)
{
    size_t n = 3 * (size_t)m->nf;
    int64_t *e = malloc(sizeof *e * n);
    int ok = 1;
    for (size_t i = 0; i < n; i++) {
        int32_t a = m->F[i], b = m->F[i - i % 3 + (i % 3 + 1) % 3];
        e[i] = (int64_t)a * m->nv + b;
    }
    qsort(e, n, sizeof *e, cmp_i64);
    for (size_t i = 0; ok && i < n; i++) {
        int64_t a = e[i] / m->nv, b = e[i] % m->nv, rev = b * m->nv + a;
        if (i > 0 && e[i] == e[i - 1])
            ok = 0;
        else if (!bsearch(&rev, e, n, sizeof *e, cmp_i64))
            ok = 0;
    }
    free(e);
    return ok;
}

/* Smallest signed volume over the components (positive: outward faces). */
static double min_component_volume(const dtx_mesh *m)
{
    int32_t *c = malloc(sizeof *c * (size_t)m->nv), nc = dtx_mesh_components(m, c);
    double *vol = calloc((size_t)nc, sizeof *vol), mn = INFINITY;
    for (int32_t f = 0; f < m->nf; f++) {
        const double *a = m->V + 3 * m->F[3 * f], *b = m->V + 3 * m->F[3 * f + 1],
                     *d = m->V + 3 * m->F[3 * f + 2];
        vol[c[m->F[3 * f]]] +=
            (a[0] * (b[1] * d[2] - b[2] * d[1]) - a[1] * (b[0] * d[2] - b[2] * d[0]) +
             a[2] * (b[0] * d[1] - b[1] * d[0])) /
            6.0;
    }
    for (int32_t i = 0; i < nc; i++)
        mn = vol[i] < mn ? vol[i] : mn;
    free(vol);
    free(c);
    return mn;
}

static double total_area(const dtx_mesh *m)
{
    double s = 0.0;
    for (int32_t f = 0; f < m->nf; f++) {
        const double *a = m->V + 3 * m->F[3 * f], *b = m->V + 3 * m->F[3 * f + 1],
                     *d = m->V + 3 * m->F[3 * f + 2];
        double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        double w[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
        double n[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
                       u[0] * w[1] - u[1] * w[0]};
        s += 0.5 * sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    }
    return s;
}

static int edge_count(const dtx_mesh *m)
{
    size_t n = 3 * (size_t)m->nf;
    int64_t *e = malloc(sizeof *e * n);
    int k = 0;
    for (size_t i = 0; i < n; i++) {
        int32_t a = m->F[i], b = m->F[i - i % 3 + (i % 3 + 1) % 3];
        e[i] = (int64_t)(a < b ? a : b) * m->nv + (a < b ? b : a);
    }
    qsort(e, n, sizeof *e, cmp_i64);
    for (size_t i = 0; i < n; i++)
        k += i == 0 || e[i] != e[i - 1];
    free(e);
    return k;
}

/* A face as a key that keeps its orientation: rotated so that the lowest
 * vertex comes first. */
static void face_key(int32_t a, int32_t b, int32_t c, int32_t nv, int64_t *k1, int32_t *k2)
{
    int32_t t[3] = {a, b, c}, r = 0;
    if (t[1] < t[r])
        r = 1;
    if (t[2] < t[r])
        r = 2;
    *k1 = (int64_t)t[r] * nv + t[(r + 1) % 3];
    *k2 = t[(r + 2) % 3];
}

typedef struct {
    int64_t k1;
    int32_t k2;
} fkey;

static int cmp_fkey(const void *a, const void *b)
{
    const fkey *x = a, *y = b;
    if (x->k1 != y->k1)
        return x->k1 < y->k1 ? -1 : 1;
    return (x->k2 > y->k2) - (x->k2 < y->k2);
}

/* The first nf faces of `out` mapped through map are the faces of `in`
 * (same orientation), each exactly once. */
static int faces_partition(const dtx_mesh *in, const dtx_mesh *out, const int32_t *map)
{
    fkey *a = malloc(sizeof *a * (size_t)in->nf), *b = malloc(sizeof *b * (size_t)in->nf);
    int ok = out->nf >= in->nf;
    for (int32_t f = 0; ok && f < in->nf; f++) {
        const int32_t *t = in->F + 3 * f, *u = out->F + 3 * f;
        face_key(t[0], t[1], t[2], in->nv, &a[f].k1, &a[f].k2);
        face_key(map[u[0]], map[u[1]], map[u[2]], in->nv, &b[f].k1, &b[f].k2);
    }
    if (ok) {
        qsort(a, (size_t)in->nf, sizeof *a, cmp_fkey);
        qsort(b, (size_t)in->nf, sizeof *b, cmp_fkey);
        for (int32_t f = 0; ok && f < in->nf; f++)
            ok = cmp_fkey(&a[f], &b[f]) == 0;
    }
    free(a);
    free(b);
    return ok;
}

/* No two vertices of one component map to the same input vertex (a piece
 * holds one copy of each of its vertices; -1 entries ignored). */
static int one_copy_per_piece(const dtx_mesh *out, const int32_t *map)
{
    int32_t *c = malloc(sizeof *c * (size_t)out->nv);
    int64_t *k = malloc(sizeof *k * (size_t)out->nv);
    size_t n = 0;
    int ok = 1;
    dtx_mesh_components(out, c);
    for (int32_t v = 0; v < out->nv; v++)
        if (map[v] >= 0)
            k[n++] = (int64_t)c[v] * out->nv + map[v];
    qsort(k, n, sizeof *k, cmp_i64);
    for (size_t i = 1; ok && i < n; i++)
        ok = k[i] != k[i - 1];
    free(c);
    free(k);
    return ok;
}

/* Largest distance of an output vertex from the input vertex it maps to
 * (map >= 0 only), and the smallest distance between two copies of one
 * input vertex (INFINITY when no vertex has two copies). */
static void copy_distances(const dtx_mesh *in, const dtx_mesh *out, const int32_t *map,
                           double *maxd, double *min_pair)
{
    int32_t *first = malloc(sizeof *first * (size_t)in->nv);
    *maxd = 0.0;
    *min_pair = INFINITY;
    for (int32_t v = 0; v < in->nv; v++)
        first[v] = -1;
    for (int32_t v = 0; v < out->nv; v++) {
        const double *x = out->V + 3 * v, *y;
        double d;
        if (map[v] < 0)
            continue;
        y = in->V + 3 * map[v];
        d = sqrt((x[0] - y[0]) * (x[0] - y[0]) + (x[1] - y[1]) * (x[1] - y[1]) +
                 (x[2] - y[2]) * (x[2] - y[2]));
        *maxd = d > *maxd ? d : *maxd;
        if (first[map[v]] >= 0) {
            const double *z = out->V + 3 * first[map[v]];
            double e = sqrt((x[0] - z[0]) * (x[0] - z[0]) + (x[1] - z[1]) * (x[1] - z[1]) +
                            (x[2] - z[2]) * (x[2] - z[2]));
            *min_pair = e < *min_pair ? e : *min_pair;
        } else {
            first[map[v]] = v;
        }
    }
    free(first);
}

static int map_in_range(const int32_t *map, int32_t n, int32_t nv_in, int allow_minus1)
{
    for (int32_t v = 0; v < n; v++)
        if (map[v] >= nv_in || map[v] < (allow_minus1 ? -1 : 0))
            return 0;
    return 1;
}

/* Two disjoint capsules in one mesh. */
static void two_capsules(dtx_mesh *m)
{
    dtx_mesh a;
    dtx_error err;
    CHECK_OK(gen_capsule(12, 8, 1.0, &a), &err);
    CHECK_OK(dtx_mesh_alloc(m, 2 * a.nv, 2 * a.nf, &err), &err);
    memcpy(m->V, a.V, sizeof(double) * 3 * (size_t)a.nv);
    memcpy(m->F, a.F, sizeof(int32_t) * 3 * (size_t)a.nf);
    for (int32_t v = 0; v < a.nv; v++) {
        m->V[3 * (a.nv + v)] = a.V[3 * v] + 5.0;
        m->V[3 * (a.nv + v) + 1] = a.V[3 * v + 1];
        m->V[3 * (a.nv + v) + 2] = a.V[3 * v + 2];
    }
    for (int32_t i = 0; i < 3 * a.nf; i++)
        m->F[3 * a.nf + i] = a.F[i] + a.nv;
    dtx_mesh_free(&a);
}

/* ------------------------------------------------------------ tests */

static void test_subdivide_icosphere(void)
{
    dtx_mesh cap, s, ico;
    int32_t *map = NULL;
    dtx_error err;
    CHECK_OK(gen_capsule(16, 10, 1.5, &cap), &err);
    for (int l = 0; l <= 2; l++) {
        CHECK_OK(dtx_gen_subdivide(&cap, l, &s, &map, &err), &err);
        CHECK_EQ_INT(s.nf, cap.nf << (2 * l));
        /* Closed genus-0 surface: V - E + F = 2 at every level. */
        CHECK_EQ_INT(s.nv - edge_count(&s) + s.nf, 2);
        CHECK(closed_oriented(&s));
        CHECK_NEAR(total_area(&s), total_area(&cap), 1e-12 * total_area(&cap));
        CHECK(memcmp(s.V, cap.V, sizeof(double) * 3 * (size_t)cap.nv) == 0);
        for (int32_t v = 0; v < s.nv; v++)
            if (map[v] != (v < cap.nv ? v : -1)) {
                CHECK_EQ_INT(map[v], v < cap.nv ? v : -1);
                break;
            }
        dtx_mesh_free(&s);
        free(map);
    }
    CHECK(dtx_gen_subdivide(&cap, DTX_GEN_MAX_SUBDIVIDE + 1, &s, &map, &err) == DTX_EINVAL);
    CHECK(map == NULL && s.V == NULL);
    CHECK(dtx_gen_subdivide(&cap, -1, &s, &map, &err) == DTX_EINVAL);

    for (int l = 0; l <= 3; l++) {
        double maxr = 0.0;
        CHECK_OK(dtx_gen_icosphere(l, &ico, &err), &err);
        CHECK_EQ_INT(ico.nv, 10 * (1 << (2 * l)) + 2);
        CHECK_EQ_INT(ico.nf, 20 * (1 << (2 * l)));
        CHECK_EQ_INT(ncomp(&ico), 1);
        CHECK(closed_oriented(&ico));
        CHECK_DBL(min_component_volume(&ico), >, 2.5); /* 2.54 at level 0, 4/3 pi in the limit */
        for (int32_t v = 0; v < ico.nv; v++) {
            const double *x = ico.V + 3 * v;
            double r = fabs(sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]) - 1.0);
            maxr = r > maxr ? r : maxr;
        }
        CHECK_DBL(maxr, <, 1e-14);
        dtx_mesh_free(&ico);
    }
    dtx_mesh_free(&cap);
}

/* The properties every open (thickness 0) pebble mesh has. */
static void check_pebbles(const dtx_mesh *in, int32_t npieces, double gap, const char *what)
{
    dtx_mesh out, again;
    int32_t *map = NULL, *map2 = NULL;
    dtx_error err;
    double diag = dtx_bbox_diagonal(in->V, in->nv), maxd, minpair;
    CHECK_OK(dtx_gen_pebbles(in, npieces, gap, 0.0, 0, &out, &map, &err), &err);
    if (!map)
        return;
    CHECK_EQ_INT(ncomp(&out), npieces);
    CHECK_EQ_INT(out.nf, in->nf);
    CHECK_EQ_INT(dtx_mesh_count_unreferenced(&out), 0);
    CHECK(map_in_range(map, out.nv, in->nv, 0));
    CHECK(faces_partition(in, &out, map));
    CHECK(one_copy_per_piece(&out, map));
    copy_distances(in, &out, map, &maxd, &minpair);
    /* Boundary vertices move in by gap/2 on average; the farthest ones (a
     * piece's corners) up to about twice that. */
    CHECK_DBL(maxd, <=, 1.5 * gap * diag);
    if (gap > 0 && npieces > 1)
        CHECK_DBL(minpair, >, 0.0);
    if (gap == 0)
        CHECK_DBL(maxd, ==, 0.0);
    printf("%s: %d pieces, gap %g: %d vertices; farthest copy %.3g x gap, closest copies "
           "%.3g x gap\n",
           what, (int)npieces, gap, (int)out.nv, maxd / (gap * diag + 1e-300),
           minpair / (gap * diag + 1e-300));
    /* Deterministic. */
    CHECK_OK(dtx_gen_pebbles(in, npieces, gap, 0.0, 0, &again, &map2, &err), &err);
    CHECK(again.nv == out.nv && again.nf == out.nf &&
          memcmp(again.V, out.V, sizeof(double) * 3 * (size_t)out.nv) == 0 &&
          memcmp(again.F, out.F, sizeof(int32_t) * 3 * (size_t)out.nf) == 0 &&
          memcmp(map2, map, sizeof(int32_t) * (size_t)out.nv) == 0);
    dtx_mesh_free(&again);
    free(map2);
    dtx_mesh_free(&out);
    free(map);
}

static void test_pebbles(void)
{
    dtx_mesh cap, two, out;
    int32_t *map = NULL;
    dtx_error err;
    double diag, maxd, minpair;
    CHECK_OK(gen_capsule(24, 16, 2.0, &cap), &err);
    diag = dtx_bbox_diagonal(cap.V, cap.nv);
    check_pebbles(&cap, 1, 0.01, "capsule");
    check_pebbles(&cap, 7, 0.01, "capsule");
    check_pebbles(&cap, 60, 0.005, "capsule");
    check_pebbles(&cap, 60, 0.0, "capsule");
    check_pebbles(&cap, cap.nf, 0.002, "capsule, one face per piece");

    /* Stones: closed, outward, one component each. */
    CHECK_OK(dtx_gen_pebbles(&cap, 12, 0.01, 0.02, 0, &out, &map, &err), &err);
    CHECK_EQ_INT(ncomp(&out), 12);
    CHECK(closed_oriented(&out));
    CHECK_DBL(min_component_volume(&out), >, 0.0);
    CHECK(map_in_range(map, out.nv, cap.nv, 0));
    CHECK(one_copy_per_piece(&out, map) == 0); /* inner copies map like their patch vertex */
    copy_distances(&cap, &out, map, &maxd, &minpair);
    CHECK_DBL(maxd, <=, (1.5 * 0.01 + 0.02) * diag);
    dtx_mesh_free(&out);
    free(map);

    /* Subdivided first: midpoints map to -1, the rest stay near their vertex. */
    CHECK_OK(dtx_gen_pebbles(&cap, 30, 0.004, 0.0, 2, &out, &map, &err), &err);
    CHECK_EQ_INT(ncomp(&out), 30);
    CHECK_EQ_INT(out.nf, 16 * cap.nf);
    CHECK(map_in_range(map, out.nv, cap.nv, 1));
    {
        int32_t nminus = 0;
        for (int32_t v = 0; v < out.nv; v++)
            nminus += map[v] < 0;
        CHECK_INT(nminus, >, out.nv / 2);
        /* Every input vertex still has a copy (markers can be remapped). */
        int32_t *idx = malloc(sizeof *idx * (size_t)cap.nv), bad;
        for (int32_t v = 0; v < cap.nv; v++)
            idx[v] = v;
        CHECK_OK(dtx_gen_remap(map, out.nv, cap.nv, cap.nv, idx, &bad, &err), &err);
        free(idx);
    }
    copy_distances(&cap, &out, map, &maxd, &minpair);
    CHECK_DBL(maxd, <=, 1.5 * 0.004 * diag);
    dtx_mesh_free(&out);
    free(map);

    /* A mesh of two parts: each part gets a seed first. */
    two_capsules(&two);
    check_pebbles(&two, 2, 0.01, "two capsules");
    check_pebbles(&two, 9, 0.01, "two capsules");
    CHECK(dtx_gen_pebbles(&two, 1, 0.01, 0.0, 0, &out, &map, &err) == DTX_EINVAL);
    CHECK(strstr(err.msg, "2 separate parts") != NULL);
    CHECK(out.V == NULL && map == NULL);

    /* Parameter errors. */
    CHECK(dtx_gen_pebbles(&cap, 0, 0.01, 0.0, 0, &out, &map, &err) == DTX_EINVAL);
    CHECK(dtx_gen_pebbles(&cap, cap.nf + 1, 0.01, 0.0, 0, &out, &map, &err) == DTX_EINVAL);
    CHECK(strstr(err.msg, "faces") != NULL);
    CHECK(dtx_gen_pebbles(&cap, 5, -0.01, 0.0, 0, &out, &map, &err) == DTX_EINVAL);
    CHECK(dtx_gen_pebbles(&cap, 5, NAN, 0.0, 0, &out, &map, &err) == DTX_EINVAL);
    CHECK(dtx_gen_pebbles(&cap, 5, 0.01, -1.0, 0, &out, &map, &err) == DTX_EINVAL);
    CHECK(dtx_gen_pebbles(&cap, 5, 0.01, INFINITY, 0, &out, &map, &err) == DTX_EINVAL);
    CHECK(dtx_gen_pebbles(&cap, 5, 0.01, 0.0, DTX_GEN_MAX_SUBDIVIDE + 1, &out, &map, &err) ==
          DTX_EINVAL);
    CHECK(out.V == NULL && out.nv == 0 && map == NULL);
    cap.F[0] = cap.nv; /* a face index out of range */
    CHECK(dtx_gen_pebbles(&cap, 5, 0.01, 0.0, 0, &out, &map, &err) == DTX_ERANGE);
    dtx_mesh_free(&two);
    dtx_mesh_free(&cap);
}

/* reshape: identity at thicken = legs = 1; else the same faces, the other
 * axes scaled exactly, the axis order of vertices kept (one-to-one), the top
 * unmoved up to the hyperbola's tail, the bottom pushed down by (legs - 1)
 * times its depth below u_0. */
static void test_reshape(void)
{
    dtx_mesh cap, out;
    int32_t *map = NULL;
    dtx_error err;
    double zmin = INFINITY, zmax = -INFINITY, xmax0 = 0, xmax1 = 0, newmin = INFINITY;
    int same = 1, order = 1, ids = 1;
    CHECK_OK(gen_capsule(24, 16, 2.0, &cap), &err);
    CHECK_OK(dtx_gen_reshape(&cap, 2, 1.0, 1.0, 0.3, &out, &map, &err), &err);
    for (int32_t i = 0; map && i < 3 * cap.nv; i++)
        same &= out.V[i] == cap.V[i];
    CHECK(same);
    dtx_mesh_free(&out);
    free(map);
    CHECK_OK(dtx_gen_reshape(&cap, 2, 1.5, 2.0, 0.3, &out, &map, &err), &err);
    if (!map)
        return;
    CHECK_INT(out.nv, ==, cap.nv);
    CHECK_INT(out.nf, ==, cap.nf);
    CHECK(memcmp(out.F, cap.F, 3 * sizeof *cap.F * (size_t)cap.nf) == 0);
    for (int32_t v = 0; v < cap.nv; v++) {
        zmin = fmin(zmin, cap.V[3 * v + 2]);
        zmax = fmax(zmax, cap.V[3 * v + 2]);
        xmax0 = fmax(xmax0, fabs(cap.V[3 * v]));
        xmax1 = fmax(xmax1, fabs(out.V[3 * v]));
        newmin = fmin(newmin, out.V[3 * v + 2]);
        ids &= map[v] == v;
        for (int32_t w = 0; w < cap.nv; w += 7)
            if (cap.V[3 * w + 2] < cap.V[3 * v + 2] && !(out.V[3 * w + 2] < out.V[3 * v + 2]))
                order = 0;
    }
    CHECK(ids);
    CHECK(order);
    CHECK_NEAR(xmax1, 1.5 * xmax0, 1e-12);
    /* The lowest point was 0.3 (zmax - zmin) below u_0: now about twice. */
    CHECK_NEAR(newmin, zmin - 0.3 * (zmax - zmin), 0.01 * (zmax - zmin));
    dtx_mesh_free(&out);
    free(map);
    CHECK_INT(dtx_gen_reshape(&cap, 3, 1.5, 2.0, 0.3, &out, &map, &err), ==, DTX_EINVAL);
    CHECK_INT(dtx_gen_reshape(&cap, 2, 0.0, 2.0, 0.3, &out, &map, &err), ==, DTX_EINVAL);
    CHECK_INT(dtx_gen_reshape(&cap, 2, 1.0, 2.0, -0.1, &out, &map, &err), ==, DTX_EINVAL);
    CHECK(map == NULL && out.nv == 0);
    dtx_mesh_free(&cap);
}

static void test_garment(void)
{
    dtx_mesh cap, out;
    int32_t *map = NULL, nshell = 0;
    dtx_error err;
    double diag, worst = 0.0, zlo, zhi;
    int ok_faces = 1, ok_map = 1;
    CHECK_OK(gen_capsule(24, 16, 2.0, &cap), &err);
    diag = dtx_bbox_diagonal(cap.V, cap.nv);
    CHECK_OK(dtx_gen_garment(&cap, 2, 0.3, 0.7, 0.02, &out, &map, &err), &err);
    if (!map)
        return;
    CHECK_INT(out.nv, >, cap.nv);
    CHECK(memcmp(out.V, cap.V, sizeof(double) * 3 * (size_t)cap.nv) == 0);
    CHECK(memcmp(out.F, cap.F, sizeof(int32_t) * 3 * (size_t)cap.nf) == 0);
    CHECK_EQ_INT(ncomp(&out), 2);
    CHECK(map_in_range(map, out.nv, cap.nv, 0));
    for (int32_t v = 0; v < cap.nv; v++)
        ok_map &= map[v] == v;
    CHECK(ok_map);
    for (int32_t v = cap.nv; v < out.nv; v++) {
        const double *x = out.V + 3 * v, *y = cap.V + 3 * map[v];
        double d = sqrt((x[0] - y[0]) * (x[0] - y[0]) + (x[1] - y[1]) * (x[1] - y[1]) +
                        (x[2] - y[2]) * (x[2] - y[2]));
        worst = fmax(worst, fabs(d - 0.02 * diag));
        nshell++;
    }
    CHECK_DBL(worst, <=, 1e-12 * diag);
    /* Shell faces are body faces in the band, same orientation, and every
     * band face has its copy. */
    zlo = -2.1 + 0.3 * 4.2;
    zhi = -2.1 + 0.7 * 4.2;
    {
        int32_t nband = 0;
        for (int32_t f = 0; f < cap.nf; f++) {
            const int32_t *t = cap.F + 3 * f;
            double c = (cap.V[3 * t[0] + 2] + cap.V[3 * t[1] + 2] + cap.V[3 * t[2] + 2]) / 3;
            nband += c >= zlo && c <= zhi;
        }
        CHECK_EQ_INT(out.nf - cap.nf, nband);
    }
    for (int32_t f = cap.nf; f < out.nf; f++) {
        const int32_t *u = out.F + 3 * f, *t = cap.F + 3 * (size_t)(f - cap.nf);
        int found = 0;
        for (int32_t g = 0; g < cap.nf && !found; g++) {
            t = cap.F + 3 * g;
            found = t[0] == map[u[0]] && t[1] == map[u[1]] && t[2] == map[u[2]];
        }
        ok_faces &= found && u[0] >= cap.nv && u[1] >= cap.nv && u[2] >= cap.nv;
    }
    CHECK(ok_faces);
    dtx_mesh_free(&out);
    free(map);

    CHECK(dtx_gen_garment(&cap, 3, 0.3, 0.7, 0.02, &out, &map, &err) == DTX_EINVAL);
    CHECK(dtx_gen_garment(&cap, 2, 0.7, 0.3, 0.02, &out, &map, &err) == DTX_EINVAL);
    CHECK(dtx_gen_garment(&cap, 2, 0.3, 0.7, 0.0, &out, &map, &err) == DTX_EINVAL);
    CHECK(dtx_gen_garment(&cap, 2, 2.0, 3.0, 0.02, &out, &map, &err) == DTX_EINVAL);
    CHECK(strstr(err.msg, "no face") != NULL);
    CHECK(out.V == NULL && map == NULL);
    dtx_mesh_free(&cap);
}

/* Smallest distance from a vertex of sphere k to the body's triangles. */
static double sphere_clearance(const dtx_mesh *body, const dtx_mesh *out, int k, int32_t nvs)
{
    dtx_bvh *bvh = dtx_bvh_build(body->V, body->F, body->nf);
    double mn = INFINITY;
    for (int32_t v = body->nv + k * nvs; v < body->nv + (k + 1) * nvs; v++) {
        double d2;
        dtx_bvh_closest(bvh, out->V + 3 * v, INFINITY, NULL, NULL, NULL, &d2);
        mn = fmin(mn, sqrt(d2));
    }
    dtx_bvh_free(&bvh);
    return mn;
}

static void sphere_centre(const dtx_mesh *out, int32_t first, int32_t nvs, double *c)
{
    c[0] = c[1] = c[2] = 0.0;
    for (int32_t v = first; v < first + nvs; v++)
        for (int j = 0; j < 3; j++)
            c[j] += out->V[3 * v + j] / nvs;
}

static void check_eyes(const dtx_mesh *body, const int32_t *anchors, int32_t na, double radius,
                       double gap, const char *what)
{
    dtx_mesh out;
    int32_t *map = NULL, nvs, body_comp = ncomp(body);
    dtx_error err;
    double diag = dtx_bbox_diagonal(body->V, body->nv);
    CHECK_OK(dtx_gen_eyes(body, anchors, na, radius, gap, &out, &map, &err), &err);
    if (!map)
        return;
    nvs = (out.nv - body->nv) / na;
    CHECK_EQ_INT(nvs, 10 * 16 + 2);
    CHECK_EQ_INT(out.nv, body->nv + na * nvs);
    CHECK_EQ_INT(ncomp(&out), body_comp + na);
    CHECK(memcmp(out.V, body->V, sizeof(double) * 3 * (size_t)body->nv) == 0);
    CHECK(memcmp(out.F, body->F, sizeof(int32_t) * 3 * (size_t)body->nf) == 0);
    for (int32_t k = 0; k < na; k++) {
        double c[3], worst = 0.0, clear;
        int ok = 1;
        sphere_centre(&out, body->nv + k * nvs, nvs, c);
        for (int32_t v = body->nv + k * nvs; v < body->nv + (k + 1) * nvs; v++) {
            const double *x = out.V + 3 * v;
            double r = sqrt((x[0] - c[0]) * (x[0] - c[0]) + (x[1] - c[1]) * (x[1] - c[1]) +
                            (x[2] - c[2]) * (x[2] - c[2]));
            worst = fmax(worst, fabs(r - radius * diag));
            ok &= map[v] == anchors[k];
        }
        CHECK_DBL(worst, <=, 1e-12 * diag);
        CHECK(ok);
        if (gap >= 0) {
            clear = sphere_clearance(body, &out, (int)k, nvs);
            CHECK_DBL(clear, >, 0.0);
            CHECK_DBL(clear, >=, 0.999 * gap * diag);
            printf("%s: sphere %d: clearance %.3g of the diagonal (gap %g)\n", what, (int)k,
                   clear / diag, gap);
        } else {
            const double *a = body->V + 3 * anchors[k];
            CHECK_NEAR(c[0], a[0], 1e-12 * diag);
            CHECK_NEAR(c[1], a[1], 1e-12 * diag);
            CHECK_NEAR(c[2], a[2], 1e-12 * diag);
        }
    }
    dtx_mesh_free(&out);
    free(map);
}

static void test_eyes(void)
{
    dtx_mesh cap, out;
    int32_t anchors[3] = {0, 100, 200}, bad[1] = {-1}, *map = NULL;
    dtx_error err;
    CHECK_OK(gen_capsule(24, 16, 2.0, &cap), &err);
    check_eyes(&cap, anchors, 3, 0.02, 0.01, "capsule");
    check_eyes(&cap, anchors, 3, 0.02, 0.0, "capsule, touching");
    check_eyes(&cap, anchors, 1, 0.05, -1.0, "capsule, embedded");
    bad[0] = cap.nv;
    CHECK(dtx_gen_eyes(&cap, bad, 1, 0.02, 0.01, &out, &map, &err) == DTX_EINVAL);
    CHECK(strstr(err.msg, "anchor 0") != NULL);
    CHECK(dtx_gen_eyes(&cap, anchors, 0, 0.02, 0.01, &out, &map, &err) == DTX_EINVAL);
    CHECK(dtx_gen_eyes(&cap, anchors, 3, 0.0, 0.01, &out, &map, &err) == DTX_EINVAL);
    CHECK(dtx_gen_eyes(&cap, anchors, 3, 0.02, NAN, &out, &map, &err) == DTX_EINVAL);
    CHECK(out.V == NULL && map == NULL);
    dtx_mesh_free(&cap);
}

static void test_remap(void)
{
    const int32_t map[5] = {2, 0, -1, 0, 1};
    int32_t idx[3] = {0, 1, 2}, bad, r1[1] = {3}, r2[2] = {2, 1};
    const int32_t map2[3] = {0, 0, 2};
    dtx_error err;
    CHECK_OK(dtx_gen_remap(map, 5, 3, 3, idx, &bad, &err), &err);
    CHECK_EQ_INT(idx[0], 1);
    CHECK_EQ_INT(idx[1], 4);
    CHECK_EQ_INT(idx[2], 0);
    CHECK_EQ_INT(bad, -1);
    CHECK(dtx_gen_remap(map, 5, 3, 1, r1, &bad, &err) == DTX_ERANGE);
    CHECK_EQ_INT(bad, 0);
    CHECK(dtx_gen_remap(map2, 3, 3, 2, r2, &bad, &err) == DTX_EINVAL);
    CHECK_EQ_INT(bad, 1);
    CHECK_EQ_INT(r2[0], 2); /* unchanged on failure */
    CHECK_EQ_INT(r2[1], 1);
}

/* The bundled lion: what scripts/make-multicomponent-targets.sh makes. */
static void test_lion(void)
{
    dtx_mesh lion, out;
    dtx_markers mk;
    int32_t *map = NULL, *idx, bad, eyes[2] = {2754, 3779};
    dtx_error err;
    double diag;
    CHECK_OK(dtx_obj_read(LION, &lion, NULL, &err), &err);
    CHECK_OK(dtx_markers_read_csv(MARKERS, 0, &mk, &err), &err);
    if (check_failed_)
        return;
    diag = dtx_bbox_diagonal(lion.V, lion.nv);
    CHECK_EQ_INT(ncomp(&lion), 1);
    check_pebbles(&lion, 250, 0.003, "lion");

    /* Markers move to the first copy, which is a copy of the marker vertex. */
    CHECK_OK(dtx_gen_pebbles(&lion, 250, 0.003, 0.0, 0, &out, &map, &err), &err);
    idx = malloc(sizeof *idx * (size_t)mk.n);
    memcpy(idx, mk.tgt, sizeof *idx * (size_t)mk.n);
    CHECK_OK(dtx_gen_remap(map, out.nv, lion.nv, mk.n, idx, &bad, &err), &err);
    for (int32_t i = 0; i < mk.n; i++)
        if (map[idx[i]] != mk.tgt[i]) {
            CHECK_EQ_INT(map[idx[i]], mk.tgt[i]);
            break;
        }
    free(idx);
    dtx_mesh_free(&out);
    free(map);

    /* Stones with a finer mesh: the benchmark's kind of target. */
    CHECK_OK(dtx_gen_pebbles(&lion, 750, 0.002, 0.003, 1, &out, &map, &err), &err);
    CHECK_EQ_INT(ncomp(&out), 750);
    CHECK_DBL(min_component_volume(&out), >, 0.0);
    dtx_mesh_free(&out);
    free(map);

    /* The shirt: one shell, at the offset. */
    CHECK_OK(dtx_gen_garment(&lion, 2, 0.45, 0.72, 0.01, &out, &map, &err), &err);
    CHECK_EQ_INT(ncomp(&out), 2);
    if (map) {
        double worst = 0.0;
        for (int32_t v = lion.nv; v < out.nv; v++) {
            const double *x = out.V + 3 * v, *y = lion.V + 3 * map[v];
            double d = sqrt((x[0] - y[0]) * (x[0] - y[0]) + (x[1] - y[1]) * (x[1] - y[1]) +
                            (x[2] - y[2]) * (x[2] - y[2]));
            worst = fmax(worst, fabs(d - 0.01 * diag));
        }
        CHECK_DBL(worst, <=, 1e-12 * diag);
        printf("lion garment: %d shell vertices, %d shell faces\n", (int)(out.nv - lion.nv),
               (int)(out.nf - lion.nf));
    }
    dtx_mesh_free(&out);
    free(map);

    check_eyes(&lion, eyes, 2, 0.004, 0.002, "lion eyes");
    dtx_markers_free(&mk);
    dtx_mesh_free(&lion);
}

int main(void)
{
    test_subdivide_icosphere();
    test_pebbles();
    test_reshape();
    test_garment();
    test_eyes();
    test_remap();
    test_lion();
    return check_report();
}
