/*
 * test_proximity.c: the proximity graph of a multi-component mesh (Zhou et
 * al. 2010, 2.1) and the E_R triangle pairs (2.2).
 *
 * Hand cases with known answers (two squares side by side, a chain of four
 * components, one component, a triangle pair), the whole result against a
 * brute-force O(n^2) reference (Kruskal on all component distances) on
 * random scattered meshes, lattices full of ties and close grids with many
 * pairs, structural properties (spanning tree, bounds, sorting), and
 * bitwise equality between 1 and 2 OpenMP threads.
 */
#include "check.h"
#include "dtx_core.h"
#include "proximity.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#endif

/* ------------------------------------------------------------------ */
/* Mesh building                                                       */
/* ------------------------------------------------------------------ */

typedef struct {
    double *V;
    int32_t *F;
    int32_t nv, nf, capv, capf;
} builder;

static int32_t add_v(builder *b, double x, double y, double z)
{
    if (b->nv == b->capv) {
        b->capv = b->capv ? 2 * b->capv : 64;
        b->V = realloc(b->V, (size_t)b->capv * 3 * sizeof *b->V);
    }
    b->V[3 * b->nv] = x;
    b->V[3 * b->nv + 1] = y;
    b->V[3 * b->nv + 2] = z;
    return b->nv++;
}

static void add_f(builder *b, int32_t i, int32_t j, int32_t k)
{
    if (b->nf == b->capf) {
        b->capf = b->capf ? 2 * b->capf : 64;
        b->F = realloc(b->F, (size_t)b->capf * 3 * sizeof *b->F);
    }
    b->F[3 * b->nf] = i;
    b->F[3 * b->nf + 1] = j;
    b->F[3 * b->nf + 2] = k;
    b->nf++;
}

/* Moves the builder's arrays into a mesh (the builder is emptied). */
static dtx_mesh finish(builder *b)
{
    dtx_mesh m = {b->nv, b->nf, b->V, b->F};
    memset(b, 0, sizeof *b);
    return m;
}

/* An nx x ny grid of spacing h in the plane z = z0, origin (x0, y0). */
static void add_grid(builder *b, int nx, int ny, double h, double x0, double y0, double z0)
{
    int32_t base = b->nv;
    for (int j = 0; j < ny; j++)
        for (int i = 0; i < nx; i++)
            add_v(b, x0 + i * h, y0 + j * h, z0);
    for (int j = 0; j + 1 < ny; j++)
        for (int i = 0; i + 1 < nx; i++) {
            int32_t a = base + j * nx + i;
            add_f(b, a, a + 1, a + nx + 1);
            add_f(b, a, a + nx + 1, a + nx);
        }
}

static uint64_t rng_state = 88172645463325252ull;

static double urand(void)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return (double)(rng_state >> 11) / 9007199254740992.0;
}

/* ncomp small components (tetrahedra, single triangles, 3x3 or 5x4 grids) at
 * random places in a box of side `box`, with some vertices in no face and
 * the vertex numbering shuffled, so components interleave.  lattice != 0
 * puts every vertex on the integer lattice (many equal distances). */
static dtx_mesh random_scene(int ncomp, double box, int lattice, int nloose)
{
    builder b = {0};
    dtx_mesh m;
    int32_t *perm, *inv;
    double *V2;
    for (int c = 0; c < ncomp; c++) {
        double o[3] = {urand() * box, urand() * box, urand() * box};
        double s = lattice ? 1.0 : 0.2 + urand();
        int kind = (int)(urand() * 4);
        int32_t base = b.nv;
        if (lattice)
            for (int k = 0; k < 3; k++)
                o[k] = floor(o[k]);
        if (kind == 0) {
            add_v(&b, o[0], o[1], o[2]);
            add_v(&b, o[0] + s, o[1], o[2]);
            add_v(&b, o[0], o[1] + s, o[2]);
            add_v(&b, o[0], o[1], o[2] + s);
            add_f(&b, base, base + 2, base + 1);
            add_f(&b, base, base + 1, base + 3);
            add_f(&b, base, base + 3, base + 2);
            add_f(&b, base + 1, base + 2, base + 3);
        } else if (kind == 1) {
            add_v(&b, o[0], o[1], o[2]);
            add_v(&b, o[0] + s, o[1] + (lattice ? 0 : 0.3 * s), o[2]);
            add_v(&b, o[0], o[1] + s, o[2] + s);
            add_f(&b, base, base + 1, base + 2);
        } else {
            /* 3x3 or 5x4: big enough to span several k-d tree leaves. */
            add_grid(&b, kind == 2 ? 3 : 5, kind == 2 ? 3 : 4, lattice ? 1.0 : 0.5 * s, o[0], o[1],
                     o[2]);
        }
    }
    for (int k = 0; k < nloose; k++)
        add_v(&b, urand() * box, urand() * box, urand() * box);
    /* Shuffle the vertex numbering. */
    perm = malloc((size_t)b.nv * sizeof *perm);
    inv = malloc((size_t)b.nv * sizeof *inv);
    V2 = malloc((size_t)b.nv * 3 * sizeof *V2);
    for (int32_t v = 0; v < b.nv; v++)
        perm[v] = v;
    for (int32_t v = b.nv - 1; v > 0; v--) {
        int32_t w = (int32_t)(urand() * (v + 1)), t = perm[v];
        perm[v] = perm[w];
        perm[w] = t;
    }
    for (int32_t v = 0; v < b.nv; v++) {
        inv[perm[v]] = v;
        memcpy(V2 + 3 * v, b.V + 3 * perm[v], 3 * sizeof *V2);
    }
    for (int32_t k = 0; k < 3 * b.nf; k++)
        b.F[k] = inv[b.F[k]];
    free(b.V);
    b.V = V2;
    free(perm);
    free(inv);
    m = finish(&b);
    return m;
}

