/*
 * springs.c: deformation transfer by stretchiness ratios on mass-spring
 * systems (Yang, Ma & Ouhyoung; see springs.h for the method and the API).
 *
 * (The barrier, the sp04 start and the share theta of the indefinite
 * part that Newton keeps are described in springs.h; below, "projected"
 * is theta = 0 and "exact" theta = 1.)
 *
 * Newton.  For E(x) = sum_e k_e (l_e - r_e)^2, l_e = |x_i - x_j|, d = (x_i -
 * x_j) / l_e, the gradient at x_i is 2 k (l - r) d and the Hessian block
 *     K_e = 2 k [ d d^T + (1 - r/l) (I - d d^T) ]
 * (+K at (i, i) and (j, j), -K at (i, j)).  K is indefinite for a compressed
 * spring (l < r); the standard projection for springs clamps 1 - r/l at 0,
 * which makes every block positive semi-definite.  E is invariant under
 * rigid motions, so the projected Hessian H is singular (translations) or
 * nearly so (rotations near the equilibrium): H + mu I is factored instead,
 * mu = damping x the mean diagonal of H (tiny: the step in the stiff
 * directions is unchanged, and the gradient has no component along the
 * rigid motions, so those get no step).  The step's mean translation,
 * which only rounding puts there, is removed when no vertex is pinned, so
 * the centroid of the start is kept (exactly in exact arithmetic).  A
 * backtracking line search (Armijo, c = 1e-4, halving) accepts only steps
 * that lower E, so E decreases monotonically.  Where springs stay compressed
 * at the equilibrium the projected Hessian converges only linearly; so once
 * full steps are taken and small, the exact Hessian is tried (quadratic
 * convergence), and dropped again for the projected one when it is not
 * positive definite or needs a shortened step.  The Hessian's pattern
 * (upper triangle, 3 x 3 blocks of the springs and the vertices) never
 * changes: CHOLMOD analyses it once per level in the plan, and each Newton
 * step is one numeric factorisation and one solve.
 *
 * Multigrid start (nested iteration).  The spring network is coarsened
 * (coarsen.c) up to prm->levels times; the coarse springs have their own
 * reference lengths between the representatives' positions (source, target
 * and per frame deformed source), so a coarse level is the same kind of
 * problem with its own stretch ratios.  Levels are solved coarsest first,
 * each from a start made from the coarser solution (coarse_tol on the coarse
 * levels, tol on the fine one); see springs.h for the two kinds of start.
 * Every frame starts this way from its own data only: a start from the
 * previous frame's solution would make a frame's result depend on where the
 * sequence is split between ranks, threads and calls.
 *
 * Rotations (R_s, the cluster rotations, the final placement) are fitted by
 * Horn's quaternion method: the eigenvector of the largest eigenvalue of a
 * symmetric 4 x 4 matrix, by cyclic Jacobi sweeps; it always gives a proper
 * rotation, and the identity for degenerate data.
 */
#include "springs.h"
#include "cholmod_util.h"
#include "coarsen.h"
#include "plan_util.h"
#include "transfer.h"
#include "vec3.h"

#include <cholmod.h>
#include <math.h>
#include <stdio.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#endif

void dtx_springs_params_default(dtx_springs_params *p)
{
    memset(p, 0, sizeof *p);
    p->bending = 1;
    p->internal = 1;
    p->levels = 4;
    p->coarse_min = 150;
    p->max_iter = 100;
    p->tol = 1e-8;
    p->coarse_max_iter = 50;
    p->coarse_tol = 1e-5;
    p->start = DTX_SPRINGS_START_SP04;
    p->barrier = 1;
    p->damping = 1e-10;
}

void dtx_spring_set_free(dtx_spring_set *s)
{
    if (!s)
        return;
    free(s->ends);
    free(s->kind);
    memset(s, 0, sizeof *s);
}

/* ------------------------------------------------------------------ */
/* Rotations                                                           */
/* ------------------------------------------------------------------ */

/* Eigen-decomposition of the symmetric n x n (n <= 4) matrix A by cyclic
 * Jacobi sweeps: on return A's diagonal holds the eigenvalues and the
 * columns of V the eigenvectors. */
static void jacobi_eigen(int n, double A[4][4], double V[4][4])
{
    for (int a = 0; a < n; a++)
        for (int b = 0; b < n; b++)
            V[a][b] = a == b ? 1.0 : 0.0;
    for (int sweep = 0; sweep < 50; sweep++) {
        double off = 0.0, norm = 0.0;
        for (int a = 0; a < n; a++)
            for (int b = 0; b < n; b++) {
                norm += A[a][b] * A[a][b];
                if (a != b)
                    off += A[a][b] * A[a][b];
            }
        if (!(off > 1e-32 * norm))
            break;
        for (int p = 0; p < n; p++)
            for (int q = p + 1; q < n; q++) {
                double theta, t, c, s;
                if (A[p][q] == 0.0)
                    continue;
                theta = (A[q][q] - A[p][p]) / (2.0 * A[p][q]);
                t = (theta >= 0.0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(theta * theta + 1.0));
                c = 1.0 / sqrt(t * t + 1.0);
                s = t * c;
                for (int k = 0; k < n; k++) {
                    double akp = A[k][p], akq = A[k][q];
                    A[k][p] = c * akp - s * akq;
                    A[k][q] = s * akp + c * akq;
                }
                for (int k = 0; k < n; k++) {
                    double apk = A[p][k], aqk = A[q][k];
                    A[p][k] = c * apk - s * aqk;
                    A[q][k] = s * apk + c * aqk;
                }
                for (int k = 0; k < n; k++) {
                    double vkp = V[k][p], vkq = V[k][q];
                    V[k][p] = c * vkp - s * vkq;
                    V[k][q] = s * vkp + c * vkq;
                }
            }
    }
}

/* The rotation R (row-major) maximising sum q_i . R p_i, from the
 * cross-covariance C = sum p_i q_i^T (row-major, C[3a + b] = sum p_a q_b):
 * Horn's quaternion method.  Degenerate data give a deterministic rotation
 * (the identity for C = 0). */
static void rotation_fit(const double *C, double *R)
{
    double N[4][4], V[4][4], q[4];
    const double sxx = C[0], sxy = C[1], sxz = C[2], syx = C[3], syy = C[4], syz = C[5], szx = C[6],
                 szy = C[7], szz = C[8];
    int best = 0;
    N[0][0] = sxx + syy + szz;
    N[0][1] = N[1][0] = syz - szy;
    N[0][2] = N[2][0] = szx - sxz;
    N[0][3] = N[3][0] = sxy - syx;
    N[1][1] = sxx - syy - szz;
    N[1][2] = N[2][1] = sxy + syx;
    N[1][3] = N[3][1] = szx + sxz;
    N[2][2] = -sxx + syy - szz;
    N[2][3] = N[3][2] = syz + szy;
    N[3][3] = -sxx - syy + szz;
    jacobi_eigen(4, N, V);
    for (int k = 1; k < 4; k++)
        if (N[k][k] > N[best][best])
            best = k;
    for (int k = 0; k < 4; k++)
        q[k] = V[k][best];
    {
        double w = q[0], x = q[1], y = q[2], z = q[3], nn = w * w + x * x + y * y + z * z;
        double s = nn > 0.0 ? 2.0 / nn : 0.0;
        R[0] = 1.0 - s * (y * y + z * z);
        R[1] = s * (x * y - w * z);
        R[2] = s * (x * z + w * y);
        R[3] = s * (x * y + w * z);
        R[4] = 1.0 - s * (x * x + z * z);
        R[5] = s * (y * z - w * x);
        R[6] = s * (x * z - w * y);
        R[7] = s * (y * z + w * x);
        R[8] = 1.0 - s * (x * x + y * y);
    }
}

static inline void mat_vec(const double *R, const double *v, double *out)
{
    for (int a = 0; a < 3; a++)
        out[a] = R[3 * a] * v[0] + R[3 * a + 1] * v[1] + R[3 * a + 2] * v[2];
}

/* C += p q^T. */
static inline void add_outer(double *C, const double *p, const double *q)
{
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++)
            C[3 * a + b] += p[a] * q[b];
}

/* Orthonormal frame of triangle (a, b, c), rows u = e1 / |e1|, w = n x u,
 * n = e1 x e2 / |e1 x e2|; returns 0 (frame zeroed) for a degenerate one. */
static int triangle_frame(const double *a, const double *b, const double *c, double *Fr)
{
    double e1[3], e2[3], n[3], ln, le;
    sub3(b, a, e1);
    sub3(c, a, e2);
    cross3(e1, e2, n);
    ln = sqrt(dot3(n, n));
    le = sqrt(dot3(e1, e1));
    if (!(ln > 0.0) || !(le > 0.0)) {
        memset(Fr, 0, 9 * sizeof *Fr);
        return 0;
    }
    for (int k = 0; k < 3; k++) {
        Fr[k] = e1[k] / le;
        Fr[6 + k] = n[k] / ln;
    }
    cross3(Fr + 6, Fr, Fr + 3);
    return 1;
}

/* ------------------------------------------------------------------ */
/* Spring networks                                                     */
/* ------------------------------------------------------------------ */

typedef struct {
    const int32_t *F;
    int32_t v;
} not_incident;

static int not_incident_filter(const void *ctx, int32_t prim)
{
    const not_incident *c = ctx;
    const int32_t *f = c->F + 3 * (size_t)prim;
    return f[0] != c->v && f[1] != c->v && f[2] != c->v;
}

typedef struct {
    int32_t a, b; /* a < b */
    int32_t opp;  /* the vertex of the face opposite the edge */
} half_edge;

static int compare_half_edge(const void *x, const void *y)
{
    const half_edge *p = x, *q = y;
    if (p->a != q->a)
        return p->a < q->a ? -1 : 1;
    if (p->b != q->b)
        return p->b < q->b ? -1 : 1;
    return (p->opp > q->opp) - (p->opp < q->opp);
}

/* Internal spring candidates: for every vertex in a face, the partner found
 * by the ray (see springs.h), or -1.  elen: mean edge length per vertex. */
static dtx_status internal_partners(const double *V, int32_t nv, const int32_t *F, int32_t nf,
                                    const double *elen, int32_t *partner, dtx_error *err)
{
    double *N = dtx_alloc((size_t)nv, 3 * sizeof *N, 0), vol = 0.0, sign, diag;
    dtx_bvh *bvh = NULL;
    if (!N)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory building internal springs");
    bvh = dtx_bvh_build(V, F, nf);
    if (!bvh) {
        free(N);
        return dtx_seterr(err, DTX_ENOMEM, "out of memory building internal springs");
    }
    dtx_vertex_normals(V, nv, F, nf, N);
    for (int32_t f = 0; f < nf; f++) {
        const double *a = V + 3 * (size_t)F[3 * (size_t)f],
                     *b = V + 3 * (size_t)F[3 * (size_t)f + 1],
                     *c = V + 3 * (size_t)F[3 * (size_t)f + 2];
        double bc[3];
        cross3(b, c, bc);
        vol += dot3(a, bc);
    }
    /* Inward is against the outward normals of a positively oriented surface. */
    sign = vol >= 0.0 ? -1.0 : 1.0;
    diag = dtx_bbox_diagonal(V, nv);
#pragma omp parallel for schedule(dynamic, 256)
    for (int32_t v = 0; v < nv; v++) {
        double d[3], t = 0.0, bary[3], hit[3], best = INFINITY, fn[3], e1[3], e2[3];
        not_incident ctx;
        int32_t f, w = -1;
        const int32_t *tri;
        partner[v] = -1;
        if (!(elen[v] > 0.0) || !(dot3(N + 3 * (size_t)v, N + 3 * (size_t)v) > 0.0))
            continue;
        for (int k = 0; k < 3; k++)
            d[k] = sign * N[3 * (size_t)v + k];
        ctx.F = F;
        ctx.v = v;
        f = dtx_bvh_raycast(bvh, V + 3 * (size_t)v, d, 1e-9 * diag, INFINITY, not_incident_filter,
                            &ctx, &t, bary);
        if (f < 0)
            continue;
        tri = F + 3 * (size_t)f;
        /* The ray must leave the volume through the triangle: it meets the
         * triangle's back side. */
        sub3(V + 3 * (size_t)tri[1], V + 3 * (size_t)tri[0], e1);
        sub3(V + 3 * (size_t)tri[2], V + 3 * (size_t)tri[0], e2);
        cross3(e1, e2, fn);
        if (!(sign * -1.0 * dot3(fn, d) > 0.0))
            continue;
        for (int k = 0; k < 3; k++)
            hit[k] = V[3 * (size_t)v + k] + t * d[k];
        for (int j = 0; j < 3; j++) {
            double q[3], dd;
            sub3(V + 3 * (size_t)tri[j], hit, q);
            dd = dot3(q, q);
            if (dd < best || (dd == best && tri[j] < w)) {
                best = dd;
                w = tri[j];
            }
        }
        if (w < 0 || w == v)
            continue;
        {
            double q[3];
            sub3(V + 3 * (size_t)w, V + 3 * (size_t)v, q);
            if (!(sqrt(dot3(q, q)) > elen[v]))
                continue;
        }
        partner[v] = w;
    }
    dtx_bvh_free(&bvh);
    free(N);
    return DTX_OK;
}

dtx_status dtx_springs_build(const double *V, int32_t nv, const int32_t *F, int32_t nf, int bending,
                             int internal, dtx_spring_set *out, dtx_error *err)
{
    half_edge *he = NULL;
    double *elen = NULL;
    int32_t *ecount = NULL, *partner = NULL;
    int64_t nhe = 3 * (int64_t)nf, m = 0, cap;
    dtx_status st = DTX_OK;

    memset(out, 0, sizeof *out);
    if (nhe > INT32_MAX)
        return dtx_seterr(err, DTX_ENOMEM, "too many faces for the spring network (%d)", (int)nf);
    he = dtx_alloc((size_t)nhe, sizeof *he, 0);
    elen = dtx_alloc((size_t)nv, sizeof *elen, 1);
    ecount = dtx_alloc((size_t)nv, sizeof *ecount, 1);
    /* At most: every edge, one bending spring per edge, one internal
     * spring per vertex. */
    cap = nhe + nhe + nv;
    if (cap > INT32_MAX)
        cap = INT32_MAX;
    out->ends = dtx_alloc((size_t)cap, 2 * sizeof *out->ends, 0);
    out->kind = dtx_alloc((size_t)cap, 1, 0);
    if (!he || !elen || !ecount || !out->ends || !out->kind)
        goto nomem;

    /* ---- Edges and bending pairs from the sorted half-edges. ---- */
    for (int32_t f = 0; f < nf; f++)
        for (int j = 0; j < 3; j++) {
            int32_t a = F[3 * (size_t)f + j], b = F[3 * (size_t)f + (j + 1) % 3];
            half_edge *h = he + 3 * (size_t)f + j;
            h->a = a < b ? a : b;
            h->b = a < b ? b : a;
            h->opp = F[3 * (size_t)f + (j + 2) % 3];
        }
    qsort(he, (size_t)nhe, sizeof *he, compare_half_edge);
    for (int64_t s = 0; s < nhe;) {
        int64_t e = s + 1;
        while (e < nhe && he[e].a == he[s].a && he[e].b == he[s].b)
            e++;
        {
            double q[3], l;
            sub3(V + 3 * (size_t)he[s].a, V + 3 * (size_t)he[s].b, q);
            l = sqrt(dot3(q, q));
            elen[he[s].a] += l;
            elen[he[s].b] += l;
            ecount[he[s].a]++;
            ecount[he[s].b]++;
        }
        out->ends[2 * m] = he[s].a;
        out->ends[2 * m + 1] = he[s].b;
        out->kind[m++] = DTX_SPRING_EDGE;
        if (bending && e - s == 2 && he[s].opp != he[s + 1].opp) {
            int32_t c = he[s].opp, d = he[s + 1].opp;
            out->ends[2 * m] = c < d ? c : d;
            out->ends[2 * m + 1] = c < d ? d : c;
            out->kind[m++] = DTX_SPRING_BENDING;
        }
        s = e;
    }
    free(he);
    he = NULL;
    for (int32_t v = 0; v < nv; v++)
        elen[v] = ecount[v] > 0 ? elen[v] / ecount[v] : 0.0;

    /* ---- Internal springs. ---- */
    if (internal) {
        partner = dtx_alloc((size_t)nv, sizeof *partner, 0);
        if (!partner)
            goto nomem;
        st = internal_partners(V, nv, F, nf, elen, partner, err);
        if (st != DTX_OK)
            goto fail;
        for (int32_t v = 0; v < nv && m < cap; v++)
            if (partner[v] >= 0) {
                int32_t w = partner[v];
                out->ends[2 * m] = v < w ? v : w;
                out->ends[2 * m + 1] = v < w ? w : v;
                out->kind[m++] = DTX_SPRING_INTERNAL;
            }
    }

    {
        int32_t mm = dtx__springs_sort_unique(out->ends, out->kind, (int32_t)m, out->count);
        if (mm < 0)
            goto nomem;
        out->n = mm;
    }
    free(elen);
    free(ecount);
    free(partner);
    return DTX_OK;

nomem:
    st = dtx_seterr(err, DTX_ENOMEM, "out of memory building the spring network");
fail:
    free(he);
    free(elen);
    free(ecount);
    free(partner);
    dtx_spring_set_free(out);
    return st;
}

