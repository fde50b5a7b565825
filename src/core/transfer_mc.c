/*
 * transfer_mc.c: deformation transfer onto targets made of several
 * components (Zhou, Xu, Tong & Desbrun 2010, section 2.3).  For deformed
 * target vertices x (vertex-only gradients, T_t = sum_j x_j g_tj^T, as in
 * transfer_sp04.c) the energy
 *
 *     E = w1 E1 + w2 E2 + w3 E3 + w4 E4
 *     E1 = sum over pairs (s, t)         || S_s - T_t ||^2      matched gradients
 *     E2 = sum over orphan triangles t_i,
 *          t_j in the one-ring of t_i    || T_ti - T_tj ||^2    orphan smoothness
 *     E3 = sum over proximity pairs (i, j)  c_ij (|x_i - x_j| - l_ij)^2
 *     E4 = sum over vertices of orphan components
 *                                        | L x - dhat(x) |^2 / h^2
 *
 * is minimised (paper: w1 = w2 = w4 = 1, w3 = 0.1; dtx: w3 = 3 with E3 in
 * relative lengths, see below).  An orphan triangle is a target triangle in
 * no pair; an orphan component one with no paired triangle; the one-ring of
 * a triangle is every triangle sharing a vertex with it; L is the uniform
 * Laplacian of the component and dhat(x) = L x
 * |L v| / |L x| keeps the rest Laplacian coordinates' lengths (Huang et al.
 * 2006).  Lengths in E4 are divided by h, the target's bounding-box
 * diagonal, so that the weights mean the same at any model scale (E1 and E2
 * are scale-free).
 *
 * E3's pair weights c_ij.  The paper's E3 is absolute, with w3 = 0.1 at its
 * models' (unstated) scale.  DTX_MC_LENGTHS_DIAGONAL is that with lengths in
 * units of h: c_ij = 1 / h^2.  It holds the pieces too loosely: on the lion
 * shattered into 240 pebbles the cracks between them open and close by a
 * median 9-12% of their width, since a crack is a few hundredths of h and
 * its change weighs nothing against E1.  DTX_MC_LENGTHS_RELATIVE (the
 * default) measures the relative change, c_ij = 1 / (l_ij^2 n_ij), with l_ij
 * floored at a tenth of the mean edge (pieces that touch) and n_ij the mean
 * number of pairs at i and at j.  E3 is then scale-free like E1, and a vertex
 * carries about one unit of E3 weight whether it has 2 pairs (a pebble's
 * crack) or 40 (a shirt over a body), so that eps_factor and the mesh
 * resolution change where the pieces are tied, not how strongly.  With w3 =
 * 3 the pebble lion's cracks change by a median 1-4% per pose, its vertices
 * stay within 1.3% of the diagonal (RMS) of sp04's unbroken lion, and a
 * shirt stays on a body within 1.8% of it.
 *
 * Gauss-Newton with the usual linearisation: in iteration k, E3's pairs
 * aim at l_ij d_ij and E4's rows at dhat, with the directions d_ij = (x_i -
 * x_j) / |x_i - x_j| and dhat taken from the previous iterate (for the
 * first: the rest directions of the pairs turned by the source gradients at
 * their ends, and the rest Laplacian coordinates).  Each iteration is then
 * a linear least-squares problem whose matrix
 *     A = w1 sum G_t^T G_t + w2 sum (G_ti - G_tj)^T (G_ti - G_tj)
 *       + w3 sum c_ij (e_i - e_j)(e_i - e_j)^T + w4/h^2 sum L^T L
 * does not depend on the iterate or the frame: it is factored once (CHOLMOD,
 * simplicial L D L^T, so that no BLAS runs inside the OpenMP loop), and an
 * iteration is one back-substitution with 3 right-hand sides.  Without E3
 * and E4 terms (one component, every triangle paired) one solve is exact,
 * and the result is sp04's.
 *
 * The iterations are a fixed-point iteration x <- G(x) (G(x): the solve
 * with the directions of x), which only ever lowers E: each step minimises
 * a quadratic that bounds E from above and equals it at x.  It converges
 * slowly where the components can slide against each other, so it is
 * accelerated (Anderson, type II, over the last MC_AA_DEPTH steps) and
 * safeguarded: an accelerated iterate is kept only if it lowers E, else the
 * plain step is taken and the history dropped.  A frame stops when the
 * step G(x) - x moves no vertex by more than tol x the target diagonal (the
 * result is then G(x)), or after max_iter solves.
 *
 * Newton (DTX_MC_SOLVER_NEWTON).  The fixed-point iteration is slow
 * because A holds every proximity pair isotropically, w3 c_ij I, while E's
 * second derivative across the pair direction d is w3 c_ij (1 - l_ij / |x_i
 * - x_j|): a pair that keeps its length holds its ends only along d, and A
 * makes every motion of a boundary vertex across d (a piece sliding along
 * its neighbour) far stiffer than it is.  The Newton solver takes the same
 * first iterate, then steps on the model E(x + dx) ~ E(x) - 2 r.dx + dx.H dx,
 * where r = -grad E / 2 = b(x) - A x comes for free (b(x) the fixed-point
 * right-hand side with the directions of x) and H, half E's Hessian, is A
 * less, per pair, w3 c_ij (l_ij / |x_i - x_j|) (I - d d^T) on the pair's
 * difference (the same for E4's rows, with |L v| and L x).  H is
 * indefinite where pairs are compressed (|x_i - x_j| < l_ij).  Each step
 * minimises the model in a trust region, |dx|_A <= delta in A's norm, by
 * Steihaug-Toint conjugate gradients preconditioned with A's factor from dx
 * = 0 (the first direction is the fixed-point step): until the residual in
 * A^-1's norm has fallen by MC_CG_ETA or after MC_CG_MAX products, or to
 * the boundary along a direction of negative curvature or one that would
 * leave the region (the preconditioner, and so the region's norm, is A's
 * factor rounded to single precision: precond_solve; the first iterate's
 * solve is exact).  The step stands when E falls by more than MC_TR_ACCEPT
 * of the model's decrease; delta shrinks to a quarter of the step when E
 * fell by less than a quarter of it and doubles after a step to the
 * boundary that E followed to 3/4; a rejected step is halved up to
 * MC_TR_BACKTRACK times (energy evaluations only), keeping the first half
 * that lowers E.
 *
 * Why a trust region (measured on the cat -> pebble lion, relative
 * lengths, with dtx_bench_mc): the pairs across its cracks are as short
 * as the cracks are wide (0.4% of the diagonal), and a piece sliding by a
 * fraction of that turns them, so a quadratic model of E holds only within
 * a fraction of a crack width, while from the first iterate the pieces
 * slide by several; and compressed pairs make H indefinite: the conjugate
 * gradients of the line-search Newton solver this one replaces met
 * negative curvature in most steps, stopped there, and its line search cut
 * most steps by 4 to 64 (0 of 9 frames converged within 30 steps);
 * in the trust region all 9 converge in 44-86 steps (about 700-1200
 * back-substitutions), the last few quadratically, and the shirt within
 * 11.
 * Where the time goes (pebble camel, 750 stones, 288,042 pairs, one frame
 * at 1 thread, counted in the code): 40 steps, 34 of them to the region's
 * boundary with 1-13 conjugate-gradient products each, the last 5 inside
 * it with 9-26 (101 of the frame's 227); 233 back-substitutions, about 2/3
 * of the time, and 227 Hessian products, about 1/4 (a third of that in
 * the product with A).  The steps are many because the energy is quartic,
 * not quadratic, in a piece sliding along its neighbour while its pairs
 * keep their length ((sqrt(l^2 + s^2) - l)^2 ~ s^4 / 4 l^2) and its pairs
 * turn: a quadratic model holds only a short way along it.  Hence each
 * back-substitution is made cheaper
 * (precond_solve: A's factor in single precision, 1.4x; the pairs' share
 * of H once per step, hess_prepare) rather than fewer.  Tried, and no
 * fewer products: a coarse correction with one translation per component
 * (A^-1 + Z C^-1 Z^T, C = Z^T H Z with compressed pairs capped; the last
 * steps took 22-40 products instead of 9-26); dropping L's entries below
 * 1e-3 (scaled by D) from the preconditioner (half of them: 735 products
 * instead of 232); stretching an accepted step 2, 3 or 4.5 times along dx
 * (never lowered E); and shrinking the radius by 1/2 instead of 1/4, or
 * growing it by 1.5 instead of 2 (within the frames' spread).
 * Tried before, and no faster: moving whole pieces by Newton steps in their
 * translations between steps (E1, E2, E4 do not change); 20 or 60
 * accelerated fixed-point iterations before the Newton steps (0.78 and
 * 0.83 s CPU a frame against 0.71 s); a looser conjugate-gradient
 * tolerance far from the minimiser (Eisenstat-Walker), 20 or 80 products
 * a step at most, and other radius factors (the steps are as many).
 *
 * A frame has converged when a Newton step inside the region (conjugate
 * gradients to MC_CG_ETA), an estimate of the distance to the minimiser,
 * moves no vertex by more than tol x the target diagonal.  Where E is
 * flatter than quadratic (a piece moved off its neighbours' surface
 * stretches their pairs only to second order, so E is quartic in it) the
 * Newton step is a third of that distance or more.  max_iter (default
 * DTX_MC_MAX_ITER_NEWTON) counts the first solve and the Newton steps,
 * taken or not.
 *
 * Every frame is solved by one thread with its own workspace, in a fixed
 * order, so its result does not depend on the thread count or on how the
 * sequence is split.  (Solving several frames' right-hand sides in one
 * sweep over the factor was tried: with 4 frames a sweep took 4 times as
 * long as one frame's, the rows of the frames' values being too many for
 * the caches, and a hand-written sweep was slower than cholmod_solve2.)
 *
 * The global translation is fixed as in sp04: pinned vertices, or one
 * anchor vertex solved at 0 and the frame shifted afterwards so that its
 * centroid is the rest centroid (or follows the source's centroid).  Every
 * frame starts from the rest pose.
 */
#include "cholmod_util.h"
#include "dtx_core.h"
#include "plan_util.h"
#include "proximity.h"
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

void dtx_mc_params_default(dtx_mc_params *p)
{
    memset(p, 0, sizeof *p);
    p->w_match = 1.0;
    p->w_orphan = 1.0;
    p->w_proximity = 3.0;
    p->lengths = DTX_MC_LENGTHS_RELATIVE;
    p->w_laplacian = 1.0;
    p->eps_factor = 1.5;
    p->max_iter = 0; /* the solver's */
    p->tol = 1e-6;
    p->solver = DTX_MC_SOLVER_FIXED_POINT;
}

/* Anderson acceleration: the number of past steps combined. */
#define MC_AA_DEPTH 5

/* ------------------------------------------------------------------ */
/* Plan                                                                */
/* ------------------------------------------------------------------ */

/* One frame in progress.  Vectors over the free unknowns are nfree x 3,
 * column-major (coordinate c of free unknown i at c * nfree + i). */
