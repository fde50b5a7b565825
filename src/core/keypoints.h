/*
 * keypoints.h: automatic key-point selection (Yang, Gao, Lai, Rosin & Xia
 * 2018, section 3.5 and Algorithm 1).
 *
 * Given a source rest mesh A and deformed frames A'_1..A'_n, find a small set
 * S of vertices (key points) such that skinning A with one affine map per key
 * point (biharmonic weights, clustered ARAP fit: skinning.h, bbw.h)
 * reproduces every frame closely.  Candidates C are nc vertices from
 * farthest point sampling (dtx_farthest_points); then
 *
 *   stage 1 (add):     S = {c_1}; repeat: add the candidate that gives the
 *                      smallest error, until the error is <= eps or S has
 *                      max_keys points or C is used up;
 *   stage 2 (replace): for each key point in turn, replace it by the
 *                      candidate that gives the smallest error if that is
 *                      smaller than the current error; sweep until a whole
 *                      sweep changes nothing (or max_sweeps sweeps).
 *
 * The error of a set S.  Every frame is fitted (dtx_skin_fit_frames: lambda
 * E_arap + E_diff, one rotation per cluster, as many clusters as key
 * points), the fitted mesh q is compared with the frame q', and
 *
 *   error(S) = mean over frames and vertices of |q_i - q'_i| / R,
 *
 * R the radius of the rest mesh about its bounding-box centre: the paper
 * scales the models into the unit sphere and uses eps = 0.03.  (The paper
 * writes the Frobenius norm of the whole frame divided by the vertex count,
 * which shrinks with the mesh size; its plot of the same quantity is the
 * mean vertex distance, which is what dtx uses.)
 *
 * Exact and fast evaluation.  The paper re-solves everything for each
 * candidate: bounded biharmonic weights of S + {c} (one quadratic
 * programme per key point) and a k-means clustering of [W, rotation and
 * stretch features].  dtx by default (exact = 0) uses
 *  - the unbounded biharmonic weights of S + {c}, obtained exactly from the
 *    factorisation kept for S by a rank-one update (one back-substitution
 *    per candidate; dtx_bbw_incr_weights_add / _replace), clamped to [0, 1]
 *    and renormalised (dtx_bbw_clamp_normalise) as an approximation of the
 *    bounded weights; and
 *  - one clustering per round (per step of stage 1, per key point of stage
 *    2) computed from the weights of the set the round starts from, with
 *    |S| + 1 clusters when adding and |S| when replacing, shared by every
 *    candidate of the round.
 * The fast mode's fits and errors come from dtx_skin_eval_error (the
 * frames centred, their starting rotations and the clusters' covariance
 * map set up once per round; per candidate three BLAS products and the
 * local/global iterations), the same mathematics as the exact mode's
 * dtx_skin_fit_create + dtx_skin_fit_frames + dtx_skin_apply up to
 * rounding.  A candidate's Green's function depends on the set only, so it
 * is kept from one round to the next until the set changes (at most
 * 2^25 doubles of cache; dtx_bbw_incr_green).
 * exact = 1 does what the paper does (bounded weights, dtx_bbw, and a
 * clustering per candidate); it is for measuring how far the fast path
 * moves the chosen points and errors (tests/bench/bench_keypoints.c).
 * Whatever the mode, the final set's error is also reported with bounded
 * weights and its own clustering (final_error_exact).
 *
 * Parallelism and reproducibility.  Candidates of a round are evaluated in
 * parallel over OpenMP threads; across processes, the round's candidates
 * not in the set, numbered j = 0, 1, ... in index order, are evaluated by
 * the part j % part_count == part_index, and `reduce` (given
 * by the caller, e.g. an MPI_Allreduce with MPI_MIN) combines the parts'
 * error arrays (entries not evaluated by a part are +INFINITY).  Every
 * candidate's error is computed by one thread in a fixed way, and the best
 * candidate is the smallest error with ties to the lowest candidate index,
 * so the selection is bitwise the same for any number of threads and parts.
 * The candidates' Green's functions (fast mode) are solved once over the
 * parts, shared out like the candidates, and put together through reduce
 * (one solve from the same factor whichever part runs it).
 * The final set's bounded weights (error_exact, weights) are shared out
 * over the parts by handle (in fixed blocks, or as the parts ask for them
 * through claim) and put together through reduce, bitwise as one part
 * computes them.
 *
 * No printing; thread-safe (no shared state).
 */
#ifndef DTX_KEYPOINTS_H
#define DTX_KEYPOINTS_H

#include "bbw.h"
#include "mesh.h"
#include "skinning.h"
#include "status.h"

#include <stdint.h>