/* ------------------------------------------------------------------ */
/* Plan                                                                */
/* ------------------------------------------------------------------ */

/* One level of the hierarchy: a spring network over n vertices, each
 * standing for a vertex of the solve mesh (fine). */
typedef struct {
    int32_t n, nfree;
    int32_t *fine;    /* n: solve-mesh vertex of each vertex */
    int32_t *freeidx; /* n: unknown (block) index, or -1 for a fixed vertex */
    int32_t *freev;   /* nfree: the vertex of each unknown */
    double *rest;     /* n x 3: reference (target or proxy) positions */
    double rest_centroid[3];
    double diag; /* bounding-box diagonal of rest */
    dtx_spring_set springs;
    double *rt, *rs; /* springs.n: target (proxy) and source reference lengths */
    double *k;       /* springs.n: stiffness 1 / rt */
    double mu;       /* added to the Hessian's diagonal */
    double kmean;    /* mean over the unknowns of the sum of their springs' k */
    /* Hessian: upper triangle, compressed columns over 3 nfree unknowns
     * (3 f + c for coordinate c of unknown f); column 3 f + c holds the
     * lower neighbours' blocks (rows 3 g .. 3 g + 2, g < f, increasing g)
     * then the diagonal block's rows 3 f .. 3 f + c. */
    int32_t *colp, *rowi;
    int64_t nnz;
    int32_t *offpos;     /* springs.n x 3: position of entry (3 g, 3 f + c) of the
                            spring's off-diagonal block (g < f its unknowns), or -1 */
    cholmod_factor *L;   /* symbolic factor (the plan's common) */
    int32_t *adjp, *adj; /* edge-spring adjacency, for prolongating from this level */
    int32_t *parent;     /* n: vertex of the next coarser level each follows (-1:
                            none); NULL on the coarsest level */
    int32_t *rep;        /* n: the representative of each vertex in the next finer
                            level (an index there); NULL on the fine level */
} level;

typedef struct {
    double *x, *xt; /* n x 3: iterate and trial */
    double *g;      /* 3 nfree */
    double *Hx;     /* nnz */
    double *rtil;   /* springs.n: the frame's rest lengths */
    cholmod_factor *L;
    cholmod_dense *B, *X, *Y, *E;
    cholmod_dense *C, *Z, *ZY, *ZE; /* fine level with the barrier: the rigid
                                       motions (6 columns) and H^-1 of them */
} level_work;

typedef struct {
    cholmod_common cc;
    level_work lw[DTX_SPRINGS_MAX_LEVELS + 1];
    double *rot;       /* 9 x (largest level): per-vertex rotations */
    double *tm;        /* nf_s x 3: the frame's expected unit normals (barrier) */
    double *tsh;       /* nf_s: the frame's barrier thresholds */
    unsigned char *on; /* nf_s: triangle in the frame's barrier */
} worker;

struct dtx_springs_plan {
    int32_t nv_s, nf_s, nv_t, nf_t;
    int proxy;
    double *Vs;           /* nv_s x 3 source rest */
    int32_t *Fs;          /* nf_s x 3 */
    unsigned char *sused; /* nv_s: in a face */
    double src_centroid_used[3], src_centroid_all[3];
    double *sframe;       /* nf_s x 9: rest frames of the source triangles */
    double *Vt;           /* nv_t x 3 target rest */
    int32_t *Ft;          /* nf_t x 3 */
    unsigned char *tused; /* nv_t: placed by the solve (the others keep their
                             rest offset) */
    double tgt_centroid_used[3], tgt_centroid_all[3];
    double *tnormal; /* nf_t x 3: rest unit normals */
    int32_t *drive;  /* nf_t: driving source triangle */
    double scale;    /* target / source diagonal */

    /* Proxy binding of the target vertices. */
    int32_t *bind_tri; /* nv_t: solve-mesh triangle */
    double *bind_bary; /* nv_t x 3 */
    double *bind_off;  /* nv_t x 3: offset in the triangle's rest frame */

    dtx_anchor anchor;
    int32_t npins;
    int32_t *pins;
    double *pin_pos;

    int nlev;
    level lev[DTX_SPRINGS_MAX_LEVELS + 1];
    int32_t max_level_n; /* vertices of the largest level */

    /* Barrier over the solve mesh's triangles (Fs on the fine level). */
    int barrier;
    double *tri_n0;    /* nf_s x 3: rest unit normals of the solve mesh */
    double *tri_area;  /* nf_s: rest double areas (0: not in the barrier) */
    double *tri_kappa; /* nf_s: barrier weights */
    int32_t *tri_sp;   /* nf_s x 3: edge springs (0,1), (1,2), (2,0), or -1 */

    /* sp04 start: sp04 from the source onto the solve mesh (identity pairs)
     * and the starts of the frames of the current apply. */
    dtx_sp04_plan *sp04;
    /* With a proxy of one connected component: sp04 from the proxy (rest
     * Vr) onto the target, every target triangle paired with its driving
     * proxy triangle, which carries each frame's solution to the target. */
    dtx_sp04_plan *carry;
    double *starts;     /* the frames' starts, then (with carry) their solutions */
    int64_t starts_cap; /* frames starts holds */

    int max_iter, coarse_max_iter;
    double tol, coarse_tol;
    dtx_springs_start start;

    cholmod_common cc;
    dtx_springs_info info;
    dtx__workers workers; /* a worker per thread */
};

int32_t dtx_springs_plan_nv_src(const dtx_springs_plan *p) { return p->nv_s; }
int32_t dtx_springs_plan_nv_tgt(const dtx_springs_plan *p) { return p->nv_t; }
void dtx_springs_plan_info(const dtx_springs_plan *p, dtx_springs_info *info) { *info = p->info; }

static void fini_worker(void *plan, void *workspace)
{
    const dtx_springs_plan *p = plan;
    worker *k = workspace;
    for (int l = 0; l < p->nlev; l++) {
        level_work *lw = &k->lw[l];
        free(lw->x);
        free(lw->xt);
        free(lw->g);
        free(lw->Hx);
        free(lw->rtil);
        cholmod_free_factor(&lw->L, &k->cc);
        cholmod_free_dense(&lw->B, &k->cc);
        cholmod_free_dense(&lw->X, &k->cc);
        cholmod_free_dense(&lw->Y, &k->cc);
        cholmod_free_dense(&lw->E, &k->cc);
        cholmod_free_dense(&lw->C, &k->cc);
        cholmod_free_dense(&lw->Z, &k->cc);
        cholmod_free_dense(&lw->ZY, &k->cc);
        cholmod_free_dense(&lw->ZE, &k->cc);
    }
    free(k->rot);
    free(k->tm);
    free(k->tsh);
    free(k->on);
    cholmod_finish(&k->cc);
}

static void level_free(level *L, cholmod_common *cc)
{
    free(L->fine);
    free(L->freeidx);
    free(L->freev);
    free(L->rest);
    dtx_spring_set_free(&L->springs);
    free(L->rt);
    free(L->rs);
    free(L->k);
    free(L->colp);
    free(L->rowi);
    free(L->offpos);
    cholmod_free_factor(&L->L, cc);
    free(L->adjp);
    free(L->adj);
    free(L->parent);
    free(L->rep);
    memset(L, 0, sizeof *L);
}

void dtx_springs_plan_free(dtx_springs_plan **pp)
{
    dtx_springs_plan *p;
    if (!pp || !*pp)
        return;
    p = *pp;
    dtx__workers_free(&p->workers, p, fini_worker);
    for (int l = 0; l < p->nlev; l++)
        level_free(&p->lev[l], &p->cc);
    cholmod_finish(&p->cc);
    free(p->Vs);
    free(p->Fs);
    free(p->sused);
    free(p->sframe);
    free(p->Vt);
    free(p->Ft);
    free(p->tused);
    free(p->tnormal);
    free(p->drive);
    free(p->bind_tri);
    free(p->bind_bary);
    free(p->bind_off);
    free(p->pins);
    free(p->pin_pos);
    free(p->tri_n0);
    free(p->tri_area);
    free(p->tri_kappa);
    free(p->tri_sp);
    dtx_sp04_plan_free(&p->sp04);
    dtx_sp04_plan_free(&p->carry);
    free(p->starts);
    free(p);
    *pp = NULL;
}

/* Centroid of the n points X whose flag is set (all when used == NULL). */
static void centroid_of(const double *X, int32_t n, const unsigned char *used, double *c)
{
    int32_t m = 0;
    c[0] = c[1] = c[2] = 0.0;
    for (int32_t i = 0; i < n; i++)
        if (!used || used[i]) {
            for (int k = 0; k < 3; k++)
                c[k] += X[3 * (size_t)i + k];
            m++;
        }
    for (int k = 0; k < 3; k++)
        c[k] = m > 0 ? c[k] / m : 0.0;
}

/* Drops the springs whose source or target reference length is below 1e-12
 * of that shape's diagonal, and fills the level's rt, rs and k.  Vs, Vr:
 * source and reference positions indexed by the level's fine vertices. */
static dtx_status level_springs(level *L, const double *Vs, double diag_s, const double *Vr,
                                double diag_r, int32_t *dropped, dtx_error *err)
{
    dtx_spring_set *S = &L->springs;
    int32_t m = 0;
    L->rt = dtx_alloc((size_t)S->n, sizeof *L->rt, 0);
    L->rs = dtx_alloc((size_t)S->n, sizeof *L->rs, 0);
    L->k = dtx_alloc((size_t)S->n, sizeof *L->k, 0);
    if (!L->rt || !L->rs || !L->k)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory creating the springs plan");
    for (int k = 0; k < DTX_SPRING_KINDS; k++)
        S->count[k] = 0;
    for (int32_t s = 0; s < S->n; s++) {
        int32_t i = S->ends[2 * (size_t)s], j = S->ends[2 * (size_t)s + 1];
        int32_t fi = L->fine[i], fj = L->fine[j];
        double q[3], rs, rt;
        sub3(Vs + 3 * (size_t)fi, Vs + 3 * (size_t)fj, q);
        rs = sqrt(dot3(q, q));
        sub3(Vr + 3 * (size_t)fi, Vr + 3 * (size_t)fj, q);
        rt = sqrt(dot3(q, q));
        if (!(rs > 1e-12 * diag_s) || !(rt > 1e-12 * diag_r)) {
            (*dropped)++;
            continue;
        }
        S->ends[2 * (size_t)m] = i;
        S->ends[2 * (size_t)m + 1] = j;
        S->kind[m] = S->kind[s];
        S->count[S->kind[s]]++;
        L->rs[m] = rs;
        L->rt[m] = rt;
        L->k[m] = 1.0 / rt;
        m++;
    }
    S->n = m;
    return DTX_OK;
}

typedef struct {
    int32_t lo, hi; /* unknown block indices, lo < hi */
    int32_t spring; /* the spring, or -1 for a duplicate block */
} block_entry;

static int compare_block(const void *x, const void *y)
{
    const block_entry *a = x, *b = y;
    if (a->hi != b->hi)
        return a->hi < b->hi ? -1 : 1;
    if (a->lo != b->lo)
        return a->lo < b->lo ? -1 : 1;
    return (a->spring > b->spring) - (a->spring < b->spring);
}

/* The level's Hessian pattern, offpos, mu, and its symbolic factorisation. */
/* The level's Hessian pattern (upper triangle, 3 nfree columns) as a
 * CHOLMOD matrix header over L's arrays, with values x (nnz entries), or
 * the pattern alone when x is NULL. */
static void hessian_view(const level *L, double *x, cholmod_sparse *A)
{
    memset(A, 0, sizeof *A);
    A->nrow = A->ncol = 3 * (size_t)L->nfree;
    A->nzmax = (size_t)L->nnz;
    A->p = L->colp;
    A->i = L->rowi;
    A->x = x;
    A->stype = 1;
    A->itype = CHOLMOD_INT;
    A->xtype = x ? CHOLMOD_REAL : CHOLMOD_PATTERN;
    A->dtype = CHOLMOD_DOUBLE;
    A->sorted = 1;
    A->packed = 1;
}

static dtx_status level_pattern(level *L, double damping, cholmod_common *cc, dtx_error *err)
{
    const int32_t ns = L->springs.n, nf = L->nfree;
    block_entry *be = NULL;
    int32_t nb = 0, *nlow = NULL;
    int64_t nnz = 0;
    double ksum = 0.0;
    cholmod_sparse A;

    L->offpos = dtx_alloc((size_t)ns, 3 * sizeof *L->offpos, 0);
    L->colp = dtx_alloc(3 * (size_t)nf + 1, sizeof *L->colp, 0);
    be = dtx_alloc((size_t)ns, sizeof *be, 0);
    nlow = dtx_alloc((size_t)nf + 1, sizeof *nlow, 1);
    if (!L->offpos || !L->colp || !be || !nlow)
        goto nomem;
    for (int32_t s = 0; s < ns; s++) {
        int32_t a = L->freeidx[L->springs.ends[2 * (size_t)s]];
        int32_t b = L->freeidx[L->springs.ends[2 * (size_t)s + 1]];
        L->offpos[3 * (size_t)s] = L->offpos[3 * (size_t)s + 1] = L->offpos[3 * (size_t)s + 2] = -1;
        ksum += (a >= 0 ? 2.0 * L->k[s] : 0.0) + (b >= 0 ? 2.0 * L->k[s] : 0.0);
        if (a < 0 || b < 0 || a == b)
            continue;
        be[nb].lo = a < b ? a : b;
        be[nb].hi = a < b ? b : a;
        be[nb++].spring = s;
    }
    qsort(be, (size_t)nb, sizeof *be, compare_block);
    /* Lower neighbours per unknown (duplicate blocks counted once). */
    for (int32_t e = 0; e < nb; e++)
        if (e == 0 || be[e].lo != be[e - 1].lo || be[e].hi != be[e - 1].hi)
            nlow[be[e].hi]++;
    L->colp[0] = 0;
    for (int32_t f = 0; f < nf; f++)
        for (int c = 0; c < 3; c++) {
            int64_t len = 3 * (int64_t)nlow[f] + c + 1;
            nnz += len;
            if (nnz > INT32_MAX) {
                free(be);
                free(nlow);
                return dtx_seterr(err, DTX_ENOMEM,
                                  "the springs Hessian has too many entries (%lld) for 32-bit "
                                  "indices",
                                  (long long)nnz);
            }
            L->colp[3 * f + c + 1] = (int32_t)nnz;
        }
    L->nnz = nnz;
    L->rowi = dtx_alloc((size_t)nnz, sizeof *L->rowi, 0);
    if (!L->rowi)
        goto nomem;
    {
        /* Blocks in order of (hi, lo): each column's rows are filled in
         * increasing order, then the diagonal block closes it. */
        int32_t e = 0;
        for (int32_t f = 0; f < nf; f++) {
            int32_t pos[3];
            for (int c = 0; c < 3; c++)
                pos[c] = L->colp[3 * f + c];
            for (; e < nb && be[e].hi == f; e++) {
                int dup = e > 0 && be[e].lo == be[e - 1].lo && be[e].hi == be[e - 1].hi;
                int32_t s = be[e].spring;
                for (int c = 0; c < 3; c++) {
                    if (dup) {
                        L->offpos[3 * (size_t)s + c] = L->offpos[3 * (size_t)be[e - 1].spring + c];
                        continue;
                    }
                    L->offpos[3 * (size_t)s + c] = pos[c];
                    for (int r = 0; r < 3; r++)
                        L->rowi[pos[c]++] = 3 * be[e].lo + r;
                }
            }
            for (int c = 0; c < 3; c++)
                for (int r = 0; r <= c; r++)
                    L->rowi[pos[c]++] = 3 * f + r;
        }
    }
    free(be);
    be = NULL;
    free(nlow);
    nlow = NULL;
    L->kmean = nf > 0 ? 0.5 * ksum / nf : 1.0;
    L->mu = damping * (nf > 0 ? ksum / nf : 1.0);
    if (!(L->mu > 0.0))
        L->mu = damping > 0.0 ? damping : 1e-300;

    if (nf == 0)
        return DTX_OK;
    hessian_view(L, NULL, &A);
    return dtx__chol_analyze(&A, "the springs Hessian", &L->L, cc, err);

nomem:
    free(be);
    free(nlow);
    return dtx_seterr(err, DTX_ENOMEM, "out of memory creating the springs plan");
}