/* ------------------------------------------------------------------ */
/* Brute-force reference                                               */
/* ------------------------------------------------------------------ */

static double d2of(const double *V, int32_t i, int32_t j)
{
    double dx = V[3 * i] - V[3 * j], dy = V[3 * i + 1] - V[3 * j + 1],
           dz = V[3 * i + 2] - V[3 * j + 2];
    return dx * dx + dy * dy + dz * dz;
}

static int32_t root(int32_t *p, int32_t i)
{
    while (p[i] != i)
        i = p[i] = p[p[i]];
    return i;
}

typedef struct {
    double d2;
    int32_t a, b;
} kedge;

static int cmp_kedge(const void *x, const void *y)
{
    const kedge *p = x, *q = y;
    if (p->d2 != q->d2)
        return p->d2 < q->d2 ? -1 : 1;
    if (p->a != q->a)
        return p->a < q->a ? -1 : 1;
    return p->b < q->b ? -1 : (p->b > q->b);
}

/* The paper's construction, literally: all component distances, Kruskal,
 * the added-edge rule, all vertex pairs.  Fills *out like the real one. */
static void reference(const dtx_mesh *m, double eps_factor, dtx_proximity *out)
{
    int32_t nv = m->nv, nc = 0, ne = 0;
    int32_t *p = malloc((size_t)nv * sizeof *p), *lab = malloc((size_t)nv * sizeof *lab);
    double *D2, *dmax;
    int32_t *CI, *CJ;
    unsigned char *intree;
    kedge *all;
    int64_t np = 0, cap = 64;
    memset(out, 0, sizeof *out);
    out->comp = malloc((size_t)nv * sizeof *out->comp);
    for (int32_t v = 0; v < nv; v++) {
        p[v] = v;
        lab[v] = -1;
        out->comp[v] = -1;
    }
    for (int32_t f = 0; f < m->nf; f++)
        for (int k = 0; k < 3; k++) {
            int32_t a = root(p, m->F[3 * f + k]), b = root(p, m->F[3 * f + (k + 1) % 3]);
            p[a > b ? a : b] = a > b ? b : a;
            out->comp[m->F[3 * f + k]] = -2;
        }
    for (int32_t v = 0; v < nv; v++)
        if (out->comp[v] == -2) {
            int32_t r = root(p, v);
            if (lab[r] < 0)
                lab[r] = nc++;
            out->comp[v] = lab[r];
        }
    out->ncomp = nc;
    out->eps = calloc((size_t)nc + 1, sizeof *out->eps);
    for (int32_t f = 0; f < m->nf; f++)
        for (int k = 0; k < 3; k++) {
            double l = sqrt(d2of(m->V, m->F[3 * f + k], m->F[3 * f + (k + 1) % 3]));
            double *e = &out->eps[out->comp[m->F[3 * f]]];
            *e = l > *e ? l : *e;
        }
    for (int32_t c = 0; c < nc; c++)
        out->eps[c] *= eps_factor;

    D2 = malloc((size_t)nc * nc * sizeof *D2 + 1);
    CI = malloc((size_t)nc * nc * sizeof *CI + 1);
    CJ = malloc((size_t)nc * nc * sizeof *CJ + 1);
    for (int64_t k = 0; k < (int64_t)nc * nc; k++)
        D2[k] = INFINITY, CI[k] = CJ[k] = -1;
    for (int32_t i = 0; i < nv; i++)
        for (int32_t j = 0; j < nv; j++) {
            int32_t a = out->comp[i], b = out->comp[j];
            double d2;
            if (a < 0 || b < 0 || a >= b)
                continue;
            d2 = d2of(m->V, i, j);
            if (d2 < D2[a * nc + b]) {
                D2[a * nc + b] = d2;
                CI[a * nc + b] = i;
                CJ[a * nc + b] = j;
            }
        }
    /* Kruskal with edges ordered by (d2, a, b). */
    all = malloc(((size_t)nc * nc / 2 + 1) * sizeof *all);
    for (int32_t a = 0; a < nc; a++)
        for (int32_t b = a + 1; b < nc; b++)
            all[ne++] = (kedge){D2[a * nc + b], a, b};
    qsort(all, (size_t)ne, sizeof *all, cmp_kedge);
    intree = calloc((size_t)nc * nc + 1, 1);
    dmax = calloc((size_t)nc + 1, sizeof *dmax);
    for (int32_t c = 0; c < nc; c++)
        p[c] = c;
    for (int32_t k = 0; k < ne; k++) {
        int32_t ra = root(p, all[k].a), rb = root(p, all[k].b);
        double d = sqrt(all[k].d2);
        if (ra == rb)
            continue;
        p[ra > rb ? ra : rb] = ra > rb ? rb : ra;
        intree[all[k].a * nc + all[k].b] = 1;
        dmax[all[k].a] = d > dmax[all[k].a] ? d : dmax[all[k].a];
        dmax[all[k].b] = d > dmax[all[k].b] ? d : dmax[all[k].b];
    }
    /* Edges and pairs. */
    out->edges = malloc((size_t)ne * 2 * sizeof(int32_t) + 8);
    out->edge_dist = malloc((size_t)ne * sizeof(double) + 8);
    out->in_tree = malloc((size_t)ne + 1);
    out->edge_pair = malloc((size_t)ne * 2 * sizeof(int32_t) + 8);
    out->pairs = malloc((size_t)cap * 2 * sizeof(int32_t));
    out->rest_len = malloc((size_t)cap * sizeof(double));
    out->pair_edge = malloc((size_t)cap * sizeof(int32_t));
    for (int32_t a = 0; a < nc; a++)
        for (int32_t b = a + 1; b < nc; b++) {
            double d = sqrt(D2[a * nc + b]), R;
            int32_t e = out->nedges;
            if (!intree[a * nc + b] && !(d <= dmax[a] + out->eps[a] && d <= dmax[b] + out->eps[b]))
                continue;
            out->edges[2 * e] = a;
            out->edges[2 * e + 1] = b;
            out->edge_dist[e] = d;
            out->in_tree[e] = intree[a * nc + b];
            out->edge_pair[2 * e] = CI[a * nc + b];
            out->edge_pair[2 * e + 1] = CJ[a * nc + b];
            out->nedges++;
            R = d + (out->eps[a] < out->eps[b] ? out->eps[a] : out->eps[b]);
            for (int32_t i = 0; i < nv; i++) {
                if (out->comp[i] != a)
                    continue;
                for (int32_t j = 0; j < nv; j++) {
                    double dij;
                    if (out->comp[j] != b)
                        continue;
                    dij = sqrt(d2of(m->V, i, j));
                    if (!(dij < R) && !(i == CI[a * nc + b] && j == CJ[a * nc + b]))
                        continue;
                    if (np == cap) {
                        cap *= 2;
                        out->pairs = realloc(out->pairs, (size_t)cap * 2 * sizeof(int32_t));
                        out->rest_len = realloc(out->rest_len, (size_t)cap * sizeof(double));
                        out->pair_edge = realloc(out->pair_edge, (size_t)cap * sizeof(int32_t));
                    }
                    out->pairs[2 * np] = i;
                    out->pairs[2 * np + 1] = j;
                    out->rest_len[np] = dij;
                    out->pair_edge[np] = e;
                    np++;
                }
            }
        }
    out->npairs = np;
    free(p);
    free(lab);
    free(D2);
    free(CI);
    free(CJ);
    free(all);
    free(intree);
    free(dmax);
}

