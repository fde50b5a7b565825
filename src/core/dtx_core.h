/*
 * dtx_core.h: the numeric core of dtx.  Pure functions on flat arrays; no
 * MPI, no HDF5, no files, no printing.  Sparse factorisations use CHOLMOD;
 * loops over frames use OpenMP.
 *
 * Conventions: V, X are n x 3 row-major doubles; F is nf x 3 int32, 0-based;
 * 3x3 matrices are 9 doubles, row-major.  Outputs are caller-allocated unless
 * a function says it allocates.  Functions are thread-safe on distinct
 * arguments unless stated otherwise.
 */
#ifndef DTX_CORE_H
#define DTX_CORE_H

#include "markers.h"
#include "mesh.h"
#include "status.h"

#include <stdint.h>

/* ------------------------------------------------------------------ */
/* Deformation gradients (deformation_gradients.c)                     */
/* ------------------------------------------------------------------ */

/* Per-triangle inverse of the rest frame V = [v2-v1, v3-v1, v4-v1] with the
 * fourth vertex v4 = v1 + n / sqrt(|n|), n = (v2-v1) x (v3-v1) (Sumner &
 * Popovic 2004, eq. 1).  Vinv: nf x 9.  A triangle whose area is below
 * eps_area (absolute, >= 0) or whose height is below 1e-4 of its longest
 * edge L (a needle; DTX_MESH_THIN_RATIO) gets the Tikhonov-regularised
 * inverse (M^T M + 1e-4 L^2 I)^-1 M^T instead, so that it stays bounded
 * whatever the thinness; the number of such triangles is returned (0 for a
 * clean mesh). */
int32_t dtx_frame_inverses(const double *V, const int32_t *F, int32_t nf, double eps_area,
                           double *Vinv);

/* Deformation gradients S_i = Vtilde_i * Vinv_i of the deformed positions X
 * (nv x 3) for every triangle; S: nf x 9.  The deformed fourth vertex is
 * built from X the same way.  A deformed triangle of zero area gives a
 * gradient whose normal column is zero (still finite). */
void dtx_deformation_gradients(const double *Vinv, const int32_t *F, int32_t nf, const double *X,
                               double *S);

/* Vertex-only gradient operator (Botsch et al. 2006): for each triangle the
 * three row vectors g1, g2, g3 (G: nf x 9, g_j at G[9f + 3j]) with
 * Xtilde-edge-matrix * pinv(E) = sum_j x_j g_j^T, pinv(E) = (E^T E)^-1 E^T,
 * E = [v2-v1, v3-v1].  Degenerate triangles (area < eps_area, or height
 * below 1e-4 of the longest edge L) get the regularised (E^T E + 1e-4 L^2
 * I)^-1 E^T instead (g = 0 when the triangle is a point) and are counted in
 * the return value. */
int32_t dtx_gradient_operator(const double *V, const int32_t *F, int32_t nf, double eps_area,
                              double *G);

/* ------------------------------------------------------------------ */
/* Spatial index (bvh.c)                                               */
/* ------------------------------------------------------------------ */

typedef struct dtx_bvh dtx_bvh;

/* Builds a bounding-volume hierarchy over the triangles (F, nf) of the
 * vertex positions X (nv x 3; kept by pointer, must outlive the tree), or,
 * with F == NULL, over the nf points X.  Returns NULL on allocation failure.
 * Queries are thread-safe. */
dtx_bvh *dtx_bvh_build(const double *X, const int32_t *F, int32_t nf);
void dtx_bvh_free(dtx_bvh **bvh);

/* Primitive filter for queries: returns non-zero when primitive `prim` may
 * be returned.  May be NULL (every primitive allowed). */
typedef int (*dtx_bvh_filter)(const void *ctx, int32_t prim);

/* Closest allowed primitive to p within max_dist (use INFINITY for no
 * limit).  Returns its index (or -1 if none) and the closest point (closest,
 * may be NULL) and squared distance (d2, may be NULL). */