typedef struct {
    const double *Xs;        /* the frame's source positions */
    double *Xt;              /* where its result goes */
    double *residual;        /* NULL or where its residual goes */
    dtx_mc_frame_info *info; /* NULL or where its solver figures go */
    int it;                  /* solves done */
    int nh, head, have_last; /* Anderson history: count, next slot, fl/gl valid */
    double e_cur;            /* energy of the current iterate */
    double *S;               /* nf_s x 9: the frame's source gradients */
    double *Sp;              /* npairs x 9: each pair's source gradient projected onto
                                the target triangle's plane (E1's target) */
    double *b1;              /* frame part of the right-hand side */
    double *b;               /* the right-hand side of the next solve (the worker's B) */
    const double *g;         /* the last solve's result (the worker's X) */
    double *x;               /* nv_t x 3: current iterate (anchored) */
    double *lx;              /* nlap x 3: L x of the current iterate */
    double *xf;              /* the current iterate */
    double *fl, *gl;         /* the last step G(x) - x and its G(x) */
    double *df, *dg;         /* MC_AA_DEPTH vectors each: differences of successive f, g */
    double gram[MC_AA_DEPTH * MC_AA_DEPTH]; /* df_i . df_j */
} mc_frame;

typedef struct {
    cholmod_common cc;
    cholmod_dense *B, *X, *Y, *E; /* cholmod_solve2's right-hand side, result, workspace */
    cholmod_dense *P, *HP;        /* Newton: a conjugate direction and H times it */
    double *mt;                   /* Newton: nfree x 3 (row-major), precond_solve's vector */
    double *hq;                   /* Newton: prox.npairs x 4, hess_prepare's d and c */
    mc_frame fr;                  /* the frame in progress */
} mc_worker;

struct dtx_mc_plan {
    int32_t nv_s, nf_s, nv_t, nf_t;
    int32_t *Fs, *Ft;      /* copies of the faces */
    double *Vt;            /* nv_t x 3 target rest positions */
    double *Vinv;          /* nf_s x 9 source rest-frame inverses */
    double *G;             /* nf_t x 9 target gradient operator */
    double *N;             /* nf_t x 3 target unit normals */
    int64_t npairs;
    int32_t *pairs;        /* npairs x 2 (source, target triangle) */
    int64_t nsmooth;
    int32_t *smooth;       /* nsmooth x 2 (orphan triangle, one-ring triangle) */
    dtx_proximity prox;
    int32_t *prox_src;     /* prox.npairs x 2: a source triangle paired with a target
                              triangle at i (at j), or -1: rotates the first iterate */
    int32_t nlap;          /* Laplacian rows (vertices of orphan components) */
    int32_t *lap_vertex;   /* nlap */
    int64_t *lap_ptr;      /* nlap + 1 */
    int32_t *lap_col;      /* lap_ptr[nlap]: vertex of each coefficient */
    double *lap_coef;
    double *lap_mag;       /* nlap: |L v| at rest */
    double *lap_rest;      /* nlap x 3: L v at rest */
    double w1, w2, w3, w4; /* w4 divided by h^2 */
    double *w3p;           /* prox.npairs: w3 c_ij, E3's weight of pair ij */
    int max_iter;
    double tol_abs;
    int nonlinear;         /* E3 or E4 present */

    int32_t nfree;
    int32_t *freeidx;      /* nv_t: free index or -1 */
    double *fixedval;      /* nv_t x 3: pins at their positions, anchor at 0 */
    double *bconst;        /* nfree x 3 (column-major): pins' share of the rhs */
    int32_t nunref;
    unsigned char *used;   /* nv_t: vertex in a face */
    double rest_centroid_ref[3], rest_centroid_t[3], rest_centroid_s[3], scale;
    dtx_anchor anchor;
    int32_t npins;

    cholmod_common cc;
    cholmod_factor *L;
    cholmod_sparse *A;     /* Newton: the matrix (lower triangle) for H's products */
    /* Newton's preconditioner, L D L' = A(perm, perm) with L's entries
     * rounded to single precision (see precond_solve): column j of L below
     * the diagonal is mrow/mval[mptr[j] .. mptr[j + 1]); mdinv: 1 / D. */
    int64_t *mptr;
    int32_t *mrow, *mperm;
    float *mval;
    double *mdinv;
    double factor_seconds;
    dtx_mc_info info;

    dtx__workers workers; /* an mc_worker per thread */
};

static void fini_worker(void *plan, void *workspace)
{
    mc_worker *k = workspace;
    mc_frame *fr = &k->fr;
    cholmod_free_dense(&k->B, &k->cc);
    cholmod_free_dense(&k->X, &k->cc);
    cholmod_free_dense(&k->Y, &k->cc);
    cholmod_free_dense(&k->E, &k->cc);
    cholmod_free_dense(&k->P, &k->cc);
    cholmod_free_dense(&k->HP, &k->cc);
    free(k->mt);
    free(k->hq);
    cholmod_finish(&k->cc);
    free(fr->S);
    free(fr->Sp);
    free(fr->b1);
    free(fr->x);
    free(fr->lx);
    free(fr->xf);
    free(fr->fl);
    free(fr->gl);
    free(fr->df);
    free(fr->dg);
}

void dtx_mc_plan_free(dtx_mc_plan **pp)
{
    dtx_mc_plan *p;
    if (!pp || !*pp)
        return;
    p = *pp;
    dtx__workers_free(&p->workers, p, fini_worker);
    cholmod_free_factor(&p->L, &p->cc);
    cholmod_free_sparse(&p->A, &p->cc);
    cholmod_finish(&p->cc);
    free(p->mptr);
    free(p->mrow);
    free(p->mperm);
    free(p->mval);
    free(p->mdinv);
    dtx_proximity_free(&p->prox);
    free(p->prox_src);
    free(p->w3p);
    free(p->Fs);
    free(p->Ft);
    free(p->Vt);
    free(p->Vinv);
    free(p->G);
    free(p->N);
    free(p->pairs);
    free(p->smooth);
    free(p->lap_vertex);
    free(p->lap_ptr);
    free(p->lap_col);
    free(p->lap_coef);
    free(p->lap_mag);
    free(p->lap_rest);
    free(p->freeidx);
    free(p->fixedval);
    free(p->bconst);
    free(p->used);
    free(p);
    *pp = NULL;
}

/* ------------------------------------------------------------------ */
/* Assembly                                                            */
/* ------------------------------------------------------------------ */

/* Lower-triangle triplets of the free-free block, grown as needed. */
typedef struct {
    int64_t n, cap;
    int32_t *i, *j;
    double *x;
} coo;

static int coo_push(coo *c, int32_t i, int32_t j, double x)
{
    if (c->n == c->cap) {
        int64_t ncap = c->cap ? 2 * c->cap : 1 << 16;
        int32_t *ni = realloc(c->i, (size_t)ncap * sizeof *ni);
        int32_t *nj;
        double *nx;
        if (!ni)
            return 0;
        c->i = ni;
        nj = realloc(c->j, (size_t)ncap * sizeof *nj);
        if (!nj)
            return 0;
        c->j = nj;
        nx = realloc(c->x, (size_t)ncap * sizeof *nx);
        if (!nx)
            return 0;
        c->x = nx;
        c->cap = ncap;
    }
    c->i[c->n] = i;
    c->j[c->n] = j;
    c->x[c->n] = x;
    c->n++;
    return 1;
}

/* A term w sum_c |sum_p x_{var_p, c} a_p - t_c|^2 (3-vector coefficients
 * a_p; scalar terms use (a, 0, 0)).  Its matrix goes to the triplets and
 * the fixed unknowns' share of the right-hand side to bconst; the targets
 * t_c are the frame's business. */
typedef struct {
    int n;
    int32_t var[16];
    double a[16][3];
} term;

static void term_add(term *t, int32_t var, const double *a, double sign)
{
    for (int i = 0; i < t->n; i++)
        if (t->var[i] == var) {
            for (int k = 0; k < 3; k++)
                t->a[i][k] += sign * a[k];
            return;
        }
    t->var[t->n] = var;
    for (int k = 0; k < 3; k++)
        t->a[t->n][k] = sign * a[k];
    t->n++;
}

static void term_triangle(term *t, const dtx_mc_plan *p, int32_t f, double sign)
{
    for (int j = 0; j < 3; j++)
        term_add(t, p->Ft[3 * f + j], p->G + 9 * (size_t)f + 3 * j, sign);
}

static int emit(const dtx_mc_plan *p, coo *c, const term *t, double w)
{
    for (int a = 0; a < t->n; a++) {
        int32_t fa = p->freeidx[t->var[a]];
        if (fa < 0)
            continue;
        for (int b = 0; b < t->n; b++) {
            int32_t fb = p->freeidx[t->var[b]];
            double v = w * dot3(t->a[a], t->a[b]);
            if (fb < 0) {
                for (int k = 0; k < 3; k++)
                    p->bconst[(size_t)k * p->nfree + fa] -=
                        v * p->fixedval[3 * (size_t)t->var[b] + k];
            } else if (fb <= fa) {
                if (!coo_push(c, fa, fb, v))
                    return 0;
            }
        }
    }
    return 1;
}

/* Orphan triangles' one-ring pairs (t_i orphan, t_j sharing a vertex). */
static dtx_status build_smooth(dtx_mc_plan *p, const unsigned char *paired, dtx_error *err)
{
    const int32_t nv = p->nv_t, nf = p->nf_t;
    int64_t *vptr = dtx_alloc((size_t)nv + 1, sizeof *vptr, 1);
    int32_t *vfaces = dtx_alloc((size_t)nf, 3 * sizeof *vfaces, 0);
    int32_t *mark = dtx_alloc((size_t)nf, sizeof *mark, 0);
    int64_t n = 0, cap = 0;
    dtx_status st = DTX_OK;
    if (!vptr || !vfaces || !mark)
        goto nomem;
    for (int64_t i = 0; i < 3 * (int64_t)nf; i++)
        vptr[p->Ft[i] + 1]++;
    for (int32_t v = 0; v < nv; v++)
        vptr[v + 1] += vptr[v];
    {
        int64_t *fill = dtx_alloc((size_t)nv, sizeof *fill, 0);
        if (!fill)
            goto nomem;
        memcpy(fill, vptr, (size_t)nv * sizeof *fill);
        for (int32_t f = 0; f < nf; f++)
            for (int k = 0; k < 3; k++)
                vfaces[fill[p->Ft[3 * f + k]]++] = f;
        free(fill);
    }
    for (int32_t f = 0; f < nf; f++)
        mark[f] = -1;
    for (int32_t f = 0; f < nf; f++) {
        if (paired[f])
            continue;
        mark[f] = f;
        /* Faces around each vertex are in increasing order: the one-ring
         * is visited vertex by vertex, each face once. */
        for (int k = 0; k < 3; k++) {
            int32_t v = p->Ft[3 * f + k];
            for (int64_t q = vptr[v]; q < vptr[v + 1]; q++) {
                int32_t g = vfaces[q];
                if (mark[g] == f)
                    continue;
                mark[g] = f;
                if (n == cap) {
                    int64_t ncap = cap ? 2 * cap : 1024;
                    int32_t *ns = realloc(p->smooth, (size_t)ncap * 2 * sizeof *ns);
                    if (!ns)
                        goto nomem;
                    p->smooth = ns;
                    cap = ncap;
                }
                p->smooth[2 * n] = f;
                p->smooth[2 * n + 1] = g;
                n++;
            }
        }
    }
    p->nsmooth = n;
    goto done;
nomem:
    st = dtx_seterr(err, DTX_ENOMEM, "out of memory building the orphan-triangle terms");
done:
    free(vptr);
    free(vfaces);
    free(mark);
    return st;
}

