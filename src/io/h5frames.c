/*
 * h5frames.c: frames, faces and dataset lists from HDF5 files other
 * programs wrote (h5frames.h).
 */
#include "h5frames.h"

#include "file_util.h"
#include "h5guard.h"
#include "h5layout.h"
#include "h5util.h"

#include <errno.h>
#include <fnmatch.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

dtx_status dtx_h5_foreign_open(const char *path, hid_t *file, dtx_error *err)
{
    hid_t fapl;
    htri_t is;
    dtx_status st;
    dtx_h5_init();
    *file = H5I_INVALID_HID;
    if (access(path, R_OK) != 0)
        return dtx_seterr(err, DTX_EIO, "%s: %s", path,
                          errno == ENOENT ? "no such file or directory" : strerror(errno));
    /* H5Fis_hdf5 blocks forever on a FIFO. */
    if ((st = dtx_file_check_regular(path, err)) != DTX_OK)
        return st;
    is = H5Fis_hdf5(path);
    if (is == 0)
        return dtx_seterr(err, DTX_EFORMAT, "%s: not an HDF5 file", path);
    if (is < 0)
        return dtx_seterr(err, DTX_EIO, "%s: cannot read the file", path);
    fapl = H5Pcreate(H5P_FILE_ACCESS);
    if (fapl < 0 || dtx_h5_guard_set_fapl(fapl) < 0) {
        CLOSE_ID(H5Pclose, fapl);
        return dtx_seterr(err, DTX_EIO, "%s: cannot set up file access", path);
    }
    *file = H5Fopen(path, H5F_ACC_RDONLY, fapl);
    H5Pclose(fapl);
    if (*file < 0) {
        *file = H5I_INVALID_HID;
        return dtx_seterr(err, DTX_EIO, "%s: cannot open the HDF5 file", path);
    }
    return DTX_OK;
}

/* ------------------------------------------------------------- positions */

dtx_status dtx_h5_axes_parse(const char *axes, int ndim, int ax[3], dtx_error *err)
{
    static const char letters[3] = {'T', 'V', 'C'};
    ax[0] = ax[1] = ax[2] = -1;
    if ((int)strlen(axes) != ndim)
        return dtx_seterr(err, DTX_EINVAL,
                          "axis order \"%s\" has %d letters but the dataset has %d dimensions",
                          axes, (int)strlen(axes), ndim);
    for (int d = 0; d < ndim; d++) {
        const char *k = memchr(letters, axes[d], sizeof letters);
        if (!k || ax[k - letters] >= 0)
            return dtx_seterr(err, DTX_EINVAL,
                              "axis order \"%s\": use each of T (frames), V (vertices) and C "
                              "(coordinates) once, e.g. TVC or VCT",
                              axes);
        ax[k - letters] = d;
    }
    if (ax[1] < 0 || ax[2] < 0 || (ndim == 3 && ax[0] < 0))
        return dtx_seterr(err, DTX_EINVAL,
                          "axis order \"%s\": V and C (and T for a 3-D dataset) are needed", axes);
    return DTX_OK;
}

/* "(d0 x d1 x d2)" of a shape. */
static void shape_text(const hsize_t *dims, int ndim, char *out, size_t n)
{
    size_t k = 0;
    out[0] = '\0';
    for (int d = 0; d < ndim && k < n; d++)
        k +=
            (size_t)snprintf(out + k, n - k, "%s%llu", d ? " x " : "", (unsigned long long)dims[d]);
}

/* Fails when the dataset's bytes were never all written (HDF5 would read
 * fill values for the rest). */
static dtx_status check_stored(hid_t dset, const char *name, const hsize_t *dims, int ndim,
                               size_t esz, dtx_error *err)
{
    uint64_t need = esz, stored;
    hid_t dcpl;
    int nfilt;
    for (int d = 0; d < ndim; d++) {
        if (dims[d] != 0 && need > UINT64_MAX / dims[d])
            return dtx_seterr(err, DTX_ERANGE, "%s: dimensions overflow 64 bits", name);
        need *= dims[d];
    }
    stored = H5Dget_storage_size(dset);
    dcpl = H5Dget_create_plist(dset);
    nfilt = dcpl >= 0 ? H5Pget_nfilters(dcpl) : -1;
    CLOSE_ID(H5Pclose, dcpl);
    if (nfilt < 0)
        return dtx_seterr(err, DTX_EIO, "%s: cannot inspect the dataset's filters", name);
    if (dtx_h5_short_of_storage(need, stored, nfilt)) {
        char s[128];
        shape_text(dims, ndim, s, sizeof s);
        return dtx_seterr(err, DTX_EFORMAT,
                          "%s: shape %s needs %llu bytes, but only %llu %sbytes are stored: the "
                          "dataset was never fully written",
                          name, s, (unsigned long long)need, (unsigned long long)stored,
                          nfilt > 0 ? "compressed " : "");
    }
    return DTX_OK;
}