int32_t dtx_bvh_closest(const dtx_bvh *bvh, const double p[3], double max_dist,
                        dtx_bvh_filter filter, const void *ctx, double closest[3], double *d2);

/* dtx_bvh_closest started from a guess: the allowed primitive `hint` (a
 * triangle or point index, or -1 for none; say the answer of a previous
 * query from a nearby point) bounds the search from the start, so far
 * fewer nodes are visited when it is close.  The answer is the same, bit
 * for bit, as dtx_bvh_closest's with any hint: the closest primitive, ties
 * to the lower index. */
int32_t dtx_bvh_closest_from(const dtx_bvh *bvh, const double p[3], double max_dist,
                             dtx_bvh_filter filter, const void *ctx, int32_t hint,
                             double closest[3], double *d2);

/* The tree's primitives (nf indices) in the order of its leaves, left to
 * right: neighbours in space are mostly neighbours in this order.  Queries
 * issued in the leaf order of a point tree over their positions touch the
 * queried tree's nodes in far fewer distinct places from one query to the
 * next (cache-friendly), whatever the order of the points.  Owned by the
 * tree. */
const int32_t *dtx_bvh_leaf_order(const dtx_bvh *bvh);

/* Closest point to p on triangle (a, b, c); returns the squared distance. */
double dtx_closest_point_triangle(const double p[3], const double a[3], const double b[3],
                                  const double c[3], double out[3]);

/* First allowed triangle hit by the ray o + t d with tmin < t < tmax (d
 * need not be unit length; t is in units of |d|), from either side.  Tree
 * over triangles only (returns -1 for a point set).  Returns the triangle
 * (-1 if none; ties in t go to the lower index) and, when non-NULL, its t
 * and the barycentric coordinates bary (of F[3f], F[3f+1], F[3f+2]) of the
 * hit point.  Moller-Trumbore intersection; thread-safe. */
int32_t dtx_bvh_raycast(const dtx_bvh *bvh, const double o[3], const double d[3], double tmin,
                        double tmax, dtx_bvh_filter filter, const void *ctx, double *t,
                        double bary[3]);

/* ------------------------------------------------------------------ */
/* Alignment (align.c)                                                 */
/* ------------------------------------------------------------------ */

/* Similarity transform x -> s R x + t that best maps the n points P onto Q
 * in least squares (Umeyama 1991; proper rotation).  R: 9, t: 3, s: 1. */
dtx_status dtx_similarity_fit(const double *P, const double *Q, int32_t n, double *R,
                              double *t, double *s, dtx_error *err);

/* Applies x -> s R x + t to n points in place. */
void dtx_similarity_apply(const double *R, const double *t, double s, double *X, int32_t n);

/* ------------------------------------------------------------------ */
/* Sumner-Popovic correspondence (correspondence.c)                    */
/* ------------------------------------------------------------------ */

typedef struct {
    double w_smooth;      /* E_S weight (paper: 1.0) */
    double w_identity;    /* E_I weight (paper: 0.001) */
    int n_closest;        /* number of closest-point phases after the first solve */
    double w_closest[16]; /* E_C weight of each phase */
    double max_distance;  /* closest-point and pairing threshold, fraction of the
                             target's size (dtx_rms_extent: rotation-invariant) */
    double max_angle_deg; /* normals must differ by less than this (paper: 90) */
    int align;            /* 1: similarity pre-alignment of the source on the markers */
    int closest_on;       /* where closest points lie: DTX_CORR_ON_SURFACE (default:
                             anywhere on the target's triangles) or
                             DTX_CORR_ON_VERTICES (target vertices only) */
    int closest_normals;  /* 1 (default): a closest point is valid only where the
                             target's normal is within max_angle_deg of the source
                             vertex's (the paper's rule); 0: any closest point */
    int weights;          /* DTX_CORR_WEIGHTS_ELEMENT (default): w_I per triangle and
                             w_C per vertex, as the paper writes the energy;
                             DTX_CORR_WEIGHTS_AREA: each triangle's E_I and each
                             vertex's E_C weighted by its share of the source's
                             area at DTX_CORR_REF_DENSITY (see correspondence.c) */
    int lowrank_max;      /* a phase at the factored phase's weight whose set of
                             vertices with a valid closest point differs from the
                             factored one's by at most this many vertices is
                             solved from the old factor by a low-rank correction
                             (default 200; 0: such phases refactorise, as before
                             issue 20; must be in [0, 100000]) */
} dtx_corr_params;