/* Edge-spring adjacency of the level (CSR, sorted lists). */
static int level_adjacency(level *L)
{
    return dtx__spring_adjacency(L->n, L->springs.ends, L->springs.kind, L->springs.n,
                                 DTX_SPRING_EDGE, &L->adjp, &L->adj);
}

/* Rest positions, centroid, diagonal and (all free unless fixed[v])
 * unknowns of a level whose fine[] is set. */
static dtx_status level_vertices(level *L, const double *Vr, const unsigned char *fixed,
                                 dtx_error *err)
{
    L->rest = dtx_alloc((size_t)L->n, 3 * sizeof *L->rest, 0);
    L->freeidx = dtx_alloc((size_t)L->n, sizeof *L->freeidx, 0);
    L->freev = dtx_alloc((size_t)L->n, sizeof *L->freev, 0);
    if (!L->rest || !L->freeidx || !L->freev)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory creating the springs plan");
    L->nfree = 0;
    for (int32_t v = 0; v < L->n; v++) {
        memcpy(L->rest + 3 * (size_t)v, Vr + 3 * (size_t)L->fine[v], 3 * sizeof *L->rest);
        if (fixed && fixed[v]) {
            L->freeidx[v] = -1;
        } else {
            L->freeidx[v] = L->nfree;
            L->freev[L->nfree++] = v;
        }
    }
    centroid_of(L->rest, L->n, NULL, L->rest_centroid);
    L->diag = dtx_bbox_diagonal(L->rest, L->n);
    return DTX_OK;
}

/* Argument checks of dtx_springs_plan_create. */
static dtx_status check_args(const dtx_mesh *src, const dtx_mesh *tgt, const double *proxy,
                             const dtx_springs_params *prm, dtx_anchor anchor, const int32_t *pins,
                             const double *pin_pos, int32_t npins, dtx_error *err)
{
    if (!(prm->levels >= 0 && prm->levels <= DTX_SPRINGS_MAX_LEVELS) || prm->coarse_min < 3 ||
        (prm->start != DTX_SPRINGS_START_LINEAR && prm->start != DTX_SPRINGS_START_REST &&
         prm->start != DTX_SPRINGS_START_SP04) ||
        (prm->barrier != 0 && prm->barrier != 1) || prm->max_iter < 0 || prm->coarse_max_iter < 0 ||
        !(prm->tol >= 0.0) || !(prm->coarse_tol >= 0.0) ||
        !(prm->damping > 0.0 && prm->damping < 1.0))
        return dtx_seterr(err, DTX_EINVAL,
                          "springs parameters out of range (levels 0..%d, coarse_min >= 3, "
                          "start linear, rest or sp04, barrier 0 or 1, max_iter and "
                          "coarse_max_iter >= 0, tol and coarse_tol >= 0, 0 < damping < 1)",
                          DTX_SPRINGS_MAX_LEVELS);
    if (anchor != DTX_ANCHOR_FIXED && anchor != DTX_ANCHOR_FOLLOW && anchor != DTX_ANCHOR_PINS)
        return dtx_seterr(err, DTX_EINVAL, "unknown translation mode %d", (int)anchor);
    if (anchor == DTX_ANCHOR_PINS && npins < 1)
        return dtx_seterr(err, DTX_EINVAL, "translation \"pins\" needs at least one pinned vertex");
    if (npins < 0 || (npins > 0 && (!pins || !pin_pos)))
        return dtx_seterr(err, DTX_EINVAL, "pins: %d given without their indices or positions",
                          (int)npins);
    if (npins > 0 && proxy)
        return dtx_seterr(err, DTX_EINVAL,
                          "pinned vertices are not supported by the springs method with a proxy "
                          "(source and target of different connectivity): use translation "
                          "\"fixed\" or \"follow\"");
    for (int32_t i = 0; i < npins; i++) {
        if (pins[i] < 0 || pins[i] >= tgt->nv)
            return dtx_seterr(err, DTX_ERANGE, "pin %d: vertex %d out of range [0, %d)", (int)i,
                              (int)pins[i], (int)tgt->nv);
        for (int k = 0; k < 3; k++)
            if (!isfinite(pin_pos[3 * (size_t)i + k]))
                return dtx_seterr(err, DTX_ENONFINITE, "pin %d: position is not finite", (int)i);
    }
    if (!proxy) {
        if (src->nv != tgt->nv || src->nf != tgt->nf)
            return dtx_seterr(err, DTX_EMESH,
                              "springs: source (%d vertices, %d faces) and target (%d vertices, "
                              "%d faces) do not share their connectivity; pass the source "
                              "deformed into the target (dtx_sp04_correspond's deformed_src) as "
                              "a proxy",
                              (int)src->nv, (int)src->nf, (int)tgt->nv, (int)tgt->nf);
        for (int32_t f = 0; f < src->nf; f++)
            for (int j = 0; j < 3; j++)
                if (src->F[3 * (size_t)f + j] != tgt->F[3 * (size_t)f + j])
                    return dtx_seterr(
                        err, DTX_EMESH,
                        "springs: source and target do not share their connectivity (face %d is "
                        "(%d, %d, %d) in the source, (%d, %d, %d) in the target); pass the "
                        "source deformed into the target (dtx_sp04_correspond's deformed_src) "
                        "as a proxy",
                        (int)f, (int)src->F[3 * (size_t)f], (int)src->F[3 * (size_t)f + 1],
                        (int)src->F[3 * (size_t)f + 2], (int)tgt->F[3 * (size_t)f],
                        (int)tgt->F[3 * (size_t)f + 1], (int)tgt->F[3 * (size_t)f + 2]);
    } else {
        for (int64_t i = 0; i < 3 * (int64_t)src->nv; i++)
            if (!isfinite(proxy[i]))
                return dtx_seterr(err, DTX_ENONFINITE,
                                  "proxy vertex %lld has a non-finite coordinate",
                                  (long long)(i / 3));
    }
    return DTX_OK;
}

typedef struct {
    const double *N; /* face normals */
    double n[3];     /* the query's normal */
} normal_ctx;

static int normal_filter(const void *ctx, int32_t prim)
{
    const normal_ctx *c = ctx;
    return dot3(c->N + 3 * (size_t)prim, c->n) > 0.0;
}

/* Closest point of p on the solve mesh (bvh over Vr, F with face normals
 * Nr), preferring faces whose normal agrees with n; returns the face and
 * fills cp. */
static int32_t closest_on(const dtx_bvh *bvh, const double *Nr, const double *p, const double *n,
                          double *cp)
{
    normal_ctx ctx;
    int32_t f;
    ctx.N = Nr;
    memcpy(ctx.n, n, sizeof ctx.n);
    f = dtx_bvh_closest(bvh, p, INFINITY, normal_filter, &ctx, cp, NULL);
    if (f < 0)
        f = dtx_bvh_closest(bvh, p, INFINITY, NULL, NULL, cp, NULL);
    return f;
}

/* Barycentric coordinates of p (on or near triangle a, b, c). */
static void barycentric(const double *p, const double *a, const double *b, const double *c,
                        double *w)
{
    double v0[3], v1[3], v2[3], d00, d01, d11, d20, d21, den;
    sub3(b, a, v0);
    sub3(c, a, v1);
    sub3(p, a, v2);
    d00 = dot3(v0, v0);
    d01 = dot3(v0, v1);
    d11 = dot3(v1, v1);
    d20 = dot3(v2, v0);
    d21 = dot3(v2, v1);
    den = d00 * d11 - d01 * d01;
    if (!(den > 0.0)) {
        w[0] = 1.0;
        w[1] = w[2] = 0.0;
        return;
    }
    w[1] = (d11 * d20 - d01 * d21) / den;
    w[2] = (d00 * d21 - d01 * d20) / den;
    w[0] = 1.0 - w[1] - w[2];
}

/* Target side: rest normals, driving triangles and, with a proxy, the
 * binding of every target vertex to the solve mesh (positions Vr). */
static dtx_status bind_target(dtx_springs_plan *p, const dtx_mesh *tgt, const double *Vr,
                              dtx_error *err)
{
    double *Nr = NULL, *Nt = NULL, s2 = 0.0;
    dtx_bvh *bvh = NULL;
    dtx_status st = DTX_OK;

    p->tnormal = dtx_alloc((size_t)p->nf_t, 3 * sizeof *p->tnormal, 0);
    p->drive = dtx_alloc((size_t)p->nf_t, sizeof *p->drive, 0);
    if (!p->tnormal || !p->drive)
        goto nomem;
    dtx_face_normals(tgt->V, tgt->F, tgt->nf, p->tnormal);
    if (!p->proxy) {
        for (int32_t f = 0; f < p->nf_t; f++)
            p->drive[f] = f;
        return DTX_OK;
    }
    p->bind_tri = dtx_alloc((size_t)p->nv_t, sizeof *p->bind_tri, 0);
    p->bind_bary = dtx_alloc((size_t)p->nv_t, 3 * sizeof *p->bind_bary, 0);
    p->bind_off = dtx_alloc((size_t)p->nv_t, 3 * sizeof *p->bind_off, 0);
    Nr = dtx_alloc((size_t)p->nf_s, 3 * sizeof *Nr, 0);
    Nt = dtx_alloc((size_t)p->nv_t, 3 * sizeof *Nt, 0);
    if (!p->bind_tri || !p->bind_bary || !p->bind_off || !Nr || !Nt)
        goto nomem;
    dtx_face_normals(Vr, p->Fs, p->nf_s, Nr);
    dtx_vertex_normals(tgt->V, tgt->nv, tgt->F, tgt->nf, Nt);
    bvh = dtx_bvh_build(Vr, p->Fs, p->nf_s);
    if (!bvh)
        goto nomem;
#pragma omp parallel for schedule(dynamic, 256)
    for (int32_t t = 0; t < p->nv_t; t++) {
        double cp[3], o[3], Fr[9];
        const double *x = tgt->V + 3 * (size_t)t;
        int32_t f = closest_on(bvh, Nr, x, Nt + 3 * (size_t)t, cp);
        const int32_t *tri = p->Fs + 3 * (size_t)f;
        p->bind_tri[t] = f;
        barycentric(cp, Vr + 3 * (size_t)tri[0], Vr + 3 * (size_t)tri[1], Vr + 3 * (size_t)tri[2],
                    p->bind_bary + 3 * (size_t)t);
        /* The offset is measured from the point the barycentric coordinates
         * give back, so that the rest proxy reproduces the target exactly. */
        for (int k = 0; k < 3; k++) {
            const double *b = p->bind_bary + 3 * (size_t)t;
            cp[k] = b[0] * Vr[3 * (size_t)tri[0] + k] + b[1] * Vr[3 * (size_t)tri[1] + k] +
                    b[2] * Vr[3 * (size_t)tri[2] + k];
        }
        sub3(x, cp, o);
        triangle_frame(Vr + 3 * (size_t)tri[0], Vr + 3 * (size_t)tri[1], Vr + 3 * (size_t)tri[2],
                       Fr);
        mat_vec(Fr, o, p->bind_off + 3 * (size_t)t);
    }
#pragma omp parallel for schedule(dynamic, 256)
    for (int32_t f = 0; f < p->nf_t; f++) {
        double c[3], cp[3];
        const int32_t *tri = tgt->F + 3 * (size_t)f;
        for (int k = 0; k < 3; k++)
            c[k] = (tgt->V[3 * (size_t)tri[0] + k] + tgt->V[3 * (size_t)tri[1] + k] +
                    tgt->V[3 * (size_t)tri[2] + k]) /
                   3.0;
        p->drive[f] = closest_on(bvh, Nr, c, p->tnormal + 3 * (size_t)f, cp);
    }
    for (int32_t t = 0; t < p->nv_t; t++) {
        const double *o = p->bind_off + 3 * (size_t)t;
        s2 += dot3(o, o);
    }
    {
        double diag = dtx_bbox_diagonal(tgt->V, tgt->nv);
        p->info.proxy_rms = diag > 0.0 ? sqrt(s2 / p->nv_t) / diag : 0.0;
    }
    goto done;
nomem:
    st = dtx_seterr(err, DTX_ENOMEM, "out of memory binding the target to the proxy");
done:
    dtx_bvh_free(&bvh);
    free(Nr);
    free(Nt);
    return st;
}

/* The hierarchy: the fine level over the solve mesh (positions Vr) and up
 * to prm->levels coarser ones. */
static dtx_status build_levels(dtx_springs_plan *p, const double *Vr, const dtx_springs_params *prm,
                               dtx_error *err)
{
    dtx_status st;
    unsigned char *fixed = NULL;
    const int32_t nv = p->nv_s;
    double diag_s = dtx_bbox_diagonal(p->Vs, nv), diag_r = dtx_bbox_diagonal(Vr, nv);
    level *L0 = &p->lev[0];

    if (!(diag_s > 0.0) || !(diag_r > 0.0))
        return dtx_seterr(err, DTX_EMESH, "springs: the %s mesh has zero extent",
                          diag_s > 0.0 ? (p->proxy ? "proxy" : "target") : "source");
    st = dtx_springs_build(Vr, nv, p->Fs, p->nf_s, prm->bending, prm->internal, &L0->springs, err);
    if (st != DTX_OK)
        return st;
    p->nlev = 1;
    L0->n = nv;
    L0->fine = dtx_alloc((size_t)nv, sizeof *L0->fine, 0);
    fixed = dtx_alloc((size_t)nv, 1, 1);
    if (!L0->fine || !fixed)
        goto nomem;
    for (int32_t v = 0; v < nv; v++)
        L0->fine[v] = v;
    st = level_springs(L0, p->Vs, diag_s, Vr, diag_r, &p->info.dropped, err);
    if (st != DTX_OK)
        goto fail;
    /* Unknowns: vertices with springs that are not pinned. */
    memset(fixed, 1, (size_t)nv);
    for (int32_t s = 0; s < L0->springs.n; s++) {
        fixed[L0->springs.ends[2 * (size_t)s]] = 0;
        fixed[L0->springs.ends[2 * (size_t)s + 1]] = 0;
    }
    for (int32_t i = 0; i < p->npins; i++)
        fixed[p->pins[i]] = 1;
    st = level_vertices(L0, Vr, fixed, err);
    if (st != DTX_OK)
        goto fail;
    free(fixed);
    fixed = NULL;
    if (!level_adjacency(L0))
        goto nomem;
    p->max_level_n = L0->n;

    /* The sp04 start is made on the fine level: no hierarchy. */
    while (p->nlev <= (prm->start == DTX_SPRINGS_START_SP04 ? 0 : prm->levels)) {
        level *F = &p->lev[p->nlev - 1], *C = &p->lev[p->nlev];
        dtx_coarse_level cl;
        st = dtx_coarsen(F->n, &F->springs, &cl, err);
        if (st != DTX_OK)
            goto fail;
        /* A level must keep enough vertices to stand for the shape, and be
         * worth it. */
        if (cl.n < prm->coarse_min || cl.n > 0.8 * F->n) {
            dtx_coarse_level_free(&cl);
            break;
        }
        F->parent = cl.cluster;
        cl.cluster = NULL;
        C->n = cl.n;
        C->springs = cl.springs;
        memset(&cl.springs, 0, sizeof cl.springs);
        C->rep = cl.rep;
        cl.rep = NULL;
        dtx_coarse_level_free(&cl);
        p->nlev++;
        C->fine = dtx_alloc((size_t)C->n, sizeof *C->fine, 0);
        if (!C->fine)
            goto nomem;
        for (int32_t c = 0; c < C->n; c++)
            C->fine[c] = F->fine[C->rep[c]];
        {
            int32_t dropped = 0;
            st = level_springs(C, p->Vs, diag_s, Vr, diag_r, &dropped, err);
            if (st != DTX_OK)
                goto fail;
        }
        st = level_vertices(C, Vr, NULL, err);
        if (st != DTX_OK)
            goto fail;
        if (!level_adjacency(C))
            goto nomem;
    }
    for (int l = 0; l < p->nlev; l++) {
        st = level_pattern(&p->lev[l], prm->damping, &p->cc, err);
        if (st != DTX_OK)
            goto fail;
    }
    return DTX_OK;

nomem:
    st = dtx_seterr(err, DTX_ENOMEM, "out of memory creating the springs plan");
fail:
    free(fixed);
    return st;
}

