/* mesh.c: allocation, validation and simple queries on dtx_mesh. */
#include "mesh.h"

#include <math.h>
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

static int32_t find_root(int32_t *parent, int32_t i)
{
    while (parent[i] != i) {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    return i;
}

int32_t dtx_mesh_components(const dtx_mesh *m, int32_t *comp)
{
    int32_t *parent = dtx_alloc((size_t)m->nv, sizeof *parent, 0);
    int32_t *label = dtx_alloc((size_t)m->nv, sizeof *label, 0);
    int32_t n = 0;
    if (!parent || !label) {
        free(parent);
        free(label);
        return -1;
    }
    for (int32_t i = 0; i < m->nv; i++)
        parent[i] = i;
    for (int32_t f = 0; f < m->nf; f++)
        for (int k = 0; k < 2; k++) {
            int32_t a = find_root(parent, m->F[3 * f + k]);
            int32_t b = find_root(parent, m->F[3 * f + k + 1]);
            if (a != b)
                parent[a > b ? a : b] = a > b ? b : a;
        }
    for (int32_t i = 0; i < m->nv; i++)
        label[i] = -1;
    for (int32_t i = 0; i < m->nv; i++) {
        int32_t r = find_root(parent, i);
        if (label[r] < 0)
            label[r] = n++;
        comp[i] = label[r];
    }
    free(parent);
    free(label);
    return n;
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
    for (int32_t f = 0; f < nf; f++) {
        double c[3];
        face_cross(X, F + 3 * f, c);
        for (int j = 0; j < 3; j++)
            for (int k = 0; k < 3; k++)
                N[3 * F[3 * f + j] + k] += c[k];
    }
    for (int32_t i = 0; i < nv; i++) {
        double *n = N + 3 * i;
        double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (len > 0)
            for (int k = 0; k < 3; k++)
                n[k] /= len;
    }
}
