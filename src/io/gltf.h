/*
 * gltf.h: a mesh animation as glTF 2.0 binary (.glb): the rest mesh with
 * the asset's attributes (UVs, normals, materials, a base colour texture),
 * one morph target per frame and an animation that shows the frames in turn.
 *
 * What the file holds (glTF 2.0 specification, Khronos,
 * https://registry.khronos.org/glTF/specs/2.0/glTF-2.0.html: "GLB File
 * Format Specification", "Meshes", "Morph Targets", "Materials",
 * "Animations"):
 *
 *   scene 0 -> node 0 -> mesh 0, one triangle primitive per material
 *   (material 0, 1, ... in order, then the faces without one; a material
 *   with no faces gets no primitive).  Every primitive shares the vertex
 *   accessors and the morph targets and has its own indices:
 *     POSITION    the rest mesh, float32 VEC3, with min/max
 *     NORMAL      unit normals: the asset's (opts.attrs->normals) where it
 *                 has them, else area-weighted normals of the rest mesh with
 *                 vertices at bit-identical positions summed together (so a
 *                 UV seam does not show as a crease)
 *     TEXCOORD_0  the asset's UVs (only with opts.attrs->uv), float32 VEC2,
 *                 v flipped: (u, 1 - v) (OBJ's v runs up, glTF's down)
 *     indices     UNSIGNED_SHORT when the glTF vertices number <= 65535,
 *                 else UNSIGNED_INT
 *     targets     frame k: POSITION = frame k - rest, float32 VEC3, min/max;
 *                 NORMAL = n_k - n_rest, n the area-weighted normals above
 *                 recomputed on frame k and on the rest (so without asset
 *                 normals a viewer shows frame k's own normals; with them,
 *                 the asset's normals turned by the frame's change)
 *   mesh.weights  nframes zeros; mesh.extras.targetNames  one name a frame
 *   materials   one per opts.materials (name; pbrMetallicRoughness with
 *               metallicFactor 0, baseColorFactor = the .mtl's Kd when known
 *               and no texture, baseColorTexture when an image is given and
 *               the mesh has UVs); images embedded through a buffer view
 *               (image/png or image/jpeg, told by their first bytes)
 *   animation 0: one sampler, input = frame times (float32 seconds, strictly
 *     increasing, with min/max), output = nframes x nframes weights, row k
 *     one-hot at k, so at time k the mesh is rest + (frame k - rest) = frame
 *     k; LINEAR interpolation blends neighbouring frames (the same as
 *     interpolating the positions), STEP holds each frame.
 *
 * glTF vertices and dtx vertices.  glTF wants one UV and one normal per
 * vertex; an OBJ gives them per face corner.  Each distinct (vertex, uv
 * index, normal index) of a face corner is one glTF vertex: the first
 * corner met of dtx vertex i (faces in order) is glTF vertex i, so glTF
 * vertices 0..nv-1 are the dtx vertices in order, and every other
 * combination is a copy appended after them.  When the mesh has copies,
 * mesh.extras.dtx_vertex_copies = {"vertices": nv, "copy_of": [i0, i1,
 * ...]} says that glTF vertex nv + j is a copy of dtx vertex copy_of[j]
 * (0-based); a mesh whose uv_faces and normal_faces equal its faces (one
 * UV and normal per vertex, as a split OBJ or a glTF asset has) has none,
 * and its glTF vertices are exactly the dtx vertices.
 *
 * The weights are a sparse accessor ("Sparse Accessors" in the
 * specification): no buffer view, so they start as zeros, and nframes
 * entries (UNSIGNED_INT index k * nframes + k, value 1.0f).  The file
 * therefore grows linearly with the frames (per frame: one morph target of
 * 24 * ng bytes for ng glTF vertices, positions and normals, 12 bytes of
 * time and sparse entry, and about 370 bytes of JSON, 35 more for each
 * further primitive, which lists the targets too); DTX_GLB_MAX_FRAMES
 * keeps the largest sparse index, nframes^2 - 1, below 2^32.  (Readers that
 * expand the accessor, as Blender's importer does, still hold nframes^2
 * floats in memory.)
 *
 * Binary layout: 12-byte header ("glTF", version 2, total length), a JSON
 * chunk padded with spaces and a BIN chunk padded with zeros, both to 4
 * bytes; one buffer; buffer views (positions, normals, UVs, indices of
 * every primitive, each image, all morph deltas with byteStride 12 --
 * frame k's positions then its normals --, times, sparse indices, sparse
 * values) start at multiples of 4; everything little-endian.  The whole
 * file must stay below 4 GiB (the GLB length field is 32 bits):
 * DTX_ERANGE otherwise, before anything is written.
 *
 * Memory is O(nv + nf + nframes) besides the JSON (O(nframes)) and the
 * images: frames are fetched through a callback twice each (first for the
 * accessors' min/max, which the JSON chunk needs before the binary data,
 * then to write them); the two passes must return the same data (checked:
 * DTX_EINVAL otherwise).
 *
 * Output is atomic (src/io/atomic_file.h): on any error no file is left
 * and an existing file at path is untouched.
 *
 * Thread-safety: reentrant.
 */