/* ------------------------------------------------------------------ */
/* Comparisons and properties                                          */
/* ------------------------------------------------------------------ */

/* Bitwise equality of two results; returns 1 when equal (each difference
 * is also a failed check). */
static int same_result(const dtx_mesh *m, const dtx_proximity *x, const dtx_proximity *y)
{
    int before = check_failed_;
    CHECK_EQ_INT(x->ncomp, y->ncomp);
    CHECK_EQ_INT(x->nedges, y->nedges);
    CHECK_EQ_INT(x->npairs, y->npairs);
    if (check_failed_ != before)
        return 0;
    CHECK(memcmp(x->comp, y->comp, (size_t)m->nv * sizeof *x->comp) == 0);
    CHECK(memcmp(x->eps, y->eps, (size_t)x->ncomp * sizeof *x->eps) == 0);
    CHECK(memcmp(x->edges, y->edges, (size_t)x->nedges * 2 * sizeof *x->edges) == 0);
    CHECK(memcmp(x->edge_dist, y->edge_dist, (size_t)x->nedges * sizeof *x->edge_dist) == 0);
    CHECK(memcmp(x->in_tree, y->in_tree, (size_t)x->nedges) == 0);
    CHECK(memcmp(x->edge_pair, y->edge_pair, (size_t)x->nedges * 2 * sizeof *x->edge_pair) == 0);
    CHECK(memcmp(x->pairs, y->pairs, (size_t)x->npairs * 2 * sizeof *x->pairs) == 0);
    CHECK(memcmp(x->rest_len, y->rest_len, (size_t)x->npairs * sizeof *x->rest_len) == 0);
    CHECK(memcmp(x->pair_edge, y->pair_edge, (size_t)x->npairs * sizeof *x->pair_edge) == 0);
    return check_failed_ == before;
}

