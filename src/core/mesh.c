/* mesh.c: allocation, validation and simple queries on dtx_mesh. */
#include "mesh.h"

#include "graph.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

dtx_status dtx_mesh_alloc(dtx_mesh *m, int32_t nv, int32_t nf, dtx_error *err)
{
    memset(m, 0, sizeof *m);
    if (nv < 0 || nf < 0)
        return dtx_seterr(err, DTX_EINVAL, "negative mesh size (%d vertices, %d faces)",
                          (int)nv, (int)nf);
    m->V = dtx_alloc((size_t)nv, 3 * sizeof(double), 1);
    m->F = dtx_alloc((size_t)nf, 3 * sizeof(int32_t), 1);
    if (!m->V || !m->F) {
        dtx_mesh_free(m);
        return dtx_seterr(err, DTX_ENOMEM, "cannot allocate a mesh of %d vertices and %d faces",
                          (int)nv, (int)nf);
    }
    m->nv = nv;
    m->nf = nf;
    return DTX_OK;
}

void dtx_mesh_free(dtx_mesh *m)
{
    if (!m)
        return;
    free(m->V);
    free(m->F);
    memset(m, 0, sizeof *m);
}

dtx_status dtx_mesh_copy(const dtx_mesh *src, dtx_mesh *dst, dtx_error *err)
{
    dtx_status st = dtx_mesh_alloc(dst, src->nv, src->nf, err);
    if (st != DTX_OK)
        return st;
    memcpy(dst->V, src->V, (size_t)src->nv * 3 * sizeof(double));
    memcpy(dst->F, src->F, (size_t)src->nf * 3 * sizeof(int32_t));
    return DTX_OK;
}

dtx_status dtx_mesh_validate(const dtx_mesh *m, const char *what, dtx_error *err)
{
    if (m->nv < 3)
        return dtx_seterr(err, DTX_EMESH, "%s: mesh has %d vertices (at least 3 needed)", what,
                          (int)m->nv);
    if (m->nf < 1)
        return dtx_seterr(err, DTX_EMESH, "%s: mesh has no faces", what);
    for (int32_t i = 0; i < m->nv; i++)
        for (int k = 0; k < 3; k++)
            if (!isfinite(m->V[3 * i + k]))
                return dtx_seterr(err, DTX_ENONFINITE,
                                  "%s: vertex %d (0-based) has a non-finite coordinate", what,
                                  (int)i);
    for (int32_t f = 0; f < m->nf; f++) {
        const int32_t *t = m->F + 3 * f;
        for (int k = 0; k < 3; k++)
            if (t[k] < 0 || t[k] >= m->nv)
                return dtx_seterr(err, DTX_ERANGE,
                                  "%s: face %d (0-based) has vertex index %d out of range "
                                  "[0, %d)",
                                  what, (int)f, (int)t[k], (int)m->nv);
        if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2])
            return dtx_seterr(err, DTX_EMESH,
                              "%s: face %d (0-based) repeats a vertex (%d %d %d)", what, (int)f,
                              (int)t[0], (int)t[1], (int)t[2]);
    }
    return DTX_OK;
}

int32_t dtx_mesh_components(const dtx_mesh *m, int32_t *comp)
{
    return dtx__tri_components(m->F, m->nf, m->nv, DTX__ISOLATED_OWN, comp);
}

int32_t dtx_mesh_count_unreferenced(const dtx_mesh *m)
{
    unsigned char *used = dtx_alloc((size_t)m->nv, 1, 1);
    int32_t n = 0;
    if (!used)
        return -1;
    for (int64_t i = 0; i < 3 * (int64_t)m->nf; i++)
        used[m->F[i]] = 1;
    for (int32_t i = 0; i < m->nv; i++)
        n += !used[i];
    free(used);
    return n;
}

double dtx_bbox_diagonal(const double *X, int32_t n)
{
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    if (n <= 0)
        return 0.0;
    for (int32_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            double x = X[3 * i + k];
            lo[k] = x < lo[k] ? x : lo[k];
            hi[k] = x > hi[k] ? x : hi[k];
        }
    return sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                (hi[2] - lo[2]) * (hi[2] - lo[2]));
}

double dtx_rms_extent(const double *X, int32_t n)
{
    double c[3] = {0, 0, 0}, s2 = 0;
    if (n <= 0)
        return 0.0;
    for (int32_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++)
            c[k] += X[3 * (size_t)i + k];
    for (int k = 0; k < 3; k++)
        c[k] /= n;
    for (int32_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            double d = X[3 * (size_t)i + k] - c[k];
            s2 += d * d;
        }
    return 2.0 * sqrt(3.0 * s2 / n);
}

