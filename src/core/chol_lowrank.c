/*
 * chol_lowrank.c: solves with A' = A + U C U' from a Cholesky factor of A,
 * where U's k columns are unit vectors (rows idx) and C = diag(c): a few
 * diagonal entries of A changed (Sherman-Morrison-Woodbury).
 *
 * With A = P' L D L' P (D = I for an L L' factor) and W = L \ (P U),
 *     A'^-1 = A^-1 - A^-1 U S^-1 U' A^-1,   S = C^-1 + W' D^-1 W,
 * so one application is a forward solve y = L \ (P b), the k x k system
 * S t = W' D^-1 y, and a back solve x = P' (L' \ (D \ (y - W t))): the cost
 * of one ordinary solve.  Each column of W is L \ e_j (j = the position of
 * a row of idx in the factor's order), whose nonzeros lie on the path from
 * j to the root of the elimination tree; it is computed along that path
 * only (supernode by supernode for a supernodal factor), so setting up
 * costs far less than a solve.  S is factored by Gaussian elimination with
 * partial pivoting (it is indefinite when some c are negative).
 *
 * A downdate (c < 0, undoing an earlier +w) subtracts nearly equal terms in
 * S, so the answer is refined against A' itself: residual r = b - A' x by
 * a mat-vec, correction by the same formula, until the backward error is
 * that of a direct solve.  Everything runs on the calling thread in a fixed
 * order: the result does not depend on the thread count.
 */
#include "cholmod_util.h"
#include "dtx_core.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void dtx__chol_lowrank_free(dtx__chol_lowrank *lr, cholmod_common *cc)
{
    if (!lr)
        return;
    free(lr->wp);
    free(lr->wi);
    free(lr->wx);
    free(lr->dinv);
    free(lr->s);
    free(lr->piv);
    free(lr->t);
    cholmod_free_dense(&lr->Y1, cc);
    cholmod_free_dense(&lr->Y2, cc);
    cholmod_free_dense(&lr->R, cc);
    cholmod_free_dense(&lr->DX, cc);
    cholmod_free_dense(&lr->Yw, cc);
    cholmod_free_dense(&lr->Ew, cc);
    memset(lr, 0, sizeof *lr);
}

/* Appends (j, y[j]) to W's last column, growing wi and wx; 0 when out of
 * memory. */
static int w_push(dtx__chol_lowrank *lr, int64_t *cap, int32_t j, double v)
{
    if (lr->nw == *cap) {
        int64_t nc = *cap ? 2 * *cap : 4096;
        int32_t *wi = realloc(lr->wi, (size_t)nc * sizeof *wi);
        double *wx;
        if (!wi)
            return 0;
        lr->wi = wi;
        wx = realloc(lr->wx, (size_t)nc * sizeof *wx);
        if (!wx)
            return 0;
        lr->wx = wx;
        *cap = nc;
    }
    lr->wi[lr->nw] = j;
    lr->wx[lr->nw] = v;
    lr->nw++;
    return 1;
}

/* y = L \ e_p along the elimination tree path from p, appended to W as a
 * column (the path's columns, ascending); y is all zero on entry and on
 * return.  col2sup: each column's supernode (supernodal L only). */
static int forward_unit(const cholmod_factor *L, const int32_t *col2sup, int32_t p, double *y,
                        dtx__chol_lowrank *lr, int64_t *cap)
{
    const double *Lx = L->x;
    const int64_t first = lr->nw;
    y[p] = 1.0;
    if (L->is_super) {
        const int32_t *super = L->super, *pi = L->pi, *px = L->px, *Ls = L->s;
        int32_t s = col2sup[p];
        while (s >= 0) {
            const int32_t k1 = super[s], nscol = super[s + 1] - k1;
            const int32_t nsrow = pi[s + 1] - pi[s];
            const int32_t *rows = Ls + pi[s];
            const double *Xs = Lx + px[s];
            for (int32_t c = k1 <= p ? p - k1 : 0; c < nscol; c++) {
                const double *col = Xs + (size_t)c * nsrow;
                double yj = y[k1 + c];
                if (yj != 0.0) {
                    yj /= col[c];
                    y[k1 + c] = yj;
                    for (int32_t r = c + 1; r < nsrow; r++)
                        y[rows[r]] -= col[r] * yj;
                }
                if (!w_push(lr, cap, k1 + c, yj))
                    return 0;
            }
            s = nsrow > nscol ? col2sup[rows[nscol]] : -1;
        }
    } else {
        const int32_t *Lp = L->p, *Li = L->i, *Lnz = L->nz;
        int32_t j = p;
        while (j >= 0) {
            const int32_t q0 = Lp[j], q1 = Lp[j] + Lnz[j];
            int32_t parent = -1;
            double yj = y[j];
            if (L->is_ll)
                yj /= Lx[q0];
            y[j] = yj;
            for (int32_t q = q0 + 1; q < q1; q++) {
                y[Li[q]] -= Lx[q] * yj;
                if (parent < 0 || Li[q] < parent)
                    parent = Li[q];
            }
            if (!w_push(lr, cap, j, yj))
                return 0;
            j = parent;
        }
    }
    for (int64_t q = first; q < lr->nw; q++)
        y[lr->wi[q]] = 0.0;
    return 1;
}

