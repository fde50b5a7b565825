/*
 * proximity.c: the proximity graph of a multi-component mesh and its
 * proximity pairs (Zhou, Xu, Tong & Desbrun 2010, section 2.1), and the
 * triangle pairs of the E_R term (section 2.2).
 *
 * Method:
 *  1. Components by union-find over the faces; eps per component.
 *  2. A k-d tree over the vertices in faces, split at the median of the
 *     longest axis (depth below log2 n + 2); every node knows the lowest and
 *     highest component below it.
 *  3. The minimum spanning tree of the complete component graph without
 *     forming it, by Boruvka rounds: every vertex finds its nearest vertex
 *     in another cluster (subtrees wholly inside its own cluster are
 *     skipped), each cluster takes its lightest outgoing edge and the
 *     clusters merge, at least halving their number per round.  A vertex's
 *     nearest foreign vertex stays the nearest until the two clusters merge
 *     (the foreign set only shrinks), so only those queries are redone, and
 *     within a bound that the kept ones give their cluster.
 *  4. Graph edges: every graph edge has d_ab <= min(r_a, r_b), r_a = d_a +
 *     eps_a (tree edges too, since d_ab <= d_a), so a radius query of radius
 *     r_a from every vertex of component a, skipping nodes farther than
 *     every r_b below them, finds the closest vertex of every candidate
 *     component b > a.
 *  5. Pairs: for every edge (a, b) and every vertex of a near b's bounding
 *     box, a radius query restricted to b.
 *
 * Steps 3-5 run on OpenMP threads over vertices or components.  Every
 * result is the minimum under a strict total order or a set, so the bits do
 * not depend on the thread count.  Steps 4 and 5 write each component's
 * records, already in output order, into per-thread buffers allocated
 * before the parallel loop; the output is the components' records in
 * component order.  A component whose records do not fit is done again
 * after the full buffers have been grown.
 *
 * The searches compare squared distances against r^2 enlarged by a relative
 * 1e-12, so they never drop a candidate to rounding; the rules themselves
 * (d <= r, d < d_ab + eps) are then tested on distances exactly as written.
 */
#include "proximity.h"

#include "graph.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#define KD_LEAF 8    /* a node with more points is split */
#define KD_STACK 192 /* traversal stack; the depth is below 34 for 2^31 points */

static int max_threads(void)
{
#ifdef _OPENMP
    return omp_get_max_threads();
#else
    return 1;
#endif
}

static int thread_num(void)
{
#ifdef _OPENMP
    return omp_get_thread_num();
#else
    return 0;
#endif
}

/* Squared distance, written once so that the same two points always give
 * the same bits (also swapped: the differences only change sign). */
static inline double dist2(const double *p, const double *q)
{
    double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
    return dx * dx + dy * dy + dz * dz;
}

/* A search bound for squared distances that is safe against the rounding
 * of sqrt: sqrt(d2) <= r implies d2 <= search2(r). */
static inline double search2(double r) { return r * r * (1.0 + 1e-12); }

/* ------------------------------------------------------------------ */
/* Input checks and components                                         */
/* ------------------------------------------------------------------ */

static dtx_status check_mesh(const dtx_mesh *m, dtx_error *err)
{
    if (m->nv < 0 || m->nf < 0 || (m->nv > 0 && !m->V) || (m->nf > 0 && !m->F))
        return dtx_seterr(err, DTX_EINVAL,
                          "proximity: mesh with %d vertices and %d faces "
                          "has missing or negative arrays",
                          (int)m->nv, (int)m->nf);
    for (int32_t f = 0; f < m->nf; f++)
        for (int k = 0; k < 3; k++) {
            int32_t v = m->F[3 * f + k];
            if (v < 0 || v >= m->nv)
                return dtx_seterr(err, DTX_ERANGE,
                                  "proximity: face %d (0-based) has vertex "
                                  "index %d out of range [0, %d)",
                                  (int)f, (int)v, (int)m->nv);
            if (!isfinite(m->V[3 * v]) || !isfinite(m->V[3 * v + 1]) || !isfinite(m->V[3 * v + 2]))
                return dtx_seterr(err, DTX_ENONFINITE,
                                  "proximity: vertex %d (0-based, in "
                                  "face %d) has a non-finite coordinate",
                                  (int)v, (int)f);
        }
    return DTX_OK;
}

/* eps[c] = eps_factor x the longest edge of component c. */
static void component_eps(const dtx_mesh *m, const int32_t *comp, double eps_factor, int32_t ncomp,
                          double *eps)
{
    for (int32_t c = 0; c < ncomp; c++)
        eps[c] = 0.0;
    for (int32_t f = 0; f < m->nf; f++) {
        const int32_t *t = m->F + 3 * f;
        double *e = &eps[comp[t[0]]];
        for (int k = 0; k < 3; k++) {
            double len = sqrt(dist2(m->V + 3 * t[k], m->V + 3 * t[(k + 1) % 3]));
            *e = len > *e ? len : *e;
        }
    }
    for (int32_t c = 0; c < ncomp; c++)
        eps[c] *= eps_factor;
}

/* ------------------------------------------------------------------ */
/* k-d tree over the vertices in faces                                 */
/* ------------------------------------------------------------------ */

/* Not the point mode of bvh.c, on purpose: the searches here prune whole
 * subtrees by what lies below a node (one cluster only, lab[]; the range of
 * components, clo/chi), which dtx_bvh's per-primitive filter callback cannot
 * do, and they break ties by (d2, component, vertex) rather than by index.
 * The BVH in turn serves triangles and points with one traversal and a
 * filter that depends on the query (the normal test of the
 * correspondences).  One index for both would carry the other's extras on
 * every query. */

typedef struct {
    double lo[3], hi[3];
    int32_t first; /* leaf: first point (tree order); inner: left child (right = left + 1) */
    int32_t count; /* leaf: number of points; inner: 0 */
} kd_node;

typedef struct {
    int32_t n, nnodes;
    kd_node *node;      /* nnodes; children have higher indices than parents */
    double *x;          /* n x 3: positions in tree order */
    int32_t *vid;       /* n: vertex of each point */
    int32_t *comp;      /* n: component of each point */
    int32_t *clo, *chi; /* nnodes: lowest and highest component below the node */
} kd_tree;