/* What must hold of any result, whatever the mesh. */
static void check_properties(const dtx_mesh *m, const dtx_proximity *p)
{
    int32_t ntree = 0, nc = p->ncomp, ncl = nc;
    int32_t *uf = malloc(((size_t)nc + 1) * sizeof *uf);
    int bad_sort = 0, bad_comp = 0, bad_len = 0, bad_bound = 0, bad_pair = 0, bad_tree = 0;
    for (int32_t c = 0; c < nc; c++)
        uf[c] = c;
    for (int32_t e = 0; e < p->nedges; e++) {
        int32_t a = p->edges[2 * e], b = p->edges[2 * e + 1];
        int32_t i = p->edge_pair[2 * e], j = p->edge_pair[2 * e + 1];
        if (!(a < b) || a < 0 || b >= nc ||
            (e > 0 &&
             !(p->edges[2 * e - 2] < a || (p->edges[2 * e - 2] == a && p->edges[2 * e - 1] < b))))
            bad_sort++;
        if (p->comp[i] != a || p->comp[j] != b)
            bad_comp++;
        if (sqrt(d2of(m->V, i, j)) != p->edge_dist[e])
            bad_len++;
        if (p->in_tree[e]) {
            int32_t ra = root(uf, a), rb = root(uf, b);
            ntree++;
            if (ra == rb)
                bad_tree++; /* a cycle */
            uf[ra > rb ? ra : rb] = ra > rb ? rb : ra;
            ncl -= ra != rb;
        }
    }
    CHECK_EQ_INT(ntree, nc > 0 ? nc - 1 : 0);
    CHECK_EQ_INT(ncl, nc > 0 ? 1 : 0);
    CHECK_EQ_INT(bad_tree, 0);
    CHECK_EQ_INT(bad_sort, 0);
    CHECK_EQ_INT(bad_comp, 0);
    CHECK_EQ_INT(bad_len, 0);
    bad_sort = bad_comp = bad_len = 0;
    for (int64_t k = 0; k < p->npairs; k++) {
        int32_t e = p->pair_edge[k], i = p->pairs[2 * k], j = p->pairs[2 * k + 1];
        int32_t a, b;
        double R;
        if (e < 0 || e >= p->nedges) {
            bad_comp++;
            continue;
        }
        a = p->edges[2 * e];
        b = p->edges[2 * e + 1];
        if (p->comp[i] != a || p->comp[j] != b)
            bad_comp++;
        if (p->rest_len[k] != sqrt(d2of(m->V, i, j)))
            bad_len++;
        R = p->edge_dist[e] + (p->eps[a] < p->eps[b] ? p->eps[a] : p->eps[b]);
        if (!(p->rest_len[k] < R) && !(i == p->edge_pair[2 * e] && j == p->edge_pair[2 * e + 1]))
            bad_bound++;
        if (p->rest_len[k] < p->edge_dist[e])
            bad_bound++;
        if (k > 0) {
            int32_t e0 = p->pair_edge[k - 1], i0 = p->pairs[2 * k - 2], j0 = p->pairs[2 * k - 1];
            if (!(e0 < e || (e0 == e && (i0 < i || (i0 == i && j0 < j)))))
                bad_sort++;
        }
    }
    /* Every edge has its closest pair among its pairs. */
    for (int32_t e = 0, k = 0; e < p->nedges; e++) {
        int found = 0;
        for (; k < p->npairs && p->pair_edge[k] == e; k++)
            if (p->pairs[2 * k] == p->edge_pair[2 * e] &&
                p->pairs[2 * k + 1] == p->edge_pair[2 * e + 1])
                found = 1;
        bad_pair += !found;
    }
    CHECK_EQ_INT(bad_comp, 0);
    CHECK_EQ_INT(bad_len, 0);
    CHECK_EQ_INT(bad_bound, 0);
    CHECK_EQ_INT(bad_sort, 0);
    CHECK_EQ_INT(bad_pair, 0);
    free(uf);
}

static void set_threads(int n)
{
#ifdef _OPENMP
    omp_set_num_threads(n);
#else
    (void)n;
#endif
}

/* Builds with 1 and with 2 threads, checks they agree bitwise, the
 * properties, and (when check_ref) the brute-force reference. */
static void check_mesh_case(const dtx_mesh *m, double eps_factor, int check_ref, const char *what)
{
    dtx_proximity p1, p2, ref;
    dtx_error err = {0};
    int before = check_failed_;
    set_threads(1);
    CHECK_OK(dtx_proximity_build(m, eps_factor, &p1, &err), &err);
    set_threads(2);
    CHECK_OK(dtx_proximity_build(m, eps_factor, &p2, &err), &err);
    same_result(m, &p1, &p2);
    check_properties(m, &p2);
    if (check_ref) {
        reference(m, eps_factor, &ref);
        same_result(m, &p2, &ref);
        dtx_proximity_free(&ref);
    }
    if (check_failed_ != before)
        fprintf(stderr, "  in case %s (eps_factor %g: %d components, %d edges, %lld pairs)\n", what,
                eps_factor, (int)p2.ncomp, (int)p2.nedges, (long long)p2.npairs);
    dtx_proximity_free(&p1);
    dtx_proximity_free(&p2);
}

/* ------------------------------------------------------------------ */
/* Hand cases                                                          */
/* ------------------------------------------------------------------ */

