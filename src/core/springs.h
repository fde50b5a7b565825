/*
 * springs.h: deformation transfer by stretchiness ratios on mass-spring
 * systems (Yang, Ma & Ouhyoung, "Deformation Transfer based on Stretchiness
 * Ratio"), with a multigrid start, inversion reports and, beyond the paper,
 * targets whose connectivity differs from the source's (through a proxy).
 *
 * The method.  Springs join the vertex pairs of the solve mesh: every edge,
 * a bending spring across every interior edge (the two vertices opposite
 * it) and internal springs through the volume (see dtx_springs_build).  A
 * spring e has reference lengths r_S (source rest), r_T (target rest) and,
 * per frame, r_S~ (deformed source); the target's rest length in the frame
 * is r_T~ = r_T * r_S~ / r_S (the stretchiness ratio is transferred), the
 * stiffness k = 1 / r_T, and the result is the equilibrium of
 *     E(x) = sum_e k_e (|x_i - x_j| - r_T~_e)^2,
 * found by Newton with a backtracking line search, started from the sp04
 * transfer of the same frame (or from the solution of the same problem on
 * a coarsened hierarchy of the mesh), with an orientation barrier that no
 * triangle the start has right side up can cross (beyond the paper, whose
 * stated limitation is element inversion).  E fixes a result only up to a
 * rigid motion; see dtx_springs_apply for how it is placed.
 *
 * Same connectivity (the paper's setting): source and target have the same
 * vertices and faces (registered meshes); the solve mesh is the target.
 * Different connectivity: give a proxy, the source mesh deformed into the
 * target's shape (dtx_corr.deformed_src from dtx_sp04_correspond); the solve
 * mesh is then the source's connectivity at the proxy's positions (r_T
 * measured on the proxy), and each target vertex follows the solved proxy
 * through its closest point on it (barycentric coordinates plus its offset
 * in the triangle's orthonormal frame).
 *
 * Conventions as in dtx_core.h: positions are n x 3 row-major doubles, faces
 * nf x 3 int32, 0-based; outputs caller-allocated unless stated.  Sparse
 * factorisations use CHOLMOD, loops over frames OpenMP.
 */
#ifndef DTX_SPRINGS_H
#define DTX_SPRINGS_H

#include "dtx_core.h"

#include <stdint.h>

/* ------------------------------------------------------------------ */
/* Spring networks                                                     */
/* ------------------------------------------------------------------ */

/* Kinds of springs, in the order of precedence when two constructions give
 * the same vertex pair (the pair is kept once, with the lower kind). */
typedef enum {
    DTX_SPRING_EDGE = 0,     /* a mesh edge */
    DTX_SPRING_BENDING = 1,  /* the two vertices opposite an interior edge */
    DTX_SPRING_INTERNAL = 2, /* through the volume (or, on coarse levels, any
                                spring mapped from one) */
    DTX_SPRING_KINDS = 3
} dtx_spring_kind;

typedef struct {
    int32_t n;                       /* springs */
    int32_t *ends;                   /* n x 2 vertex pairs (i < j), sorted by (i, j); owned */
    unsigned char *kind;             /* n: dtx_spring_kind of each; owned */
    int32_t count[DTX_SPRING_KINDS]; /* springs of each kind */
} dtx_spring_set;

/* The springs of the mesh (V: nv x 3, F: nf x 3), which must pass
 * dtx_mesh_validate:
 *   - edge springs: every edge of a face;
 *   - bending springs (bending != 0): for every edge shared by exactly two
 *     faces, the two vertices opposite it (when distinct);
 *   - internal springs (internal != 0): from every vertex v in a face, a ray
 *     along the inward area-weighted vertex normal (inward: against the
 *     normal when the mesh's signed volume is positive, with it otherwise)
 *     is cast through the mesh (dtx_bvh_raycast), skipping v's own faces;
 *     the first triangle hit is kept only if the ray leaves through it
 *     (reaches it from its back side: a closed, consistently oriented
 *     surface), and v is joined to the vertex of that triangle nearest to
 *     the hit point, unless that spring would be shorter than the mean
 *     length of v's edges (it would add nothing the bending springs do not
 *     give) or is v itself.
 * Pairs found twice are kept once.  Deterministic for any thread count
 * (OpenMP over the rays).  Returns DTX_ENOMEM on allocation failure (*out
 * then empty).  Free with dtx_spring_set_free. */
dtx_status dtx_springs_build(const double *V, int32_t nv, const int32_t *F, int32_t nf, int bending,
                             int internal, dtx_spring_set *out, dtx_error *err);