/* LU with partial pivoting of the k x k row-major a, in place; 0 when a
 * pivot is zero or not finite. */
static int lu_factor(double *a, int32_t *piv, int32_t k)
{
    for (int32_t c = 0; c < k; c++) {
        int32_t best = c;
        for (int32_t r = c + 1; r < k; r++)
            if (fabs(a[(size_t)r * k + c]) > fabs(a[(size_t)best * k + c]))
                best = r;
        piv[c] = best;
        if (best != c)
            for (int32_t q = 0; q < k; q++) {
                double t = a[(size_t)c * k + q];
                a[(size_t)c * k + q] = a[(size_t)best * k + q];
                a[(size_t)best * k + q] = t;
            }
        if (!(fabs(a[(size_t)c * k + c]) > 0.0) || !isfinite(a[(size_t)c * k + c]))
            return 0;
        for (int32_t r = c + 1; r < k; r++) {
            double f = a[(size_t)r * k + c] /= a[(size_t)c * k + c];
            for (int32_t q = c + 1; q < k; q++)
                a[(size_t)r * k + q] -= f * a[(size_t)c * k + q];
        }
    }
    return 1;
}

/* Solves with lu_factor's a and piv: the row interchanges first (the
 * multipliers were interchanged with their rows), then L and U. */
static void lu_solve(const double *a, const int32_t *piv, int32_t k, double *b)
{
    for (int32_t c = 0; c < k; c++) {
        double t = b[piv[c]];
        b[piv[c]] = b[c];
        b[c] = t;
    }
    for (int32_t c = 0; c < k; c++)
        for (int32_t r = c + 1; r < k; r++)
            b[r] -= a[(size_t)r * k + c] * b[c];
    for (int32_t c = k - 1; c >= 0; c--) {
        for (int32_t q = c + 1; q < k; q++)
            b[c] -= a[(size_t)c * k + q] * b[q];
        b[c] /= a[(size_t)c * k + c];
    }
}

