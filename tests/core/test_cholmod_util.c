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

/* The diagonal position of column j in A (sorted lower triangle). */
static double *diag_of(cholmod_sparse *A, int j)
{
    return (double *)A->x + ((int *)A->p)[j];
}

/* max |a - b| and max |b| over n entries. */
static void max_diff(const double *a, const double *b, size_t n, double *d, double *bmax)
{
    *d = 0.0;
    *bmax = 0.0;
    for (size_t q = 0; q < n; q++) {
        double e = fabs(a[q] - b[q]);
        *d = e > *d || e != e ? e : *d;
        *bmax = fabs(b[q]) > *bmax ? fabs(b[q]) : *bmax;
    }
}

/* The low-rank solve from A's factor against a fresh factorisation of A'
 * = A plus updates (+w on rows that had nothing added) and downdates (-w
 * on rows that had +w: the correspondence's vertices that lose their
 * closest point, where S subtracts nearly equal terms), w large against
 * A's diagonal; supernodal L L' and simplicial L D L'.  Then the
 * refinement against A' reaches a direct solve's backward error, and bad
 * changes, an unreachable tolerance and too few steps are reported. */
static void lowrank_vs_fresh(void)
{
    enum { M = 10, N = M * M * M, NUP = 6, NDOWN = 6, NRHS = 3 };
    const double w = 5000.0;
    for (int super = 1; super >= 0; super--) {
        cholmod_common cc;
        cholmod_sparse *A, *A2;
        cholmod_factor *L = NULL, *L2 = NULL;
        cholmod_dense *B, *Xref = NULL, *X = NULL;
        dtx__chol_lowrank lr;
        dtx_error err;
        int32_t idx[NUP + NDOWN];
        double c[NUP + NDOWN], d, xmax;
        int steps = -1;
        memset(&err, 0, sizeof err);
        memset(&lr, 0, sizeof lr);
        dtx__chol_start(&cc, super ? DTX__CHOL_AUTO : DTX__CHOL_SIMPLICIAL, DTX__CHOL_ORDER_AMD);
        if (super)
            cc.supernodal = CHOLMOD_SUPERNODAL;
        A = grid3(M, 7.0, 0.3, &cc);
        A2 = grid3(M, 7.0, 0.3, &cc);
        B = cholmod_zeros(N, NRHS, CHOLMOD_REAL, &cc);
        CHECK(A && A2 && B);
        if (!A || !A2 || !B)
            return;
        for (int q = 0; q < N * NRHS; q++)
            ((double *)B->x)[q] = cos(0.7 * q) + 0.5;
        /* A: +w on the rows to be downdated; A2 (= A'): +w on the others. */
        for (int a = 0; a < NUP + NDOWN; a++) {
            int row = (int)((a * 7919L + 13) % N);
            double before;
            idx[a] = row;
            if (a < NDOWN)
                *diag_of(A, row) += w;
            else
                *diag_of(A2, row) += w;
            before = *diag_of(A, row);
            c[a] = *diag_of(A2, row) - before;
        }
        CHECK_EQ_INT(dtx__chol_analyze_factorize(A, DTX__CHOL_NO_TEAMS, "A", NULL, &L, &cc, &err),
                     DTX_OK);
        CHECK_EQ_INT(dtx__chol_analyze_factorize(A2, DTX__CHOL_NO_TEAMS, "A'", NULL, &L2, &cc,
                                                 &err),
                     DTX_OK);
        if (!L || !L2)
            return;
        CHECK_EQ_INT(L->is_super, super);
        Xref = cholmod_solve(CHOLMOD_A, L2, B, &cc);
        CHECK(Xref != NULL);

        /* The Woodbury solve alone (no refinement asked). */
        CHECK_OK(dtx__chol_lowrank_set(L, NUP + NDOWN, idx, c, &lr, &cc, &err), &err);
        CHECK_OK(dtx__chol_lowrank_solve(&lr, L, A2, B, 0, 1.0, &X, &steps, &cc, &err), &err);
        CHECK_EQ_INT(steps, 0);
        max_diff(X->x, Xref->x, (size_t)N * NRHS, &d, &xmax);
        CHECK_DBL(xmax, >, 0.01);
        CHECK_DBL(d, <=, 1e-12 * xmax);
        /* With refinement to a direct solve's backward error. */
        CHECK_OK(dtx__chol_lowrank_solve(&lr, L, A2, B, 3, 1e-15, &X, &steps, &cc, &err), &err);
        CHECK_INT(steps, <=, 3);
        CHECK_DBL(lr.eta, <=, 1e-15);
        max_diff(X->x, Xref->x, (size_t)N * NRHS, &d, &xmax);
        CHECK_DBL(d, <=, 1e-13 * xmax);
        /* A tolerance no solve reaches, without steps: said, not hidden. */
        CHECK_EQ_INT(dtx__chol_lowrank_solve(&lr, L, A2, B, 0, 0.0, &X, &steps, &cc, &err),
                     DTX_ESOLVE);
        CHECK(strstr(err.msg, "backward error") != NULL);
        /* The old factor alone is not the answer: the changes matter. */
        {
            cholmod_dense *X0 = cholmod_solve(CHOLMOD_A, L, B, &cc);
            max_diff(X0->x, Xref->x, (size_t)N * NRHS, &d, &xmax);
            CHECK_DBL(d, >, 1e-6 * xmax);
            cholmod_free_dense(&X0, &cc);
        }
        /* Bad changes. */
        idx[0] = N;
        CHECK_EQ_INT(dtx__chol_lowrank_set(L, NUP + NDOWN, idx, c, &lr, &cc, &err), DTX_EINVAL);
        CHECK(lr.k == 0 && lr.wp == NULL);
        idx[0] = 0;
        c[0] = 0.0;
        CHECK_EQ_INT(dtx__chol_lowrank_set(L, 1, idx, c, &lr, &cc, &err), DTX_EINVAL);
        c[0] = NAN;
        CHECK_EQ_INT(dtx__chol_lowrank_set(L, 1, idx, c, &lr, &cc, &err), DTX_EINVAL);

        dtx__chol_lowrank_free(&lr, &cc);
        cholmod_free_dense(&X, &cc);
        cholmod_free_dense(&Xref, &cc);
        cholmod_free_dense(&B, &cc);
        cholmod_free_factor(&L2, &cc);
        cholmod_free_factor(&L, &cc);
        cholmod_free_sparse(&A2, &cc);
        cholmod_free_sparse(&A, &cc);
        cholmod_finish(&cc);
    }
}

