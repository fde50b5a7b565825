/*
 * assimp_import.h: rest meshes from glTF 2.0 (.glb, .gltf) and FBX files
 * through Debian's assimp (libassimp-dev), with their attributes.
 *
 * What is read: positions, triangles (polygons triangulated by assimp's
 * aiProcess_Triangulate; point and line primitives are skipped with a
 * warning), TEXCOORD_0 (u, v, as assimp gives them: its glTF importer
 * flips v to the OBJ convention, v up), NORMAL and the material names.
 * The file's vertex order is kept: no JoinIdenticalVertices or other
 * post-processing that reorders, so vertices split along seams stay split
 * (dtx run welds them; outputs keep this order).  Several meshes of a
 * scene (glTF primitives, FBX meshes) are concatenated in assimp's order
 * (scene->mMeshes) with one warning; node transforms are not applied (the
 * meshes' own coordinates are taken).  UVs (normals) are kept only when
 * every mesh has them; a mesh's faces get its material (names deduplicated
 * in order of first use).  UVs and normals are per vertex: uv_faces and
 * normal_faces equal the faces.
 */
#ifndef DTX_ASSIMP_IMPORT_H
#define DTX_ASSIMP_IMPORT_H

#include "meshfile.h"

/* 1 when path's extension is one this reader takes (.glb, .gltf, .fbx;
 * case-insensitive). */
int dtx_assimp_handles(const char *path);

/* Reads the mesh at path into *out (free with dtx_mesh_free) and its
 * attributes into *a (free with dtx_mesh_attrs_free); both zeroed on
 * failure.  Errors: DTX_EIO / DTX_EPARSE with assimp's own message after
 * the file name, DTX_EPARSE for a scene without triangles, DTX_ERANGE for
 * more than INT32_MAX vertices or faces, DTX_ENONFINITE for a non-finite
 * position, UV or normal (naming the vertex), DTX_ENOMEM.  Not
 * thread-safe (assimp's C API keeps the last error in a global). */
dtx_status dtx_assimp_read(const char *path, dtx_mesh *out, dtx_mesh_attrs *a,
                           const dtx_warner *w, dtx_error *err);

#endif /* DTX_ASSIMP_IMPORT_H */
