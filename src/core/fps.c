/*
 * fps.c: farthest point sampling of key-point candidates, with distances
 * along the mesh edges (bbw.h, dtx_farthest_points).
 *
 * dmin[v] is v's distance to the nearest sample so far.  Each new sample s
 * runs a Dijkstra from s that only follows vertices whose distance it
 * improves: a vertex it does not improve cannot lie on a shortest path to
 * one it does (dmin satisfies the triangle inequality along edges, also in
 * floating point, since a <= b implies fl(a + l) <= fl(b + l)), so the
 * pruned search gives exactly min(dmin, dist_s) at a fraction of the cost.
 */
#include "bbw.h"

#include "vec3.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------ */
/* Edge graph                                                          */
/* ------------------------------------------------------------------ */

typedef struct {
    int64_t *start; /* nv + 1 */
    int32_t *adj;   /* neighbours, ascending per vertex, no duplicates */
    double *len;    /* edge lengths */
} graph;

static int compare_i32(const void *a, const void *b)
{
    int32_t x = *(const int32_t *)a, y = *(const int32_t *)b;
    return (x > y) - (x < y);
}

static void graph_free(graph *g)
{
    free(g->start);
    free(g->adj);
    free(g->len);
}

static int graph_build(const dtx_mesh *mesh, graph *g)
{
    int32_t nv = mesh->nv;
    int64_t *fill = NULL, out = 0;
    memset(g, 0, sizeof *g);
    g->start = dtx_alloc((size_t)nv + 1, sizeof *g->start, 1);
    fill = dtx_alloc((size_t)nv, sizeof *fill, 0);
    g->adj = dtx_alloc((size_t)mesh->nf, 6 * sizeof *g->adj, 0);
    g->len = dtx_alloc((size_t)mesh->nf, 6 * sizeof *g->len, 0);
    if (!g->start || !fill || !g->adj || !g->len) {
        free(fill);
        graph_free(g);
        return 0;
    }
    for (int32_t f = 0; f < mesh->nf; f++)
        for (int k = 0; k < 3; k++)
            g->start[mesh->F[3 * (size_t)f + k] + 1] += 2;
    for (int32_t i = 0; i < nv; i++)
        g->start[i + 1] += g->start[i];
    memcpy(fill, g->start, (size_t)nv * sizeof *fill);
    for (int32_t f = 0; f < mesh->nf; f++) {
        const int32_t *t = mesh->F + 3 * (size_t)f;
        for (int k = 0; k < 3; k++) {
            int32_t a = t[k], b = t[(k + 1) % 3];
            g->adj[fill[a]++] = b;
            g->adj[fill[b]++] = a;
        }
    }
    /* Sort and compact each row in place; start[] is rewritten as we go
     * (row i is read from its old start before row i's new start, which is
     * never beyond the old one, is written). */
    for (int32_t i = 0; i < nv; i++) {
        int64_t lo = g->start[i], hi = g->start[i + 1];
        qsort(g->adj + lo, (size_t)(hi - lo), sizeof *g->adj, compare_i32);
        g->start[i] = out;
        for (int64_t p = lo; p < hi; p++)
            if (p == lo || g->adj[p] != g->adj[p - 1]) {
                int32_t j = g->adj[p];
                double d[3];
                sub3(mesh->V + 3 * (size_t)i, mesh->V + 3 * (size_t)j, d);
                g->adj[out] = j;
                g->len[out++] = sqrt(dot3(d, d));
            }
    }
    g->start[nv] = out;
    free(fill);
    return 1;
}

/* ------------------------------------------------------------------ */
/* Indexed binary heap on (distance, vertex)                           */
/* ------------------------------------------------------------------ */

typedef struct {
    int32_t n;
    int32_t *v;      /* heap of vertices */
    int32_t *pos;    /* nv: position in v, -1 when absent */
    const double *d; /* keys */
} heap;

static int less(const heap *h, int32_t a, int32_t b)
{
    return h->d[a] < h->d[b] || (h->d[a] == h->d[b] && a < b);
}

static void sift_up(heap *h, int32_t i)
{
    int32_t x = h->v[i];
    while (i > 0) {
        int32_t parent = (i - 1) / 2;
        if (!less(h, x, h->v[parent]))
            break;
        h->v[i] = h->v[parent];
        h->pos[h->v[i]] = i;
        i = parent;
    }
    h->v[i] = x;
    h->pos[x] = i;
}

static void sift_down(heap *h, int32_t i)
{
    int32_t x = h->v[i];
    for (;;) {
        int32_t c = 2 * i + 1;
        if (c >= h->n)
            break;
        if (c + 1 < h->n && less(h, h->v[c + 1], h->v[c]))
            c++;
        if (!less(h, h->v[c], x))
            break;
        h->v[i] = h->v[c];
        h->pos[h->v[i]] = i;
        i = c;
    }
    h->v[i] = x;
    h->pos[x] = i;
}