static void kd_free(kd_tree *t)
{
    free(t->node);
    free(t->x);
    free(t->vid);
    free(t->comp);
    free(t->clo);
    free(t->chi);
    memset(t, 0, sizeof *t);
}

/* Strict order of vertices along an axis: coordinate, then index. */
static inline int kd_less(const double *V, int axis, int32_t a, int32_t b)
{
    double xa = V[3 * a + axis], xb = V[3 * b + axis];
    return xa < xb || (xa == xb && a < b);
}

/* Quickselect: puts the k-th smallest of o[0..n) at o[k], smaller before,
 * larger after. */
static void kd_select(const double *V, int axis, int32_t *o, int32_t n, int32_t k)
{
    int32_t lo = 0, hi = n - 1;
    while (hi > lo) {
        int32_t mid = lo + (hi - lo) / 2, i = lo, j = hi, pivot, tmp;
        /* Median of three as the pivot. */
        if (kd_less(V, axis, o[mid], o[lo]))
            tmp = o[mid], o[mid] = o[lo], o[lo] = tmp;
        if (kd_less(V, axis, o[hi], o[lo]))
            tmp = o[hi], o[hi] = o[lo], o[lo] = tmp;
        if (kd_less(V, axis, o[hi], o[mid]))
            tmp = o[hi], o[hi] = o[mid], o[mid] = tmp;
        pivot = o[mid];
        while (i <= j) {
            while (kd_less(V, axis, o[i], pivot))
                i++;
            while (kd_less(V, axis, pivot, o[j]))
                j--;
            if (i <= j) {
                tmp = o[i], o[i] = o[j], o[j] = tmp;
                i++;
                j--;
            }
        }
        if (k <= j)
            hi = j;
        else if (k >= i)
            lo = i;
        else
            return;
    }
}

/* Builds node ni over o[first .. first + count); returns the next free
 * node index. */
static int32_t kd_build_node(kd_tree *t, const double *V, int32_t *o, int32_t ni, int32_t first,
                             int32_t count, int32_t next)
{
    kd_node *nd = &t->node[ni];
    int axis = 0;
    int32_t mid = count / 2;
    for (int k = 0; k < 3; k++) {
        nd->lo[k] = INFINITY;
        nd->hi[k] = -INFINITY;
    }
    for (int32_t q = first; q < first + count; q++)
        for (int k = 0; k < 3; k++) {
            double x = V[3 * o[q] + k];
            nd->lo[k] = x < nd->lo[k] ? x : nd->lo[k];
            nd->hi[k] = x > nd->hi[k] ? x : nd->hi[k];
        }
    if (count <= KD_LEAF) {
        nd->first = first;
        nd->count = count;
        return next;
    }
    for (int k = 1; k < 3; k++)
        if (nd->hi[k] - nd->lo[k] > nd->hi[axis] - nd->lo[axis])
            axis = k;
    kd_select(V, axis, o + first, count, mid);
    nd->first = next;
    nd->count = 0;
    next += 2;
    next = kd_build_node(t, V, o, t->node[ni].first, first, mid, next);
    return kd_build_node(t, V, o, t->node[ni].first + 1, first + mid, count - mid, next);
}

/* The tree over the vertices listed in verts (n of them; reordered). */
static dtx_status kd_build(const double *V, const int32_t *comp, int32_t *verts, int32_t n,
                           kd_tree *t)
{
    /* Split nodes hold > KD_LEAF points and halve them, so every leaf has
     * at least KD_LEAF / 2 points: fewer than n / 2 + 1 nodes. */
    size_t cap = (size_t)n / (KD_LEAF / 2) * 2 + 1;
    memset(t, 0, sizeof *t);
    t->n = n;
    t->node = dtx_alloc(cap, sizeof *t->node, 0);
    t->x = dtx_alloc((size_t)n, 3 * sizeof *t->x, 0);
    t->vid = dtx_alloc((size_t)n, sizeof *t->vid, 0);
    t->comp = dtx_alloc((size_t)n, sizeof *t->comp, 0);
    t->clo = dtx_alloc(cap, sizeof *t->clo, 0);
    t->chi = dtx_alloc(cap, sizeof *t->chi, 0);
    if (!t->node || !t->x || !t->vid || !t->comp || !t->clo || !t->chi) {
        kd_free(t);
        return DTX_ENOMEM;
    }
    t->nnodes = kd_build_node(t, V, verts, 0, 0, n, 1);
    for (int32_t q = 0; q < n; q++) {
        for (int k = 0; k < 3; k++)
            t->x[3 * q + k] = V[3 * verts[q] + k];
        t->vid[q] = verts[q];
        t->comp[q] = comp[verts[q]];
    }
    for (int32_t ni = t->nnodes - 1; ni >= 0; ni--) {
        const kd_node *nd = &t->node[ni];
        if (nd->count > 0) {
            t->clo[ni] = INT32_MAX;
            t->chi[ni] = -1;
            for (int32_t q = nd->first; q < nd->first + nd->count; q++) {
                t->clo[ni] = t->comp[q] < t->clo[ni] ? t->comp[q] : t->clo[ni];
                t->chi[ni] = t->comp[q] > t->chi[ni] ? t->comp[q] : t->chi[ni];
            }
        } else {
            int32_t l = nd->first, r = nd->first + 1;
            t->clo[ni] = t->clo[l] < t->clo[r] ? t->clo[l] : t->clo[r];
            t->chi[ni] = t->chi[l] > t->chi[r] ? t->chi[l] : t->chi[r];
        }
    }
    return DTX_OK;
}

/* Squared distance from p to the node's box; never more than dist2 from p
 * to a point in the box (same operations, rounding is monotone). */
static inline double box_d2(const kd_node *nd, const double *p)
{
    double d2 = 0.0;
    for (int k = 0; k < 3; k++) {
        double d =
            p[k] < nd->lo[k] ? nd->lo[k] - p[k] : (p[k] > nd->hi[k] ? p[k] - nd->hi[k] : 0.0);
        d2 += d * d;
    }
    return d2;
}

