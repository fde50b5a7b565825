/* h5mesh_attrs.c: an asset mesh's optional attributes in HDF5 (h5mesh_attrs.h). */
#include "h5mesh_attrs.h"

#include "h5layout.h"

#include <stdlib.h>
#include <string.h>

static dtx_status put(hid_t g, const char *where, const char *name, hid_t ftype, hid_t mtype,
                      hsize_t rows, hsize_t cols, const void *data, dtx_error *err)
{
    hsize_t d[2] = {rows, cols};
    hid_t sp = H5Screate_simple(cols ? 2 : 1, d, NULL), ds = H5I_INVALID_HID;
    herr_t rc = -1;
    if (sp >= 0)
        ds = H5Dcreate2(g, name, ftype, sp, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    if (ds >= 0)
        rc = rows ? H5Dwrite(ds, mtype, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) : 0;
    if (ds >= 0)
        H5Dclose(ds);
    if (sp >= 0)
        H5Sclose(sp);
    return rc < 0 ? dtx_seterr(err, DTX_EIO, "%s/%s: cannot write", where, name) : DTX_OK;
}

dtx_status dtx_h5_write_mesh_attrs(hid_t g, const char *where, const dtx_mesh_attrs *a,
                                   int32_t nv, int32_t nf, dtx_error *err)
{
    dtx_status st;
    if (!dtx_mesh_attrs_any(a))
        return DTX_OK;
    if ((st = dtx_mesh_attrs_validate(a, nv, nf, where, err)) != DTX_OK)
        return st;
    if (a->uv &&
        ((st = put(g, where, "uv", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, (hsize_t)a->nuv, 2, a->uv,
                   err)) != DTX_OK ||
         (st = put(g, where, "uv_faces", H5T_STD_I32LE, H5T_NATIVE_INT32, (hsize_t)nf, 3,
                   a->uv_faces, err)) != DTX_OK))
        return st;
    if (a->normals &&
        ((st = put(g, where, "normals", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, (hsize_t)a->nn, 3,
                   a->normals, err)) != DTX_OK ||
         (st = put(g, where, "normal_faces", H5T_STD_I32LE, H5T_NATIVE_INT32, (hsize_t)nf, 3,
                   a->normal_faces, err)) != DTX_OK))
        return st;
    if (a->colors && (st = put(g, where, "colors", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE,
                               (hsize_t)nv, (hsize_t)a->ncolor, a->colors, err)) != DTX_OK)
        return st;
    if (a->material) {
        size_t len = 1;
        char *names;
        for (int32_t m = 0; m < a->nmat; m++)
            len += strlen(a->material_names[m]) + 1;
        if (!(names = malloc(len)))
            return dtx_seterr(err, DTX_ENOMEM, "%s: out of memory", where);
        names[0] = 0;
        for (int32_t m = 0; m < a->nmat; m++) {
            if (m)
                strcat(names, "\n");
            strcat(names, a->material_names[m]);
        }
        st = put(g, where, "material", H5T_STD_I32LE, H5T_NATIVE_INT32, (hsize_t)nf, 0,
                 a->material, err);
        if (st == DTX_OK)
            st = dtx_h5_write_attr_str(g, "material", "material_names", names, err);
        free(names);
        if (st != DTX_OK)
            return st;
    }
    if (a->mtllib && (st = dtx_h5_write_attr_str(g, ".", "mtllib", a->mtllib, err)) != DTX_OK)
        return st;
    return DTX_OK;
}

/* Reads group/name when it exists: rows x cols (cols 0: 1-D), rows given
 * (want_rows >= 0) or read into *rows; *out allocated. */
static dtx_status get(hid_t file, const char *group, const char *name, hid_t mtype,
                      size_t esize, int64_t want_rows, int cols_lo, int cols_hi, int32_t *rows,
                      int32_t *cols, void **out, dtx_error *err)
{
    char path[DTX_H5_PATH_MAX];
    hid_t ds, sp;
    hsize_t d[2] = {0, 0};
    int nd;
    herr_t rc;
    *out = NULL;
    snprintf(path, sizeof path, "%s/%s", group, name);
    if (!dtx_h5_path_exists(file, path))
        return DTX_OK;
    if ((ds = H5Dopen2(file, path, H5P_DEFAULT)) < 0)
        return dtx_seterr(err, DTX_EFORMAT, "%s: cannot open", path);
    sp = H5Dget_space(ds);
    nd = sp >= 0 ? H5Sget_simple_extent_ndims(sp) : -1;
    if (nd >= 1 && nd <= 2)
        H5Sget_simple_extent_dims(sp, d, NULL);
    if (sp >= 0)
        H5Sclose(sp);
    if (nd != (cols_hi ? 2 : 1) || (cols_hi && ((int)d[1] < cols_lo || (int)d[1] > cols_hi)) ||
        (want_rows >= 0 && d[0] != (hsize_t)want_rows) || d[0] > INT32_MAX) {
        H5Dclose(ds);
        return dtx_seterr(err, DTX_EFORMAT,
                          "%s: shape %dD (%llu x %llu) where %s x %s is expected", path, nd,
                          (unsigned long long)d[0], (unsigned long long)d[1],
                          want_rows >= 0 ? "nf or nv" : "n",
                          !cols_hi ? "1" : cols_lo == cols_hi ? (cols_lo == 2 ? "2" : "3")
                                                              : "3 or 4");
    }
    *out = malloc((size_t)(d[0] ? d[0] : 1) * (size_t)(cols_hi ? d[1] : 1) * esize);
    if (!*out) {
        H5Dclose(ds);
        return dtx_seterr(err, DTX_ENOMEM, "%s: out of memory", path);
    }
    rc = d[0] ? H5Dread(ds, mtype, H5S_ALL, H5S_ALL, H5P_DEFAULT, *out) : 0;
    H5Dclose(ds);
    if (rc < 0) {
        free(*out);
        *out = NULL;
        return dtx_seterr(err, DTX_EIO, "%s: cannot read", path);
    }
    if (rows)
        *rows = (int32_t)d[0];
    if (cols)
        *cols = (int32_t)d[1];
    return DTX_OK;
}

dtx_status dtx_h5_read_mesh_attrs(hid_t file, const char *group, int32_t nv, int32_t nf,
                                  dtx_mesh_attrs *a, dtx_error *err)
{
    dtx_status st;
    void *p;
    char *names = NULL;
    memset(a, 0, sizeof *a);
    if ((st = get(file, group, "uv", H5T_NATIVE_DOUBLE, 8, -1, 2, 2, &a->nuv, NULL, &p, err)) ||
        ((a->uv = p), 0) ||
        (st = get(file, group, "uv_faces", H5T_NATIVE_INT32, 4, nf, 3, 3, NULL, NULL, &p, err)) ||
        ((a->uv_faces = p), 0) ||
        (st = get(file, group, "normals", H5T_NATIVE_DOUBLE, 8, -1, 3, 3, &a->nn, NULL, &p,
                  err)) ||
        ((a->normals = p), 0) ||
        (st = get(file, group, "normal_faces", H5T_NATIVE_INT32, 4, nf, 3, 3, NULL, NULL, &p,
                  err)) ||
        ((a->normal_faces = p), 0) ||
        (st = get(file, group, "colors", H5T_NATIVE_DOUBLE, 8, nv, 3, 4, NULL, &a->ncolor, &p,
                  err)) ||
        ((a->colors = p), 0) ||
        (st = get(file, group, "material", H5T_NATIVE_INT32, 4, nf, 0, 0, NULL, NULL, &p, err)) ||
        ((a->material = p), 0))
        goto fail;
    if (a->material) {
        char path[DTX_H5_PATH_MAX];
        snprintf(path, sizeof path, "%s/material", group);
        if ((st = dtx_h5_read_attr_str(file, path, "material_names", &names, err)) != DTX_OK)
            goto fail;
        for (char *q = names; q; q = strchr(q, '\n'), q = q ? q + 1 : NULL)
            a->nmat++;
        if (!(a->material_names = calloc((size_t)a->nmat, sizeof *a->material_names))) {
            st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
            goto fail;
        }
        {
            char *q = names;
            for (int32_t m = 0; m < a->nmat; m++) {
                size_t n = strcspn(q, "\n");
                if (!(a->material_names[m] = malloc(n + 1))) {
                    st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
                    goto fail;
                }
                memcpy(a->material_names[m], q, n);
                a->material_names[m][n] = 0;
                q += n + (q[n] == '\n');
            }
        }
    }
    if (H5Aexists_by_name(file, group, "mtllib", H5P_DEFAULT) > 0 &&
        (st = dtx_h5_read_attr_str(file, group, "mtllib", &a->mtllib, err)) != DTX_OK)
        goto fail;
    if ((st = dtx_mesh_attrs_validate(a, nv, nf, group, err)) != DTX_OK)
        goto fail;
    free(names);
    return DTX_OK;
fail:
    free(names);
    dtx_mesh_attrs_free(a);
    return st;
}

/* Rows of group/name (a dataset), or -1. */
static int64_t rows_of(hid_t file, const char *group, const char *name)
{
    char path[DTX_H5_PATH_MAX];
    hsize_t d[3] = {0, 0, 0};
    hid_t ds, sp;
    int nd = -1;
    snprintf(path, sizeof path, "%s/%s", group, name);
    if (!dtx_h5_path_exists(file, path) || (ds = H5Dopen2(file, path, H5P_DEFAULT)) < 0)
        return -1;
    if ((sp = H5Dget_space(ds)) >= 0) {
        nd = H5Sget_simple_extent_ndims(sp);
        if (nd >= 1 && nd <= 3)
            H5Sget_simple_extent_dims(sp, d, NULL);
        H5Sclose(sp);
    }
    H5Dclose(ds);
    return nd >= 1 && nd <= 3 && d[0] <= INT32_MAX ? (int64_t)d[0] : -1;
}

dtx_status dtx_h5_check_mesh_attrs(hid_t file, const char *group, dtx_error *err)
{
    int64_t nv = rows_of(file, group, "vertices"), nf = rows_of(file, group, "faces");
    dtx_mesh_attrs a;
    dtx_status st;
    if (nv < 0 || nf < 0)
        return dtx_seterr(err, DTX_EFORMAT, "%s: no readable vertices and faces", group);
    st = dtx_h5_read_mesh_attrs(file, group, (int32_t)nv, (int32_t)nf, &a, err);
    dtx_mesh_attrs_free(&a);
    return st;
}
