/* test_cholmod_util.c: the CHOLMOD wrapper (core/cholmod_util.h). */
#include "check.h"
#include "cholmod_util.h"

#include <math.h>
#include <string.h>

/* The n x n tridiagonal matrix with d on the diagonal and -1 beside it,
 * lower triangle (stype -1), sorted and packed.  Positive definite for
 * d >= 2; with d = 1 the leading 2 x 2 block [1 -1; -1 1] is singular, so
 * in the natural order the factorisation breaks down at column 2 (counted
 * from 1) with an exact zero pivot. */
static cholmod_sparse *tridiag(int n, double d, cholmod_common *cc)
{
    cholmod_sparse *A = cholmod_allocate_sparse((size_t)n, (size_t)n, (size_t)(2 * n - 1), 1, 1, -1,
                                                CHOLMOD_REAL, cc);
    int *Ap, *Ai, k = 0;
    double *Ax;
    if (!A)
        return NULL;
    Ap = A->p;
    Ai = A->i;
    Ax = A->x;
    for (int j = 0; j < n; j++) {
        Ap[j] = k;
        Ai[k] = j;
        Ax[k++] = d;
        if (j + 1 < n) {
            Ai[k] = j + 1;
            Ax[k++] = -1.0;
        }
    }
    Ap[n] = k;
    return A;
}

/* The settings each caller asks for reach the common. */
static void settings(void)
{
    cholmod_common cc;
    dtx__chol_start(&cc, DTX__CHOL_AUTO, DTX__CHOL_ORDER_DEFAULT);
    CHECK_EQ_INT(cc.print, 0);
    CHECK_EQ_INT(cc.supernodal, CHOLMOD_AUTO);
    CHECK_EQ_INT(cc.nmethods, 0);
    CHECK_EQ_INT(cc.final_ll, 0);
    CHECK_EQ_INT(cc.postorder, 1);
    cholmod_finish(&cc);

    dtx__chol_start(&cc, DTX__CHOL_SIMPLICIAL, DTX__CHOL_ORDER_AMD);
    CHECK_EQ_INT(cc.print, 0);
    CHECK_EQ_INT(cc.supernodal, CHOLMOD_SIMPLICIAL);
    CHECK_EQ_INT(cc.final_ll, 0);
    CHECK_EQ_INT(cc.nmethods, 1);
    CHECK_EQ_INT(cc.method[0].ordering, CHOLMOD_AMD);
    CHECK_EQ_INT(cc.postorder, 1);
    cholmod_finish(&cc);

    dtx__chol_start(&cc, DTX__CHOL_SIMPLICIAL, DTX__CHOL_ORDER_NESDIS);
    CHECK_EQ_INT(cc.supernodal, CHOLMOD_SIMPLICIAL);
    CHECK_EQ_INT(cc.nmethods, 1);
    CHECK_EQ_INT(cc.method[0].ordering, CHOLMOD_NESDIS);
    cholmod_finish(&cc);
}

/* A positive definite system factors (with and without CHOLMOD's teams,
 * to the same bits) and solves to the known answer: A x = A 1. */
static void factor_and_solve(void)
{
    enum { N = 50 };
    cholmod_common cc;
    cholmod_sparse *A;
    cholmod_factor *L = NULL, *L2 = NULL;
    cholmod_dense *ones, *b, *x;
    double one[2] = {1, 0}, zero[2] = {0, 0};
    dtx_error err;
    memset(&err, 0, sizeof err);
    dtx__chol_start(&cc, DTX__CHOL_SIMPLICIAL, DTX__CHOL_ORDER_AMD);
    A = tridiag(N, 3.0, &cc);
    CHECK(A != NULL);
    CHECK_EQ_INT(
        dtx__chol_analyze_factorize(A, DTX__CHOL_TEAMS, "the test system", NULL, &L, &cc, &err),
        DTX_OK);
    CHECK(L != NULL);
    CHECK_EQ_INT(L->is_super, 0);
    CHECK_EQ_INT(L->is_ll, 0);
    CHECK_EQ_INT(L->minor, N);
    CHECK_EQ_INT(dtx__chol_analyze(A, "the test system", &L2, &cc, &err), DTX_OK);
    CHECK_EQ_INT(dtx__chol_factorize(A, DTX__CHOL_NO_TEAMS, "the test system", NULL, L2, &cc, &err),
                 DTX_OK);
    CHECK_EQ_INT(memcmp(L->x, L2->x, ((int *)L->p)[N] * sizeof(double)), 0);

    ones = cholmod_ones(N, 1, CHOLMOD_REAL, &cc);
    b = cholmod_zeros(N, 1, CHOLMOD_REAL, &cc);
    cholmod_sdmult(A, 0, one, zero, ones, b, &cc);
    x = cholmod_solve(CHOLMOD_A, L, b, &cc);
    CHECK(x != NULL);
    for (int i = 0; x && i < N; i++)
        CHECK_NEAR(((double *)x->x)[i], 1.0, 1e-12);
    cholmod_free_dense(&x, &cc);
    cholmod_free_dense(&b, &cc);
    cholmod_free_dense(&ones, &cc);
    cholmod_free_factor(&L2, &cc);
    cholmod_free_factor(&L, &cc);
    cholmod_free_sparse(&A, &cc);
    cholmod_finish(&cc);
}