dtx_status dtx__chol_lowrank_set(const cholmod_factor *L, int32_t k, const int32_t *idx,
                                 const double *c, dtx__chol_lowrank *lr, cholmod_common *cc,
                                 dtx_error *err)
{
    const int32_t n = (int32_t)L->n;
    int32_t *ipos = NULL, *col2sup = NULL;
    double *y = NULL;
    int64_t cap = 0;
    dtx_status st = DTX_OK;

    dtx__chol_lowrank_free(lr, cc);
    if (L->xtype != CHOLMOD_REAL || L->itype != CHOLMOD_INT || L->dtype != CHOLMOD_DOUBLE ||
        !L->is_monotonic || (L->is_super && !L->is_ll) || L->minor < L->n)
        return dtx_seterr(err, DTX_EINVAL, "low-rank solve: unsupported or incomplete factor");
    for (int32_t a = 0; a < k; a++)
        if (idx[a] < 0 || idx[a] >= n || !(c[a] != 0.0) || !isfinite(c[a]))
            return dtx_seterr(err, DTX_EINVAL,
                              "low-rank solve: change %d (row %d, value %g) is not a finite "
                              "nonzero change of a row of the matrix",
                              (int)a, (int)idx[a], c[a]);
    lr->k = k;
    lr->n = n;
    lr->wp = dtx_alloc((size_t)k + 1, sizeof *lr->wp, 1);
    lr->dinv = dtx_alloc((size_t)n, sizeof *lr->dinv, 0);
    lr->s = dtx_alloc((size_t)k * k + 1, sizeof *lr->s, 1);
    lr->piv = dtx_alloc((size_t)k + 1, sizeof *lr->piv, 0);
    lr->t = dtx_alloc((size_t)k + 1, 8 * sizeof *lr->t, 0);
    ipos = dtx_alloc((size_t)n, sizeof *ipos, 0);
    y = dtx_alloc((size_t)n, sizeof *y, 1);
    if (!lr->wp || !lr->dinv || !lr->s || !lr->piv || !lr->t || !ipos || !y)
        goto nomem;
    /* Where each row of A sits in the factor's order. */
    for (int32_t q = 0; q < n; q++)
        ipos[L->ordering == CHOLMOD_NATURAL ? q : ((const int32_t *)L->Perm)[q]] = q;
    if (L->is_super) {
        const int32_t *super = L->super;
        col2sup = dtx_alloc((size_t)n, sizeof *col2sup, 0);
        if (!col2sup)
            goto nomem;
        for (int32_t s = 0; s < (int32_t)L->nsuper; s++)
            for (int32_t j = super[s]; j < super[s + 1]; j++)
                col2sup[j] = s;
    }
    for (int32_t j = 0; j < n; j++)
        lr->dinv[j] = L->is_ll ? 1.0 : 1.0 / ((const double *)L->x)[((const int32_t *)L->p)[j]];

    /* W, a column per change. */
    for (int32_t a = 0; a < k; a++) {
        if (!forward_unit(L, col2sup, ipos[idx[a]], y, lr, &cap))
            goto nomem;
        lr->wp[a + 1] = lr->nw;
    }
    /* S = C^-1 + W' D^-1 W, one column of W scattered at a time. */
    for (int32_t a = 0; a < k; a++) {
        for (int64_t q = lr->wp[a]; q < lr->wp[a + 1]; q++)
            y[lr->wi[q]] = lr->wx[q] * lr->dinv[lr->wi[q]];
        for (int32_t b = 0; b <= a; b++) {
            double sum = 0.0;
            for (int64_t q = lr->wp[b]; q < lr->wp[b + 1]; q++)
                sum += lr->wx[q] * y[lr->wi[q]];
            lr->s[(size_t)a * k + b] = sum;
            lr->s[(size_t)b * k + a] = sum;
        }
        for (int64_t q = lr->wp[a]; q < lr->wp[a + 1]; q++)
            y[lr->wi[q]] = 0.0;
        lr->s[(size_t)a * k + a] += 1.0 / c[a];
    }
    if (!lu_factor(lr->s, lr->piv, k))
        st = dtx_seterr(err, DTX_ESOLVE, "low-rank solve: the %d x %d capacitance matrix is "
                                         "singular",
                        (int)k, (int)k);
    goto done;
nomem:
    st = dtx_seterr(err, DTX_ENOMEM, "out of memory setting up a low-rank solve");
done:
    if (st != DTX_OK)
        dtx__chol_lowrank_free(lr, cc);
    free(ipos);
    free(col2sup);
    free(y);
    return st;
}

/* *X = A'^-1 B for B with at most 8 columns; 0 when out of memory. */
static int lowrank_apply(dtx__chol_lowrank *lr, cholmod_factor *L, cholmod_dense *B,
                         cholmod_dense **X, cholmod_common *cc)
{
    const int32_t k = lr->k, m = (int32_t)B->ncol;
    double *y;
    size_t d;
    if (!cholmod_solve2(CHOLMOD_P, L, B, NULL, &lr->Y1, NULL, &lr->Yw, &lr->Ew, cc) ||
        !cholmod_solve2(CHOLMOD_L, L, lr->Y1, NULL, &lr->Y2, NULL, &lr->Yw, &lr->Ew, cc))
        return 0;
    y = lr->Y2->x;
    d = lr->Y2->d;
    for (int32_t col = 0; col < m; col++) {
        double *yc = y + (size_t)col * d, *t = lr->t + (size_t)col * k;
        for (int32_t a = 0; a < k; a++) {
            double sum = 0.0;
            for (int64_t q = lr->wp[a]; q < lr->wp[a + 1]; q++)
                sum += lr->wx[q] * lr->dinv[lr->wi[q]] * yc[lr->wi[q]];
            t[a] = sum;
        }
        lu_solve(lr->s, lr->piv, k, t);
        for (int32_t a = 0; a < k; a++)
            for (int64_t q = lr->wp[a]; q < lr->wp[a + 1]; q++)
                yc[lr->wi[q]] -= lr->wx[q] * t[a];
    }
    return cholmod_solve2(CHOLMOD_DLt, L, lr->Y2, NULL, &lr->Y1, NULL, &lr->Yw, &lr->Ew, cc) &&
           cholmod_solve2(CHOLMOD_Pt, L, lr->Y1, NULL, X, NULL, &lr->Yw, &lr->Ew, cc);
}

