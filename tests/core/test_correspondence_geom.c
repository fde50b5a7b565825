/*
 * test_correspondence_geom.c: the geometric pieces of the sp04
 * correspondence's closest-point term (correspondence.c, bvh.c).
 *  - dtx_closest_point_triangle: each of the seven Voronoi regions of a
 *    triangle against a hand-computed answer, and on random triangles and
 *    points the answer is in the triangle and no farther than any point of
 *    a fine barycentric grid over it;
 *  - closest points on the surface: above a triangle's interior the
 *    closest valid point is the foot of the perpendicular, not a vertex
 *    (which a point tree over the vertices gives);
 *  - the normal rule: a nearer triangle facing away (normals more than 90
 *    degrees apart) is skipped for the next-closest valid one, at 89
 *    degrees it is taken, and without the rule the nearest wins; nothing
 *    beyond max_dist;
 *  - per-area weights: a source refined by midpoint subdivision (the same
 *    surface at 4x the triangles) deforms onto the target much as the
 *    unrefined one does with weights per area, and measurably less so with
 *    weights per element (the paper's sums), whose E_I and E_C grow 4x
 *    against E_S; and the result with weights per area is the same, bit
 *    for bit, at 1 and 2 threads (deformed source, pairs and fit);
 *  - the tree's closest-point search against a brute-force scan of every
 *    triangle (closest allowed one, ties to the lower index, strictly
 *    within max_dist; same point and distance), with and without a
 *    filter and a distance limit, from every kind of hint (none, the
 *    answer, its twin, a random one, one the filter rejects, one out of
 *    range) and without (dtx_bvh_closest); its leaf
 *    order is a permutation of the primitives that keeps neighbours close;
 *    and dtx__fit_rms_from gives dtx__fit_rms's figure with any hints.
 */
#include "check.h"
#include "correspondence_internal.h"
#include "dtx_core.h"
#include "generate.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846

static void test_triangle_regions(void)
{
    static const double a[3] = {0, 0, 0}, b[3] = {1, 0, 0}, c[3] = {0, 1, 0};
    static const struct {
        double p[3], q[3], d2;
    } cases[] = {
        {{0.2, 0.3, 0.5}, {0.2, 0.3, 0}, 0.25},  /* face */
        {{-1, -1, 2}, {0, 0, 0}, 6.0},           /* vertex a */
        {{2, -0.5, 0}, {1, 0, 0}, 1.25},         /* vertex b */
        {{-0.5, 2, 1}, {0, 1, 0}, 2.25},         /* vertex c */
        {{0.5, -1, 0}, {0.5, 0, 0}, 1.0},        /* edge ab */
        {{-1, 0.5, 0}, {0, 0.5, 0}, 1.0},        /* edge ca */
        {{1, 1, -1}, {0.5, 0.5, 0}, 1.5},        /* edge bc */
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        double q[3];
        double d2 = dtx_closest_point_triangle(cases[i].p, a, b, c, q);
        CHECK_NEAR(d2, cases[i].d2, 1e-15);
        for (int k = 0; k < 3; k++)
            CHECK_NEAR(q[k], cases[i].q[k], 1e-15);
    }
}

static double rnd(uint64_t *s)
{
    *s = *s * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(*s >> 11) / 9007199254740992.0 - 0.5;
}

