/*
 * h5mesh_attrs.h: an asset mesh's optional attributes in the HDF5 layout
 * (version 1, additions only; schemas/hdf5-layout-v1.md, "Mesh
 * attributes").  Inside /meshes/NAME, all optional:
 *   uv f64 nuv x 2 + uv_faces i32 nf x 3 (indices into uv)
 *   normals f64 nn x 3 + normal_faces i32 nf x 3 (indices into normals)
 *   material i32 nf (-1: none) + attribute material_names (one string,
 *     the names joined by newlines, nmat lines)
 *   colors f64 nv x 3 or nv x 4 (per vertex, in [0, 1])
 *   attribute mtllib (string: the OBJ material library, by reference)
 */
#ifndef DTX_H5MESH_ATTRS_H
#define DTX_H5MESH_ATTRS_H

#include "meshfile.h"
#include "status.h"

#include <hdf5.h>

/* Writes a's datasets and attributes into the open group g (a mesh of nv
 * vertices, nf faces); a NULL or empty a writes nothing.  a is checked with
 * dtx_mesh_attrs_validate first.  where names the group in messages. */
dtx_status dtx_h5_write_mesh_attrs(hid_t g, const char *where, const dtx_mesh_attrs *a,
                                   int32_t nv, int32_t nf, dtx_error *err);

/* dtx_h5_write_mesh (h5layout.h) with the attributes a (may be NULL),
 * written in the same temporary group, so the mesh appears with them or
 * not at all. */
dtx_status dtx_h5_write_mesh_with(hid_t file, const char *group, const dtx_mesh *m,
                                  const dtx_mesh_attrs *a, const char *source, dtx_error *err);

/* Reads whatever attributes the mesh group `group` of file holds into *a
 * (zeroed first; free with dtx_mesh_attrs_free), checking shapes against
 * nv and nf and then dtx_mesh_attrs_validate. */
dtx_status dtx_h5_read_mesh_attrs(hid_t file, const char *group, int32_t nv, int32_t nf,
                                  dtx_mesh_attrs *a, dtx_error *err);

/* The check `dtx validate` makes of the attributes of the mesh group
 * `group` (the layout description's check "mesh_attributes"): the counts
 * are the rows of its vertices and faces, then dtx_h5_read_mesh_attrs
 * (shapes, uv with uv_faces and normals with normal_faces, material with
 * its material_names and in [-1, nmat), index ranges, finite values,
 * colours with 3 or 4 channels in [0, 1]).  DTX_OK when the group has no
 * attributes; otherwise the first problem, its message naming the group. */
dtx_status dtx_h5_check_mesh_attrs(hid_t file, const char *group, dtx_error *err);

#endif /* DTX_H5MESH_ATTRS_H */
