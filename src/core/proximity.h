/*
 * proximity.h: the proximity graph of a multi-component target mesh and its
 * proximity pairs (Zhou, Xu, Tong & Desbrun 2010, "Deformation Transfer to
 * Multi-Component Objects", section 2.1), and the triangle pairs of the
 * correspondence term E_R (section 2.2).
 *
 * Components are the connected components (over shared vertices) of the
 * vertices that are in a face.  d_ab is the shortest vertex-vertex distance
 * between components a and b.  The graph is the minimum spanning tree K of
 * the complete graph on the components weighted by d_ab, plus every edge
 * (a, b) with d_ab <= d_a + eps_a and d_ab <= d_b + eps_b, d_a the longest
 * tree edge at a and eps_a = eps_factor x the longest edge of a.  For every
 * graph edge, P_ab holds the closest vertex pair and every vertex pair
 * closer than d_ab + min(eps_a, eps_b).
 *
 * Ties are broken by lowest index throughout, so the result is a function
 * of the mesh alone: the tree is the one of Kruskal's algorithm with edges
 * ordered by (d_ab^2, a, b) (d_ab^2 the squared distance as computed,
 * (x_i - x_j)^2 + (y_i - y_j)^2 + (z_i - z_j)^2), and the closest pair of an
 * edge is the lowest (i, j) among the pairs at distance d_ab.
 */
#ifndef DTX_PROXIMITY_H
#define DTX_PROXIMITY_H

#include "mesh.h"
#include "status.h"

#include <stdint.h>

typedef struct {
    int32_t ncomp;          /* connected components of the vertices that are in a face */
    int32_t *comp;          /* nv: component of each vertex; -1 for a vertex in no face.
                               Components numbered 0.. in order of their lowest vertex. */
    double *eps;            /* ncomp: eps_factor x the component's longest edge (paper: 1.5) */
    int32_t nedges;         /* edges (a, b) of the proximity graph: the MST K plus the added ones */
    int32_t *edges;         /* nedges x 2, a < b, sorted by (a, b) */
    double *edge_dist;      /* nedges: d_ab, shortest vertex-vertex distance between a and b */
    unsigned char *in_tree; /* nedges: 1 when the edge is in the minimum spanning tree */
    int32_t *edge_pair;     /* nedges x 2: the closest vertex pair (i in a, j in b) of the
                               edge, |v_i - v_j| = d_ab; lowest (i, j) among ties */
    int64_t npairs;         /* proximity pairs, all edges together */
    int32_t *pairs;         /* npairs x 2 vertex pairs (i in component a, j in component b) of
                               P_ab: the closest pair of every edge plus every pair with
                               |v_i - v_j| < d_ab + min(eps_a, eps_b); sorted by edge then (i, j) */
    double *rest_len;       /* npairs: |v_i - v_j| */
    int32_t *pair_edge;     /* npairs: index into edges */
} dtx_proximity;

/* Builds the proximity graph of m (positions m->V).  eps_factor: 1.5 in the
 * paper (finite, >= 0).  Every array of *out is allocated (owned by *out,
 * freed with dtx_proximity_free) and non-NULL on success, also when its
 * count is 0.  A mesh of one component gives nedges = npairs = 0; a mesh
 * with no face gives ncomp = 0.
 *
 * Deterministic (ties broken by lowest index, see above) and bitwise the
 * same for any OpenMP thread count.  Time about O(n log n) in the number n
 * of vertices in faces, plus the output (a k-d tree over the vertices; the
 * tree by Boruvka rounds of nearest-other-cluster queries).  The output is
 * what the paper's rule gives and is not bounded by n: P_ab takes every
 * pair closer than d_ab + min(eps_a, eps_b), which for components far
 * apart compared with their size is nearly all |a| x |b| pairs (20 bytes
 * each in *out, up to about three times that while building).
 *
 * Fails with DTX_EINVAL (eps_factor negative or not finite), DTX_ERANGE (a
 * face index outside [0, nv)), DTX_ENONFINITE (a vertex in a face with a
 * non-finite coordinate) or DTX_ENOMEM, with a message; *out is then
 * empty (zeroed).  Thread-safe (no shared state); uses OpenMP inside. */
dtx_status dtx_proximity_build(const dtx_mesh *m, double eps_factor, dtx_proximity *out,
                               dtx_error *err);

/* Frees every array of *p and zeroes it.  Accepts NULL and a zeroed struct. */
void dtx_proximity_free(dtx_proximity *p);

/* E_R triangle pairs: for each proximity pair (i, j) of p, the triangle t_a
 * in the one-ring of i (the faces containing i) and t_b in the one-ring of j
 * maximising |h . n_a| + |h . n_b| (h: vector between the two triangles'
 * barycenters, n: unit face normals of m->V), ties to the lowest (t_a, t_b).
 * tri: npairs x 2 (t_a, t_b), caller-allocated.  Zero-area faces have zero
 * normals (still allowed).  p must come from dtx_proximity_build on m (or
 * have pairs of vertices that are in faces of m).
 *
 * Fails with DTX_ERANGE (a face or pair index out of range), DTX_ENONFINITE
 * (a vertex in a face with a non-finite coordinate), DTX_EINVAL (a pair
 * vertex in no face, or tri NULL with pairs to write) or DTX_ENOMEM; tri is
 * then unspecified.  Bitwise the same for any OpenMP thread count;
 * thread-safe. */
dtx_status dtx_proximity_triangle_pairs(const dtx_mesh *m, const dtx_proximity *p, int32_t *tri,
                                        dtx_error *err);

#endif /* DTX_PROXIMITY_H */
