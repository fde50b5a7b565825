/*
 * bbw.h: biharmonic skinning weights for point handles, and key-point
 * candidates (Yang, Gao, Lai, Rosin & Xia 2018, sections 3.1-3.2; Jacobson,
 * Baran, Popovic & Sorkine 2011, "Bounded biharmonic weights").
 *
 * Handles are vertices h_0..h_{m-1} of a mesh.  A weight matrix W is nv x m,
 * row-major doubles: W[i*m + k] = w_k(vertex i), with w_k(h_j) = delta_jk.
 * The energy of a weight is 1/2 w' Q w with Q = L M^-1 L, L the cotangent
 * Laplacian and M the Voronoi-mixed mass matrix (laplacian.h): the
 * discrete integral of (Laplacian w)^2.
 *
 * Mesh requirements (every function below): the mesh passes
 * dtx_mesh_validate; every vertex is in a triangle of non-zero size
 * (DTX_EMESH otherwise: remove unreferenced vertices first); and every
 * connected component holds at least one handle (DTX_EMESH otherwise: a
 * component without a handle has undefined weights).  Handles must be
 * distinct vertices in [0, nv) and m >= 1 (DTX_EINVAL / DTX_ERANGE, with a
 * message naming the handle).
 *
 * Two kinds of weights:
 *  - bounded (dtx_bbw): 0 <= w_k <= 1 and sum_k w_k = 1, the paper's
 *    weights.  One box-constrained quadratic programme per handle, solved
 *    exactly by an active-set method, then rows normalised (see dtx_bbw).
 *  - unbounded (the incremental context): the same energy with the handle
 *    constraints only.  They sum to 1 (up to the solves' rounding, ~1e-11)
 *    but oscillate below 0 and above 1 away from the handles;
 *    dtx_bbw_clamp_normalise turns them into an approximation of the
 *    bounded weights.  How rough: on the cactus with 5, 10 and 20
 *    farthest-point handles, 98-99.7% of the vertices have some weight below
 *    -1e-3 or above 1 + 1e-3 (by up to 0.13, 0.15, 0.20), and the clamped,
 *    renormalised weights differ from the bounded ones by up to 0.057,
 *    0.065, 0.067 (rms 0.014, 0.010, 0.008).  Their point is speed:
 *    the weights of a handle set plus one candidate, or with one handle
 *    replaced by a candidate, cost one back-substitution on a factorisation
 *    kept for the set (exact rank-one Green's-function updates), which is
 *    what greedy key-point selection evaluates ~100 times per round.
 */
#ifndef DTX_BBW_H
#define DTX_BBW_H

#include "mesh.h"
#include "status.h"

#include <stdint.h>

/* ------------------------------------------------------------------ */
/* Bounded biharmonic weights (bbw.c)                                  */
/* ------------------------------------------------------------------ */

typedef struct {
    /* Global active-set iterations per handle before giving up (then the
     * last iterate, clamped to [0, 1], is used and counted in
     * dtx_bbw_info.not_converged); each is followed by at most 10 local
     * ones (see dtx_bbw).  Default 100; >= 1. */
    int max_iter;
    /* 1 (default): divide each row by its sum, the partition of unity.  0:
     * leave the per-handle solutions as they are (each in [0, 1] with the
     * handle constraints, rows not summing to 1); for tests and studies. */
    int normalise;
} dtx_bbw_params;

/* What dtx_bbw did. */
typedef struct {
    int iterations_max;          /* most global active-set iterations of any handle */
    int64_t iterations_total;    /* over all handles (each is one factorisation) */
    int64_t local_total;         /* local iterations over all handles (each one
                                    factorisation of a small block; see dtx_bbw) */
    int32_t not_converged;       /* handles that reached max_iter */
    int32_t low_sum;             /* rows whose sum was below DTX_BBW_MIN_SUM (see dtx_bbw) */
    double sum_min, sum_max;     /* range of the row sums before normalisation */
    int32_t thin_triangles;      /* triangles regularised in L and M (laplacian.h) */
} dtx_bbw_info;

/* A row whose per-handle weights sum below this is replaced, before
 * normalising, by the clamped unbounded weights of that vertex (whose sum
 * is >= 1/m, computed for the purpose), so normalisation never divides by
 * (nearly) 0. */
