/*
 * cholmod_util.h: how the core library drives CHOLMOD (internal to the core
 * library): one place for the common's settings, the symbolic analysis, the
 * numeric factorisation and the mapping of CHOLMOD's failures to a
 * dtx_status with a message naming the caller's system.
 *
 * Every caller owns its cholmod_common (one per concurrent caller) and its
 * factors; solves stay with the callers (cholmod_solve2 with workspace they
 * keep across frames), except solves with a few diagonal entries of the
 * factored matrix changed (dtx__chol_lowrank_*, chol_lowrank.c).
 *
 * Factorising without CHOLMOD's own OpenMP teams (DTX__CHOL_NO_TEAMS).
 * CHOLMOD's supernodal factorisation runs some of its loops on OpenMP
 * teams of a size fixed when it was built (4 in Debian's), whatever
 * OMP_NUM_THREADS says.  On two cores those teams cost far more than they
 * bring: on the 174,000-unknown correspondence system of the pebble camel
 * (tests/bench/bench_mc.c) a factorisation takes 1.15 s with them and 0.6 s
 * without (2 to 10 s with OMP_THREAD_LIMIT=2); a springs Newton step went
 * from 0.2 s to 7.9 s on a busy machine.  Inside an active parallel region
 * nested regions get one thread (OpenMP's default max-active-levels is 1),
 * so there the factorisation is called directly; outside one it is called
 * with max-active-levels set to 0 for its duration, which makes every
 * region inactive.  (It used to be called from the first thread of a team
 * of two while the second waited: on the pebble camel's seven
 * correspondence factorisations the waiting thread and the nested teams'
 * wake-ups cost 0.4 to 0.5 s of the calling thread's CPU time and 0.5 to
 * 1 s of the process's.)  The loops only copy and clear, so the result is
 * the same bits either way.
 */
#ifndef DTX_CHOLMOD_UTIL_H
#define DTX_CHOLMOD_UTIL_H

#include "status.h"

#include <stdint.h>

#include <cholmod.h>

/* Which factorisation CHOLMOD computes. */
typedef enum {
    /* CHOLMOD's default: supernodal L L' when the analysis finds enough
     * fill for it to pay, simplicial L D L' otherwise. */
    DTX__CHOL_AUTO,
    /* Always simplicial L D L' (cc->supernodal = CHOLMOD_SIMPLICIAL,
     * cc->final_ll = 0). */
    DTX__CHOL_SIMPLICIAL
} dtx__chol_kind;

/* Fill-reducing ordering tried by the analysis. */
typedef enum {
    /* CHOLMOD's default strategy: AMD, and METIS nested dissection as well
     * when AMD's fill is high, keeping the better. */
    DTX__CHOL_ORDER_DEFAULT,
    /* AMD only (cc->nmethods = 1). */
    DTX__CHOL_ORDER_AMD,
    /* METIS nested dissection only (CHOLMOD_NESDIS, cc->nmethods = 1). */
    DTX__CHOL_ORDER_NESDIS
} dtx__chol_ordering;

/* Whether the numeric factorisation may use CHOLMOD's OpenMP teams (see
 * the file comment). */
typedef enum {
    DTX__CHOL_TEAMS,   /* cholmod_factorize as it is */
    DTX__CHOL_NO_TEAMS /* without CHOLMOD's own OpenMP teams */
} dtx__chol_threads;

/* cholmod_start(cc) and dtx's settings: no printing, the factor kind and
 * the ordering; everything else (int indices, double values, postordering)
 * stays at CHOLMOD's defaults.  A common that only solves takes
 * DTX__CHOL_AUTO, DTX__CHOL_ORDER_DEFAULT.  Release with cholmod_finish. */
void dtx__chol_start(cholmod_common *cc, dtx__chol_kind kind, dtx__chol_ordering ordering);

/* Symbolic analysis of A (symmetric, the triangle its stype says) with
 * cc's ordering, into *L (free with cholmod_free_factor).  On failure *L is
 * NULL and the status and err come from dtx__chol_error ("analysed"). */
dtx_status dtx__chol_analyze(cholmod_sparse *A, const char *system, cholmod_factor **L,
                             cholmod_common *cc, dtx_error *err);

/* Numeric factorisation of A into L (analysed from A's pattern), reusing
 * L's symbolic part.  DTX_OK when L is a complete factor
 * (cholmod_factorize succeeded and left cc->status at CHOLMOD_OK, so
 * L->minor == L->n); otherwise the status and err of dtx__chol_error
 * ("factored").  err may be NULL for a caller that retries: the status
 * still tells DTX_ENOMEM from DTX_ESOLVE. */
dtx_status dtx__chol_factorize(cholmod_sparse *A, dtx__chol_threads threads, const char *system,
                               const char *hint, cholmod_factor *L, cholmod_common *cc,
                               dtx_error *err);

/* The matrix that cholmod_factorize hands to the supernodal factorisation,
 * kept across numeric factorisations of one pattern.  For a symmetric A
 * stored as its lower triangle and a supernodal L with a fill-reducing
 * permutation p, cholmod_factorize transposes A twice (into triu(A(p,p))
 * and back into tril(A(p,p))) on every call before factorising; on the
 * 174,000-unknown correspondence system that is a tenth of each
 * factorisation.  The refactorisation makes those transposes once, with
 * each entry's position in A recorded, and afterwards only copies A's
 * values into place: the same matrix, so the same factor, bit for bit. */
typedef struct {
    cholmod_sparse *S; /* tril(A(p,p)); NULL: refactorise with cholmod_factorize */
    int32_t *src;      /* S->nzmax: the entry of A->x that S->x[q] holds */
} dtx__chol_refactor;