/* Unit squares A (x in [0, 1]) and B (x in [1.1, 2.1]), in the plane z = 0.
 * Vertices A: 0 (0,0) 1 (1,0) 2 (1,1) 3 (0,1); B: 4 (1.1,0) 5 (2.1,0)
 * 6 (2.1,1) 7 (1.1,1). */
static dtx_mesh two_squares(void)
{
    builder b = {0};
    add_v(&b, 0, 0, 0);
    add_v(&b, 1, 0, 0);
    add_v(&b, 1, 1, 0);
    add_v(&b, 0, 1, 0);
    add_v(&b, 1.1, 0, 0);
    add_v(&b, 2.1, 0, 0);
    add_v(&b, 2.1, 1, 0);
    add_v(&b, 1.1, 1, 0);
    add_f(&b, 0, 1, 2);
    add_f(&b, 0, 2, 3);
    add_f(&b, 4, 5, 6);
    add_f(&b, 4, 6, 7);
    return finish(&b);
}

static int has_pair(const dtx_proximity *p, int32_t i, int32_t j)
{
    for (int64_t k = 0; k < p->npairs; k++)
        if (p->pairs[2 * k] == i && p->pairs[2 * k + 1] == j)
            return 1;
    return 0;
}

static void test_two_squares(void)
{
    dtx_mesh m = two_squares();
    dtx_proximity p;
    dtx_error err = {0};
    /* eps = 1.2: radius 1.3 takes the pairs at 0.1 (1-4, 2-7), ~1.005 (1-7,
     * 2-4) and 1.1 (0-4, 3-7, 1-5, 2-6); the next ones are at ~1.49. */
    double f12 = 1.2 / sqrt(2.0);
    static const int32_t want[8][2] = {{0, 4}, {1, 4}, {1, 5}, {1, 7},
                                       {2, 4}, {2, 6}, {2, 7}, {3, 7}};
    CHECK_OK(dtx_proximity_build(&m, f12, &p, &err), &err);
    CHECK_EQ_INT(p.ncomp, 2);
    CHECK_EQ_INT(p.comp[0], 0);
    CHECK_EQ_INT(p.comp[7], 1);
    CHECK_NEAR(p.eps[0], 1.2, 1e-12);
    CHECK_NEAR(p.eps[1], 1.2, 1e-12);
    CHECK_EQ_INT(p.nedges, 1);
    if (p.nedges == 1) {
        CHECK_EQ_INT(p.edges[0], 0);
        CHECK_EQ_INT(p.edges[1], 1);
        CHECK_EQ_INT(p.in_tree[0], 1);
        CHECK_NEAR(p.edge_dist[0], 0.1, 1e-12);
        /* Two pairs at 0.1: the lowest is (1, 4). */
        CHECK_EQ_INT(p.edge_pair[0], 1);
        CHECK_EQ_INT(p.edge_pair[1], 4);
    }
    CHECK_EQ_INT(p.npairs, 8);
    if (p.npairs == 8)
        for (int k = 0; k < 8; k++) {
            CHECK_EQ_INT(p.pairs[2 * k], want[k][0]);
            CHECK_EQ_INT(p.pairs[2 * k + 1], want[k][1]);
            CHECK_EQ_INT(p.pair_edge[k], 0);
        }
    check_properties(&m, &p);
    dtx_proximity_free(&p);

    /* The paper's 1.5: eps = 1.5 sqrt 2 ~ 2.121, radius ~ 2.221: every pair
     * but the two diagonals across (0-6, 3-5 at ~2.326). */
    CHECK_OK(dtx_proximity_build(&m, 1.5, &p, &err), &err);
    CHECK_EQ_INT(p.npairs, 14);
    CHECK(!has_pair(&p, 0, 6));
    CHECK(!has_pair(&p, 3, 5));
    CHECK(has_pair(&p, 0, 5));
    check_properties(&m, &p);
    dtx_proximity_free(&p);

    /* eps = 0: only the closest pair. */
    CHECK_OK(dtx_proximity_build(&m, 0.0, &p, &err), &err);
    CHECK_EQ_INT(p.nedges, 1);
    CHECK_EQ_INT(p.npairs, 1);
    if (p.npairs == 1) {
        CHECK_EQ_INT(p.pairs[0], 1);
        CHECK_EQ_INT(p.pairs[1], 4);
        CHECK_NEAR(p.rest_len[0], 0.1, 1e-12);
    }
    check_properties(&m, &p);
    dtx_proximity_free(&p);
    check_mesh_case(&m, 1.5, 1, "two squares");
    dtx_mesh_free(&m);
}

/* Four thin triangles along x, each of longest edge 1, gaps 0.5: component
 * k spans x in [1.5 k, 1.5 k + 1].  d_{k,k+1} = 0.5, d_{k,k+2} = 2,
 * d_{0,3} = 3.5; every d_a = 0.5, so (a, a+2) joins when eps >= 1.5 and
 * (0, 3) when eps >= 3. */
