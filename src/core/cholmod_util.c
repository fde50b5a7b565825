/*
 * cholmod_util.c: the common's settings, analysis, factorisation and error
 * mapping for CHOLMOD (cholmod_util.h).
 */
#include "cholmod_util.h"

#ifdef _OPENMP
#include <omp.h>
#endif

void dtx__chol_start(cholmod_common *cc, dtx__chol_kind kind, dtx__chol_ordering ordering)
{
    cholmod_start(cc);
    cc->print = 0;
    if (kind == DTX__CHOL_SIMPLICIAL) {
        cc->supernodal = CHOLMOD_SIMPLICIAL;
        cc->final_ll = 0;
    }
    /* One method only: CHOLMOD's default also tries METIS when AMD's fill
     * is high, which for the AMD callers costs more than it saves; the
     * NESDIS caller wants METIS whatever AMD would give. */
    if (ordering == DTX__CHOL_ORDER_AMD) {
        cc->nmethods = 1;
        cc->method[0].ordering = CHOLMOD_AMD;
    } else if (ordering == DTX__CHOL_ORDER_NESDIS) {
        cc->nmethods = 1;
        cc->method[0].ordering = CHOLMOD_NESDIS;
    }
}

dtx_status dtx__chol_error(const cholmod_factor *L, const char *doing, const char *system,
                           const char *hint, const cholmod_common *cc, dtx_error *err)
{
    if (!hint)
        hint = "";
    if (cc->status == CHOLMOD_OUT_OF_MEMORY)
        return dtx_seterr(err, DTX_ENOMEM, "%s could not be %s (CHOLMOD status %d: out of memory)",
                          system, doing, cc->status);
    if (cc->status == CHOLMOD_NOT_POSDEF && L)
        return dtx_seterr(err, DTX_ESOLVE,
                          "%s could not be %s (CHOLMOD status %d: not positive definite at "
                          "column %d of %d)%s",
                          system, doing, cc->status, (int)L->minor + 1, (int)L->n, hint);
    return dtx_seterr(err, DTX_ESOLVE, "%s could not be %s (CHOLMOD status %d)%s", system, doing,
                      cc->status, hint);
}

dtx_status dtx__chol_analyze(cholmod_sparse *A, const char *system, cholmod_factor **L,
                             cholmod_common *cc, dtx_error *err)
{
    *L = cholmod_analyze(A, cc);
    if (!*L || cc->status < CHOLMOD_OK) {
        cholmod_free_factor(L, cc);
        return dtx__chol_error(NULL, "analysed", system, NULL, cc, err);
    }
    return DTX_OK;
}

/* cholmod_factorize(A, L, cc) in a team of two of which only the first
 * thread works, when not already inside a parallel region (cholmod_util.h). */
static int factorize_no_teams(cholmod_sparse *A, cholmod_factor *L, cholmod_common *cc)
{
    int ok = 0;
#ifdef _OPENMP
    if (!omp_in_parallel()) {
#pragma omp parallel num_threads(2)
        {
#pragma omp master
            ok = cholmod_factorize(A, L, cc);
        }
        return ok;
    }
#endif
    ok = cholmod_factorize(A, L, cc);
    return ok;
}

dtx_status dtx__chol_factorize(cholmod_sparse *A, dtx__chol_threads threads, const char *system,
                               const char *hint, cholmod_factor *L, cholmod_common *cc,
                               dtx_error *err)
{
    int ok =
        threads == DTX__CHOL_NO_TEAMS ? factorize_no_teams(A, L, cc) : cholmod_factorize(A, L, cc);
    if (ok && cc->status == CHOLMOD_OK)
        return DTX_OK;
    return dtx__chol_error(L, "factored", system, hint, cc, err);
}

dtx_status dtx__chol_analyze_factorize(cholmod_sparse *A, dtx__chol_threads threads,
                                       const char *system, const char *hint, cholmod_factor **L,
                                       cholmod_common *cc, dtx_error *err)
{
    dtx_status st = dtx__chol_analyze(A, system, L, cc, err);
    if (st == DTX_OK) {
        st = dtx__chol_factorize(A, threads, system, hint, *L, cc, err);
        if (st != DTX_OK)
            cholmod_free_factor(L, cc);
    }
    return st;
}