#ifndef DTX_GLTF_H
#define DTX_GLTF_H

#include "mesh.h"
#include "meshfile.h"
#include "status.h"

#include <stddef.h>

#include <stdint.h>

/* Most frames (morph targets) one .glb may hold. */
#define DTX_GLB_MAX_FRAMES 65535

/* Fills X (nv x 3 doubles, row-major) with frame k (0 <= k < nframes) of
 * the animation.  Returns DTX_OK or an error with err filled. */
typedef dtx_status (*dtx_glb_frame_fn)(void *ctx, int64_t k, double *X, dtx_error *err);

/* One glTF material: attribute material id m of the mesh gets
 * materials[m]. */
typedef struct {
    const char *name;           /* NULL: "material-M" */
    int has_color;              /* base_color holds the .mtl's Kd (and d as alpha) */
    float base_color[4];        /* RGBA in [0, 1] */
    const unsigned char *image; /* PNG or JPEG bytes (NULL: none) */
    size_t image_len;
    const char *image_name; /* the image's name in the file (NULL: none) */
} dtx_glb_material;

typedef struct {
    double seconds_per_frame; /* time of frame k = k * seconds_per_frame; > 0 */
    int step;                 /* 1: STEP interpolation, 0: LINEAR */
    const char *name;         /* node and mesh name (NULL: "dtx") */
    /* Morph target k is named "frame-NNNNN" with NNNNN = label_first + k *
     * label_step (the frame numbers of the exported frames). */
    int64_t label_first, label_step;
    const char *source; /* recorded in asset.extras.source (NULL: omitted) */
    /* The asset's attributes (NULL: none): uv + uv_faces, normals +
     * normal_faces and material are used; colors and mtllib are not.
     * Checked with dtx_mesh_attrs_validate. */
    const dtx_mesh_attrs *attrs;
    /* attrs->nmat materials (NULL: named from attrs->material_names, no
     * colour); nmaterials must then equal attrs->nmat. */
    const dtx_glb_material *materials;
    int32_t nmaterials;
} dtx_glb_opts;

/* Writes the .glb described above to path.
 *   rest:    the rest mesh (nv >= 1, nf >= 1, indices in range, finite
 *            coordinates that fit float32)
 *   nframes: 1..DTX_GLB_MAX_FRAMES (and the file below 4 GiB)
 *   frame:   the frame callback, called with k = 0..nframes-1 in order,
 *            twice; every coordinate and every difference from the rest
 *            must be finite in float32 (DTX_ENONFINITE naming the frame and
 *            vertex otherwise).
 * Errors: DTX_EINVAL (arguments, frame times not strictly increasing in
 * float32, attributes that do not fit the mesh, an image that is neither
 * PNG nor JPEG), DTX_ERANGE (file over 4 GiB), DTX_ENONFINITE, DTX_ENOMEM,
 * DTX_EIO, or what the callback returned. */
dtx_status dtx_glb_write(const char *path, const dtx_mesh *rest, int64_t nframes,
                         dtx_glb_frame_fn frame, void *ctx, const dtx_glb_opts *opts,
                         dtx_error *err);

#endif /* DTX_GLTF_H */
