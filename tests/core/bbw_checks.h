/*
 * bbw_checks.h: checks on bounded biharmonic weights shared by
 * test_bbw.c (generated meshes) and test_bbw_cactus.c (the shared cactus).
 * Include after check.h.
 */
#ifndef DTX_TEST_BBW_CHECKS_H
#define DTX_TEST_BBW_CHECKS_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

static double max_abs_diff(const double *a, const double *b, size_t n)
{
    double d = 0.0;
    for (size_t i = 0; i < n; i++)
        d = fmax(d, fabs(a[i] - b[i]));
    return d;
}

/* W (nv x m, row-major): w_k(h_j) = delta_jk exactly, rows sum to 1 within
 * tol, entries in [lo, hi]. */
static void check_weights(const double *W, int32_t nv, const int32_t *h, int32_t m, double tol,
                          double lo, double hi)
{
    double worst_sum = 0.0, below = 0.0, above = 0.0;
    int exact = 1;
    for (int32_t j = 0; j < m; j++)
        for (int32_t k = 0; k < m; k++)
            exact &= W[(size_t)h[j] * m + k] == (j == k ? 1.0 : 0.0);
    CHECK(exact);
    for (int32_t i = 0; i < nv; i++) {
        double s = 0.0;
        for (int32_t k = 0; k < m; k++) {
            double w = W[(size_t)i * m + k];
            s += w;
            below = fmin(below, w - lo);
            above = fmax(above, w - hi);
        }
        worst_sum = fmax(worst_sum, fabs(s - 1.0));
    }
    CHECK_DBL(worst_sum, <=, tol);
    CHECK_DBL(below, >=, 0.0);
    CHECK_DBL(above, <=, 0.0);
}

#endif /* DTX_TEST_BBW_CHECKS_H */