/* Opens the dataset at path with its dataspace's dims; DTX_EFORMAT when
 * there is none. */
static dtx_status open_dataset(hid_t file, const char *name, const char *path, hid_t *dset,
                               hsize_t dims[H5S_MAX_RANK], int *ndim, H5T_class_t *cls, size_t *esz,
                               dtx_error *err)
{
    H5O_info_t info;
    hid_t sp, ft;
    char abs[4096];
    *dset = H5I_INVALID_HID;
    /* "walk" is "/walk": paths are taken from the root group. */
    if (path[0] != '/') {
        snprintf(abs, sizeof abs, "/%s", path);
        path = abs;
    }
    if (!dtx_h5_path_exists(file, path))
        return dtx_seterr(err, DTX_EFORMAT, "%s: no such dataset", name);
    if (H5Oget_info_by_name2(file, path, &info, H5O_INFO_BASIC, H5P_DEFAULT) < 0 ||
        info.type != H5O_TYPE_DATASET)
        return dtx_seterr(err, DTX_EFORMAT, "%s: not a dataset (a group?)", name);
    if ((*dset = H5Dopen2(file, path, H5P_DEFAULT)) < 0) {
        *dset = H5I_INVALID_HID;
        return dtx_seterr(err, DTX_EIO, "%s: cannot open the dataset", name);
    }
    sp = H5Dget_space(*dset);
    ft = H5Dget_type(*dset);
    *ndim = sp >= 0 ? H5Sget_simple_extent_dims(sp, dims, NULL) : -1;
    *cls = ft >= 0 ? H5Tget_class(ft) : H5T_NO_CLASS;
    *esz = ft >= 0 ? H5Tget_size(ft) : 0;
    CLOSE_ID(H5Sclose, sp);
    CLOSE_ID(H5Tclose, ft);
    if (*ndim < 0 || *cls == H5T_NO_CLASS) {
        CLOSE_ID(H5Dclose, *dset);
        return dtx_seterr(err, DTX_EIO, "%s: cannot inspect the dataset", name);
    }
    return DTX_OK;
}

dtx_status dtx_h5_frames_open(hid_t file, const char *fname, const char *path, const char *axes,
                              dtx_h5_frames *fr, dtx_error *err)
{
    hsize_t dims[H5S_MAX_RANK];
    H5T_class_t cls;
    size_t esz;
    int ndim;
    dtx_status st;
    char s[128];
    memset(fr, 0, sizeof *fr);
    fr->dset = H5I_INVALID_HID;
    snprintf(fr->name, sizeof fr->name, "%s:%s", fname, path);
    if ((st = open_dataset(file, fr->name, path, &fr->dset, dims, &ndim, &cls, &esz, err)) !=
        DTX_OK)
        return st;
    shape_text(dims, ndim, s, sizeof s);
    if (cls != H5T_FLOAT) {
        st = dtx_seterr(err, DTX_EFORMAT, "%s: expected floating-point positions, found %s values",
                        fr->name, cls == H5T_INTEGER ? "integer" : "non-numeric");
        goto fail;
    }
    if (ndim != 2 && ndim != 3) {
        st = dtx_seterr(err, DTX_EFORMAT,
                        "%s: shape (%s) has %d dimensions; positions need 3 (frames, vertices, "
                        "coordinates in some order, see --axes) or 2 (one frame)",
                        fr->name, s, ndim);
        goto fail;
    }
    if ((st = dtx_h5_axes_parse(axes        ? axes
                                : ndim == 3 ? "TVC"
                                            : "VC",
                                ndim, fr->ax, err)) != DTX_OK) {
        dtx_error_prefix(err, "%s: shape (%s)", fr->name, s);
        goto fail;
    }
    if (dims[fr->ax[2]] != 3) {
        st = dtx_seterr(err, DTX_EFORMAT,
                        "%s: shape (%s) with axis order %s has %llu coordinates per vertex, not 3 "
                        "(is --axes right?)",
                        fr->name, s,
                        axes        ? axes
                        : ndim == 3 ? "TVC"
                                    : "VC",
                        (unsigned long long)dims[fr->ax[2]]);
        goto fail;
    }
    {
        hsize_t t = fr->ax[0] >= 0 ? dims[fr->ax[0]] : 1, v = dims[fr->ax[1]];
        if (t < 1 || v < 1 || t > INT32_MAX || v > INT32_MAX) {
            st = dtx_seterr(err, DTX_EFORMAT,
                            "%s: shape (%s): %llu frames of %llu vertices (each must be 1 .. "
                            "2147483647)",
                            fr->name, s, (unsigned long long)t, (unsigned long long)v);
            goto fail;
        }
        fr->nframes = (int32_t)t;
        fr->nv = (int32_t)v;
    }
    if ((st = check_stored(fr->dset, fr->name, dims, ndim, esz, err)) != DTX_OK)
        goto fail;
    fr->ndim = ndim;
    memcpy(fr->dims, dims, sizeof fr->dims);
    return DTX_OK;
fail:
    dtx_h5_frames_close(fr);
    return st;
}