/* Inserts v or moves it up after its key decreased. */
static void heap_push(heap *h, int32_t v)
{
    if (h->pos[v] < 0) {
        h->v[h->n] = v;
        h->pos[v] = h->n++;
    }
    sift_up(h, h->pos[v]);
}

static int32_t heap_pop(heap *h)
{
    int32_t top = h->v[0];
    h->pos[top] = -1;
    if (--h->n > 0) {
        h->v[0] = h->v[h->n];
        h->pos[h->v[0]] = 0;
        sift_down(h, 0);
    }
    return top;
}

/* ------------------------------------------------------------------ */
/* Sampling                                                            */
/* ------------------------------------------------------------------ */

dtx_status dtx_farthest_points(const dtx_mesh *mesh, int32_t nc, int32_t *samples,
                               double *radius, dtx_error *err)
{
    graph g;
    heap h;
    double *dmin = NULL, cen[3] = {0, 0, 0}, best;
    unsigned char *picked = NULL;
    int32_t nv, ninface = 0, s = -1;
    dtx_status st;

    if (!mesh || !samples)
        return dtx_seterr(err, DTX_EINVAL, "farthest point sampling: %s",
                          mesh ? "no output array" : "no mesh");
    st = dtx_mesh_validate(mesh, "farthest point sampling: mesh", err);
    if (st != DTX_OK)
        return st;
    if (nc < 1)
        return dtx_seterr(err, DTX_EINVAL, "farthest point sampling: %d samples asked for (at "
                          "least 1)", (int)nc);
    nv = mesh->nv;
    memset(&h, 0, sizeof h);
    if (!graph_build(mesh, &g))
        return dtx_seterr(err, DTX_ENOMEM, "out of memory for the edge graph of %d vertices",
                          (int)nv);
    dmin = dtx_alloc((size_t)nv, sizeof *dmin, 0);
    picked = dtx_alloc((size_t)nv, 1, 1);
    h.v = dtx_alloc((size_t)nv, sizeof *h.v, 0);
    h.pos = dtx_alloc((size_t)nv, sizeof *h.pos, 0);
    if (!dmin || !picked || !h.v || !h.pos) {
        st = dtx_seterr(err, DTX_ENOMEM, "out of memory sampling %d vertices", (int)nv);
        goto done;
    }
    h.d = dmin;
    for (int32_t i = 0; i < nv; i++) {
        dmin[i] = INFINITY;
        h.pos[i] = -1;
        if (g.start[i + 1] > g.start[i]) {
            ninface++;
            for (int k = 0; k < 3; k++)
                cen[k] += mesh->V[3 * (size_t)i + k];
        }
    }
    if (nc > ninface) {
        st = dtx_seterr(err, DTX_ERANGE, "farthest point sampling: %d samples asked for but "
                        "only %d vertices are in a face", (int)nc, (int)ninface);
        goto done;
    }
    for (int k = 0; k < 3; k++)
        cen[k] /= ninface;

    /* The first sample: farthest from the centroid, lowest index on ties. */
    best = -1.0;
    for (int32_t i = 0; i < nv; i++)
        if (g.start[i + 1] > g.start[i]) {
            double d[3], d2;
            sub3(mesh->V + 3 * (size_t)i, cen, d);
            d2 = dot3(d, d);
            if (d2 > best) {
                best = d2;
                s = i;
            }
        }

    for (int32_t n = 0; n < nc; n++) {
        if (n > 0) {
            /* The farthest unpicked vertex in a face, lowest index on ties
             * (dmin is INFINITY in components without a sample). */
            s = -1;
            for (int32_t i = 0; i < nv; i++)
                if (!picked[i] && g.start[i + 1] > g.start[i] && (s < 0 || dmin[i] > dmin[s]))
                    s = i;
        }
        samples[n] = s;
        if (radius)
            radius[n] = dmin[s];
        picked[s] = 1;
        dmin[s] = 0.0;
        heap_push(&h, s);
        while (h.n > 0) {
            int32_t u = heap_pop(&h);
            for (int64_t p = g.start[u]; p < g.start[u + 1]; p++) {
                int32_t v = g.adj[p];
                double nd = dmin[u] + g.len[p];
                if (nd < dmin[v]) {
                    dmin[v] = nd;
                    heap_push(&h, v);
                }
            }
        }
    }
    st = DTX_OK;
done:
    graph_free(&g);
    free(dmin);
    free(picked);
    free(h.v);
    free(h.pos);
    return st;
}
