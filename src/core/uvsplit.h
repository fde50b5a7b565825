/*
 * uvsplit.h: a mesh split the way a DCC or glTF export splits it, as test
 * data for seam welding (`dtx generate uvsplit`).
 *
 * A cylindrical UV projection around the vertical (y) axis through the
 * centroid cuts a seam where u wraps from 1 to 0; with two materials, faces
 * whose centroid lies above the centroid's height get material 1 and the
 * others material 0.  Every distinct (vertex, u wrapped?, material) of a
 * face corner becomes its own vertex, as glTF requires: the mesh is cut
 * along the UV seam (still one piece) and, with two materials, into pieces
 * where they meet.  The first corner seen of each vertex (in face order)
 * keeps the vertex's index, so the split mesh's first nv vertices are the
 * input's in order and welding it gives the input back exactly; the
 * duplicates follow in order of first appearance.
 */
#ifndef DTX_UVSPLIT_H
#define DTX_UVSPLIT_H

#include "mesh.h"
#include "status.h"

#include <stdint.h>

typedef struct {
    dtx_mesh mesh;     /* the split mesh: faces in the input's order */
    double *uv;        /* mesh.nv x 2, per split vertex */
    double *normals;   /* mesh.nv x 3, the input's area-weighted unit normal */
    int32_t *material; /* mesh.nf, 0 or 1 */
    int32_t *orig;     /* mesh.nv, the input vertex each split vertex copies */
    int32_t nseam;     /* duplicates made by the UV seam */
    int32_t nmatcut;   /* duplicates made by the material boundary only */
} dtx_uvsplit;

/* Splits m (validated) with `materials` 1 or 2.  *out is allocated here;
 * free with dtx_uvsplit_free.  DTX_EINVAL, DTX_ENOMEM. */
dtx_status dtx_uvsplit_make(const dtx_mesh *m, int materials, dtx_uvsplit *out, dtx_error *err);

void dtx_uvsplit_free(dtx_uvsplit *s);

#endif /* DTX_UVSPLIT_H */