dtx_status dtx_h5_frames_read(const dtx_h5_frames *fr, int32_t first, int32_t count, double *out,
                              dtx_error *err)
{
    hsize_t start[3] = {0, 0, 0}, cnt[3], stride[3];
    hid_t fs = H5I_INVALID_HID, ms = H5I_INVALID_HID;
    double *tmp = NULL;
    size_t n;
    dtx_status st = DTX_OK;
    if (first < 0 || count < 1 || first > fr->nframes - count)
        return dtx_seterr(err, DTX_EINVAL, "%s: frames %d .. %d asked of %d", fr->name, (int)first,
                          (int)(first + count - 1), (int)fr->nframes);
    memcpy(cnt, fr->dims, sizeof cnt);
    if (fr->ax[0] >= 0) {
        start[fr->ax[0]] = (hsize_t)first;
        cnt[fr->ax[0]] = (hsize_t)count;
    }
    n = (size_t)count * (size_t)fr->nv * 3;
    if (!(tmp = dtx_alloc(n, sizeof *tmp, 0)))
        return dtx_seterr(err, DTX_ENOMEM, "%s: out of memory for %zu values", fr->name, n);
    fs = H5Dget_space(fr->dset);
    ms = H5Screate_simple(fr->ndim, cnt, NULL);
    if (fs < 0 || ms < 0 || H5Sselect_hyperslab(fs, H5S_SELECT_SET, start, NULL, cnt, NULL) < 0 ||
        H5Dread(fr->dset, H5T_NATIVE_DOUBLE, ms, fs, H5P_DEFAULT, tmp) < 0) {
        st = dtx_seterr(err, DTX_EIO, "%s: cannot read frames %d .. %d", fr->name, (int)first,
                        (int)(first + count - 1));
        goto done;
    }
    /* The block in the file's axis order -> (frame, vertex, coordinate):
     * element (t, v, c) sits at sum of index x stride over the axes. */
    stride[fr->ndim - 1] = 1;
    for (int d = fr->ndim - 2; d >= 0; d--)
        stride[d] = stride[d + 1] * cnt[d + 1];
    {
        const hsize_t st_t = fr->ax[0] >= 0 ? stride[fr->ax[0]] : 0, st_v = stride[fr->ax[1]],
                      st_c = stride[fr->ax[2]];
        for (size_t t = 0; t < (size_t)count; t++)
            for (size_t v = 0; v < (size_t)fr->nv; v++)
                for (size_t c = 0; c < 3; c++)
                    out[(t * (size_t)fr->nv + v) * 3 + c] = tmp[t * st_t + v * st_v + c * st_c];
    }
done:
    CLOSE_ID(H5Sclose, ms);
    CLOSE_ID(H5Sclose, fs);
    free(tmp);
    return st;
}

void dtx_h5_frames_close(dtx_h5_frames *fr) { CLOSE_ID(H5Dclose, fr->dset); }

/* ----------------------------------------------------------------- faces */

