/*
 * skinning.h: linear blend skinning fitted to known deformed frames with a
 * clustered as-rigid-as-possible energy (Yang, Gao, Lai, Rosin & Xia 2018,
 * "Biharmonic deformation transfer with automatic key point selection",
 * sections 3.2-3.4), and the small 3x3 and clustering tools it is made of.
 *
 * The model.  m handles, each with an affine map T_k (3 x 4); a vertex moves
 * by linear blend skinning with weights W (nv x m, each row a partition of
 * unity):
 *
 *     q_i = sum_k W_ik T_k [p_i; 1].
 *
 * Fitting a deformed frame q' minimises, over the T_k and one rotation R_g per
 * cluster g,
 *
 *     E = lambda E_arap + E_diff,
 *     E_arap = sum_i sum_{j in N(i)} w_ij || (q_i - q_j) - R_g(i) (p_i - p_j) ||^2,
 *     E_diff = sum_i || q_i - q'_i ||^2,
 *
 * where N(i) is the one-ring of vertex i and g(i) the cluster of vertex i:
 * the edge groups of the paper are the one-ring spokes (i, j) of the
 * vertices of a cluster (each mesh edge is in the sum twice, once from each
 * end, as in Sorkine & Alexa 2007).  w_ij are cotangent weights
 * (cot a + cot b) / 2 (the paper) or 1 (uniform).  The minimisation
 * alternates a local step (per cluster: the 3x3 covariance, its SVD and the
 * reflection fix) and a global step (the 4m x 4m normal equations, factored
 * once per mesh, weights and clustering); it works in a reduced space, so an
 * iteration costs O(nclusters m + m^2) whatever the mesh size (see
 * dtx_skin_fit_create).  Unlike the paper's equation 20 (which solves
 * [lambda L; I] q = [lambda b; q'] in least squares, a squared-Laplacian
 * objective), the global step solves the normal equations of E itself, so
 * E never increases from one step to the next.
 *
 * The clustering (section 3.3).  Each vertex gets a per-frame deformation
 * gradient (the area-weighted mean of the gradients of its triangles,
 * Sumner & Popovic's fourth-vertex construction, dtx_deformation_gradients),
 * its polar decomposition D = U N, log U as an axis-angle 3-vector and N's
 * entries; k-means on
 *
 *     W' = [W, (gamma_logr / sqrt(nframes)) logr, (gamma_s / sqrt(nframes)) s]
 *
 * with the features of all training frames side by side groups the vertices.
 * sqrt(nframes) is the paper's sqrt(m), m being its number of deformed
 * models (equation 14).  Default number of clusters: the number of handles
 * (the paper: "we set the number of clusters to n_h").
 *
 * Use: dtx_skin_mesh_create once per mesh; dtx_skin_features once per
 * (mesh, frames); then for each handle set: dtx_skin_cluster, then
 * dtx_skin_fit_create (the O(nv m^2) set-up), then dtx_skin_fit_frames.
 * dtx_skin_apply evaluates the skinning (also on another mesh with its own
 * weights: q_tgt = sum_k w_tgt_ik T_k [p_tgt_i; 1]).
 *
 * Conventions: V, X are n x 3 row-major doubles; F is nf x 3 int32, 0-based;
 * W is nv x m row-major; 3x3 matrices are 9 doubles, row-major; a handle's
 * T_k is 12 doubles, the 3 x 4 matrix [A_k t_k] row-major (row r:
 * A_r0 A_r1 A_r2 t_r).  Outputs are caller-allocated unless a function says
 * otherwise.  No function prints.  Everything is deterministic and, with
 * OpenMP, gives bitwise the same results for any number of threads.
 */
#ifndef DTX_SKINNING_H
#define DTX_SKINNING_H

#include "status.h"

#include <stdint.h>

/* ------------------------------------------------------------------ */
/* k-means (kmeans.c)                                                  */
/* ------------------------------------------------------------------ */