typedef struct {
    int32_t a, b;
} vpair;

static int cmp_vpair(const void *x, const void *y)
{
    const vpair *p = x, *q = y;
    if (p->a != q->a)
        return p->a < q->a ? -1 : 1;
    return (p->b > q->b) - (p->b < q->b);
}

/* Uniform Laplacian rows of the vertices of orphan components. */
static dtx_status build_laplacian(dtx_mc_plan *p, const unsigned char *orphan_comp,
                                  dtx_error *err)
{
    const int32_t nf = p->nf_t;
    const int32_t *comp = p->prox.comp;
    vpair *e = dtx_alloc((size_t)nf, 6 * sizeof *e, 0);
    int64_t ne = 0, w = 0;
    int32_t *rowof = NULL;
    dtx_status st = DTX_OK;
    if (!e)
        goto nomem;
    for (int32_t f = 0; f < nf; f++) {
        int32_t c = comp[p->Ft[3 * f]];
        if (c < 0 || !orphan_comp[c])
            continue;
        for (int k = 0; k < 3; k++) {
            int32_t a = p->Ft[3 * f + k], b = p->Ft[3 * f + (k + 1) % 3];
            e[ne].a = a;
            e[ne++].b = b;
            e[ne].a = b;
            e[ne++].b = a;
        }
    }
    qsort(e, (size_t)ne, sizeof *e, cmp_vpair);
    for (int64_t i = 0; i < ne; i++)
        if (w == 0 || e[i].a != e[w - 1].a || e[i].b != e[w - 1].b)
            e[w++] = e[i];
    ne = w;
    /* Rows: one per distinct vertex a, coefficients 1 on a and -1/deg on
     * its neighbours. */
    p->nlap = 0;
    for (int64_t i = 0; i < ne; i++)
        if (i == 0 || e[i].a != e[i - 1].a)
            p->nlap++;
    p->lap_vertex = dtx_alloc((size_t)p->nlap, sizeof *p->lap_vertex, 0);
    p->lap_ptr = dtx_alloc((size_t)p->nlap + 1, sizeof *p->lap_ptr, 0);
    p->lap_col = dtx_alloc((size_t)(ne + p->nlap), sizeof *p->lap_col, 0);
    p->lap_coef = dtx_alloc((size_t)(ne + p->nlap), sizeof *p->lap_coef, 0);
    p->lap_mag = dtx_alloc((size_t)p->nlap, sizeof *p->lap_mag, 0);
    p->lap_rest = dtx_alloc((size_t)p->nlap, 3 * sizeof *p->lap_rest, 0);
    if (!p->lap_vertex || !p->lap_ptr || !p->lap_col || !p->lap_coef || !p->lap_mag ||
        !p->lap_rest)
        goto nomem;
    {
        int32_t r = 0;
        int64_t k = 0;
        for (int64_t i = 0; i < ne;) {
            int64_t j = i;
            while (j < ne && e[j].a == e[i].a)
                j++;
            p->lap_vertex[r] = e[i].a;
            p->lap_ptr[r] = k;
            p->lap_col[k] = e[i].a;
            p->lap_coef[k++] = 1.0;
            for (int64_t q = i; q < j; q++) {
                p->lap_col[k] = e[q].b;
                p->lap_coef[k++] = -1.0 / (double)(j - i);
            }
            r++;
            i = j;
        }
        p->lap_ptr[r] = k;
    }
    for (int32_t r = 0; r < p->nlap; r++) {
        double d[3] = {0, 0, 0};
        for (int64_t q = p->lap_ptr[r]; q < p->lap_ptr[r + 1]; q++)
            for (int c = 0; c < 3; c++)
                d[c] += p->lap_coef[q] * p->Vt[3 * (size_t)p->lap_col[q] + c];
        memcpy(p->lap_rest + 3 * (size_t)r, d, sizeof d);
        p->lap_mag[r] = sqrt(dot3(d, d));
    }
    goto done;
nomem:
    st = dtx_seterr(err, DTX_ENOMEM, "out of memory building the Laplacian terms");
done:
    free(e);
    free(rowof);
    return st;
}

/* E3's weight of each proximity pair, p->w3p[i] = w3 c_i (see the top of
 * the file); h is the target's bounding-box diagonal. */
static dtx_status pair_weights(dtx_mc_plan *p, const dtx_mesh *tgt, const dtx_mc_params *prm,
                               double h, dtx_error *err)
{
    const int64_t np = p->prox.npairs;
    double floor_len = 0.1 * dtx_mesh_mean_edge(tgt);
    int32_t *count = NULL;
    p->w3p = dtx_alloc((size_t)(np > 0 ? np : 1), sizeof *p->w3p, 0);
    if (!p->w3p)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory (proximity-pair weights)");
    if (prm->lengths == DTX_MC_LENGTHS_DIAGONAL) {
        for (int64_t i = 0; i < np; i++)
            p->w3p[i] = p->w3 / (h * h);
        return DTX_OK;
    }
    count = dtx_alloc((size_t)tgt->nv, sizeof *count, 1);
    if (!count)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory (proximity-pair weights)");
    for (int64_t i = 0; i < 2 * np; i++)
        count[p->prox.pairs[i]]++;
    if (!(floor_len > 0.0))
        floor_len = 1e-3 * h;
    for (int64_t i = 0; i < np; i++) {
        double l = p->prox.rest_len[i] > floor_len ? p->prox.rest_len[i] : floor_len;
        double n = 0.5 * (count[p->prox.pairs[2 * i]] + count[p->prox.pairs[2 * i + 1]]);
        p->w3p[i] = p->w3 / (l * l * n);
    }
    free(count);
    return DTX_OK;
}

/* For each proximity pair, a source triangle deforming each end's
 * neighbourhood: the first pair of the lowest paired target triangle
 * around the vertex. */
static dtx_status build_prox_src(dtx_mc_plan *p, dtx_error *err)
{
    int32_t *tsrc = dtx_alloc((size_t)p->nf_t, sizeof *tsrc, 0);
    int32_t *vsrc = dtx_alloc((size_t)p->nv_t, sizeof *vsrc, 0);
    p->prox_src = dtx_alloc((size_t)p->prox.npairs, 2 * sizeof *p->prox_src, 0);
    if (!tsrc || !vsrc || !p->prox_src) {
        free(tsrc);
        free(vsrc);
        return dtx_seterr(err, DTX_ENOMEM, "out of memory building the proximity terms");
    }
    for (int32_t f = 0; f < p->nf_t; f++)
        tsrc[f] = -1;
    for (int64_t i = 0; i < p->npairs; i++)
        if (tsrc[p->pairs[2 * i + 1]] < 0)
            tsrc[p->pairs[2 * i + 1]] = p->pairs[2 * i];
    for (int32_t v = 0; v < p->nv_t; v++)
        vsrc[v] = -1;
    for (int32_t f = p->nf_t - 1; f >= 0; f--)
        if (tsrc[f] >= 0)
            for (int k = 0; k < 3; k++)
                vsrc[p->Ft[3 * f + k]] = tsrc[f];
    for (int64_t i = 0; i < p->prox.npairs; i++) {
        p->prox_src[2 * i] = vsrc[p->prox.pairs[2 * i]];
        p->prox_src[2 * i + 1] = vsrc[p->prox.pairs[2 * i + 1]];
    }
    free(tsrc);
    free(vsrc);
    return DTX_OK;
}

/* Newton's preconditioner (precond_solve) from A's factor p->L (simplicial
 * L D L', CHOLMOD_SIMPLICIAL without final_ll): L's entries below the
 * diagonal as floats, 1 / D, the permutation.  0 when out of memory. */
static int precond_plan(dtx_mc_plan *p)
{
    const cholmod_factor *L = p->L;
    const int *Lp = L->p, *Li = L->i, *Lnz = L->nz, *Perm = L->Perm;
    const double *Lx = L->x;
    const int32_t n = p->nfree;
    int64_t nnz = 0;
    if (L->is_super || L->is_ll || L->xtype != CHOLMOD_REAL || (int64_t)L->n != n)
        return 1; /* not the expected kind: precond_solve falls back to CHOLMOD */
    for (int32_t j = 0; j < n; j++)
        nnz += Lnz[j] - 1;
    p->mptr = dtx_alloc((size_t)n + 1, sizeof *p->mptr, 0);
    p->mrow = dtx_alloc((size_t)(nnz > 0 ? nnz : 1), sizeof *p->mrow, 0);
    p->mval = dtx_alloc((size_t)(nnz > 0 ? nnz : 1), sizeof *p->mval, 0);
    p->mperm = dtx_alloc((size_t)n, sizeof *p->mperm, 0);
    p->mdinv = dtx_alloc((size_t)n, sizeof *p->mdinv, 0);
    if (!p->mptr || !p->mrow || !p->mval || !p->mperm || !p->mdinv)
        return 0;
    nnz = 0;
    for (int32_t j = 0; j < n; j++) {
        p->mptr[j] = nnz;
        p->mdinv[j] = 1.0 / Lx[Lp[j]];
        p->mperm[j] = Perm ? Perm[j] : j;
        for (int q = Lp[j] + 1; q < Lp[j] + Lnz[j]; q++) {
            if (!(fabs(Lx[q]) < 1e30)) /* beyond float's range: keep CHOLMOD's */
                goto exact;
            p->mrow[nnz] = Li[q];
            p->mval[nnz++] = (float)Lx[q];
        }
    }
    p->mptr[n] = nnz;
    return 1;
exact:
    free(p->mptr);
    p->mptr = NULL;
    return 1;
}