enum { DTX_CORR_ON_SURFACE = 0, DTX_CORR_ON_VERTICES = 1 };
enum { DTX_CORR_WEIGHTS_ELEMENT = 0, DTX_CORR_WEIGHTS_AREA = 1 };

/* Vertices per unit area (the target's size, dtx_rms_extent, being 1) at
 * which DTX_CORR_WEIGHTS_AREA weighs each term as the paper's per-element
 * sums do; the density of the paper's own cat (README, sp04 as implemented). */
#define DTX_CORR_REF_DENSITY 13500.0

/* The defaults (the paper's rules; the weights differ, see correspondence.c). */
void dtx_corr_params_default(dtx_corr_params *p);

typedef struct {
    int64_t npairs;
    int32_t *pairs;        /* npairs x 2: (source triangle, target triangle), owned;
                              sorted by target triangle then source triangle */
    double *deformed_src;  /* nv_s x 3: the source deformed onto the target, owned
                              (sp04; NULL from dtx_mc_correspond) */
    int32_t nv_src;
    double *deformed_tgt;  /* nv_t x 3: the target deformed into the source, owned
                              (dtx_mc_correspond; NULL from sp04) */
    int32_t nv_tgt;
    int32_t unmatched_tgt; /* sp04: target triangles that needed a fallback pairing;
                              multicomponent: orphan target triangles (in no pair) */
    int solves;            /* linear solves done */
    int factorizations;    /* numeric factorisations done: a phase whose matrix
                              is the factored one (same weight, same set of
                              valid closest points) reuses its factor, and so
                              does one where at most params->lowrank_max
                              vertices gained or lost their closest point
                              (low-rank correction) */
    double fit_rms;        /* RMS distance (fraction of target diagonal) of the
                              deformed source vertices to the target surface */
} dtx_corr;

/* Deforms the source onto the target (markers, smoothness, identity and
 * closest valid point terms with increasing weight), then pairs triangles
 * by centroid distance and normals in both directions.  Every target
 * triangle ends in at least one pair.  Uses OpenMP for closest-point
 * queries; deterministic for any thread count. */
dtx_status dtx_sp04_correspond(const dtx_mesh *src, const dtx_mesh *tgt,
                               const dtx_markers *markers, const dtx_corr_params *params,
                               dtx_corr *out, dtx_error *err);
void dtx_corr_free(dtx_corr *c);

/* Zhou et al. 2010, section 2.2 (correspondence_mc.c): deforms the target
 * into the source (markers, E_S, E_I, closest valid points on the source,
 * and E_R over the target's proximity pairs, built with eps_factor as in
 * proximity.h), then pairs each target triangle that touches a marker or a
 * vertex with a valid closest point with the source triangle of nearest
 * barycenter; the other target triangles stay unpaired (orphans, counted
 * in unmatched_tgt).  out->deformed_tgt gets the deformed target,
 * deformed_src stays NULL; fit_rms is the RMS distance of the deformed
 * target to the source surface.  Same parameters as dtx_sp04_correspond,
 * except that weights are always per element (prm->weights is ignored);
 * deterministic for any thread count. */
dtx_status dtx_mc_correspond(const dtx_mesh *src, const dtx_mesh *tgt,
                             const dtx_markers *markers, const dtx_corr_params *params,
                             double eps_factor, dtx_corr *out, dtx_error *err);

/* ------------------------------------------------------------------ */
/* Sumner-Popovic transfer (transfer_sp04.c)                           */
/* ------------------------------------------------------------------ */