/* Pushes the children of inner node nd, the nearer one last (visited first). */
static inline void push_children(const kd_tree *t, const kd_node *nd, const double *p,
                                 int32_t *stack, int *sp)
{
    int32_t l = nd->first, r = nd->first + 1;
    if (box_d2(&t->node[l], p) <= box_d2(&t->node[r], p)) {
        stack[(*sp)++] = r;
        stack[(*sp)++] = l;
    } else {
        stack[(*sp)++] = l;
        stack[(*sp)++] = r;
    }
}

/* ------------------------------------------------------------------ */
/* Minimum spanning tree by Boruvka rounds                             */
/* ------------------------------------------------------------------ */

/* The nearest point to p whose cluster (pcl, tree order) is not cl, among
 * those with d2 <= bound: the minimum of (d2, component, vertex).  lab: per
 * node, the one cluster of its points or -1.  Returns its tree index and d2
 * (-1 if there is none within the bound). */
static int32_t nn_foreign(const kd_tree *t, const int32_t *pcl, const int32_t *lab, const double *p,
                          int32_t cl, double bound, double *d2out)
{
    int32_t stack[KD_STACK];
    int sp = 0;
    int32_t best = -1;
    double bd2 = bound;
    stack[sp++] = 0;
    while (sp > 0) {
        int32_t ni = stack[--sp];
        const kd_node *nd = &t->node[ni];
        if (lab[ni] == cl || box_d2(nd, p) > bd2)
            continue;
        if (nd->count == 0) {
            push_children(t, nd, p, stack, &sp);
            continue;
        }
        for (int32_t q = nd->first; q < nd->first + nd->count; q++) {
            double d2;
            if (pcl[q] == cl)
                continue;
            d2 = dist2(p, t->x + 3 * q);
            if (best < 0 ? d2 <= bd2
                         : (d2 < bd2 || (d2 == bd2 && (t->comp[q] < t->comp[best] ||
                                                       (t->comp[q] == t->comp[best] &&
                                                        t->vid[q] < t->vid[best]))))) {
                best = q;
                bd2 = d2;
            }
        }
    }
    *d2out = bd2;
    return best;
}

/* The minimum spanning tree of the components of t, edges ordered by
 * (d2, lower component, higher component): tree (ncomp - 1) x 2 (lower,
 * higher) and tree_d2.  Returns the number of tree edges, or -1 when out of
 * memory. */
static int32_t mst_boruvka(const kd_tree *t, int32_t ncomp, int32_t *tree, double *tree_d2)
{
    int32_t n = t->n, ntree = 0, ncl = ncomp;
    int32_t *parent = dtx_alloc((size_t)ncomp, sizeof *parent, 0);
    int32_t *pcl = dtx_alloc((size_t)n, sizeof *pcl, 0);
    int32_t *lab = dtx_alloc((size_t)t->nnodes, sizeof *lab, 0);
    int32_t *nnq = dtx_alloc((size_t)n, sizeof *nnq, 0);
    double *nnd2 = dtx_alloc((size_t)n, sizeof *nnd2, 0);
    double *cd2 = dtx_alloc((size_t)ncomp, sizeof *cd2, 0);
    double *cbound = dtx_alloc((size_t)ncomp, sizeof *cbound, 0);
    int32_t *clo = dtx_alloc((size_t)ncomp, sizeof *clo, 0);
    int32_t *chi = dtx_alloc((size_t)ncomp, sizeof *chi, 0);
    if (!parent || !pcl || !lab || !nnq || !nnd2 || !cd2 || !cbound || !clo || !chi) {
        ntree = -1;
        goto done;
    }
    dtx__uf_init(parent, ncomp);
    for (int32_t q = 0; q < n; q++) {
        pcl[q] = t->comp[q];
        nnq[q] = -1;
        nnd2[q] = 0.0;
    }
    while (ncl > 1) {
        int32_t merged = 0;

        /* Node labels: the one cluster below a node, or -1. */
        for (int32_t ni = t->nnodes - 1; ni >= 0; ni--) {
            const kd_node *nd = &t->node[ni];
            if (nd->count > 0) {
                lab[ni] = pcl[nd->first];
                for (int32_t q = nd->first + 1; q < nd->first + nd->count; q++)
                    if (pcl[q] != lab[ni])
                        lab[ni] = -1;
            } else {
                lab[ni] = lab[nd->first] == lab[nd->first + 1] ? lab[nd->first] : -1;
            }
        }

        /* Nearest foreign point of every point.  One found in an earlier
         * round is still the nearest while it is foreign (the foreign set
         * only shrinks).  Those give each cluster a bound (cbound) that the
         * other points' searches need not pass, since only the cluster
         * minimum matters: a point with nothing within it keeps a lower
         * bound in nnd2 (nnq < 0) and is not searched again while that is
         * above its cluster's bound.  Such points are strictly farther than
         * the minimum, so no tie is lost, and every bound comes from the
         * previous round, so the threads do not change the result. */
        for (int32_t c = 0; c < ncomp; c++)
            cbound[c] = INFINITY;
        for (int32_t q = 0; q < n; q++) {
            int32_t j = nnq[q];
            if (j >= 0 && pcl[j] != pcl[q] && nnd2[q] < cbound[pcl[q]])
                cbound[pcl[q]] = nnd2[q];
        }
#pragma omp parallel for schedule(dynamic, 64)
        for (int32_t q = 0; q < n; q++) {
            int32_t j = nnq[q];
            double bound = cbound[pcl[q]], d2;
            if (j >= 0 && pcl[j] != pcl[q])
                continue;
            if (nnd2[q] > bound) {
                nnq[q] = -1;
                continue;
            }
            nnq[q] = nn_foreign(t, pcl, lab, t->x + 3 * q, pcl[q], bound, &d2);
            nnd2[q] = nnq[q] >= 0 ? d2 : bound;
        }

        /* Lightest outgoing edge of every cluster (indexed by its root). */
        for (int32_t c = 0; c < ncomp; c++)
            clo[c] = -1;
        for (int32_t q = 0; q < n; q++) {
            int32_t j = nnq[q], c = pcl[q], a, b, lo, hi;
            double d2 = nnd2[q];
            if (j < 0 || pcl[j] == c)
                continue;
            a = t->comp[q];
            b = t->comp[j];
            lo = a < b ? a : b;
            hi = a < b ? b : a;
            if (clo[c] < 0 || d2 < cd2[c] ||
                (d2 == cd2[c] && (lo < clo[c] || (lo == clo[c] && hi < chi[c])))) {
                cd2[c] = d2;
                clo[c] = lo;
                chi[c] = hi;
            }
        }

        /* Merge along them; two clusters may have chosen the same edge. */
        for (int32_t c = 0; c < ncomp; c++) {
            if (clo[c] < 0 || !dtx__uf_union(parent, clo[c], chi[c]))
                continue;
            tree[2 * ntree] = clo[c];
            tree[2 * ntree + 1] = chi[c];
            tree_d2[ntree++] = cd2[c];
            merged++;
        }
        if (merged == 0)
            break; /* unreachable: every cluster has an outgoing edge */
        ncl -= merged;
        for (int32_t q = 0; q < n; q++)
            pcl[q] = dtx__uf_find(parent, t->comp[q]);
    }
done:
    free(parent);
    free(pcl);
    free(lab);
    free(nnq);
    free(nnd2);
    free(cd2);
    free(cbound);
    free(clo);
    free(chi);
    return ntree;
}

