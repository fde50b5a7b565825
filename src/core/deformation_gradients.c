/*
 * deformation_gradients.c: per-triangle affine maps between a rest mesh and a
 * deformed one (Sumner & Popovic 2004, section 3), and the equivalent
 * vertex-only gradient operator (Botsch et al. 2006).
 */
#include "dtx_core.h"
#include "vec3.h"

#include <math.h>
#include <string.h>

/* Tikhonov-regularised pseudo-inverse (M^T M + delta I)^-1 M^T of the
 * matrix with columns c0, c1, c2, for triangles too thin to invert. */
static void regularised_inverse(const double *c0, const double *c1, const double *c2,
                                double delta, double *inv)
{
    const double *c[3] = {c0, c1, c2};
    double A[9], Ainv[9], cols[3][3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            A[3 * i + j] = dot3(c[i], c[j]) + (i == j ? delta : 0.0);
    /* A is symmetric positive definite; invert it through its columns. */
    for (int j = 0; j < 3; j++)
        for (int i = 0; i < 3; i++)
            cols[j][i] = A[3 * i + j];
    if (inverse_of_columns(cols[0], cols[1], cols[2], Ainv) == 0.0) {
        memset(inv, 0, 9 * sizeof *inv);
        return;
    }
    /* inv = Ainv * M^T, where M^T has rows c0, c1, c2. */
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++)
            inv[3 * i + k] =
                Ainv[3 * i] * c0[k] + Ainv[3 * i + 1] * c1[k] + Ainv[3 * i + 2] * c2[k];
}

/* A triangle is thin when its height is below this fraction of its longest
 * edge (|e1 x e2| < DTX_THIN_RATIO * longest^2).  Its exact inverse would
 * have entries of order 1 / height, so a deformation that changes the
 * height a little gives a huge gradient (and, on the target, a stiffness
 * matrix too ill-conditioned to factor): such triangles get the
 * regularised inverse, like zero-area ones.  Real meshes (the cat and lion
 * of the bundled data: 3.6e-3 at worst) are far above it. */
#define DTX_THIN_RATIO DTX_MESH_THIN_RATIO

/* Squared length of the longest edge of the triangle with edges e1, e2. */
static double longest_edge2(const double *e1, const double *e2)
{
    double d[3] = {e2[0] - e1[0], e2[1] - e1[1], e2[2] - e1[2]};
    double a = dot3(e1, e1), b = dot3(e2, e2), c = dot3(d, d);
    return a > b ? (a > c ? a : c) : (b > c ? b : c);
}

int32_t dtx_frame_inverses(const double *V, const int32_t *F, int32_t nf, double eps_area,
                           double *Vinv)
{
    int32_t degenerate = 0;
    for (int32_t f = 0; f < nf; f++) {
        const int32_t *t = F + 3 * f;
        double e1[3], e2[3], e3[3], n[3], area, scale2;
        double *inv = Vinv + 9 * f;
        sub3(V + 3 * t[1], V + 3 * t[0], e1);
        sub3(V + 3 * t[2], V + 3 * t[0], e2);
        cross3(e1, e2, n);
        area = 0.5 * sqrt(dot3(n, n));
        fourth_edge(e1, e2, e3);
        scale2 = longest_edge2(e1, e2);
        if (area > eps_area && 2.0 * area > DTX_THIN_RATIO * scale2 &&
            inverse_of_columns(e1, e2, e3, inv) != 0.0)
            continue;
        /* Zero-area or needle triangle: a regularised pseudo-inverse keeps
         * the gradient finite and meaningful along the edges that exist. */
        degenerate++;
        if (scale2 > 0.0)
            regularised_inverse(e1, e2, e3, DTX_THIN_RATIO * scale2, inv);
        else
            memset(inv, 0, 9 * sizeof *inv);
    }
    return degenerate;
}

void dtx_deformation_gradients(const double *Vinv, const int32_t *F, int32_t nf, const double *X,
                               double *S)
{
    for (int32_t f = 0; f < nf; f++) {
        const int32_t *t = F + 3 * f;
        const double *inv = Vinv + 9 * f;
        double e1[3], e2[3], e3[3];
        double *s = S + 9 * f;
        sub3(X + 3 * t[1], X + 3 * t[0], e1);
        sub3(X + 3 * t[2], X + 3 * t[0], e2);
        fourth_edge(e1, e2, e3);
        /* S = [e1 e2 e3] * inv: row r of S is sum_k e_k[r] * inv row k. */
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 3; c++)
                s[3 * r + c] = e1[r] * inv[c] + e2[r] * inv[3 + c] + e3[r] * inv[6 + c];
    }
}

int32_t dtx_gradient_operator(const double *V, const int32_t *F, int32_t nf, double eps_area,
                              double *G)
{
    int32_t degenerate = 0;
    for (int32_t f = 0; f < nf; f++) {
        const int32_t *t = F + 3 * f;
        double e1[3], e2[3], n[3], a, b, c, det, scale2;
        double *g = G + 9 * f;
        sub3(V + 3 * t[1], V + 3 * t[0], e1);
        sub3(V + 3 * t[2], V + 3 * t[0], e2);
        cross3(e1, e2, n);
        det = dot3(n, n); /* = a c - b^2, the Gram determinant */
        scale2 = longest_edge2(e1, e2);
        a = dot3(e1, e1);
        b = dot3(e1, e2);
        c = dot3(e2, e2);
        if (0.5 * sqrt(det) <= eps_area || sqrt(det) <= DTX_THIN_RATIO * scale2) {
            /* Zero-area or needle triangle: the Tikhonov-regularised
             * pseudo-inverse (E^T E + delta I)^-1 E^T keeps the constraint
             * along the edges that exist and a bounded one across. */
            double delta = DTX_THIN_RATIO * scale2;
            degenerate++;
            a += delta;
            c += delta;
            det = a * c - b * b;
            if (scale2 == 0.0 || !(det > 0.0)) {
                memset(g, 0, 9 * sizeof *g);
                continue;
            }
        }
        for (int k = 0; k < 3; k++) {
            double r1 = (c * e1[k] - b * e2[k]) / det; /* row 1 of pinv(E) */
            double r2 = (a * e2[k] - b * e1[k]) / det; /* row 2 of pinv(E) */
            g[k] = -(r1 + r2);
            g[3 + k] = r1;
            g[6 + k] = r2;
        }
    }
    return degenerate;
}