dtx_status dtx_mc_plan_create(const dtx_mesh *src, const dtx_mesh *tgt, const int32_t *pairs,
                              int64_t npairs, const dtx_mc_params *prm, dtx_anchor anchor,
                              const int32_t *pins, const double *pin_pos, int32_t npins,
                              dtx_mc_plan **out, dtx_error *err)
{
    dtx_mc_plan *p = NULL;
    dtx_status st = DTX_OK;
    const int32_t nv = tgt->nv, nf = tgt->nf;
    unsigned char *paired = NULL, *orphan_comp = NULL;
    cholmod_triplet *T = NULL;
    cholmod_sparse *K = NULL;
    coo c = {0, 0, NULL, NULL, NULL};
    double h = 0.0, diag_t, diag_s, t0;

    *out = NULL;
    if (!(prm->w_match > 0.0) || !(prm->w_orphan >= 0.0) || !(prm->w_proximity >= 0.0) ||
        !(prm->w_laplacian >= 0.0) || prm->max_iter < 0 || !(prm->tol >= 0.0) ||
        !(prm->eps_factor >= 0.0) ||
        (prm->lengths != DTX_MC_LENGTHS_RELATIVE && prm->lengths != DTX_MC_LENGTHS_DIAGONAL) ||
        (prm->solver != DTX_MC_SOLVER_FIXED_POINT && prm->solver != DTX_MC_SOLVER_NEWTON))
        return dtx_seterr(err, DTX_EINVAL,
                          "multicomponent parameters out of range (w_match > 0, other weights, "
                          "tol and eps_factor >= 0, max_iter >= 0)");
    st = dtx__check_pins(anchor, pins, npins, nv, err);
    if (st != DTX_OK)
        return st;
    if (npairs < 0 || npairs > INT32_MAX)
        return dtx_seterr(err, DTX_ERANGE, "%lld correspondence pairs: 0 to %d supported",
                          (long long)npairs, (int)INT32_MAX);
    st = dtx__check_pairs(pairs, npairs, src->nf, nf, err);
    if (st != DTX_OK)
        return st;

    p = calloc(1, sizeof *p);
    if (!p)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory creating the transfer plan");
    /* Simplicial L D L' with nested dissection (METIS) only: every
     * iteration of every frame is a back-substitution, bound by the
     * factor's size, and on the 59,000-vertex pebble camel the factor is
     * 18% smaller than with AMD (3.57 M entries against 4.35 M): 7-9%
     * faster frames for 0.5 s more analysis. */
    dtx__chol_start(&p->cc, DTX__CHOL_SIMPLICIAL, DTX__CHOL_ORDER_NESDIS);
    p->nv_s = src->nv;
    p->nf_s = src->nf;
    p->nv_t = nv;
    p->nf_t = nf;
    p->npairs = npairs;
    p->anchor = anchor;
    p->npins = npins;
    p->max_iter = prm->max_iter > 0                     ? prm->max_iter
                  : prm->solver == DTX_MC_SOLVER_NEWTON ? DTX_MC_MAX_ITER_NEWTON
                                                        : DTX_MC_MAX_ITER_FIXED_POINT;
    p->Fs = dtx_alloc((size_t)src->nf, 3 * sizeof *p->Fs, 0);
    p->Ft = dtx_alloc((size_t)nf, 3 * sizeof *p->Ft, 0);
    p->Vt = dtx_alloc((size_t)nv, 3 * sizeof *p->Vt, 0);
    p->Vinv = dtx_alloc((size_t)src->nf, 9 * sizeof *p->Vinv, 0);
    p->G = dtx_alloc((size_t)nf, 9 * sizeof *p->G, 0);
    p->N = dtx_alloc((size_t)nf, 3 * sizeof *p->N, 0);
    p->pairs = dtx_alloc((size_t)npairs, 2 * sizeof *p->pairs, 0);
    p->freeidx = dtx_alloc((size_t)nv, sizeof *p->freeidx, 0);
    p->fixedval = dtx_alloc((size_t)nv, 3 * sizeof *p->fixedval, 1);
    p->used = dtx_alloc((size_t)nv, 1, 1);
    paired = dtx_alloc((size_t)nf, 1, 1);
    if (!p->Fs || !p->Ft || !p->Vt || !p->Vinv || !p->G || !p->N || !p->pairs ||
        !p->freeidx || !p->fixedval || !p->used || !paired)
        goto nomem;
    memcpy(p->Fs, src->F, (size_t)src->nf * 3 * sizeof *p->Fs);
    memcpy(p->Ft, tgt->F, (size_t)nf * 3 * sizeof *p->Ft);
    memcpy(p->Vt, tgt->V, (size_t)nv * 3 * sizeof *p->Vt);
    memcpy(p->pairs, pairs, (size_t)npairs * 2 * sizeof *p->pairs);

    /* Operators, as sp04's. */
    diag_s = dtx_bbox_diagonal(src->V, src->nv);
    diag_t = dtx_bbox_diagonal(tgt->V, nv);
    if (!(diag_t > 0.0)) {
        st = dtx_seterr(err, DTX_EMESH, "the target mesh has zero extent");
        goto fail;
    }
    dtx_frame_inverses(src->V, src->F, src->nf, 1e-14 * diag_s * diag_s, p->Vinv);
    dtx_gradient_operator(tgt->V, tgt->F, nf, 1e-14 * diag_t * diag_t, p->G);
    dtx_face_normals(tgt->V, tgt->F, nf, p->N);
    p->tol_abs = prm->tol * diag_t;

    /* Components, proximity pairs, orphans. */
    st = dtx_proximity_build(tgt, prm->eps_factor, &p->prox, err);
    if (st != DTX_OK)
        goto fail;
    for (int64_t i = 0; i < npairs; i++)
        paired[pairs[2 * i + 1]] = 1;
    orphan_comp = dtx_alloc((size_t)p->prox.ncomp, 1, 0);
    if (!orphan_comp)
        goto nomem;
    memset(orphan_comp, 1, (size_t)p->prox.ncomp);
    for (int32_t f = 0; f < nf; f++)
        if (paired[f])
            orphan_comp[p->prox.comp[tgt->F[3 * f]]] = 0;
    p->info.components = p->prox.ncomp;
    p->info.proximity_pairs = p->prox.npairs;
    p->info.proximity_edges = p->prox.nedges;
    for (int32_t f = 0; f < nf; f++)
        p->info.orphan_triangles += !paired[f];
    for (int32_t k = 0; k < p->prox.ncomp; k++)
        p->info.orphan_components += orphan_comp[k];
    st = build_smooth(p, paired, err);
    if (st != DTX_OK)
        goto fail;
    st = build_laplacian(p, orphan_comp, err);
    if (st != DTX_OK)
        goto fail;
    st = build_prox_src(p, err);
    if (st != DTX_OK)
        goto fail;
    p->nonlinear = (p->prox.npairs > 0 && prm->w_proximity > 0.0) ||
                   (p->nlap > 0 && prm->w_laplacian > 0.0);

    /* Length unit: the target's bounding-box diagonal. */
    h = diag_t;
    p->w1 = prm->w_match;
    p->w2 = prm->w_orphan;
    p->w3 = prm->w_proximity;
    p->w4 = prm->w_laplacian / (h * h);
    st = pair_weights(p, tgt, prm, h, err);
    if (st != DTX_OK)
        goto fail;

    /* Unknowns: as sp04 (pins and, without pins, one anchor removed;
     * vertices in no face keep their rest offset from the centroid). */
    for (int64_t i = 0; i < 3 * (int64_t)nf; i++)
        p->used[tgt->F[i]] = 1;
    dtx__centroid(tgt->V, nv, p->rest_centroid_t);
    dtx__centroid(src->V, src->nv, p->rest_centroid_s);
    /* "follow": the source's centroid motion scaled by the meshes' size
     * ratio (dtx_rms_extent: the same however both are turned). */
    {
        double es = dtx_rms_extent(src->V, src->nv), et = dtx_rms_extent(tgt->V, nv);
        p->scale = es > 0 ? et / es : 1.0;
    }
    for (int32_t v = 0; v < nv; v++)
        p->freeidx[v] = p->used[v] ? 0 : -1;
    for (int32_t i = 0; i < npins; i++) {
        p->freeidx[pins[i]] = -1;
        memcpy(p->fixedval + 3 * (size_t)pins[i], pin_pos + 3 * (size_t)i, 3 * sizeof(double));
    }
    if (npins == 0)
        for (int32_t v = 0; v < nv; v++)
            if (p->used[v]) {
                p->freeidx[v] = -1;
                break;
            }
    for (int32_t v = 0; v < nv; v++)
        if (p->freeidx[v] == 0)
            p->freeidx[v] = p->nfree++;
        else
            p->freeidx[v] = -1;
    for (int32_t v = 0; v < nv; v++)
        p->nunref += !p->used[v];
    if (p->nunref > 0) {
        for (int32_t v = 0; v < nv; v++)
            if (p->used[v])
                for (int k = 0; k < 3; k++)
                    p->rest_centroid_ref[k] += tgt->V[3 * (size_t)v + k] / (nv - p->nunref);
    }
    if (p->nfree == 0) {
        st = dtx_seterr(err, DTX_EMESH, "every target vertex is pinned: nothing to solve");
        goto fail;
    }
    p->bconst = dtx_alloc((size_t)p->nfree, 3 * sizeof *p->bconst, 1);
    if (!p->bconst)
        goto nomem;

    /* The matrix, term by term. */
    for (int64_t i = 0; i < npairs; i++) {
        term t = {0};
        term_triangle(&t, p, pairs[2 * i + 1], 1.0);
        if (!emit(p, &c, &t, p->w1))
            goto nomem;
    }
    if (p->w2 > 0.0)
        for (int64_t i = 0; i < p->nsmooth; i++) {
            term t = {0};
            term_triangle(&t, p, p->smooth[2 * i], 1.0);
            term_triangle(&t, p, p->smooth[2 * i + 1], -1.0);
            if (!emit(p, &c, &t, p->w2))
                goto nomem;
        }
    if (p->w3 > 0.0)
        for (int64_t i = 0; i < p->prox.npairs; i++) {
            static const double one[3] = {1, 0, 0};
            term t = {0};
            term_add(&t, p->prox.pairs[2 * i], one, 1.0);
            term_add(&t, p->prox.pairs[2 * i + 1], one, -1.0);
            if (!emit(p, &c, &t, p->w3p[i]))
                goto nomem;
        }
    if (p->w4 > 0.0)
        for (int32_t r = 0; r < p->nlap; r++) {
            /* A row has 1 + degree coefficients; rows of very high degree
             * are emitted pairwise without the term's fixed capacity. */
            int64_t q0 = p->lap_ptr[r], q1 = p->lap_ptr[r + 1];
            for (int64_t a = q0; a < q1; a++) {
                int32_t fa = p->freeidx[p->lap_col[a]];
                if (fa < 0)
                    continue;
                for (int64_t b = q0; b < q1; b++) {
                    int32_t fb = p->freeidx[p->lap_col[b]];
                    double v = p->w4 * p->lap_coef[a] * p->lap_coef[b];
                    if (fb < 0) {
                        for (int k = 0; k < 3; k++)
                            p->bconst[(size_t)k * p->nfree + fa] -=
                                v * p->fixedval[3 * (size_t)p->lap_col[b] + k];
                    } else if (fb <= fa && !coo_push(&c, fa, fb, v)) {
                        goto nomem;
                    }
                }
            }
        }
    T = cholmod_allocate_triplet((size_t)p->nfree, (size_t)p->nfree, (size_t)c.n, -1,
                                 CHOLMOD_REAL, &p->cc);
    if (!T)
        goto nomem;
    memcpy(T->i, c.i, (size_t)c.n * sizeof *c.i);
    memcpy(T->j, c.j, (size_t)c.n * sizeof *c.j);
    memcpy(T->x, c.x, (size_t)c.n * sizeof *c.x);
    T->nnz = (size_t)c.n;
    free(c.i);
    free(c.j);
    free(c.x);
    c.i = c.j = NULL;
    c.x = NULL;
    K = cholmod_triplet_to_sparse(T, T->nnz, &p->cc);
    cholmod_free_triplet(&T, &p->cc);
    if (!K)
        goto nomem;

    t0 = dtx__now_seconds();
    st = dtx__chol_analyze_factorize(K, DTX__CHOL_TEAMS, "the multicomponent transfer system",
                                     ": some vertex is reached by no term (a component with "
                                     "neither pairs, proximity pairs nor orphan terms?)",
                                     &p->L, &p->cc, err);
    if (st != DTX_OK)
        goto fail;
    p->factor_seconds = dtx__now_seconds() - t0;
    p->info.factor_seconds = p->factor_seconds;
    if (p->nonlinear && prm->solver == DTX_MC_SOLVER_NEWTON) {
        p->A = K; /* kept for H's products */
        K = NULL;
        if (!precond_plan(p))
            goto nomem;
    }
    cholmod_free_sparse(&K, &p->cc);
    free(paired);
    free(orphan_comp);
    *out = p;
    return DTX_OK;

nomem:
    st = dtx_seterr(err, DTX_ENOMEM, "out of memory creating the multicomponent transfer plan");
fail:
    if (p) {
        cholmod_free_sparse(&K, &p->cc);
        cholmod_free_triplet(&T, &p->cc);
    }
    free(c.i);
    free(c.j);
    free(c.x);
    free(paired);
    free(orphan_comp);
    dtx_mc_plan_free(&p);
    return st;
}