static void test_chain(void)
{
    builder b = {0};
    dtx_mesh m;
    dtx_proximity p;
    dtx_error err = {0};
    static const struct {
        double f;
        int32_t nedges;
    } cases[] = {{0.0, 3}, {1.4, 3}, {1.6, 5}, {2.9, 5}, {3.2, 6}};
    for (int k = 0; k < 4; k++) {
        double x = 1.5 * k;
        int32_t v = b.nv;
        add_v(&b, x, 0, 0);
        add_v(&b, x + 1, 0, 0);
        add_v(&b, x + 0.5, 0.1, 0);
        add_f(&b, v, v + 1, v + 2);
    }
    m = finish(&b);
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        CHECK_OK(dtx_proximity_build(&m, cases[c].f, &p, &err), &err);
        CHECK_EQ_INT(p.ncomp, 4);
        CHECK_EQ_INT(p.nedges, cases[c].nedges);
        for (int32_t e = 0; e < p.nedges; e++) {
            int32_t a = p.edges[2 * e], bb = p.edges[2 * e + 1];
            /* The tree is the chain; the added edges skip one or two. */
            CHECK_EQ_INT(p.in_tree[e], bb == a + 1);
            if (bb == a + 1)
                CHECK_NEAR(p.edge_dist[e], 0.5, 1e-12);
            else if (bb == a + 2)
                CHECK_NEAR(p.edge_dist[e], 2.0, 1e-12);
            else
                CHECK_NEAR(p.edge_dist[e], 3.5, 1e-12);
        }
        if (cases[c].nedges == 5) {
            CHECK_EQ_INT(p.edges[2], 0); /* (0,1) (0,2) (1,2) (1,3) (2,3) */
            CHECK_EQ_INT(p.edges[3], 2);
            CHECK_EQ_INT(p.edges[6], 1);
            CHECK_EQ_INT(p.edges[7], 3);
        }
        check_properties(&m, &p);
        dtx_proximity_free(&p);
        check_mesh_case(&m, cases[c].f, 1, "chain");
    }
    dtx_mesh_free(&m);
}

/* A tie for the closest pair at the same vertex i: i = 0 at the origin is
 * at the same distance from two vertices of a 5 x 4 grid in z = 1 (x and y
 * descending, so the lower index is at the larger y): (0, 0.5, 1) is
 * vertex 3 + 7 = 10 and (0, -0.5, 1) is 3 + 12 = 15.  The two sit in
 * different k-d tree leaves at the same box distance, and the search meets
 * 15 first (lower y); the lower index must still win. */
static void test_tie_same_vertex(void)
{
    builder b = {0};
    dtx_mesh m;
    dtx_proximity p;
    dtx_error err = {0};
    add_v(&b, 0, 0, 0);
    add_v(&b, -5, 0, -1);
    add_v(&b, -5, 1, -1);
    add_f(&b, 0, 1, 2);
    add_grid(&b, 5, 4, -1.0, 2.0, 1.5, 1.0);
    m = finish(&b);
    CHECK_OK(dtx_proximity_build(&m, 0.0, &p, &err), &err);
    CHECK_EQ_INT(p.nedges, 1);
    if (p.nedges == 1) {
        CHECK_EQ_INT(p.edge_pair[0], 0);
        CHECK_EQ_INT(p.edge_pair[1], 10);
        CHECK_DBL(p.edge_dist[0], ==, sqrt(1.25));
    }
    CHECK_EQ_INT(p.npairs, 1);
    dtx_proximity_free(&p);
    check_mesh_case(&m, 0.0, 1, "tie at one vertex");
    check_mesh_case(&m, 1.5, 1, "tie at one vertex");
    dtx_mesh_free(&m);
}

static void test_single_component(void)
{
    builder b = {0};
    dtx_mesh m;
    dtx_proximity p;
    dtx_error err = {0};
    add_grid(&b, 4, 3, 0.5, 0, 0, 0);
    add_v(&b, 5, 5, 5); /* in no face */
    m = finish(&b);
    CHECK_OK(dtx_proximity_build(&m, 1.5, &p, &err), &err);
    CHECK_EQ_INT(p.ncomp, 1);
    CHECK_EQ_INT(p.nedges, 0);
    CHECK_EQ_INT(p.npairs, 0);
    CHECK_EQ_INT(p.comp[0], 0);
    CHECK_EQ_INT(p.comp[11], 0);
    CHECK_EQ_INT(p.comp[12], -1);
    CHECK_NEAR(p.eps[0], 1.5 * sqrt(0.5), 1e-12);
    CHECK(p.edges != NULL && p.pairs != NULL);
    dtx_proximity_free(&p);
    dtx_mesh_free(&m);

    /* No face at all. */
    b = (builder){0};
    add_v(&b, 0, 0, 0);
    m = finish(&b);
    CHECK_OK(dtx_proximity_build(&m, 1.5, &p, &err), &err);
    CHECK_EQ_INT(p.ncomp, 0);
    CHECK_EQ_INT(p.comp[0], -1);
    CHECK_EQ_INT(p.nedges, 0);
    dtx_proximity_free(&p);
    dtx_proximity_free(&p); /* zeroed: a second free is harmless */
    dtx_proximity_free(NULL);
    dtx_mesh_free(&m);
}