#define DTX_BBW_MIN_SUM 1e-6

/* Sets the defaults: max_iter 100, normalise 1. */
void dtx_bbw_params_default(dtx_bbw_params *prm);

/* Bounded biharmonic weights of the m handles on mesh.
 *
 * For each handle k independently (Jacobson et al. 2011, section 4:
 * the partition-of-unity constraint is dropped and restored by
 * normalisation), w_k minimises 1/2 w' Q w subject to w(h_j) = delta_jk and
 * 0 <= w <= 1, solved exactly (KKT conditions to rounding) by a primal-dual
 * active-set method (Hintermueller, Ito & Kunisch 2002): start from the
 * unconstrained minimiser; fix the vertices below 0 at 0 and above 1 at 1;
 * re-solve on the rest (a fresh CHOLMOD factorisation of Q on the free
 * vertices); release fixed vertices whose multiplier has the wrong sign;
 * repeat until the sets stop changing (typically 5 to 20 times).  Between
 * two such global iterations, up to 10 local ones re-solve only near the
 * vertices that changed (within 6 mesh rings), which moves the support's
 * boundary out at the price of a small block (see bbw.c); the method ends
 * only at a global iteration that changes nothing.  Rows are
 * then divided by their sums: the result satisfies w_k(h_j) = delta_jk
 * exactly, 0 <= w <= 1 and sum_k w_k = 1 to rounding.  (Dropping the
 * coupling is the usual practice; the normalised weights are not the exact
 * minimiser of the coupled problem.)
 *
 * W: nv x m, caller-allocated, overwritten.  prm: NULL for the defaults.
 * info: may be NULL.  Handles are processed in parallel over the OpenMP
 * threads of the caller's team size (omp_get_max_threads()), each with its
 * own CHOLMOD workspace and factorisations (serial CHOLMOD); the result is
 * bitwise the same for any thread count.  Memory: a few copies of Q per
 * thread plus its factor.  Thread-safe (no shared state).
 * Errors: those in the file comment, DTX_ENOMEM, DTX_ESOLVE. */
dtx_status dtx_bbw(const dtx_mesh *mesh, const int32_t *handles, int32_t m,
                   const dtx_bbw_params *prm, double *W, dtx_bbw_info *info, dtx_error *err);

/* dtx_bbw in two steps, so that the handles can be shared out (over MPI
 * ranks, say) and the results put together:
 *
 * dtx_bbw_handles solves the programmes of handles k0..k1-1 (0 <= k0 <=
 * k1 <= m) of the set handles[0..m-1] and writes each solution, clamped to
 * [0, 1] and not normalised, as a row of Wk ((k1 - k0) x nv, handle-major:
 * Wk[(k - k0) * nv + i] is handle k's weight at vertex i).  info (may be
 * NULL) receives the iteration counts and thin_triangles of these handles
 * (the sums are dtx_bbw_normalise's).  Threads, errors and memory as
 * dtx_bbw; a handle's row is the same bits whoever computes it.
 *
 * dtx_bbw_normalise takes all m rows (Wk, m x nv handle-major) and writes
 * W (nv x m) as dtx_bbw does: rows divided by their sums (when
 * prm->normalise), a row summing below DTX_BBW_MIN_SUM replaced by the
 * clamped unbounded weights of that vertex (computed only then, one
 * factorisation: dtx_bbw_incr_create), exact at the handles.  info (may be
 * NULL): its low_sum, sum_min and sum_max are set, the rest left alone.
 * dtx_bbw(mesh, handles, m, prm, W, info) is dtx_bbw_handles over [0, m)
 * then dtx_bbw_normalise, bit for bit. */
dtx_status dtx_bbw_handles(const dtx_mesh *mesh, const int32_t *handles, int32_t m, int32_t k0,
                           int32_t k1, const dtx_bbw_params *prm, double *Wk, dtx_bbw_info *info,
                           dtx_error *err);
dtx_status dtx_bbw_normalise(const dtx_mesh *mesh, const int32_t *handles, int32_t m,
                             const double *Wk, const dtx_bbw_params *prm, double *W,
                             dtx_bbw_info *info, dtx_error *err);

