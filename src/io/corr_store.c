/*
 * corr_store.c: the correspondence store (corr_store.h), a directory of
 * files KEY.h5 written aside and renamed into place.
 */
#define _GNU_SOURCE /* gethostname */
#include "corr_store.h"

#include <hdf5.h>

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static int is_key(const char *key)
{
    size_t n = key ? strlen(key) : 0;
    if (n < 1 || n > 64)
        return 0;
    for (size_t i = 0; i < n; i++)
        if (!((key[i] >= '0' && key[i] <= '9') || (key[i] >= 'a' && key[i] <= 'f')))
            return 0;
    return 1;
}

/* The hash of a correspondence's arrays (their bytes as in memory): the
 * store's check that what it reads back is what was written. */
static void content_hash(const int32_t *pairs, int64_t npairs, const double *def, int32_t nv_s,
                         char out[17])
{
    static const char tag[] = "dtx-corr-store-content-v1";
    uint64_t h = dtx_hash_bytes(DTX_HASH_INIT, tag, sizeof tag);
    h = dtx_hash_bytes(h, &npairs, sizeof npairs);
    h = dtx_hash_bytes(h, pairs, (size_t)npairs * 2 * sizeof *pairs);
    if (def) {
        h = dtx_hash_bytes(h, &nv_s, sizeof nv_s);
        h = dtx_hash_bytes(h, def, (size_t)nv_s * 3 * sizeof *def);
    }
    dtx_hash_hex(h, out);
}

dtx_status dtx_corr_store_path(const char *dir, const char *key, char *out, size_t n,
                               dtx_error *err)
{
    int len;
    if (!is_key(key))
        return dtx_seterr(err, DTX_EINVAL, "correspondence store %s: bad key \"%s\"", dir,
                          key ? key : "");
    len = snprintf(out, n, "%s/%s.h5", dir, key);
    if (len < 0 || (size_t)len >= n)
        return dtx_seterr(err, DTX_EINVAL, "correspondence store %s: path too long", dir);
    return DTX_OK;
}

dtx_status dtx_corr_store_read(const char *dir, const char *key, int32_t src_nv, int32_t src_nf,
                               int32_t tgt_nf, int need_deformed, dtx_h5_corr *c, int *found,
                               dtx_error *err)
{
    char path[4400], group[DTX_H5_PATH_MAX], hash[17], *stored = NULL;
    hid_t f = H5I_INVALID_HID;
    struct stat sb;
    dtx_status st;
    memset(c, 0, sizeof *c);
    *found = 0;
    if ((st = dtx_corr_store_path(dir, key, path, sizeof path, err)) != DTX_OK)
        return st;
    if (stat(path, &sb) != 0) {
        if (errno == ENOENT)
            return DTX_OK;
        return dtx_seterr(err, DTX_EIO, "%s: %s", path, strerror(errno));
    }
    *found = 1;
    if (!S_ISREG(sb.st_mode))
        return dtx_seterr(err, DTX_EIO, "%s: not a regular file", path);
    snprintf(group, sizeof group, "/correspondences/%s", key);
    if ((st = dtx_h5_open(path, MPI_COMM_NULL, 0, &f, err)) != DTX_OK)
        return st;
    st = dtx_h5_read_corr(f, group, src_nv, src_nf, tgt_nf, c, err);
    if (st == DTX_OK)
        st = dtx_h5_read_attr_str(f, group, "content_hash", &stored, err);
    dtx_h5_close(&f, NULL);
    if (st != DTX_OK) {
        dtx_h5_corr_free(c);
        return st;
    }
    content_hash(c->pairs, c->npairs, c->deformed_src, c->nv_s, hash);
    if (strcmp(stored, hash) != 0)
        st = dtx_seterr(err, DTX_EFORMAT,
                        "%s: %s: its arrays do not match their content_hash %s (found %s): "
                        "the file is damaged",
                        path, group, stored, hash);
    else if (!c->key || strcmp(c->key, key) != 0)
        st = dtx_seterr(err, DTX_EFORMAT, "%s: %s: attribute key is \"%s\", not the file's %s",
                        path, group, c->key ? c->key : "", key);
    else if (need_deformed && !c->deformed_src)
        st = dtx_seterr(err, DTX_EFORMAT,
                        "%s: %s: no deformed_source (an sp04 correspondence has one)", path, group);
    else if (!need_deformed && c->deformed_src)
        st = dtx_seterr(err, DTX_EFORMAT,
                        "%s: %s: has a deformed_source (a multicomponent correspondence has "
                        "none)",
                        path, group);
    free(stored);
    if (st != DTX_OK)
        dtx_h5_corr_free(c);
    return st;
}

/* fsync of a file or a directory by path (0 on success). */
static int sync_path(const char *path, int dir)
{
    int fd = open(path, (dir ? O_RDONLY | O_DIRECTORY : O_RDONLY) | O_CLOEXEC), rc;
    if (fd < 0)
        return -1;
    rc = fsync(fd);
    close(fd);
    return rc;
}

dtx_status dtx_corr_store_write(const char *dir, const char *key, const int32_t *pairs,
                                int64_t npairs, const double *deformed_src, int32_t nv_s,
                                const dtx_h5_corr_meta *meta, dtx_error *err)
{
    char path[4400], tmp[4600], group[DTX_H5_PATH_MAX], host[64] = "host", hash[17];
    hid_t f = H5I_INVALID_HID;
    dtx_status st;
    if ((st = dtx_corr_store_path(dir, key, path, sizeof path, err)) != DTX_OK)
        return st;
    if (!meta || !meta->key || strcmp(meta->key, key) != 0)
        return dtx_seterr(err, DTX_EINVAL, "%s: the correspondence's key differs from the file's",
                          path);
    /* A name of this host and process alone: jobs on other hosts sharing
     * the directory write their own temporaries. */
    if (gethostname(host, sizeof host) != 0)
        snprintf(host, sizeof host, "host");
    host[sizeof host - 1] = '\0';
    for (char *p = host; *p; p++)
        if (*p == '/')
            *p = '_';
    if (snprintf(tmp, sizeof tmp, "%s/.%s.h5.tmp-%s-%ld", dir, key, host, (long)getpid()) >=
        (int)sizeof tmp)
        return dtx_seterr(err, DTX_EINVAL, "correspondence store %s: path too long", dir);
    snprintf(group, sizeof group, "/correspondences/%s", key);
    content_hash(pairs, npairs, deformed_src, nv_s, hash);
    st = dtx_h5_create(tmp, MPI_COMM_NULL, &f, err);
    if (st == DTX_OK)
        st = dtx_h5_write_corr(f, group, pairs, npairs, deformed_src, nv_s, meta, err);
    if (st == DTX_OK)
        st = dtx_h5_write_attr_str(f, group, "content_hash", hash, err);
    if (f >= 0) {
        dtx_error e2;
        if (dtx_h5_close(&f, &e2) != DTX_OK && st == DTX_OK) {
            *err = e2;
            st = e2.code;
        }
    }
    if (st == DTX_OK && sync_path(tmp, 0) != 0)
        st = dtx_seterr(err, DTX_EIO, "%s: cannot sync: %s", tmp, strerror(errno));
    if (st == DTX_OK && rename(tmp, path) != 0)
        st = dtx_seterr(err, DTX_EIO, "%s: cannot rename to %s: %s", tmp, path, strerror(errno));
    if (st != DTX_OK) {
        remove(tmp);
        return st;
    }
    (void)sync_path(dir, 1); /* the rename is durable; a failure here loses nothing */
    return DTX_OK;
}