typedef enum {
    DTX_ANCHOR_FIXED = 0,  /* result centroid = target rest centroid */
    DTX_ANCHOR_FOLLOW = 1, /* result centroid = rest centroid + scaled source
                              centroid displacement */
    DTX_ANCHOR_PINS = 2    /* pinned vertices only */
} dtx_anchor;

typedef struct dtx_sp04_plan dtx_sp04_plan;

/* Frames are transferred in groups of this many (the SIMD lanes of one
 * pass over the operators and one back-substitution with 3 x 8 right-hand
 * sides).  Every frame gets the same arithmetic whatever its place in a
 * group, so splitting a sequence anywhere gives the same bits; splits at
 * multiples of it (ranks, blocks) also leave no partly filled group. */
#define DTX_SP04_SOLVE_GROUP 8

/* Precompute: builds the target's normal equations sum_pairs G_t^T G_t,
 * removes the anchor/pinned vertices and factors it once (CHOLMOD, kept as
 * a simplicial L D L^T), and the per-pair operators of the right-hand side
 * and of the residual.  pairs: npairs x 2 (source triangle, target
 * triangle), 0 <= npairs <= INT32_MAX.  pins: npins vertex indices with
 * positions pin_pos (npins x 3); used when anchor == DTX_ANCHOR_PINS
 * (npins >= 1) and also honoured with the other anchors (then the centroid
 * is not adjusted).  Fails with DTX_ERANGE for out-of-range pairs or pins,
 * DTX_EMESH if the target has more than one connected component (the
 * message points at the multicomponent method), DTX_ESOLVE if the system
 * cannot be factored, DTX_ENOMEM.  The plan copies what it needs (src, tgt
 * and pairs may be freed afterwards). */
dtx_status dtx_sp04_plan_create(const dtx_mesh *src, const dtx_mesh *tgt, const int32_t *pairs,
                                int64_t npairs, dtx_anchor anchor, const int32_t *pins,
                                const double *pin_pos, int32_t npins, dtx_sp04_plan **plan,
                                dtx_error *err);
void dtx_sp04_plan_free(dtx_sp04_plan **plan);

/* Apply: transfers nframes source frames Xs (nframes x nv_s x 3) to
 * target frames Xt (nframes x nv_t x 3, caller-allocated).  residual
 * (nframes, may be NULL) gets per frame sqrt(E / npairs), E the minimised
 * energy: the sum over pairs of ||S_s - T_t||_F^2 in the target triangle's
 * plane (the paper's energy with the optimal fourth vertex); it is NaN for
 * a frame with non-finite positions, and no other frame is affected.
 * Frames go in groups of DTX_SP04_SOLVE_GROUP, OpenMP threads taking whole
 * groups; per-thread scratch is allocated on the first call (and again when
 * the thread count grows), never per frame.  Results are bitwise the same
 * whatever the thread count, the kernel variant and the way frames are
 * split into calls.  Fails only with DTX_ENOMEM (scratch).  Not thread-safe
 * on one plan (it owns the scratch). */
dtx_status dtx_sp04_apply(dtx_sp04_plan *plan, int64_t nframes, const double *Xs, double *Xt,
                          double *residual, dtx_error *err);

/* For callers that deal the groups to threads themselves (a team of
 * threads that also has other work, such as I/O): dtx_sp04_plan_workers
 * makes the per-thread scratch of apply, one workspace per thread of the
 * calling context (omp_get_max_threads(), 1 without OpenMP); not
 * thread-safe, call it before the parallel region; fails only with
 * DTX_ENOMEM.  Then dtx_sp04_apply_group transfers one group of nfr (1 ..
 * DTX_SP04_SOLVE_GROUP) frames Xs (nfr x nv_s x 3) into Xt (nfr x nv_t x 3)
 * and residual (nfr, may be NULL) on workspace `worker` (0 <= worker <
 * the count above); calls on distinct workspaces may run at once on one
 * plan.  The bits are those of dtx_sp04_apply on the same frames. */
