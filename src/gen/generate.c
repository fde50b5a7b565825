/*
 * generate.c: multi-component test targets (pebbles, garment, eyes) made from
 * one mesh, with a map from every output vertex to the input vertex it
 * copies.  See generate.h for what each generator guarantees.
 *
 * Edges are found by sorting the 3 nf half-edges by their (lower, higher)
 * vertex pair; the groups of equal pairs give the midpoints of subdivision,
 * the face adjacency of the pebble growth and the boundary of each pebble.
 */
#include "generate.h"

#include "dtx_core.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------ half-edges */

/* Half-edge he = 3 f + k runs from F[3f + k] to F[3f + (k + 1) % 3]. */
typedef struct {
    int64_t key; /* lower * nv + higher */
    int32_t he;
} half_edge;

static int half_edge_cmp(const void *pa, const void *pb)
{
    const half_edge *a = pa, *b = pb;
    if (a->key != b->key)
        return a->key < b->key ? -1 : 1;
    return (a->he > b->he) - (a->he < b->he);
}

static int32_t he_from(const int32_t *F, int32_t he) { return F[he]; }
static int32_t he_to(const int32_t *F, int32_t he) { return F[he - he % 3 + (he % 3 + 1) % 3]; }

/* The 3 nf half-edges sorted by undirected edge, then by index, so that
 * equal edges form consecutive groups in a deterministic order.  Returns
 * NULL when out of memory. */
static half_edge *sorted_half_edges(const int32_t *F, int32_t nf, int32_t nv)
{
    size_t n = 3 * (size_t)nf;
    half_edge *h = dtx_alloc(n, sizeof *h, 0);
    if (!h)
        return NULL;
    for (size_t i = 0; i < n; i++) {
        int32_t a = he_from(F, (int32_t)i), b = he_to(F, (int32_t)i);
        int32_t lo = a < b ? a : b, hi = a < b ? b : a;
        h[i].key = (int64_t)lo * nv + hi;
        h[i].he = (int32_t)i;
    }
    qsort(h, n, sizeof *h, half_edge_cmp);
    return h;
}

static double dist3(const double *a, const double *b)
{
    double d0 = a[0] - b[0], d1 = a[1] - b[1], d2 = a[2] - b[2];
    return sqrt(d0 * d0 + d1 * d1 + d2 * d2);
}

static void clear_outputs(dtx_mesh *out, int32_t **map)
{
    memset(out, 0, sizeof *out);
    *map = NULL;
}

/* ------------------------------------------------------------ subdivision */

/* One level of midpoint subdivision (see dtx_gen_subdivide). */
static dtx_status subdivide_once(const dtx_mesh *in, dtx_mesh *out, dtx_error *err)
{
    size_t nh = 3 * (size_t)in->nf;
    half_edge *h = NULL;
    int32_t *mid = NULL;
    int64_t ne = 0;
    dtx_status st = DTX_OK;
    memset(out, 0, sizeof *out);
    if (in->nf > INT32_MAX / 4)
        return dtx_seterr(err, DTX_ENOMEM,
                          "subdivision: %d faces would become more than "
                          "INT32_MAX",
                          (int)in->nf);
    h = sorted_half_edges(in->F, in->nf, in->nv);
    mid = dtx_alloc(nh, sizeof *mid, 0);
    if (!h || !mid) {
        st = dtx_seterr(err, DTX_ENOMEM, "subdivision: out of memory");
        goto done;
    }
    for (size_t i = 0; i < nh; i++)
        if (i == 0 || h[i].key != h[i - 1].key)
            ne++;
    if (in->nv + ne > INT32_MAX) {
        st = dtx_seterr(err, DTX_ENOMEM, "subdivision: %lld vertices would not fit in int32",
                        (long long)(in->nv + ne));
        goto done;
    }
    if ((st = dtx_mesh_alloc(out, in->nv + (int32_t)ne, 4 * in->nf, err)) != DTX_OK)
        goto done;
    memcpy(out->V, in->V, (size_t)in->nv * 3 * sizeof *out->V);
    {
        int32_t next = in->nv;
        for (size_t i = 0; i < nh; i++) {
            if (i == 0 || h[i].key != h[i - 1].key) {
                const double *a = in->V + 3 * he_from(in->F, h[i].he);
                const double *b = in->V + 3 * he_to(in->F, h[i].he);
                for (int k = 0; k < 3; k++)
                    out->V[3 * next + k] = 0.5 * (a[k] + b[k]);
                next++;
            }
            mid[h[i].he] = next - 1;
        }
    }
    for (int32_t f = 0; f < in->nf; f++) {
        const int32_t *t = in->F + 3 * f;
        int32_t ab = mid[3 * f], bc = mid[3 * f + 1], ca = mid[3 * f + 2];
        int32_t q[12] = {t[0], ab, ca, ab, t[1], bc, ca, bc, t[2], ab, bc, ca};
        memcpy(out->F + 12 * (size_t)f, q, sizeof q);
    }
done:
    free(h);
    free(mid);
    return st;
}

