/*
 * obj_frames.h: OBJ frames of an asset with its attributes (`dtx export
 * --obj-dir`, a job's export_obj_dir).
 *
 * Each frame's OBJ has the asset's vertex order and count, its `mtllib`,
 * `vt` lines, `usemtl` groups and `f v/t/n` corners (dtx_obj_write_attrs).
 * Normals: when the asset had normals, each frame gets normals recomputed
 * from its own positions that keep the asset's smoothing
 * (core/frame_normals.h: area-weighted, per smoothing group, twins along a
 * seam together; the asset's per-vertex indexing kept when it had one);
 * when it had none, none are written.  Material names with white space
 * (common in glTF and FBX) get '_' for it, an empty name "material_N".
 * Without attributes the file is what dtx_obj_write writes.
 */
#ifndef DTX_OBJ_FRAMES_H
#define DTX_OBJ_FRAMES_H

#include "frame_normals.h"
#include "meshfile.h"

typedef struct {
    const dtx_mesh *mesh;   /* the asset (rest positions, faces), borrowed */
    dtx_mesh_attrs a;       /* the asset's attributes, normals replaced per frame */
    dtx_mesh_attrs owned;   /* what begin read or copied, freed by end */
    dtx_frame_normals plan; /* empty when the asset had no normals */
} dtx_obj_frames;

/* Prepares frames of mesh with attributes a (may be NULL; taken over:
 * *a is zeroed, end frees it).  mesh is borrowed until end. */
dtx_status dtx_obj_frames_begin(dtx_obj_frames *w, const dtx_mesh *mesh, dtx_mesh_attrs *a,
                                dtx_error *err);

/* Writes frame X (mesh->nv x 3 doubles, or floats Xf; exactly one
 * non-NULL) to path atomically (see dtx_obj_write). */
dtx_status dtx_obj_frames_write(dtx_obj_frames *w, const char *path, const double *X,
                                const float *Xf, const char *comment, dtx_error *err);

/* Frees what begin kept.  Accepts NULL. */
void dtx_obj_frames_end(dtx_obj_frames *w);

#endif /* DTX_OBJ_FRAMES_H */
