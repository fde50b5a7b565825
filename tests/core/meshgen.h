/*
 * meshgen.h: small procedural meshes and deformations for the core tests.
 */
#ifndef DTX_TEST_MESHGEN_H
#define DTX_TEST_MESHGEN_H

#include "dtx_core.h"

#include <math.h>
#include <string.h>

/* A closed capsule-like surface: a UV sphere of nu x nv vertices stretched
 * along z by `len`, plus two poles.  Single component, watertight. */
static inline dtx_status gen_capsule(int nu, int nvr, double len, dtx_mesh *m)
{
    int32_t nverts = nu * nvr + 2, nfaces = 2 * nu * (nvr - 1) + 2 * nu;
    dtx_status st = dtx_mesh_alloc(m, nverts, nfaces, NULL);
    int32_t f = 0;
    if (st != DTX_OK)
        return st;
    for (int j = 0; j < nvr; j++) {
        double th = 3.14159265358979323846 * (j + 1) / (nvr + 1);
        for (int i = 0; i < nu; i++) {
            double ph = 2 * 3.14159265358979323846 * i / nu;
            double *x = m->V + 3 * (j * nu + i);
            x[0] = sin(th) * cos(ph) * (1.0 + 0.1 * sin(3 * ph));
            x[1] = sin(th) * sin(ph) * 0.8;
            x[2] = cos(th) * len;
        }
    }
    m->V[3 * (nu * nvr) + 2] = len * 1.05;
    m->V[3 * (nu * nvr + 1) + 2] = -len * 1.05;
    for (int j = 0; j + 1 < nvr; j++)
        for (int i = 0; i < nu; i++) {
            int32_t a = j * nu + i, b = j * nu + (i + 1) % nu;
            int32_t c = (j + 1) * nu + i, d = (j + 1) * nu + (i + 1) % nu;
            int32_t *t = m->F + 3 * f;
            t[0] = a, t[1] = c, t[2] = b;
            t += 3;
            t[0] = b, t[1] = c, t[2] = d;
            f += 2;
        }
    for (int i = 0; i < nu; i++) {
        int32_t *t = m->F + 3 * f++;
        t[0] = nu * nvr, t[1] = i, t[2] = (i + 1) % nu;
        t = m->F + 3 * f++;
        t[0] = nu * nvr + 1, t[1] = (nvr - 1) * nu + (i + 1) % nu, t[2] = (nvr - 1) * nu + i;
    }
    return DTX_OK;
}

/* A smooth non-rigid deformation: bend about the y axis by angle k*z, a
 * twist and a bulge; amount in [0, 1]. */
static inline void deform(const double *V, int32_t n, double amount, double *X)
{
    for (int32_t i = 0; i < n; i++) {
        double x = V[3 * i], y = V[3 * i + 1], z = V[3 * i + 2];
        double a = amount * 0.6 * z, tw = amount * 0.4 * z, s = 1.0 + 0.2 * amount * sin(2 * z);
        double xt = s * (x * cos(tw) - y * sin(tw)), yt = s * (x * sin(tw) + y * cos(tw));
        X[3 * i] = xt * cos(a) + z * sin(a);
        X[3 * i + 1] = yt;
        X[3 * i + 2] = -xt * sin(a) + z * cos(a) + 0.3 * amount;
    }
}

/* Rotation matrix about the axis (1, 2, 3)/|.| by angle a. */
static inline void rotation(double a, double *R)
{
    double u[3] = {1, 2, 3}, n = sqrt(14.0), c = cos(a), s = sin(a);
    for (int k = 0; k < 3; k++)
        u[k] /= n;
    R[0] = c + u[0] * u[0] * (1 - c);
    R[1] = u[0] * u[1] * (1 - c) - u[2] * s;
    R[2] = u[0] * u[2] * (1 - c) + u[1] * s;
    R[3] = u[1] * u[0] * (1 - c) + u[2] * s;
    R[4] = c + u[1] * u[1] * (1 - c);
    R[5] = u[1] * u[2] * (1 - c) - u[0] * s;
    R[6] = u[2] * u[0] * (1 - c) - u[1] * s;
    R[7] = u[2] * u[1] * (1 - c) + u[0] * s;
    R[8] = c + u[2] * u[2] * (1 - c);
}

#endif /* DTX_TEST_MESHGEN_H */