void dtx_spring_set_free(dtx_spring_set *s);

/* ------------------------------------------------------------------ */
/* Transfer                                                            */
/* ------------------------------------------------------------------ */

/* Coarse levels of the multigrid start at most. */
#define DTX_SPRINGS_MAX_LEVELS 8

/* How each frame's Newton solve is started (see dtx_springs_apply). */
typedef enum {
    DTX_SPRINGS_START_LINEAR = 0, /* rotation-aware linear start on every level,
                                     anchored to the coarser level's solution */
    DTX_SPRINGS_START_REST = 1,   /* the paper's: rest shape on the coarsest level,
                                     the coarser solution prolongated on the others */
    DTX_SPRINGS_START_SP04 = 2    /* the sp04 transfer of the same frame onto the
                                     solve mesh, on the fine level only (levels is
                                     not used) */
} dtx_springs_start;

typedef struct {
    int bending;             /* bending springs [1] */
    int internal;            /* internal springs [1] */
    int levels;              /* coarse levels of the multigrid start at most,
                                0 .. DTX_SPRINGS_MAX_LEVELS; 0 solves on the fine
                                level only (started as `start` says) [4] */
    int32_t coarse_min;      /* a coarser level is made only when it keeps at least
                                this many vertices (and at most 0.8 of the finer
                                level's) [150] */
    int max_iter;            /* Newton iterations on the fine level at most [100] */
    double tol;              /* the fine level stops when a full Newton step moves
                                no vertex by more than tol x the bounding-box
                                diagonal (or lowers the energy
                                by less than 1e-10 of it) [1e-8] */
    int coarse_max_iter;     /* Newton iterations on each coarse level at most [50] */
    double coarse_tol;       /* as tol, on the coarse levels [1e-5] */
    dtx_springs_start start; /* [DTX_SPRINGS_START_SP04] */
    int barrier;             /* with the sp04 start: keep every solve-mesh
                                triangle that the start has right side up
                                from turning over (see dtx_springs_apply);
                                not used with the other starts [1] */
    double damping;          /* mu = damping x the mean diagonal of the spring
                                Hessian is added to its diagonal, so that it is
                                positive definite despite the rigid motions [1e-10] */
} dtx_springs_params;

/* The defaults above. */
void dtx_springs_params_default(dtx_springs_params *p);

/* What a plan built (for summaries). */
typedef struct {
    int32_t springs[DTX_SPRING_KINDS]; /* fine-level springs of each kind (kept) */
    int32_t dropped;                   /* springs dropped because their length is
                                          (near) zero in the source or target rest
                                          shape (below 1e-12 of the diagonal) */
    int levels;                        /* levels of the hierarchy, the fine one included */
    int32_t level_vertices[DTX_SPRINGS_MAX_LEVELS + 1]; /* [0] fine, then coarser */
    int32_t level_springs[DTX_SPRINGS_MAX_LEVELS + 1];
    int64_t factor_nnz;   /* entries of the fine level's factor */
    int supernodal;       /* 1 when the fine factor is supernodal */
    int proxy;            /* 1 when the target follows a proxy */
    double proxy_rms;     /* proxy only: RMS distance of the target
                             vertices from the proxy surface, fraction
                             of the target diagonal */
    double setup_seconds; /* dtx_springs_plan_create's wall time */
} dtx_springs_info;

/* Per frame, from dtx_springs_apply. */
typedef struct {
    int32_t iterations;        /* Newton steps on the fine level (one numeric
                                  factorisation each; more when one with part of
                                  the exact Hessian was tried and found
                                  indefinite) */
    int32_t factorizations;    /* numeric factorisations on the fine level, the
                                  failed ones included (the cost of a frame) */
    int32_t coarse_iterations; /* on the coarse levels, summed */
    int32_t converged;         /* 1 when the fine level met its stopping test; 0 when
                                  max_iter ran out, the line search stalled or
                                  (with the barrier) no shift of the Hessian could
                                  be factored; the iterate is kept then */
    double energy_start;       /* E at the start of the fine level */
    double energy;             /* E of the result (length units) */
    double residual;           /* sqrt(E / sum_e k_e r_T~_e^2): the RMS relative error of
                                  the spring lengths; NaN for a non-finite frame */
    double grad_norm;          /* Euclidean norm of the gradient of the fine level's
                                  energy (springs and barrier) at the result; NaN
                                  for a non-finite frame */
    int32_t barrier_skipped;   /* solve-mesh triangles the start has inverted
                                  (under the unfolding penalty, not the barrier,
                                  until they are right side up) */
    int32_t inverted;          /* target triangles that are inverted (see
                                  dtx_springs_apply) */
    int32_t first_inverted;    /* the lowest of them, -1 if none */
} dtx_springs_frame_info;

