/*
 * gltf.h: a mesh animation as glTF 2.0 binary (.glb): the rest mesh, one
 * morph target per frame and an animation that shows the frames in turn.
 *
 * What the file holds (glTF 2.0 specification, Khronos,
 * https://registry.khronos.org/glTF/specs/2.0/glTF-2.0.html: "GLB File
 * Format Specification", "Morph Targets", "Animations"):
 *
 *   scene 0 -> node 0 -> mesh 0, one triangle primitive:
 *     POSITION  the rest mesh, float32 VEC3, with min/max
 *     NORMAL    area-weighted unit vertex normals of the rest mesh
 *     indices   UNSIGNED_SHORT when nv <= 65535, else UNSIGNED_INT
 *     targets   frame k: POSITION = frame k - rest, float32 VEC3, min/max;
 *               the frame's normals are not stored (viewers keep the rest
 *               normals; shading of strongly bent parts is approximate)
 *   mesh.weights  nframes zeros; mesh.extras.targetNames  one name a frame
 *   animation 0: one sampler, input = frame times (float32 seconds, strictly
 *     increasing, with min/max), output = nframes x nframes weights, row k
 *     one-hot at k, so at time k the mesh is rest + (frame k - rest) = frame
 *     k; LINEAR interpolation blends neighbouring frames (the same as
 *     interpolating the positions), STEP holds each frame.
 *
 * The weights are a sparse accessor ("Sparse Accessors" in the
 * specification): no buffer view, so they start as zeros, and nframes
 * entries (UNSIGNED_INT index k * nframes + k, value 1.0f).  The file
 * therefore grows linearly with the frames (per frame: one morph target of
 * 12 * nv bytes, 12 bytes of time and sparse entry, and about 200 bytes of
 * JSON); DTX_GLB_MAX_FRAMES keeps the largest sparse index, nframes^2 - 1,
 * below 2^32.  (Readers that expand the accessor, as Blender's importer
 * does, still hold nframes^2 floats in memory.)

 * Binary layout: 12-byte header ("glTF", version 2, total length), a JSON
 * chunk padded with spaces and a BIN chunk padded with zeros, both to 4
 * bytes; one buffer; buffer views (positions, normals, indices, all morph
 * deltas with byteStride 12, times, sparse indices, sparse values) start at multiples of 4;
 * everything little-endian.  The whole file must stay below 4 GiB (the
 * GLB length field is 32 bits): DTX_ERANGE otherwise, before anything is
 * written.
 *
 * Memory is O(nv + nframes) besides the JSON (O(nframes)): frames are
 * fetched through a callback twice each (first for the accessors' min/max,
 * which the JSON chunk needs before the binary data, then to write them);
 * the two passes must return the same data (checked: DTX_EINVAL otherwise).
 *
 * Output is atomic (src/io/atomic_file.h): on any error no file is left
 * and an existing file at path is untouched.
 *
 * Thread-safety: reentrant.
 */
#ifndef DTX_GLTF_H
#define DTX_GLTF_H

#include "mesh.h"
#include "status.h"

#include <stdint.h>

/* Most frames (morph targets) one .glb may hold. */
#define DTX_GLB_MAX_FRAMES 65535

/* Fills X (nv x 3 doubles, row-major) with frame k (0 <= k < nframes) of
 * the animation.  Returns DTX_OK or an error with err filled. */
typedef dtx_status (*dtx_glb_frame_fn)(void *ctx, int64_t k, double *X, dtx_error *err);

typedef struct {
    double seconds_per_frame; /* time of frame k = k * seconds_per_frame; > 0 */
    int step;                 /* 1: STEP interpolation, 0: LINEAR */
    const char *name;         /* node and mesh name (NULL: "dtx") */
    /* Morph target k is named "frame-NNNNN" with NNNNN = label_first + k *
     * label_step (the frame numbers of the exported frames). */
    int64_t label_first, label_step;
    const char *source; /* recorded in asset.extras.source (NULL: omitted) */
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
 * float32), DTX_ERANGE (file over 4 GiB), DTX_ENONFINITE, DTX_ENOMEM,
 * DTX_EIO, or what the callback returned. */
dtx_status dtx_glb_write(const char *path, const dtx_mesh *rest, int64_t nframes,
                         dtx_glb_frame_fn frame, void *ctx, const dtx_glb_opts *opts,
                         dtx_error *err);

#endif /* DTX_GLTF_H */