/* Hands out handles 0..m-1 to solve: sets *k0 and returns n >= 1 to give
 * this caller handles *k0..*k0+n-1 (n <= want), or returns 0 when none are
 * left.  Over all the callers sharing the handles (the ranks of a run,
 * say), each handle must be handed out exactly once.  Called from the
 * caller's thread only, outside any parallel region. */
typedef int32_t (*dtx_bbw_claim_fn)(void *ctx, int32_t m, int32_t want, int32_t *k0);

/* dtx_bbw_handles with the handles dealt out as they are asked for, so
 * that callers whose programmes take longer get fewer of them: solves the
 * handles claim hands out (asking for one per thread at a time) until it
 * has none left, and writes handle k's row at Wk + k nv (Wk: m x nv,
 * handle-major; other rows untouched).  The rows are the bits
 * dtx_bbw_handles gives, whoever solves them.  info: as dtx_bbw_handles,
 * over the handles solved here.  Errors: as dtx_bbw_handles; DTX_ERANGE
 * when claim hands out handles outside [0, m); DTX_EINVAL (claim NULL). */
dtx_status dtx_bbw_handles_claim(const dtx_mesh *mesh, const int32_t *handles, int32_t m,
                                 dtx_bbw_claim_fn claim, void *claim_ctx,
                                 const dtx_bbw_params *prm, double *Wk, dtx_bbw_info *info,
                                 dtx_error *err);

/* Clamps every entry of W (nv x m) to [0, 1] and divides each row by its
 * sum, in place: the clamped-and-renormalised unbounded weights, an
 * approximation of the bounded ones.  Unbounded weights sum to 1 in every
 * row, so after clamping a row sums to at least its largest entry, >= 1/m
 * > 0; rows at a handle (one entry 1, the others 0) are unchanged.
 * Returns the number of rows that had an entry outside [0, 1] before
 * clamping; max_violation (may be NULL) receives the largest distance of an
 * entry from [0, 1] (0 if none).  A row that sums to <= 0 after clamping
 * (impossible for unbounded weights, possible for arbitrary input) is left
 * all zero and makes the return value -1 (the other rows are still done). */
int32_t dtx_bbw_clamp_normalise(double *W, int32_t nv, int32_t m, double *max_violation);

/* ------------------------------------------------------------------ */
/* Unbounded weights, incremental (bbw_incremental.c)                  */
/* ------------------------------------------------------------------ */

/* A handle set with the factorisation of Q on its free vertices (the
 * non-handles) and its unbounded weights W (nv x m). */
typedef struct dtx_bbw_incr dtx_bbw_incr;

/* Per-thread scratch for the evaluation functions (a CHOLMOD workspace and
 * vectors of length nv).  One per concurrent caller; it may be used with
 * the context it was made for after any number of add/replace commits. */
typedef struct dtx_bbw_work dtx_bbw_work;

/* Builds the context for handles[0..m-1] (copied): forms Q, factors it on
 * the non-handles and solves for the m unbounded weights.  *out is NULL on
 * failure.  Errors: those in the file comment, DTX_ENOMEM, DTX_ESOLVE.
 * Cost: forming Q, one factorisation and m solves (60-140 ms on the
 * 5,261-vertex cactus; tests/bench/bench_bbw.c). */
dtx_status dtx_bbw_incr_create(const dtx_mesh *mesh, const int32_t *handles, int32_t m,
                               dtx_bbw_incr **out, dtx_error *err);

/* Frees the context; accepts NULL and *ctx == NULL; sets *ctx = NULL. */
void dtx_bbw_incr_free(dtx_bbw_incr **ctx);

/* The current handle count, handles (m, owned by ctx) and weights (nv x m,
 * owned by ctx; valid until the next commit or free). */
int32_t dtx_bbw_incr_count(const dtx_bbw_incr *ctx);
int32_t dtx_bbw_incr_nv(const dtx_bbw_incr *ctx);
const int32_t *dtx_bbw_incr_handles(const dtx_bbw_incr *ctx);
const double *dtx_bbw_incr_weights(const dtx_bbw_incr *ctx);

