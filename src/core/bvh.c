/*
 * bvh.c: a bounding-volume hierarchy over triangles or points, for
 * closest-point queries on a surface with a per-primitive filter (the normal
 * test of the correspondence phase).
 *
 * Build: top-down, splitting each node at the middle of its primitives'
 * centroid bounds along the longest axis (falling back to an even split by
 * count), leaves of at most LEAF_SIZE primitives.  Query: depth first,
 * nearer child first, pruned by the best distance found so far.
 */
#include "dtx_core.h"

#include <math.h>
#include <stdlib.h>

#define LEAF_SIZE 4
#define MAX_DEPTH 64

typedef struct {
    double lo[3], hi[3];
    int32_t first; /* leaf: first index into order[]; inner: left child */
    int32_t count; /* leaf: number of primitives; inner: 0 (right = left + 1) */
} bvh_node;

struct dtx_bvh {
    const double *X;
    const int32_t *F; /* NULL for a point set */
    int32_t nprim;
    int32_t nnodes;
    bvh_node *nodes;
    int32_t *order; /* primitive indices, grouped by leaf */
};

static void prim_bounds(const dtx_bvh *b, int32_t p, double *lo, double *hi)
{
    if (!b->F) {
        for (int k = 0; k < 3; k++)
            lo[k] = hi[k] = b->X[3 * p + k];
        return;
    }
    for (int k = 0; k < 3; k++) {
        lo[k] = INFINITY;
        hi[k] = -INFINITY;
    }
    for (int j = 0; j < 3; j++) {
        const double *x = b->X + 3 * b->F[3 * p + j];
        for (int k = 0; k < 3; k++) {
            lo[k] = x[k] < lo[k] ? x[k] : lo[k];
            hi[k] = x[k] > hi[k] ? x[k] : hi[k];
        }
    }
}

/* Builds the subtree of node `ni` over order[first .. first+count) and
 * returns the number of nodes used so far.  cen: nprim x 3 centroids. */
static int32_t build(dtx_bvh *b, const double *cen, int32_t ni, int32_t first, int32_t count,
                     int32_t next, int depth)
{
    bvh_node *n = &b->nodes[ni];
    double clo[3] = {INFINITY, INFINITY, INFINITY}, chi[3] = {-INFINITY, -INFINITY, -INFINITY};
    int axis = 0;
    int32_t mid;
    for (int k = 0; k < 3; k++) {
        n->lo[k] = INFINITY;
        n->hi[k] = -INFINITY;
    }
    for (int32_t i = first; i < first + count; i++) {
        double lo[3], hi[3];
        int32_t p = b->order[i];
        prim_bounds(b, p, lo, hi);
        for (int k = 0; k < 3; k++) {
            n->lo[k] = lo[k] < n->lo[k] ? lo[k] : n->lo[k];
            n->hi[k] = hi[k] > n->hi[k] ? hi[k] : n->hi[k];
            clo[k] = cen[3 * p + k] < clo[k] ? cen[3 * p + k] : clo[k];
            chi[k] = cen[3 * p + k] > chi[k] ? cen[3 * p + k] : chi[k];
        }
    }
    if (count <= LEAF_SIZE || depth >= MAX_DEPTH) {
        n->first = first;
        n->count = count;
        return next;
    }
    for (int k = 1; k < 3; k++)
        if (chi[k] - clo[k] > chi[axis] - clo[axis])
            axis = k;
    {
        /* Partition around the middle of the centroid bounds. */
        double split = 0.5 * (clo[axis] + chi[axis]);
        int32_t i = first, j = first + count - 1;
        while (i <= j) {
            if (cen[3 * b->order[i] + axis] < split) {
                i++;
            } else {
                int32_t tmp = b->order[i];
                b->order[i] = b->order[j];
                b->order[j] = tmp;
                j--;
            }
        }
        mid = i - first;
        if (mid == 0 || mid == count)
            mid = count / 2; /* all centroids coincide along the axis */
    }
    n->first = next;
    n->count = 0;
    next += 2;
    next = build(b, cen, n->first, first, mid, next, depth + 1);
    next = build(b, cen, b->nodes[ni].first + 1, first + mid, count - mid, next, depth + 1);
    return next;
}