/* The spring of level L joining vertices i and j, or -1. */
static int32_t find_spring(const level *L, int32_t i, int32_t j)
{
    const int32_t a = i < j ? i : j, b = i < j ? j : i;
    int32_t lo = 0, hi = L->springs.n;
    while (lo < hi) {
        const int32_t mid = lo + (hi - lo) / 2;
        const int32_t *e = L->springs.ends + 2 * (size_t)mid;
        if (e[0] < a || (e[0] == a && e[1] < b))
            lo = mid + 1;
        else
            hi = mid;
    }
    if (lo < L->springs.n && L->springs.ends[2 * (size_t)lo] == a &&
        L->springs.ends[2 * (size_t)lo + 1] == b)
        return lo;
    return -1;
}

/* The barrier's triangles: the solve mesh's (positions Vr, faces Fs) with
 * their rest normals, double areas, weights and edge springs.  A triangle
 * of (near) zero area or with an edge whose spring was dropped is left
 * out (area 0). */
/* The barrier's weight per sqrt(rest double area) (see assemble_barrier). */
#define BARRIER_KAPPA 0.1

static dtx_status build_barrier(dtx_springs_plan *p, const double *Vr, dtx_error *err)
{
    const level *L0 = &p->lev[0];
    const double diag = L0->diag;
    p->tri_n0 = dtx_alloc((size_t)p->nf_s, 3 * sizeof *p->tri_n0, 1);
    p->tri_area = dtx_alloc((size_t)p->nf_s, sizeof *p->tri_area, 1);
    p->tri_kappa = dtx_alloc((size_t)p->nf_s, sizeof *p->tri_kappa, 1);
    p->tri_sp = dtx_alloc((size_t)p->nf_s, 3 * sizeof *p->tri_sp, 0);
    if (!p->tri_n0 || !p->tri_area || !p->tri_kappa || !p->tri_sp)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory creating the springs plan");
    for (int32_t t = 0; t < p->nf_s; t++) {
        const int32_t *tri = p->Fs + 3 * (size_t)t;
        double e1[3], e2[3], n[3], A;
        int ok = 1;
        sub3(Vr + 3 * (size_t)tri[1], Vr + 3 * (size_t)tri[0], e1);
        sub3(Vr + 3 * (size_t)tri[2], Vr + 3 * (size_t)tri[0], e2);
        cross3(e1, e2, n);
        A = sqrt(dot3(n, n));
        for (int k = 0; k < 3; k++) {
            p->tri_sp[3 * (size_t)t + k] = find_spring(L0, tri[k], tri[(k + 1) % 3]);
            ok = ok && p->tri_sp[3 * (size_t)t + k] >= 0;
        }
        if (!ok || !(A > 1e-12 * diag * diag))
            continue;
        for (int k = 0; k < 3; k++)
            p->tri_n0[3 * (size_t)t + k] = n[k] / A;
        p->tri_area[t] = A;
        /* Length units, like a spring's k (l - r)^2 with k = 1 / r. */
        p->tri_kappa[t] = BARRIER_KAPPA * sqrt(A);
    }
    return DTX_OK;
}

/* The solve mesh (positions Vr, the source's faces), borrowed. */
static dtx_mesh solve_mesh(const dtx_springs_plan *p, const double *Vr)
{
    dtx_mesh sm = {p->nv_s, p->nf_s, (double *)Vr, p->Fs};
    return sm;
}

/* The sp04 start: sp04 from src onto the solve mesh (every triangle paired
 * with itself). */
static dtx_status build_sp04_start(dtx_springs_plan *p, const dtx_mesh *src, const double *Vr,
                                   dtx_error *err)
{
    const dtx_mesh sm = solve_mesh(p, Vr);
    dtx_status st;
    int32_t *pairs = dtx_alloc((size_t)p->nf_s, 2 * sizeof *pairs, 0);
    if (!pairs)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory creating the springs plan");
    for (int32_t t = 0; t < p->nf_s; t++)
        pairs[2 * (size_t)t] = pairs[2 * (size_t)t + 1] = t;
    st = dtx_sp04_plan_create(src, &sm, pairs, p->nf_s,
                              p->npins > 0 ? DTX_ANCHOR_PINS : DTX_ANCHOR_FIXED, p->pins,
                              p->pin_pos, p->npins, &p->sp04, err);
    free(pairs);
    if (st == DTX_EMESH)
        dtx_error_prefix(err, "springs start \"sp04\" (a target of several connected components "
                              "needs start \"linear\" or \"rest\")");
    return st;
}

/* The carry to the target (see the plan's field): target triangle f
 * follows the deformation gradient of its driving proxy triangle, in the
 * least-squares sense of sp04, so neighbouring target triangles bound to
 * proxy triangles that turn differently (where the correspondence crumpled
 * the proxy) still meet without folding.  A target of several components
 * keeps the closest-point binding (p->carry stays NULL). */
static dtx_status build_carry(dtx_springs_plan *p, const dtx_mesh *tgt, const double *Vr,
                              dtx_error *err)
{
    const dtx_mesh sm = solve_mesh(p, Vr);
    dtx_status st;
    int32_t *pairs = dtx_alloc((size_t)p->nf_t, 2 * sizeof *pairs, 0);
    if (!pairs)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory creating the springs plan");
    for (int32_t f = 0; f < p->nf_t; f++) {
        pairs[2 * (size_t)f] = p->drive[f];
        pairs[2 * (size_t)f + 1] = f;
    }
    st = dtx_sp04_plan_create(&sm, tgt, pairs, p->nf_t, DTX_ANCHOR_FIXED, NULL, NULL, 0, &p->carry,
                              err);
    free(pairs);
    if (st == DTX_EMESH || st == DTX_ESOLVE) {
        p->carry = NULL;
        return DTX_OK;
    }
    return st;
}

dtx_status dtx_springs_plan_create(const dtx_mesh *src, const dtx_mesh *tgt, const double *proxy,
                                   const dtx_springs_params *prm, dtx_anchor anchor,
                                   const int32_t *pins, const double *pin_pos, int32_t npins,
                                   dtx_springs_plan **out, dtx_error *err)
{
    dtx_springs_plan *p = NULL;
    dtx_status st;
    const double *Vr;
    double t0 = dtx__now_seconds(), diag_s, diag_t;

    *out = NULL;
    st = check_args(src, tgt, proxy, prm, anchor, pins, pin_pos, npins, err);
    if (st != DTX_OK)
        return st;
    p = calloc(1, sizeof *p);
    if (!p)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory creating the springs plan");
    dtx__chol_start(&p->cc, DTX__CHOL_AUTO, DTX__CHOL_ORDER_DEFAULT);
    p->nv_s = src->nv;
    p->nf_s = src->nf;
    p->nv_t = tgt->nv;
    p->nf_t = tgt->nf;
    p->proxy = proxy != NULL;
    p->anchor = anchor;
    p->npins = npins;
    p->max_iter = prm->max_iter;
    p->coarse_max_iter = prm->coarse_max_iter;
    p->tol = prm->tol;
    p->coarse_tol = prm->coarse_tol;
    p->start = prm->start;
    p->Vs = dtx_alloc((size_t)src->nv, 3 * sizeof *p->Vs, 0);
    p->Fs = dtx_alloc((size_t)src->nf, 3 * sizeof *p->Fs, 0);
    p->sused = dtx_alloc((size_t)src->nv, 1, 1);
    p->sframe = dtx_alloc((size_t)src->nf, 9 * sizeof *p->sframe, 0);
    p->Vt = dtx_alloc((size_t)tgt->nv, 3 * sizeof *p->Vt, 0);
    p->Ft = dtx_alloc((size_t)tgt->nf, 3 * sizeof *p->Ft, 0);
    p->tused = dtx_alloc((size_t)tgt->nv, 1, 1);
    p->pins = dtx_alloc((size_t)npins, sizeof *p->pins, 0);
    p->pin_pos = dtx_alloc((size_t)npins, 3 * sizeof *p->pin_pos, 0);
    if (!p->Vs || !p->Fs || !p->sused || !p->sframe || !p->Vt || !p->Ft || !p->tused || !p->pins ||
        !p->pin_pos) {
        st = dtx_seterr(err, DTX_ENOMEM, "out of memory creating the springs plan");
        goto fail;
    }
    memcpy(p->Vs, src->V, (size_t)src->nv * 3 * sizeof *p->Vs);
    memcpy(p->Fs, src->F, (size_t)src->nf * 3 * sizeof *p->Fs);
    memcpy(p->Vt, tgt->V, (size_t)tgt->nv * 3 * sizeof *p->Vt);
    memcpy(p->Ft, tgt->F, (size_t)tgt->nf * 3 * sizeof *p->Ft);
    if (npins > 0) {
        memcpy(p->pins, pins, (size_t)npins * sizeof *p->pins);
        memcpy(p->pin_pos, pin_pos, (size_t)npins * 3 * sizeof *p->pin_pos);
    }
    for (int64_t i = 0; i < 3 * (int64_t)src->nf; i++)
        p->sused[src->F[i]] = 1;
    for (int32_t f = 0; f < src->nf; f++)
        triangle_frame(src->V + 3 * (size_t)src->F[3 * (size_t)f],
                       src->V + 3 * (size_t)src->F[3 * (size_t)f + 1],
                       src->V + 3 * (size_t)src->F[3 * (size_t)f + 2], p->sframe + 9 * (size_t)f);
    if (proxy)
        memset(p->tused, 1, (size_t)tgt->nv);
    else
        for (int64_t i = 0; i < 3 * (int64_t)tgt->nf; i++)
            p->tused[tgt->F[i]] = 1;
    centroid_of(p->Vs, p->nv_s, p->sused, p->src_centroid_used);
    centroid_of(p->Vs, p->nv_s, NULL, p->src_centroid_all);
    centroid_of(p->Vt, p->nv_t, p->tused, p->tgt_centroid_used);
    centroid_of(p->Vt, p->nv_t, NULL, p->tgt_centroid_all);
    diag_s = dtx_bbox_diagonal(src->V, src->nv);
    diag_t = dtx_bbox_diagonal(tgt->V, tgt->nv);
    p->scale = diag_s > 0.0 ? diag_t / diag_s : 1.0;

    Vr = proxy ? proxy : tgt->V;
    st = build_levels(p, Vr, prm, err);
    if (st != DTX_OK)
        goto fail;
    st = bind_target(p, tgt, Vr, err);
    if (st != DTX_OK)
        goto fail;
    if (p->proxy) {
        st = build_carry(p, tgt, Vr, err);
        if (st != DTX_OK)
            goto fail;
    }
    /* The barrier needs a start whose triangles face as the source turns
     * them and whose orientation is the source's: the sp04 start's. */
    p->barrier = prm->barrier && prm->start == DTX_SPRINGS_START_SP04;
    if (p->barrier) {
        st = build_barrier(p, Vr, err);
        if (st != DTX_OK)
            goto fail;
    }
    if (p->start == DTX_SPRINGS_START_SP04) {
        st = build_sp04_start(p, src, Vr, err);
        if (st != DTX_OK)
            goto fail;
    }

    for (int k = 0; k < DTX_SPRING_KINDS; k++)
        p->info.springs[k] = p->lev[0].springs.count[k];
    p->info.levels = p->nlev;
    for (int l = 0; l < p->nlev; l++) {
        p->info.level_vertices[l] = p->lev[l].n;
        p->info.level_springs[l] = p->lev[l].springs.n;
    }
    if (p->lev[0].L) {
        const cholmod_factor *F = p->lev[0].L;
        const int32_t *cnt = F->ColCount;
        int64_t nz = 0;
        for (size_t j = 0; j < F->n; j++)
            nz += cnt[j];
        p->info.factor_nnz = nz;
        p->info.supernodal = F->is_super != 0;
    }
    p->info.proxy = p->proxy;
    p->info.setup_seconds = dtx__now_seconds() - t0;
    *out = p;
    return DTX_OK;

fail:
    dtx_springs_plan_free(&p);
    return st;
}

/* ------------------------------------------------------------------ */
/* Newton on one level                                                 */
/* ------------------------------------------------------------------ */

static double spring_energy(const level *L, const double *rtil, const double *x)
{
    double e = 0.0;
    for (int32_t s = 0; s < L->springs.n; s++) {
        const int32_t i = L->springs.ends[2 * (size_t)s], j = L->springs.ends[2 * (size_t)s + 1];
        double q[3], r;
        sub3(x + 3 * (size_t)i, x + 3 * (size_t)j, q);
        r = sqrt(dot3(q, q)) - rtil[s];
        e += L->k[s] * r * r;
    }
    return e;
}

/* Gradient g (3 nfree) and projected Hessian + mu I (Hx, the pattern's
 * values) at x. */
static void assemble(const level *L, const double *rtil, const double *x, double theta, double *g,
                     double *Hx)
{
    memset(g, 0, 3 * (size_t)L->nfree * sizeof *g);
    memset(Hx, 0, (size_t)L->nnz * sizeof *Hx);
    for (int32_t s = 0; s < L->springs.n; s++) {
        const int32_t i = L->springs.ends[2 * (size_t)s], j = L->springs.ends[2 * (size_t)s + 1];
        const int32_t fi = L->freeidx[i], fj = L->freeidx[j];
        const double k2 = 2.0 * L->k[s];
        double q[3], l, u[3] = {0, 0, 0}, c = 1.0, gs = 0.0, K[3][3];
        sub3(x + 3 * (size_t)i, x + 3 * (size_t)j, q);
        l = sqrt(dot3(q, q));
        if (l > 0.0) {
            for (int a = 0; a < 3; a++)
                u[a] = q[a] / l;
            c = 1.0 - rtil[s] / l;
            if (c < 0.0)
                c *= theta;
            gs = k2 * (l - rtil[s]);
        }
        /* K = 2k [c I + (1 - c) u u^T]; a spring of zero length gets 2k I. */
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++)
                K[a][b] = k2 * ((a == b ? c : 0.0) + (1.0 - c) * u[a] * u[b]);
        if (fi >= 0) {
            for (int a = 0; a < 3; a++)
                g[3 * (size_t)fi + a] += gs * u[a];
            for (int b = 0; b < 3; b++)
                for (int a = 0; a <= b; a++)
                    Hx[L->colp[3 * fi + b + 1] - 1 - b + a] += K[a][b];
        }
        if (fj >= 0) {
            for (int a = 0; a < 3; a++)
                g[3 * (size_t)fj + a] -= gs * u[a];
            for (int b = 0; b < 3; b++)
                for (int a = 0; a <= b; a++)
                    Hx[L->colp[3 * fj + b + 1] - 1 - b + a] += K[a][b];
        }
        if (fi >= 0 && fj >= 0) {
            const int32_t *op = L->offpos + 3 * (size_t)s;
            for (int b = 0; b < 3; b++)
                for (int a = 0; a < 3; a++)
                    Hx[op[b] + a] -= K[a][b];
        }
    }
    for (int32_t f = 0; f < L->nfree; f++)
        for (int b = 0; b < 3; b++)
            Hx[L->colp[3 * f + b + 1] - 1] += L->mu;
}