typedef struct dtx_springs_plan dtx_springs_plan;

/* Precompute, once per target: the springs (on the target, or on the proxy),
 * their reference lengths, the multigrid hierarchy, every level's Hessian
 * pattern and its symbolic factorisation (CHOLMOD analyse, kept; each Newton
 * step only refactors numerically), and with a proxy the binding of every
 * target vertex to it.
 *
 * proxy: NULL when src and tgt share their connectivity (same vertex and
 * face counts, same faces), else src->nv x 3 positions: the source deformed
 * into the target's shape (dtx_corr.deformed_src).  anchor, pins, pin_pos,
 * npins as for dtx_sp04_plan_create: pinned target vertices are held at
 * pin_pos in the solve (not with a proxy: DTX_EINVAL).
 *
 * Fails with DTX_EINVAL (parameters, pins with a proxy, DTX_ANCHOR_PINS
 * without pins), DTX_EMESH (different connectivity without a proxy: the
 * message says where they differ and what to pass), DTX_ERANGE (pins),
 * DTX_ENONFINITE (a proxy position), DTX_ESOLVE (the symbolic analysis
 * failed), DTX_ENOMEM.  src and tgt must pass dtx_mesh_validate.  The plan
 * copies what it needs.  Uses OpenMP for the rays and the binding;
 * deterministic for any thread count. */
dtx_status dtx_springs_plan_create(const dtx_mesh *src, const dtx_mesh *tgt, const double *proxy,
                                   const dtx_springs_params *prm, dtx_anchor anchor,
                                   const int32_t *pins, const double *pin_pos, int32_t npins,
                                   dtx_springs_plan **plan, dtx_error *err);
void dtx_springs_plan_free(dtx_springs_plan **plan);
void dtx_springs_plan_info(const dtx_springs_plan *plan, dtx_springs_info *info);
int32_t dtx_springs_plan_nv_src(const dtx_springs_plan *plan);
int32_t dtx_springs_plan_nv_tgt(const dtx_springs_plan *plan);