dtx_bvh *dtx_bvh_build(const double *X, const int32_t *F, int32_t nf)
{
    dtx_bvh *b = calloc(1, sizeof *b);
    double *cen = NULL;
    if (!b)
        return NULL;
    b->X = X;
    b->F = F;
    b->nprim = nf;
    /* A binary tree with leaves of >= 1 primitive has < 2 n nodes. */
    b->nodes = dtx_alloc((size_t)(nf > 0 ? 2 * (size_t)nf : 1), sizeof *b->nodes, 0);
    b->order = dtx_alloc((size_t)nf, sizeof *b->order, 0);
    cen = dtx_alloc((size_t)nf, 3 * sizeof *cen, 0);
    if (!b->nodes || !b->order || !cen) {
        free(cen);
        dtx_bvh_free(&b);
        return NULL;
    }
    for (int32_t p = 0; p < nf; p++) {
        b->order[p] = p;
        if (F) {
            for (int k = 0; k < 3; k++)
                cen[3 * p + k] = (X[3 * F[3 * p] + k] + X[3 * F[3 * p + 1] + k] +
                                  X[3 * F[3 * p + 2] + k]) / 3.0;
        } else {
            for (int k = 0; k < 3; k++)
                cen[3 * p + k] = X[3 * p + k];
        }
    }
    if (nf > 0)
        b->nnodes = build(b, cen, 0, 0, nf, 1, 0);
    free(cen);
    return b;
}

void dtx_bvh_free(dtx_bvh **bvh)
{
    if (!bvh || !*bvh)
        return;
    free((*bvh)->nodes);
    free((*bvh)->order);
    free(*bvh);
    *bvh = NULL;
}

static double box_dist2(const bvh_node *n, const double *p)
{
    double d2 = 0.0;
    for (int k = 0; k < 3; k++) {
        double d = p[k] < n->lo[k] ? n->lo[k] - p[k] : (p[k] > n->hi[k] ? p[k] - n->hi[k] : 0.0);
        d2 += d * d;
    }
    return d2;
}

double dtx_closest_point_triangle(const double p[3], const double a[3], const double b[3],
                                  const double c[3], double out[3])
{
    /* Voronoi-region walk (Ericson, Real-Time Collision Detection, 5.1.5). */
    double ab[3], ac[3], ap[3], bp[3], cp[3], d1, d2, d3, d4, d5, d6, va, vb, vc, v, w, den;
    for (int k = 0; k < 3; k++) {
        ab[k] = b[k] - a[k];
        ac[k] = c[k] - a[k];
        ap[k] = p[k] - a[k];
    }
    d1 = ab[0] * ap[0] + ab[1] * ap[1] + ab[2] * ap[2];
    d2 = ac[0] * ap[0] + ac[1] * ap[1] + ac[2] * ap[2];
    if (d1 <= 0.0 && d2 <= 0.0) {
        for (int k = 0; k < 3; k++)
            out[k] = a[k];
        goto done;
    }
    for (int k = 0; k < 3; k++)
        bp[k] = p[k] - b[k];
    d3 = ab[0] * bp[0] + ab[1] * bp[1] + ab[2] * bp[2];
    d4 = ac[0] * bp[0] + ac[1] * bp[1] + ac[2] * bp[2];
    if (d3 >= 0.0 && d4 <= d3) {
        for (int k = 0; k < 3; k++)
            out[k] = b[k];
        goto done;
    }
    vc = d1 * d4 - d3 * d2;
    if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
        v = d1 / (d1 - d3);
        for (int k = 0; k < 3; k++)
            out[k] = a[k] + v * ab[k];
        goto done;
    }
    for (int k = 0; k < 3; k++)
        cp[k] = p[k] - c[k];
    d5 = ab[0] * cp[0] + ab[1] * cp[1] + ab[2] * cp[2];
    d6 = ac[0] * cp[0] + ac[1] * cp[1] + ac[2] * cp[2];
    if (d6 >= 0.0 && d5 <= d6) {
        for (int k = 0; k < 3; k++)
            out[k] = c[k];
        goto done;
    }
    vb = d5 * d2 - d1 * d6;
    if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
        w = d2 / (d2 - d6);
        for (int k = 0; k < 3; k++)
            out[k] = a[k] + w * ac[k];
        goto done;
    }
    va = d3 * d6 - d5 * d4;
    if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        for (int k = 0; k < 3; k++)
            out[k] = b[k] + w * (c[k] - b[k]);
        goto done;
    }
    den = va + vb + vc;
    if (den == 0.0) { /* degenerate triangle: nearest vertex */
        for (int k = 0; k < 3; k++)
            out[k] = a[k];
        goto done;
    }
    v = vb / den;
    w = vc / den;
    for (int k = 0; k < 3; k++)
        out[k] = a[k] + ab[k] * v + ac[k] * w;
done:
    return (p[0] - out[0]) * (p[0] - out[0]) + (p[1] - out[1]) * (p[1] - out[1]) +
           (p[2] - out[2]) * (p[2] - out[2]);
}