dtx_status dtx_gen_subdivide(const dtx_mesh *in, int levels, dtx_mesh *out, int32_t **map,
                             dtx_error *err)
{
    dtx_mesh cur, next;
    int32_t *m = NULL;
    dtx_status st;
    clear_outputs(out, map);
    if (levels < 0 || levels > DTX_GEN_MAX_SUBDIVIDE)
        return dtx_seterr(err, DTX_EINVAL, "subdivision level %d outside [0, %d]", levels,
                          DTX_GEN_MAX_SUBDIVIDE);
    if ((st = dtx_mesh_validate(in, "subdivision input", err)) != DTX_OK)
        return st;
    if ((st = dtx_mesh_copy(in, &cur, err)) != DTX_OK)
        return st;
    for (int l = 0; l < levels; l++) {
        if ((st = subdivide_once(&cur, &next, err)) != DTX_OK) {
            dtx_mesh_free(&cur);
            return st;
        }
        dtx_mesh_free(&cur);
        cur = next;
    }
    m = dtx_alloc((size_t)cur.nv, sizeof *m, 0);
    if (!m) {
        dtx_mesh_free(&cur);
        return dtx_seterr(err, DTX_ENOMEM, "subdivision: out of memory");
    }
    /* Each level appends its midpoints after the vertices it was given. */
    for (int32_t v = 0; v < cur.nv; v++)
        m[v] = v < in->nv ? v : -1;
    *out = cur;
    *map = m;
    return DTX_OK;
}

/* ------------------------------------------------------------ icosphere */

dtx_status dtx_gen_icosphere(int level, dtx_mesh *out, dtx_error *err)
{
    static const int32_t faces[60] = {0, 11, 5, 0, 5,  1,  0,  1,  7,  0,  7, 10, 0, 10, 11,
                                      1, 5,  9, 5, 11, 4,  11, 10, 2,  10, 7, 6,  7, 1,  8,
                                      3, 9,  4, 3, 4,  2,  3,  2,  6,  3,  6, 8,  3, 8,  9,
                                      4, 9,  5, 2, 4,  11, 6,  2,  10, 8,  6, 7,  9, 8,  1};
    const double t = (1.0 + sqrt(5.0)) / 2.0;
    const double verts[36] = {-1, t,  0,  1, t, 0,  -1, -t, 0,  1, -t, 0, 0,  -1, t,  0,  1, t,
                              0,  -1, -t, 0, 1, -t, t,  0,  -1, t, 0,  1, -t, 0,  -1, -t, 0, 1};
    dtx_mesh ico;
    int32_t *map = NULL;
    dtx_status st;
    memset(out, 0, sizeof *out);
    if (level < 0 || level > DTX_GEN_MAX_SUBDIVIDE)
        return dtx_seterr(err, DTX_EINVAL, "icosphere level %d outside [0, %d]", level,
                          DTX_GEN_MAX_SUBDIVIDE);
    if ((st = dtx_mesh_alloc(&ico, 12, 20, err)) != DTX_OK)
        return st;
    memcpy(ico.V, verts, sizeof verts);
    memcpy(ico.F, faces, sizeof faces);
    /* Outward orientation whatever the table's: the origin is inside. */
    for (int32_t f = 0; f < 20; f++) {
        int32_t *q = ico.F + 3 * f;
        const double *a = ico.V + 3 * q[0], *b = ico.V + 3 * q[1], *c = ico.V + 3 * q[2];
        double u[3], w[3], n[3];
        for (int k = 0; k < 3; k++)
            u[k] = b[k] - a[k], w[k] = c[k] - a[k];
        n[0] = u[1] * w[2] - u[2] * w[1];
        n[1] = u[2] * w[0] - u[0] * w[2];
        n[2] = u[0] * w[1] - u[1] * w[0];
        if (n[0] * (a[0] + b[0] + c[0]) + n[1] * (a[1] + b[1] + c[1]) +
                n[2] * (a[2] + b[2] + c[2]) <
            0) {
            int32_t s = q[1];
            q[1] = q[2];
            q[2] = s;
        }
    }
    st = dtx_gen_subdivide(&ico, level, out, &map, err);
    dtx_mesh_free(&ico);
    free(map);
    if (st != DTX_OK)
        return st;
    for (int32_t v = 0; v < out->nv; v++) {
        double *x = out->V + 3 * v, r = sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
        for (int k = 0; k < 3; k++)
            x[k] /= r;
    }
    return DTX_OK;
}

/* ------------------------------------------------------------ pebbles */

typedef struct {
    double d;
    int32_t f;
} heap_item;

static int heap_less(const heap_item *a, const heap_item *b)
{
    return a->d < b->d || (a->d == b->d && a->f < b->f);
}

static void heap_push(heap_item *h, size_t *n, heap_item x)
{
    size_t i = (*n)++;
    while (i > 0) {
        size_t p = (i - 1) / 2;
        if (!heap_less(&x, &h[p]))
            break;
        h[i] = h[p];
        i = p;
    }
    h[i] = x;
}

static heap_item heap_pop(heap_item *h, size_t *n)
{
    heap_item top = h[0], x = h[--(*n)];
    size_t i = 0;
    for (;;) {
        size_t c = 2 * i + 1;
        if (c >= *n)
            break;
        if (c + 1 < *n && heap_less(&h[c + 1], &h[c]))
            c++;
        if (!heap_less(&h[c], &x))
            break;
        h[i] = h[c];
        i = c;
    }
    if (*n > 0)
        h[i] = x;
    return top;
}

/* Face adjacency over shared edges in CSR form (adj_start: nf + 1, adj:
 * adj_start[nf]); faces on a non-manifold edge are all adjacent to each
 * other.  grp (3 nf): for every half-edge the index into h of the first
 * half-edge of its edge's group; grp_end likewise one past the last. */
typedef struct {
    int64_t *adj_start;
    int32_t *adj;
    int32_t *grp, *grp_end;
} face_graph;

static void face_graph_free(face_graph *g)
{
    free(g->adj_start);
    free(g->adj);
    free(g->grp);
    free(g->grp_end);
    memset(g, 0, sizeof *g);
}