static void test_triangle_random(void)
{
    uint64_t s = 2024;
    int inside = 1, nearest = 1;
    for (int it = 0; it < 200; it++) {
        double t[3][3], p[3], q[3], d2, e1[3], e2[3], n[3], nn, dist;
        for (int j = 0; j < 3; j++)
            for (int k = 0; k < 3; k++)
                t[j][k] = rnd(&s);
        for (int k = 0; k < 3; k++)
            p[k] = 2.0 * rnd(&s);
        d2 = dtx_closest_point_triangle(p, t[0], t[1], t[2], q);
        /* q in the triangle: in its plane, with barycentric coordinates >= 0. */
        for (int k = 0; k < 3; k++) {
            e1[k] = t[1][k] - t[0][k];
            e2[k] = t[2][k] - t[0][k];
        }
        n[0] = e1[1] * e2[2] - e1[2] * e2[1];
        n[1] = e1[2] * e2[0] - e1[0] * e2[2];
        n[2] = e1[0] * e2[1] - e1[1] * e2[0];
        nn = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
        for (int j = 0; j < 3; j++) {
            /* Twice the signed area of (q, t[j+1], t[j+2]) over the whole. */
            const double *u = t[(j + 1) % 3], *v = t[(j + 2) % 3];
            double x[3] = {u[0] - q[0], u[1] - q[1], u[2] - q[2]},
                   y[3] = {v[0] - q[0], v[1] - q[1], v[2] - q[2]};
            double w = ((x[1] * y[2] - x[2] * y[1]) * n[0] + (x[2] * y[0] - x[0] * y[2]) * n[1] +
                        (x[0] * y[1] - x[1] * y[0]) * n[2]) /
                       nn;
            if (!(w >= -1e-12))
                inside = 0;
        }
        dist = ((q[0] - t[0][0]) * n[0] + (q[1] - t[0][1]) * n[1] + (q[2] - t[0][2]) * n[2]) /
               sqrt(nn);
        if (!(fabs(dist) <= 1e-12))
            inside = 0;
        /* No grid point of the triangle is nearer. */
        for (int i = 0; i <= 60; i++)
            for (int j = 0; i + j <= 60; j++) {
                double u = i / 60.0, v = j / 60.0, g2 = 0.0;
                for (int k = 0; k < 3; k++) {
                    double g = t[0][k] + u * e1[k] + v * e2[k] - p[k];
                    g2 += g * g;
                }
                if (!(d2 <= g2 + 1e-14))
                    nearest = 0;
            }
    }
    CHECK(inside);
    CHECK(nearest);
}

/* Closest points on the surface, and the normal rule.  Two parallel
 * triangles: T0 in z = 0 facing -z, T1 in z = -1 facing +z (both cover
 * x, y in [0, 2] x [0, 2] near the query). */
static void test_closest_valid(void)
{
    static const double V[] = {0, 0, 0, 4, 0, 0, 0, 4, 0, 0, 0, -1, 4, 0, -1, 0, 4, -1};
    static const int32_t F[] = {0, 2, 1, 3, 4, 5};
    double N[6], cp[3];
    const double p[3] = {0.5, 0.7, 0.4};
    const double cosmax = cos(90.0 * PI / 180.0);
    dtx_bvh *tri = dtx_bvh_build(V, F, 2), *pts = dtx_bvh_build(V, NULL, 6);
    CHECK(tri != NULL && pts != NULL);
    if (!tri || !pts)
        return;
    dtx_face_normals(V, F, 2, N);
    CHECK_NEAR(N[2], -1.0, 1e-15);
    CHECK_NEAR(N[5], 1.0, 1e-15);

    /* Facing -z like T0: T0, at the foot of the perpendicular. */
    {
        const double n[3] = {0, 0, -1};
        CHECK_EQ_INT(dtx__closest_valid(tri, N, p, n, cosmax, INFINITY, 1, -1, cp), 0);
        CHECK(cp[0] == 0.5 && cp[1] == 0.7 && cp[2] == 0.0);
    }
    /* Facing +z: T0 (0.4 away) faces away, so T1 (1.4 away) is the closest
     * valid point; without the rule, T0. */
    {
        const double n[3] = {0, 0, 1};
        CHECK_EQ_INT(dtx__closest_valid(tri, N, p, n, cosmax, INFINITY, 1, -1, cp), 1);
        CHECK(cp[0] == 0.5 && cp[1] == 0.7 && cp[2] == -1.0);
        /* The answer does not depend on the hint, even a rejected one. */
        CHECK_EQ_INT(dtx__closest_valid(tri, N, p, n, cosmax, INFINITY, 1, 0, cp), 1);
        CHECK_EQ_INT(dtx__closest_valid(tri, N, p, n, cosmax, INFINITY, 0, -1, cp), 0);
        CHECK(cp[2] == 0.0);
        /* Nothing valid within 1.0. */
        CHECK_EQ_INT(dtx__closest_valid(tri, N, p, n, cosmax, 1.0, 1, -1, cp), -1);
    }
    /* 89 degrees from T0's normal: valid; 91 degrees: not (T1 instead). */
    {
        double a = 89.0 * PI / 180.0;
        double n89[3] = {sin(a), 0, -cos(a)}, n91[3] = {sin(a + 2 * PI / 180.0), 0,
                                                      -cos(a + 2 * PI / 180.0)};
        CHECK_EQ_INT(dtx__closest_valid(tri, N, p, n89, cosmax, INFINITY, 1, -1, cp), 0);
        CHECK_EQ_INT(dtx__closest_valid(tri, N, p, n91, cosmax, INFINITY, 1, -1, cp), 1);
    }
    /* Among the vertices only (with their normals: T0's are -z), the
     * nearest valid vertex is T0's corner at the origin, 0.95 away, not the
     * surface point 0.4 away. */
    {
        const double n[3] = {0, 0, -1};
        double VN[18];
        for (int v = 0; v < 6; v++) {
            VN[3 * v] = VN[3 * v + 1] = 0.0;
            VN[3 * v + 2] = v < 3 ? -1.0 : 1.0;
        }
        CHECK_EQ_INT(dtx__closest_valid(pts, VN, p, n, cosmax, INFINITY, 1, -1, cp), 0);
        CHECK(cp[0] == 0.0 && cp[1] == 0.0 && cp[2] == 0.0);
    }
    dtx_bvh_free(&tri);
    dtx_bvh_free(&pts);
}