/* Squared distance from p to primitive prim, its closest point in pt. */
static double prim_dist2(const dtx_bvh *b, const double p[3], int32_t prim, double pt[3])
{
    if (b->F) {
        const int32_t *t = b->F + 3 * prim;
        return dtx_closest_point_triangle(p, b->X + 3 * t[0], b->X + 3 * t[1], b->X + 3 * t[2],
                                          pt);
    }
    for (int k = 0; k < 3; k++)
        pt[k] = b->X[3 * prim + k];
    return (p[0] - pt[0]) * (p[0] - pt[0]) + (p[1] - pt[1]) * (p[1] - pt[1]) +
           (p[2] - pt[2]) * (p[2] - pt[2]);
}

int32_t dtx_bvh_closest(const dtx_bvh *b, const double p[3], double max_dist,
                        dtx_bvh_filter filter, const void *ctx, double closest[3], double *d2out)
{
    return dtx_bvh_closest_from(b, p, max_dist, filter, ctx, -1, closest, d2out);
}

int32_t dtx_bvh_closest_from(const dtx_bvh *b, const double p[3], double max_dist,
                             dtx_bvh_filter filter, const void *ctx, int32_t hint,
                             double closest[3], double *d2out)
{
    /* Each stacked node carries its box distance, computed once when it
     * was pushed: a node is pushed only when its box is within the best
     * distance, and skipped when popped if the best has since dropped
     * below it (equal distances stay in for the tie rule). */
    struct {
        int32_t node;
        double d2;
    } stack[2 * MAX_DEPTH + 8];
    int sp = 0;
    int32_t best = -1;
    double best_d2 = isfinite(max_dist) ? max_dist * max_dist : INFINITY;
    double best_pt[3] = {0, 0, 0};
    if (b->nprim == 0)
        return -1;
    /* The hint taken as a first candidate, on the same terms as the
     * traversal's (strictly inside max_dist): every primitive at least as
     * close still lies in a box no farther than it, so the traversal below
     * visits them all and the tie rule picks the same one. */
    if (hint >= 0 && hint < b->nprim && (!filter || filter(ctx, hint))) {
        double pt[3], d2 = prim_dist2(b, p, hint, pt);
        if (d2 < best_d2) {
            best_d2 = d2;
            best = hint;
            for (int k = 0; k < 3; k++)
                best_pt[k] = pt[k];
        }
    }
    stack[sp].node = 0;
    stack[sp++].d2 = box_dist2(&b->nodes[0], p);
    while (sp > 0) {
        const bvh_node *n;
        --sp;
        if (stack[sp].d2 > best_d2)
            continue;
        n = &b->nodes[stack[sp].node];
        if (n->count > 0) {
            for (int32_t i = n->first; i < n->first + n->count; i++) {
                int32_t prim = b->order[i];
                double pt[3], d2;
                if (filter && !filter(ctx, prim))
                    continue;
                d2 = prim_dist2(b, p, prim, pt);
                /* Ties go to the lower index so results never depend on
                 * traversal order. */
                if (d2 < best_d2 || (d2 == best_d2 && best >= 0 && prim < best)) {
                    best_d2 = d2;
                    best = prim;
                    for (int k = 0; k < 3; k++)
                        best_pt[k] = pt[k];
                }
            }
        } else {
            int32_t l = n->first, r = n->first + 1;
            double dl = box_dist2(&b->nodes[l], p), dr = box_dist2(&b->nodes[r], p);
            /* The farther child goes in first so the nearer one is visited
             * first. */
            int32_t c0 = dl <= dr ? r : l, c1 = dl <= dr ? l : r;
            double d0 = dl <= dr ? dr : dl, d1 = dl <= dr ? dl : dr;
            if (d0 <= best_d2) {
                stack[sp].node = c0;
                stack[sp++].d2 = d0;
            }
            if (d1 <= best_d2) {
                stack[sp].node = c1;
                stack[sp++].d2 = d1;
            }
        }
    }
    if (best >= 0) {
        if (closest)
            for (int k = 0; k < 3; k++)
                closest[k] = best_pt[k];
        if (d2out)
            *d2out = best_d2;
    }
    return best;
}

const int32_t *dtx_bvh_leaf_order(const dtx_bvh *b)
{
    return b->order;
}

/* ------------------------------------------------------------------ */
/* Ray casting                                                         */
/* ------------------------------------------------------------------ */

/* Entry parameter of the ray o + t d into the node's box, clipped to
 * [tmin, tmax]; INFINITY when the ray misses it there (slab test; inv = 1/d
 * per axis, +-inf for a zero component). */