dtx_status dtx_sp04_plan_workers(dtx_sp04_plan *plan, dtx_error *err);
void dtx_sp04_apply_group(dtx_sp04_plan *plan, int worker, int64_t nfr, const double *Xs,
                          double *Xt, double *residual);

/* Sizes of the plan, for callers that allocate buffers. */
int32_t dtx_sp04_plan_nv_src(const dtx_sp04_plan *plan);
int32_t dtx_sp04_plan_nv_tgt(const dtx_sp04_plan *plan);

/* Benchmark hook: seconds per frame of a bare CHOLMOD back-substitution
 * (3 right-hand sides, cholmod_solve2 with reused workspace) on the plan's
 * factor, averaged over nrep solves (the reference dtx_sp04_apply is
 * measured against; apply does its own back-substitutions).  For
 * scripts/bench.sh; -1 when out of memory. */
double dtx_sp04_plan_bare_solve_seconds(dtx_sp04_plan *plan, int nrep);

/* As dtx_sp04_plan_bare_solve_seconds with frames_per_solve frames (3 x
 * frames_per_solve right-hand sides) per cholmod_solve2 call; returns
 * seconds per frame, or -1 for frames_per_solve < 1 or out of memory. */
double dtx_sp04_plan_bare_solve_seconds_group(dtx_sp04_plan *plan, int frames_per_solve,
                                              int nrep);

/* Kernel variant of dtx_sp04_apply: with on != 0 the AVX2 variant when the
 * build has it (x86-64, GCC or Clang) and the CPU supports it (the default),
 * else the baseline one.  Both give bitwise the same results; for tests and
 * benchmarks.  Returns 1 when the AVX2 variant is now in use.  Not
 * thread-safe with a concurrent apply on the same plan. */
int dtx_sp04_plan_use_avx2(dtx_sp04_plan *plan, int on);

/* Seconds the factorisation took (analyze + factorize). */
double dtx_sp04_plan_factor_seconds(const dtx_sp04_plan *plan);

/* ------------------------------------------------------------------ */
/* Multi-component transfer (transfer_mc.c; Zhou et al. 2010, 2.3)     */
/* ------------------------------------------------------------------ */

/* How E3 measures a proximity pair's length change (transfer_mc.c):
 *  RELATIVE: (|x_i - x_j| - l) / l, l floored at a tenth of the target's
 *    mean edge, each pair's square divided by the mean number of pairs at
 *    its two ends (so every vertex in pairs carries about one unit of
 *    weight, whatever the pair density); scale-free like E1.  The default,
 *    with w_proximity 3.
 *  DIAGONAL: the paper's absolute (|x_i - x_j| - l)^2, lengths in units of
 *    the target's bounding-box diagonal; the paper's w_proximity is 0.1
 *    (DTX_MC_W_PROXIMITY_DIAGONAL). */
typedef enum { DTX_MC_LENGTHS_RELATIVE = 0, DTX_MC_LENGTHS_DIAGONAL = 1 } dtx_mc_lengths;
#define DTX_MC_W_PROXIMITY_DIAGONAL 0.1

/* How a frame is solved (transfer_mc.c):
 *  FIXED_POINT: the fixed-point iteration on the factored matrix with
 *    Anderson acceleration; an iteration is one back-substitution.  The
 *    default.
 *  NEWTON: Newton steps on the full energy in a trust region, each solved
 *    by conjugate gradients preconditioned with the factored matrix (up to
 *    40 back-substitutions a step); converges where pieces slide against
 *    each other, at several times the fixed-point iteration's cost a
 *    frame. */
typedef enum { DTX_MC_SOLVER_FIXED_POINT = 0, DTX_MC_SOLVER_NEWTON = 1 } dtx_mc_solver;

