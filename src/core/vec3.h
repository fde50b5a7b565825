/*
 * vec3.h: the 3-vector and 3x3 helpers the core's geometry code shares
 * (static inline; not part of the public API).  Vectors are 3 doubles;
 * 3x3 matrices 9 doubles, row-major.
 */
#ifndef DTX_VEC3_H
#define DTX_VEC3_H

#include <math.h>

static inline void sub3(const double *a, const double *b, double *r)
{
    r[0] = a[0] - b[0];
    r[1] = a[1] - b[1];
    r[2] = a[2] - b[2];
}

static inline void cross3(const double *a, const double *b, double *r)
{
    r[0] = a[1] * b[2] - a[2] * b[1];
    r[1] = a[2] * b[0] - a[0] * b[2];
    r[2] = a[0] * b[1] - a[1] * b[0];
}

static inline double dot3(const double *a, const double *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* Area of triangle (a, b, c): half the length of (b - a) x (c - a). */
static inline double tri_area3(const double *a, const double *b, const double *c)
{
    double e1[3], e2[3], n[3];
    sub3(b, a, e1);
    sub3(c, a, e2);
    cross3(e1, e2, n);
    return 0.5 * sqrt(dot3(n, n));
}

/* Inverse of the 3x3 matrix whose COLUMNS are c0, c1, c2, written row-major
 * into inv.  Returns the determinant (0 leaves inv untouched). */
static inline double inverse_of_columns(const double *c0, const double *c1, const double *c2,
                                        double *inv)
{
    /* For M = [c0 c1 c2], M^-1 has rows (c1 x c2, c2 x c0, c0 x c1) / det. */
    double r0[3], r1[3], r2[3], det;
    cross3(c1, c2, r0);
    cross3(c2, c0, r1);
    cross3(c0, c1, r2);
    det = dot3(c0, r0);
    if (det == 0.0)
        return 0.0;
    for (int k = 0; k < 3; k++) {
        inv[k] = r0[k] / det;
        inv[3 + k] = r1[k] / det;
        inv[6 + k] = r2[k] / det;
    }
    return det;
}

/* Sumner's fourth edge e3 = n / sqrt(|n|), n = e1 x e2 (0 for |n| = 0): the
 * fourth vertex of a triangle (v1, v2, v3) is v1 + e3 with e1 = v2 - v1,
 * e2 = v3 - v1. */
static inline void fourth_edge(const double *e1, const double *e2, double *e3)
{
    double n[3], len;
    cross3(e1, e2, n);
    len = sqrt(dot3(n, n));
    if (len > 0.0) {
        double s = 1.0 / sqrt(len);
        e3[0] = n[0] * s;
        e3[1] = n[1] * s;
        e3[2] = n[2] * s;
    } else {
        e3[0] = e3[1] = e3[2] = 0.0;
    }
}

#endif /* DTX_VEC3_H */
