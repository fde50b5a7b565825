/*
 * frame_normals.h: normals of a deformed frame that keep the asset's
 * smoothing.
 *
 * An asset's normals are authored for its rest shape; a frame of a result
 * needs normals of its own geometry.  What is kept from the asset is where
 * the surface is smooth and where it has hard edges:
 *
 *   - the output normals are indexed per (vertex, asset normal index): one
 *     output normal per distinct pair the faces' corners use.  When the
 *     asset's indexing is per vertex (normal_faces == faces: smooth, one
 *     normal per vertex) the output indexing is exactly the asset's
 *     (normal_faces = faces, one normal per vertex, nout = nv);
 *   - the normal of a corner at vertex v with asset normal n0 is the
 *     area-weighted sum of the frame's face normals of the faces around
 *     v's POSITION (twins split along a UV seam count as one vertex: the
 *     seam stays invisible) whose corner there has an asset normal within
 *     about 0.8 degrees of n0 (the same smoothing group; a hard edge, where
 *     the asset's normals differ, stays hard), normalised.
 *
 * Precompute / apply: the plan depends on the rest mesh and its normals
 * only; apply is per frame.  Pure functions, no I/O; apply uses the plan's
 * scratch, so one plan is applied by one thread at a time.
 */
#ifndef DTX_FRAME_NORMALS_H
#define DTX_FRAME_NORMALS_H

#include "status.h"

#include <stdint.h>

typedef struct {
    int32_t nf;
    int32_t nout;       /* output normals */
    int32_t *out_faces; /* nf x 3: corner (f, k) uses output normal out_faces[3f + k] */
    int32_t *out_group; /* nout: the smoothing group of output o, or -1 (no corner) */
    int32_t ngroup;     /* smoothing groups (a position and an asset normal there) */
    int32_t *start;     /* ngroup + 1: faces of group g are faces[start[g] .. start[g+1]) */
    int32_t *faces;     /* 3 nf entries */
    double *fallback;   /* nout x 3: the asset's normal, used where the sum vanishes */
    double *sum;        /* ngroup x 3: apply's scratch */
} dtx_frame_normals;

/* The plan for a mesh of nv rest vertices V (nv x 3 doubles; twins are
 * found by bit-identical position), nf faces F (nf x 3 int32, in range)
 * and the asset's normals (nn x 3 doubles) with normal_faces (nf x 3, in
 * [0, nn)).  *p is overwritten; free with dtx_frame_normals_free.
 * DTX_ENOMEM, or DTX_EINVAL for bad counts. */
dtx_status dtx_frame_normals_plan(const double *V, int32_t nv, const int32_t *F, int32_t nf,
                                  const double *normals, int32_t nn,
                                  const int32_t *normal_faces, dtx_frame_normals *p,
                                  dtx_error *err);

/* The output normals N (p->nout x 3, caller-allocated, unit length) of the
 * frame X (the plan's scratch is overwritten) (nv x 3 doubles or, when Xf is given instead, floats; exactly
 * one non-NULL) of the planned mesh with faces F. */
void dtx_frame_normals_apply(const dtx_frame_normals *p, const double *X, const float *Xf,
                             const int32_t *F, double *N);

/* Frees the plan and zeroes it.  Accepts NULL. */
void dtx_frame_normals_free(dtx_frame_normals *p);

#endif /* DTX_FRAME_NORMALS_H */
