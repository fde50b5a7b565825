/*
 * mesh.h: the triangle mesh type shared by every layer, and checks on it.
 *
 * V: nv x 3 row-major doubles (x, y, z of vertex i at V[3i..3i+2]).
 * F: nf x 3 row-major int32, 0-based vertex indices, counter-clockwise.
 */
#ifndef DTX_MESH_H
#define DTX_MESH_H

#include "status.h"

#include <stdint.h>

typedef struct {
    int32_t nv;
    int32_t nf;
    double *V;  /* nv x 3, owned */
    int32_t *F; /* nf x 3, owned */
} dtx_mesh;

/* Allocates V and F for nv vertices and nf faces (zeroed).  Returns
 * DTX_ENOMEM (and leaves *m empty) on failure.  nv, nf >= 0. */
dtx_status dtx_mesh_alloc(dtx_mesh *m, int32_t nv, int32_t nf, dtx_error *err);

/* Frees V and F and zeroes the struct.  Accepts NULL and empty meshes. */
void dtx_mesh_free(dtx_mesh *m);

/* Deep copy of src into *dst (dst is overwritten, not freed first). */
dtx_status dtx_mesh_copy(const dtx_mesh *src, dtx_mesh *dst, dtx_error *err);

/* Checks what every method needs: nv >= 3, nf >= 1, every index in
 * [0, nv), no face with a repeated vertex, every coordinate finite.
 * `what` names the mesh in the message (a file name or an HDF5 path). */
dtx_status dtx_mesh_validate(const dtx_mesh *m, const char *what, dtx_error *err);

/* Connected components over shared vertices.  comp: nv int32 (output,
 * caller-allocated), component id of each vertex, numbered 0.. in order of
 * first appearance by vertex index; vertices in no face get their own
 * component each.  Returns the number of components, or -1 on allocation
 * failure. */
int32_t dtx_mesh_components(const dtx_mesh *m, int32_t *comp);

/* Number of vertices referenced by no face. */
int32_t dtx_mesh_count_unreferenced(const dtx_mesh *m);

/* Length of the bounding-box diagonal of X (n x 3). */
double dtx_bbox_diagonal(const double *X, int32_t n);

/* Unit face normals N (nf x 3, caller-allocated) of the mesh with vertex
 * positions X (nv x 3).  Zero-area faces get a zero normal. */
void dtx_face_normals(const double *X, const int32_t *F, int32_t nf, double *N);

/* Area-weighted unit vertex normals N (nv x 3, caller-allocated). */
void dtx_vertex_normals(const double *X, int32_t nv, const int32_t *F, int32_t nf,
                        double *N);

#endif /* DTX_MESH_H */