/* Combines the error arrays of all parts: on return err[0..n-1] holds, at
 * every part, the element-wise minimum over the parts.  (The selection
 * also gathers the final set's weight rows through it: then n is nv x m,
 * more than the candidates.)  Returns DTX_OK or an error (with e filled),
 * which stops the selection at every part.
 *
 * Every part calls it at the same points, so that a part that fails on its
 * own (out of memory) cannot leave the others waiting: it then makes one
 * more call with local_ok = 0 (errs NULL, n 0) and stops, and the function
 * must first combine local_ok over the parts (logical and) and, when any
 * part passed 0, return an error at every part without exchanging errs.
 * After the last round every part also makes a closing call (errs NULL,
 * n 0, local_ok 1), which a failing part's call meets. */
typedef dtx_status (*dtx_kp_reduce_fn)(void *ctx, double *errs, int32_t n, int local_ok,
                                       dtx_error *e);

typedef struct {
    int32_t candidates; /* nc, farthest-point samples (paper: 100); >= 1 */
    double eps;         /* stop adding at this error (paper: 0.03); >= 0 */
    int32_t max_keys;   /* at most this many key points (default 40); >= 1 */
    int max_sweeps;     /* stage-2 sweeps at most (default 10); 0 skips stage 2 */
    int exact;          /* 0: fast evaluation (see above); 1: the paper's */
    dtx_skin_params skin; /* lambda, gammas, k-means and fit settings; nclusters
                             and threads are set by the selection */
    int threads;        /* OpenMP threads for the candidates (0: default) */
    int part_index, part_count; /* this process's share of the candidates */
    dtx_kp_reduce_fn reduce;    /* NULL when part_count == 1 */
    void *reduce_ctx;
    /* Several parts: NULL to split the final set's bounded weights into
     * fixed blocks of handles, one per part; else the handles are dealt
     * out by claim as the parts ask for them (dtx_bbw_handles_claim; each
     * handle to exactly one part over all parts, whatever the timing). */
    dtx_bbw_claim_fn claim;
    void *claim_ctx;
} dtx_kp_params;

/* What the selection found. */
typedef struct {
    int32_t count;          /* |S| */
    int32_t *keys;          /* count vertex indices, in the order chosen (owned) */
    int32_t ncand;          /* candidates used (<= params candidates: the
                               vertices in faces bound it) */
    int32_t *candidates;    /* ncand vertex indices, FPS order (owned) */
    double *trace;          /* error after each accepted step: count - 1 adds,
                               then one entry per accepted replacement
                               (ntrace entries, owned) */
    int32_t ntrace;
    double error_first;     /* error of {c_1} alone */
    double error;           /* error of the final set (as evaluated by the mode) */
    double error_exact;     /* the final set with bounded weights and its own
                               clustering (equal to error when exact = 1) */
    int32_t replacements;   /* accepted in stage 2 */
    int sweeps;             /* stage-2 sweeps done */
    int64_t evaluations;    /* candidate sets evaluated by this part */
    int64_t failed;         /* evaluations that failed (singular fit): error +inf */
    int64_t solves;         /* fast mode: candidates' Green's functions solved by
                               this part (the rest are carried across commits or
                               come from the other parts) */
    double radius;          /* R, the error's length unit */
    double *weights;        /* the final set's bounded biharmonic weights on the
                               source (nv x count, as dtx_bbw gives them; owned),
                               kept from the closing evaluation; NULL in exact
                               mode */
} dtx_kp_result;

/* The defaults above (skin: dtx_skin_params_default), one part. */
void dtx_kp_params_default(dtx_kp_params *p);

/* Selects key points on src (which must pass dtx_mesh_validate, with every
 * vertex in a face) from nframes >= 1 deformed frames X (nframes x nv x 3,
 * same vertex order).  res is filled (free with dtx_kp_result_free; zeroed
 * on failure).  Errors: DTX_EINVAL (parameters), DTX_EMESH (mesh unsuitable
 * for biharmonic weights, e.g. an isolated vertex, or a component the
 * candidates miss), DTX_ENONFINITE, DTX_ENOMEM, DTX_ESOLVE, or what reduce
 * returns. */
dtx_status dtx_keypoints_select(const dtx_mesh *src, int32_t nframes, const double *X,
                                const dtx_kp_params *p, dtx_kp_result *res, dtx_error *err);

/* The error of a given key-point set (m vertices) evaluated as exact = 1
 * does (bounded weights, its own clustering): for tests and comparisons. */
dtx_status dtx_keypoints_error(const dtx_mesh *src, int32_t nframes, const double *X,
                               const int32_t *keys, int32_t m, const dtx_skin_params *skin,
                               double *error, dtx_error *err);

void dtx_kp_result_free(dtx_kp_result *res);

#endif /* DTX_KEYPOINTS_H */