static double max_abs(const double *x, size_t n)
{
    double m = 0.0;
    for (size_t i = 0; i < n; i++) {
        if (x[i] != x[i])
            return INFINITY;
        m = fabs(x[i]) > m ? fabs(x[i]) : m;
    }
    return m;
}

/* The infinity norm of the symmetric A stored as its lower triangle. */
static double sym_lower_norm_inf(const cholmod_sparse *A, double *rowsum)
{
    const int32_t n = (int32_t)A->nrow, *Ap = A->p, *Ai = A->i;
    const double *Ax = A->x;
    memset(rowsum, 0, (size_t)n * sizeof *rowsum);
    for (int32_t j = 0; j < n; j++)
        for (int32_t q = Ap[j]; q < Ap[j + 1]; q++) {
            rowsum[Ai[q]] += fabs(Ax[q]);
            if (Ai[q] != j)
                rowsum[j] += fabs(Ax[q]);
        }
    return max_abs(rowsum, (size_t)n);
}

dtx_status dtx__chol_lowrank_solve(dtx__chol_lowrank *lr, cholmod_factor *L, cholmod_sparse *A,
                                   cholmod_dense *B, int max_steps, double tol, cholmod_dense **X,
                                   int *steps, cholmod_common *cc, dtx_error *err)
{
    const size_t n = (size_t)lr->n, m = B->ncol;
    double anorm, one[2] = {1.0, 0.0}, mone[2] = {-1.0, 0.0};
    *steps = 0;
    if (m > 8 || B->nrow != n || B->d != n || A->stype >= 0 || A->nrow != n || !A->packed ||
        A->itype != CHOLMOD_INT)
        return dtx_seterr(err, DTX_EINVAL, "low-rank solve: B must be %zu x (at most 8), A "
                                           "symmetric (lower) of that size",
                          n);
    if (!cholmod_ensure_dense(&lr->R, n, m, n, CHOLMOD_REAL, cc) ||
        !cholmod_ensure_dense(&lr->DX, n, m, n, CHOLMOD_REAL, cc))
        goto nomem;
    anorm = sym_lower_norm_inf(A, lr->R->x);
    if (!lowrank_apply(lr, L, B, X, cc))
        goto nomem;
    for (;;) {
        /* Backward error of X, column by column: |B - A X| against
         * |A| |X| + |B| (infinity norms). */
        double eta = 0.0;
        memcpy(lr->R->x, B->x, n * m * sizeof(double));
        if (!cholmod_sdmult(A, 0, mone, one, *X, lr->R, cc))
            goto nomem;
        for (size_t col = 0; col < m; col++) {
            double r = max_abs((double *)lr->R->x + col * n, n);
            double x = max_abs((double *)(*X)->x + col * n, n);
            double b = max_abs((double *)B->x + col * n, n);
            double e = r == 0.0 ? 0.0 : r / (anorm * x + b);
            if (!(e <= eta)) /* NaN too */
                eta = e == e ? e : INFINITY;
        }
        lr->eta = eta;
        if (eta <= tol)
            return DTX_OK;
        if (*steps >= max_steps)
            return dtx_seterr(err, DTX_ESOLVE,
                              "low-rank solve: backward error %.3g above %.3g after %d "
                              "refinement steps",
                              eta, tol, *steps);
        if (!lowrank_apply(lr, L, lr->R, &lr->DX, cc))
            goto nomem;
        for (size_t q = 0; q < n * m; q++)
            ((double *)(*X)->x)[q] += ((double *)lr->DX->x)[q];
        (*steps)++;
    }
nomem:
    return dtx_seterr(err, DTX_ENOMEM, "out of memory in a low-rank solve");
}
