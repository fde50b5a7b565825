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

/* A triangle is a needle (or degenerate) when its height is below this
 * fraction of its longest edge: |e1 x e2| <= DTX_MESH_THIN_RATIO * longest^2.
 * Zero-area triangles are included.  The bundled cat and lion meshes are at
 * 3.6e-3 at worst. */
#define DTX_MESH_THIN_RATIO 1e-4

/* What dtx_mesh_inspect finds: properties that a mesh can have and still
 * pass dtx_mesh_validate, each with a count and the first instance (lowest
 * index; -1 entries when the count is 0).  All indices are 0-based. */
typedef struct {
    /* Connected components (over shared vertices) of the vertices that are
     * in a face.  With components > 1, other_component is the lowest vertex
     * not connected to vertex F[0]. */
    int32_t components;
    int32_t other_component;
    /* Vertices in no face. */
    int32_t unreferenced;
    int32_t first_unreferenced;
    /* Faces with |e1 x e2| <= DTX_MESH_THIN_RATIO * longest edge^2 (zero
     * area and needles); thinnest is the smallest ratio |e1 x e2| /
     * longest^2 over all faces (0 for a zero-area face). */
    int32_t degenerate;
    int32_t first_degenerate;
    double thinnest;
    /* Vertices in a face at exactly the position of a lower-numbered vertex
     * in a face: dup_vertex = {lower, higher} of the first such pair by the
     * higher index. */
    int32_t duplicate_positions;
    int32_t dup_vertex[2];
    /* Edges shared by three or more faces (non-manifold), the first edge
     * by (lower, higher) vertex, and how many faces share it. */
    int32_t nonmanifold_edges;
    int32_t nonmanifold_edge[2];
    int32_t nonmanifold_faces;
    /* Faces on the same three vertices as a lower-numbered face:
     * dup_face = {lower, higher} of the first such pair by the higher. */
    int32_t duplicate_faces;
    int32_t dup_face[2];
} dtx_mesh_report;

/* Fills *rep for m, which must pass dtx_mesh_validate (indices in range).
 * O(nf log nf) time, O(nv + nf) temporary memory.  Returns DTX_ENOMEM (and
 * *rep zeroed) when the temporary arrays cannot be allocated.  Thread-safe
 * (no shared state). */
dtx_status dtx_mesh_inspect(const dtx_mesh *m, dtx_mesh_report *rep, dtx_error *err);

/* Writes into buf (n bytes, always NUL-terminated when n > 0) one sentence
 * per notable finding of rep that a method still accepts, separated by
 * "; ": vertices in no face, degenerate faces, duplicate positions,
 * non-manifold edges, duplicate faces (components are not included: a
 * method decides about them).  Returns the number of findings (also those
 * cut off when buf is too small; 0 leaves buf ""). */
int dtx_mesh_report_notes(const dtx_mesh_report *rep, char *buf, size_t n);

/* Length of the bounding-box diagonal of X (n x 3). */
double dtx_bbox_diagonal(const double *X, int32_t n);
/* A size of the n points X that no rotation changes: 2 sqrt(3) times the
 * RMS distance of the points from their centroid (for points spread evenly
 * through a box, about the box's diagonal).  The bounding box's diagonal
 * changes when the points rotate (by up to a factor sqrt(3)), so scale
 * factors and thresholds derived from it are not rotation-invariant; this
 * one is.  0 for n <= 0. */
double dtx_rms_extent(const double *X, int32_t n);

/* Mean edge length of the mesh (each face's three edges, shared edges
 * counted from each face); 0 for a mesh without faces. */
double dtx_mesh_mean_edge(const dtx_mesh *m);

/* Unit face normals N (nf x 3, caller-allocated) of the mesh with vertex
 * positions X (nv x 3).  Zero-area faces get a zero normal. */
void dtx_face_normals(const double *X, const int32_t *F, int32_t nf, double *N);

/* Area-weighted unit vertex normals N (nv x 3, caller-allocated).  A vertex
 * whose faces' normals cancel (their sum under DTX_NORMAL_NOISE of the
 * mesh's largest face's cross product: rounding noise, no direction) and a
 * vertex without faces get a zero normal. */
#define DTX_NORMAL_NOISE 1e-12
void dtx_vertex_normals(const double *X, int32_t nv, const int32_t *F, int32_t nf,
                        double *N);

#endif /* DTX_MESH_H */