/* ------------------------------------------------------------------ */
/* Per-component tasks with per-thread output buffers                  */
/* ------------------------------------------------------------------ */

typedef struct {
    int32_t b, i, j; /* edge (a, b) of the task's component a, closest pair */
    double d2;
} edge_rec;

typedef struct {
    int32_t e, i, j;
    double len;
} pair_rec;

/* A thread's output: records of `size` bytes; `full` once a push did not
 * fit (the task's records are then dropped and the task done again). */
typedef struct {
    unsigned char *rec;
    size_t size, n, cap;
    int full;
} tbuf;

static inline void tbuf_push(tbuf *b, const void *r)
{
    if (b->n == b->cap) {
        b->full = 1;
        return;
    }
    memcpy(b->rec + b->n * b->size, r, b->size);
    b->n++;
}

/* Where each component's records went: thread, first record, count. */
typedef struct {
    int32_t *tid;
    size_t *off, *n;
} chunks;

/* A thread's scratch, indexed by component; kept clean between tasks. */
typedef struct {
    double *bd2;      /* closest squared distance to each touched component */
    int32_t *bi, *bj; /* its vertex pair; bi = -1 when untouched */
    int32_t *touched;
} scratch;

typedef struct {
    const kd_tree *t;
    const double *V;
    int32_t ncomp;
    const int32_t *cstart, *cvert; /* vertices of each component, ascending */
    const kd_node *cbox;           /* ncomp: bounding box of each component */
    /* Edge search. */
    const double *r, *r2;  /* ncomp: d_a + eps_a and its search bound */
    const double *node_r2; /* nnodes: max r2 of the components below */
    /* Pair search. */
    const int32_t *estart;        /* ncomp + 1: edges with a as lower end */
    const int32_t *eb, *ei, *ej;  /* nedges: b and closest pair */
    const double *edist, *R, *R2; /* nedges: d_ab, d_ab + min(eps_a, eps_b), bound */
} prox_ctx;

typedef void (*comp_task)(const prox_ctx *c, int32_t a, scratch *s, tbuf *out);

static int cmp_edge_b(const void *x, const void *y)
{
    const edge_rec *p = x, *q = y;
    return p->b < q->b ? -1 : (p->b > q->b);
}

static int cmp_pair_j(const void *x, const void *y)
{
    const pair_rec *p = x, *q = y;
    return p->j < q->j ? -1 : (p->j > q->j);
}

/* Candidate edges (a, b > a) with their closest pairs, sorted by b. */
static void edge_task(const prox_ctx *c, int32_t a, scratch *s, tbuf *out)
{
    const kd_tree *t = c->t;
    double ra2 = c->r2[a];
    int32_t ntouched = 0;
    size_t mark = out->n;
    for (int32_t u = c->cstart[a]; u < c->cstart[a + 1]; u++) {
        int32_t i = c->cvert[u], stack[KD_STACK];
        const double *p = c->V + 3 * i;
        int sp = 0;
        stack[sp++] = 0;
        while (sp > 0) {
            int32_t ni = stack[--sp];
            const kd_node *nd = &t->node[ni];
            double bd;
            if (t->chi[ni] <= a)
                continue;
            bd = box_d2(nd, p);
            if (bd > ra2 || bd > c->node_r2[ni])
                continue;
            if (t->clo[ni] == t->chi[ni] && s->bi[t->clo[ni]] >= 0 && bd > s->bd2[t->clo[ni]])
                continue;
            if (nd->count == 0) {
                push_children(t, nd, p, stack, &sp);
                continue;
            }
            for (int32_t q = nd->first; q < nd->first + nd->count; q++) {
                int32_t b = t->comp[q], j = t->vid[q];
                double d2;
                if (b <= a)
                    continue;
                d2 = dist2(p, t->x + 3 * q);
                if (d2 > ra2 || d2 > c->r2[b])
                    continue;
                if (s->bi[b] < 0) {
                    s->touched[ntouched++] = b;
                } else if (!(d2 < s->bd2[b] ||
                             (d2 == s->bd2[b] &&
                              (i < s->bi[b] || (i == s->bi[b] && j < s->bj[b]))))) {
                    continue;
                }
                s->bd2[b] = d2;
                s->bi[b] = i;
                s->bj[b] = j;
            }
        }
    }
    for (int32_t u = 0; u < ntouched; u++) {
        int32_t b = s->touched[u];
        double d = sqrt(s->bd2[b]);
        if (d <= c->r[a] && d <= c->r[b]) {
            edge_rec e = {b, s->bi[b], s->bj[b], s->bd2[b]};
            tbuf_push(out, &e);
        }
        s->bi[b] = -1;
    }
    if (!out->full)
        qsort(out->rec + mark * out->size, out->n - mark, out->size, cmp_edge_b);
}