double dtx_mesh_mean_edge(const dtx_mesh *m)
{
    double sum = 0;
    if (m->nf < 1)
        return 0;
    for (int32_t f = 0; f < m->nf; f++)
        for (int e = 0; e < 3; e++) {
            const double *a = m->V + 3 * (size_t)m->F[3 * (size_t)f + e];
            const double *b = m->V + 3 * (size_t)m->F[3 * (size_t)f + (e + 1) % 3];
            sum += sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                        (a[2] - b[2]) * (a[2] - b[2]));
        }
    return sum / (3.0 * m->nf);
}

static void face_cross(const double *X, const int32_t *t, double *c)
{
    const double *a = X + 3 * t[0], *b = X + 3 * t[1], *d = X + 3 * t[2];
    double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    double e2[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
    c[0] = e1[1] * e2[2] - e1[2] * e2[1];
    c[1] = e1[2] * e2[0] - e1[0] * e2[2];
    c[2] = e1[0] * e2[1] - e1[1] * e2[0];
}

void dtx_face_normals(const double *X, const int32_t *F, int32_t nf, double *N)
{
    for (int32_t f = 0; f < nf; f++) {
        double c[3], len;
        face_cross(X, F + 3 * f, c);
        len = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
        for (int k = 0; k < 3; k++)
            N[3 * f + k] = len > 0 ? c[k] / len : 0.0;
    }
}

void dtx_vertex_normals(const double *X, int32_t nv, const int32_t *F, int32_t nf, double *N)
{
    memset(N, 0, (size_t)nv * 3 * sizeof *N);
    double cmax = 0; /* the largest face's |cross product| (twice its area) */
    for (int32_t f = 0; f < nf; f++) {
        double c[3];
        face_cross(X, F + 3 * f, c);
        double l = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
        if (l > cmax)
            cmax = l;
        for (int j = 0; j < 3; j++)
            for (int k = 0; k < 3; k++)
                N[3 * F[3 * f + j] + k] += c[k];
    }
    /* A sum of face normals that cancels leaves rounding noise (a few
     * machine epsilons of its faces' size), whose direction is chance:
     * normalising it would give a unit normal that one more rounding
     * turns into another, or into none.  A sum under DTX_NORMAL_NOISE
     * of the largest face's is taken as no normal (zero). */
    double floor = DTX_NORMAL_NOISE * sqrt(cmax);
    for (int32_t i = 0; i < nv; i++) {
        double *n = N + 3 * i;
        double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (len > floor && len > 0)
            for (int k = 0; k < 3; k++)
                n[k] /= len;
        else
            n[0] = n[1] = n[2] = 0;
    }
}

/* ------------------------------------------------------------------ */
/* Inspection: what a valid mesh can still hold                        */
/* ------------------------------------------------------------------ */

typedef struct {
    double x[3];
    int32_t v;
} pos_key;

typedef struct {
    int32_t a, b; /* a < b */
    int32_t face;
} edge_key;

typedef struct {
    int32_t v[3]; /* sorted */
    int32_t face;
} face_key;

static int cmp_pos(const void *pa, const void *pb)
{
    const pos_key *a = pa, *b = pb;
    for (int k = 0; k < 3; k++)
        if (a->x[k] != b->x[k])
            return a->x[k] < b->x[k] ? -1 : 1;
    return (a->v > b->v) - (a->v < b->v);
}

static int cmp_edge(const void *pa, const void *pb)
{
    const edge_key *a = pa, *b = pb;
    if (a->a != b->a)
        return a->a < b->a ? -1 : 1;
    if (a->b != b->b)
        return a->b < b->b ? -1 : 1;
    return (a->face > b->face) - (a->face < b->face);
}

static int cmp_face(const void *pa, const void *pb)
{
    const face_key *a = pa, *b = pb;
    for (int k = 0; k < 3; k++)
        if (a->v[k] != b->v[k])
            return a->v[k] < b->v[k] ? -1 : 1;
    return (a->face > b->face) - (a->face < b->face);
}

static void sort3(const int32_t *t, int32_t *s)
{
    int32_t a = t[0], b = t[1], c = t[2], x;
    if (a > b)
        x = a, a = b, b = x;
    if (b > c)
        x = b, b = c, c = x;
    if (a > b)
        x = a, a = b, b = x;
    s[0] = a;
    s[1] = b;
    s[2] = c;
}

/* Degenerate faces: zero area or height below DTX_MESH_THIN_RATIO of the
 * longest edge. */
static void inspect_shape(const dtx_mesh *m, dtx_mesh_report *rep)
{
    rep->thinnest = INFINITY;
    for (int32_t f = 0; f < m->nf; f++) {
        const int32_t *t = m->F + 3 * (size_t)f;
        const double *p = m->V + 3 * (size_t)t[0], *q = m->V + 3 * (size_t)t[1],
                     *r = m->V + 3 * (size_t)t[2];
        double e[3][3], c[3], len[3], longest, ratio; /* longest: squared length */
        for (int k = 0; k < 3; k++) {
            e[0][k] = q[k] - p[k];
            e[1][k] = r[k] - p[k];
            e[2][k] = r[k] - q[k];
        }
        for (int i = 0; i < 3; i++)
            len[i] = e[i][0] * e[i][0] + e[i][1] * e[i][1] + e[i][2] * e[i][2];
        longest = len[0] > len[1] ? len[0] : len[1];
        longest = len[2] > longest ? len[2] : longest;
        face_cross(m->V, t, c);
        ratio = longest > 0 ? sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]) / longest : 0.0;
        rep->thinnest = ratio < rep->thinnest ? ratio : rep->thinnest;
        if (ratio <= DTX_MESH_THIN_RATIO && rep->degenerate++ == 0)
            rep->first_degenerate = f;
    }
    if (m->nf == 0)
        rep->thinnest = 0.0;
}

