/*
 * weld_setup.h: a run's meshes welded along their seams (core/weld.h), and
 * the way back to the asset's own vertices for every output.
 *
 * The solvers see the welded mesh; the results, the output's copy of the
 * target mesh, OBJ frames and every export see the asset's vertex order and
 * count (twins get identical positions).  Source frames stored in the
 * asset's split order are compacted to the welded source before the solve.
 */
#ifndef DTX_WELD_SETUP_H
#define DTX_WELD_SETUP_H

#include "markers.h"
#include "obj_frames.h"
#include "mesh.h"
#include "status.h"

#include <hdf5.h>

#include <stdint.h>

typedef struct {
    int32_t nv;         /* the asset's vertex count */
    int32_t nw;         /* the welded count (nv when nothing was welded) */
    int32_t *map, *rep; /* weld.h's map (nv) and rep (nw); NULL when nothing was welded */
    dtx_mesh asset;     /* the mesh as stored; empty when nothing was welded */
    int obj_ready;      /* obj holds the asset's attributes (dtx_weld_write_obj) */
    dtx_obj_frames obj;
} dtx_weld_ctx;

/* Welds *m in place (twins within tol; tol < 0: no welding) and keeps the
 * asset's mesh and map in *w.  When nothing is welded, *m is untouched and
 * w->map is NULL.  The welded mesh is checked with dtx_mesh_validate (a
 * tolerance so large that it collapses a triangle is DTX_EMESH, naming
 * `what`).  Every rank calls it alike; it says nothing. */
dtx_status dtx_weld_setup(dtx_mesh *m, double tol, const char *what, dtx_weld_ctx *w,
                          dtx_error *err);

/* The mesh outputs are written on: the asset's when welded, else welded. */
const dtx_mesh *dtx_weld_asset(const dtx_weld_ctx *w, const dtx_mesh *welded);

/* The welded index of asset vertex i (i itself when nothing was welded or
 * i is out of [0, nv): range errors are left to the caller's checks). */
int32_t dtx_weld_index(const dtx_weld_ctx *w, int32_t i);

/* Maps markers given on the assets' vertices onto the welded meshes (src
 * may be NULL: source indices unchanged).  Call after validating the
 * markers against the asset counts. */
void dtx_weld_markers(dtx_markers *mk, const dtx_weld_ctx *src, const dtx_weld_ctx *tgt);

/* n source frames X (n x nv x 3, the asset's order) to the welded source
 * (n x nw x 3, in place).  Nothing when nothing was welded. */
void dtx_weld_source_frames(const dtx_weld_ctx *w, double *X, int64_t n);

/* n result frames X (n x nw x 3) to the asset's order (n x nv x 3, in
 * place: X must have room).  Nothing when nothing was welded. */
void dtx_weld_result_frames(const dtx_weld_ctx *w, double *X, int64_t n);

/* Writes the target mesh into the output as group `group`: the asset's
 * vertices (dtx_weld_asset) with the attributes its group in `file` holds
 * (UVs, normals, materials, colours: h5mesh_attrs.h), so results in the
 * asset's order keep them.  Collective like dtx_h5_write_mesh. */
dtx_status dtx_weld_write_asset(hid_t out, const char *group, const dtx_weld_ctx *w,
                                const dtx_mesh *welded, const char *file, const char *mesh,
                                const char *source, dtx_error *err);

/* Writes result frame X (the asset's order: dtx_weld_asset's nv x 3) as
 * an OBJ at path with the attributes of the mesh group `mesh` of `file`
 * (io/obj_frames.h: UVs, materials, mtllib, per-frame normals where the
 * asset had normals).  The attributes are read at the first call and kept
 * in w until dtx_weld_ctx_free.  Not collective. */
dtx_status dtx_weld_write_obj(dtx_weld_ctx *w, const dtx_mesh *welded, const char *file,
                              const char *mesh, const char *path, const double *X,
                              const char *comment, dtx_error *err);

void dtx_weld_ctx_free(dtx_weld_ctx *w);

#endif /* DTX_WELD_SETUP_H */