/* Proximity pairs of the edges (a, b > a), sorted by (edge, i, j): edges
 * in order, for each the vertices i of a in order, for each a radius query
 * restricted to b, whose hits are then sorted by j. */
static void pair_task(const prox_ctx *c, int32_t a, scratch *s, tbuf *out)
{
    const kd_tree *t = c->t;
    (void)s;
    for (int32_t e = c->estart[a]; e < c->estart[a + 1]; e++) {
        int32_t b = c->eb[e];
        double R = c->R[e], R2 = c->R2[e];
        /* The closest pair when the radius rule does not take it (eps = 0). */
        int closest_apart = !(c->edist[e] < R);
        for (int32_t u = c->cstart[a]; u < c->cstart[a + 1]; u++) {
            int32_t i = c->cvert[u], stack[KD_STACK];
            const double *p = c->V + 3 * i;
            size_t mark = out->n;
            int sp = 0;
            if (closest_apart && i == c->ei[e]) {
                pair_rec rec = {e, i, c->ej[e], c->edist[e]};
                tbuf_push(out, &rec);
            }
            if (box_d2(&c->cbox[b], p) > R2)
                continue;
            stack[sp++] = 0;
            while (sp > 0) {
                int32_t ni = stack[--sp];
                const kd_node *nd = &t->node[ni];
                if (t->clo[ni] > b || t->chi[ni] < b || box_d2(nd, p) > R2)
                    continue;
                if (nd->count == 0) {
                    push_children(t, nd, p, stack, &sp);
                    continue;
                }
                for (int32_t q = nd->first; q < nd->first + nd->count; q++) {
                    double d2, len;
                    if (t->comp[q] != b)
                        continue;
                    d2 = dist2(p, t->x + 3 * q);
                    if (d2 <= R2 && (len = sqrt(d2)) < R) {
                        pair_rec rec = {e, i, t->vid[q], len};
                        tbuf_push(out, &rec);
                    }
                }
            }
            if (out->full)
                return;
            /* Hits of one i: sort by j (insertion sort for short runs). */
            if (out->n - mark > 32) {
                qsort(out->rec + mark * out->size, out->n - mark, out->size, cmp_pair_j);
            } else {
                pair_rec *r = (pair_rec *)(void *)(out->rec + mark * out->size);
                size_t k = out->n - mark;
                for (size_t x = 1; x < k; x++) {
                    pair_rec v = r[x];
                    size_t y = x;
                    for (; y > 0 && r[y - 1].j > v.j; y--)
                        r[y] = r[y - 1];
                    r[y] = v;
                }
            }
        }
    }
}

/* Runs task for every component on the OpenMP threads (nthreads buffers
 * and scratches) and notes where each component's records are.  A task
 * that overflows its thread's buffer is dropped and run again once the full
 * buffers have doubled.  todo: ncomp, redo: ncomp zeroed (both scratch). */
static dtx_status run_tasks(const prox_ctx *c, comp_task task, scratch *scr, tbuf *buf,
                            int nthreads, int32_t *todo, unsigned char *redo, chunks *ch,
                            dtx_error *err)
{
    int32_t ntodo = c->ncomp;
    for (int32_t a = 0; a < c->ncomp; a++)
        todo[a] = a;
    while (ntodo > 0) {
        int32_t nleft = 0;
#pragma omp parallel for schedule(dynamic, 1) num_threads(nthreads)
        for (int32_t k = 0; k < ntodo; k++) {
            int tid = thread_num();
            tbuf *b = &buf[tid];
            size_t mark = b->n;
            int32_t a = todo[k];
            if (!b->full)
                task(c, a, &scr[tid], b);
            if (b->full) {
                b->n = mark;
                redo[a] = 1;
            } else {
                ch->tid[a] = tid;
                ch->off[a] = mark;
                ch->n[a] = b->n - mark;
            }
        }
        for (int32_t k = 0; k < ntodo; k++)
            if (redo[todo[k]]) {
                redo[todo[k]] = 0;
                todo[nleft++] = todo[k];
            }
        for (int th = 0; th < nthreads; th++) {
            unsigned char *grown;
            if (!buf[th].full)
                continue;
            grown = buf[th].cap <= SIZE_MAX / 2 / buf[th].size
                        ? realloc(buf[th].rec, 2 * buf[th].cap * buf[th].size)
                        : NULL;
            if (!grown)
                return dtx_seterr(err, DTX_ENOMEM,
                                  "proximity: cannot grow an output buffer "
                                  "beyond %zu records",
                                  buf[th].cap);
            buf[th].rec = grown;
            buf[th].cap *= 2;
            buf[th].full = 0;
        }
        ntodo = nleft;
    }
    return DTX_OK;
}

static void tbufs_free(tbuf *buf, int nthreads)
{
    if (!buf)
        return;
    for (int th = 0; th < nthreads; th++)
        free(buf[th].rec);
    free(buf);
}

/* nthreads empty buffers of cap records each. */
static tbuf *tbufs_alloc(int nthreads, size_t size, size_t cap)
{
    tbuf *buf = dtx_alloc((size_t)nthreads, sizeof *buf, 1);
    if (!buf)
        return NULL;
    for (int th = 0; th < nthreads; th++) {
        buf[th].size = size;
        buf[th].cap = cap;
        if (!(buf[th].rec = dtx_alloc(cap, size, 0))) {
            tbufs_free(buf, nthreads);
            return NULL;
        }
    }
    return buf;
}

/* The record of component a's chunk number k. */
static inline const void *chunk_rec(const tbuf *buf, const chunks *ch, int32_t a, size_t k)
{
    const tbuf *b = &buf[ch->tid[a]];
    return b->rec + (ch->off[a] + k) * b->size;
}

static int cmp_int2(const void *x, const void *y)
{
    const int32_t *p = x, *q = y;
    if (p[0] != q[0])
        return p[0] < q[0] ? -1 : 1;
    return p[1] < q[1] ? -1 : (p[1] > q[1]);
}

/* ------------------------------------------------------------------ */
/* The proximity graph                                                 */
/* ------------------------------------------------------------------ */

