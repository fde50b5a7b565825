/*
 * coarsen.c: vertex clustering of a spring network and the coarse springs
 * between the clusters (see coarsen.h), for the multigrid start of the
 * springs method.
 */
#include "coarsen.h"

#include <stdlib.h>
#include <string.h>

typedef struct {
    int32_t i, j;
    int32_t kind;
} pair_kind;

static int compare_pair_kind(const void *a, const void *b)
{
    const pair_kind *x = a, *y = b;
    if (x->i != y->i)
        return x->i < y->i ? -1 : 1;
    if (x->j != y->j)
        return x->j < y->j ? -1 : 1;
    return (x->kind > y->kind) - (x->kind < y->kind);
}

int32_t dtx__springs_sort_unique(int32_t *ends, unsigned char *kind, int32_t n,
                                 int32_t count[DTX_SPRING_KINDS])
{
    pair_kind *pk = dtx_alloc((size_t)n, sizeof *pk, 0);
    int32_t m = 0;
    for (int k = 0; k < DTX_SPRING_KINDS; k++)
        count[k] = 0;
    if (!pk)
        return -1;
    for (int32_t s = 0; s < n; s++) {
        pk[s].i = ends[2 * (size_t)s];
        pk[s].j = ends[2 * (size_t)s + 1];
        pk[s].kind = kind[s];
    }
    qsort(pk, (size_t)n, sizeof *pk, compare_pair_kind);
    for (int32_t s = 0; s < n; s++) {
        if (m > 0 && pk[s].i == ends[2 * (size_t)(m - 1)] &&
            pk[s].j == ends[2 * (size_t)(m - 1) + 1])
            continue;
        ends[2 * (size_t)m] = pk[s].i;
        ends[2 * (size_t)m + 1] = pk[s].j;
        kind[m] = (unsigned char)pk[s].kind;
        count[pk[s].kind]++;
        m++;
    }
    free(pk);
    return m;
}

void dtx_coarse_level_free(dtx_coarse_level *c)
{
    if (!c)
        return;
    free(c->rep);
    free(c->cluster);
    dtx_spring_set_free(&c->springs);
    memset(c, 0, sizeof *c);
}

int dtx__spring_adjacency(int32_t n, const int32_t *ends, const unsigned char *kind, int32_t ns,
                          int want, int32_t **adjp_out, int32_t **adj_out)
{
    int32_t *adjp = dtx_alloc((size_t)n + 1, sizeof *adjp, 1), *adj = NULL, *fill = NULL;
    int64_t m = 0;
    if (!adjp)
        return 0;
    for (int32_t s = 0; s < ns; s++)
        if (kind[s] == want) {
            adjp[ends[2 * (size_t)s] + 1]++;
            adjp[ends[2 * (size_t)s + 1] + 1]++;
            m += 2;
        }
    for (int32_t v = 0; v < n; v++)
        adjp[v + 1] += adjp[v];
    adj = dtx_alloc((size_t)m, sizeof *adj, 0);
    fill = dtx_alloc((size_t)n, sizeof *fill, 0);
    if (!adj || !fill) {
        free(adjp);
        free(adj);
        free(fill);
        return 0;
    }
    memcpy(fill, adjp, (size_t)n * sizeof *fill);
    for (int32_t s = 0; s < ns; s++)
        if (kind[s] == want) {
            int32_t i = ends[2 * (size_t)s], j = ends[2 * (size_t)s + 1];
            adj[fill[i]++] = j;
            adj[fill[j]++] = i;
        }
    for (int32_t v = 0; v < n; v++) {
        /* Insertion sort: the lists are short (vertex valences). */
        for (int32_t a = adjp[v] + 1; a < adjp[v + 1]; a++) {
            int32_t x = adj[a], b = a - 1;
            while (b >= adjp[v] && adj[b] > x) {
                adj[b + 1] = adj[b];
                b--;
            }
            adj[b + 1] = x;
        }
    }
    free(fill);
    *adjp_out = adjp;
    *adj_out = adj;
    return 1;
}

