/*
 * generate.h: multi-component test targets with a known structure, made
 * from one mesh (for the multicomponent method, Zhou et al. 2010).
 *
 *   reshape  the same mesh with other proportions (thicker, longer legs);
 *   pebbles  the surface cut into N connected patches that share no vertex,
 *            each shrunk a little so that cracks open between them (optionally
 *            each closed into a stone of some thickness);
 *   garment  the body plus a separate shell offset along the normals over a
 *            band of the body (a shirt over the torso);
 *   eyes     the body plus small closed spheres floating just off (or half
 *            sunk into) the surface at given vertices.
 *
 * Every generator also returns a vertex map: for each output vertex, the
 * input vertex it was made from (or -1 for a vertex made from none), so that
 * markers on the input and results on the output can be related to the
 * input.  Pure geometry: no files, no printing, no global state.  All
 * functions are deterministic (the same input gives the same bits) and
 * thread-safe on distinct arguments.
 *
 * Conventions: meshes as in mesh.h (V: nv x 3 row-major doubles, F: nf x 3
 * int32, 0-based, counter-clockwise seen from outside).  Lengths given as
 * "fractions" are fractions of the input's bounding-box diagonal
 * (dtx_bbox_diagonal).  On success *out is a new mesh (free with
 * dtx_mesh_free) and *map a new array of out->nv entries (free with free()).
 * On failure *out is zeroed, *map is NULL, nothing needs freeing, and the
 * status is DTX_EINVAL (a bad parameter, named in the message), DTX_EMESH /
 * DTX_ERANGE / DTX_ENONFINITE (an input mesh that fails dtx_mesh_validate),
 * or DTX_ENOMEM (also when an output size would not fit in int32).
 *
 * The generators form their own layer (src/gen/, library dtx_gen): built on
 * the numeric core, which knows nothing of them, and used by `dtx generate`,
 * the tests and the benchmarks.
 */
#ifndef DTX_GENERATE_H
#define DTX_GENERATE_H

#include "mesh.h"
#include "status.h"

#include <stdint.h>

/* Largest subdivision level dtx_gen_pebbles and dtx_gen_subdivide accept
 * (each level multiplies the face count by 4). */
#define DTX_GEN_MAX_SUBDIVIDE 8

/* Subdivision level of the spheres made by dtx_gen_eyes: 162 vertices and
 * 320 faces each. */
#define DTX_GEN_EYE_LEVEL 2

/* Midpoint subdivision, `levels` times (0 <= levels <= DTX_GEN_MAX_SUBDIVIDE):
 * each level splits every triangle (a, b, c) into (a, ab, ca), (ab, b, bc),
 * (ca, bc, c), (ab, bc, ca), where ab is the midpoint of edge ab, one new
 * vertex per edge shared by the faces on that edge.  The input's vertices
 * keep their indices (first), midpoints follow in the order of their edges'
 * (lower, higher) vertex pairs.  Face 4f + j of a level comes from face f of
 * the level before, so orientation is kept.  map (allocated, out->nv
 * entries): i for an input vertex i, -1 for a midpoint.  in must pass
 * dtx_mesh_validate. */
dtx_status dtx_gen_subdivide(const dtx_mesh *in, int levels, dtx_mesh *out, int32_t **map,
                             dtx_error *err);

/* A unit icosphere centred at the origin: the icosahedron subdivided
 * `level` times (0..DTX_GEN_MAX_SUBDIVIDE) with every vertex pushed onto the
 * unit sphere; 10 * 4^level + 2 vertices, 20 * 4^level faces, outward
 * counter-clockwise faces, one closed manifold component. */
dtx_status dtx_gen_icosphere(int level, dtx_mesh *out, dtx_error *err);

/* Pebbles.  Splits the surface of `in` (after `subdivide` levels of
 * dtx_gen_subdivide) into npieces patches:
 *   - seeds: one face per edge-connected part of the mesh (the lowest face of
 *     each part, face 0's part first), then farthest-point sampling of the face
 *     centroids (Euclidean; ties to the lowest face) until npieces seeds;
 *   - growth: multi-source Dijkstra over edge adjacency (faces sharing an
 *     edge; weight: centroid distance), each face joining the piece of the
 *     face it was reached from, so every piece is edge-connected;
 *   - every piece gets its own copies of its vertices (pieces share none),
 *     and is scaled about its area centroid c by s = 1 - g / (2 r), where
 *     g = gap * diagonal and r is the mean distance of the piece's boundary
 *     vertices from c: the boundary moves inward by g/2 on average, so
 *     neighbouring pieces are g apart (s is clamped to [0.1, 1]; gap 0 gives
 *     exact copies);
 *   - thickness > 0: each piece becomes a closed stone: the patch, a copy moved
 *     inward along the patch's area-weighted vertex normals by thickness *
 *     diagonal (faces reversed), and a wall of two triangles on every
 *     boundary edge of the patch.
 * Output order: piece by piece (pieces numbered by seed order); within a
 * piece its patch vertices in order of first use by its faces (faces in
 * increasing input order), then (thickness > 0) the inner copies in the
 * same order; faces: the patch (input orientation), then the inner faces,
 * then the wall.  out has exactly npieces connected components.
 * map (out->nv entries): the vertex of `in` each output vertex is a copy of;
 * inner copies map to the same vertex as their patch vertex; midpoints made
 * by subdivision map to -1.  Each input vertex's lowest output copy is thus a
 * patch vertex.
 * Parameters: 1 <= npieces <= faces after subdivision, and at least the
 * number of edge-connected parts of the mesh; gap >= 0; thickness >= 0
 * (both finite); 0 <= subdivide <= DTX_GEN_MAX_SUBDIVIDE.
 * Cost: O(npieces * nf) for the seeds plus O(nf log nf). */