static void test_errors(void)
{
    dtx_mesh m = two_squares();
    dtx_proximity p;
    dtx_error err = {0};
    int32_t tri[2];
    CHECK_EQ_INT(dtx_proximity_build(&m, -1.0, &p, &err), DTX_EINVAL);
    CHECK(strstr(err.msg, "eps_factor") != NULL);
    CHECK(p.comp == NULL && p.nedges == 0);
    CHECK_EQ_INT(dtx_proximity_build(&m, NAN, &p, &err), DTX_EINVAL);
    CHECK_EQ_INT(dtx_proximity_build(&m, INFINITY, &p, &err), DTX_EINVAL);
    m.F[4] = 8;
    CHECK_EQ_INT(dtx_proximity_build(&m, 1.5, &p, &err), DTX_ERANGE);
    CHECK(strstr(err.msg, "face 1") != NULL);
    m.F[4] = 2;
    m.V[3 * 5] = NAN;
    CHECK_EQ_INT(dtx_proximity_build(&m, 1.5, &p, &err), DTX_ENONFINITE);
    CHECK(strstr(err.msg, "vertex 5") != NULL);
    m.V[3 * 5] = 2.1;

    /* Triangle pairs: pair indices out of range, a vertex in no face. */
    {
        int32_t pr[2] = {1, 9};
        dtx_proximity q = {0};
        q.npairs = 1;
        q.pairs = pr;
        CHECK_EQ_INT(dtx_proximity_triangle_pairs(&m, &q, tri, &err), DTX_ERANGE);
        pr[1] = 7;
        m.nf = 3; /* vertex 7 is only in face 3 */
        CHECK_EQ_INT(dtx_proximity_triangle_pairs(&m, &q, tri, &err), DTX_EINVAL);
        CHECK(strstr(err.msg, "vertex 7") != NULL);
        m.nf = 4;
    }
    dtx_mesh_free(&m);
}

/* ------------------------------------------------------------------ */
/* Triangle pairs                                                      */
/* ------------------------------------------------------------------ */

static double pair_score(const dtx_mesh *m, int32_t ta, int32_t tb)
{
    double N[6], Ba[3], Bb[3], h[3];
    dtx_face_normals(m->V, m->F + 3 * ta, 1, N);
    dtx_face_normals(m->V, m->F + 3 * tb, 1, N + 3);
    for (int k = 0; k < 3; k++) {
        Ba[k] = (m->V[3 * m->F[3 * ta] + k] + m->V[3 * m->F[3 * ta + 1] + k] +
                 m->V[3 * m->F[3 * ta + 2] + k]) /
                3.0;
        Bb[k] = (m->V[3 * m->F[3 * tb] + k] + m->V[3 * m->F[3 * tb + 1] + k] +
                 m->V[3 * m->F[3 * tb + 2] + k]) /
                3.0;
        h[k] = Bb[k] - Ba[k];
    }
    return fabs(h[0] * N[0] + h[1] * N[1] + h[2] * N[2]) +
           fabs(h[0] * N[3] + h[1] * N[4] + h[2] * N[5]);
}

static int face_has(const dtx_mesh *m, int32_t f, int32_t v)
{
    return m->F[3 * f] == v || m->F[3 * f + 1] == v || m->F[3 * f + 2] == v;
}

static void test_triangle_pairs_hand(void)
{
    builder b = {0};
    dtx_mesh m;
    dtx_error err = {0};
    int32_t pr[2] = {0, 4}, tri[2] = {-1, -1};
    dtx_proximity q = {0};
    /* A: t0 = (0,1,2) in z = 0 and t1 = (0,2,3) in x = 0, sharing vertex 0.
     * B: t2 = (4,5,6) in the plane x = 2.  From t0, h = (5/3, 0, 1/3) and the
     * score is 1/3 + 5/3 = 2; from t1, h = (2, 0, 0), score 2 + 2 = 4. */
    add_v(&b, 0, 0, 0);
    add_v(&b, 1, 0, 0);
    add_v(&b, 0, 1, 0);
    add_v(&b, 0, 0, 1);
    add_v(&b, 2, 0, 0);
    add_v(&b, 2, 1, 0);
    add_v(&b, 2, 0, 1);
    add_f(&b, 0, 1, 2);
    add_f(&b, 0, 2, 3);
    add_f(&b, 4, 5, 6);
    m = finish(&b);
    q.npairs = 1;
    q.pairs = pr;
    CHECK_OK(dtx_proximity_triangle_pairs(&m, &q, tri, &err), &err);
    CHECK_EQ_INT(tri[0], 1);
    CHECK_EQ_INT(tri[1], 2);
    CHECK_NEAR(pair_score(&m, 0, 2), 2.0, 1e-12);
    CHECK_NEAR(pair_score(&m, 1, 2), 4.0, 1e-12);
    dtx_mesh_free(&m);

    /* Two stacked unit squares 0.1 apart: every combination scores 0.2, so
     * the lowest (t_a, t_b) wins.  Vertex 2 is in faces 0 and 1 of A,
     * vertex 6 in faces 2 and 3 of B. */
    b = (builder){0};
    add_grid(&b, 2, 2, 1.0, 0, 0, 0);
    add_grid(&b, 2, 2, 1.0, 0, 0, 0.1);
    m = finish(&b);
    pr[0] = 3;
    pr[1] = 7;
    CHECK_OK(dtx_proximity_triangle_pairs(&m, &q, tri, &err), &err);
    CHECK_EQ_INT(tri[0], 0);
    CHECK_EQ_INT(tri[1], 2);
    dtx_mesh_free(&m);
}