/* Scratch for ctx (see dtx_bbw_work).  NULL on allocation failure. */
dtx_bbw_work *dtx_bbw_work_new(const dtx_bbw_incr *ctx);
void dtx_bbw_work_free(dtx_bbw_work **work);

/* The unbounded weights of the handles plus vertex c, which must not be a
 * handle: W_out (nv x (m+1), caller-allocated) holds the m current handles'
 * weights in columns 0..m-1 and c's in column m.  Exact: with g = Q_ff^-1
 * e_c (f the free vertices, g = 0 at the handles; one back-substitution),
 * w'_k = w_k - (w_k(c) / g(c)) g and w'_c = g / g(c).
 * ctx is only read: concurrent calls with distinct work are safe.  Cost:
 * one solve with the factor plus O(nv m).  Errors: DTX_ERANGE (c out of
 * range), DTX_EINVAL (c is a handle, NULL arguments). */
dtx_status dtx_bbw_incr_weights_add(const dtx_bbw_incr *ctx, int32_t c, double *W_out,
                                    dtx_bbw_work *work, dtx_error *err);

/* The unbounded weights of the handle set with handle j (0 <= j < m)
 * replaced by vertex c (not a handle; c = handles[j] is allowed and gives
 * the current weights): W_out (nv x m) with c's weight in column j.  Exact,
 * from the current factorisation and weights alone: dropping handle j gives
 * w^-_k = w_k - ((Q w_k)(h_j) / (Q w_j)(h_j)) w_j, its Green's function for
 * c is g^- = g - ((Q g)(h_j) / (Q w_j)(h_j)) w_j with g as above, and c is
 * added to that set as in dtx_bbw_incr_weights_add.  When h_j is the only
 * handle of its component, c must lie in the same component (DTX_EINVAL
 * otherwise).  Same thread-safety, cost and errors as
 * dtx_bbw_incr_weights_add (DTX_ERANGE also for j). */
dtx_status dtx_bbw_incr_weights_replace(const dtx_bbw_incr *ctx, int32_t j, int32_t c,
                                        double *W_out, dtx_bbw_work *work, dtx_error *err);

/* The Green's function g (nv, caller-allocated) of vertex c (not a handle)
 * for the current set: g = 0 at the handles, Q_ff g(f) = e_c: the one
 * back-substitution of the two functions above.  A caller that evaluates
 * the same candidate for several rounds with no commit in between (the
 * replacement rounds of key-point selection) computes it once and passes
 * it to the _g variants below, which then give the bits of the functions
 * above.  Same thread-safety and errors. */
dtx_status dtx_bbw_incr_green(const dtx_bbw_incr *ctx, int32_t c, double *g, dtx_bbw_work *work,
                              dtx_error *err);

/* dtx_bbw_incr_weights_add and _replace with c's Green's function g from
 * dtx_bbw_incr_green for the current set (NULL: computed here).  g is only
 * read.  Cost O(nv m). */
dtx_status dtx_bbw_incr_weights_add_g(const dtx_bbw_incr *ctx, int32_t c, const double *g,
                                      double *W_out, dtx_bbw_work *work, dtx_error *err);
dtx_status dtx_bbw_incr_weights_replace_g(const dtx_bbw_incr *ctx, int32_t j, int32_t c,
                                          const double *g, double *W_out, dtx_bbw_work *work,
                                          dtx_error *err);

/* Carries Green's functions across a commit, before it is made: G (n x
 * nv, row t that of vertex verts[t] for the current set, as
 * dtx_bbw_incr_green gives it) becomes each vertex's Green's function for
 * the set the commit will make: c added (j < 0) or handle j moved to c
 * (0 <= j < m).  gc is c's Green's function for the current set (only
 * read; it must not be a row of G that is updated).  Rows with verts[t] <
 * 0 are left alone; the others must be free in the new set, and when
 * moving, verts[t] = handles[j] is allowed (its row is only written).
 * Exact, as in dtx_bbw_incr_weights_add / _replace: with g_c^- = gc -
 * ((Q gc)(h_j) / E_jj) w_j (or gc when adding), every g^- is formed
 * likewise (w_j / E_jj for h_j itself), then g' = g^- - (g^-(c) / g_c^-(c))
 * g_c^- and g'(c) = 0.  It agrees with new back-substitutions up to
 * rounding, at O(nv) per row instead of a solve each.  Rows are
 * independent (threads: OpenMP threads, 0 for the default), so the bits do
 * not depend on the thread count.  ctx is only read.  Errors: DTX_EINVAL
 * (bad arguments, or h_j the only handle of its component: then nothing is
 * written and the caller solves afresh after the commit), DTX_ESOLVE
 * (g_c^-(c) or E_jj not positive), DTX_ENOMEM. */