/* Lloyd's k-means of the n points X (n x d, row-major) into k clusters,
 * seeded by k-means++ with a fixed-seed generator (splitmix64 of `seed`),
 * at most max_iters assignment rounds (stops earlier when no label
 * changes).  Hamerly's distance bounds skip points whose centre provably
 * stays nearest, and the means are updated by the points that moved, so a
 * round after the first costs about O(n + moves d + rescans k d); the
 * labels are plain Lloyd's (lowest centre index on ties).  A cluster that
 * empties is given the point farthest from its centre (lowest index on
 * ties).  labels: n int32 in [0, k), output.
 * centers: k x d, output, may be NULL.  iters: rounds done, may be NULL.
 * threads: OpenMP threads for the assignment (0: the OpenMP default); the
 * result does not depend on it.  Errors: DTX_EINVAL (k < 1, k > n, d < 1),
 * DTX_ENONFINITE, DTX_ENOMEM.  Thread-safe. */
dtx_status dtx_kmeans(const double *X, int32_t n, int32_t d, int32_t k, int max_iters,
                      uint64_t seed, int threads, int32_t *labels, double *centers, int *iters,
                      dtx_error *err);

/* ------------------------------------------------------------------ */
/* Parameters                                                          */
/* ------------------------------------------------------------------ */

typedef enum {
    DTX_SKIN_COTAN = 0,  /* w_ij = (cot a_ij + cot b_ij) / 2 (the paper) */
    DTX_SKIN_UNIFORM = 1 /* w_ij = 1 */
} dtx_skin_edge_weights;

typedef struct {
    double lambda;        /* weight of E_arap (paper: 0.5) */
    int32_t nclusters;    /* rotation clusters; 0: the number of handles (paper) */
    double gamma_logr;    /* clustering weight of the rotations (paper: 1) */
    double gamma_s;       /* clustering weight of the scale/shear (paper: 0.1) */
    int kmeans_iters;     /* k-means round cap (100) */
    uint64_t kmeans_seed; /* k-means++ seed (fixed default) */
    int max_iters;        /* local/global iteration cap per frame (100) */
    double tol;           /* stop when one local+global pair lowers E by less
                             than tol * E (1e-5) */
    int threads;          /* OpenMP threads (0: the OpenMP default; a call made
                             inside a parallel region runs on one thread unless
                             nesting is enabled) */
} dtx_skin_params;

/* The defaults above. */
void dtx_skin_params_default(dtx_skin_params *p);

/* ------------------------------------------------------------------ */
/* The rest mesh (skinning.c)                                          */
/* ------------------------------------------------------------------ */

/* What the fit needs of the rest mesh alone: the one-ring spokes with their
 * weights, the rest frame inverses for the deformation gradients, the
 * vertex-to-triangle incidence and a normalisation (centroid, RMS radius)
 * used internally for conditioning.  Immutable once built; every function
 * taking a const dtx_skin_mesh * may run concurrently on it. */
typedef struct dtx_skin_mesh dtx_skin_mesh;

/* V: nv x 3 (copied), F: nf x 3 (copied).  Needs nv >= 3, nf >= 1, indices
 * in range, finite coordinates, every vertex in a face (an isolated vertex
 * has no gradient), rest positions not all equal.  Cotangents of angles in
 * needle triangles (|e1 x e2| <= DTX_MESH_THIN_RATIO |e1||e2|) are clamped
 * to +-1/DTX_MESH_THIN_RATIO.  Errors: DTX_EINVAL, DTX_ERANGE,
 * DTX_ENONFINITE, DTX_EMESH, DTX_ENOMEM; *out is NULL on failure. */
dtx_status dtx_skin_mesh_create(const double *V, int32_t nv, const int32_t *F, int32_t nf,
                                dtx_skin_edge_weights weights, dtx_skin_mesh **out, dtx_error *err);
void dtx_skin_mesh_free(dtx_skin_mesh **mesh);
int32_t dtx_skin_mesh_nv(const dtx_skin_mesh *mesh);

/* ------------------------------------------------------------------ */
/* Clustering features (skinning_features.c)                           */
/* ------------------------------------------------------------------ */

/* Floats per vertex and frame in the feature array: logr (3) then s (6). */
#define DTX_SKIN_FEAT 9

/* Per-vertex features of nframes deformed frames X (nframes x nv x 3):
 * feat (nv x (DTX_SKIN_FEAT * nframes), row-major; vertex i, frame f at
 * feat[i * 9 nframes + 9 f]) gets logr = log U (axis-angle) and the six
 * entries (N00, N11, N22, sqrt2 N01, sqrt2 N02, sqrt2 N12) of N, where
 * D = U N is the polar decomposition of the vertex's deformation gradient D
 * (the mean of its triangles' gradients weighted by rest area).  The sqrt2
 * makes Euclidean distances of s equal the Frobenius distances of the
 * paper's nine-entry vector; N (not N - I) is stored, which k-means cannot
 * tell apart.  Independent of the weights: compute once per frame set.
 * OpenMP over frames (p->threads; NULL p: defaults).  Errors: DTX_EINVAL,
 * DTX_ENONFINITE (a non-finite coordinate), DTX_ENOMEM. */
