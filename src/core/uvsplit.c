/* uvsplit.c: a mesh split along a UV seam and a material boundary (uvsplit.h). */
#include "uvsplit.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void dtx_uvsplit_free(dtx_uvsplit *s)
{
    if (!s)
        return;
    dtx_mesh_free(&s->mesh);
    free(s->uv);
    free(s->normals);
    free(s->material);
    free(s->orig);
    memset(s, 0, sizeof *s);
}

dtx_status dtx_uvsplit_make(const dtx_mesh *m, int materials, dtx_uvsplit *out, dtx_error *err)
{
    const int32_t nv = m->nv, nf = m->nf;
    double c[3] = {0, 0, 0}, ylo = INFINITY, yhi = -INFINITY, *u = NULL, *N = NULL;
    int32_t *key_of = NULL, *slot = NULL, n = 0, *first = NULL;
    dtx_status st = DTX_OK;
    const double pi = 3.14159265358979323846;

    memset(out, 0, sizeof *out);
    if (materials != 1 && materials != 2)
        return dtx_seterr(err, DTX_EINVAL, "uvsplit: materials must be 1 or 2 (got %d)",
                          materials);
    /* Corner keys: (vertex, wrapped, material) -> 4 slots per vertex. */
    u = malloc((size_t)nv * sizeof *u);
    N = calloc((size_t)nv * 3, sizeof *N);
    slot = malloc((size_t)nv * 4 * sizeof *slot);
    first = calloc((size_t)nv, sizeof *first);
    key_of = malloc((size_t)nf * 3 * sizeof *key_of);
    out->material = malloc((size_t)(nf > 0 ? nf : 1) * sizeof *out->material);
    if (!u || !N || !slot || !first || !key_of || !out->material) {
        st = dtx_seterr(err, DTX_ENOMEM, "uvsplit: out of memory");
        goto done;
    }
    for (int32_t i = 0; i < nv; i++)
        for (int k = 0; k < 3; k++)
            c[k] += m->V[3 * (size_t)i + k] / nv;
    for (int32_t i = 0; i < nv; i++) {
        const double *p = m->V + 3 * (size_t)i;
        u[i] = atan2(p[2] - c[2], p[0] - c[0]) / (2 * pi) + 0.5;
        ylo = p[1] < ylo ? p[1] : ylo;
        yhi = p[1] > yhi ? p[1] : yhi;
    }
    /* Area-weighted normals. */
    for (int32_t f = 0; f < nf; f++) {
        const int32_t *t = m->F + 3 * (size_t)f;
        const double *a = m->V + 3 * (size_t)t[0], *b = m->V + 3 * (size_t)t[1],
                     *d = m->V + 3 * (size_t)t[2];
        double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]},
               e2[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
        double x[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                       e1[0] * e2[1] - e1[1] * e2[0]};
        for (int j = 0; j < 3; j++)
            for (int k = 0; k < 3; k++)
                N[3 * (size_t)t[j] + k] += x[k];
    }
    for (int32_t i = 0; i < nv; i++) {
        double *q = N + 3 * (size_t)i, l = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
        for (int k = 0; k < 3; k++)
            q[k] = l > 0 ? q[k] / l : (k == 1);
    }
    /* Keys per corner: a face whose u spans more than half the circle
     * crosses the seam, and its corners with u < 0.5 wrap to u + 1. */
    for (int32_t f = 0; f < nf; f++) {
        const int32_t *t = m->F + 3 * (size_t)f;
        double lo = fmin(u[t[0]], fmin(u[t[1]], u[t[2]]));
        double hi = fmax(u[t[0]], fmax(u[t[1]], u[t[2]]));
        double cy = (m->V[3 * (size_t)t[0] + 1] + m->V[3 * (size_t)t[1] + 1] +
                     m->V[3 * (size_t)t[2] + 1]) / 3;
        int mat = materials == 2 && cy > c[1];
        out->material[f] = mat;
        for (int j = 0; j < 3; j++) {
            int wrap = hi - lo > 0.5 && u[t[j]] < 0.5;
            key_of[3 * (size_t)f + j] = 4 * t[j] + 2 * wrap + mat;
        }
    }
    /* Numbering: a vertex's first key keeps its index; later keys are new
     * vertices in order of first appearance. */
    for (size_t k = 0; k < 4 * (size_t)nv; k++)
        slot[k] = -1;
    n = nv;
    for (size_t k = 0; k < 3 * (size_t)nf; k++) {
        int32_t key = key_of[k], v = key / 4;
        if (slot[key] >= 0)
            continue;
        if (!first[v]) {
            first[v] = 1;
            slot[key] = v;
        } else {
            slot[key] = n++;
        }
    }
    st = dtx_mesh_alloc(&out->mesh, n, nf, err);
    if (st != DTX_OK)
        goto done;
    out->uv = malloc((size_t)n * 2 * sizeof *out->uv);
    out->normals = malloc((size_t)n * 3 * sizeof *out->normals);
    out->orig = malloc((size_t)n * sizeof *out->orig);
    if (!out->uv || !out->normals || !out->orig) {
        st = dtx_seterr(err, DTX_ENOMEM, "uvsplit: out of memory");
        goto done;
    }
    for (int32_t i = 0; i < nv; i++) { /* unreferenced vertices stay as they are */
        out->orig[i] = i;
        out->uv[2 * (size_t)i] = u[i];
        out->uv[2 * (size_t)i + 1] = yhi > ylo ? (m->V[3 * (size_t)i + 1] - ylo) / (yhi - ylo) : 0;
    }
    for (int32_t key = 0; key < 4 * nv; key++) {
        int32_t s = slot[key], v = key / 4;
        if (s < 0)
            continue;
        out->orig[s] = v;
        out->uv[2 * (size_t)s] = u[v] + ((key & 2) ? 1.0 : 0.0);
        out->uv[2 * (size_t)s + 1] = out->uv[2 * (size_t)v + 1];
        if (s >= nv) {
            /* Count a duplicate as a seam one when its wrap differs from
             * the kept vertex's. */
            int32_t k0 = -1;
            for (int q = 0; q < 4; q++)
                if (slot[4 * v + q] == v)
                    k0 = q;
            if (k0 >= 0 && ((k0 & 2) != (key & 2)))
                out->nseam++;
            else
                out->nmatcut++;
        }
    }
    for (int32_t s = 0; s < n; s++) {
        memcpy(out->mesh.V + 3 * (size_t)s, m->V + 3 * (size_t)out->orig[s], 3 * sizeof(double));
        memcpy(out->normals + 3 * (size_t)s, N + 3 * (size_t)out->orig[s], 3 * sizeof(double));
    }
    for (size_t k = 0; k < 3 * (size_t)nf; k++)
        out->mesh.F[k] = slot[key_of[k]];
done:
    free(u);
    free(N);
    free(slot);
    free(first);
    free(key_of);
    if (st != DTX_OK)
        dtx_uvsplit_free(out);
    return st;
}