static int face_graph_build(const half_edge *h, int32_t nf, face_graph *g)
{
    size_t nh = 3 * (size_t)nf;
    memset(g, 0, sizeof *g);
    g->adj_start = dtx_alloc((size_t)nf + 1, sizeof *g->adj_start, 1);
    g->grp = dtx_alloc(nh, sizeof *g->grp, 0);
    g->grp_end = dtx_alloc(nh, sizeof *g->grp_end, 0);
    if (!g->adj_start || !g->grp || !g->grp_end)
        goto nomem;
    for (size_t i = 0, j; i < nh; i = j) {
        for (j = i + 1; j < nh && h[j].key == h[i].key; j++)
            ;
        for (size_t k = i; k < j; k++) {
            g->grp[h[k].he] = (int32_t)i;
            g->grp_end[h[k].he] = (int32_t)j;
            g->adj_start[h[k].he / 3 + 1] += (int64_t)(j - i - 1);
        }
    }
    for (int32_t f = 0; f < nf; f++)
        g->adj_start[f + 1] += g->adj_start[f];
    g->adj = dtx_alloc((size_t)g->adj_start[nf], sizeof *g->adj, 0);
    if (!g->adj)
        goto nomem;
    {
        int64_t *fill = dtx_alloc((size_t)nf, sizeof *fill, 0);
        if (!fill)
            goto nomem;
        memcpy(fill, g->adj_start, (size_t)nf * sizeof *fill);
        for (size_t he = 0; he < nh; he++) {
            int32_t f = (int32_t)(he / 3);
            for (int32_t k = g->grp[he]; k < g->grp_end[he]; k++)
                if (h[k].he != (int32_t)he)
                    g->adj[fill[f]++] = h[k].he / 3;
        }
        free(fill);
    }
    return 0;
nomem:
    face_graph_free(g);
    return -1;
}

/* Seeds (see generate.h): the lowest face of each edge-connected part, then
 * farthest-point sampling of the centroids C (nf x 3).  seeds: npieces
 * entries.  Returns the number of parts (> npieces: nothing chosen), or -1
 * when out of memory. */
static int32_t choose_seeds(const face_graph *g, const double *C, int32_t nf, int32_t npieces,
                            int32_t *seeds)
{
    int32_t *part = dtx_alloc((size_t)nf, sizeof *part, 0);
    int32_t *queue = dtx_alloc((size_t)nf, sizeof *queue, 0);
    double *mind = dtx_alloc((size_t)nf, sizeof *mind, 0);
    int32_t nparts = 0, nseeds = 0;
    if (!part || !queue || !mind) {
        nparts = -1;
        goto done;
    }
    for (int32_t f = 0; f < nf; f++)
        part[f] = -1;
    for (int32_t f = 0; f < nf; f++) {
        int32_t qh = 0, qt = 0;
        if (part[f] >= 0)
            continue;
        if (nparts < npieces)
            seeds[nparts] = f;
        part[f] = nparts;
        queue[qt++] = f;
        while (qh < qt) {
            int32_t x = queue[qh++];
            for (int64_t k = g->adj_start[x]; k < g->adj_start[x + 1]; k++)
                if (part[g->adj[k]] < 0) {
                    part[g->adj[k]] = nparts;
                    queue[qt++] = g->adj[k];
                }
        }
        nparts++;
    }
    if (nparts > npieces)
        goto done;
    /* Farthest-point sampling: mind is the squared distance to the nearest
     * seed, -1 on seeds so that they are never chosen again. */
    for (int32_t f = 0; f < nf; f++)
        mind[f] = INFINITY;
    for (nseeds = 0; nseeds < npieces; nseeds++) {
        int32_t s;
        if (nseeds >= nparts) {
            int32_t best = -1;
            for (int32_t f = 0; f < nf; f++)
                if (mind[f] >= 0 && (best < 0 || mind[f] > mind[best]))
                    best = f;
            seeds[nseeds] = best;
        }
        s = seeds[nseeds];
        mind[s] = -1;
        for (int32_t f = 0; f < nf; f++) {
            double d0 = C[3 * f] - C[3 * s], d1 = C[3 * f + 1] - C[3 * s + 1],
                   d2 = C[3 * f + 2] - C[3 * s + 2], d = d0 * d0 + d1 * d1 + d2 * d2;
            if (mind[f] >= 0 && d < mind[f])
                mind[f] = d;
        }
    }
done:
    free(part);
    free(queue);
    free(mind);
    return nparts;
}

/* Multi-source Dijkstra from the seeds over the face graph: piece[f] is the
 * index of the seed whose region f joins.  Every face is reached (every
 * part has a seed).  Returns -1 when out of memory. */
static int grow_pieces(const face_graph *g, const double *C, int32_t nf, const int32_t *seeds,
                       int32_t npieces, int32_t *piece)
{
    size_t cap = (size_t)g->adj_start[nf] + (size_t)npieces, n = 0;
    heap_item *heap = dtx_alloc(cap, sizeof *heap, 0);
    double *dist = dtx_alloc((size_t)nf, sizeof *dist, 0);
    unsigned char *done = dtx_alloc((size_t)nf, 1, 1);
    if (!heap || !dist || !done) {
        free(heap);
        free(dist);
        free(done);
        return -1;
    }
    for (int32_t f = 0; f < nf; f++) {
        dist[f] = INFINITY;
        piece[f] = -1;
    }
    for (int32_t i = 0; i < npieces; i++) {
        heap_item x = {0.0, seeds[i]};
        dist[seeds[i]] = 0.0;
        piece[seeds[i]] = i;
        heap_push(heap, &n, x);
    }
    while (n > 0) {
        heap_item x = heap_pop(heap, &n);
        if (done[x.f] || x.d > dist[x.f])
            continue;
        done[x.f] = 1;
        for (int64_t k = g->adj_start[x.f]; k < g->adj_start[x.f + 1]; k++) {
            int32_t y = g->adj[k];
            double nd = x.d + dist3(C + 3 * x.f, C + 3 * y);
            if (!done[y] && nd < dist[y]) {
                heap_item e = {nd, y};
                dist[y] = nd;
                piece[y] = piece[x.f];
                heap_push(heap, &n, e);
            }
        }
    }
    free(heap);
    free(dist);
    free(done);
    return 0;
}