void dtx_proximity_free(dtx_proximity *p)
{
    if (!p)
        return;
    free(p->comp);
    free(p->eps);
    free(p->edges);
    free(p->edge_dist);
    free(p->in_tree);
    free(p->edge_pair);
    free(p->pairs);
    free(p->rest_len);
    free(p->pair_edge);
    memset(p, 0, sizeof *p);
}

/* Edge arrays of *out for nedges edges, pair arrays for npairs pairs. */
static int alloc_edges(dtx_proximity *out, size_t nedges)
{
    out->edges = dtx_alloc(nedges, 2 * sizeof *out->edges, 0);
    out->edge_dist = dtx_alloc(nedges, sizeof *out->edge_dist, 0);
    out->in_tree = dtx_alloc(nedges, sizeof *out->in_tree, 1);
    out->edge_pair = dtx_alloc(nedges, 2 * sizeof *out->edge_pair, 0);
    return out->edges && out->edge_dist && out->in_tree && out->edge_pair;
}

static int alloc_pairs(dtx_proximity *out, size_t npairs)
{
    out->pairs = dtx_alloc(npairs, 2 * sizeof *out->pairs, 0);
    out->rest_len = dtx_alloc(npairs, sizeof *out->rest_len, 0);
    out->pair_edge = dtx_alloc(npairs, sizeof *out->pair_edge, 0);
    return out->pairs && out->rest_len && out->pair_edge;
}

