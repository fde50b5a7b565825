/*
 * cholmod_util.c: the common's settings, analysis, factorisation and error
 * mapping for CHOLMOD (cholmod_util.h).
 */
#include "cholmod_util.h"

#include <stdlib.h>

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

/* The numeric factorisation: of A by cholmod_factorize, or (A NULL) of the
 * already permuted S by cholmod_super_numeric, which is what
 * cholmod_factorize calls after its transposes. */
static int factorize_either(cholmod_sparse *A, cholmod_sparse *S, cholmod_factor *L,
                            cholmod_common *cc)
{
    double zero[2] = {0.0, 0.0};
    return A ? cholmod_factorize(A, L, cc) : cholmod_super_numeric(S, NULL, zero, L, cc);
}

/* factorize_either with CHOLMOD's parallel regions inactive (one thread
 * each): outside any active region, by allowing no active level for the
 * call's duration (no other thread of this process runs OpenMP code then);
 * inside one, nested regions already get one thread (cholmod_util.h). */
static int factorize_no_teams(cholmod_sparse *A, cholmod_sparse *S, cholmod_factor *L,
                              cholmod_common *cc)
{
    int ok = 0;
#ifdef _OPENMP
    if (!omp_in_parallel()) {
        const int levels = omp_get_max_active_levels();
        omp_set_max_active_levels(0);
        ok = factorize_either(A, S, L, cc);
        omp_set_max_active_levels(levels);
        return ok;
    }
#endif
    ok = factorize_either(A, S, L, cc);
    return ok;
}

static dtx_status factorize(cholmod_sparse *A, cholmod_sparse *S, dtx__chol_threads threads,
                            const char *system, const char *hint, cholmod_factor *L,
                            cholmod_common *cc, dtx_error *err)
{
    int ok = threads == DTX__CHOL_NO_TEAMS ? factorize_no_teams(A, S, L, cc)
                                           : factorize_either(A, S, L, cc);
    if (ok && cc->status == CHOLMOD_OK)
        return DTX_OK;
    return dtx__chol_error(L, "factored", system, hint, cc, err);
}

dtx_status dtx__chol_factorize(cholmod_sparse *A, dtx__chol_threads threads, const char *system,
                               const char *hint, cholmod_factor *L, cholmod_common *cc,
                               dtx_error *err)
{
    return factorize(A, NULL, threads, system, hint, L, cc, err);
}

dtx_status dtx__chol_refactor_start(cholmod_sparse *A, const cholmod_factor *L,
                                    dtx__chol_refactor *R, cholmod_common *cc, dtx_error *err)
{
    cholmod_sparse *I = NULL, *U = NULL;
    size_t nz;
    R->S = NULL;
    R->src = NULL;
    /* Only the case cholmod_factorize handles with two transposes (see
     * cholmod_factorize.c: supernodal, permuted, stype < 0). */
    if (!L->is_super || L->ordering == CHOLMOD_NATURAL || A->stype >= 0 ||
        A->xtype != CHOLMOD_REAL || A->dtype != CHOLMOD_DOUBLE || A->itype != CHOLMOD_INT ||
        !A->packed)
        return DTX_OK;
    /* The same two transposes, of a copy of A holding each entry's own
     * position as its value (exact in a double): they move values without
     * arithmetic, so S->x then says where each of S's entries comes from. */
    nz = ((int32_t *)A->p)[A->ncol];
    I = cholmod_copy_sparse(A, cc);
    if (!I)
        goto nomem;
    for (size_t k = 0; k < nz; k++)
        ((double *)I->x)[k] = (double)k;
    U = cholmod_ptranspose(I, 2, L->Perm, NULL, 0, cc);
    cholmod_free_sparse(&I, cc);
    if (!U)
        goto nomem;
    R->S = cholmod_ptranspose(U, 2, NULL, NULL, 0, cc);
    cholmod_free_sparse(&U, cc);
    if (!R->S)
        goto nomem;
    nz = ((int32_t *)R->S->p)[R->S->ncol];
    R->src = malloc((nz ? nz : 1) * sizeof *R->src);
    if (!R->src)
        goto nomem;
    for (size_t q = 0; q < nz; q++)
        R->src[q] = (int32_t)((double *)R->S->x)[q];
    return DTX_OK;
nomem:
    dtx__chol_refactor_free(R, cc);
    return dtx_seterr(err, DTX_ENOMEM, "out of memory preparing a refactorisation");
}

dtx_status dtx__chol_factorize_again(cholmod_sparse *A, dtx__chol_refactor *R,
                                     dtx__chol_threads threads, const char *system,
                                     const char *hint, cholmod_factor *L, cholmod_common *cc,
                                     dtx_error *err)
{
    if (!R->S)
        return factorize(A, NULL, threads, system, hint, L, cc, err);
    {
        const int32_t nz = ((int32_t *)R->S->p)[R->S->ncol];
        const double *Ax = A->x;
        double *Sx = R->S->x;
        const int32_t *src = R->src;
        /* Each entry is copied on its own: no trace of the schedule. */
#pragma omp parallel for schedule(static) if (nz > 100000 && !omp_in_parallel())
        for (int32_t q = 0; q < nz; q++)
            Sx[q] = Ax[src[q]];
    }
    return factorize(NULL, R->S, threads, system, hint, L, cc, err);
}

void dtx__chol_refactor_free(dtx__chol_refactor *R, cholmod_common *cc)
{
    cholmod_free_sparse(&R->S, cc);
    free(R->src);
    R->src = NULL;
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
