/*
 * glb_materials.h: the materials of a stored asset mesh for the .glb
 * writer (gltf.h): names from the mesh's material_names, base colours and
 * texture images from the OBJ material library it names (attribute
 * mtllib, kept by reference).
 *
 * Where the .mtl is looked for: the mesh's attribute source names what it
 * was made from.  A result's mesh names "FILE.h5:/meshes/NAME" (the job's
 * target), which names the OBJ it was imported from; the chain is
 * followed (at most 8 links).  A relative path is taken against the folder
 * of the file that stores it, then as written (the folder dtx ran in).
 * The .mtl is looked for next to the OBJ, then next to the dtx file.  In
 * the .mtl: newmtl, Kd (the base colour), d or Tr (its alpha), map_Kd (the
 * base colour texture, options before the file name skipped), relative to
 * the .mtl's folder.  Images must be PNG or JPEG (told by their first
 * bytes).
 *
 * Nothing here is an error but running out of memory: what is not found
 * (the OBJ, the .mtl, a material in it, an image) is said in note, and
 * the material keeps its name without colour or image.
 */
#ifndef DTX_GLB_MATERIALS_H
#define DTX_GLB_MATERIALS_H

#include "gltf.h"
#include "meshfile.h"
#include "status.h"

#include <hdf5.h>

/* One .mtl material. */
typedef struct {
    char *name;
    int has_kd;
    double kd[3];
    double alpha; /* d, or 1 - Tr; 1 when neither is given */
    char *map_kd; /* the texture's file name as written (NULL: none) */
} dtx_mtl_material;

typedef struct {
    int32_t n;
    dtx_mtl_material *m;
} dtx_mtl;

/* Parses the len bytes at buf as a .mtl (name for messages).  Unknown
 * statements are skipped; a Kd or d that is not numbers is DTX_EPARSE
 * naming the line.  Free with dtx_mtl_free. */
dtx_status dtx_mtl_parse(const char *name, const char *buf, size_t len, dtx_mtl *out,
                         dtx_error *err);
void dtx_mtl_free(dtx_mtl *m);

typedef struct {
    int32_t n;
    dtx_glb_material *mat; /* n entries, for dtx_glb_opts.materials (owning their strings) */
    char *obj_path;        /* the asset's OBJ when found (NULL otherwise) */
    char *mtl_path;        /* the .mtl used (NULL: none found) */
    int nimages;           /* images embedded */
    char note[2048];       /* what was not found ("" when nothing is missing) */
} dtx_glb_materials;

/* Fills *out for the mesh group `group` of the open dtx file f (its path
 * file) whose attributes are a (a->nmat materials; none: out->n = 0).
 * DTX_ENOMEM only. */
dtx_status dtx_glb_materials_load(hid_t f, const char *file, const char *group,
                                  const dtx_mesh_attrs *a, dtx_glb_materials *out, dtx_error *err);
void dtx_glb_materials_free(dtx_glb_materials *m);

#endif /* DTX_GLB_MATERIALS_H */