void dtx_mc_plan_info(const dtx_mc_plan *p, dtx_mc_info *info)
{
    *info = p->info;
}

int32_t dtx_mc_plan_nv_src(const dtx_mc_plan *p) { return p->nv_s; }
int32_t dtx_mc_plan_nv_tgt(const dtx_mc_plan *p) { return p->nv_t; }

/* ------------------------------------------------------------------ */
/* Apply                                                               */
/* ------------------------------------------------------------------ */

static int init_worker(void *plan, void *workspace)
{
    dtx_mc_plan *p = plan;
    const size_t n3 = 3 * (size_t)p->nfree;
    mc_worker *k = workspace;
    mc_frame *fr = &k->fr;
    dtx__chol_start(&k->cc, DTX__CHOL_AUTO, DTX__CHOL_ORDER_DEFAULT);
    k->B = cholmod_zeros((size_t)p->nfree, 3, CHOLMOD_REAL, &k->cc);
    fr->S = dtx_alloc((size_t)p->nf_s, 9 * sizeof *fr->S, 0);
    fr->Sp = dtx_alloc((size_t)p->npairs, 9 * sizeof *fr->Sp, 0);
    fr->b1 = dtx_alloc(n3, sizeof *fr->b1, 0);
    fr->x = dtx_alloc((size_t)p->nv_t, 3 * sizeof *fr->x, 0);
    fr->lx = dtx_alloc((size_t)p->nlap, 3 * sizeof *fr->lx, 0);
    fr->xf = dtx_alloc(n3, sizeof *fr->xf, 0);
    fr->fl = dtx_alloc(n3, sizeof *fr->fl, 0);
    fr->gl = dtx_alloc(n3, sizeof *fr->gl, 0);
    fr->df = dtx_alloc(n3, MC_AA_DEPTH * sizeof *fr->df, 0);
    fr->dg = dtx_alloc(n3, MC_AA_DEPTH * sizeof *fr->dg, 0);
    if (p->A) {
        k->P = cholmod_zeros((size_t)p->nfree, 3, CHOLMOD_REAL, &k->cc);
        k->HP = cholmod_zeros((size_t)p->nfree, 3, CHOLMOD_REAL, &k->cc);
        k->mt = dtx_alloc((size_t)p->nfree, 3 * sizeof *k->mt, 0);
        k->hq = dtx_alloc((size_t)(p->prox.npairs > 0 ? p->prox.npairs : 1), 4 * sizeof *k->hq, 0);
        if (!k->P || !k->HP || !k->mt || !k->hq)
            return 0;
    }
    if (!k->B || !fr->S || !fr->Sp || !fr->b1 || !fr->x || !fr->lx || !fr->xf || !fr->fl ||
        !fr->gl || !fr->df || !fr->dg)
        return 0;
    fr->b = k->B->x;
    return 1;
}

/* L x for every Laplacian row into lx. */
static void laplacian_apply(const dtx_mc_plan *p, const double *x, double *lx)
{
    for (int32_t r = 0; r < p->nlap; r++) {
        double d[3] = {0, 0, 0};
        for (int64_t q = p->lap_ptr[r]; q < p->lap_ptr[r + 1]; q++)
            for (int c = 0; c < 3; c++)
                d[c] += p->lap_coef[q] * x[3 * (size_t)p->lap_col[q] + c];
        memcpy(lx + 3 * (size_t)r, d, sizeof d);
    }
}

/* The Laplacian target of row r: L x scaled to the rest length (the rest
 * vector itself while L x vanishes).  Returns the row's E4 term (|L x| -
 * |L v|)^2, unweighted. */
static double lap_target(const dtx_mc_plan *p, int32_t r, const double *lx, double *t)
{
    const double *d = lx + 3 * (size_t)r;
    double n = sqrt(dot3(d, d));
    if (n > 1e-12 * p->lap_mag[r] && n > 0.0)
        for (int c = 0; c < 3; c++)
            t[c] = d[c] * (p->lap_mag[r] / n);
    else
        memcpy(t, p->lap_rest + 3 * (size_t)r, 3 * sizeof *t);
    return (n - p->lap_mag[r]) * (n - p->lap_mag[r]);
}

/* The proximity pair's target vector l d (rest direction while the pair
 * has collapsed).  Returns the pair's E3 term (|x_i - x_j| - l)^2,
 * unweighted. */
static double prox_target(const dtx_mc_plan *p, int64_t i, const double *x, double *t)
{
    int32_t a = p->prox.pairs[2 * i], b = p->prox.pairs[2 * i + 1];
    double d[3], n, l = p->prox.rest_len[i], e;
    for (int c = 0; c < 3; c++)
        d[c] = x[3 * (size_t)a + c] - x[3 * (size_t)b + c];
    n = sqrt(dot3(d, d));
    e = (n - l) * (n - l);
    if (!(n > 0.0)) {
        for (int c = 0; c < 3; c++)
            d[c] = p->Vt[3 * (size_t)a + c] - p->Vt[3 * (size_t)b + c];
        n = sqrt(dot3(d, d));
    }
    for (int c = 0; c < 3; c++)
        t[c] = n > 0.0 ? d[c] * (l / n) : 0.0;
    return e;
}

/* The first iterate's target for proximity pair i: the rest vector
 * turned by the source gradients at its two ends (the rest vector where
 * neither end is paired), at the rest length. */
static void prox_target_first(const dtx_mc_plan *p, int64_t i, const double *S, double *t)
{
    int32_t a = p->prox.pairs[2 * i], b = p->prox.pairs[2 * i + 1];
    double u[3], d[3] = {0, 0, 0}, n, l = p->prox.rest_len[i];
    int used = 0;
    for (int c = 0; c < 3; c++)
        u[c] = p->Vt[3 * (size_t)a + c] - p->Vt[3 * (size_t)b + c];
    for (int e = 0; e < 2; e++) {
        int32_t s = p->prox_src[2 * i + e];
        if (s < 0)
            continue;
        for (int c = 0; c < 3; c++)
            d[c] += dot3(S + 9 * (size_t)s + 3 * c, u);
        used = 1;
    }
    if (!used)
        memcpy(d, u, sizeof d);
    n = sqrt(dot3(d, d));
    if (!(n > 0.0) || !isfinite(n)) {
        memcpy(d, u, sizeof d);
        n = sqrt(dot3(d, d));
    }
    for (int c = 0; c < 3; c++)
        t[c] = n > 0.0 ? d[c] * (l / n) : 0.0;
}

/* E1 and E2 (weighted) of the iterate x, E1's targets Sp (see mc_frame). */
static double energy12(const dtx_mc_plan *p, const double *Sp, const double *x)
{
    double e1 = 0.0, e2 = 0.0;
    for (int64_t i = 0; i < p->npairs; i++) {
        int32_t t = p->pairs[2 * i + 1];
        const double *g = p->G + 9 * (size_t)t, *sp = Sp + 9 * (size_t)i;
        const double *x0 = x + 3 * (size_t)p->Ft[3 * t], *x1 = x + 3 * (size_t)p->Ft[3 * t + 1],
                     *x2 = x + 3 * (size_t)p->Ft[3 * t + 2];
        for (int c = 0; c < 3; c++) {
            double r[3];
            for (int k = 0; k < 3; k++)
                r[k] = sp[3 * c + k] - x0[c] * g[k] - x1[c] * g[3 + k] - x2[c] * g[6 + k];
            e1 += dot3(r, r);
        }
    }
    for (int64_t i = 0; i < p->nsmooth; i++) {
        int32_t a = p->smooth[2 * i], b = p->smooth[2 * i + 1];
        for (int c = 0; c < 3; c++) {
            double r[3] = {0, 0, 0};
            for (int j = 0; j < 3; j++) {
                double xa = x[3 * (size_t)p->Ft[3 * a + j] + c];
                double xb = x[3 * (size_t)p->Ft[3 * b + j] + c];
                for (int k = 0; k < 3; k++)
                    r[k] += xa * p->G[9 * (size_t)a + 3 * j + k] -
                            xb * p->G[9 * (size_t)b + 3 * j + k];
            }
            e2 += dot3(r, r);
        }
    }
    return p->w1 * e1 + p->w2 * e2;
}

/* E3 and E4 (weighted) of the iterate x with Laplacian coordinates lx. */
static double energy34(const dtx_mc_plan *p, const double *x, const double *lx)
{
    double e3 = 0.0, e4 = 0.0;
    for (int64_t i = 0; i < p->prox.npairs; i++) {
        int32_t a = p->prox.pairs[2 * i], b = p->prox.pairs[2 * i + 1];
        double d[3], r;
        for (int c = 0; c < 3; c++)
            d[c] = x[3 * (size_t)a + c] - x[3 * (size_t)b + c];
        r = sqrt(dot3(d, d)) - p->prox.rest_len[i];
        e3 += p->w3p[i] * r * r;
    }
    for (int32_t r = 0; r < p->nlap; r++) {
        const double *l = lx + 3 * (size_t)r;
        double n = sqrt(dot3(l, l)) - p->lap_mag[r];
        e4 += n * n;
    }
    return e3 + p->w4 * e4;
}

/* The right-hand side of the frame's next solve into fr->b: the frame's
 * part b1 plus E3's and E4's targets, with the directions of the iterate
 * fr->x (its Laplacian fr->lx), or for the first step (first != 0) the rest
 * directions turned by the source gradients.  Returns E3 + E4 (weighted)
 * of the iterate, as energy34 (meaningless for the first step), from the
 * same lengths. */
static double build_rhs(const dtx_mc_plan *p, mc_frame *fr, int first)
{
    const int32_t nfree = p->nfree;
    double *b = fr->b, e3 = 0.0, e4 = 0.0;
    memcpy(b, fr->b1, (size_t)nfree * 3 * sizeof *b);
    if (p->w3 > 0.0)
        for (int64_t i = 0; i < p->prox.npairs; i++) {
            double t[3];
            int32_t fa = p->freeidx[p->prox.pairs[2 * i]];
            int32_t fb = p->freeidx[p->prox.pairs[2 * i + 1]];
            if (first)
                prox_target_first(p, i, fr->S, t);
            else
                e3 += p->w3p[i] * prox_target(p, i, fr->x, t);
            for (int c = 0; c < 3; c++) {
                if (fa >= 0)
                    b[(size_t)c * nfree + fa] += p->w3p[i] * t[c];
                if (fb >= 0)
                    b[(size_t)c * nfree + fb] -= p->w3p[i] * t[c];
            }
        }
    if (p->w4 > 0.0)
        for (int32_t r = 0; r < p->nlap; r++) {
            double t[3];
            e4 += lap_target(p, r, fr->lx, t);
            for (int64_t q = p->lap_ptr[r]; q < p->lap_ptr[r + 1]; q++) {
                int32_t fv = p->freeidx[p->lap_col[q]];
                if (fv < 0)
                    continue;
                for (int c = 0; c < 3; c++)
                    b[(size_t)c * nfree + fv] += p->w4 * p->lap_coef[q] * t[c];
            }
        }
    return e3 + p->w4 * e4;
}