dtx_status dtx_proximity_build(const dtx_mesh *m, double eps_factor, dtx_proximity *out,
                               dtx_error *err)
{
    dtx_status st = DTX_OK;
    int nthreads = max_threads();
    int32_t ncomp, nin = 0, ntree, nedges = 0;
    int32_t *cstart = NULL, *cvert = NULL, *tree = NULL, *todo = NULL, *estart = NULL;
    int32_t *eb = NULL, *ei = NULL, *ej = NULL, *scr_int = NULL;
    double *tree_d2 = NULL, *r = NULL, *r2 = NULL, *node_r2 = NULL, *R = NULL, *R2 = NULL;
    double *scr_dbl = NULL;
    unsigned char *redo = NULL;
    kd_node *cbox = NULL;
    scratch *scr = NULL;
    tbuf *buf = NULL;
    chunks ch = {NULL, NULL, NULL};
    size_t total, at;
    kd_tree t = {0};
    prox_ctx ctx;

    if (!out)
        return dtx_seterr(err, DTX_EINVAL, "proximity: no output given");
    memset(out, 0, sizeof *out);
    if (!m)
        return dtx_seterr(err, DTX_EINVAL, "proximity: no mesh given");
    if (!(eps_factor >= 0.0) || !isfinite(eps_factor))
        return dtx_seterr(err, DTX_EINVAL,
                          "proximity: eps_factor %g must be finite and >= 0 "
                          "(the paper uses 1.5)",
                          eps_factor);
    if ((st = check_mesh(m, err)) != DTX_OK)
        return st;

    /* ---- Components and their eps. */
    if (!(out->comp = dtx_alloc((size_t)m->nv, sizeof *out->comp, 0)))
        goto nomem;
    if ((ncomp = dtx__tri_components(m->F, m->nf, m->nv, DTX__ISOLATED_UNLABELLED, out->comp)) < 0)
        goto nomem;
    out->ncomp = ncomp;
    if (!(out->eps = dtx_alloc((size_t)ncomp, sizeof *out->eps, 0)))
        goto nomem;
    component_eps(m, out->comp, eps_factor, ncomp, out->eps);
    if (ncomp <= 1) {
        if (!alloc_edges(out, 0) || !alloc_pairs(out, 0))
            goto nomem;
        return DTX_OK;
    }

    /* ---- Vertices and bounding box of each component; the k-d tree. */
    cstart = dtx_alloc((size_t)ncomp + 1, sizeof *cstart, 1);
    cbox = dtx_alloc((size_t)ncomp, sizeof *cbox, 0);
    todo = dtx_alloc((size_t)ncomp, sizeof *todo, 1);
    if (!cstart || !cbox || !todo)
        goto nomem;
    for (int32_t c = 0; c < ncomp; c++)
        for (int k = 0; k < 3; k++) {
            cbox[c].lo[k] = INFINITY;
            cbox[c].hi[k] = -INFINITY;
        }
    for (int32_t v = 0; v < m->nv; v++) {
        int32_t c = out->comp[v];
        if (c < 0)
            continue;
        cstart[c + 1]++;
        nin++;
        for (int k = 0; k < 3; k++) {
            double x = m->V[3 * v + k];
            cbox[c].lo[k] = x < cbox[c].lo[k] ? x : cbox[c].lo[k];
            cbox[c].hi[k] = x > cbox[c].hi[k] ? x : cbox[c].hi[k];
        }
    }
    for (int32_t c = 0; c < ncomp; c++)
        cstart[c + 1] += cstart[c];
    if (!(cvert = dtx_alloc((size_t)nin, sizeof *cvert, 0)))
        goto nomem;
    for (int32_t v = 0; v < m->nv; v++)
        if (out->comp[v] >= 0)
            cvert[cstart[out->comp[v]] + todo[out->comp[v]]++] = v;
    {
        /* The tree reorders its list: give it a copy. */
        int32_t *verts = dtx_alloc((size_t)nin, sizeof *verts, 0);
        if (!verts)
            goto nomem;
        memcpy(verts, cvert, (size_t)nin * sizeof *verts);
        st = kd_build(m->V, out->comp, verts, nin, &t);
        free(verts);
        if (st != DTX_OK)
            goto nomem;
    }

    /* ---- Minimum spanning tree, then r_a = d_a + eps_a. */
    if (!(tree = dtx_alloc((size_t)ncomp - 1, 2 * sizeof *tree, 0)) ||
        !(tree_d2 = dtx_alloc((size_t)ncomp - 1, sizeof *tree_d2, 0)))
        goto nomem;
    if ((ntree = mst_boruvka(&t, ncomp, tree, tree_d2)) < 0)
        goto nomem;
    if (!(r = dtx_alloc((size_t)ncomp, sizeof *r, 1)) ||
        !(r2 = dtx_alloc((size_t)ncomp, sizeof *r2, 0)) ||
        !(node_r2 = dtx_alloc((size_t)t.nnodes, sizeof *node_r2, 0)))
        goto nomem;
    for (int32_t e = 0; e < ntree; e++) {
        double d = sqrt(tree_d2[e]);
        for (int k = 0; k < 2; k++)
            r[tree[2 * e + k]] = d > r[tree[2 * e + k]] ? d : r[tree[2 * e + k]];
    }
    for (int32_t c = 0; c < ncomp; c++) {
        r[c] += out->eps[c];
        r2[c] = search2(r[c]);
    }
    for (int32_t ni = t.nnodes - 1; ni >= 0; ni--) {
        const kd_node *nd = &t.node[ni];
        if (nd->count > 0) {
            node_r2[ni] = 0.0;
            for (int32_t q = nd->first; q < nd->first + nd->count; q++)
                node_r2[ni] = r2[t.comp[q]] > node_r2[ni] ? r2[t.comp[q]] : node_r2[ni];
        } else {
            double l = node_r2[nd->first], rr = node_r2[nd->first + 1];
            node_r2[ni] = l > rr ? l : rr;
        }
    }

    /* ---- Per-thread scratch (kept clean by the tasks), chunk records. */
    if (!(scr = dtx_alloc((size_t)nthreads, sizeof *scr, 1)) ||
        !(scr_dbl = dtx_alloc((size_t)nthreads * (size_t)ncomp, sizeof *scr_dbl, 0)) ||
        !(scr_int = dtx_alloc((size_t)nthreads * (size_t)ncomp, 3 * sizeof *scr_int, 0)) ||
        !(redo = dtx_alloc((size_t)ncomp, 1, 1)) ||
        !(ch.tid = dtx_alloc((size_t)ncomp, sizeof *ch.tid, 0)) ||
        !(ch.off = dtx_alloc((size_t)ncomp, sizeof *ch.off, 0)) ||
        !(ch.n = dtx_alloc((size_t)ncomp, sizeof *ch.n, 0)))
        goto nomem;
    for (int th = 0; th < nthreads; th++) {
        int32_t *base = scr_int + (size_t)th * 3 * (size_t)ncomp;
        scr[th].bd2 = scr_dbl + (size_t)th * (size_t)ncomp;
        scr[th].bi = base;
        scr[th].bj = base + ncomp;
        scr[th].touched = base + 2 * (size_t)ncomp;
        for (int32_t c = 0; c < ncomp; c++)
            scr[th].bi[c] = -1;
    }

    /* ---- Graph edges: each component's chunk is sorted by b, so the
     * chunks in component order are sorted by (a, b). */
    memset(&ctx, 0, sizeof ctx);
    ctx.t = &t;
    ctx.V = m->V;
    ctx.ncomp = ncomp;
    ctx.cstart = cstart;
    ctx.cvert = cvert;
    ctx.cbox = cbox;
    ctx.r = r;
    ctx.r2 = r2;
    ctx.node_r2 = node_r2;
    if (!(buf = tbufs_alloc(nthreads, sizeof(edge_rec), 4 * (size_t)ncomp / (size_t)nthreads + 64)))
        goto nomem;
    if ((st = run_tasks(&ctx, edge_task, scr, buf, nthreads, todo, redo, &ch, err)) != DTX_OK)
        goto fail;
    total = 0;
    for (int32_t c = 0; c < ncomp; c++)
        total += ch.n[c];
    if (total > INT32_MAX) {
        st =
            dtx_seterr(err, DTX_ERANGE, "proximity: %zu graph edges exceed the int32 range", total);
        goto fail;
    }
    nedges = (int32_t)total;
    if (!alloc_edges(out, total) || !(estart = dtx_alloc((size_t)ncomp + 1, sizeof *estart, 1)) ||
        !(eb = dtx_alloc(total, sizeof *eb, 0)) || !(ei = dtx_alloc(total, sizeof *ei, 0)) ||
        !(ej = dtx_alloc(total, sizeof *ej, 0)) || !(R = dtx_alloc(total, sizeof *R, 0)) ||
        !(R2 = dtx_alloc(total, sizeof *R2, 0)))
        goto nomem;
    out->nedges = nedges;
    for (int32_t a = 0, e = 0; a < ncomp; a++) {
        estart[a + 1] = estart[a] + (int32_t)ch.n[a];
        for (size_t k = 0; k < ch.n[a]; k++, e++) {
            const edge_rec *x = chunk_rec(buf, &ch, a, k);
            double ea = out->eps[a], ebb = out->eps[x->b];
            out->edges[2 * e] = a;
            out->edges[2 * e + 1] = x->b;
            out->edge_pair[2 * e] = x->i;
            out->edge_pair[2 * e + 1] = x->j;
            out->edge_dist[e] = sqrt(x->d2);
            eb[e] = x->b;
            ei[e] = x->i;
            ej[e] = x->j;
            R[e] = out->edge_dist[e] + (ea < ebb ? ea : ebb);
            R2[e] = search2(R[e]);
        }
    }
    tbufs_free(buf, nthreads);
    buf = NULL;
    /* Tree edges, sorted, against the sorted edge list (they are all in it:
     * d_ab <= d_a <= r_a). */
    qsort(tree, (size_t)ntree, 2 * sizeof *tree, cmp_int2);
    for (int32_t e = 0, k = 0; e < nedges && k < ntree; e++) {
        while (k < ntree && cmp_int2(tree + 2 * k, out->edges + 2 * e) < 0)
            k++;
        if (k < ntree && cmp_int2(tree + 2 * k, out->edges + 2 * e) == 0)
            out->in_tree[e] = 1;
    }

    /* ---- Proximity pairs, sorted the same way. */
    ctx.estart = estart;
    ctx.eb = eb;
    ctx.ei = ei;
    ctx.ej = ej;
    ctx.edist = out->edge_dist;
    ctx.R = R;
    ctx.R2 = R2;
    if (!(buf = tbufs_alloc(nthreads, sizeof(pair_rec), 4 * (size_t)nin / (size_t)nthreads + 1024)))
        goto nomem;
    if ((st = run_tasks(&ctx, pair_task, scr, buf, nthreads, todo, redo, &ch, err)) != DTX_OK)
        goto fail;
    total = 0;
    for (int32_t c = 0; c < ncomp; c++)
        total += ch.n[c];
    if (!alloc_pairs(out, total))
        goto nomem;
    out->npairs = (int64_t)total;
    at = 0;
    for (int32_t a = 0; a < ncomp; a++) {
        const pair_rec *x = ch.n[a] ? chunk_rec(buf, &ch, a, 0) : NULL;
        for (size_t k = 0; k < ch.n[a]; k++, at++) {
            out->pairs[2 * at] = x[k].i;
            out->pairs[2 * at + 1] = x[k].j;
            out->pair_edge[at] = x[k].e;
            out->rest_len[at] = x[k].len;
        }
    }
    goto done;

nomem:
    st = dtx_seterr(err, DTX_ENOMEM,
                    "proximity: out of memory (mesh of %d vertices, %d "
                    "faces)",
                    (int)m->nv, (int)m->nf);
fail:
    dtx_proximity_free(out);
done:
    kd_free(&t);
    tbufs_free(buf, nthreads);
    free(cstart);
    free(cvert);
    free(cbox);
    free(tree);
    free(todo);
    free(estart);
    free(eb);
    free(ei);
    free(ej);
    free(scr_int);
    free(tree_d2);
    free(r);
    free(r2);
    free(node_r2);
    free(R);
    free(R2);
    free(scr_dbl);
    free(redo);
    free(scr);
    free(ch.tid);
    free(ch.off);
    free(ch.n);
    return st;
}

