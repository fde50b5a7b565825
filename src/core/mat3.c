/*
 * mat3.c: 3x3 signed SVD, polar decomposition and the SO(3) log and exp
 * maps, for the skinning fit's local step and clustering features.
 *
 * The SVD is one-sided Jacobi (Hestenes): plane rotations on the right
 * orthogonalise the columns of A, so A V = B with orthogonal columns whose
 * norms are the singular values.  Working on A rather than A^T A keeps the
 * relative accuracy of small singular values, which matters for the
 * covariance of a nearly flat cluster.  U is then built from B's two
 * largest columns by Gram-Schmidt and a cross product, so it is a rotation
 * even when A is rank deficient, and the sign of det A lands on sigma[2].
 */
#include "mat3.h"
#include "vec3.h"

#include <float.h>
#include <math.h>
#include <string.h>

/* Enough for 3x3: Jacobi converges quadratically, typically in 4-6 sweeps. */
#define SVD3_MAX_SWEEPS 40

static double norm3(const double *a) { return sqrt(dot3(a, a)); }

/* Some unit vector orthogonal to the unit vector u. */
static void any_orthogonal(const double *u, double *r)
{
    /* Cross u with the coordinate axis it is least aligned with. */
    double e[3] = {0, 0, 0}, n;
    int k = 0;
    if (fabs(u[1]) < fabs(u[k]))
        k = 1;
    if (fabs(u[2]) < fabs(u[k]))
        k = 2;
    e[k] = 1.0;
    cross3(u, e, r);
    n = norm3(r);
    r[0] /= n;
    r[1] /= n;
    r[2] /= n;
}

void dtx_svd3(const double A[9], double U[9], double sigma[3], double V[9])
{
    /* Columns of B (b[c]) and of V (v[c]) kept as separate 3-vectors. */
    double b[3][3], v[3][3], nrm[3], u[3][3], amax = 0.0, scale = 1.0;
    int order[3] = {0, 1, 2};
    /* Scale by a power of two (exact) near the largest entry, so that the
     * squares below neither underflow nor overflow. */
    for (int k = 0; k < 9; k++)
        amax = fmax(amax, fabs(A[k]));
    if (amax > 0.0 && isfinite(amax)) {
        int ex;
        (void)frexp(amax, &ex);
        scale = ldexp(1.0, ex);
    }
    for (int c = 0; c < 3; c++)
        for (int r = 0; r < 3; r++) {
            b[c][r] = A[3 * r + c] / scale;
            v[c][r] = (r == c);
        }

    /* ---- one-sided Jacobi sweeps over the column pairs */
    for (int sweep = 0; sweep < SVD3_MAX_SWEEPS; sweep++) {
        int rotated = 0;
        for (int p = 0; p < 2; p++)
            for (int q = p + 1; q < 3; q++) {
                double alpha = dot3(b[p], b[p]), beta = dot3(b[q], b[q]);
                double gamma = dot3(b[p], b[q]), zeta, t, c, s;
                if (gamma == 0.0 || fabs(gamma) <= DBL_EPSILON * sqrt(alpha * beta))
                    continue;
                rotated = 1;
                zeta = (beta - alpha) / (2.0 * gamma);
                t = (zeta >= 0.0 ? 1.0 : -1.0) / (fabs(zeta) + sqrt(1.0 + zeta * zeta));
                c = 1.0 / sqrt(1.0 + t * t);
                s = c * t;
                for (int r = 0; r < 3; r++) {
                    double bp = b[p][r], bq = b[q][r], vp = v[p][r], vq = v[q][r];
                    b[p][r] = c * bp - s * bq;
                    b[q][r] = s * bp + c * bq;
                    v[p][r] = c * vp - s * vq;
                    v[q][r] = s * vp + c * vq;
                }
            }
        if (!rotated)
            break;
    }

    /* ---- order the columns by decreasing norm (stable on ties) */
    for (int c = 0; c < 3; c++)
        nrm[c] = norm3(b[c]);
    for (int i = 1; i < 3; i++)
        for (int j = i; j > 0 && nrm[order[j]] > nrm[order[j - 1]]; j--) {
            int tmp = order[j];
            order[j] = order[j - 1];
            order[j - 1] = tmp;
        }
    {
        double bs[3][3], vs[3][3];
        for (int c = 0; c < 3; c++) {
            memcpy(bs[c], b[order[c]], sizeof bs[c]);
            memcpy(vs[c], v[order[c]], sizeof vs[c]);
        }
        memcpy(b, bs, sizeof b);
        memcpy(v, vs, sizeof v);
    }
    /* V a rotation: flipping v3 flips b3, which only moves the sign onto
     * sigma[2] below. */
    {
        double x[3];
        cross3(v[0], v[1], x);
        if (dot3(x, v[2]) < 0.0)
            for (int r = 0; r < 3; r++) {
                v[2][r] = -v[2][r];
                b[2][r] = -b[2][r];
            }
    }

    /* ---- U = [u1, u2, u1 x u2] from B by Gram-Schmidt */
    {
        double n0 = norm3(b[0]), n1;
        if (n0 == 0.0) { /* A = 0 */
            for (int k = 0; k < 9; k++)
                U[k] = V[k] = (k % 4 == 0);
            sigma[0] = sigma[1] = sigma[2] = 0.0;
            return;
        }
        for (int r = 0; r < 3; r++)
            u[0][r] = b[0][r] / n0;
        {
            double d = dot3(u[0], b[1]);
            for (int r = 0; r < 3; r++)
                u[1][r] = b[1][r] - d * u[0][r];
        }
        n1 = norm3(u[1]);
        if (n1 > 8.0 * DBL_EPSILON * n0)
            for (int r = 0; r < 3; r++)
                u[1][r] /= n1;
        else
            any_orthogonal(u[0], u[1]);
        cross3(u[0], u[1], u[2]);
    }
    for (int c = 0; c < 3; c++) {
        sigma[c] = dot3(u[c], b[c]) * scale;
        for (int r = 0; r < 3; r++) {
            U[3 * r + c] = u[c][r];
            V[3 * r + c] = v[c][r];
        }
    }
}