/* Makes xf the frame's iterate: its free vertices into fr->x (the fixed ones
 * stay), and the Laplacian coordinates fr->lx. */
static void set_iterate(const dtx_mc_plan *p, mc_frame *fr, const double *xf)
{
    const int32_t nfree = p->nfree;
    for (int32_t v = 0; v < p->nv_t; v++) {
        int32_t fv = p->freeidx[v];
        if (fv < 0)
            continue;
        for (int c = 0; c < 3; c++)
            fr->x[3 * (size_t)v + c] = xf[(size_t)c * nfree + fv];
    }
    laplacian_apply(p, fr->x, fr->lx);
}

/* E at the free unknowns xf (E1 + E2 + E3 + E4), which become the frame's
 * iterate (set_iterate). */
static double energy_at(const dtx_mc_plan *p, mc_frame *fr, const double *xf)
{
    set_iterate(p, fr, xf);
    return energy12(p, fr->Sp, fr->x) + energy34(p, fr->x, fr->lx);
}

/* Anderson step from the last step (fr->fl = G(x) - x, fr->gl = G(x)) and
 * the nh stored differences, r[i] = df_i . fl: gamma minimising |fl - df
 * gamma| (normal equations by Cholesky, 1e-10 of the largest diagonal entry
 * added to the diagonal), then fr->xf = gl - dg gamma.  0 (xf unchanged)
 * when that system is not positive definite or gamma is not finite. */
static int anderson(mc_frame *fr, int nh, size_t n3, double *r)
{
    enum { D = MC_AA_DEPTH };
    double M[D * D], dmax = 0.0;
    if (nh < 1 || nh > D)
        return 0;
    for (int i = 0; i < nh; i++) {
        for (int j = 0; j < nh; j++)
            M[i * D + j] = fr->gram[i * D + j];
        dmax = M[i * D + i] > dmax ? M[i * D + i] : dmax;
    }
    if (!(dmax > 0.0))
        return 0;
    for (int i = 0; i < nh; i++)
        M[i * D + i] += 1e-10 * dmax;
    /* M = C C^T (C lower, in place), then C z = r and C^T gamma = z. */
    for (int j = 0; j < nh; j++) {
        double d = M[j * D + j];
        for (int k = 0; k < j; k++)
            d -= M[j * D + k] * M[j * D + k];
        if (!(d > 0.0))
            return 0;
        d = sqrt(d);
        M[j * D + j] = d;
        for (int i = j + 1; i < nh; i++) {
            double v = M[i * D + j];
            for (int k = 0; k < j; k++)
                v -= M[i * D + k] * M[j * D + k];
            M[i * D + j] = v / d;
        }
    }
    for (int i = 0; i < nh; i++) {
        for (int k = 0; k < i; k++)
            r[i] -= M[i * D + k] * r[k];
        r[i] /= M[i * D + i];
    }
    for (int i = nh - 1; i >= 0; i--) {
        for (int k = i + 1; k < nh; k++)
            r[i] -= M[k * D + i] * r[k];
        r[i] /= M[i * D + i];
        if (!isfinite(r[i]))
            return 0;
    }
    for (size_t i = 0; i < n3; i++) {
        double v = fr->gl[i];
        for (int j = 0; j < nh; j++)
            v -= r[j] * fr->dg[(size_t)j * n3 + i];
        fr->xf[i] = v;
    }
    return 1;
}

/* The frame is done (its result is fr->x): residual, vertices in no face,
 * the translation (as sp04), the output. */
static void frame_finish(const dtx_mc_plan *p, mc_frame *fr, int converged)
{
    const int32_t nv = p->nv_t;
    double want[3];
    if (fr->info) {
        fr->info->iterations = fr->it;
        fr->info->converged = converged;
    }
    if (fr->residual) {
        double e = energy12(p, fr->Sp, fr->x) + energy34(p, fr->x, fr->lx);
        *fr->residual = sqrt((e > 0.0 ? e : 0.0) / (double)(p->npairs > 0 ? p->npairs : 1));
    }
    if (p->nunref > 0) {
        double cref[3] = {0, 0, 0};
        for (int32_t v = 0; v < nv; v++)
            if (p->used[v])
                for (int c = 0; c < 3; c++)
                    cref[c] += fr->x[3 * (size_t)v + c];
        for (int c = 0; c < 3; c++)
            cref[c] = cref[c] / (nv - p->nunref) - p->rest_centroid_ref[c];
        for (int32_t v = 0; v < nv; v++)
            if (!p->used[v])
                for (int c = 0; c < 3; c++)
                    fr->x[3 * (size_t)v + c] = p->Vt[3 * (size_t)v + c] + cref[c];
    }
    if (p->npins == 0) {
        double cs[3], cx[3];
        dtx__centroid(fr->x, nv, cx);
        if (p->anchor == DTX_ANCHOR_FOLLOW)
            dtx__centroid(fr->Xs, p->nv_s, cs);
        for (int c = 0; c < 3; c++) {
            want[c] = p->rest_centroid_t[c] +
                      (p->anchor == DTX_ANCHOR_FOLLOW ? p->scale * (cs[c] - p->rest_centroid_s[c])
                                                      : 0.0);
            want[c] -= cx[c];
        }
        for (int32_t v = 0; v < nv; v++)
            for (int c = 0; c < 3; c++)
                fr->Xt[3 * (size_t)v + c] = fr->x[3 * (size_t)v + c] + want[c];
    } else {
        memcpy(fr->Xt, fr->x, (size_t)nv * 3 * sizeof *fr->Xt);
    }
}

/* A frame whose solve failed (out of memory for its workspace) is reported
 * as failed, all NaN, rather than stopping the other frames. */
static void frame_failed(const dtx_mc_plan *p, mc_frame *fr)
{
    for (int64_t i = 0; i < 3 * (int64_t)p->nv_t; i++)
        fr->Xt[i] = NAN;
    if (fr->residual)
        *fr->residual = NAN;
    if (fr->info) {
        fr->info->iterations = fr->it;
        fr->info->converged = 0;
    }
}

/* Starts frame f: the source gradients, the frame's part of the right-hand
 * side and the first step's.  Returns 1 when the frame now waits for a
 * solve, 0 when it is already done (non-finite source positions: NaN out,
 * no iteration). */
static int frame_start(const dtx_mc_plan *p, mc_frame *fr, int64_t f, const double *Xs, double *Xt,
                      double *residual, dtx_mc_frame_info *info)
{
    const int32_t nv = p->nv_t, nfree = p->nfree;
    fr->Xs = Xs + (size_t)f * 3 * p->nv_s;
    fr->Xt = Xt + (size_t)f * 3 * nv;
    fr->residual = residual ? residual + f : NULL;
    fr->info = info ? info + f : NULL;
    for (int64_t i = 0; i < 3 * (int64_t)p->nv_s; i++)
        if (!isfinite(fr->Xs[i])) {
            for (int64_t k = 0; k < 3 * (int64_t)nv; k++)
                fr->Xt[k] = NAN;
            if (fr->residual)
                *fr->residual = NAN;
            if (fr->info)
                fr->info->iterations = fr->info->converged = 0;
            return 0;
        }
    fr->it = 0;

    /* E1's right-hand side (the frame's source gradients) plus the pins'. */
    dtx_deformation_gradients(p->Vinv, p->Fs, p->nf_s, fr->Xs, fr->S);
    memcpy(fr->b1, p->bconst, (size_t)nfree * 3 * sizeof *fr->b1);
    for (int64_t i = 0; i < p->npairs; i++) {
        int32_t s = p->pairs[2 * i], t = p->pairs[2 * i + 1];
        const double *S = fr->S + 9 * (size_t)s;
        for (int j = 0; j < 3; j++) {
            int32_t fv = p->freeidx[p->Ft[3 * t + j]];
            const double *g = p->G + 9 * (size_t)t + 3 * j;
            if (fv < 0)
                continue;
            for (int c = 0; c < 3; c++)
                fr->b1[(size_t)c * nfree + fv] += p->w1 * dot3(g, S + 3 * c);
        }
    }
    for (int64_t i = 0; i < p->npairs; i++) {
        const double *S = fr->S + 9 * (size_t)p->pairs[2 * i];
        const double *n = p->N + 3 * (size_t)p->pairs[2 * i + 1];
        double *sp = fr->Sp + 9 * (size_t)i;
        for (int c = 0; c < 3; c++) {
            double sn = dot3(S + 3 * c, n);
            for (int k = 0; k < 3; k++)
                sp[3 * c + k] = S[3 * c + k] - sn * n[k];
        }
    }

    /* The first step from the rest pose, with the proximity directions
     * turned by the source gradients (see prox_target_first). */
    memcpy(fr->x, p->Vt, (size_t)nv * 3 * sizeof *fr->x);
    for (int32_t v = 0; v < nv; v++)
        if (p->freeidx[v] < 0 && p->used[v])
            memcpy(fr->x + 3 * (size_t)v, p->fixedval + 3 * (size_t)v, 3 * sizeof(double));
    laplacian_apply(p, p->Vt, fr->lx);
    build_rhs(p, fr, 1);
    return 1;
}

/* After a solve (fr->g = G(x), the step from the iterate fr->xf): ends the
 * frame or prepares the next solve (returns 1).  Iterations as in the file
 * comment. */