/* Prepares R for refactorising matrices of A's pattern into L (analysed
 * from A).  When L is not supernodal, has the natural ordering or A is not
 * symmetric-lower, R->S stays NULL and dtx__chol_factorize_again calls
 * cholmod_factorize.  DTX_ENOMEM (err says so) when out of memory.  Release
 * with dtx__chol_refactor_free. */
dtx_status dtx__chol_refactor_start(cholmod_sparse *A, const cholmod_factor *L,
                                    dtx__chol_refactor *R, cholmod_common *cc, dtx_error *err);

/* dtx__chol_factorize of A (the pattern R was prepared from, any values)
 * into L: the same result, bit for bit, without the transposes. */
dtx_status dtx__chol_factorize_again(cholmod_sparse *A, dtx__chol_refactor *R,
                                     dtx__chol_threads threads, const char *system,
                                     const char *hint, cholmod_factor *L, cholmod_common *cc,
                                     dtx_error *err);

/* Frees R's matrix and map (R may be unprepared, all NULL). */
void dtx__chol_refactor_free(dtx__chol_refactor *R, cholmod_common *cc);

/* dtx__chol_analyze then dtx__chol_factorize into *L; on failure *L is
 * NULL (no factor is left behind). */
dtx_status dtx__chol_analyze_factorize(cholmod_sparse *A, dtx__chol_threads threads,
                                       const char *system, const char *hint, cholmod_factor **L,
                                       cholmod_common *cc, dtx_error *err);

/* Turns the failure of a CHOLMOD call that was `doing` ("analysed",
 * "factored") the caller's `system` (a noun phrase that starts the
 * message, e.g. "the springs Newton system") into a status and a message:
 *   CHOLMOD_OUT_OF_MEMORY: DTX_ENOMEM, "SYSTEM could not be DOING (CHOLMOD
 *     status -2: out of memory)";
 *   CHOLMOD_NOT_POSDEF: DTX_ESOLVE, "... (CHOLMOD status 1: not positive
 *     definite at column K of N)HINT", K = L->minor + 1 counted from 1
 *     (without it when L is NULL);
 *   anything else: DTX_ESOLVE, "... (CHOLMOD status S)HINT".
 * hint (NULL for none) is appended as it is, so it brings its own
 * separator ("; the mesh may have degenerate triangles").  err may be
 * NULL; returns the status. */
dtx_status dtx__chol_error(const cholmod_factor *L, const char *doing, const char *system,
                           const char *hint, const cholmod_common *cc, dtx_error *err);

/* ------------------------------------------------------------------ */
/* Low-rank diagonal changes (chol_lowrank.c)                          */
/* ------------------------------------------------------------------ */

/* Solves with A' = A + sum_a c[a] e_idx[a] e_idx[a]' (a few diagonal
 * entries of A changed) from a factor L of A, without refactorising:
 * Sherman-Morrison-Woodbury, see chol_lowrank.c.  Set up with
 * dtx__chol_lowrank_set, solve any number of times with
 * dtx__chol_lowrank_solve while L holds A's factor, release with
 * dtx__chol_lowrank_free.  Zero-initialise before the first set. */
typedef struct {
    int32_t k, n;
    int64_t nw;       /* entries of W */
    int64_t *wp;      /* k + 1: column starts of W = L \ (P U) */
    int32_t *wi;      /* nw: their rows, in the factor's order */
    double *wx;       /* nw: their values */
    double *dinv;     /* n: 1 / D (1 for an L L' factor) */
    double *s;        /* k x k: LU of S = C^-1 + W' D^-1 W, row-major */
    int32_t *piv;     /* k: its row interchanges */
    double *t;        /* 8 k: scratch */
    double eta;       /* backward error of the last solve */
    cholmod_dense *Y1, *Y2, *R, *DX, *Yw, *Ew; /* workspace kept across solves */
} dtx__chol_lowrank;

/* Prepares lr for the k changes (idx: distinct rows of A in [0, n), c:
 * finite nonzero changes) of the matrix that L (numeric, complete: a
 * supernodal L L' or a simplicial factor, int indices, real double) holds.
 * Costs the k forward solves along the elimination tree paths of the
 * changed rows, and O(k^3).  DTX_EINVAL for an unsupported factor or a bad
 * change, DTX_ESOLVE when S is singular (A' is), DTX_ENOMEM; lr is then
 * empty.  Not thread-safe on one lr. */
dtx_status dtx__chol_lowrank_set(const cholmod_factor *L, int32_t k, const int32_t *idx,
                                 const double *c, dtx__chol_lowrank *lr, cholmod_common *cc,
                                 dtx_error *err);

/* *X (allocated or reused, as cholmod_solve2's X) = A'^-1 B, B n x m (m <=
 * 8), A the changed matrix A' itself (symmetric, lower triangle, packed):
 * the Woodbury solve, then refinement steps x += A'^-1 (B - A' x) (each
 * costs a solve with L and a mat-vec with A) until the backward error
 * max over columns |B - A' x|_inf / (|A'|_inf |x|_inf + |B|_inf) is at
 * most tol, for at most max_steps steps (*steps says how many; lr->eta the
 * last backward error).  DTX_ESOLVE when tol was not reached (*X holds the
 * last iterate), DTX_ENOMEM.  Serial, in a fixed order: the same bits for
 * any thread count. */
dtx_status dtx__chol_lowrank_solve(dtx__chol_lowrank *lr, cholmod_factor *L, cholmod_sparse *A,
                                   cholmod_dense *B, int max_steps, double tol, cholmod_dense **X,
                                   int *steps, cholmod_common *cc, dtx_error *err);

/* Frees what lr holds and zeroes it (lr may be NULL or empty). */
void dtx__chol_lowrank_free(dtx__chol_lowrank *lr, cholmod_common *cc);

#endif /* DTX_CHOLMOD_UTIL_H */