typedef struct {
    double w_match;     /* E1, matched gradients [1] */
    double w_orphan;    /* E2, orphan-triangle smoothness over one-rings [1] */
    double w_proximity; /* E3, proximity-pair lengths kept [3; 0.1 for DIAGONAL] */
    dtx_mc_lengths lengths; /* E3's measure of a length change [RELATIVE] */
    double w_laplacian; /* E4, Laplacian-coordinate lengths of orphan components [1] */
    double eps_factor;  /* proximity threshold: this x a component's longest edge [1.5] */
    int max_iter;       /* iterations (NEWTON: the first solve and the Newton steps)
                           per frame at most; 0: the solver's default
                           (DTX_MC_MAX_ITER_FIXED_POINT or _NEWTON) [0] */
    double tol;         /* stop when the last step (NEWTON: the Newton step, an
                           estimate of the distance to the minimiser) moves no
                           vertex more than this x the target's bounding-box
                           diagonal [1e-6] */
    dtx_mc_solver solver; /* [FIXED_POINT] */
} dtx_mc_params;

/* max_iter's defaults. */
#define DTX_MC_MAX_ITER_FIXED_POINT 30
#define DTX_MC_MAX_ITER_NEWTON 100

/* The paper's values, except E3's measure (RELATIVE, weight 3). */
void dtx_mc_params_default(dtx_mc_params *p);

/* What a plan found in the target (for summaries). */
typedef struct {
    int32_t components;        /* connected components (vertices in faces) */
    int32_t proximity_edges;   /* edges of the proximity graph */
    int64_t proximity_pairs;   /* vertex pairs whose distances E3 keeps */
    int32_t orphan_triangles;  /* target triangles in no pair */
    int32_t orphan_components; /* components with no paired triangle */
    double factor_seconds;     /* analyse + factorise */
} dtx_mc_info;

typedef struct dtx_mc_plan dtx_mc_plan;

/* Precompute: the target's proximity graph (proximity.h), the orphan
 * triangles and components implied by pairs (npairs x 2, source triangle,
 * target triangle; a target triangle in no pair is an orphan), and the
 * factorisation of the Gauss-Newton matrix, which is the same for every
 * iteration and frame.  anchor, pins, pin_pos, npins as for
 * dtx_sp04_plan_create.  Any number of components (one included: with every
 * triangle paired the result is sp04's).  Fails with DTX_EINVAL (params),
 * DTX_ERANGE (pairs, pins), DTX_ESOLVE (a vertex no term reaches),
 * DTX_ENOMEM.  The plan copies what it needs. */
dtx_status dtx_mc_plan_create(const dtx_mesh *src, const dtx_mesh *tgt, const int32_t *pairs,
                              int64_t npairs, const dtx_mc_params *prm, dtx_anchor anchor,
                              const int32_t *pins, const double *pin_pos, int32_t npins,
                              dtx_mc_plan **plan, dtx_error *err);
void dtx_mc_plan_free(dtx_mc_plan **plan);
void dtx_mc_plan_info(const dtx_mc_plan *plan, dtx_mc_info *info);
int32_t dtx_mc_plan_nv_src(const dtx_mc_plan *plan);
int32_t dtx_mc_plan_nv_tgt(const dtx_mc_plan *plan);

/* One frame's Gauss-Newton iterations. */
typedef struct {
    int32_t iterations; /* solves done (0 for a frame with non-finite input) */
    int32_t converged;  /* 1 when the last step moved no vertex more than tol x
                           the diagonal (or the problem was linear); 0 when
                           max_iter ran out */
} dtx_mc_frame_info;

/* Apply: as dtx_sp04_apply (Xs: nframes x nv_s x 3 in, Xt: nframes x nv_t x
 * 3 out, residual: nframes or NULL, sqrt(E / npairs) of the final iterate
 * with E the whole energy, NaN for a non-finite frame), plus info (nframes
 * or NULL): each frame's Gauss-Newton iterations.  OpenMP
 * threads take whole frames; a frame's result does not depend on the thread
 * count or the split into calls.  Fails only with DTX_ENOMEM.  Not
 * thread-safe on one plan. */
dtx_status dtx_mc_apply(dtx_mc_plan *plan, int64_t nframes, const double *Xs, double *Xt,
                        double *residual, dtx_mc_frame_info *info, dtx_error *err);

#endif /* DTX_CORE_H */