/* Vertices in a face that share their exact position with another one. */
static dtx_status inspect_positions(const dtx_mesh *m, const unsigned char *used,
                                    dtx_mesh_report *rep)
{
    pos_key *k = dtx_alloc((size_t)m->nv, sizeof *k, 0);
    int32_t n = 0;
    if (!k)
        return DTX_ENOMEM;
    for (int32_t v = 0; v < m->nv; v++)
        if (used[v]) {
            memcpy(k[n].x, m->V + 3 * (size_t)v, sizeof k[n].x);
            k[n++].v = v;
        }
    qsort(k, (size_t)n, sizeof *k, cmp_pos);
    /* Within a run of equal positions, every vertex but the lowest (the
     * first of the run: ties sort by index) is a duplicate of it. */
    for (int32_t i = 1, lo = 0; i < n; i++) {
        /* Compared as numbers, so -0.0 and 0.0 are the same position. */
        if (k[i].x[0] != k[lo].x[0] || k[i].x[1] != k[lo].x[1] || k[i].x[2] != k[lo].x[2]) {
            lo = i;
            continue;
        }
        if (rep->duplicate_positions++ == 0 || k[i].v < rep->dup_vertex[1]) {
            rep->dup_vertex[0] = k[lo].v;
            rep->dup_vertex[1] = k[i].v;
        }
    }
    free(k);
    return DTX_OK;
}

/* Non-manifold edges and duplicate faces. */
static dtx_status inspect_edges_faces(const dtx_mesh *m, dtx_mesh_report *rep)
{
    size_t ne = 3 * (size_t)m->nf;
    edge_key *e = dtx_alloc(ne, sizeof *e, 0);
    face_key *fk = dtx_alloc((size_t)m->nf, sizeof *fk, 0);
    if (!e || !fk) {
        free(e);
        free(fk);
        return DTX_ENOMEM;
    }
    for (int32_t f = 0; f < m->nf; f++) {
        const int32_t *t = m->F + 3 * (size_t)f;
        for (int j = 0; j < 3; j++) {
            int32_t a = t[j], b = t[(j + 1) % 3];
            edge_key *x = &e[3 * (size_t)f + (size_t)j];
            x->a = a < b ? a : b;
            x->b = a < b ? b : a;
            x->face = f;
        }
        sort3(t, fk[f].v);
        fk[f].face = f;
    }
    qsort(e, ne, sizeof *e, cmp_edge);
    for (size_t i = 0; i < ne;) {
        size_t j = i + 1;
        while (j < ne && e[j].a == e[i].a && e[j].b == e[i].b)
            j++;
        /* Edges are sorted, so the first non-manifold one found is the
         * lowest. */
        if (j - i > 2 && rep->nonmanifold_edges++ == 0) {
            rep->nonmanifold_edge[0] = e[i].a;
            rep->nonmanifold_edge[1] = e[i].b;
            rep->nonmanifold_faces = (int32_t)(j - i);
        }
        i = j;
    }
    qsort(fk, (size_t)m->nf, sizeof *fk, cmp_face);
    for (int32_t i = 1, lo = 0; i < m->nf; i++) {
        if (memcmp(fk[i].v, fk[lo].v, sizeof fk[i].v) != 0) {
            lo = i;
            continue;
        }
        if (rep->duplicate_faces++ == 0 || fk[i].face < rep->dup_face[1]) {
            rep->dup_face[0] = fk[lo].face;
            rep->dup_face[1] = fk[i].face;
        }
    }
    free(e);
    free(fk);
    return DTX_OK;
}

