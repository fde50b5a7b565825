/* assimp_import.c: glTF 2.0 and FBX rest meshes through assimp
 * (assimp_import.h). */
#include "assimp_import.h"

#include "meshfile_util.h"

#include <assimp/cimport.h>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

int dtx_assimp_handles(const char *path)
{
    static const char *const ext[] = {".glb", ".gltf", ".fbx"};
    size_t n = strlen(path);
    for (size_t i = 0; i < sizeof ext / sizeof *ext; i++) {
        size_t k = strlen(ext[i]);
        if (n > k && strcasecmp(path + n - k, ext[i]) == 0)
            return 1;
    }
    return 0;
}

/* The index of name in the first *n names, appended when new. */
static int32_t material_index(char ***names, int32_t *n, const char *name)
{
    char **p;
    for (int32_t i = 0; i < *n; i++)
        if (strcmp((*names)[i], name) == 0)
            return i;
    p = realloc(*names, ((size_t)*n + 1) * sizeof *p);
    if (!p)
        return -2;
    *names = p;
    if (!(p[*n] = malloc(strlen(name) + 1)))
        return -2;
    strcpy(p[*n], name);
    return (*n)++;
}

dtx_status dtx_assimp_read(const char *path, dtx_mesh *out, dtx_mesh_attrs *a,
                           const dtx_warner *w, dtx_error *err)
{
    const struct aiScene *sc;
    int64_t nv = 0, nf = 0, nskip = 0;
    int have_uv = 1, have_n = 1;
    dtx_status st = DTX_OK;
    int32_t vbase = 0, fi = 0;

    memset(out, 0, sizeof *out);
    memset(a, 0, sizeof *a);
    if (access(path, R_OK) != 0)
        return dtx_seterr(err, DTX_EIO, "%s: cannot open", path);
    sc = aiImportFile(path, aiProcess_Triangulate);
    if (!sc)
        return dtx_seterr(err, DTX_EPARSE, "%s: not read by assimp: %s", path,
                          aiGetErrorString());

    /* ---- counts, before anything is allocated */
    for (unsigned m = 0; m < sc->mNumMeshes; m++) {
        const struct aiMesh *me = sc->mMeshes[m];
        nv += me->mNumVertices;
        for (unsigned f = 0; f < me->mNumFaces; f++)
            if (me->mFaces[f].mNumIndices == 3)
                nf++;
            else
                nskip++;
        have_uv &= me->mTextureCoords[0] != NULL;
        have_n &= me->mNormals != NULL;
    }
    if (nv > INT32_MAX || nf > INT32_MAX) {
        st = dtx_seterr(err, DTX_ERANGE, "%s: %lld vertices, %lld triangles: more than %d",
                        path, (long long)nv, (long long)nf, (int)INT32_MAX);
        goto done;
    }
    if (nf == 0) {
        st = dtx_seterr(err, DTX_EPARSE, "%s: the scene has no triangles (%u meshes)", path,
                        sc->mNumMeshes);
        goto done;
    }
    if (sc->mNumMeshes > 1)
        dtx_warnf(w, "%s: %u meshes in the scene, concatenated in order into one mesh (node "
                     "transforms not applied)",
                  path, sc->mNumMeshes);
    if (nskip > 0)
        dtx_warnf(w, "%s: %lld point or line primitives skipped", path, (long long)nskip);

    if ((st = dtx_mesh_alloc(out, (int32_t)nv, (int32_t)nf, err)) != DTX_OK)
        goto done;
    a->material = malloc((size_t)nf * sizeof *a->material);
    if (have_uv) {
        a->nuv = (int32_t)nv;
        a->uv = malloc((size_t)nv * 2 * sizeof *a->uv);
        a->uv_faces = malloc((size_t)nf * 3 * sizeof *a->uv_faces);
    }
    if (have_n) {
        a->nn = (int32_t)nv;
        a->normals = malloc((size_t)nv * 3 * sizeof *a->normals);
        a->normal_faces = malloc((size_t)nf * 3 * sizeof *a->normal_faces);
    }
    if (!a->material || (have_uv && (!a->uv || !a->uv_faces)) ||
        (have_n && (!a->normals || !a->normal_faces))) {
        st = dtx_seterr(err, DTX_ENOMEM, "%s: out of memory", path);
        goto done;
    }

    /* ---- the meshes, concatenated */
    for (unsigned m = 0; m < sc->mNumMeshes; m++) {
        const struct aiMesh *me = sc->mMeshes[m];
        int32_t mat = -1;
        if (sc->mMaterials && me->mMaterialIndex < sc->mNumMaterials) {
            struct aiString name;
            if (aiGetMaterialString(sc->mMaterials[me->mMaterialIndex], AI_MATKEY_NAME, &name) ==
                    aiReturn_SUCCESS &&
                name.length > 0) {
                mat = material_index(&a->material_names, &a->nmat, name.data);
                if (mat == -2) {
                    st = dtx_seterr(err, DTX_ENOMEM, "%s: out of memory", path);
                    goto done;
                }
            }
        }
        for (unsigned i = 0; i < me->mNumVertices; i++) {
            size_t v = (size_t)vbase + i;
            const struct aiVector3D *p = &me->mVertices[i];
            out->V[3 * v] = p->x, out->V[3 * v + 1] = p->y, out->V[3 * v + 2] = p->z;
            if (!isfinite(out->V[3 * v]) || !isfinite(out->V[3 * v + 1]) ||
                !isfinite(out->V[3 * v + 2])) {
                st = dtx_seterr(err, DTX_ENONFINITE,
                                "%s: mesh %u, vertex %u (0-based) has a non-finite coordinate",
                                path, m, i);
                goto done;
            }
            if (have_uv) {
                a->uv[2 * v] = me->mTextureCoords[0][i].x;
                a->uv[2 * v + 1] = me->mTextureCoords[0][i].y;
            }
            if (have_n) {
                a->normals[3 * v] = me->mNormals[i].x;
                a->normals[3 * v + 1] = me->mNormals[i].y;
                a->normals[3 * v + 2] = me->mNormals[i].z;
            }
        }
        for (unsigned f = 0; f < me->mNumFaces; f++) {
            const struct aiFace *fc = &me->mFaces[f];
            if (fc->mNumIndices != 3)
                continue;
            for (int k = 0; k < 3; k++) {
                if (fc->mIndices[k] >= me->mNumVertices) {
                    st = dtx_seterr(err, DTX_ERANGE,
                                    "%s: mesh %u, face %u: vertex index %u out of range [0, %u)",
                                    path, m, f, fc->mIndices[k], me->mNumVertices);
                    goto done;
                }
                out->F[3 * (size_t)fi + k] = vbase + (int32_t)fc->mIndices[k];
            }
            a->material[fi++] = mat;
        }
        vbase += (int32_t)me->mNumVertices;
    }
    if (have_uv)
        memcpy(a->uv_faces, out->F, (size_t)nf * 3 * sizeof *out->F);
    if (have_n)
        memcpy(a->normal_faces, out->F, (size_t)nf * 3 * sizeof *out->F);
    if (a->nmat == 0) { /* no named material: none kept */
        free(a->material);
        a->material = NULL;
    }
    st = dtx_mesh_attrs_validate(a, out->nv, out->nf, path, err);
done:
    aiReleaseImport(sc);
    if (st != DTX_OK) {
        dtx_mesh_free(out);
        dtx_mesh_attrs_free(a);
    }
    return st;
}
