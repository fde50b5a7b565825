/*
 * align.c: least-squares similarity alignment of two point sets (Umeyama,
 * "Least-squares estimation of transformation parameters between two point
 * patterns", PAMI 1991), used to bring the source near the target from the
 * markers before the correspondence deformation.
 */
#include "dtx_core.h"

#include <math.h>
#include <string.h>

/* LAPACK's SVD (column-major). */
extern void dgesvd_(const char *jobu, const char *jobvt, const int *m, const int *n, double *a,
                    const int *lda, double *s, double *u, const int *ldu, double *vt,
                    const int *ldvt, double *work, const int *lwork, int *info);

dtx_status dtx_similarity_fit(const double *P, const double *Q, int32_t n, double *R, double *t,
                              double *s, dtx_error *err)
{
    double mp[3] = {0, 0, 0}, mq[3] = {0, 0, 0}, varp = 0.0, C[9] = {0}, a[9], sv[3], U[9], VT[9],
           work[64], d = 1.0, trace = 0.0;
    int three = 3, lwork = 64, info = 0;
    if (n < 3)
        return dtx_seterr(err, DTX_EINVAL, "alignment needs at least 3 markers, got %d", (int)n);
    for (int32_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            mp[k] += P[3 * i + k] / n;
            mq[k] += Q[3 * i + k] / n;
        }
    /* C = (1/n) sum (q - mq)(p - mp)^T, row-major. */
    for (int32_t i = 0; i < n; i++) {
        double dp[3], dq[3];
        for (int k = 0; k < 3; k++) {
            dp[k] = P[3 * i + k] - mp[k];
            dq[k] = Q[3 * i + k] - mq[k];
        }
        varp += (dp[0] * dp[0] + dp[1] * dp[1] + dp[2] * dp[2]) / n;
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 3; c++)
                C[3 * r + c] += dq[r] * dp[c] / n;
    }
    if (!(varp > 0.0))
        return dtx_seterr(err, DTX_EINVAL, "alignment markers all lie at one point");
    /* LAPACK is column-major: pass C^T's storage, i.e. a = C in column-major. */
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++)
            a[r + 3 * c] = C[3 * r + c];
    dgesvd_("A", "A", &three, &three, a, &three, sv, U, &three, VT, &three, work, &lwork, &info);
    if (info != 0)
        return dtx_seterr(err, DTX_ESOLVE, "SVD failed in marker alignment (info %d)", info);
    /* U, VT column-major.  R = U diag(1,1,d) VT with d fixing reflections. */
    {
        double Ur[9], Vr[9], detU, detV;
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 3; c++) {
                Ur[3 * r + c] = U[r + 3 * c];
                Vr[3 * r + c] = VT[r + 3 * c]; /* row-major VT */
            }
        detU = Ur[0] * (Ur[4] * Ur[8] - Ur[5] * Ur[7]) - Ur[1] * (Ur[3] * Ur[8] - Ur[5] * Ur[6]) +
               Ur[2] * (Ur[3] * Ur[7] - Ur[4] * Ur[6]);
        detV = Vr[0] * (Vr[4] * Vr[8] - Vr[5] * Vr[7]) - Vr[1] * (Vr[3] * Vr[8] - Vr[5] * Vr[6]) +
               Vr[2] * (Vr[3] * Vr[7] - Vr[4] * Vr[6]);
        if (detU * detV < 0.0)
            d = -1.0;
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 3; c++)
                R[3 * r + c] = Ur[3 * r + 0] * Vr[0 * 3 + c] + Ur[3 * r + 1] * Vr[1 * 3 + c] +
                               d * Ur[3 * r + 2] * Vr[2 * 3 + c];
        trace = sv[0] + sv[1] + d * sv[2];
    }
    *s = trace / varp;
    for (int r = 0; r < 3; r++)
        t[r] = mq[r] - *s * (R[3 * r] * mp[0] + R[3 * r + 1] * mp[1] + R[3 * r + 2] * mp[2]);
    return DTX_OK;
}

void dtx_similarity_apply(const double *R, const double *t, double s, double *X, int32_t n)
{
    for (int32_t i = 0; i < n; i++) {
        double x[3];
        memcpy(x, X + 3 * i, sizeof x);
        for (int r = 0; r < 3; r++)
            X[3 * i + r] = s * (R[3 * r] * x[0] + R[3 * r + 1] * x[1] + R[3 * r + 2] * x[2]) + t[r];
    }
}