/* ------------------------------------------------------------------ */
/* Orientation barrier                                                 */
/* ------------------------------------------------------------------ */

/* The barrier of one frame on the fine level.  Triangle t (vertices a, b,
 * c, rest double area A_t) has the oriented area a_t(x) = m_t . (x_b - x_a)
 * x (x_c - x_a), m_t its rest unit normal turned by the rotation of its
 * source triangle (as dtx_springs_apply counts inversions), so s_t = a_t /
 * A_t is 1 at rest and 0 when the triangle stands at 90 degrees to where
 * the source turns it (or has collapsed).  Its term is
 *     kappa_t b(s_t / h_t),  b(u) = (1 - u)^3 / u for 0 < u < 1,
 * 0 for u >= 1 and +inf for u <= 0, kappa_t = BARRIER_KAPPA sqrt(A_t)
 * (length units, like a spring's term), h_t = BARRIER_SHAT min(1, the
 * source triangle's area ratio in the frame).  b is C2 at u = 1 and convex
 * (b'' = 6 (1 - u) / u + 6 (1 - u)^2 / u^2 + 2 (1 - u)^3 / u^3 > 0): the
 * projected Hessian keeps b'' grad a grad a^T, the exact one adds b' times
 * a's (constant, indefinite) Hessian.  It grows like 1 / u, not like the
 * log of incremental potential contact's barrier, which compressed springs
 * could beat: with it Newton pushed triangles to s ~ 1e-12, where the
 * Hessian no longer factors.  It is zero on every triangle that keeps a
 * tenth of the area its source triangle keeps, in the expected orientation,
 * so it changes the springs' equilibrium only where a triangle would
 * otherwise fold (and T = S, whose s_t are the source's, never meets it);
 * since the energy is +inf on a folded triangle, a line search that accepts
 * only decreases never reaches one.
 *
 * A triangle that the start already has folded (s_t <= 0) gets the
 * unfolding penalty UNFOLD_WEIGHT kappa_t (1 - s_t / h_t)^2 instead (finite
 * on both sides of 0, so Newton can turn it over), and joins the barrier
 * once s_t reaches UNFOLD_JOIN h_t. */
#define BARRIER_SHAT 0.1

/* The weight W of the unfolding penalty, and the share of h_t a triangle
 * under it must reach to join the barrier. */
#define UNFOLD_WEIGHT 100.0
#define UNFOLD_JOIN 0.5

typedef struct {
    int32_t nt;
    const int32_t *F;        /* nt x 3 fine-level vertices */
    const int32_t *sp;       /* nt x 3 edge springs (0,1), (1,2), (2,0) */
    const double *area;      /* nt rest double areas */
    const double *kappa;     /* nt weights */
    const double *m;         /* nt x 3 the frame's expected unit normals */
    const double *shat;      /* nt: the frame's thresholds */
    unsigned char *on;       /* nt: 1 in the barrier this frame, 2 folded at
                                the start (the unfolding penalty, until it is
                                right side up), 0 neither */
} barrier_terms;

/* a_t of x and the gradients of a_t at its three vertices. */
static double oriented_area(const double *x, const int32_t *tri, const double *m, double gr[3][3])
{
    double e1[3], e2[3], n[3];
    sub3(x + 3 * (size_t)tri[1], x + 3 * (size_t)tri[0], e1);
    sub3(x + 3 * (size_t)tri[2], x + 3 * (size_t)tri[0], e2);
    if (gr) {
        cross3(e2, m, gr[1]);
        cross3(m, e1, gr[2]);
        for (int k = 0; k < 3; k++)
            gr[0][k] = -gr[1][k] - gr[2][k];
    }
    cross3(e1, e2, n);
    return dot3(n, m);
}

static double barrier_energy(const barrier_terms *bt, const double *x)
{
    double e = 0.0;
    for (int32_t t = 0; t < bt->nt; t++) {
        double s;
        if (!bt->on[t])
            continue;
        s = oriented_area(x, bt->F + 3 * (size_t)t, bt->m + 3 * (size_t)t, NULL) / bt->area[t];
        if (bt->on[t] == 2) {
            const double w = 1.0 - s / bt->shat[t];
            if (w > 0.0)
                e += UNFOLD_WEIGHT * bt->kappa[t] * w * w;
            continue;
        }
        if (!(s > 0.0))
            return INFINITY;
        if (s < bt->shat[t]) {
            const double u = s / bt->shat[t], w = 1.0 - u;
            e += bt->kappa[t] * w * w * w / u;
        }
    }
    return e;
}

/* Adds the block M (rows: unknown of vertex p, columns: of q, p != q, both
 * free) of a symmetric matrix to the upper-triangle values Hx at the
 * positions of spring s (which joins p and q). */
static void add_off_block(const level *L, int32_t s, int32_t fp, int32_t fq, double M[3][3],
                          double *Hx)
{
    const int32_t *op = L->offpos + 3 * (size_t)s;
    for (int c = 0; c < 3; c++)
        for (int r = 0; r < 3; r++)
            Hx[op[c] + r] += fp < fq ? M[r][c] : M[c][r];
}

/* Adds the barrier's gradient to g and its Hessian (projected, or exact
 * when exact != 0) to Hx at x. */
static void assemble_barrier(const level *L, const barrier_terms *bt, const double *x, double theta,
                             double *g, double *Hx)
{
    for (int32_t t = 0; t < bt->nt; t++) {
        const int32_t *tri = bt->F + 3 * (size_t)t;
        const double *m = bt->m + 3 * (size_t)t;
        double gr[3][3], s, db, d2, S[3][3], sh;
        int32_t fv[3];
        if (!bt->on[t])
            continue;
        s = oriented_area(x, tri, m, gr) / bt->area[t];
        sh = bt->shat[t];
        if (!(s < sh))
            continue;
        if (bt->on[t] == 2) {
            /* The unfolding penalty W kappa (1 - u)^2. */
            const double sc = 1.0 / (sh * bt->area[t]);
            db = -2.0 * UNFOLD_WEIGHT * bt->kappa[t] * (1.0 - s / sh) * sc;
            d2 = 2.0 * UNFOLD_WEIGHT * bt->kappa[t] * sc * sc;
        } else if (!(s > 0.0)) {
            continue;
        } else {
            /* b'(u) and b''(u), scaled to a_t = A_t h_t u. */
            const double u = s / sh, w = 1.0 - u, sc = 1.0 / (sh * bt->area[t]);
            db = -bt->kappa[t] * w * w * (1.0 + 2.0 * u) / (u * u) * sc;
            d2 = bt->kappa[t] * (6.0 * w / u + 6.0 * w * w / (u * u) + 2.0 * w * w * w / (u * u * u)) *
                 sc * sc;
        }
        /* a's Hessian: block (p, q) is S for q = p + 1 (mod 3), -S for
         * q = p - 1, 0 for q = p, with S v = v x m. */
        S[0][0] = S[1][1] = S[2][2] = 0.0;
        S[0][1] = m[2];
        S[0][2] = -m[1];
        S[1][0] = -m[2];
        S[1][2] = m[0];
        S[2][0] = m[1];
        S[2][1] = -m[0];
        for (int v = 0; v < 3; v++)
            fv[v] = L->freeidx[tri[v]];
        for (int v = 0; v < 3; v++) {
            if (fv[v] < 0)
                continue;
            for (int a = 0; a < 3; a++)
                g[3 * (size_t)fv[v] + a] += db * gr[v][a];
            for (int b = 0; b < 3; b++)
                for (int a = 0; a <= b; a++)
                    Hx[L->colp[3 * fv[v] + b + 1] - 1 - b + a] += d2 * gr[v][a] * gr[v][b];
        }
        for (int k = 0; k < 3; k++) {
            const int pv = k, qv = (k + 1) % 3;
            double M[3][3];
            if (fv[pv] < 0 || fv[qv] < 0)
                continue;
            for (int r = 0; r < 3; r++)
                for (int c = 0; c < 3; c++)
                    M[r][c] = d2 * gr[pv][r] * gr[qv][c] + theta * db * S[r][c];
            add_off_block(L, bt->sp[3 * (size_t)t + k], fv[pv], fv[qv], M, Hx);
        }
    }
}

/* The largest step alpha along dx (3 nfree, by unknown) before some
 * triangle of the barrier reaches a_t = 0 (INFINITY when none does):
 * a_t(alpha) is a quadratic. */
static double barrier_max_step(const level *L, const barrier_terms *bt, const double *x,
                               const double *dx)
{
    double amax = INFINITY;
    for (int32_t t = 0; t < bt->nt; t++) {
        const int32_t *tri = bt->F + 3 * (size_t)t;
        const double *m = bt->m + 3 * (size_t)t;
        double d[3][3], e1[3], e2[3], d1[3], d2[3], q[3], c0, c1, c2, r = INFINITY;
        if (bt->on[t] != 1)
            continue;
        for (int v = 0; v < 3; v++) {
            const int32_t f = L->freeidx[tri[v]];
            for (int k = 0; k < 3; k++)
                d[v][k] = f >= 0 ? dx[3 * (size_t)f + k] : 0.0;
        }
        sub3(x + 3 * (size_t)tri[1], x + 3 * (size_t)tri[0], e1);
        sub3(x + 3 * (size_t)tri[2], x + 3 * (size_t)tri[0], e2);
        sub3(d[1], d[0], d1);
        sub3(d[2], d[0], d2);
        cross3(e1, e2, q);
        c0 = dot3(q, m);
        cross3(d1, e2, q);
        c1 = dot3(q, m);
        cross3(e1, d2, q);
        c1 += dot3(q, m);
        cross3(d1, d2, q);
        c2 = dot3(q, m);
        if (fabs(c2) <= 1e-12 * fabs(c1)) {
            if (c1 < 0.0)
                r = -c0 / c1;
        } else {
            const double disc = c1 * c1 - 4.0 * c2 * c0;
            if (disc >= 0.0) {
                /* The roots, computed without cancellation. */
                const double qq = -0.5 * (c1 + (c1 >= 0.0 ? 1.0 : -1.0) * sqrt(disc));
                const double r1 = qq / c2, r2 = qq != 0.0 ? c0 / qq : INFINITY;
                if (r1 > 0.0)
                    r = r1;
                if (r2 > 0.0 && r2 < r)
                    r = r2;
            }
        }
        if (r < amax)
            amax = r;
    }
    return amax;
}

/* Newton switches to the exact Hessian after a full step that moved no
 * vertex by more than this fraction of the diagonal. */
#define EXACT_HESSIAN_STEP 1e-2

/* The smallest share theta of the Hessian's indefinite part that Newton
 * keeps (below it, none: the projected Hessian). */
#define THETA_MIN (1.0 / 64.0)

/* Steps at theta_cap before Newton tries twice as much again (see
 * newton). */
#define THETA_HOLD 4

/* Newton's energy test (see newton). */
#define FTOL 1e-10

typedef struct {
    int iterations;
    int factorizations; /* numeric factorisations, failed ones included */
    int converged;
    int failed; /* out of memory or the factorisation failed */
    double energy_start, energy;
} newton_result;

/* Factors A into L without CHOLMOD's own OpenMP teams (cholmod_util.h):
 * DTX_OK when L is a complete factor, DTX_ENOMEM or DTX_ESOLVE otherwise.
 * Newton retries and reports a failed frame itself, so no message. */
static dtx_status factorize(cholmod_sparse *A, cholmod_factor *L, cholmod_common *cc,
                            newton_result *res)
{
    res->factorizations++;
    return dtx__chol_factorize(A, DTX__CHOL_NO_TEAMS, "the springs Newton system", NULL, L, cc,
                               NULL);
}

/* Projected Newton with a backtracking line search on level L from lw->x
 * (see the file comment); fixed vertices stay.  free_translation: the
 * problem has no pins, so the steps' mean translation is removed. */
/* Removes from d (3 nfree, by unknown) its least-squares infinitesimal
 * rotation about the centroid of the free vertices of x: d_i -= w x p_i
 * with J w = sum p_i x d_i, J = sum |p_i|^2 I - p_i p_i^T. */
static void remove_rotation(const level *L, const double *x, double *d)
{
    double c[3] = {0, 0, 0}, J[9] = {0}, b[3] = {0, 0, 0}, w[3], det;
    if (L->nfree < 3)
        return;
    for (int32_t f = 0; f < L->nfree; f++)
        for (int k = 0; k < 3; k++)
            c[k] += x[3 * (size_t)L->freev[f] + k] / L->nfree;
    for (int32_t f = 0; f < L->nfree; f++) {
        double pv[3], q[3];
        sub3(x + 3 * (size_t)L->freev[f], c, pv);
        cross3(pv, d + 3 * (size_t)f, q);
        for (int a = 0; a < 3; a++) {
            b[a] += q[a];
            for (int k = 0; k < 3; k++)
                J[3 * a + k] += (a == k ? dot3(pv, pv) : 0.0) - pv[a] * pv[k];
        }
    }
    /* J^-1 b by the adjugate (J is the inertia tensor: positive definite
     * unless every vertex is on one line). */
    det = J[0] * (J[4] * J[8] - J[5] * J[7]) - J[1] * (J[3] * J[8] - J[5] * J[6]) +
          J[2] * (J[3] * J[7] - J[4] * J[6]);
    if (!(fabs(det) > 0.0))
        return;
    w[0] = ((J[4] * J[8] - J[5] * J[7]) * b[0] - (J[1] * J[8] - J[2] * J[7]) * b[1] +
            (J[1] * J[5] - J[2] * J[4]) * b[2]) /
           det;
    w[1] = (-(J[3] * J[8] - J[5] * J[6]) * b[0] + (J[0] * J[8] - J[2] * J[6]) * b[1] -
            (J[0] * J[5] - J[2] * J[3]) * b[2]) /
           det;
    w[2] = ((J[3] * J[7] - J[4] * J[6]) * b[0] - (J[0] * J[7] - J[1] * J[6]) * b[1] +
            (J[0] * J[4] - J[1] * J[3]) * b[2]) /
           det;
    for (int32_t f = 0; f < L->nfree; f++) {
        double pv[3], q[3];
        sub3(x + 3 * (size_t)L->freev[f], c, pv);
        cross3(w, pv, q);
        for (int k = 0; k < 3; k++)
            d[3 * (size_t)f + k] -= q[k];
    }
}

/* Makes the step in lw->X the Newton step restricted to the motions with
 * no rigid part: with C the 6 rigid motions of the free vertices about
 * their centroid (3 nfree x 6, columns) and Z = H^-1 C (H in lw->L), the
 * step d0 = -H^-1 g becomes d0 - Z (C^T Z)^-1 C^T d0, the minimiser of the
 * quadratic model under C^T d = 0.  Simply removing the rigid part of d0
 * would not do: the barrier couples the near-null turns of H to the
 * deformations, so d0's large turn carries deformation with it.  Returns 0
 * when a solve fails. */