/* Apply: transfers nframes source frames Xs (nframes x nv_s x 3) to target
 * frames Xt (nframes x nv_t x 3, caller-allocated); info (nframes entries,
 * may be NULL) gets each frame's figures.
 *
 * Starts.  Each level (coarsest first) is solved by Newton from a start
 * computed from that frame alone, never from another frame's solution, so a
 * frame's result does not depend on the thread count or on how the sequence
 * is split into calls; OpenMP threads take whole frames.  R_s is the rotation
 * that best maps the source rest shape onto the frame (Horn's quaternion
 * method, centroids removed).
 *   DTX_SPRINGS_START_LINEAR: the level's rest shape turned by R_s, then the
 *     least-squares fit of every spring to its rest vector turned by the
 *     source's local rotations at its ends and scaled by its stretch ratio
 *     (one linear solve); on a finer level each representative of the
 *     coarser one is also softly anchored to the coarser solution.
 *   DTX_SPRINGS_START_REST (the paper's scheme): the coarsest level from its
 *     rest shape turned by R_s; each finer level from the coarser solution,
 *     every vertex moving with the rigid transforms of its cluster and of
 *     the neighbouring clusters (each turned by the rotation that best fits
 *     its coarse neighbourhood), blended by inverse distance.
 *   DTX_SPRINGS_START_SP04 (default): the sp04 transfer of the frame onto
 *     the solve mesh (every triangle paired with itself; one sp04 apply for
 *     all the frames of the call, whose results do not depend on the split),
 *     solved on the fine level only.  Needs a solve mesh of one connected
 *     component (dtx_springs_plan_create fails with DTX_EMESH otherwise).
 * The energy has local minima (element inversion, the paper's stated
 * limitation): different starts can end in different ones; the inverted
 * triangles of each result are counted and reported.
 *
 * Barrier (prm->barrier with the sp04 start).  Every solve-mesh triangle t
 * that the start has right side up (oriented area a_t = m_t . (x_b - x_a)
 * x (x_c - x_a) > 0, m_t its rest unit normal turned by its source
 * triangle's rotation, as inversions are counted) gets the term
 * 0.1 sqrt(A_t) b(s / h), s = a_t / A_t, b(u) = (1 - u)^3 / u (C2, convex,
 * growing like 1 / u so that compressed springs cannot squeeze a triangle
 * to a near-zero area, where the Hessian would no longer factor) below h =
 * 0.1 min(1, the source triangle's area ratio), 0 above, +inf at s <= 0;
 * the line search, which accepts only decreases, therefore never folds
 * one.  The barrier is zero wherever a triangle keeps a tenth of the area
 * its source triangle keeps, so the equilibrium changes only where a
 * triangle would otherwise fold (T = S still gives S~ exactly).  The
 * orientation is the start's: Newton's steps have no rigid part (they
 * minimise the quadratic model under that constraint), and the result is
 * not turned (placement below).  Triangles the start already has folded
 * (reported: barrier_skipped) get an unfolding penalty instead, 10 sqrt(A_t)
 * (1 - s / h)^2 below h (finite on both sides of 0, so Newton can turn
 * them over), and join the barrier once s reaches h / 2.  Newton stops
 * when a full step moves no vertex by more than tol x the diagonal, or
 * lowers the energy by less than 1e-10 of it (the energy test of L-BFGS-B,
 * whose default is 2.2e-9; where the minimum is degenerate the steps
 * shrink only linearly while the energy no longer changes).  Newton uses
 * the Hessian with a share theta in [0, 1] of its indefinite part (the
 * compressed springs' and the barrier's): 0 (projected, positive definite)
 * far from the solution, doubled after each small full step up to the
 * exact Hessian, reduced when a factorisation fails or a step is cut;
 * after a failure it is kept at or below half the failed share for 4
 * steps (near a degenerate minimum the exact Hessian fails step after
 * step, each failure costing up to three factorisations).
 *
 * Placement.  Without pins the result (not with the sp04 start, which
 * keeps sp04's orientation) is turned so that it best fits R_s applied to
 * the target rest shape (so T = S gives S~ and T = s S gives
 * s S~, up to a translation), then translated like sp04's: its centroid is
 * the target rest centroid (DTX_ANCHOR_FIXED) or follows the source's
 * (DTX_ANCHOR_FOLLOW, scaled by the ratio of the diagonals).  With pins the
 * start is fitted rigidly to the pins (at least 3 not collinear; fewer:
 * translated onto their centroid) and the pins are held in the Newton
 * solve.  Vertices in no face keep their rest offset from the centroid of
 * the others, turned by R_s.
 *
 * Inversions.  A target triangle t counts as inverted when its normal makes
 * an angle of 90 degrees or more with its rest normal turned by its driving
 * source triangle's rotation (the rotation taking the source triangle's rest
 * frame (e1/|e1|, n x e1/|e1|, n) to its deformed one); the driving triangle
 * is t itself with the same connectivity, else the proxy (= source) triangle
 * nearest to t's centroid.  Triangles with a zero rest normal are not
 * counted.  They are counted in the solve's frame (before the placement's
 * turn).  With a proxy the solution is carried to the target by sp04 from
 * the proxy onto the target, every target triangle paired with its driving
 * triangle (one factorisation in the plan, one apply for all the frames of
 * the call): each target triangle follows its proxy triangle's deformation
 * gradient in the least-squares sense, so target triangles bound to proxy
 * triangles that turn differently still meet without folding.  (A target
 * of several connected components, which sp04 refuses, keeps the binding:
 * each vertex at its closest point on the proxy plus its offset in that
 * triangle's frame.)  The barrier on the proxy does not cover the target's
 * triangles: dtx_springs_count_inverted counts them on any result (sp04's,
 * say) for comparison.
 *
 * A frame with a non-finite source position gives NaN positions, a NaN
 * energy and residual, and affects no other frame.  Fails only with
 * DTX_ENOMEM (workspaces, allocated on the first call and when the thread
 * count grows; a frame whose factorisation runs out of memory gets NaN).
 * Not thread-safe on one plan. */
dtx_status dtx_springs_apply(dtx_springs_plan *plan, int64_t nframes, const double *Xs, double *Xt,
                             dtx_springs_frame_info *info, dtx_error *err);

/* The target triangles of y (nv_t x 3, any target frame in the solve's
 * orientation, e.g. sp04's result for source frame xs) that count as
 * inverted against source frame xs (nv_s x 3) by the test above: a
 * reference for the counts in dtx_springs_frame_info.  Thread-safe. */
int32_t dtx_springs_count_inverted(const dtx_springs_plan *plan, const double *xs, const double *y);

#endif /* DTX_SPRINGS_H */