dtx_status dtx_skin_features(const dtx_skin_mesh *mesh, int32_t nframes, const double *X,
                             const dtx_skin_params *p, double *feat, dtx_error *err);

/* Clusters the vertices by k-means on W' (see the top of this file):
 * W: nv x m; feat: from dtx_skin_features over nframes frames (nframes may
 * be 0: then W alone, feat unused); labels: nv int32 output in
 * [0, nclusters) with nclusters = p->nclusters or m when that is 0.
 * Errors: DTX_EINVAL, DTX_ENONFINITE, DTX_ENOMEM. */
dtx_status dtx_skin_cluster(int32_t nv, int32_t m, const double *W, int32_t nframes,
                            const double *feat, const dtx_skin_params *p, int32_t *labels,
                            dtx_error *err);

/* ------------------------------------------------------------------ */
/* The fit (skinning.c)                                                */
/* ------------------------------------------------------------------ */

/* The precomputed fit for one (mesh, weights, clustering): the normal
 * matrix lambda K + G of E in the handle transforms (K = M^T L_arap M,
 * G = M^T M, M the nv x 4m skinning matrix) and its Cholesky factor, and
 * per cluster the 3 x 4m map P_g from the transforms to the cluster's
 * covariance sum w_ij (p_i - p_j)(q_i - q_j)^T.  Immutable once built:
 * dtx_skin_fit_frames may run concurrently on one fit. */
typedef struct dtx_skin_fit dtx_skin_fit;

/* Builds the fit.  mesh is kept by pointer and must outlive the fit; W
 * (nv x m, rows summing to 1 within 1e-6, entries finite) and labels (nv,
 * in [0, nclusters)) are copied.  nclusters >= 1 (empty clusters allowed).
 * Cost O(nv m^2 + spokes m): the normal matrix, P_g and one 4m x 4m
 * Cholesky (LAPACK dpotrf).  Uses p->lambda.  Errors: DTX_EINVAL,
 * DTX_ERANGE (a label out of range), DTX_ENONFINITE, DTX_ESOLVE (the normal
 * matrix is not positive definite: the weights times [p 1] are linearly
 * dependent, e.g. two equal weight columns), DTX_ENOMEM. */
dtx_status dtx_skin_fit_create(const dtx_skin_mesh *mesh, int32_t m, const double *W,
                               const int32_t *labels, int32_t nclusters, const dtx_skin_params *p,
                               dtx_skin_fit **out, dtx_error *err);
void dtx_skin_fit_free(dtx_skin_fit **fit);

/* Outputs of dtx_skin_fit_frames, caller-allocated; all but T may be NULL. */
typedef struct {
    double *T;      /* nframes x m x 12: the handle transforms */
    double *energy; /* nframes: E = lambda E_arap + E_diff at the end */
    double *diff;   /* nframes: its E_diff part, sum ||q_i - q'_i||^2 */
    int32_t *iters; /* nframes: local/global pairs done */
    double *R;      /* nframes x nclusters x 9: the cluster rotations */
    double *trace;  /* nframes x (2 max_iters + 1): E after the first global
                       step, then after each local and each global step;
                       entries past the last step are NaN */
} dtx_skin_out;

/* Fits nframes frames X (nframes x nv x 3) independently: the rotations
 * start as the best cluster rotations of the known frame itself, then a
 * global step, then local/global pairs until a pair lowers E by no more
 * than p->tol * E (or a few ulps of the frame's scale), or p->max_iters
 * pairs.  The fit's lambda is used (p->lambda is not read here).
 * Per frame: O(nv m + spokes) to set up the right-hand side, then
 * O(nclusters m + m^2) per iteration.  OpenMP over frames with per-thread
 * workspace allocated before the loop; results are bitwise independent of
 * the thread count.  Energies are evaluated in the reduced space: their
 * absolute error is a few ulps of lambda sum w_ij |p_i - p_j|^2 + sum
 * |q'_i - centroid(q')|^2.  Errors: DTX_EINVAL, DTX_ENONFINITE (a
 * non-finite coordinate in X; nothing is written), DTX_ENOMEM. */