/* The m x m x m grid's 7-point matrix, lower triangle (stype -1), sorted
 * and packed, its values varying with `seed` (positive definite when
 * diag > 6.6): enough fill for a supernodal factor. */
static cholmod_sparse *grid3(int m, double diag, double seed, cholmod_common *cc)
{
    const int n = m * m * m;
    cholmod_sparse *A =
        cholmod_allocate_sparse((size_t)n, (size_t)n, (size_t)(4 * n), 1, 1, -1, CHOLMOD_REAL, cc);
    int *Ap, *Ai, k = 0;
    double *Ax;
    if (!A)
        return NULL;
    Ap = A->p;
    Ai = A->i;
    Ax = A->x;
    for (int j = 0; j < n; j++) {
        const int x = j % m, y = (j / m) % m, z = j / (m * m);
        Ap[j] = k;
        Ai[k] = j;
        Ax[k++] = diag + 0.1 * sin(seed + j);
        if (x + 1 < m) {
            Ai[k] = j + 1;
            Ax[k++] = -1.0 - 0.1 * cos(seed + 3 * j);
        }
        if (y + 1 < m) {
            Ai[k] = j + m;
            Ax[k++] = -1.0 - 0.1 * cos(seed + 5 * j);
        }
        if (z + 1 < m) {
            Ai[k] = j + m * m;
            Ax[k++] = -1.0 - 0.1 * cos(seed + 7 * j);
        }
    }
    Ap[n] = k;
    return A;
}

/* dtx__chol_factorize_again gives dtx__chol_factorize's factor bit for bit
 * (supernodal: by its own permuted copy; simplicial: by cholmod_factorize),
 * for the matrix it was prepared from and for new values on the same
 * pattern, and fails as dtx__chol_factorize does on an indefinite one. */
static void refactor_same_bits(void)
{
    enum { M = 12 };
    for (int super = 1; super >= 0; super--) {
        cholmod_common cc;
        cholmod_sparse *A;
        cholmod_factor *L = NULL, *L2 = NULL;
        dtx__chol_refactor R = {NULL, NULL};
        dtx_error err, err2;
        memset(&err, 0, sizeof err);
        memset(&err2, 0, sizeof err2);
        dtx__chol_start(&cc, super ? DTX__CHOL_AUTO : DTX__CHOL_SIMPLICIAL, DTX__CHOL_ORDER_AMD);
        if (super)
            cc.supernodal = CHOLMOD_SUPERNODAL;
        A = grid3(M, 7.0, 0.0, &cc);
        CHECK(A != NULL);
        if (!A)
            return;
        CHECK_EQ_INT(dtx__chol_analyze(A, "the test system", &L, &cc, &err), DTX_OK);
        CHECK_EQ_INT(dtx__chol_analyze(A, "the test system", &L2, &cc, &err), DTX_OK);
        CHECK_EQ_INT(L->is_super, super);
        CHECK_EQ_INT(dtx__chol_refactor_start(A, L2, &R, &cc, &err), DTX_OK);
        CHECK_EQ_INT(R.S != NULL, super);
        for (int round = 0; round < 3; round++) {
            cholmod_sparse *B = grid3(M, round == 2 ? 1.0 : 7.0 + round, 0.5 * round, &cc);
            dtx_status s1, s2;
            CHECK(B != NULL);
            if (!B)
                break;
            s1 = dtx__chol_factorize(B, DTX__CHOL_NO_TEAMS, "the test system", "; hint", L, &cc,
                                     &err);
            s2 = dtx__chol_factorize_again(B, &R, DTX__CHOL_NO_TEAMS, "the test system", "; hint",
                                           L2, &cc, &err2);
            if (round < 2) {
                CHECK_EQ_INT(s1, DTX_OK);
                CHECK_EQ_INT(s2, DTX_OK);
                CHECK_EQ_INT((int)L->xsize, (int)L2->xsize);
                CHECK_EQ_INT(memcmp(L->x, L2->x, L->xsize * sizeof(double)), 0);
            } else {
                /* Diagonal 1 against six neighbours: indefinite, which
                 * the supernodal L L' cannot factor (a simplicial L D L'
                 * may, with negative pivots). */
                if (super)
                    CHECK_EQ_INT(s1, DTX_ESOLVE);
                CHECK_EQ_INT(s2, s1);
                CHECK_EQ_INT((int)L->minor, (int)L2->minor);
                if (s1 != DTX_OK)
                    CHECK(strcmp(err.msg, err2.msg) == 0);
                else
                    CHECK_EQ_INT(memcmp(L->x, L2->x, L->xsize * sizeof(double)), 0);
            }
            cholmod_free_sparse(&B, &cc);
        }
        dtx__chol_refactor_free(&R, &cc);
        CHECK(R.S == NULL && R.src == NULL);
        cholmod_free_factor(&L2, &cc);
        cholmod_free_factor(&L, &cc);
        cholmod_free_sparse(&A, &cc);
        cholmod_finish(&cc);
    }
}