dtx_status dtx_bbw_incr_green_move(const dtx_bbw_incr *ctx, int32_t j, int32_t c, const double *gc,
                                   int32_t n, const int32_t *verts, double *G, int threads,
                                   dtx_error *err);

/* Commits: appends c to the handles (add), or sets handle j to c
 * (replace), then refactors and re-solves the weights from scratch (so no
 * rounding accumulates over commits).  Not thread-safe against any other
 * use of ctx.  On failure ctx is unchanged (errors as for create). */
dtx_status dtx_bbw_incr_add(dtx_bbw_incr *ctx, int32_t c, dtx_error *err);
dtx_status dtx_bbw_incr_replace(dtx_bbw_incr *ctx, int32_t j, int32_t c, dtx_error *err);

/* A carried commit: c added (j < 0) or put in place of handle j, with the
 * new set's weights from c's Green's function g for the current set (as
 * dtx_bbw_incr_weights_add_g / _replace_g give them) instead of a
 * factorisation and solves.  Rounding then accumulates over such commits
 * (about 1e-12 relative per commit on the cat), and the new set is not
 * factored: dtx_bbw_incr_green and the functions that solve (no g) fail
 * with DTX_EINVAL until dtx_bbw_incr_factor.  For callers that carry their
 * Green's functions too (dtx_bbw_incr_green_move) and rarely solve.  Not
 * thread-safe; on failure ctx is unchanged.  Errors: those of the _g
 * functions, DTX_ENOMEM. */
dtx_status dtx_bbw_incr_commit_g(dtx_bbw_incr *ctx, int32_t j, int32_t c, const double *g,
                                 dtx_bbw_work *work, dtx_error *err);

/* Factors the current set when a carried commit left it unfactored (a
 * no-op otherwise).  Not thread-safe.  Errors: DTX_ENOMEM, DTX_ESOLVE. */
dtx_status dtx_bbw_incr_factor(dtx_bbw_incr *ctx, dtx_error *err);

/* ------------------------------------------------------------------ */
/* Key-point candidates (fps.c)                                        */
/* ------------------------------------------------------------------ */

/* Farthest point sampling of nc vertices (the paper uses nc = 100), with
 * distances measured along the mesh edges (Dijkstra with a binary heap over
 * the edge graph, edge length = Euclidean distance of its end points): an
 * approximation of the geodesic distance from above.
 *
 * samples[0] is the vertex farthest (Euclidean) from the centroid of the
 * vertices (the mean of the positions of vertices in faces); each next
 * sample is the vertex farthest from all samples so far.  Ties go to the
 * lowest vertex index, so the result is a function of the mesh alone.
 * Vertices in no face are never picked.  On a mesh of several components
 * a vertex unreachable from the samples so far is infinitely far: each
 * component gets a sample before any gets a second (in order of their
 * lowest vertex).
 *
 * samples: nc int32 (output, caller-allocated), distinct.  radius: nc
 * doubles (may be NULL): radius[i] is sample i's distance to samples
 * 0..i-1 when it was picked (INFINITY for samples[0] and for the first
 * sample of each further component), non-increasing within a component.
 * Errors: DTX_EINVAL (nc < 1, NULL arguments), DTX_ERANGE (nc above the
 * number of vertices in faces), those of dtx_mesh_validate, DTX_ENOMEM.
 * O(nc nv log nv) time at worst (each Dijkstra stops where the distances
 * stop improving), O(nv + nf) memory; thread-safe. */
dtx_status dtx_farthest_points(const dtx_mesh *mesh, int32_t nc, int32_t *samples,
                               double *radius, dtx_error *err);

#endif /* DTX_BBW_H */