dtx_status dtx_h5_read_faces(hid_t file, const char *fname, const char *path, int32_t nv,
                             int32_t *nf, int32_t **F, dtx_error *err)
{
    hsize_t dims[H5S_MAX_RANK];
    H5T_class_t cls;
    size_t esz;
    int ndim;
    hid_t dset;
    int64_t *raw = NULL;
    char name[512], s[128];
    dtx_status st;
    *F = NULL;
    *nf = 0;
    snprintf(name, sizeof name, "faces %s:%s", fname, path);
    if ((st = open_dataset(file, name, path, &dset, dims, &ndim, &cls, &esz, err)) != DTX_OK)
        return st;
    shape_text(dims, ndim, s, sizeof s);
    if (cls != H5T_INTEGER)
        st = dtx_seterr(err, DTX_EFORMAT, "%s: expected integer vertex indices, found %s", name,
                        cls == H5T_FLOAT ? "floating-point values" : "non-numeric values");
    else if (ndim != 2 || dims[1] != 3 || dims[0] < 1 || dims[0] > INT32_MAX)
        st = dtx_seterr(err, DTX_EFORMAT,
                        "%s: shape (%s): expected (faces, 3), triangles of 0-based vertex "
                        "indices",
                        name, s);
    else
        st = check_stored(dset, name, dims, ndim, esz, err);
    if (st == DTX_OK && !(raw = dtx_alloc((size_t)dims[0] * 3, sizeof *raw, 0)))
        st = dtx_seterr(err, DTX_ENOMEM, "%s: out of memory", name);
    if (st == DTX_OK && H5Dread(dset, H5T_NATIVE_INT64, H5S_ALL, H5S_ALL, H5P_DEFAULT, raw) < 0)
        st = dtx_seterr(err, DTX_EIO, "%s: cannot read the dataset", name);
    if (st == DTX_OK && !(*F = dtx_alloc((size_t)dims[0] * 3, sizeof **F, 0)))
        st = dtx_seterr(err, DTX_ENOMEM, "%s: out of memory", name);
    for (size_t i = 0; st == DTX_OK && i < (size_t)dims[0] * 3; i++) {
        if (raw[i] < 0 || raw[i] >= nv)
            st = dtx_seterr(err, DTX_EFORMAT,
                            "%s: face %zu (0-based): vertex index %lld out of range [0, %d) "
                            "(indices are 0-based)",
                            name, i / 3, (long long)raw[i], (int)nv);
        else
            (*F)[i] = (int32_t)raw[i];
    }
    free(raw);
    CLOSE_ID(H5Dclose, dset);
    if (st != DTX_OK) {
        free(*F);
        *F = NULL;
        return st;
    }
    *nf = (int32_t)dims[0];
    return DTX_OK;
}

/* -------------------------------------------------------------- listing */

static int cmp_str(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

dtx_status dtx_h5_match_datasets(hid_t file, const char *fname, const char *group,
                                 const char *pattern, char ***paths, int *n, dtx_error *err)
{
    H5O_info_t info;
    dtx_h5_names l;
    char **out = NULL;
    int kept = 0;
    char abs[4096];
    *paths = NULL;
    *n = 0;
    if (group[0] != '/') {
        snprintf(abs, sizeof abs, "/%s", group);
        group = abs;
    }
    if (!dtx_h5_path_exists(file, group) ||
        H5Oget_info_by_name2(file, group, &info, H5O_INFO_BASIC, H5P_DEFAULT) < 0 ||
        info.type != H5O_TYPE_GROUP)
        return dtx_seterr(err, DTX_EFORMAT, "%s:%s: no such group", fname, group);
    if (dtx_h5_list_names(file, group, &l) < 0)
        return dtx_seterr(err, l.oom ? DTX_ENOMEM : DTX_EIO, "%s:%s: cannot list the group", fname,
                          group);
    if (l.n && !(out = calloc(l.n, sizeof *out))) {
        dtx_h5_names_free(&l);
        return dtx_seterr(err, DTX_ENOMEM, "out of memory");
    }
    for (size_t i = 0; i < l.n; i++) {
        size_t len = strlen(group) + strlen(l.names[i]) + 2;
        char *p;
        if (fnmatch(pattern, l.names[i], 0) != 0)
            continue;
        if (!(p = malloc(len))) {
            for (int k = 0; k < kept; k++)
                free(out[k]);
            free(out);
            dtx_h5_names_free(&l);
            return dtx_seterr(err, DTX_ENOMEM, "out of memory");
        }
        snprintf(p, len, "%s%s%s", group, group[strlen(group) - 1] == '/' ? "" : "/", l.names[i]);
        if (H5Oget_info_by_name2(file, p, &info, H5O_INFO_BASIC, H5P_DEFAULT) >= 0 &&
            info.type == H5O_TYPE_DATASET)
            out[kept++] = p;
        else
            free(p);
    }
    dtx_h5_names_free(&l);
    if (kept > 1)
        qsort(out, (size_t)kept, sizeof *out, cmp_str);
    if (!kept) {
        free(out);
        out = NULL;
    }
    *paths = out;
    *n = kept;
    return DTX_OK;
}