static int rigid_free_step(const level *L, level_work *lw, cholmod_common *cc)
{
    const int32_t nf = L->nfree;
    double c[3] = {0, 0, 0}, M[6][7], lam[6], *C = lw->C->x, *d = lw->X->x;
    const double *Z;
    for (int32_t f = 0; f < nf; f++)
        for (int k = 0; k < 3; k++)
            c[k] += lw->x[3 * (size_t)L->freev[f] + k] / nf;
    memset(C, 0, 3 * (size_t)nf * 6 * sizeof *C);
    for (int32_t f = 0; f < nf; f++) {
        double pv[3];
        sub3(lw->x + 3 * (size_t)L->freev[f], c, pv);
        for (int k = 0; k < 3; k++) {
            double e[3] = {0, 0, 0}, r[3];
            e[k] = 1.0;
            C[(size_t)k * 3 * nf + 3 * (size_t)f + k] = 1.0;
            cross3(e, pv, r);
            for (int a = 0; a < 3; a++)
                C[(size_t)(3 + k) * 3 * nf + 3 * (size_t)f + a] = r[a];
        }
    }
    if (!cholmod_solve2(CHOLMOD_A, lw->L, lw->C, NULL, &lw->Z, NULL, &lw->ZY, &lw->ZE, cc))
        return 0;
    Z = lw->Z->x;
    /* M = [C^T Z | C^T d0], solved by Gaussian elimination with partial
     * pivoting (C^T Z is symmetric positive definite). */
    for (int a = 0; a < 6; a++) {
        for (int b = 0; b < 6; b++) {
            double sum = 0.0;
            for (size_t i = 0; i < 3 * (size_t)nf; i++)
                sum += C[(size_t)a * 3 * nf + i] * Z[(size_t)b * 3 * nf + i];
            M[a][b] = sum;
        }
        M[a][6] = 0.0;
        for (size_t i = 0; i < 3 * (size_t)nf; i++)
            M[a][6] += C[(size_t)a * 3 * nf + i] * d[i];
    }
    for (int col = 0; col < 6; col++) {
        int piv = col;
        for (int r = col + 1; r < 6; r++)
            if (fabs(M[r][col]) > fabs(M[piv][col]))
                piv = r;
        if (!(fabs(M[piv][col]) > 0.0))
            return 1; /* degenerate: keep d0 */
        if (piv != col)
            for (int k = 0; k < 7; k++) {
                double t = M[col][k];
                M[col][k] = M[piv][k];
                M[piv][k] = t;
            }
        for (int r = col + 1; r < 6; r++) {
            const double fct = M[r][col] / M[col][col];
            for (int k = col; k < 7; k++)
                M[r][k] -= fct * M[col][k];
        }
    }
    for (int r = 5; r >= 0; r--) {
        double sum = M[r][6];
        for (int k = r + 1; k < 6; k++)
            sum -= M[r][k] * lam[k];
        lam[r] = sum / M[r][r];
    }
    for (int b = 0; b < 6; b++)
        for (size_t i = 0; i < 3 * (size_t)nf; i++)
            d[i] -= Z[(size_t)b * 3 * nf + i] * lam[b];
    return 1;
}

/* Moves every triangle under the unfolding penalty that has reached
 * UNFOLD_JOIN h_t into the barrier; returns how many did. */
static int unfold_join(const barrier_terms *bt, const double *x)
{
    int joined = 0;
    for (int32_t t = 0; t < bt->nt; t++)
        if (bt->on[t] == 2 &&
            oriented_area(x, bt->F + 3 * (size_t)t, bt->m + 3 * (size_t)t, NULL) / bt->area[t] >=
                UNFOLD_JOIN * bt->shat[t]) {
            bt->on[t] = 1;
            joined++;
        }
    return joined;
}

static double total_energy(const level *L, const level_work *lw, const barrier_terms *bt,
                           const double *x)
{
    double e = bt ? barrier_energy(bt, x) : 0.0;
    return isinf(e) ? e : e + spring_energy(L, lw->rtil, x);
}

static void assemble_all(const level *L, const level_work *lw, const barrier_terms *bt,
                         const double *x, double theta)
{
    assemble(L, lw->rtil, x, theta, lw->g, lw->Hx);
    if (bt)
        assemble_barrier(L, bt, x, theta, lw->g, lw->Hx);
}

static void newton(const level *L, level_work *lw, const barrier_terms *bt, cholmod_common *cc,
                   int max_iter, double tol, int free_translation, newton_result *res)
{
    const size_t n3 = 3 * (size_t)L->nfree;
    double e = total_energy(L, lw, bt, lw->x);
    double theta = 0.0; /* share of the indefinite part of the Hessian kept */
    /* The most of it to try: half a share that failed to factor, raised
     * again after THETA_HOLD steps there (near a degenerate minimum the
     * exact Hessian fails step after step, and each failure costs up to
     * three factorisations). */
    double theta_cap = 1.0;
    int at_cap = 0;
    cholmod_sparse A;

    res->iterations = 0;
    res->factorizations = 0;
    res->converged = 0;
    res->failed = 0;
    res->energy_start = e;
    res->energy = e;
    if (L->nfree == 0) {
        res->converged = 1;
        return;
    }
    hessian_view(L, lw->Hx, &A);

    while (res->iterations < max_iter) {
        double gmax = 0.0, dmax2 = 0.0, slope = 0.0, alpha = 1.0, et = e;
        const double *dx;
        double *b = lw->B->x;
        dtx_status fst;
        int accepted = 0;
        assemble_all(L, lw, bt, lw->x, theta);
        for (size_t i = 0; i < n3; i++)
            gmax = fmax(gmax, fabs(lw->g[i]));
        if (gmax == 0.0) {
            res->converged = 1;
            break;
        }
        fst = factorize(&A, lw->L, cc, res);
        if (fst == DTX_ESOLVE && theta > 0.0 && bt) {
            /* With the barrier the solve leaves the turns out, and where the
             * barrier pushes, the exact Hessian is slightly negative along
             * them (the torque it exerts): a small shift of the diagonal
             * (1e-6, then 1e-4 of its mean), which the turns' removal makes
             * harmless, keeps the exact steps. */
            double added = 0.0;
            for (double sh = 1e-6; sh < 1e-3 && fst == DTX_ESOLVE; sh *= 100.0) {
                const double d = sh * 2.0 * L->kmean - added;
                for (int32_t f = 0; f < L->nfree; f++)
                    for (int c = 0; c < 3; c++)
                        lw->Hx[L->colp[3 * f + c + 1] - 1] += d;
                added += d;
                fst = factorize(&A, lw->L, cc, res);
            }
        }
        if (fst == DTX_ESOLVE && theta > 0.0) {
            theta_cap = theta > THETA_MIN ? 0.5 * theta : THETA_MIN;
            at_cap = 0;
        }
        while (fst == DTX_ESOLVE && theta > 0.0) {
            /* Not positive definite with this much of the indefinite part:
             * less of it, down to the projected Hessian. */
            theta = theta > THETA_MIN ? 0.25 * theta : 0.0;
            assemble_all(L, lw, bt, lw->x, theta);
            fst = factorize(&A, lw->L, cc, res);
        }
        /* The projected H + mu I is positive definite in exact arithmetic;
         * should rounding say otherwise, a larger mu is tried. */
        for (int attempt = 1; attempt < 4 && fst == DTX_ESOLVE; attempt++) {
            for (int32_t f = 0; f < L->nfree; f++)
                for (int c = 0; c < 3; c++)
                    lw->Hx[L->colp[3 * f + c + 1] - 1] += 100.0 * L->mu * attempt;
            fst = factorize(&A, lw->L, cc, res);
        }
        /* A barrier term that has grown huge can defeat that: shifts of
         * 1e-4 and 1e-1 of the mean diagonal (a shorter, still descending
         * step). */
        for (double sh = 1e-4; bt && sh < 1.0 && fst == DTX_ESOLVE; sh *= 1000.0) {
            for (int32_t f = 0; f < L->nfree; f++)
                for (int c = 0; c < 3; c++)
                    lw->Hx[L->colp[3 * f + c + 1] - 1] += sh * 2.0 * L->kmean;
            fst = factorize(&A, lw->L, cc, res);
        }
        if (fst == DTX_ESOLVE && bt) {
            /* Rounding in a barrier term that has grown huge: the iterate
             * is a valid shape with every triangle of the barrier right side
             * up, so it is kept (not converged). */
            break;
        }
        if (fst != DTX_OK) {
            res->failed = 1;
            return;
        }
        if (bt && free_translation)
            /* The solve is over shapes placed as the start: the gradient's
             * turning part (the barrier's torque) is left out too, so that
             * the step stays a descent direction. */
            remove_rotation(L, lw->x, lw->g);
        for (size_t i = 0; i < n3; i++)
            b[i] = -lw->g[i];
        if (!cholmod_solve2(CHOLMOD_A, lw->L, lw->B, NULL, &lw->X, NULL, &lw->Y, &lw->E, cc)) {
            res->failed = 1;
            return;
        }
        res->iterations++;
        dx = lw->X->x;
        if (free_translation) {
            /* Remove the step's mean translation (in place in X). */
            double m[3] = {0, 0, 0};
            double *d = lw->X->x;
            for (int32_t f = 0; f < L->nfree; f++)
                for (int c = 0; c < 3; c++)
                    m[c] += d[3 * (size_t)f + c];
            for (int32_t f = 0; f < L->nfree; f++)
                for (int c = 0; c < 3; c++)
                    d[3 * (size_t)f + c] -= m[c] / L->nfree;
            /* With the barrier, whose normals are fixed in space, the
             * energy is no longer invariant under rotations, yet H is
             * nearly singular along them: the barrier's small torque would
             * give a huge turn, which the line search then cuts short.  The
             * orientation is the start's: the turn is removed (the solve is
             * over shapes, placed as the start). */
            if (bt && !rigid_free_step(L, lw, cc)) {
                res->failed = 1;
                return;
            }
        }
        for (int32_t f = 0; f < L->nfree; f++) {
            const double *d = dx + 3 * (size_t)f;
            dmax2 = fmax(dmax2, dot3(d, d));
        }
        if (!isfinite(dmax2))
            break; /* as a failed factorisation: the iterate is kept */
        for (size_t i = 0; i < n3; i++)
            slope += lw->g[i] * dx[i];
        if (!(slope < 0.0)) {
            /* No descent left at this precision. */
            res->converged = sqrt(dmax2) <= tol * L->diag;
            break;
        }
        if (bt) {
            /* Start the search short of the first fold. */
            const double amax = barrier_max_step(L, bt, lw->x, dx);
            if (amax <= 1.0)
                alpha = 0.9 * amax;
        }
        for (int ls = 0; ls < 60; ls++) {
            memcpy(lw->xt, lw->x, (size_t)L->n * 3 * sizeof *lw->xt);
            for (int32_t f = 0; f < L->nfree; f++) {
                const int32_t v = L->freev[f];
                for (int c = 0; c < 3; c++)
                    lw->xt[3 * (size_t)v + c] += alpha * dx[3 * (size_t)f + c];
            }
            et = total_energy(L, lw, bt, lw->xt);
            if (et < e && et <= e + 1e-4 * alpha * slope) {
                accepted = 1;
                break;
            }
            alpha *= 0.5;
        }
        if (!accepted) {
            /* The line search stalled: rounding is all that is left when
             * the step is small. */
            res->converged = sqrt(dmax2) <= tol * L->diag;
            break;
        }
        memcpy(lw->x, lw->xt, (size_t)L->n * 3 * sizeof *lw->x);
        if (bt && unfold_join(bt, lw->x)) {
            /* A triangle folded at the start is right side up: it joins the
             * barrier, which changes the energy (up: the barrier is not
             * zero until h_t). */
            e = total_energy(L, lw, bt, lw->x);
            theta = 0.0;
            continue;
        }
        /* Near the minimum the exact Hessian is positive definite and gives
         * quadratic convergence where the projected one converges only
         * linearly (when springs stay compressed at the equilibrium): it is
         * used once full steps are taken and small, and dropped again when
         * it needs a shorter step or is not positive definite. */
        if (alpha == 1.0 && sqrt(dmax2) <= EXACT_HESSIAN_STEP * L->diag) {
            if (theta >= theta_cap && ++at_cap >= THETA_HOLD) {
                theta_cap = fmin(1.0, 2.0 * theta_cap);
                at_cap = 0;
            }
            theta = theta > 0.0 ? fmin(theta_cap, 2.0 * theta) : THETA_MIN;
        } else if (alpha < 0.5)
            theta = theta > THETA_MIN ? 0.25 * theta : 0.0;
        /* Converged when the step is below tol, or when a full Newton step
         * lowered the energy by less than a relative FTOL (the energy test
         * of L-BFGS-B, whose default is 2.2e-9): where the minimum is
         * degenerate (springs that can turn freely about a compressed
         * neighbour) Newton converges only linearly and its steps shrink
         * slowly while the energy no longer changes. */
        if (sqrt(dmax2) <= tol * L->diag || (alpha == 1.0 && e - et <= FTOL * fabs(et))) {
            e = et;
            res->converged = 1;
            break;
        }
        e = et;
    }
    res->energy = e;
}

/* ------------------------------------------------------------------ */
/* Apply                                                               */
/* ------------------------------------------------------------------ */

static int init_worker(void *plan, void *workspace)
{
    dtx_springs_plan *p = plan;
    worker *k = workspace;
    dtx__chol_start(&k->cc, DTX__CHOL_AUTO, DTX__CHOL_ORDER_DEFAULT);
    k->rot = dtx_alloc((size_t)p->max_level_n, 9 * sizeof *k->rot, 0);
    k->tm = dtx_alloc((size_t)p->nf_s, 3 * sizeof *k->tm, 0);
    k->tsh = dtx_alloc((size_t)p->nf_s, sizeof *k->tsh, 0);
    k->on = dtx_alloc((size_t)p->nf_s, 1, 0);
    if (!k->rot || !k->tm || !k->tsh || !k->on)
        return 0;
    for (int l = 0; l < p->nlev; l++) {
        const level *L = &p->lev[l];
        level_work *lw = &k->lw[l];
        lw->x = dtx_alloc((size_t)L->n, 3 * sizeof *lw->x, 1);
        lw->xt = dtx_alloc((size_t)L->n, 3 * sizeof *lw->xt, 1);
        lw->g = dtx_alloc((size_t)L->nfree, 3 * sizeof *lw->g, 0);
        lw->Hx = dtx_alloc((size_t)L->nnz, sizeof *lw->Hx, 0);
        lw->rtil = dtx_alloc((size_t)L->springs.n, sizeof *lw->rtil, 0);
        if (!lw->x || !lw->xt || !lw->g || !lw->Hx || !lw->rtil)
            return 0;
        if (L->nfree > 0) {
            lw->L = cholmod_copy_factor(L->L, &k->cc);
            lw->B = cholmod_zeros(3 * (size_t)L->nfree, 1, CHOLMOD_REAL, &k->cc);
            if (!lw->L || !lw->B)
                return 0;
            if (l == 0 && p->barrier) {
                lw->C = cholmod_zeros(3 * (size_t)L->nfree, 6, CHOLMOD_REAL, &k->cc);
                if (!lw->C)
                    return 0;
            }
        }
    }
    return 1;
}

/* The coarsest level's start: its rest shape turned by Rs about its rest
 * centroid. */
static void rigid_start(const level *L, const double *Rs, double *x)
{
    for (int32_t v = 0; v < L->n; v++) {
        double q[3];
        sub3(L->rest + 3 * (size_t)v, L->rest_centroid, q);
        mat_vec(Rs, q, x + 3 * (size_t)v);
        for (int c = 0; c < 3; c++)
            x[3 * (size_t)v + c] += L->rest_centroid[c];
    }
}

/* Per vertex of level L, the rotation that best maps its edge neighbourhood
 * in the source rest shape onto the source frame xs (Rs for a vertex
 * without edges). */