/* On a real graph: every returned triangle contains its vertex, and no
 * other combination of the two one-rings scores higher (or as high with a
 * lower (t_a, t_b)). */
static void test_triangle_pairs_random(void)
{
    dtx_mesh m;
    dtx_proximity p;
    dtx_error err = {0};
    int32_t *tri1, *tri2;
    int bad_contains = 0, bad_max = 0;
    rng_state = 12345;
    m = random_scene(40, 6.0, 0, 5);
    CHECK_OK(dtx_proximity_build(&m, 1.5, &p, &err), &err);
    CHECK(p.npairs > 40);
    tri1 = malloc((size_t)(p.npairs + 1) * 2 * sizeof *tri1);
    tri2 = malloc((size_t)(p.npairs + 1) * 2 * sizeof *tri2);
    set_threads(1);
    CHECK_OK(dtx_proximity_triangle_pairs(&m, &p, tri1, &err), &err);
    set_threads(2);
    CHECK_OK(dtx_proximity_triangle_pairs(&m, &p, tri2, &err), &err);
    CHECK(memcmp(tri1, tri2, (size_t)p.npairs * 2 * sizeof *tri1) == 0);
    for (int64_t k = 0; k < p.npairs; k++) {
        int32_t i = p.pairs[2 * k], j = p.pairs[2 * k + 1], ta = tri1[2 * k], tb = tri1[2 * k + 1];
        double s;
        if (ta < 0 || tb < 0 || !face_has(&m, ta, i) || !face_has(&m, tb, j)) {
            bad_contains++;
            continue;
        }
        s = pair_score(&m, ta, tb);
        for (int32_t fa = 0; fa < m.nf; fa++) {
            if (!face_has(&m, fa, i))
                continue;
            for (int32_t fb = 0; fb < m.nf; fb++) {
                double t;
                if (!face_has(&m, fb, j))
                    continue;
                t = pair_score(&m, fa, fb);
                if (t > s || (t == s && (fa < ta || (fa == ta && fb < tb))))
                    bad_max++;
            }
        }
    }
    CHECK_EQ_INT(bad_contains, 0);
    CHECK_EQ_INT(bad_max, 0);
    free(tri1);
    free(tri2);
    dtx_proximity_free(&p);
    dtx_mesh_free(&m);
}

/* ------------------------------------------------------------------ */
/* Against the brute force                                             */
/* ------------------------------------------------------------------ */

static void test_random_against_reference(void)
{
    char what[64];
    rng_state = 42;
    for (int rep = 0; rep < 12; rep++) {
        int ncomp = 2 + rep * 4;
        dtx_mesh m = random_scene(ncomp, 2.0 + 0.5 * rep, 0, rep % 3);
        snprintf(what, sizeof what, "random scene %d", rep);
        check_mesh_case(&m, 1.5, 1, what);
        check_mesh_case(&m, 0.3, 1, what);
        dtx_mesh_free(&m);
    }
    /* Integer lattices: equal distances everywhere, so every tie-break
     * shows. */
    for (int rep = 0; rep < 8; rep++) {
        dtx_mesh m = random_scene(10 + 5 * rep, 4.0 + rep, 1, 2);
        snprintf(what, sizeof what, "lattice %d", rep);
        check_mesh_case(&m, 1.5, 1, what);
        check_mesh_case(&m, 0.0, 1, what);
        dtx_mesh_free(&m);
    }
    /* Many edges (big eps): more than the first edge buffers hold. */
    {
        dtx_mesh m = random_scene(120, 8.0, 0, 0);
        check_mesh_case(&m, 6.0, 1, "many edges");
        dtx_mesh_free(&m);
    }
}

/* Two fine grids close together: thousands of pairs, more than the first
 * pair buffers hold; plus a sphere-like blob of components. */
static void test_many_pairs(void)
{
    builder b = {0};
    dtx_mesh m;
    add_grid(&b, 24, 24, 0.1, 0, 0, 0);
    add_grid(&b, 24, 24, 0.1, 0.03, 0.04, 0.05);
    add_grid(&b, 5, 5, 0.3, 3, 0, 0);
    m = finish(&b);
    check_mesh_case(&m, 1.5, 1, "close grids");
    dtx_mesh_free(&m);
}

/* Threads only (the brute force would be slow): a few thousand
 * components. */
static void test_threads_large(void)
{
    dtx_mesh m;
    rng_state = 777;
    m = random_scene(3000, 30.0, 0, 10);
    check_mesh_case(&m, 1.5, 0, "3000 components");
    dtx_mesh_free(&m);
}

int main(void)
{
    test_two_squares();
    test_chain();
    test_tie_same_vertex();
    test_single_component();
    test_errors();
    test_triangle_pairs_hand();
    test_triangle_pairs_random();
    test_random_against_reference();
    test_many_pairs();
    test_threads_large();
    return check_report();
}
