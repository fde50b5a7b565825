/*
 * h5remove.c: `dtx rm`'s removal of objects, after checking that nothing
 * left in the file refers to them (h5remove.h).
 */
#include "h5remove.h"

#include "h5inspect.h"
#include "h5layout.h"

#include <hdf5.h>
#include <string.h>

/* Attributes that name another object of the same file by its HDF5 path. */
static const char *const ref_attrs[] = {"rest_mesh", "target_mesh", "source_mesh"};

/* 1 when item path p is removed by removing r (p == r, or p lies under r). */
static int covers(const char *r, const char *p)
{
    size_t n = strlen(r);
    return strncmp(r, p, n) == 0 && (p[n] == '\0' || p[n] == '/');
}

static int removed(const char *const *paths, int n, const char *p)
{
    for (int i = 0; i < n; i++)
        if (covers(paths[i], p))
            return 1;
    return 0;
}

/* Checks that each path is an object (or a /results/TARGET group) of the
 * summary; DTX_EINVAL otherwise. */
static dtx_status check_paths(const char *file, const dtx_h5_summary *s,
                              const char *const *paths, int n, dtx_error *err)
{
    for (int i = 0; i < n; i++) {
        int found = 0;
        for (int j = 0; j < i; j++)
            if (covers(paths[j], paths[i]) || covers(paths[i], paths[j]))
                return dtx_seterr(err, DTX_EINVAL, "%s: %s named twice (or inside %s)", file,
                                  paths[i], paths[j]);
        for (int64_t k = 0; k < s->nitems && !found; k++) {
            const dtx_h5_item *it = &s->items[k];
            if (it->temporary)
                continue;
            if (strcmp(it->path, paths[i]) == 0)
                found = 1;
            /* /results/TARGET: the group of a target's results. */
            else if (it->kind == DTX_H5_KIND_RESULT && covers(paths[i], it->path) &&
                     strncmp(paths[i], "/results/", 9) == 0 && !strchr(paths[i] + 9, '/'))
                found = 1;
        }
        if (!found)
            return dtx_seterr(err, DTX_EINVAL,
                              "%s: %s: no such object (`dtx inspect %s` lists what the file "
                              "holds)",
                              file, paths[i], file);
    }
    return DTX_OK;
}

/* DTX_EFORMAT when an object that stays refers to one that goes. */
static dtx_status check_referrers(const char *file, const dtx_h5_summary *s,
                                  const char *const *paths, int n, dtx_error *err)
{
    for (int64_t k = 0; k < s->nitems; k++) {
        const dtx_h5_item *it = &s->items[k];
        if (it->temporary || removed(paths, n, it->path))
            continue;
        for (size_t a = 0; a < sizeof ref_attrs / sizeof *ref_attrs; a++) {
            const char *v = dtx_h5_attr_find(it->attrs, it->nattrs, ref_attrs[a]);
            if (v && v[0] == '/' && removed(paths, n, v))
                return dtx_seterr(err, DTX_EFORMAT,
                                  "%s: cannot remove %s: %s refers to it (%s); remove both in "
                                  "one command: dtx rm %s %s %s",
                                  file, v, it->path, ref_attrs[a], file, it->path, v);
        }
    }
    return DTX_OK;
}

dtx_status dtx_h5_remove_objects(const char *path, const char *const *paths, int n, dtx_error *err)
{
    dtx_h5_summary s;
    dtx_status st;
    hid_t f = H5I_INVALID_HID;
    if ((st = dtx_h5_inspect(path, &s, err)) != DTX_OK)
        return st;
    st = check_paths(path, &s, paths, n, err);
    if (st == DTX_OK)
        st = check_referrers(path, &s, paths, n, err);
    dtx_h5_summary_free(&s);
    if (st != DTX_OK)
        return st;
    if ((st = dtx_h5_open(path, MPI_COMM_NULL, 1, &f, err)) != DTX_OK)
        return st;
    for (int i = 0; st == DTX_OK && i < n; i++) {
        if (H5Ldelete(f, paths[i], H5P_DEFAULT) < 0) {
            st = dtx_seterr(err, DTX_EIO, "%s: %s: HDF5 could not unlink it", path, paths[i]);
            break;
        }
        /* A /results/TARGET group left without results goes too. */
        if (strncmp(paths[i], "/results/", 9) == 0) {
            char parent[DTX_H5_PATH_MAX];
            const char *slash = strrchr(paths[i], '/');
            H5G_info_t gi;
            if (slash > paths[i] + 8 && (size_t)(slash - paths[i]) < sizeof parent) {
                memcpy(parent, paths[i], (size_t)(slash - paths[i]));
                parent[slash - paths[i]] = '\0';
                if (H5Gget_info_by_name(f, parent, &gi, H5P_DEFAULT) >= 0 && gi.nlinks == 0 &&
                    H5Ldelete(f, parent, H5P_DEFAULT) < 0)
                    st = dtx_seterr(err, DTX_EIO, "%s: %s: HDF5 could not unlink it", path,
                                    parent);
            }
        }
    }
    {
        dtx_error e2;
        if (dtx_h5_close(&f, &e2) != DTX_OK && st == DTX_OK) {
            *err = e2;
            st = e2.code;
        }
    }
    return st;
}