dtx_status dtx_gen_pebbles(const dtx_mesh *in, int32_t npieces, double gap, double thickness,
                           int subdivide, dtx_mesh *out, int32_t **map, dtx_error *err);

/* Garment.  out = the body (its vertices and faces first, unchanged, same
 * indices) followed by a shell: copies of the body faces whose centroid
 * lies between lo and hi along axis (0 = x, 1 = y, 2 = z; lo, hi fractions
 * of the body's bounding-box extent on that axis from its minimum, lo < hi),
 * on copies of their vertices (in increasing body index) moved outward
 * along the body's area-weighted vertex normals (dtx_vertex_normals) by
 * offset * diagonal (offset > 0).  The shell keeps the body's orientation
 * and shares no vertex with the body.  map: identity on the body, then the
 * body vertex each shell vertex copies.  DTX_EINVAL when no face lies in
 * the band. */
dtx_status dtx_gen_garment(const dtx_mesh *body, int axis, double lo, double hi, double offset,
                           dtx_mesh *out, int32_t **map, dtx_error *err);

/* Reshape: the same vertices and faces at new positions, a smooth
 * non-rigid change of proportions (a target for methods that need the
 * source's connectivity, such as springs).  With u the coordinate along
 * axis (0 = x, 1 = y, 2 = z: the "up" axis), [u_min, u_max] its range and
 * c the bounding-box centre:
 *   - thicker: the two other coordinates are scaled about c by thicken;
 *   - longer legs: below u_0 = u_min + lo (u_max - u_min) the mesh is
 *     stretched along the axis by the factor legs, u -> u - (legs - 1) r(u)
 *     with r a smooth version of max(0, u_0 - u) (a hyperbola of width
 *     0.05 (u_max - u_min)), so the map is smooth and one-to-one.
 * thicken > 0, legs > 0, 0 <= lo <= 1, all finite (DTX_EINVAL otherwise).
 * map: the identity. */
dtx_status dtx_gen_reshape(const dtx_mesh *in, int axis, double thicken, double legs, double lo,
                           dtx_mesh *out, int32_t **map, dtx_error *err);

/* Eyes.  out = the body (first, unchanged) followed by one closed sphere
 * (dtx_gen_icosphere(DTX_GEN_EYE_LEVEL)) per anchor, in anchor order, of
 * radius radius * diagonal (radius > 0).  With gap >= 0 the sphere floats
 * off the surface: its centre lies on the ray from the anchor along the
 * anchor's smoothed normal (the area-weighted normal of the body faces whose
 * centroid is within 2 (radius + gap) * diagonal of the anchor; the vertex
 * normal when that is zero), first at (radius + gap) * diagonal from the
 * anchor, then marched out along the ray while the body (its triangles) is
 * nearer to the centre than that (steps of at least 1/20 of it, at most
 * 1000), so the sphere also clears a concave place such as an eye socket and
 * lies at least gap * diagonal from the body.  With gap < 0 the sphere is
 * embedded half-way: centred on the anchor.  anchors: nanchors >= 1 body
 * vertex indices (0-based; repeats allowed).  map: identity on the body,
 * then each sphere vertex -> its anchor.  out has (body components) +
 * nanchors components.  Cost: O(nf) per anchor for the smoothed normal. */
dtx_status dtx_gen_eyes(const dtx_mesh *body, const int32_t *anchors, int32_t nanchors,
                        double radius, double gap, dtx_mesh *out, int32_t **map, dtx_error *err);

/* Marker remapping through a vertex map.  For each of the n indices idx[i]
 * (in/out; 0-based vertices of the generator's input, which had nv_in
 * vertices), replaces it by the lowest output vertex v < nv_out with
 * map[v] == idx[i].  DTX_ERANGE when an index is outside [0, nv_in), and
 * DTX_EINVAL when no output vertex maps to it; *bad (may be NULL) is then the
 * position i of the first such index, and idx is left unchanged (*bad = -1
 * on success).  DTX_ENOMEM when out of memory. */
dtx_status dtx_gen_remap(const int32_t *map, int32_t nv_out, int32_t nv_in, int32_t n, int32_t *idx,
                         int32_t *bad, dtx_error *err);

#endif /* DTX_GENERATE_H */