dtx_status dtx_skin_fit_frames(const dtx_skin_fit *fit, int32_t nframes, const double *X,
                               const dtx_skin_params *p, dtx_skin_out *out, dtx_error *err);

/* ------------------------------------------------------------------ */
/* Fit errors of many weight sets (skinning.c)                         */
/* ------------------------------------------------------------------ */

/* What the error of a fit depends on besides the weights, for callers that
 * try many weight sets with one clustering and one frame set (the key-point
 * selection's round): the frames centred and scaled, their starting
 * rotations and the clusters' covariance map
 * from the rest mesh alone.  Immutable once built: dtx_skin_eval_error may
 * run concurrently on one, each caller with its own workspace. */
typedef struct dtx_skin_eval dtx_skin_eval;
typedef struct dtx_skin_eval_work dtx_skin_eval_work;

/* labels: nv in [0, nclusters); X: nframes x nv x 3 (nframes >= 1), copied
 * centred and scaled; p: lambda, max_iters, tol.  mesh must outlive the
 * result.  O(nframes spokes).  Errors: DTX_EINVAL, DTX_ERANGE (a label),
 * DTX_ENONFINITE (a coordinate), DTX_ENOMEM; *out is NULL on failure. */
dtx_status dtx_skin_eval_create(const dtx_skin_mesh *mesh, const int32_t *labels,
                                int32_t nclusters, int32_t nframes, const double *X,
                                const dtx_skin_params *p, dtx_skin_eval **out, dtx_error *err);
void dtx_skin_eval_free(dtx_skin_eval **ev);

/* Scratch for dtx_skin_eval_error with up to mmax handles, nclmax
 * clusters and nframes frames of mesh; NULL when out of memory or too big. */
dtx_skin_eval_work *dtx_skin_eval_work_new(const dtx_skin_mesh *mesh, int32_t nframes,
                                           int32_t mmax, int32_t nclmax);
void dtx_skin_eval_work_free(dtx_skin_eval_work **work);

/* The mean over frames and vertices of |q_i - q'_i|, q the frame fitted
 * with weights W (nv x m, rows summing to 1 within 1e-6) as
 * dtx_skin_fit_create + dtx_skin_fit_frames + dtx_skin_apply would fit
 * and skin it, q' the frame, in the frames' units.  The same mathematics
 * as that path, computed with fewer passes over the mesh (the normal
 * matrix, every frame's M^T q' and the skinned frames are three BLAS
 * products, the covariance map a sparse product), so the last bits differ.
 * Deterministic: one call gives the same bits on any thread.  Errors:
 * DTX_EINVAL (arguments, a row sum), DTX_ENONFINITE, DTX_ESOLVE (the normal
 * matrix is not positive definite). */
dtx_status dtx_skin_eval_error(const dtx_skin_eval *ev, int32_t m, const double *W,
                               dtx_skin_eval_work *work, double *mean_dist, dtx_error *err);

/* E = lambda E_arap + E_diff (the fit's lambda) evaluated directly on the
 * mesh (O(nv m + spokes)) for one frame X (nv x 3), transforms T (m x 12)
 * and cluster rotations R (nclusters x 9): a check on the reduced-space
 * values.
 * energy and diff (may be NULL) get E and E_diff.  Errors: DTX_ENOMEM. */
dtx_status dtx_skin_energy(const dtx_skin_fit *fit, const double *X, const double *T,
                           const double *R, double *energy, double *diff, dtx_error *err);

/* Linear blend skinning of the rest positions V (nv x 3) with weights W
 * (nv x m) by nframes transform sets T (nframes x m x 12) into Q
 * (nframes x nv x 3): q_i = p_i + sum_k W_ik (T_k - [I 0]) [p_i; 1], which
 * is sum_k W_ik T_k [p_i; 1] for weights summing to one, and gives the rest
 * positions bit for bit when every T_k is the identity.  Works for any mesh
 * with its own weights (the transfer onto a target).  Thread-safe; OpenMP
 * over frames with `threads` threads (0: the OpenMP default). */
void dtx_skin_apply(int32_t nv, int32_t m, const double *V, const double *W, int32_t nframes,
                    const double *T, int threads, double *Q);

#endif /* DTX_SKINNING_H */