dtx_status dtx_coarsen(int32_t nfine, const dtx_spring_set *fine, dtx_coarse_level *out,
                       dtx_error *err)
{
    int32_t *adjp = NULL, *adj = NULL, *hop = NULL, *queue = NULL, *touched = NULL;
    int32_t *cadjp = NULL, *cadj = NULL, *ends = NULL;
    unsigned char *kind = NULL, *covered = NULL;
    int64_t cap = 0, m = 0;
    int32_t nc = 0, nt = 0;
    dtx_status st;

    memset(out, 0, sizeof *out);
    if (!dtx__spring_adjacency(nfine, fine->ends, fine->kind, fine->n, DTX_SPRING_EDGE, &adjp,
                               &adj))
        goto nomem;
    out->cluster = dtx_alloc((size_t)nfine, sizeof *out->cluster, 0);
    hop = dtx_alloc((size_t)nfine, sizeof *hop, 0);
    queue = dtx_alloc((size_t)nfine, sizeof *queue, 0);
    touched = dtx_alloc((size_t)nfine, sizeof *touched, 0);
    covered = dtx_alloc((size_t)nfine, 1, 0);
    if (!out->cluster || !hop || !queue || !touched || !covered)
        goto nomem;

    /* ---- Seeds: no two within two hops. ---- */
    for (int32_t v = 0; v < nfine; v++) {
        out->cluster[v] = -1;
        hop[v] = -1; /* hops from the current seed, -1 when not reached */
        covered[v] = 0;
    }
    for (int32_t v = 0; v < nfine; v++) {
        int32_t head = 0;
        if (adjp[v] == adjp[v + 1] || covered[v])
            continue;
        /* v is a seed: cover its two-ring. */
        out->cluster[v] = nc++;
        hop[v] = 0;
        nt = 0;
        touched[nt++] = v;
        while (head < nt) {
            int32_t u = touched[head++];
            covered[u] = 1;
            if (hop[u] == 2)
                continue;
            for (int32_t a = adjp[u]; a < adjp[u + 1]; a++) {
                int32_t w = adj[a];
                if (hop[w] < 0) {
                    hop[w] = hop[u] + 1;
                    touched[nt++] = w;
                }
            }
        }
        for (int32_t t = 0; t < nt; t++)
            hop[touched[t]] = -1;
    }
    out->n = nc;
    out->rep = dtx_alloc((size_t)nc, sizeof *out->rep, 0);
    if (!out->rep)
        goto nomem;

    /* ---- Clusters: breadth-first from all seeds at once. ---- */
    {
        int32_t head = 0, tail = 0;
        for (int32_t v = 0; v < nfine; v++)
            if (out->cluster[v] >= 0) {
                out->rep[out->cluster[v]] = v;
                queue[tail++] = v;
            }
        while (head < tail) {
            int32_t u = queue[head++];
            for (int32_t a = adjp[u]; a < adjp[u + 1]; a++) {
                int32_t w = adj[a];
                if (out->cluster[w] < 0) {
                    out->cluster[w] = out->cluster[u];
                    queue[tail++] = w;
                }
            }
        }
    }

    /* ---- Coarse springs. ---- */
    /* Edge and internal springs mapped onto the clusters. */
    cap = fine->n > 0 ? fine->n : 1;
    ends = dtx_alloc((size_t)cap, 2 * sizeof *ends, 0);
    kind = dtx_alloc((size_t)cap, 1, 0);
    if (!ends || !kind)
        goto nomem;
    for (int32_t s = 0; s < fine->n; s++) {
        int32_t a = out->cluster[fine->ends[2 * (size_t)s]];
        int32_t b = out->cluster[fine->ends[2 * (size_t)s + 1]];
        int k = fine->kind[s];
        if (k == DTX_SPRING_BENDING || a < 0 || b < 0 || a == b)
            continue;
        ends[2 * m] = a < b ? a : b;
        ends[2 * m + 1] = a < b ? b : a;
        kind[m++] = (unsigned char)k;
    }
    {
        int32_t cnt[DTX_SPRING_KINDS];
        int32_t mm = dtx__springs_sort_unique(ends, kind, (int32_t)m, cnt);
        if (mm < 0)
            goto nomem;
        m = mm;
    }
    /* Bending: pairs of edge neighbours of one coarse vertex that are not
     * neighbours themselves. */
    if (!dtx__spring_adjacency(nc, ends, kind, (int32_t)m, DTX_SPRING_EDGE, &cadjp, &cadj))
        goto nomem;
    {
        int64_t extra = 0;
        for (int32_t c = 0; c < nc; c++) {
            int64_t d = cadjp[c + 1] - cadjp[c];
            extra += d * (d - 1) / 2;
        }
        if (m + extra > INT32_MAX)
            goto nomem;
        if (m + extra > cap) {
            int32_t *e2 = realloc(ends, (size_t)(m + extra) * 2 * sizeof *ends);
            unsigned char *k2;
            if (!e2)
                goto nomem;
            ends = e2;
            k2 = realloc(kind, (size_t)(m + extra));
            if (!k2)
                goto nomem;
            kind = k2;
        }
    }
    for (int32_t c = 0; c < nc; c++)
        for (int32_t a = cadjp[c]; a < cadjp[c + 1]; a++)
            for (int32_t b = a + 1; b < cadjp[c + 1]; b++) {
                /* cadj is sorted: cadj[a] < cadj[b].  Pairs that are edges
                 * are dropped by the sort (edge has precedence). */
                ends[2 * m] = cadj[a];
                ends[2 * m + 1] = cadj[b];
                kind[m++] = DTX_SPRING_BENDING;
            }
    {
        int32_t mm = dtx__springs_sort_unique(ends, kind, (int32_t)m, out->springs.count);
        if (mm < 0)
            goto nomem;
        out->springs.n = mm;
        out->springs.ends = ends;
        out->springs.kind = kind;
        ends = NULL;
        kind = NULL;
    }
    st = DTX_OK;
    goto done;

nomem:
    free(ends);
    free(kind);
    dtx_coarse_level_free(out);
    st = dtx_seterr(err, DTX_ENOMEM, "out of memory coarsening the spring network");
done:
    free(adjp);
    free(adj);
    free(cadjp);
    free(cadj);
    free(hop);
    free(queue);
    free(touched);
    free(covered);
    return st;
}