/* Shrinks the piece whose vertices are X[0..k) (k x 3) about the area
 * centroid of its faces Fp (nfp x 3, indices into X) by s = 1 - g / (2 r);
 * bflag[i] marks boundary vertices. */
static void shrink_piece(double *X, int32_t k, const int32_t *Fp, int32_t nfp,
                         const unsigned char *bflag, double g)
{
    double c[3] = {0, 0, 0}, area = 0.0, r = 0.0, s;
    int32_t nb = 0;
    if (g <= 0.0)
        return;
    for (int32_t f = 0; f < nfp; f++) {
        const double *a = X + 3 * Fp[3 * f], *b = X + 3 * Fp[3 * f + 1], *d = X + 3 * Fp[3 * f + 2];
        double u[3], w[3], n[3], A;
        for (int j = 0; j < 3; j++)
            u[j] = b[j] - a[j], w[j] = d[j] - a[j];
        n[0] = u[1] * w[2] - u[2] * w[1];
        n[1] = u[2] * w[0] - u[0] * w[2];
        n[2] = u[0] * w[1] - u[1] * w[0];
        A = 0.5 * sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        for (int j = 0; j < 3; j++)
            c[j] += A * (a[j] + b[j] + d[j]) / 3.0;
        area += A;
    }
    if (area > 0.0) {
        for (int j = 0; j < 3; j++)
            c[j] /= area;
    } else {
        for (int32_t i = 0; i < k; i++)
            for (int j = 0; j < 3; j++)
                c[j] += X[3 * i + j] / k;
    }
    for (int32_t i = 0; i < k; i++)
        if (bflag[i]) {
            r += dist3(X + 3 * i, c);
            nb++;
        }
    if (nb == 0) { /* a closed piece: no crack to open, shrink by its mean radius */
        for (int32_t i = 0; i < k; i++)
            r += dist3(X + 3 * i, c);
        nb = k;
    }
    r /= nb;
    if (!(r > 0.0))
        return;
    s = 1.0 - g / (2.0 * r);
    s = s < 0.1 ? 0.1 : s;
    for (int32_t i = 0; i < k; i++)
        for (int j = 0; j < 3; j++)
            X[3 * i + j] = c[j] + s * (X[3 * i + j] - c[j]);
}