dtx_status dtx_mesh_inspect(const dtx_mesh *m, dtx_mesh_report *rep, dtx_error *err)
{
    unsigned char *used = dtx_alloc((size_t)m->nv, 1, 1);
    int32_t *comp = dtx_alloc((size_t)m->nv, sizeof *comp, 0);
    int32_t ncomp;
    dtx_status st = DTX_OK;
    memset(rep, 0, sizeof *rep);
    rep->other_component = rep->first_unreferenced = rep->first_degenerate = -1;
    rep->dup_vertex[0] = rep->dup_vertex[1] = -1;
    rep->nonmanifold_edge[0] = rep->nonmanifold_edge[1] = -1;
    rep->dup_face[0] = rep->dup_face[1] = -1;
    if (!used || !comp)
        goto nomem;

    /* Components of the vertices in faces: dtx_mesh_components gives every
     * vertex in no face a component of its own, which does not count. */
    for (int64_t i = 0; i < 3 * (int64_t)m->nf; i++)
        used[m->F[i]] = 1;
    if ((ncomp = dtx_mesh_components(m, comp)) < 0)
        goto nomem;
    for (int32_t v = 0; v < m->nv; v++) {
        if (!used[v]) {
            if (rep->unreferenced++ == 0)
                rep->first_unreferenced = v;
        } else if (m->nf > 0 && rep->other_component < 0 && comp[v] != comp[m->F[0]]) {
            rep->other_component = v;
        }
    }
    rep->components = ncomp - rep->unreferenced;

    inspect_shape(m, rep);
    if (inspect_positions(m, used, rep) != DTX_OK || inspect_edges_faces(m, rep) != DTX_OK)
        goto nomem;
    goto done;

nomem:
    memset(rep, 0, sizeof *rep);
    st = dtx_seterr(err, DTX_ENOMEM, "out of memory inspecting a mesh of %d vertices and %d faces",
                    (int)m->nv, (int)m->nf);
done:
    free(used);
    free(comp);
    return st;
}

/* Appends a note to buf at *len (printf-style), with "; " before every
 * note but the first, and counts it; truncates safely. */
static void add_note(char *buf, size_t n, size_t *len, int *count, const char *fmt, ...)
{
    va_list ap;
    int w;
    if ((*count)++ > 0 && *len + 1 < n) {
        w = snprintf(buf + *len, n - *len, "; ");
        *len += w > 0 ? (size_t)w : 0;
        if (*len >= n)
            *len = n - 1;
    }
    if (*len + 1 >= n)
        return; /* full: counted, not written */
    va_start(ap, fmt);
    w = vsnprintf(buf + *len, n - *len, fmt, ap);
    va_end(ap);
    *len += w > 0 ? (size_t)w : 0;
    if (*len >= n)
        *len = n - 1;
}

int dtx_mesh_report_notes(const dtx_mesh_report *rep, char *buf, size_t n)
{
    size_t len = 0;
    int count = 0;
    if (n == 0)
        return 0;
    buf[0] = '\0';
    if (rep->unreferenced > 0)
        add_note(buf, n, &len, &count, "%d %s in no triangle (vertex %d first)",
                 (int)rep->unreferenced, rep->unreferenced == 1 ? "vertex" : "vertices",
                 (int)rep->first_unreferenced);
    if (rep->degenerate > 0)
        add_note(buf, n, &len, &count,
                 "%d %s of zero area or thinner than %g of the longest edge (face %d first; "
                 "thinnest height/edge ratio %.3g)",
                 (int)rep->degenerate, rep->degenerate == 1 ? "triangle" : "triangles",
                 DTX_MESH_THIN_RATIO, (int)rep->first_degenerate, rep->thinnest);
    if (rep->duplicate_positions > 0)
        add_note(buf, n, &len, &count,
                 "%d %s at exactly the position of another vertex (vertices %d and %d first)",
                 (int)rep->duplicate_positions,
                 rep->duplicate_positions == 1 ? "vertex" : "vertices", (int)rep->dup_vertex[0],
                 (int)rep->dup_vertex[1]);
    if (rep->nonmanifold_edges > 0)
        add_note(buf, n, &len, &count,
                 "%d non-manifold %s (edge %d-%d first, shared by %d triangles)",
                 (int)rep->nonmanifold_edges, rep->nonmanifold_edges == 1 ? "edge" : "edges",
                 (int)rep->nonmanifold_edge[0], (int)rep->nonmanifold_edge[1],
                 (int)rep->nonmanifold_faces);
    if (rep->duplicate_faces > 0)
        add_note(buf, n, &len, &count,
                 "%d %s on the same three vertices as another (faces %d and %d first)",
                 (int)rep->duplicate_faces, rep->duplicate_faces == 1 ? "triangle" : "triangles",
                 (int)rep->dup_face[0], (int)rep->dup_face[1]);
    return count;
}
