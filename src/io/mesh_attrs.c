/* mesh_attrs.c: the optional attributes of an asset mesh (meshfile.h). */
#include "meshfile.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void dtx_mesh_attrs_free(dtx_mesh_attrs *a)
{
    if (!a)
        return;
    free(a->uv);
    free(a->uv_faces);
    free(a->normals);
    free(a->normal_faces);
    free(a->material);
    for (int32_t i = 0; a->material_names && i < a->nmat; i++)
        free(a->material_names[i]);
    free(a->material_names);
    free(a->mtllib);
    free(a->colors);
    memset(a, 0, sizeof *a);
}

int dtx_mesh_attrs_any(const dtx_mesh_attrs *a)
{
    return a && (a->uv || a->normals || a->material || a->mtllib || a->colors);
}

static dtx_status check_values(const double *x, int64_t n, const char *what, const char *name,
                               dtx_error *err)
{
    for (int64_t i = 0; i < n; i++)
        if (!isfinite(x[i]))
            return dtx_seterr(err, DTX_ENONFINITE, "%s: %s value %lld (0-based) is not finite",
                              what, name, (long long)i);
    return DTX_OK;
}

static dtx_status check_index(const int32_t *ix, int64_t n, int32_t lo, int32_t hi,
                              const char *what, const char *name, dtx_error *err)
{
    for (int64_t i = 0; i < n; i++)
        if (!(ix[i] >= lo && ix[i] < hi))
            return dtx_seterr(err, DTX_ERANGE,
                              "%s: %s entry %lld (0-based) is %d, out of range [%d, %d)", what,
                              name, (long long)i, (int)ix[i], (int)lo, (int)hi);
    return DTX_OK;
}

dtx_status dtx_mesh_attrs_validate(const dtx_mesh_attrs *a, int32_t nv, int32_t nf,
                                   const char *what, dtx_error *err)
{
    dtx_status st = DTX_OK;
    if (!a)
        return DTX_OK;
    if (a->nuv < 0 || a->nn < 0 || a->nmat < 0 || (a->uv && !a->uv_faces) ||
        (a->uv_faces && !a->uv) || (a->normals && !a->normal_faces) ||
        (a->normal_faces && !a->normals) || (a->nmat > 0 && !a->material_names) ||
        (a->colors && a->ncolor != 3 && a->ncolor != 4))
        return dtx_seterr(err, DTX_EFORMAT,
                          "%s: inconsistent attributes (uv %d, normals %d, materials %d, "
                          "colour channels %d, or an index array without its data)",
                          what, (int)a->nuv, (int)a->nn, (int)a->nmat, (int)a->ncolor);
    if (a->uv && (st = check_values(a->uv, 2 * (int64_t)a->nuv, what, "uv", err)) != DTX_OK)
        return st;
    if (a->uv && (st = check_index(a->uv_faces, 3 * (int64_t)nf, 0, a->nuv, what, "uv_faces",
                                   err)) != DTX_OK)
        return st;
    if (a->normals &&
        (st = check_values(a->normals, 3 * (int64_t)a->nn, what, "normals", err)) != DTX_OK)
        return st;
    if (a->normals && (st = check_index(a->normal_faces, 3 * (int64_t)nf, 0, a->nn, what,
                                        "normal_faces", err)) != DTX_OK)
        return st;
    if (a->material &&
        (st = check_index(a->material, nf, -1, a->nmat, what, "material", err)) != DTX_OK)
        return st;
    for (int32_t i = 0; i < a->nmat; i++)
        if (!a->material_names[i])
            return dtx_seterr(err, DTX_EFORMAT, "%s: material %d has no name", what, (int)i);
    if (a->colors)
        for (int64_t i = 0; i < (int64_t)nv * a->ncolor; i++)
            if (!(a->colors[i] >= 0 && a->colors[i] <= 1))
                return dtx_seterr(err, DTX_ERANGE,
                                  "%s: colour value %lld (0-based) is %g, not in [0, 1]", what,
                                  (long long)i, a->colors[i]);
    return DTX_OK;
}