dtx_status dtx_gen_pebbles(const dtx_mesh *in, int32_t npieces, double gap, double thickness,
                           int subdivide, dtx_mesh *out, int32_t **map, dtx_error *err)
{
    dtx_mesh m;
    int32_t *smap = NULL, *seeds = NULL, *piece = NULL, *pstart = NULL, *pfaces = NULL;
    int32_t *stamp = NULL, *local = NULL, *omap = NULL;
    half_edge *h = NULL;
    unsigned char *bnd = NULL, *bflag = NULL;
    double *C = NULL, *nrm = NULL, diag;
    face_graph g;
    int64_t tot_v = 0, tot_f = 0;
    const int thick = thickness > 0.0;
    int32_t nf, nparts;
    dtx_status st = DTX_OK;
    dtx_mesh res;

    clear_outputs(out, map);
    memset(&m, 0, sizeof m);
    memset(&g, 0, sizeof g);
    memset(&res, 0, sizeof res);
    if (npieces < 1)
        return dtx_seterr(err, DTX_EINVAL,
                          "pebbles: the number of pieces must be at least 1 "
                          "(got %d)",
                          (int)npieces);
    if (!isfinite(gap) || gap < 0)
        return dtx_seterr(err, DTX_EINVAL, "pebbles: gap must be finite and >= 0 (got %g)", gap);
    if (!isfinite(thickness) || thickness < 0)
        return dtx_seterr(err, DTX_EINVAL, "pebbles: thickness must be finite and >= 0 (got %g)",
                          thickness);
    if ((st = dtx_mesh_validate(in, "pebbles input", err)) != DTX_OK)
        return st;
    diag = dtx_bbox_diagonal(in->V, in->nv);
    if ((st = dtx_gen_subdivide(in, subdivide, &m, &smap, err)) != DTX_OK)
        return st;
    nf = m.nf;
    if (npieces > nf) {
        st = dtx_seterr(err, DTX_EINVAL,
                        "pebbles: %d pieces asked for but the mesh has only %d "
                        "faces%s",
                        (int)npieces, (int)nf,
                        subdivide > 0 ? " after subdivision" : " (subdivide it first)");
        goto fail;
    }

    /* ---------------------------------------------- split into pieces */
    h = sorted_half_edges(m.F, nf, m.nv);
    C = dtx_alloc((size_t)nf, 3 * sizeof *C, 0);
    seeds = dtx_alloc((size_t)npieces, sizeof *seeds, 0);
    piece = dtx_alloc((size_t)nf, sizeof *piece, 0);
    if (!h || !C || !seeds || !piece || face_graph_build(h, nf, &g) != 0)
        goto nomem;
    for (int32_t f = 0; f < nf; f++)
        for (int j = 0; j < 3; j++)
            C[3 * f + j] = (m.V[3 * m.F[3 * f] + j] + m.V[3 * m.F[3 * f + 1] + j] +
                            m.V[3 * m.F[3 * f + 2] + j]) /
                           3.0;
    nparts = choose_seeds(&g, C, nf, npieces, seeds);
    if (nparts < 0)
        goto nomem;
    if (nparts > npieces) {
        st = dtx_seterr(err, DTX_EINVAL,
                        "pebbles: the mesh already has %d separate parts "
                        "(over shared edges), more than the %d pieces asked for",
                        (int)nparts, (int)npieces);
        goto fail;
    }
    if (grow_pieces(&g, C, nf, seeds, npieces, piece) != 0)
        goto nomem;

    /* Faces of each piece in increasing order (counting sort). */
    pstart = dtx_alloc((size_t)npieces + 1, sizeof *pstart, 1);
    pfaces = dtx_alloc((size_t)nf, sizeof *pfaces, 0);
    bnd = dtx_alloc(3 * (size_t)nf, 1, 0);
    stamp = dtx_alloc((size_t)m.nv, sizeof *stamp, 0);
    local = dtx_alloc((size_t)m.nv, sizeof *local, 0);
    if (!pstart || !pfaces || !bnd || !stamp || !local)
        goto nomem;
    for (int32_t f = 0; f < nf; f++)
        pstart[piece[f] + 1]++;
    for (int32_t p = 0; p < npieces; p++)
        pstart[p + 1] += pstart[p];
    {
        int32_t *fill = dtx_alloc((size_t)npieces, sizeof *fill, 0);
        if (!fill)
            goto nomem;
        memcpy(fill, pstart, (size_t)npieces * sizeof *fill);
        for (int32_t f = 0; f < nf; f++)
            pfaces[fill[piece[f]]++] = f;
        free(fill);
    }
    /* A half-edge is on its piece's boundary when no other face of the
     * piece has that edge. */
    for (size_t he = 0; he < 3 * (size_t)nf; he++) {
        int32_t p = piece[he / 3], same = 0;
        for (int32_t k = g.grp[he]; k < g.grp_end[he]; k++)
            same += piece[h[k].he / 3] == p;
        bnd[he] = same == 1;
    }

    /* ---------------------------------------------- sizes */
    for (int32_t v = 0; v < m.nv; v++)
        stamp[v] = -1;
    for (int32_t p = 0; p < npieces; p++) {
        int64_t k = 0, nb = 0;
        for (int32_t i = pstart[p]; i < pstart[p + 1]; i++)
            for (int j = 0; j < 3; j++) {
                int32_t v = m.F[3 * pfaces[i] + j];
                if (stamp[v] != p) {
                    stamp[v] = p;
                    k++;
                }
                nb += bnd[3 * pfaces[i] + j];
            }
        tot_v += thick ? 2 * k : k;
        tot_f += thick ? 2 * (int64_t)(pstart[p + 1] - pstart[p]) + 2 * nb
                       : (int64_t)(pstart[p + 1] - pstart[p]);
    }
    if (tot_v > INT32_MAX || tot_f > INT32_MAX) {
        st = dtx_seterr(err, DTX_ENOMEM,
                        "pebbles: %lld vertices and %lld faces would not fit "
                        "in int32",
                        (long long)tot_v, (long long)tot_f);
        goto fail;
    }
    if ((st = dtx_mesh_alloc(&res, (int32_t)tot_v, (int32_t)tot_f, err)) != DTX_OK)
        goto fail;
    omap = dtx_alloc((size_t)tot_v, sizeof *omap, 0);
    bflag = dtx_alloc((size_t)tot_v, 1, 1);
    nrm = thick ? dtx_alloc((size_t)tot_v, 3 * sizeof *nrm, 1) : NULL;
    if (!omap || !bflag || (thick && !nrm))
        goto nomem;

    /* ---------------------------------------------- build piece by piece */
    for (int32_t v = 0; v < m.nv; v++)
        stamp[v] = -1;
    {
        int32_t vb = 0, fb = 0;
        const double g_abs = gap * diag, t_abs = thickness * diag;
        for (int32_t p = 0; p < npieces; p++) {
            int32_t k = 0, nfp = pstart[p + 1] - pstart[p], fw;
            int32_t *Fp = res.F + 3 * (size_t)fb;
            for (int32_t i = 0; i < nfp; i++) {
                int32_t f = pfaces[pstart[p] + i];
                for (int j = 0; j < 3; j++) {
                    int32_t v = m.F[3 * f + j];
                    if (stamp[v] != p) {
                        stamp[v] = p;
                        local[v] = k;
                        memcpy(res.V + 3 * (size_t)(vb + k), m.V + 3 * (size_t)v,
                               3 * sizeof *res.V);
                        omap[vb + k] = smap[v];
                        k++;
                    }
                    Fp[3 * i + j] = local[v]; /* piece-local for now */
                }
            }
            /* Boundary vertices, once every vertex of the piece is numbered. */
            for (int32_t i = 0; i < nfp; i++) {
                int32_t f = pfaces[pstart[p] + i];
                for (int j = 0; j < 3; j++)
                    if (bnd[3 * f + j]) {
                        bflag[vb + local[m.F[3 * f + j]]] = 1;
                        bflag[vb + local[m.F[3 * f + (j + 1) % 3]]] = 1;
                    }
            }
            shrink_piece(res.V + 3 * (size_t)vb, k, Fp, nfp, bflag + vb, g_abs);
            fw = nfp;
            if (thick) {
                double *N = nrm + 3 * (size_t)vb;
                dtx_vertex_normals(res.V + 3 * (size_t)vb, k, Fp, nfp, N);
                for (int32_t i = 0; i < k; i++) {
                    for (int j = 0; j < 3; j++)
                        res.V[3 * (size_t)(vb + k + i) + j] =
                            res.V[3 * (size_t)(vb + i) + j] - t_abs * N[3 * i + j];
                    omap[vb + k + i] = omap[vb + i];
                }
                /* Inner copy, reversed. */
                for (int32_t i = 0; i < nfp; i++) {
                    Fp[3 * (nfp + i)] = k + Fp[3 * i];
                    Fp[3 * (nfp + i) + 1] = k + Fp[3 * i + 2];
                    Fp[3 * (nfp + i) + 2] = k + Fp[3 * i + 1];
                }
                fw = 2 * nfp;
                /* Wall: boundary edge a->b of the patch gives (b, a, a') and
                 * (b, a', b'), which pair with the patch's a->b and the inner
                 * copy's b'->a' edge for edge. */
                for (int32_t i = 0; i < nfp; i++)
                    for (int j = 0; j < 3; j++)
                        if (bnd[3 * pfaces[pstart[p] + i] + j]) {
                            int32_t a = Fp[3 * i + j], b = Fp[3 * i + (j + 1) % 3];
                            int32_t w[6] = {b, a, a + k, b, a + k, b + k};
                            memcpy(Fp + 3 * fw, w, sizeof w);
                            fw += 2;
                        }
            }
            for (int32_t i = 0; i < 3 * fw; i++)
                Fp[i] += vb;
            vb += thick ? 2 * k : k;
            fb += fw;
        }
    }
    *out = res;
    *map = omap;
    omap = NULL;
    memset(&res, 0, sizeof res);
    goto done;

nomem:
    st = dtx_seterr(err, DTX_ENOMEM, "pebbles: out of memory");
fail:
    dtx_mesh_free(&res);
done:
    free(omap);
    free(nrm);
    free(bflag);
    free(local);
    free(stamp);
    free(bnd);
    free(pfaces);
    free(pstart);
    free(piece);
    free(seeds);
    free(C);
    free(h);
    face_graph_free(&g);
    free(smap);
    dtx_mesh_free(&m);
    return st;
}