static int frame_step(const dtx_mc_plan *p, mc_frame *fr)
{
    const size_t n3 = 3 * (size_t)p->nfree;
    const double *g = fr->g;
    double *df = fr->df + (size_t)fr->head * n3, *dg = fr->dg + (size_t)fr->head * n3;
    double move = 0.0, r[MC_AA_DEPTH];
    fr->it++;
    if (fr->it == 1) {
        memcpy(fr->xf, g, n3 * sizeof *fr->xf);
        set_iterate(p, fr, fr->xf);
        if (!p->nonlinear || fr->it >= p->max_iter) {
            frame_finish(p, fr, !p->nonlinear);
            return 0;
        }
        fr->e_cur = energy12(p, fr->Sp, fr->x) + build_rhs(p, fr, 0);
        fr->nh = fr->head = fr->have_last = 0;
        return 1;
    }
    /* The step f = G(x) - x: its largest entry, the differences of
     * successive f and G(x) into history slot head, and f, G(x) kept as fl,
     * gl (written also when the frame stops here, unused then). */
    for (size_t i = 0; i < n3; i++) {
        double f = g[i] - fr->xf[i], d = fabs(f);
        move = d > move ? d : move;
        if (fr->have_last) {
            df[i] = f - fr->fl[i];
            dg[i] = g[i] - fr->gl[i];
        }
        fr->fl[i] = f;
        fr->gl[i] = g[i];
    }
    if (!(move > p->tol_abs) || fr->it >= p->max_iter) {
        set_iterate(p, fr, g);
        frame_finish(p, fr, !(move > p->tol_abs));
        return 0;
    }
    if (fr->have_last) {
        /* The new column's Gram entries and every column's product with f,
         * in one pass (each sum in index order). */
        double gnew[MC_AA_DEPTH];
        int h = fr->head;
        fr->nh += fr->nh < MC_AA_DEPTH;
        for (int j = 0; j < fr->nh; j++)
            gnew[j] = r[j] = 0.0;
        for (size_t i = 0; i < n3; i++)
            for (int j = 0; j < fr->nh; j++) {
                double dj = fr->df[(size_t)j * n3 + i];
                gnew[j] += df[i] * dj;
                r[j] += dj * fr->fl[i];
            }
        for (int j = 0; j < fr->nh; j++) {
            fr->gram[h * MC_AA_DEPTH + j] = gnew[j];
            fr->gram[j * MC_AA_DEPTH + h] = gnew[j];
        }
        fr->head = (h + 1) % MC_AA_DEPTH;
    }
    fr->have_last = 1;
    if (fr->nh > 0 && anderson(fr, fr->nh, n3, r)) {
        double e_acc;
        set_iterate(p, fr, fr->xf);
        e_acc = energy12(p, fr->Sp, fr->x) + build_rhs(p, fr, 0);
        if (e_acc < fr->e_cur) {
            fr->e_cur = e_acc;
            return 1;
        }
        fr->nh = fr->head = 0;
    }
    memcpy(fr->xf, g, n3 * sizeof *fr->xf);
    set_iterate(p, fr, fr->xf);
    fr->e_cur = energy12(p, fr->Sp, fr->x) + build_rhs(p, fr, 0);
    return 1;
}

/* ------------------------------------------------------------------ */
/* Newton steps (DTX_MC_SOLVER_NEWTON, see the file comment)           */
/* ------------------------------------------------------------------ */

/* Newton steps (see the file comment): conjugate-gradient products per
 * step at most; the factor by which the residual (in A^-1's norm) falls
 * before a step inside the trust region is taken; the first radius, in
 * units of the first fixed-point step's length (A's norm); the least ratio
 * of E's decrease to the model's for a step to stand; halvings of a
 * rejected step tried; E's relative rounding. */
#define MC_CG_MAX 40
#define MC_CG_ETA 0.01
#define MC_TR_INIT 10.0
#define MC_TR_ACCEPT 1e-4
#define MC_TR_BACKTRACK 4
#define MC_ROUND 1e-12

/* Each proximity pair's share of H at the frame's iterate, for the
 * products of one Newton step: the unit direction d of x_i - x_j (0 where
 * the pair has collapsed) and c = w3 c_ij l_ij / |x_i - x_j| (w3 c_ij
 * then), into w->hq. */
static void hess_prepare(const dtx_mc_plan *p, mc_worker *w)
{
    const mc_frame *fr = &w->fr;
    if (!(p->w3 > 0.0))
        return;
    for (int64_t i = 0; i < p->prox.npairs; i++) {
        int32_t a = p->prox.pairs[2 * i], b = p->prox.pairs[2 * i + 1];
        double d[3], n, c = p->w3p[i], *q = w->hq + 4 * (size_t)i;
        for (int k = 0; k < 3; k++)
            d[k] = fr->x[3 * (size_t)a + k] - fr->x[3 * (size_t)b + k];
        n = sqrt(dot3(d, d));
        if (n > 0.0) {
            for (int k = 0; k < 3; k++)
                d[k] /= n;
            c *= p->prox.rest_len[i] / n;
        } else {
            d[0] = d[1] = d[2] = 0.0;
        }
        q[0] = d[0];
        q[1] = d[1];
        q[2] = d[2];
        q[3] = c;
    }
}

/* w->HP = H w->P (both nfree x 3, column-major): H is half E's Hessian at
 * the frame's iterate (fr->x, fr->lx; the pairs' shares from hess_prepare),
 * A less what A holds across each proximity pair's direction and each
 * Laplacian row's that E's second derivative does not. */
static void hess_apply(const dtx_mc_plan *p, mc_worker *w)
{
    double one[2] = {1, 0}, zero[2] = {0, 0};
    const mc_frame *fr = &w->fr;
    const int32_t nfree = p->nfree;
    const double *v = w->P->x;
    double *out = w->HP->x;
    cholmod_sdmult(p->A, 0, one, zero, w->P, w->HP, &w->cc);
    if (p->w3 > 0.0)
        for (int64_t i = 0; i < p->prox.npairs; i++) {
            int32_t fa = p->freeidx[p->prox.pairs[2 * i]], fb = p->freeidx[p->prox.pairs[2 * i + 1]];
            const double *q = w->hq + 4 * (size_t)i;
            double u[3], du;
            for (int k = 0; k < 3; k++)
                u[k] = (fa >= 0 ? v[(size_t)k * nfree + fa] : 0.0) -
                       (fb >= 0 ? v[(size_t)k * nfree + fb] : 0.0);
            du = dot3(q, u);
            for (int k = 0; k < 3; k++) {
                double t = q[3] * (u[k] - q[k] * du);
                if (fa >= 0)
                    out[(size_t)k * nfree + fa] -= t;
                if (fb >= 0)
                    out[(size_t)k * nfree + fb] += t;
            }
        }
    if (p->w4 > 0.0)
        for (int32_t r = 0; r < p->nlap; r++) {
            const double *lx = fr->lx + 3 * (size_t)r;
            double d[3] = {0, 0, 0}, u[3] = {0, 0, 0}, n = sqrt(dot3(lx, lx)), c = p->w4;
            double du = 0.0;
            for (int64_t q = p->lap_ptr[r]; q < p->lap_ptr[r + 1]; q++) {
                int32_t fv = p->freeidx[p->lap_col[q]];
                if (fv >= 0)
                    for (int k = 0; k < 3; k++)
                        u[k] += p->lap_coef[q] * v[(size_t)k * nfree + fv];
            }
            /* As lap_target: a row whose L x vanishes aims at its rest
             * vector, a constant. */
            if (n > 1e-12 * p->lap_mag[r] && n > 0.0) {
                for (int k = 0; k < 3; k++)
                    d[k] = lx[k] / n;
                c *= p->lap_mag[r] / n;
                du = dot3(d, u);
            } else {
                c = 0.0;
            }
            for (int64_t q = p->lap_ptr[r]; q < p->lap_ptr[r + 1]; q++) {
                int32_t fv = p->freeidx[p->lap_col[q]];
                if (fv >= 0)
                    for (int k = 0; k < 3; k++)
                        out[(size_t)k * nfree + fv] -= p->lap_coef[q] * c * (u[k] - d[k] * du);
            }
        }
}

static double dotn(const double *a, const double *b, size_t n)
{
    double s = 0.0;
    for (size_t i = 0; i < n; i++)
        s += a[i] * b[i];
    return s;
}

/* w->X = A^-1 w->B.  0 when CHOLMOD ran out of memory. */
static int solve_a(const dtx_mc_plan *p, mc_worker *w)
{
    return cholmod_solve2(CHOLMOD_A, p->L, w->B, NULL, &w->X, NULL, &w->Y, &w->E, &w->cc);
}

/* w->X = M^-1 w->B for Newton's preconditioner M = L~ D~ L~' (permuted),
 * A's factor with L's entries rounded to single precision: a
 * back-substitution reads every entry of L twice and is bound by that
 * traffic, which floats and 32-bit row indices make 8 bytes an entry
 * instead of CHOLMOD's 12.  M = L~ D L~' with L~ unit lower triangular
 * and D > 0 is symmetric positive definite however L's entries were
 * rounded, and within float rounding of A, so the conjugate gradients'
 * recurrences hold and it preconditions as well as A (the same steps and
 * products on the pebble camel); the arithmetic is in double, in a fixed
 * order.  (The first solve, the fixed-point step x = A^-1 b, stays exact;
 * it also made w->X.)  Falls back to A's factor when precond_plan found an
 * unexpected factor.  0 when CHOLMOD ran out of memory. */
static int precond_solve(const dtx_mc_plan *p, mc_worker *w)
{
    const int32_t n = p->nfree;
    const int64_t *ptr = p->mptr;
    const int32_t *row = p->mrow, *perm = p->mperm;
    const float *val = p->mval;
    const double *b = w->B->x;
    double *t = w->mt, *x = w->X->x;
    if (!ptr)
        return solve_a(p, w);
    for (int32_t k = 0; k < n; k++)
        for (int c = 0; c < 3; c++)
            t[3 * (size_t)k + c] = b[(size_t)c * n + perm[k]];
    /* L y = t, column by column. */
    for (int32_t j = 0; j < n; j++) {
        const double y0 = t[3 * (size_t)j], y1 = t[3 * (size_t)j + 1], y2 = t[3 * (size_t)j + 2];
        for (int64_t q = ptr[j]; q < ptr[j + 1]; q++) {
            double l = val[q];
            double *ti = t + 3 * (size_t)row[q];
            ti[0] -= l * y0;
            ti[1] -= l * y1;
            ti[2] -= l * y2;
        }
    }
    /* D z = y, then L' x = z from the last column. */
    for (int32_t j = n - 1; j >= 0; j--) {
        double s0 = t[3 * (size_t)j] * p->mdinv[j], s1 = t[3 * (size_t)j + 1] * p->mdinv[j],
               s2 = t[3 * (size_t)j + 2] * p->mdinv[j];
        for (int64_t q = ptr[j]; q < ptr[j + 1]; q++) {
            double l = val[q];
            const double *ti = t + 3 * (size_t)row[q];
            s0 -= l * ti[0];
            s1 -= l * ti[1];
            s2 -= l * ti[2];
        }
        t[3 * (size_t)j] = s0;
        t[3 * (size_t)j + 1] = s1;
        t[3 * (size_t)j + 2] = s2;
    }
    for (int32_t k = 0; k < n; k++)
        for (int c = 0; c < 3; c++)
            x[(size_t)c * n + perm[k]] = t[3 * (size_t)k + c];
    return 1;
}

/* A frame after frame_start, to its end: the first solve, then Newton
 * steps in a trust region (see the file comment).  fr->it counts the first
 * solve and the Newton steps, taken or not.  Returns 0 when a solve ran out
 * of memory (the caller reports the frame failed). */