/* RMS distance (over the coarse vertices) between the deformed coarse
 * source and the deformed refined source, with the given weights. */
static double refinement_change(const dtx_mesh *coarse, const dtx_mesh *fine,
                                const dtx_mesh *tgt, const dtx_markers *mk, int weights)
{
    dtx_corr_params prm;
    dtx_corr a, b;
    dtx_error err;
    double s2 = 0.0;
    dtx_corr_params_default(&prm);
    prm.weights = weights;
    CHECK_OK(dtx_sp04_correspond(coarse, tgt, mk, &prm, &a, &err), &err);
    CHECK_OK(dtx_sp04_correspond(fine, tgt, mk, &prm, &b, &err), &err);
    if (check_failed_)
        return NAN;
    for (int32_t i = 0; i < 3 * coarse->nv; i++)
        s2 += (a.deformed_src[i] - b.deformed_src[i]) * (a.deformed_src[i] - b.deformed_src[i]);
    dtx_corr_free(&a);
    dtx_corr_free(&b);
    return sqrt(s2 / coarse->nv) / dtx_rms_extent(tgt->V, tgt->nv);
}

/* Source: an icosphere (level 2) and the same sphere subdivided once more
 * by midpoints (flat: the same surface); target: a level-3 icosphere
 * stretched into an ellipsoid and bent.  Markers: the 12 icosahedron
 * vertices, which keep their indices in every level. */