/* ------------------------------------------------------------ garment */

/* ---------------------------------------------------------------- reshape */

dtx_status dtx_gen_reshape(const dtx_mesh *in, int axis, double thicken, double legs, double lo,
                           dtx_mesh *out, int32_t **map, dtx_error *err)
{
    double mn[3] = {INFINITY, INFINITY, INFINITY}, mx[3] = {-INFINITY, -INFINITY, -INFINITY};
    double c[3], u0, w;
    dtx_status st;
    clear_outputs(out, map);
    if (axis < 0 || axis > 2)
        return dtx_seterr(err, DTX_EINVAL, "reshape: axis must be 0, 1 or 2 (got %d)", axis);
    if (!isfinite(thicken) || !(thicken > 0) || !isfinite(legs) || !(legs > 0))
        return dtx_seterr(err, DTX_EINVAL,
                          "reshape: thicken and legs must be finite and > 0 (got %g and %g)",
                          thicken, legs);
    if (!(lo >= 0 && lo <= 1))
        return dtx_seterr(err, DTX_EINVAL, "reshape: lo must be in [0, 1] (got %g)", lo);
    if ((st = dtx_mesh_validate(in, "reshape input", err)) != DTX_OK)
        return st;
    for (int32_t v = 0; v < in->nv; v++)
        for (int k = 0; k < 3; k++) {
            mn[k] = fmin(mn[k], in->V[3 * (size_t)v + k]);
            mx[k] = fmax(mx[k], in->V[3 * (size_t)v + k]);
        }
    for (int k = 0; k < 3; k++)
        c[k] = 0.5 * (mn[k] + mx[k]);
    u0 = mn[axis] + lo * (mx[axis] - mn[axis]);
    w = 0.05 * (mx[axis] - mn[axis]);
    if ((st = dtx_mesh_copy(in, out, err)) != DTX_OK)
        return st;
    *map = dtx_alloc((size_t)in->nv, sizeof **map, 0);
    if (!*map) {
        dtx_mesh_free(out);
        return dtx_seterr(err, DTX_ENOMEM, "reshape: out of memory");
    }
    for (int32_t v = 0; v < in->nv; v++) {
        double *x = out->V + 3 * (size_t)v, d = u0 - x[axis];
        (*map)[v] = v;
        for (int k = 0; k < 3; k++)
            if (k != axis)
                x[k] = c[k] + thicken * (x[k] - c[k]);
        /* r(d) = (d + sqrt(d^2 + w^2)) / 2: 0 far above u0, d far below;
         * dr/du lies in (-1, 0), so u -> u - (legs - 1) r is increasing. */
        x[axis] -= (legs - 1.0) * 0.5 * (d + sqrt(d * d + w * w));
    }
    return DTX_OK;
}