void dtx_polar3(const double A[9], double R[9], double S[9])
{
    double U[9], sg[3], V[9];
    dtx_svd3(A, U, sg, V);
    /* R = U V^T */
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++)
            R[3 * r + c] =
                U[3 * r] * V[3 * c] + U[3 * r + 1] * V[3 * c + 1] + U[3 * r + 2] * V[3 * c + 2];
    if (S) {
        /* S = V diag(sigma) V^T: symmetric by construction. */
        for (int r = 0; r < 3; r++)
            for (int c = r; c < 3; c++) {
                double s = sg[0] * V[3 * r] * V[3 * c] + sg[1] * V[3 * r + 1] * V[3 * c + 1] +
                           sg[2] * V[3 * r + 2] * V[3 * c + 2];
                S[3 * r + c] = S[3 * c + r] = s;
            }
    }
}

void dtx_so3_log(const double R[9], double w[3])
{
    /* R - R^T = 2 sin(t) [n]x, tr R = 1 + 2 cos(t). */
    double v[3] = {R[7] - R[5], R[2] - R[6], R[3] - R[1]};
    double sn = 0.5 * norm3(v), cs = 0.5 * (R[0] + R[4] + R[8] - 1.0);
    double t = atan2(sn, cs);
    if (cs > -0.5) {
        /* t < 2 pi / 3: w = t / (2 sin t) v, with the series of t / sin t
         * near 0 (error below 1e-17 for t < 1e-4). */
        double f = sn > 1e-4 ? t / sn : 1.0 + t * t / 6.0;
        for (int k = 0; k < 3; k++)
            w[k] = 0.5 * f * v[k];
        return;
    }
    /* Near pi, sin t is small and v inaccurate: take the axis from the
     * symmetric part (R + R^T) / 2 - cos(t) I = (1 - cos t) n n^T, its
     * largest column, and the sign from v. */
    {
        double Bm[9], n[3], len;
        int k = 0;
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 3; c++)
                Bm[3 * r + c] = 0.5 * (R[3 * r + c] + R[3 * c + r]) - (r == c ? cs : 0.0);
        if (Bm[4] > Bm[3 * k + k])
            k = 1;
        if (Bm[8] > Bm[3 * k + k])
            k = 2;
        for (int r = 0; r < 3; r++)
            n[r] = Bm[3 * r + k];
        len = norm3(n);
        if (len == 0.0) { /* cannot happen for a rotation; stay finite */
            w[0] = w[1] = w[2] = 0.0;
            return;
        }
        if (dot3(n, v) < 0.0)
            len = -len;
        for (int r = 0; r < 3; r++)
            w[r] = t * n[r] / len;
    }
}

void dtx_so3_exp(const double w[3], double R[9])
{
    double t2 = dot3(w, w), t = sqrt(t2), a, b;
    double K[9] = {0, -w[2], w[1], w[2], 0, -w[0], -w[1], w[0], 0}, K2[9];
    if (t < 1e-4) { /* series: errors below 1e-17 */
        a = 1.0 - t2 / 6.0;
        b = 0.5 - t2 / 24.0;
    } else {
        a = sin(t) / t;
        b = (1.0 - cos(t)) / t2;
    }
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++)
            K2[3 * r + c] = K[3 * r] * K[c] + K[3 * r + 1] * K[3 + c] + K[3 * r + 2] * K[6 + c];
    for (int k = 0; k < 9; k++)
        R[k] = (k % 4 == 0) + a * K[k] + b * K2[k];
}