static void test_area_weights(void)
{
    dtx_mesh coarse, fine, tgt;
    dtx_markers mk;
    dtx_error err;
    int32_t *map = NULL;
    double de, da;
    CHECK_OK(dtx_gen_icosphere(2, &coarse, &err), &err);
    CHECK_OK(dtx_gen_subdivide(&coarse, 1, &fine, &map, &err), &err);
    free(map);
    CHECK_OK(dtx_gen_icosphere(3, &tgt, &err), &err);
    CHECK_OK(dtx_markers_alloc(&mk, 12, &err), &err);
    if (check_failed_)
        return;
    for (int32_t v = 0; v < tgt.nv; v++) {
        double *x = tgt.V + 3 * (size_t)v;
        x[0] *= 1.4;
        x[2] *= 0.7;
        x[1] += 0.3 * x[0] * x[0];
    }
    for (int32_t m = 0; m < 12; m++)
        mk.src[m] = mk.tgt[m] = m;
    de = refinement_change(&coarse, &fine, &tgt, &mk, DTX_CORR_WEIGHTS_ELEMENT);
    da = refinement_change(&coarse, &fine, &tgt, &mk, DTX_CORR_WEIGHTS_AREA);
    printf("refining the source moves its deformed vertices by %.3g of the size with weights "
           "per element, %.3g per area\n",
           de, da);
    CHECK_DBL(da, <, 0.5 * de);
    {
        dtx_corr a, b;
        dtx_corr_params prm;
        int nt = omp_get_max_threads();
        dtx_corr_params_default(&prm);
        CHECK_EQ_INT(prm.weights, DTX_CORR_WEIGHTS_AREA);
        omp_set_num_threads(1);
        CHECK_OK(dtx_sp04_correspond(&fine, &tgt, &mk, &prm, &a, &err), &err);
        omp_set_num_threads(2);
        CHECK_OK(dtx_sp04_correspond(&fine, &tgt, &mk, &prm, &b, &err), &err);
        omp_set_num_threads(nt);
        if (!check_failed_) {
            CHECK(memcmp(a.deformed_src, b.deformed_src, sizeof(double) * 3 * fine.nv) == 0);
            CHECK(a.npairs == b.npairs &&
                  memcmp(a.pairs, b.pairs, sizeof(int32_t) * 2 * (size_t)a.npairs) == 0);
            CHECK(a.fit_rms == b.fit_rms && a.fit_rms > 0.0);
            dtx_corr_free(&a);
            dtx_corr_free(&b);
        }
    }
    dtx_markers_free(&mk);
    dtx_mesh_free(&coarse);
    dtx_mesh_free(&fine);
    dtx_mesh_free(&tgt);
}

static int odd_only(const void *ctx, int32_t prim)
{
    (void)ctx;
    return prim % 2 == 1;
}

static double urand(uint64_t *s)
{
    *s = *s * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(*s >> 11) / 9007199254740992.0;
}

/* A bent, stretched level-3 icosphere with every triangle twice (exact
 * ties); random points inside and around it. */