dtx_status dtx_gen_garment(const dtx_mesh *body, int axis, double lo, double hi, double offset,
                           dtx_mesh *out, int32_t **map, dtx_error *err)
{
    double mn = INFINITY, mx = -INFINITY, a, b, d;
    double *N = NULL;
    int32_t *shell_id = NULL, *omap = NULL, nsv = 0, nsf = 0;
    dtx_mesh res;
    dtx_status st;
    clear_outputs(out, map);
    memset(&res, 0, sizeof res);
    if (axis < 0 || axis > 2)
        return dtx_seterr(err, DTX_EINVAL, "garment: axis must be 0, 1 or 2 (got %d)", axis);
    if (!isfinite(lo) || !isfinite(hi) || !(lo < hi))
        return dtx_seterr(err, DTX_EINVAL,
                          "garment: the band [%g, %g] must have lo < hi, both "
                          "finite",
                          lo, hi);
    if (!isfinite(offset) || !(offset > 0))
        return dtx_seterr(err, DTX_EINVAL, "garment: offset must be finite and > 0 (got %g)",
                          offset);
    if ((st = dtx_mesh_validate(body, "garment body", err)) != DTX_OK)
        return st;
    for (int32_t v = 0; v < body->nv; v++) {
        double x = body->V[3 * v + axis];
        mn = x < mn ? x : mn;
        mx = x > mx ? x : mx;
    }
    a = mn + lo * (mx - mn);
    b = mn + hi * (mx - mn);
    d = offset * dtx_bbox_diagonal(body->V, body->nv);
    shell_id = dtx_alloc((size_t)body->nv, sizeof *shell_id, 0);
    N = dtx_alloc((size_t)body->nv, 3 * sizeof *N, 0);
    if (!shell_id || !N)
        goto nomem;
    for (int32_t v = 0; v < body->nv; v++)
        shell_id[v] = -1;
    for (int32_t f = 0; f < body->nf; f++) {
        const int32_t *t = body->F + 3 * f;
        double c =
            (body->V[3 * t[0] + axis] + body->V[3 * t[1] + axis] + body->V[3 * t[2] + axis]) / 3.0;
        if (c >= a && c <= b) {
            nsf++;
            for (int j = 0; j < 3; j++)
                shell_id[t[j]] = 0;
        }
    }
    if (nsf == 0) {
        st = dtx_seterr(err, DTX_EINVAL,
                        "garment: no face of the body has its centroid in "
                        "[%g, %g] along axis %d (the body spans [%g, %g])",
                        a, b, axis, mn, mx);
        goto fail;
    }
    for (int32_t v = 0; v < body->nv; v++)
        if (shell_id[v] == 0)
            shell_id[v] = body->nv + nsv++;
    if ((int64_t)body->nv + nsv > INT32_MAX || (int64_t)body->nf + nsf > INT32_MAX) {
        st = dtx_seterr(err, DTX_ENOMEM, "garment: the result would not fit in int32");
        goto fail;
    }
    if ((st = dtx_mesh_alloc(&res, body->nv + nsv, body->nf + nsf, err)) != DTX_OK)
        goto fail;
    omap = dtx_alloc((size_t)res.nv, sizeof *omap, 0);
    if (!omap)
        goto nomem;
    dtx_vertex_normals(body->V, body->nv, body->F, body->nf, N);
    memcpy(res.V, body->V, (size_t)body->nv * 3 * sizeof *res.V);
    memcpy(res.F, body->F, (size_t)body->nf * 3 * sizeof *res.F);
    for (int32_t v = 0; v < body->nv; v++) {
        omap[v] = v;
        if (shell_id[v] >= 0) {
            for (int j = 0; j < 3; j++)
                res.V[3 * (size_t)shell_id[v] + j] = body->V[3 * v + j] + d * N[3 * v + j];
            omap[shell_id[v]] = v;
        }
    }
    {
        int32_t k = body->nf;
        for (int32_t f = 0; f < body->nf; f++) {
            const int32_t *t = body->F + 3 * f;
            double c =
                (body->V[3 * t[0] + axis] + body->V[3 * t[1] + axis] + body->V[3 * t[2] + axis]) /
                3.0;
            if (c >= a && c <= b) {
                for (int j = 0; j < 3; j++)
                    res.F[3 * (size_t)k + j] = shell_id[t[j]];
                k++;
            }
        }
    }
    free(shell_id);
    free(N);
    *out = res;
    *map = omap;
    return DTX_OK;
nomem:
    st = dtx_seterr(err, DTX_ENOMEM, "garment: out of memory");
fail:
    free(shell_id);
    free(N);
    free(omap);
    dtx_mesh_free(&res);
    return st;
}

/* ------------------------------------------------------------ eyes */

#define EYE_MAX_STEPS 1000

/* Area-weighted normal (not normalised) of the faces of m whose centroid
 * lies within R of p: the direction out of a dent such as an eye socket,
 * where a single vertex normal can point at its side. */
static void smoothed_normal(const dtx_mesh *m, const double *p, double R, double *n)
{
    n[0] = n[1] = n[2] = 0.0;
    for (int32_t f = 0; f < m->nf; f++) {
        const double *a = m->V + 3 * m->F[3 * f], *b = m->V + 3 * m->F[3 * f + 1],
                     *d = m->V + 3 * m->F[3 * f + 2];
        double c[3], u[3], w[3];
        for (int j = 0; j < 3; j++) {
            c[j] = (a[j] + b[j] + d[j]) / 3.0;
            u[j] = b[j] - a[j];
            w[j] = d[j] - a[j];
        }
        if (dist3(c, p) > R)
            continue;
        n[0] += u[1] * w[2] - u[2] * w[1];
        n[1] += u[2] * w[0] - u[0] * w[2];
        n[2] += u[0] * w[1] - u[1] * w[0];
    }
}