static double box_entry(const bvh_node *n, const double *o, const double *inv, double tmin,
                        double tmax)
{
    for (int k = 0; k < 3; k++) {
        double t0 = (n->lo[k] - o[k]) * inv[k], t1 = (n->hi[k] - o[k]) * inv[k];
        if (t0 > t1) {
            double tmp = t0;
            t0 = t1;
            t1 = tmp;
        }
        /* 0 * inf (origin on a slab plane of a zero direction) is NaN:
         * treat it as inside that slab. */
        if (t0 == t0 && t0 > tmin)
            tmin = t0;
        if (t1 == t1 && t1 < tmax)
            tmax = t1;
        if (tmin > tmax)
            return INFINITY;
    }
    return tmin;
}

/* Moller-Trumbore: t of the hit of the ray with triangle (a, b, c) and the
 * barycentric coordinates (u of b, v of c); 0 when there is none (parallel
 * or outside the triangle). */
static int ray_triangle(const double *o, const double *d, const double *a, const double *b,
                        const double *c, double *t, double *u, double *v)
{
    double e1[3], e2[3], p[3], q[3], s[3], det, inv;
    for (int k = 0; k < 3; k++) {
        e1[k] = b[k] - a[k];
        e2[k] = c[k] - a[k];
        s[k] = o[k] - a[k];
    }
    p[0] = d[1] * e2[2] - d[2] * e2[1];
    p[1] = d[2] * e2[0] - d[0] * e2[2];
    p[2] = d[0] * e2[1] - d[1] * e2[0];
    det = e1[0] * p[0] + e1[1] * p[1] + e1[2] * p[2];
    if (det == 0.0)
        return 0;
    inv = 1.0 / det;
    *u = (s[0] * p[0] + s[1] * p[1] + s[2] * p[2]) * inv;
    if (!(*u >= 0.0 && *u <= 1.0))
        return 0;
    q[0] = s[1] * e1[2] - s[2] * e1[1];
    q[1] = s[2] * e1[0] - s[0] * e1[2];
    q[2] = s[0] * e1[1] - s[1] * e1[0];
    *v = (d[0] * q[0] + d[1] * q[1] + d[2] * q[2]) * inv;
    if (!(*v >= 0.0 && *u + *v <= 1.0))
        return 0;
    *t = (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) * inv;
    return 1;
}

int32_t dtx_bvh_raycast(const dtx_bvh *b, const double o[3], const double d[3], double tmin,
                        double tmax, dtx_bvh_filter filter, const void *ctx, double *tout,
                        double bary[3])
{
    int32_t stack[2 * MAX_DEPTH + 8];
    int sp = 0;
    int32_t best = -1;
    double best_t = tmax, best_u = 0.0, best_v = 0.0, inv[3];
    if (b->nprim == 0 || !b->F)
        return -1;
    for (int k = 0; k < 3; k++)
        inv[k] = 1.0 / d[k];
    if (box_entry(&b->nodes[0], o, inv, tmin, tmax) == INFINITY)
        return -1;
    stack[sp++] = 0;
    while (sp > 0) {
        const bvh_node *n = &b->nodes[stack[--sp]];
        if (box_entry(n, o, inv, tmin, best_t) == INFINITY)
            continue;
        if (n->count > 0) {
            for (int32_t i = n->first; i < n->first + n->count; i++) {
                int32_t prim = b->order[i];
                const int32_t *f = b->F + 3 * prim;
                const double *x0 = b->X + 3 * f[0], *x1 = b->X + 3 * f[1], *x2 = b->X + 3 * f[2];
                double t, u, v;
                /* Ties in t go to the lower index (best_t starts at tmax,
                 * which is excluded). */
                if (!ray_triangle(o, d, x0, x1, x2, &t, &u, &v) || !(t > tmin) ||
                    !(t < best_t || (t == best_t && best >= 0 && prim < best)))
                    continue;
                if (filter && !filter(ctx, prim))
                    continue;
                best = prim;
                best_t = t;
                best_u = u;
                best_v = v;
            }
        } else {
            int32_t l = n->first, r = n->first + 1;
            double tl = box_entry(&b->nodes[l], o, inv, tmin, best_t);
            double tr = box_entry(&b->nodes[r], o, inv, tmin, best_t);
            /* The nearer child is visited first. */
            if (tl <= tr) {
                if (tr != INFINITY)
                    stack[sp++] = r;
                if (tl != INFINITY)
                    stack[sp++] = l;
            } else {
                if (tl != INFINITY)
                    stack[sp++] = l;
                stack[sp++] = r;
            }
        }
    }
    if (best >= 0) {
        if (tout)
            *tout = best_t;
        if (bary) {
            bary[0] = 1.0 - best_u - best_v;
            bary[1] = best_u;
            bary[2] = best_v;
        }
    }
    return best;
}
