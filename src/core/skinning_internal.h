/*
 * skinning_internal.h: the rest-mesh record shared by skinning.c and
 * skinning_features.c (not part of the public API).
 */
#ifndef DTX_SKINNING_INTERNAL_H
#define DTX_SKINNING_INTERNAL_H

#include "skinning.h"

#include <stdint.h>

struct dtx_skin_mesh {
    int32_t nv, nf;
    double *V;  /* nv x 3, the rest positions as given */
    int32_t *F; /* nf x 3 */
    /* Normalisation for conditioning: P = (V - center) / scale, scale the
     * RMS distance to the centroid.  Energies in normalised units are
     * scale^2 times the real ones. */
    double center[3], scale;
    double *P; /* nv x 3 */
    /* One-ring spokes (i, j), CSR by i, j ascending; both directions of
     * every mesh edge, with the same weight. */
    int64_t *spoke_start; /* nv + 1 */
    int32_t *spoke_j;     /* nspokes */
    double *spoke_w;      /* nspokes: w_ij */
    double *spoke_we;     /* nspokes x 3: w_ij (P_i - P_j) */
    double *vertex_we;    /* nv x 3: sum over the spokes of i of w_ij (P_i - P_j) */
    int64_t nspokes;
    double cp; /* sum over spokes of w_ij |P_i - P_j|^2 */
    /* Deformation gradients: rest frame inverses (dtx_frame_inverses) and
     * the vertex-to-triangle incidence, CSR by vertex, triangles ascending,
     * with weights area / (total area around the vertex). */
    double *Vinv;      /* nf x 9 */
    int64_t *vf_start; /* nv + 1 */
    int32_t *vf_face;  /* 3 nf */
    double *vf_w;      /* 3 nf */
};

/* Number of OpenMP threads for a `threads` parameter (<= 0: the default). */
int dtx_skin_threads_(int threads);

#endif /* DTX_SKINNING_INTERNAL_H */