dtx_status dtx_gen_eyes(const dtx_mesh *body, const int32_t *anchors, int32_t nanchors,
                        double radius, double gap, dtx_mesh *out, int32_t **map, dtx_error *err)
{
    dtx_mesh ball, res;
    dtx_bvh *bvh = NULL;
    double *N = NULL, diag, r, clear;
    int32_t *omap = NULL;
    int64_t nv64, nf64;
    dtx_status st;
    clear_outputs(out, map);
    memset(&ball, 0, sizeof ball);
    memset(&res, 0, sizeof res);
    if (nanchors < 1 || !anchors)
        return dtx_seterr(err, DTX_EINVAL, "eyes: at least one anchor vertex is needed");
    if (!isfinite(radius) || !(radius > 0))
        return dtx_seterr(err, DTX_EINVAL, "eyes: radius must be finite and > 0 (got %g)", radius);
    if (!isfinite(gap))
        return dtx_seterr(err, DTX_EINVAL, "eyes: gap must be finite (got %g)", gap);
    if ((st = dtx_mesh_validate(body, "eyes body", err)) != DTX_OK)
        return st;
    for (int32_t i = 0; i < nanchors; i++)
        if (anchors[i] < 0 || anchors[i] >= body->nv)
            return dtx_seterr(err, DTX_EINVAL,
                              "eyes: anchor %d is vertex %d, outside [0, %d) "
                              "(anchors are 0-based)",
                              (int)i, (int)anchors[i], (int)body->nv);
    if ((st = dtx_gen_icosphere(DTX_GEN_EYE_LEVEL, &ball, err)) != DTX_OK)
        return st;
    nv64 = body->nv + (int64_t)nanchors * ball.nv;
    nf64 = body->nf + (int64_t)nanchors * ball.nf;
    if (nv64 > INT32_MAX || nf64 > INT32_MAX) {
        st = dtx_seterr(err, DTX_ENOMEM, "eyes: the result would not fit in int32");
        goto fail;
    }
    if ((st = dtx_mesh_alloc(&res, (int32_t)nv64, (int32_t)nf64, err)) != DTX_OK)
        goto fail;
    omap = dtx_alloc((size_t)nv64, sizeof *omap, 0);
    N = dtx_alloc((size_t)body->nv, 3 * sizeof *N, 0);
    bvh = gap >= 0 ? dtx_bvh_build(body->V, body->F, body->nf) : NULL;
    if (!omap || !N || (gap >= 0 && !bvh))
        goto nomem;
    dtx_vertex_normals(body->V, body->nv, body->F, body->nf, N);
    diag = dtx_bbox_diagonal(body->V, body->nv);
    r = radius * diag;
    clear = (radius + gap) * diag;
    memcpy(res.V, body->V, (size_t)body->nv * 3 * sizeof *res.V);
    memcpy(res.F, body->F, (size_t)body->nf * 3 * sizeof *res.F);
    for (int32_t v = 0; v < body->nv; v++)
        omap[v] = v;
    for (int32_t i = 0; i < nanchors; i++) {
        const double *x = body->V + 3 * anchors[i];
        double n[3], c[3], len;
        int32_t vb = body->nv + i * ball.nv, fb = body->nf + i * ball.nf;
        smoothed_normal(body, x, 2.0 * clear, n);
        len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (len > 0) {
            for (int j = 0; j < 3; j++)
                n[j] /= len;
        } else {
            memcpy(n, N + 3 * anchors[i], sizeof n);
        }
        for (int j = 0; j < 3; j++)
            c[j] = x[j] + (gap >= 0 ? clear * n[j] : 0.0);
        /* March the centre out along n until the body is at least `clear`
         * away: a concave place (an eye socket) can be nearer than the
         * anchor.  Steps of at least clear / 20, so the loop ends once the
         * ray has left the body's neighbourhood. */
        for (int it = 0; gap >= 0 && it < EYE_MAX_STEPS; it++) {
            double q[3], d2, d, step;
            dtx_bvh_closest(bvh, c, INFINITY, NULL, NULL, q, &d2);
            d = sqrt(d2);
            if (d >= clear)
                break;
            step = clear - d > 0.05 * clear ? clear - d : 0.05 * clear;
            if (n[0] != 0 || n[1] != 0 || n[2] != 0) {
                for (int j = 0; j < 3; j++)
                    c[j] += step * n[j];
            } else if (d > 0) { /* no normal (a vertex in no face): away from the body */
                for (int j = 0; j < 3; j++)
                    c[j] += step * (c[j] - q[j]) / d;
            } else {
                break;
            }
        }
        for (int32_t v = 0; v < ball.nv; v++) {
            for (int j = 0; j < 3; j++)
                res.V[3 * (size_t)(vb + v) + j] = c[j] + r * ball.V[3 * v + j];
            omap[vb + v] = anchors[i];
        }
        for (int32_t f = 0; f < 3 * ball.nf; f++)
            res.F[3 * (size_t)fb + f] = vb + ball.F[f];
    }
    dtx_bvh_free(&bvh);
    free(N);
    dtx_mesh_free(&ball);
    *out = res;
    *map = omap;
    return DTX_OK;
nomem:
    st = dtx_seterr(err, DTX_ENOMEM, "eyes: out of memory");
fail:
    dtx_bvh_free(&bvh);
    free(N);
    free(omap);
    dtx_mesh_free(&ball);
    dtx_mesh_free(&res);
    return st;
}

/* ------------------------------------------------------------ remapping */

dtx_status dtx_gen_remap(const int32_t *map, int32_t nv_out, int32_t nv_in, int32_t n, int32_t *idx,
                         int32_t *bad, dtx_error *err)
{
    int32_t *first;
    if (bad)
        *bad = -1;
    for (int32_t i = 0; i < n; i++)
        if (idx[i] < 0 || idx[i] >= nv_in) {
            if (bad)
                *bad = i;
            return dtx_seterr(err, DTX_ERANGE, "index %d (at position %d) outside [0, %d)",
                              (int)idx[i], (int)i, (int)nv_in);
        }
    first = dtx_alloc((size_t)nv_in, sizeof *first, 0);
    if (!first)
        return dtx_seterr(err, DTX_ENOMEM, "remap: out of memory");
    for (int32_t v = 0; v < nv_in; v++)
        first[v] = -1;
    for (int32_t v = nv_out - 1; v >= 0; v--)
        if (map[v] >= 0 && map[v] < nv_in)
            first[map[v]] = v;
    for (int32_t i = 0; i < n; i++)
        if (first[idx[i]] < 0) {
            if (bad)
                *bad = i;
            dtx_seterr(err, DTX_EINVAL, "index %d (at position %d) has no generated vertex",
                       (int)idx[i], (int)i);
            free(first);
            return DTX_EINVAL;
        }
    for (int32_t i = 0; i < n; i++)
        idx[i] = first[idx[i]];
    free(first);
    return DTX_OK;
}