/* ------------------------------------------------------------------ */
/* E_R triangle pairs                                                  */
/* ------------------------------------------------------------------ */

dtx_status dtx_proximity_triangle_pairs(const dtx_mesh *m, const dtx_proximity *p, int32_t *tri,
                                        dtx_error *err)
{
    dtx_status st = DTX_OK;
    int64_t np;
    int64_t *vstart = NULL;
    int32_t *vface = NULL;
    double *N = NULL, *B = NULL;

    if (!m || !p)
        return dtx_seterr(err, DTX_EINVAL, "proximity triangle pairs: no mesh or graph given");
    np = p->npairs;
    if (np < 0 || (np > 0 && (!p->pairs || !tri)))
        return dtx_seterr(err, DTX_EINVAL,
                          "proximity triangle pairs: %lld pairs with "
                          "missing arrays",
                          (long long)np);
    if ((st = check_mesh(m, err)) != DTX_OK)
        return st;
    for (int64_t q = 0; q < 2 * np; q++)
        if (p->pairs[q] < 0 || p->pairs[q] >= m->nv)
            return dtx_seterr(err, DTX_ERANGE,
                              "proximity triangle pairs: pair %lld has "
                              "vertex %d out of range [0, %d)",
                              (long long)(q / 2), (int)p->pairs[q], (int)m->nv);

    /* Faces around each vertex, ascending. */
    vstart = dtx_alloc((size_t)m->nv + 1, sizeof *vstart, 1);
    vface = dtx_alloc((size_t)m->nf, 3 * sizeof *vface, 0);
    N = dtx_alloc((size_t)m->nf, 3 * sizeof *N, 0);
    B = dtx_alloc((size_t)m->nf, 3 * sizeof *B, 0);
    if (!vstart || !vface || !N || !B) {
        st = dtx_seterr(err, DTX_ENOMEM, "proximity triangle pairs: out of memory (%d faces)",
                        (int)m->nf);
        goto done;
    }
    for (int64_t k = 0; k < 3 * (int64_t)m->nf; k++)
        vstart[m->F[k] + 1]++;
    for (int32_t v = 0; v < m->nv; v++)
        vstart[v + 1] += vstart[v];
    for (int32_t f = 0; f < m->nf; f++)
        for (int k = 0; k < 3; k++)
            vface[vstart[m->F[3 * f + k]]++] = f;
    for (int32_t v = m->nv; v > 0; v--)
        vstart[v] = vstart[v - 1];
    vstart[0] = 0;
    for (int64_t q = 0; q < 2 * np; q++) {
        int32_t v = p->pairs[q];
        if (vstart[v + 1] == vstart[v]) {
            st = dtx_seterr(err, DTX_EINVAL,
                            "proximity triangle pairs: vertex %d of pair "
                            "%lld is in no face",
                            (int)v, (long long)(q / 2));
            goto done;
        }
    }
    dtx_face_normals(m->V, m->F, m->nf, N);
    for (int32_t f = 0; f < m->nf; f++)
        for (int k = 0; k < 3; k++)
            B[3 * f + k] = (m->V[3 * m->F[3 * f] + k] + m->V[3 * m->F[3 * f + 1] + k] +
                            m->V[3 * m->F[3 * f + 2] + k]) /
                           3.0;

#pragma omp parallel for schedule(static)
    for (int64_t q = 0; q < np; q++) {
        int32_t i = p->pairs[2 * q], j = p->pairs[2 * q + 1], bta = -1, btb = -1;
        double best = -1.0;
        for (int64_t u = vstart[i]; u < vstart[i + 1]; u++) {
            int32_t ta = vface[u];
            const double *na = N + 3 * ta, *ba = B + 3 * ta;
            for (int64_t w = vstart[j]; w < vstart[j + 1]; w++) {
                int32_t tb = vface[w];
                const double *nb = N + 3 * tb, *bb = B + 3 * tb;
                double h[3] = {bb[0] - ba[0], bb[1] - ba[1], bb[2] - ba[2]};
                double s = fabs(h[0] * na[0] + h[1] * na[1] + h[2] * na[2]) +
                           fabs(h[0] * nb[0] + h[1] * nb[1] + h[2] * nb[2]);
                /* Strictly larger: ties keep the lowest (t_a, t_b). */
                if (s > best) {
                    best = s;
                    bta = ta;
                    btb = tb;
                }
            }
        }
        tri[2 * q] = bta;
        tri[2 * q + 1] = btb;
    }

done:
    free(vstart);
    free(vface);
    free(N);
    free(B);
    return st;
}