/* A change that makes A' singular: A = I (n = 1..), c = -1 on a row. */
static void lowrank_singular(void)
{
    cholmod_common cc;
    cholmod_sparse *A;
    cholmod_factor *L = NULL;
    dtx__chol_lowrank lr;
    dtx_error err;
    int32_t idx[1] = {2};
    double c[1];
    memset(&err, 0, sizeof err);
    memset(&lr, 0, sizeof lr);
    dtx__chol_start(&cc, DTX__CHOL_SIMPLICIAL, DTX__CHOL_ORDER_AMD);
    A = tridiag(5, 4.0, &cc);
    CHECK(A != NULL);
    if (!A)
        return;
    /* Make row 2 decoupled (its off-diagonals zero) so that -4 on its
     * diagonal zeroes the whole row: A' singular, S = 1/c + 1/4 = 0. */
    ((double *)A->x)[((int *)A->p)[1] + 1] = 0.0;
    ((double *)A->x)[((int *)A->p)[2] + 1] = 0.0;
    c[0] = -4.0;
    CHECK_EQ_INT(dtx__chol_analyze_factorize(A, DTX__CHOL_NO_TEAMS, "A", NULL, &L, &cc, &err),
                 DTX_OK);
    if (L) {
        CHECK_EQ_INT(dtx__chol_lowrank_set(L, 1, idx, c, &lr, &cc, &err), DTX_ESOLVE);
        CHECK(strstr(err.msg, "singular") != NULL);
    }
    dtx__chol_lowrank_free(&lr, &cc);
    cholmod_free_factor(&L, &cc);
    cholmod_free_sparse(&A, &cc);
    cholmod_finish(&cc);
}

int main(void)
{
    settings();
    factor_and_solve();
    refactor_same_bits();
    not_positive_definite();
    error_mapping();
    lowrank_vs_fresh();
    lowrank_singular();
    return check_report();
}