static void test_bvh_brute(void)
{
    dtx_mesh m;
    dtx_error err;
    int32_t *F, nf, bad = 0, found = 0;
    uint64_t s = 777;
    dtx_bvh *tri, *pts;
    CHECK_OK(dtx_gen_icosphere(3, &m, &err), &err);
    if (check_failed_)
        return;
    for (int32_t v = 0; v < m.nv; v++) {
        double *x = m.V + 3 * (size_t)v;
        x[0] *= 1.5;
        x[1] += 0.4 * x[0] * x[0];
    }
    nf = 2 * m.nf;
    F = malloc((size_t)nf * 3 * sizeof *F);
    CHECK(F != NULL);
    if (!F) {
        dtx_mesh_free(&m);
        return;
    }
    memcpy(F, m.F, (size_t)m.nf * 3 * sizeof *F);
    memcpy(F + 3 * (size_t)m.nf, m.F, (size_t)m.nf * 3 * sizeof *F);
    tri = dtx_bvh_build(m.V, F, nf);
    pts = dtx_bvh_build(m.V, NULL, m.nv);
    CHECK(tri != NULL && pts != NULL);
    for (int q = 0; tri && q < 3000; q++) {
        double p[3], c[3], bc[3] = {0, 0, 0}, d2 = -1.0, bd2;
        double maxd = q % 3 == 0 ? INFINITY : 0.15;
        dtx_bvh_filter filter = q % 2 ? odd_only : NULL;
        int32_t best = -1, r, hints[6];
        for (int k = 0; k < 3; k++)
            p[k] = (urand(&s) - 0.5) * 4.0;
        bd2 = isfinite(maxd) ? maxd * maxd : INFINITY;
        for (int32_t f = 0; f < nf; f++) {
            double pt[3], e2;
            if (filter && !filter(NULL, f))
                continue;
            e2 = dtx_closest_point_triangle(p, m.V + 3 * (size_t)F[3 * f],
                                            m.V + 3 * (size_t)F[3 * f + 1],
                                            m.V + 3 * (size_t)F[3 * f + 2], pt);
            if (e2 < bd2 || (e2 == bd2 && best >= 0 && f < best)) {
                bd2 = e2;
                best = f;
                memcpy(bc, pt, sizeof bc);
            }
        }
        /* From every kind of hint: none, the answer, its twin, a random
         * triangle, the closest of all (which the filter may reject), one
         * out of range; and dtx_bvh_closest. */
        hints[0] = -1;
        hints[1] = best;
        hints[2] = best >= 0 ? (best + m.nf) % nf : 0;
        hints[3] = (int32_t)(urand(&s) * nf);
        hints[4] = dtx_bvh_closest(tri, p, maxd, NULL, NULL, NULL, NULL);
        hints[5] = nf;
        for (int h = 0; h <= 6; h++) {
            d2 = -1.0;
            r = h < 6 ? dtx_bvh_closest_from(tri, p, maxd, filter, NULL, hints[h], c, &d2)
                      : dtx_bvh_closest(tri, p, maxd, filter, NULL, c, &d2);
            if (r != best || (best >= 0 && (d2 != bd2 || memcmp(c, bc, sizeof c) != 0)))
                bad++;
        }
        found += best >= 0;
    }
    CHECK_EQ_INT(bad, 0);
    /* Both outcomes occur; every answer found ties with its twin, so the
     * agreement includes the tie rule. */
    CHECK(found > 500 && found < 3000);

    /* Leaf order: a permutation, and consecutive points close together (on
     * average under a fifth of the distance to a point taken at random). */
    if (pts) {
        const int32_t *ord = dtx_bvh_leaf_order(pts);
        unsigned char *seen = calloc((size_t)m.nv, 1);
        int perm = seen != NULL;
        double step = 0.0, rnd = 0.0;
        for (int32_t i = 0; seen && i < m.nv; i++) {
            if (ord[i] < 0 || ord[i] >= m.nv || seen[ord[i]])
                perm = 0;
            else
                seen[ord[i]] = 1;
        }
        CHECK(perm);
        for (int32_t i = 1; perm && i < m.nv; i++) {
            const double *a = m.V + 3 * (size_t)ord[i - 1], *b = m.V + 3 * (size_t)ord[i];
            const double *c = m.V + 3 * (size_t)(urand(&s) * m.nv);
            step += sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                         (a[2] - b[2]) * (a[2] - b[2]));
            rnd += sqrt((a[0] - c[0]) * (a[0] - c[0]) + (a[1] - c[1]) * (a[1] - c[1]) +
                        (a[2] - c[2]) * (a[2] - c[2]));
        }
        printf("leaf order: mean step %.4f against %.4f between random points\n",
               step / (m.nv - 1), rnd / (m.nv - 1));
        CHECK_DBL(step, <, 0.2 * rnd);
        free(seen);
    }

    /* The fit from hints (the closest triangles, random ones, none) is the
     * fit without. */
    if (tri) {
        const int32_t n = 500;
        double *X = malloc((size_t)n * 3 * sizeof *X);
        int32_t *h = malloc((size_t)n * sizeof *h);
        CHECK(X != NULL && h != NULL);
        if (X && h) {
            double f0, f1, f2;
            for (int32_t i = 0; i < n; i++) {
                for (int k = 0; k < 3; k++)
                    X[3 * i + k] = (urand(&s) - 0.5) * 3.0;
                h[i] = dtx_bvh_closest(tri, X + 3 * i, INFINITY, NULL, NULL, NULL, NULL);
            }
            f0 = dtx__fit_rms(tri, X, n, NULL);
            f1 = dtx__fit_rms_from(tri, X, n, NULL, h);
            for (int32_t i = 0; i < n; i++)
                h[i] = i % 5 == 0 ? -1 : (int32_t)(urand(&s) * nf);
            f2 = dtx__fit_rms_from(tri, X, n, NULL, h);
            CHECK(f0 > 0.0 && f0 == f1 && f0 == f2);
        }
        free(X);
        free(h);
    }
    dtx_bvh_free(&tri);
    dtx_bvh_free(&pts);
    free(F);
    dtx_mesh_free(&m);
}

int main(void)
{
    test_triangle_regions();
    test_triangle_random();
    test_closest_valid();
    test_area_weights();
    test_bvh_brute();
    return check_report();
}