/* An indefinite system is DTX_ESOLVE naming the caller's system, the
 * failing column and the hint, and leaves no factor behind; without err
 * the status alone says the same. */
static void not_positive_definite(void)
{
    cholmod_common cc;
    cholmod_sparse *A;
    cholmod_factor *L = NULL;
    dtx_error err;
    memset(&err, 0, sizeof err);
    /* Natural ordering so that the failing column is known (the
     * postordering of a path is the identity). */
    dtx__chol_start(&cc, DTX__CHOL_SIMPLICIAL, DTX__CHOL_ORDER_AMD);
    cc.method[0].ordering = CHOLMOD_NATURAL;
    A = tridiag(6, 1.0, &cc);
    CHECK(A != NULL);
    CHECK_EQ_INT(dtx__chol_analyze_factorize(A, DTX__CHOL_NO_TEAMS, "the springs Newton system",
                                             "; check the springs", &L, &cc, &err),
                 DTX_ESOLVE);
    CHECK(L == NULL);
    CHECK_EQ_INT(err.code, DTX_ESOLVE);
    CHECK(strcmp(err.msg, "the springs Newton system could not be factored (CHOLMOD status 1: "
                          "not positive definite at column 2 of 6); check the springs") == 0);
    if (strstr(err.msg, "column 2 of 6") == NULL)
        fprintf(stderr, "  message: %s\n", err.msg);

    CHECK_EQ_INT(dtx__chol_analyze(A, "the springs Newton system", &L, &cc, NULL), DTX_OK);
    CHECK_EQ_INT(
        dtx__chol_factorize(A, DTX__CHOL_TEAMS, "the springs Newton system", NULL, L, &cc, NULL),
        DTX_ESOLVE);
    CHECK_INT(L->minor, <, L->n);
    cholmod_free_factor(&L, &cc);
    cholmod_free_sparse(&A, &cc);
    cholmod_finish(&cc);
}

/* The mapping of the statuses that are not about the matrix. */
static void error_mapping(void)
{
    cholmod_common cc;
    dtx_error err;
    memset(&err, 0, sizeof err);
    dtx__chol_start(&cc, DTX__CHOL_AUTO, DTX__CHOL_ORDER_DEFAULT);
    cc.status = CHOLMOD_OUT_OF_MEMORY;
    CHECK_EQ_INT(dtx__chol_error(NULL, "analysed", "the transfer system", "; hint", &cc, &err),
                 DTX_ENOMEM);
    CHECK(strcmp(err.msg, "the transfer system could not be analysed (CHOLMOD status -2: out of "
                          "memory)") == 0);
    cc.status = CHOLMOD_INVALID;
    CHECK_EQ_INT(dtx__chol_error(NULL, "factored", "the transfer system", "; hint", &cc, &err),
                 DTX_ESOLVE);
    CHECK(strcmp(err.msg, "the transfer system could not be factored (CHOLMOD status -4); hint") ==
          0);
    CHECK_EQ_INT(dtx__chol_error(NULL, "factored", "x", NULL, &cc, NULL), DTX_ESOLVE);
    cc.status = CHOLMOD_OK;
    cholmod_finish(&cc);
}

int main(void)
{
    settings();
    factor_and_solve();
    refactor_same_bits();
    not_positive_definite();
    error_mapping();
    return check_report();
}