static int newton_frame(const dtx_mc_plan *p, mc_worker *w)
{
    mc_frame *fr = &w->fr;
    const size_t n3 = 3 * (size_t)p->nfree;
    double *x = fr->xf, *r = fr->fl, *dx = fr->gl, *xt = fr->df;
    double *pv = w->P->x, *hp = w->HP->x;
    double one[2] = {1, 0}, zero[2] = {0, 0};
    double delta = -1.0; /* the trust region's radius in A's norm; set by the first step */
    int converged = 0;
    if (!solve_a(p, w))
        return 0;
    fr->it = 1;
    memcpy(x, w->X->x, n3 * sizeof *x);
    set_iterate(p, fr, x);
    while (fr->it < p->max_iter) {
        /* m: the model's change of E / 2 along dx; dAd, dAp, pAp: dx.A dx,
         * dx.A p, p.A p for the conjugate direction p (Steihaug's
         * recurrences, without products with A). */
        double e, et, rz, rz0, m = 0.0, dAd = 0.0, dAp = 0.0, pAp, dmax = 0.0, rho;
        int boundary = 0;
        /* r = b(x) - A x = -grad E / 2 (b(x) into w->B), and z = M^-1 r,
         * about the fixed-point step, as the first conjugate direction. */
        e = energy12(p, fr->Sp, fr->x) + build_rhs(p, fr, 0);
        memcpy(pv, x, n3 * sizeof *pv);
        cholmod_sdmult(p->A, 0, one, zero, w->P, w->HP, &w->cc);
        for (size_t i = 0; i < n3; i++)
            r[i] = fr->b[i] - hp[i];
        memset(dx, 0, n3 * sizeof *dx);
        memcpy(fr->b, r, n3 * sizeof *r);
        hess_prepare(p, w);
        if (!precond_solve(p, w))
            return 0;
        memcpy(pv, w->X->x, n3 * sizeof *pv);
        rz = rz0 = dotn(r, pv, n3);
        if (!(rz0 > 0.0)) { /* a stationary point: nothing moves */
            converged = 1;
            break;
        }
        if (delta < 0.0)
            delta = MC_TR_INIT * sqrt(rz0);
        pAp = rz0;

        /* Steihaug-Toint: conjugate gradients on H dx = r from dx = 0,
         * preconditioned by A, until the residual (in A^-1's norm) has
         * fallen by MC_CG_ETA, or to the region's boundary where a step
         * would leave it or a direction has negative curvature. */
        for (int k = 0; k < MC_CG_MAX; k++) {
            double php, a, rzn, beta;
            const double *z;
            hess_apply(p, w);
            php = dotn(pv, hp, n3);
            a = php > 0.0 ? rz / php : 0.0;
            if (!(php > 0.0) || dAd + a * (2.0 * dAp + a * pAp) >= delta * delta) {
                double disc = dAp * dAp + pAp * (delta * delta - dAd);
                double tau = (-dAp + sqrt(disc > 0.0 ? disc : 0.0)) / pAp;
                for (size_t i = 0; i < n3; i++)
                    dx[i] += tau * pv[i];
                m += -tau * rz + 0.5 * tau * tau * php;
                dAd = delta * delta;
                boundary = 1;
                break;
            }
            for (size_t i = 0; i < n3; i++) {
                dx[i] += a * pv[i];
                r[i] -= a * hp[i];
            }
            m -= 0.5 * a * rz;
            dAd += a * (2.0 * dAp + a * pAp);
            if (k + 1 == MC_CG_MAX)
                break;
            memcpy(fr->b, r, n3 * sizeof *r);
            if (!precond_solve(p, w))
                return 0;
            z = w->X->x;
            rzn = dotn(r, z, n3);
            if (!(rzn > MC_CG_ETA * MC_CG_ETA * rz0))
                break;
            beta = rzn / rz;
            dAp = beta * (dAp + a * pAp);
            pAp = rzn + beta * beta * pAp;
            for (size_t i = 0; i < n3; i++)
                pv[i] = z[i] + beta * pv[i];
            rz = rzn;
        }
        fr->it++;

        /* rho: E's decrease over the model's.  A decrease the size of E's
         * rounding says nothing about the model: such a step stands unless
         * E rose by more than rounding. */
        for (size_t i = 0; i < n3; i++) {
            xt[i] = x[i] + dx[i];
            dmax = fabs(dx[i]) > dmax ? fabs(dx[i]) : dmax;
        }
        et = energy_at(p, fr, xt);
        if (-2.0 * m > MC_ROUND * fabs(e))
            rho = (e - et) / (-2.0 * m);
        else
            rho = e - et >= -MC_ROUND * fabs(e) ? 1.0 : 0.0;
        if (rho < 0.25)
            delta = 0.25 * sqrt(dAd);
        else if (rho > 0.75 && boundary)
            delta *= 2.0;
        if (rho > MC_TR_ACCEPT) {
            memcpy(x, xt, n3 * sizeof *x);
            /* Converged: an unconstrained Newton step, an estimate of the
             * distance to the minimiser, moves no vertex more than tol x
             * the diagonal. */
            if (!boundary && !(dmax > p->tol_abs)) {
                converged = 1;
                break;
            }
        } else {
            /* Rejected: first the shorter steps along dx (energy
             * evaluations only); the next radius is half the step taken
             * (a quarter of this one's without one). */
            double alpha = 0.5;
            int lowered = 0;
            for (int ls = 0; ls < MC_TR_BACKTRACK && !lowered; ls++, alpha *= 0.5) {
                for (size_t i = 0; i < n3; i++)
                    xt[i] = x[i] + alpha * dx[i];
                et = energy_at(p, fr, xt);
                lowered = e - et > -MC_TR_ACCEPT * alpha * 2.0 * m;
            }
            if (lowered) { /* alpha is half the step taken */
                memcpy(x, xt, n3 * sizeof *x);
                delta = alpha * sqrt(dAd);
            } else {
                set_iterate(p, fr, x);
            }
        }
    }
    frame_finish(p, fr, converged);
    return 1;
}

dtx_status dtx_mc_apply(dtx_mc_plan *p, int64_t nframes, const double *Xs, double *Xt,
                        double *residual, dtx_mc_frame_info *info, dtx_error *err)
{
    dtx_status st = dtx__workers_ensure(&p->workers, sizeof(mc_worker), p, init_worker,
                                        fini_worker, "solver workspaces", err);
    if (st != DTX_OK)
        return st;
#pragma omp parallel for schedule(dynamic, 1)
    for (int64_t f = 0; f < nframes; f++) {
        int t = 0;
        mc_worker *w;
        mc_frame *fr;
#ifdef _OPENMP
        t = omp_get_thread_num();
#endif
        w = dtx__worker(&p->workers, t);
        fr = &w->fr;
        if (!frame_start(p, fr, f, Xs, Xt, residual, info))
            continue;
        if (p->A) {
            if (!newton_frame(p, w))
                frame_failed(p, fr); /* out of memory for a solve's workspace */
            continue;
        }
        do {
            if (!cholmod_solve2(CHOLMOD_A, p->L, w->B, NULL, &w->X, NULL, &w->Y, &w->E,
                                &w->cc)) {
                frame_failed(p, fr); /* out of memory for the solve's workspace */
                break;
            }
            fr->g = w->X->x;
        } while (frame_step(p, fr));
    }
    return DTX_OK;
}

/* ------------------------------------------------------------------ */
/* The method table (transfer.h)                                       */
/* ------------------------------------------------------------------ */

/* The table's plan: the multicomponent plan and the last apply's figures. */
typedef struct {
    dtx_mc_plan *plan;
    void *res, *info; /* cap doubles, cap dtx_mc_frame_info */
    int64_t res_cap, info_cap;
} mc_method_plan;

static void mc_method_free(void **plan)
{
    mc_method_plan *p = *plan;
    if (!p)
        return;
    dtx_mc_plan_free(&p->plan);
    free(p->res);
    free(p->info);
    free(p);
    *plan = NULL;
}

static dtx_status mc_method_create(const dtx_transfer_inputs *in, const dtx_transfer_params *prm,
                                   void **plan, dtx_error *err)
{
    mc_method_plan *p = dtx_alloc(1, sizeof *p, 1);
    dtx_status st;
    *plan = NULL;
    if (!p)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory");
    st = dtx_mc_plan_create(in->src, in->tgt, in->pairs, in->npairs, &prm->u.mc, in->anchor,
                            in->pins, in->pin_pos, in->npins, &p->plan, err);
    *plan = p;
    if (st != DTX_OK)
        mc_method_free(plan);
    return st;
}

static dtx_status mc_method_apply(void *plan, int64_t nframes, const double *Xs, double *Xt,
                                  dtx_frame_info *info, dtx_error *err)
{
    mc_method_plan *p = plan;
    dtx_status st = dtx_transfer_scratch(&p->res, &p->res_cap, nframes, sizeof(double), err);
    const double *res = p->res;
    const dtx_mc_frame_info *mi;
    if (st == DTX_OK)
        st = dtx_transfer_scratch(&p->info, &p->info_cap, nframes, sizeof *mi, err);
    mi = p->info;
    if (st == DTX_OK)
        st = dtx_mc_apply(p->plan, nframes, Xs, Xt, p->res, p->info, err);
    for (int64_t i = 0; st == DTX_OK && i < nframes; i++) {
        info[i].residual = res[i];
        info[i].iterations = mi[i].iterations;
        info[i].converged = mi[i].converged;
        info[i].inverted = -1; /* not counted */
        info[i].grad_norm = NAN; /* not reported */
    }
    return st;
}

static void mc_method_describe(const void *plan, char *buf, size_t size)
{
    const mc_method_plan *p = plan;
    dtx_mc_info info;
    dtx_mc_plan_info(p->plan, &info);
    snprintf(buf, size,
             "%d components, %d proximity edges with %lld vertex pairs, %d orphan triangles, "
             "%d orphan components",
             (int)info.components, (int)info.proximity_edges, (long long)info.proximity_pairs,
             (int)info.orphan_triangles, (int)info.orphan_components);
}

/* The job file's "multicomponent" object (transfer.h). */
static const char *const mc_lengths[] = {"relative", "diagonal", NULL};
static const char *const mc_solvers[] = {"fixed-point", "newton", NULL};
static const dtx_setting mc_settings[] = {
    {"eps_factor", DTX_SETTING_DOUBLE, offsetof(dtx_mc_params, eps_factor), NULL},
    {"max_iter", DTX_SETTING_INT, offsetof(dtx_mc_params, max_iter), NULL},
    {"proximity_lengths", DTX_SETTING_CHOICE, offsetof(dtx_mc_params, lengths), mc_lengths},
    {"solver", DTX_SETTING_CHOICE, offsetof(dtx_mc_params, solver), mc_solvers},
    {"tol", DTX_SETTING_DOUBLE, offsetof(dtx_mc_params, tol), NULL},
    {"w_laplacian", DTX_SETTING_DOUBLE, offsetof(dtx_mc_params, w_laplacian), NULL},
    {"w_match", DTX_SETTING_DOUBLE, offsetof(dtx_mc_params, w_match), NULL},
    {"w_orphan", DTX_SETTING_DOUBLE, offsetof(dtx_mc_params, w_orphan), NULL},
    {"w_proximity", DTX_SETTING_DOUBLE, offsetof(dtx_mc_params, w_proximity), NULL},
};

static const char *mc_solver_of(const dtx_transfer_params *prm)
{
    return prm->u.mc.solver == DTX_MC_SOLVER_NEWTON ? "Newton" : "Gauss-Newton";
}

const dtx_transfer_method dtx_method_multicomponent = {
    .name = "multicomponent",
    .kind = DTX_TRANSFER_MULTICOMPONENT,
    .iterative = 1,
    .solve_group = DTX_SP04_SOLVE_GROUP,
    .correspondence = DTX_TRANSFER_CORR_MULTICOMPONENT,
    .uses_pairs = 1,
    .multi_component_target = 1,
    .solver_name = "Gauss-Newton",
    .solver_of = mc_solver_of,
    .settings = mc_settings,
    .nsettings = (int)(sizeof mc_settings / sizeof *mc_settings),
    .plan_create = mc_method_create,
    .apply = mc_method_apply,
    .plan_free = mc_method_free,
    .describe = mc_method_describe,
};