static void source_rotations(const dtx_springs_plan *p, const level *L, const double *xs,
                             const double *Rs, double *rot)
{
    for (int32_t v = 0; v < L->n; v++) {
        double S[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
        const int32_t fv = L->fine[v];
        if (L->adjp[v] == L->adjp[v + 1]) {
            memcpy(rot + 9 * (size_t)v, Rs, 9 * sizeof *rot);
            continue;
        }
        for (int32_t a = L->adjp[v]; a < L->adjp[v + 1]; a++) {
            const int32_t fn = L->fine[L->adj[a]];
            double pr[3], py[3];
            sub3(p->Vs + 3 * (size_t)fn, p->Vs + 3 * (size_t)fv, pr);
            sub3(xs + 3 * (size_t)fn, xs + 3 * (size_t)fv, py);
            add_outer(S, pr, py);
        }
        rotation_fit(S, rot + 9 * (size_t)v);
    }
}

/* The linear start of a level: with x0 the rigid start in lw->x, minimises
 *     sum_e k_e |x_i - x_j - d_e|^2 + mu |x - x0|^2 [+ w sum_c |x_rep(c) - xc_c|^2],
 *     d_e = (r~_e / r_T,e) (R_i + R_j)/2 (t_i - t_j)
 * over the free vertices (t: rest positions, R: the source's local
 * rotations at the ends): every spring turned like the source around it and
 * stretched by its ratio, in the least-squares sense.  With a coarser level
 * C, the bracketed term anchors each of its representatives to where C's
 * solution xc has it, with w = kmean (as stiff as a vertex's springs
 * together): the start takes C's large-scale shape, and the springs fill in
 * the detail smoothly (the anchors are soft, so no kink is imposed).  One
 * factorisation with the level's pattern (the blocks are multiples of I).
 * Returns 0 when the factorisation fails. */
static int linear_start(const level *L, level_work *lw, const double *rot, const level *C,
                        const double *xc, cholmod_common *cc)
{
    double *b, *x = lw->x;
    const double *sol;
    cholmod_sparse A;
    if (L->nfree == 0)
        return 1;
    b = lw->B->x;
    memset(lw->Hx, 0, (size_t)L->nnz * sizeof *lw->Hx);
    for (int32_t f = 0; f < L->nfree; f++)
        for (int c = 0; c < 3; c++) {
            lw->Hx[L->colp[3 * f + c + 1] - 1] = L->mu;
            b[3 * (size_t)f + c] = L->mu * x[3 * (size_t)L->freev[f] + c];
        }
    if (C) {
        /* Anchors: each representative of the coarser level pulled to where
         * the coarser solution has it, as stiff as its springs together. */
        const double wa = L->kmean;
        for (int32_t c = 0; c < C->n; c++) {
            const int32_t f = L->freeidx[C->rep[c]];
            if (f < 0)
                continue;
            for (int k = 0; k < 3; k++) {
                lw->Hx[L->colp[3 * f + k + 1] - 1] += wa;
                b[3 * (size_t)f + k] += wa * xc[3 * (size_t)c + k];
            }
        }
    }
    for (int32_t s = 0; s < L->springs.n; s++) {
        const int32_t i = L->springs.ends[2 * (size_t)s], j = L->springs.ends[2 * (size_t)s + 1];
        const int32_t fi = L->freeidx[i], fj = L->freeidx[j];
        const double k = L->k[s], rho = lw->rtil[s] / L->rt[s];
        double t[3], d[3], d2[3];
        sub3(L->rest + 3 * (size_t)i, L->rest + 3 * (size_t)j, t);
        mat_vec(rot + 9 * (size_t)i, t, d);
        mat_vec(rot + 9 * (size_t)j, t, d2);
        for (int c = 0; c < 3; c++)
            d[c] = 0.5 * rho * (d[c] + d2[c]);
        if (fi >= 0) {
            for (int c = 0; c < 3; c++) {
                lw->Hx[L->colp[3 * fi + c + 1] - 1] += k;
                b[3 * (size_t)fi + c] += k * (d[c] + (fj < 0 ? x[3 * (size_t)j + c] : 0.0));
            }
        }
        if (fj >= 0) {
            for (int c = 0; c < 3; c++) {
                lw->Hx[L->colp[3 * fj + c + 1] - 1] += k;
                b[3 * (size_t)fj + c] += k * (-d[c] + (fi < 0 ? x[3 * (size_t)i + c] : 0.0));
            }
        }
        if (fi >= 0 && fj >= 0) {
            const int32_t *op = L->offpos + 3 * (size_t)s;
            for (int c = 0; c < 3; c++)
                lw->Hx[op[c] + c] -= k;
        }
    }
    hessian_view(L, lw->Hx, &A);
    if (dtx__chol_factorize(&A, DTX__CHOL_NO_TEAMS, "the springs linear start", NULL, lw->L, cc,
                            NULL) != DTX_OK ||
        !cholmod_solve2(CHOLMOD_A, lw->L, lw->B, NULL, &lw->X, NULL, &lw->Y, &lw->E, cc))
        return 0;
    sol = lw->X->x;
    for (int32_t f = 0; f < L->nfree; f++)
        for (int c = 0; c < 3; c++)
            x[3 * (size_t)L->freev[f] + c] = sol[3 * (size_t)f + c];
    return 1;
}

/* Shepard weight of a coarse representative at rest distance^2 d2 from a
 * fine vertex (h2: a small regulariser, so the representative's own vertex
 * takes its transform exactly). */
static inline double shepard_weight(double d2, double h2)
{
    double w = 1.0 / (d2 + h2);
    return w * w;
}

/* REST start of level F from the solution xc of the next coarser level C:
 * each coarse vertex gets the rotation that best fits its coarse edge
 * neighbourhood (rest -> xc), and each fine vertex the blend of the rigid
 * transforms of its cluster and of the cluster's edge neighbours, weighted
 * by shepard_weight of its rest distance to their representatives (so that
 * vertices on either side of a cluster boundary move alike); vertices in no
 * cluster keep the rigid start. */
static void prolongate(const level *F, const level *C, const double *xc, const double *Rs,
                       double *rot, double *x)
{
    const double h2 = 1e-6 * C->diag * C->diag;
    for (int32_t c = 0; c < C->n; c++) {
        double S[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
        const double *rc = C->rest + 3 * (size_t)c, *yc = xc + 3 * (size_t)c;
        if (C->adjp[c] == C->adjp[c + 1]) {
            memcpy(rot + 9 * (size_t)c, Rs, 9 * sizeof *rot);
            continue;
        }
        for (int32_t a = C->adjp[c]; a < C->adjp[c + 1]; a++) {
            const int32_t nb = C->adj[a];
            double pr[3], py[3];
            sub3(C->rest + 3 * (size_t)nb, rc, pr);
            sub3(xc + 3 * (size_t)nb, yc, py);
            add_outer(S, pr, py);
        }
        rotation_fit(S, rot + 9 * (size_t)c);
    }
    rigid_start(F, Rs, x);
    for (int32_t v = 0; v < F->n; v++) {
        const int32_t c = F->parent[v];
        const double *rv = F->rest + 3 * (size_t)v;
        double acc[3] = {0, 0, 0}, wsum = 0.0;
        if (c < 0)
            continue;
        /* a = adjp[c] - 1 stands for the cluster itself. */
        for (int32_t a = C->adjp[c] - 1; a < C->adjp[c + 1]; a++) {
            const int32_t b = a < C->adjp[c] ? c : C->adj[a];
            double q[3], y[3], wgt;
            sub3(rv, C->rest + 3 * (size_t)b, q);
            wgt = shepard_weight(dot3(q, q), h2);
            mat_vec(rot + 9 * (size_t)b, q, y);
            for (int k = 0; k < 3; k++)
                acc[k] += wgt * (y[k] + xc[3 * (size_t)b + k]);
            wsum += wgt;
        }
        for (int k = 0; k < 3; k++)
            x[3 * (size_t)v + k] = acc[k] / wsum;
    }
}

/* Pins: the start is fitted rigidly onto the pins (translated onto their
 * centroid when fewer than 3 or collinear), then the pinned vertices are
 * set. */
static void place_on_pins(const dtx_springs_plan *p, const level *L, double *x)
{
    double cx[3] = {0, 0, 0}, cp[3] = {0, 0, 0}, S[9] = {0}, R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    const int32_t n = p->npins;
    for (int32_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            cx[k] += x[3 * (size_t)p->pins[i] + k] / n;
            cp[k] += p->pin_pos[3 * (size_t)i + k] / n;
        }
    if (n >= 3) {
        /* Collinear pins leave a rotation free: keep the start's then. */
        double C[4][4] = {{0}}, V[4][4], ev[3];
        for (int32_t i = 0; i < n; i++) {
            double a[3], b[3];
            sub3(x + 3 * (size_t)p->pins[i], cx, a);
            sub3(p->pin_pos + 3 * (size_t)i, cp, b);
            add_outer(S, a, b);
            for (int r = 0; r < 3; r++)
                for (int c = 0; c < 3; c++)
                    C[r][c] += b[r] * b[c];
        }
        jacobi_eigen(3, C, V);
        for (int k = 0; k < 3; k++)
            ev[k] = C[k][k];
        {
            double hi = fmax(ev[0], fmax(ev[1], ev[2])), lo = fmin(ev[0], fmin(ev[1], ev[2]));
            double mid = ev[0] + ev[1] + ev[2] - hi - lo;
            if (mid > 1e-12 * hi)
                rotation_fit(S, R);
        }
    }
    for (int32_t v = 0; v < L->n; v++) {
        double q[3];
        sub3(x + 3 * (size_t)v, cx, q);
        mat_vec(R, q, x + 3 * (size_t)v);
        for (int k = 0; k < 3; k++)
            x[3 * (size_t)v + k] += cp[k];
    }
    for (int32_t i = 0; i < n; i++)
        memcpy(x + 3 * (size_t)p->pins[i], p->pin_pos + 3 * (size_t)i, 3 * sizeof *x);
}

/* Each target vertex from the solved proxy x: its barycentric point plus
 * its offset in the solved triangle's orthonormal frame. */
static void carry_to_target(const dtx_springs_plan *p, const double *x, double *y)
{
    for (int32_t t = 0; t < p->nv_t; t++) {
        const int32_t *tri = p->Fs + 3 * (size_t)p->bind_tri[t];
        const double *b = p->bind_bary + 3 * (size_t)t, *o = p->bind_off + 3 * (size_t)t;
        const double *xa = x + 3 * (size_t)tri[0], *xb = x + 3 * (size_t)tri[1],
                     *xc = x + 3 * (size_t)tri[2];
        double Fr[9];
        triangle_frame(xa, xb, xc, Fr);
        for (int k = 0; k < 3; k++)
            y[3 * (size_t)t + k] = b[0] * xa[k] + b[1] * xb[k] + b[2] * xc[k] + o[0] * Fr[k] +
                                   o[1] * Fr[3 + k] + o[2] * Fr[6 + k];
    }
}

/* The rotation that best maps y (the target vertices in tused, centroid
 * cy) onto Rs applied to the target rest shape. */
static void fit_to_guide(const dtx_springs_plan *p, const double *y, const double *cy,
                         const double *Rs, double *Q)
{
    double S[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
    for (int32_t t = 0; t < p->nv_t; t++) {
        double a[3], r[3], b[3];
        if (!p->tused[t])
            continue;
        sub3(y + 3 * (size_t)t, cy, a);
        sub3(p->Vt + 3 * (size_t)t, p->tgt_centroid_used, r);
        mat_vec(Rs, r, b);
        add_outer(S, a, b);
    }
    rotation_fit(S, Q);
}

/* Counts the inverted target triangles of y (see springs.h); Qc turns y's
 * normals into the source's orientation. */
static void count_inverted(const dtx_springs_plan *p, const double *xs, const double *y,
                           const double *Qc, dtx_springs_frame_info *info)
{
    info->inverted = 0;
    info->first_inverted = -1;
    for (int32_t t = 0; t < p->nf_t; t++) {
        const int32_t *tri = p->Ft + 3 * (size_t)t;
        const int32_t d = p->drive[t];
        const int32_t *st = p->Fs + 3 * (size_t)d;
        const double *n0 = p->tnormal + 3 * (size_t)t, *Fr = p->sframe + 9 * (size_t)d;
        double Fd[9], rn[3], expect[3], e1[3], e2[3], n[3], nq[3];
        if (!(dot3(n0, n0) > 0.0) || !(dot3(Fr + 6, Fr + 6) > 0.0))
            continue;
        if (!triangle_frame(xs + 3 * (size_t)st[0], xs + 3 * (size_t)st[1], xs + 3 * (size_t)st[2],
                            Fd))
            continue;
        /* expect = Fd^T Fr n0: the rest normal in the source triangle's rest
         * frame, re-expressed in its deformed frame. */
        mat_vec(Fr, n0, rn);
        for (int k = 0; k < 3; k++)
            expect[k] = Fd[k] * rn[0] + Fd[3 + k] * rn[1] + Fd[6 + k] * rn[2];
        sub3(y + 3 * (size_t)tri[1], y + 3 * (size_t)tri[0], e1);
        sub3(y + 3 * (size_t)tri[2], y + 3 * (size_t)tri[0], e2);
        cross3(e1, e2, n);
        mat_vec(Qc, n, nq);
        if (!(dot3(nq, expect) > 0.0)) {
            if (info->inverted == 0)
                info->first_inverted = t;
            info->inverted++;
        }
    }
}

int32_t dtx_springs_count_inverted(const dtx_springs_plan *p, const double *xs, const double *y)
{
    const double Q[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    dtx_springs_frame_info fi;
    count_inverted(p, xs, y, Q, &fi);
    return fi.inverted;
}

/* The frame's barrier (see assemble_barrier): every solve-mesh triangle
 * whose rest and source triangles are not degenerate, in the barrier when
 * the fine start x0 has it right side up, under the unfolding penalty when
 * x0 has it folded; returns how many x0 has folded. */
static int32_t frame_barrier(const dtx_springs_plan *p, worker *w, const double *xs,
                             const double *x0, barrier_terms *bt)
{
    int32_t skipped = 0;
    bt->nt = p->nf_s;
    bt->F = p->Fs;
    bt->sp = p->tri_sp;
    bt->area = p->tri_area;
    bt->kappa = p->tri_kappa;
    bt->m = w->tm;
    bt->shat = w->tsh;
    bt->on = w->on;
    for (int32_t t = 0; t < p->nf_s; t++) {
        const int32_t *st = p->Fs + 3 * (size_t)t;
        const double *Fr = p->sframe + 9 * (size_t)t, *n0 = p->tri_n0 + 3 * (size_t)t;
        double Fd[9], rn[3], *m = w->tm + 3 * (size_t)t;
        w->on[t] = 0;
        if (!(p->tri_area[t] > 0.0) || !(dot3(Fr + 6, Fr + 6) > 0.0) ||
            !triangle_frame(xs + 3 * (size_t)st[0], xs + 3 * (size_t)st[1], xs + 3 * (size_t)st[2],
                            Fd))
            continue;
        /* m = Fd^T Fr n0, as count_inverted's expected normal. */
        mat_vec(Fr, n0, rn);
        for (int k = 0; k < 3; k++)
            m[k] = Fd[k] * rn[0] + Fd[3 + k] * rn[1] + Fd[6 + k] * rn[2];
        {
            /* A tenth of the source triangle's own area ratio (at most
             * 1), so that T = S, where every s_t is the source's, never
             * meets the barrier. */
            double e1[3], e2[3], n[3], r0[3], r1[3], r2[3], ratio;
            const double *V = p->Vs;
            sub3(xs + 3 * (size_t)st[1], xs + 3 * (size_t)st[0], e1);
            sub3(xs + 3 * (size_t)st[2], xs + 3 * (size_t)st[0], e2);
            cross3(e1, e2, n);
            sub3(V + 3 * (size_t)st[1], V + 3 * (size_t)st[0], r0);
            sub3(V + 3 * (size_t)st[2], V + 3 * (size_t)st[0], r1);
            cross3(r0, r1, r2);
            ratio = sqrt(dot3(n, n) / dot3(r2, r2));
            w->tsh[t] = BARRIER_SHAT * fmin(1.0, ratio);
        }
        if (!(oriented_area(x0, st, m, NULL) > 0.0)) {
            skipped++;
            w->on[t] = 2;
            continue;
        }
        w->on[t] = 1;
    }
    return skipped;
}

/* The source's overall rotation Rs in frame xs (rest to frame). */
static void source_rotation(const dtx_springs_plan *p, const double *xs, double *Rs)
{
    double cs[3], S[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
    centroid_of(xs, p->nv_s, p->sused, cs);
    for (int32_t v = 0; v < p->nv_s; v++) {
        double a[3], b[3];
        if (!p->sused[v])
            continue;
        sub3(p->Vs + 3 * (size_t)v, p->src_centroid_used, a);
        sub3(xs + 3 * (size_t)v, cs, b);
        add_outer(S, a, b);
    }
    rotation_fit(S, Rs);
}

static void place_frame(const dtx_springs_plan *p, const double *xs, const double *Rs, double *y,
                        dtx_springs_frame_info *fi);

/* One frame: xs (nv_s x 3) to y (nv_t x 3), or, with xsol (the carry of
 * dtx_springs_apply), only the solution on the solve mesh into xsol
 * (nv_s x 3; NaN for a failed frame), which the caller carries and
 * places. */
static void solve_frame(const dtx_springs_plan *p, worker *w, const double *xs, const double *x0,
                        double *xsol, double *y, dtx_springs_frame_info *info)
{
    double Rs[9], num = 0.0;
    const int pinned = p->npins > 0;
    newton_result nr;
    int coarse_it = 0;
    dtx_springs_frame_info fi;
    barrier_terms bt;

    memset(&fi, 0, sizeof fi);
    memset(&nr, 0, sizeof nr);
    fi.first_inverted = -1;
    for (int64_t i = 0; i < 3 * (int64_t)p->nv_s; i++)
        if (!isfinite(xs[i]))
            goto nan;

    /* ---- The source's global rotation. ---- */
    source_rotation(p, xs, Rs);

    /* ---- The frame's rest lengths on every level. ---- */
    for (int l = 0; l < p->nlev; l++) {
        const level *L = &p->lev[l];
        double *rtil = w->lw[l].rtil;
        for (int32_t s = 0; s < L->springs.n; s++) {
            double q[3];
            sub3(xs + 3 * (size_t)L->fine[L->springs.ends[2 * (size_t)s]],
                 xs + 3 * (size_t)L->fine[L->springs.ends[2 * (size_t)s + 1]], q);
            rtil[s] = L->rt[s] * (sqrt(dot3(q, q)) / L->rs[s]);
        }
    }

    /* ---- Coarse to fine. ---- */
    for (int l = p->nlev - 1; l >= 0; l--) {
        const level *L = &p->lev[l];
        level_work *lw = &w->lw[l];
        const int coarsest = l == p->nlev - 1;
        if (p->start == DTX_SPRINGS_START_SP04) {
            /* One level; sp04 holds the pins already. */
            for (int64_t i = 0; i < 3 * (int64_t)L->n; i++)
                if (!isfinite(x0[i]))
                    goto nan;
            memcpy(lw->x, x0, (size_t)L->n * 3 * sizeof *lw->x);
        } else if (p->start == DTX_SPRINGS_START_LINEAR) {
            rigid_start(L, Rs, lw->x);
            if (l == 0 && pinned)
                place_on_pins(p, L, lw->x);
            source_rotations(p, L, xs, Rs, w->rot);
            if (!linear_start(L, lw, w->rot, coarsest ? NULL : &p->lev[l + 1],
                              coarsest ? NULL : w->lw[l + 1].x, &w->cc))
                goto nan;
        } else {
            if (coarsest)
                rigid_start(L, Rs, lw->x);
            else
                prolongate(L, &p->lev[l + 1], w->lw[l + 1].x, Rs, w->rot, lw->x);
            if (l == 0 && pinned)
                place_on_pins(p, L, lw->x);
        }
        if (l > 0) {
            newton(L, lw, NULL, &w->cc, p->coarse_max_iter, p->coarse_tol, 1, &nr);
            coarse_it += nr.iterations;
        } else {
            if (p->barrier)
                fi.barrier_skipped = frame_barrier(p, w, xs, lw->x, &bt);
            newton(L, lw, p->barrier ? &bt : NULL, &w->cc, p->max_iter, p->tol, !pinned, &nr);
        }
        if (nr.failed)
            goto nan;
    }
    fi.iterations = nr.iterations;
    fi.factorizations = nr.factorizations;
    fi.coarse_iterations = coarse_it;
    fi.converged = nr.converged;
    fi.energy_start = nr.energy_start;
    fi.energy = nr.energy;
    for (int32_t s = 0; s < p->lev[0].springs.n; s++)
        num += p->lev[0].k[s] * w->lw[0].rtil[s] * w->lw[0].rtil[s];
    fi.residual =
        num > 0.0 ? sqrt(spring_energy(&p->lev[0], w->lw[0].rtil, w->lw[0].x) / num) : 0.0;
    {
        /* The final gradient (the Hessian's values are not used). */
        const level *L0 = &p->lev[0];
        double g2 = 0.0;
        assemble_all(L0, &w->lw[0], p->barrier ? &bt : NULL, w->lw[0].x, 0);
        if (!pinned) {
            /* Its part along the rigid motions, which the solve leaves out
             * (the barrier's torque), is not counted. */
            double m[3] = {0, 0, 0};
            double *g = w->lw[0].g;
            for (int32_t f = 0; f < L0->nfree; f++)
                for (int c = 0; c < 3; c++)
                    m[c] += g[3 * (size_t)f + c] / L0->nfree;
            for (int32_t f = 0; f < L0->nfree; f++)
                for (int c = 0; c < 3; c++)
                    g[3 * (size_t)f + c] -= m[c];
            remove_rotation(L0, w->lw[0].x, g);
        }
        for (size_t i = 0; i < 3 * (size_t)L0->nfree; i++)
            g2 += w->lw[0].g[i] * w->lw[0].g[i];
        fi.grad_norm = sqrt(g2);
    }

    /* ---- To the target's vertices, placed. ---- */
    if (xsol) {
        memcpy(xsol, w->lw[0].x, (size_t)p->nv_s * 3 * sizeof *xsol);
        if (info)
            *info = fi;
        return;
    }
    if (p->proxy)
        carry_to_target(p, w->lw[0].x, y);
    else
        memcpy(y, w->lw[0].x, (size_t)p->nv_t * 3 * sizeof *y);
    place_frame(p, xs, Rs, y, &fi);
    if (info)
        *info = fi;
    return;

nan:
    if (xsol)
        for (int64_t i = 0; i < 3 * (int64_t)p->nv_s; i++)
            xsol[i] = NAN;
    else
        for (int64_t i = 0; i < 3 * (int64_t)p->nv_t; i++)
            y[i] = NAN;
    fi.energy = fi.energy_start = fi.residual = fi.grad_norm = NAN;
    fi.converged = 0;
    if (info)
        *info = fi;
}

/* Counts the inverted triangles of y (nv_t x 3, the solve's frame) into
 * fi and places y (see springs.h). */
static void place_frame(const dtx_springs_plan *p, const double *xs, const double *Rs, double *y,
                        dtx_springs_frame_info *fi)
{
    const int pinned = p->npins > 0;
    {
        double cy[3], Q[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, want[3], c[3];
        /* Inversions are counted in the solve's frame, where the source's
         * rotations (and the barrier's normals) are expressed. */
        count_inverted(p, xs, y, Q, fi);
        centroid_of(y, p->nv_t, p->tused, cy);
        /* The sp04 start has sp04's orientation, which Newton keeps (its
         * steps have no rotational part): no turn then. */
        if (p->start != DTX_SPRINGS_START_SP04)
            fit_to_guide(p, y, cy, Rs, Q);
        if (!pinned) {
            for (int32_t t = 0; t < p->nv_t; t++) {
                double a[3];
                if (!p->tused[t])
                    continue;
                sub3(y + 3 * (size_t)t, cy, a);
                mat_vec(Q, a, y + 3 * (size_t)t);
                for (int k = 0; k < 3; k++)
                    y[3 * (size_t)t + k] += cy[k];
            }
        }
        for (int32_t t = 0; t < p->nv_t; t++) {
            double a[3];
            if (p->tused[t])
                continue;
            sub3(p->Vt + 3 * (size_t)t, p->tgt_centroid_used, a);
            mat_vec(Rs, a, y + 3 * (size_t)t);
            for (int k = 0; k < 3; k++)
                y[3 * (size_t)t + k] += cy[k];
        }
        if (!pinned) {
            double cs_all[3];
            centroid_of(xs, p->nv_s, NULL, cs_all);
            centroid_of(y, p->nv_t, NULL, c);
            for (int k = 0; k < 3; k++)
                want[k] =
                    p->tgt_centroid_all[k] + (p->anchor == DTX_ANCHOR_FOLLOW
                                                  ? p->scale * (cs_all[k] - p->src_centroid_all[k])
                                                  : 0.0);
            for (int32_t t = 0; t < p->nv_t; t++)
                for (int k = 0; k < 3; k++)
                    y[3 * (size_t)t + k] += want[k] - c[k];
        }
    }
}

dtx_status dtx_springs_apply(dtx_springs_plan *p, int64_t nframes, const double *Xs, double *Xt,
                             dtx_springs_frame_info *info, dtx_error *err)
{
    dtx_status st = dtx__workers_ensure(&p->workers, sizeof(worker), p, init_worker, fini_worker,
                                        "the springs workspaces", err);
    if (st != DTX_OK)
        return st;
    if ((p->sp04 || p->carry) && nframes > 0) {
        if (nframes > p->starts_cap) {
            double *s = dtx_alloc((size_t)nframes, 3 * (size_t)p->nv_s * sizeof *s, 0);
            if (!s)
                return dtx_seterr(err, DTX_ENOMEM, "out of memory for the springs starts");
            free(p->starts);
            p->starts = s;
            p->starts_cap = nframes;
        }
    }
    if (p->sp04 && nframes > 0) {
        /* The starts of all the frames in one sp04 apply (whose results do
         * not depend on how frames are split into calls or threads). */
        st = dtx_sp04_apply(p->sp04, nframes, Xs, p->starts, NULL, err);
        if (st != DTX_OK)
            return st;
    }
#pragma omp parallel for schedule(dynamic, 1)
    for (int64_t f = 0; f < nframes; f++) {
        int t = 0;
        double *xf = p->starts ? p->starts + (size_t)f * 3 * p->nv_s : NULL;
#ifdef _OPENMP
        t = omp_get_thread_num();
#endif
        /* With the carry, each solution overwrites its start. */
        solve_frame(p, dtx__worker(&p->workers, t), Xs + (size_t)f * 3 * p->nv_s,
                    p->sp04 ? xf : NULL, p->carry ? xf : NULL, Xt + (size_t)f * 3 * p->nv_t,
                    info ? info + f : NULL);
    }
    if (p->carry && nframes > 0) {
        /* All the solutions to the target in one sp04 apply, then each
         * frame placed. */
        st = dtx_sp04_apply(p->carry, nframes, p->starts, Xt, NULL, err);
        if (st != DTX_OK)
            return st;
#pragma omp parallel for schedule(dynamic, 1)
        for (int64_t f = 0; f < nframes; f++) {
            const double *xs = Xs + (size_t)f * 3 * p->nv_s;
            double *y = Xt + (size_t)f * 3 * p->nv_t, Rs[9];
            dtx_springs_frame_info fi;
            int finite = 1;
            for (int64_t i = 0; i < 3 * (int64_t)p->nv_t && finite; i++)
                finite = isfinite(y[i]);
            if (!finite) {
                for (int64_t i = 0; i < 3 * (int64_t)p->nv_t; i++)
                    y[i] = NAN;
                continue;
            }
            if (info)
                fi = info[f];
            source_rotation(p, xs, Rs);
            place_frame(p, xs, Rs, y, &fi);
            if (info) {
                info[f].inverted = fi.inverted;
                info[f].first_inverted = fi.first_inverted;
            }
        }
    }
    return DTX_OK;
}

/* ------------------------------------------------------------------ */
/* The method table (transfer.h)                                       */
/* ------------------------------------------------------------------ */

/* The table's plan: the springs plan and the last apply's figures. */
typedef struct {
    dtx_springs_plan *plan;
    void *info; /* info_cap dtx_springs_frame_info */
    int64_t info_cap;
} springs_method_plan;

static void springs_method_free(void **plan)
{
    springs_method_plan *p = *plan;
    if (!p)
        return;
    dtx_springs_plan_free(&p->plan);
    free(p->info);
    free(p);
    *plan = NULL;
}

static dtx_status springs_method_create(const dtx_transfer_inputs *in,
                                        const dtx_transfer_params *prm, void **plan, dtx_error *err)
{
    springs_method_plan *p = dtx_alloc(1, sizeof *p, 1);
    dtx_status st;
    *plan = NULL;
    if (!p)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory");
    st = dtx_springs_plan_create(in->src, in->tgt, in->proxy, &prm->u.springs, in->anchor, in->pins,
                                 in->pin_pos, in->npins, &p->plan, err);
    *plan = p;
    if (st != DTX_OK)
        springs_method_free(plan);
    return st;
}

static dtx_status springs_method_apply(void *plan, int64_t nframes, const double *Xs, double *Xt,
                                       dtx_frame_info *info, dtx_error *err)
{
    springs_method_plan *p = plan;
    const dtx_springs_frame_info *si;
    dtx_status st = dtx_transfer_scratch(&p->info, &p->info_cap, nframes, sizeof *si, err);
    si = p->info;
    if (st == DTX_OK)
        st = dtx_springs_apply(p->plan, nframes, Xs, Xt, p->info, err);
    for (int64_t i = 0; st == DTX_OK && i < nframes; i++) {
        info[i].residual = si[i].residual;
        info[i].iterations = si[i].iterations;
        info[i].converged = si[i].converged;
        info[i].inverted = si[i].inverted;
        info[i].grad_norm = si[i].grad_norm;
    }
    return st;
}

static void springs_method_describe(const void *plan, char *buf, size_t size)
{
    const springs_method_plan *p = plan;
    dtx_springs_info info;
    int n;
    dtx_springs_plan_info(p->plan, &info);
    n = snprintf(buf, size,
                 "%d edge, %d bending and %d internal springs%s; %d levels (%d vertices on the "
                 "coarsest); factor %lld entries; %.2f s",
                 (int)info.springs[DTX_SPRING_EDGE], (int)info.springs[DTX_SPRING_BENDING],
                 (int)info.springs[DTX_SPRING_INTERNAL], info.proxy ? " on the proxy" : "",
                 info.levels, (int)info.level_vertices[info.levels - 1], (long long)info.factor_nnz,
                 info.setup_seconds);
    if (info.proxy && n >= 0 && (size_t)n < size)
        snprintf(buf + n, size - (size_t)n,
                 "\nits vertices lie %.3g%% of its diagonal (RMS) from the proxy",
                 100 * info.proxy_rms);
}

/* The job file's "springs" object (transfer.h); damping is not one. */
static const char *const springs_starts[] = {"linear", "rest", "sp04", NULL};
static const dtx_setting springs_settings[] = {
    {"barrier", DTX_SETTING_BOOL, offsetof(dtx_springs_params, barrier), NULL},
    {"bending", DTX_SETTING_BOOL, offsetof(dtx_springs_params, bending), NULL},
    {"coarse_max_iter", DTX_SETTING_INT, offsetof(dtx_springs_params, coarse_max_iter), NULL},
    {"coarse_min", DTX_SETTING_INT, offsetof(dtx_springs_params, coarse_min), NULL},
    {"coarse_tol", DTX_SETTING_DOUBLE, offsetof(dtx_springs_params, coarse_tol), NULL},
    {"internal", DTX_SETTING_BOOL, offsetof(dtx_springs_params, internal), NULL},
    {"levels", DTX_SETTING_INT, offsetof(dtx_springs_params, levels), NULL},
    {"max_iter", DTX_SETTING_INT, offsetof(dtx_springs_params, max_iter), NULL},
    {"start", DTX_SETTING_CHOICE, offsetof(dtx_springs_params, start), springs_starts},
    {"tol", DTX_SETTING_DOUBLE, offsetof(dtx_springs_params, tol), NULL},
};

const dtx_transfer_method dtx_method_springs = {
    .name = "springs",
    .kind = DTX_TRANSFER_SPRINGS,
    .iterative = 1,
    .solve_group = 1,
    .correspondence = DTX_TRANSFER_CORR_SP04,
    .uses_proxy = 1,
    .solver_name = "Newton",
    .counts_inverted = 1,
    .reports_grad_norm = 1,
    .settings = springs_settings,
    .nsettings = (int)(sizeof springs_settings / sizeof *springs_settings),
    .plan_create = springs_method_create,
    .apply = springs_method_apply,
    .plan_free = springs_method_free,
    .describe = springs_method_describe,
};
