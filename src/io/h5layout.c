/*
 * h5layout.c: reading and writing the dtx HDF5 layout, version 1
 * (schemas/hdf5-layout-v1.md), serially or through MPI-IO.
 *
 * Every function follows one pattern: identifiers start as
 * H5I_INVALID_HID, every HDF5 call is checked, and a single `fail:` /
 * `done:` block closes whatever was opened, in reverse order.  HDF5 errors
 * are turned into sentences naming the file and the HDF5 path; the
 * innermost message of HDF5's error stack is appended in parentheses.
 */
#define _GNU_SOURCE 1 /* fallocate */
#include "h5layout.h"
#include "h5guard.h"
#include "h5mesh_attrs.h"
#include "h5util.h"
#include "file_util.h"
#include "write_reason.h"

#include <errno.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#ifndef DTX_VERSION
#define DTX_VERSION "unknown"
#endif

/* Largest chunk HDF5 accepts is 4 GiB - 1; stay well below it. */
#define CHUNK_MAX_BYTES ((uint64_t)0xFFFFFFFFu - 1024u)
/* Chunk cache: room for one chunk, within these bounds. */
#define CACHE_MIN_BYTES ((size_t)1 << 20)
#define CACHE_MAX_BYTES ((size_t)256 << 20)

/* ======================================================== error messages */

typedef struct {
    char *buf;
    size_t n;
} detail_buf;

static herr_t detail_cb(unsigned n, const H5E_error2_t *e, void *data)
{
    detail_buf *d = data;
    if (n == 0 && e && e->desc && e->desc[0])
        snprintf(d->buf, d->n, "%s", e->desc);
    return 0;
}

/* The innermost (most specific) message on HDF5's error stack, or "". */
static void h5_detail(char *buf, size_t n)
{
    detail_buf d = {buf, n};
    buf[0] = '\0';
    (void)H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD, detail_cb, &d);
}

const char *dtx_h5_filename(hid_t id, char *buf, size_t n)
{
    ssize_t len;
    if (n == 0)
        return buf;
    len = id >= 0 ? H5Fget_name(id, buf, n) : -1;
    if (len <= 0)
        snprintf(buf, n, "?");
    return buf;
}

/* Sets "FILE: PATH: message" (PATH omitted when NULL), with the HDF5 detail
 * appended when h5 != 0.  fname, when NULL, is taken from id.  The HDF5
 * detail is read before any other HDF5 call clears the error stack. */
static dtx_status failv(dtx_error *err, dtx_status code, hid_t id, const char *fname,
                        const char *path, int h5, const char *fmt, va_list ap)
{
    char detail[400] = "", name[400], msg[700];
    int sys = errno;
    if (h5)
        h5_detail(detail, sizeof detail);
    if (!fname)
        fname = dtx_h5_filename(id, name, sizeof name);
    vsnprintf(msg, sizeof msg, fmt, ap);
    /* MPI-IO and HDF5 often lose the reason of a failed write (and errno
     * with it): write_reason.h looks at the errno saved here, the file
     * system's free space and the file-size limit. */
    if (h5 && (strstr(msg, "write") || strstr(msg, "flush") || strstr(msg, "close") ||
               strstr(msg, "creat") || strstr(msg, "extend") || strstr(detail, "write"))) {
        char why[300];
        size_t len = strlen(detail);
        if (dtx_write_reason(fname, sys, why, sizeof why)[0] && !strstr(detail, why))
            snprintf(detail + len, sizeof detail - len, "%ssystem: %s", len ? "; " : "", why);
    }
    return dtx_seterr(err, code, "%s: %s%s%s%s%s%s", fname, path ? path : "", path ? ": " : "",
                      msg, detail[0] ? " (HDF5: " : "", detail, detail[0] ? ")" : "");
}

#if defined(__GNUC__)
#define DTX_PRINTF(a, b) __attribute__((format(printf, a, b)))
#else
#define DTX_PRINTF(a, b)
#endif

/* Bad content: no HDF5 detail. */
static dtx_status DTX_PRINTF(5, 6)
    ferr(dtx_error *err, dtx_status code, hid_t id, const char *path, const char *fmt, ...)
{
    va_list ap;
    dtx_status s;
    va_start(ap, fmt);
    s = failv(err, code, id, NULL, path, 0, fmt, ap);
    va_end(ap);
    return s;
}

/* A failed HDF5 call: DTX_EIO with the HDF5 detail. */
static dtx_status DTX_PRINTF(4, 5)
    h5err(dtx_error *err, hid_t id, const char *path, const char *fmt, ...)
{
    va_list ap;
    dtx_status s;
    va_start(ap, fmt);
    s = failv(err, DTX_EIO, id, NULL, path, 1, fmt, ap);
    va_end(ap);
    return s;
}

/* As h5err, with the file named explicitly (no id yet). */
static dtx_status DTX_PRINTF(5, 6) h5err_name(dtx_error *err, dtx_status code,
                                              const char *fname, int h5, const char *fmt, ...)
{
    va_list ap;
    dtx_status s;
    va_start(ap, fmt);
    s = failv(err, code, H5I_INVALID_HID, fname, NULL, h5, fmt, ap);
    va_end(ap);
    return s;
}

void dtx_h5_init(void)
{
    (void)H5Eset_auto2(H5E_DEFAULT, NULL, NULL);
}

/* ================================================================ hashing */

uint64_t dtx_hash_bytes(uint64_t h, const void *p, size_t n)
{
    const unsigned char *b = p;
    for (size_t i = 0; i < n; i++) {
        h ^= b[i];
        h *= UINT64_C(1099511628211);
    }
    return h;
}

/* Hashes v as its little-endian bytes, whatever the machine's order. */
static uint64_t hash_u64_le(uint64_t h, uint64_t v, int nbytes)
{
    unsigned char b[8];
    for (int k = 0; k < nbytes; k++)
        b[k] = (unsigned char)(v >> (8 * k));
    return dtx_hash_bytes(h, b, (size_t)nbytes);
}

uint64_t dtx_mesh_hash(const dtx_mesh *m)
{
    uint64_t h = DTX_HASH_INIT;
    for (size_t i = 0; i < (size_t)m->nv * 3; i++) {
        uint64_t u;
        memcpy(&u, &m->V[i], sizeof u);
        h = hash_u64_le(h, u, 8);
    }
    for (size_t i = 0; i < (size_t)m->nf * 3; i++)
        h = hash_u64_le(h, (uint64_t)(uint32_t)m->F[i], 4);
    return h;
}

void dtx_hash_hex(uint64_t h, char out[17])
{
    snprintf(out, 17, "%016llx", (unsigned long long)h);
}

/* ============================================================ small tools */

static hid_t vlen_str_type(void)
{
    hid_t t = H5Tcopy(H5T_C_S1);
    if (t < 0)
        return t;
    if (H5Tset_size(t, H5T_VARIABLE) < 0 || H5Tset_cset(t, H5T_CSET_UTF8) < 0) {
        CLOSE_ID(H5Tclose, t);
        return H5I_INVALID_HID;
    }
    return t;
}

/* Appends s to buf[n] (which holds *used characters), truncating. */
static void append(char *buf, size_t n, size_t *used, const char *s)
{
    while (*s && *used + 1 < n)
        buf[(*used)++] = *s++;
    buf[*used] = '\0';
}

/* Joins "loc's name" and a relative object path, for messages only
 * (truncated when too long). */
static const char *obj_path(hid_t loc, const char *obj, char *buf, size_t n)
{
    char base[DTX_H5_PATH_MAX];
    size_t used = 0;
    buf[0] = '\0';
    if (obj && obj[0] == '/') {
        append(buf, n, &used, obj);
        return buf;
    }
    {
        /* H5Iget_name clears HDF5's error stack, which the caller (an
         * argument of h5err) has yet to read: keep it aside meanwhile. */
        hid_t es = H5Eget_current_stack();
        if (H5Iget_name(loc, base, sizeof base) <= 0)
            snprintf(base, sizeof base, "/");
        if (es >= 0)
            (void)H5Eset_current_stack(es);
    }
    append(buf, n, &used, base);
    if (obj && strcmp(obj, ".") != 0 && obj[0] != '\0') {
        if (strcmp(base, "/") != 0)
            append(buf, n, &used, "/");
        append(buf, n, &used, obj);
    }
    return buf;
}

/* Joins group and name into out[n]; 0 on success, -1 if too long. */
static int join_path(const char *group, const char *name, char *out, size_t n)
{
    int len = snprintf(out, n, "%s%s%s", group,
                       group[0] && group[strlen(group) - 1] == '/' ? "" : "/", name);
    return len < 0 || (size_t)len >= n ? -1 : 0;
}

static char *dup_str(const char *s)
{
    size_t n = strlen(s ? s : "");
    char *d = dtx_alloc(n + 1, 1, 0);
    if (d) {
        memcpy(d, s ? s : "", n);
        d[n] = '\0';
    }
    return d;
}

static const char *class_name(H5T_class_t c)
{
    switch (c) {
    case H5T_INTEGER: return "integer";
    case H5T_FLOAT: return "float";
    case H5T_STRING: return "string";
    case H5T_BITFIELD: return "bitfield";
    case H5T_OPAQUE: return "opaque";
    case H5T_COMPOUND: return "compound";
    case H5T_REFERENCE: return "reference";
    case H5T_ENUM: return "enum";
    case H5T_VLEN: return "variable-length sequence";
    case H5T_ARRAY: return "array";
    default: return "unknown";
    }
}

/* "5 x 4" */
static void dims_text(const hsize_t *dims, int rank, char *buf, size_t n)
{
    size_t used = 0;
    buf[0] = '\0';
    if (rank == 0)
        snprintf(buf, n, "a scalar");
    for (int k = 0; k < rank && used < n; k++)
        used += (size_t)snprintf(buf + used, n - used, "%s%llu", k ? " x " : "",
                                 (unsigned long long)dims[k]);
}

/* The communicator of a parallel file, duplicated (caller frees with
 * MPI_Comm_free).  Returns 1 for a parallel file, 0 for a serial one, -1 on
 * error.  COLLECTIVE on a parallel file: both H5Fget_access_plist and
 * H5Pget_fapl_mpio duplicate the communicator (MPI_Comm_dup). */
static int file_comm(hid_t id, MPI_Comm *comm)
{
    hid_t fid = H5I_INVALID_HID, fapl = H5I_INVALID_HID;
    int r = -1;
    *comm = MPI_COMM_NULL;
    fid = H5Iget_file_id(id);
    if (fid < 0)
        goto done;
    fapl = H5Fget_access_plist(fid);
    if (fapl < 0)
        goto done;
    if (H5Pget_driver(fapl) == H5FD_MPIO) {
        MPI_Info info = MPI_INFO_NULL;
        if (H5Pget_fapl_mpio(fapl, comm, &info) < 0)
            goto done;
        if (info != MPI_INFO_NULL)
            MPI_Info_free(&info);
        r = 1;
    } else {
        r = 0;
    }
done:
    CLOSE_ID(H5Pclose, fapl);
    CLOSE_ID(H5Fclose, fid);
    return r;
}

dtx_status dtx_h5_preallocate(hid_t file, dtx_error *err)
{
    char name[4096];
    struct stat sb;
    int fd;
    /* After a flush the file's size is HDF5's end of allocated space (it
     * extends the file to it), early-allocated datasets included. */
    dtx_h5_filename(file, name, sizeof name);
    if (strcmp(name, "?") == 0 || stat(name, &sb) != 0 || sb.st_size <= 0)
        return DTX_OK;
    fd = open(name, O_WRONLY);
    if (fd < 0)
        return DTX_OK; /* only an optimisation */
    /* KEEP_SIZE: blocks are reserved, the size HDF5 sees is unchanged.  A
     * file system without fallocate says so (no slow emulation). */
    if (fallocate(fd, FALLOC_FL_KEEP_SIZE, 0, sb.st_size) != 0 &&
        (errno == ENOSPC || errno == EDQUOT || errno == EFBIG)) {
        int e = errno;
        close(fd);
        return dtx_seterr(err, DTX_EIO, "%s: no room for the output (%.3g GB): %s", name,
                          (double)sb.st_size / 1e9, strerror(e));
    }
    close(fd);
    return DTX_OK;
}

int dtx_h5_is_parallel(hid_t id)
{
    hid_t fid = H5Iget_file_id(id);
    hbool_t atomic = 0;
    int r;
    if (fid < 0)
        return 0;
    /* H5Fget_mpi_atomicity succeeds only on MPI-IO files and is a local
     * call, unlike anything that reads the file access list (which
     * duplicates the communicator, collectively): reading ranks may call
     * this alone. */
    r = H5Fget_mpi_atomicity(fid, &atomic) >= 0;
    CLOSE_ID(H5Fclose, fid);
    return r;
}

/* This process's rank among the processes that opened the file (0 for
 * serial files).  Local: uses the MPI file handle's group. */
static int file_rank(hid_t id)
{
    hid_t fid;
    MPI_File *fh = NULL;
    int rank = 0;
    if (!dtx_h5_is_parallel(id))
        return 0;
    fid = H5Iget_file_id(id);
    if (fid < 0)
        return 0;
    if (H5Fget_vfd_handle(fid, H5P_DEFAULT, (void **)&fh) >= 0 && fh) {
        MPI_Group g;
        if (MPI_File_get_group(*fh, &g) == MPI_SUCCESS) {
            MPI_Group_rank(g, &rank);
            MPI_Group_free(&g);
        }
    }
    CLOSE_ID(H5Fclose, fid);
    return rank;
}

/* A transfer property list: collective MPI-IO when asked on a parallel
 * file, else H5P_DEFAULT.  Close with close_dxpl. */
static hid_t make_dxpl(int parallel, int collective)
{
    hid_t dxpl;
    if (!parallel || !collective)
        return H5P_DEFAULT;
    dxpl = H5Pcreate(H5P_DATASET_XFER);
    if (dxpl < 0)
        return dxpl;
    if (H5Pset_dxpl_mpio(dxpl, H5FD_MPIO_COLLECTIVE) < 0) {
        CLOSE_ID(H5Pclose, dxpl);
        return H5I_INVALID_HID;
    }
    return dxpl;
}

static void close_dxpl(hid_t dxpl)
{
    if (dxpl >= 0 && dxpl != H5P_DEFAULT)
        CLOSE_ID(H5Pclose, dxpl);
}

/* ================================================================== files */

static hid_t make_fapl(MPI_Comm comm)
{
    hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
    if (fapl < 0)
        return fapl;
    if (comm != MPI_COMM_NULL && H5Pset_fapl_mpio(fapl, comm, MPI_INFO_NULL) < 0) {
        CLOSE_ID(H5Pclose, fapl);
        return H5I_INVALID_HID;
    }
    /* Serial files: sec2's I/O, with corrupt global heaps refused before
     * HDF5 loops over them (h5guard.h). */
    if (comm == MPI_COMM_NULL && dtx_h5_guard_set_fapl(fapl) < 0) {
        CLOSE_ID(H5Pclose, fapl);
        return H5I_INVALID_HID;
    }
    return fapl;
}

static dtx_status check_comm(const char *path, MPI_Comm comm, dtx_error *err)
{
    int init = 0;
    if (comm == MPI_COMM_NULL)
        return DTX_OK;
    MPI_Initialized(&init);
    if (!init)
        return h5err_name(err, DTX_EINVAL, path, 0,
                          "parallel access asked for, but MPI is not initialised");
    return DTX_OK;
}

dtx_status dtx_h5_create(const char *path, MPI_Comm comm, hid_t *file, dtx_error *err)
{
    hid_t fapl = H5I_INVALID_HID, f = H5I_INVALID_HID;
    dtx_status st;
    dtx_h5_init();
    *file = H5I_INVALID_HID;
    if ((st = check_comm(path, comm, err)) != DTX_OK)
        return st;
    fapl = make_fapl(comm);
    if (fapl < 0) {
        st = h5err_name(err, DTX_EIO, path, 1, "cannot set up file access");
        goto fail;
    }
    f = H5Fcreate(path, H5F_ACC_TRUNC, H5P_DEFAULT, fapl);
    if (f < 0) {
        st = h5err_name(err, DTX_EIO, path, 1, "cannot create the file");
        goto fail;
    }
    if ((st = dtx_h5_write_attr_str(f, ".", "format", DTX_H5_FORMAT, err)) != DTX_OK ||
        (st = dtx_h5_write_attr_int(f, ".", "format_version", DTX_H5_FORMAT_VERSION, err)) !=
            DTX_OK ||
        (st = dtx_h5_write_attr_str(f, ".", "created_by", "dtx " DTX_VERSION, err)) != DTX_OK)
        goto fail;
    CLOSE_ID(H5Pclose, fapl);
    *file = f;
    return DTX_OK;
fail:
    CLOSE_ID(H5Fclose, f);
    CLOSE_ID(H5Pclose, fapl);
    return st;
}

dtx_status dtx_h5_open(const char *path, MPI_Comm comm, int writable, hid_t *file,
                       dtx_error *err)
{
    hid_t fapl = H5I_INVALID_HID, f = H5I_INVALID_HID;
    dtx_status st;
    htri_t is;
    char *format = NULL;
    int64_t version = 0;
    dtx_h5_init();
    *file = H5I_INVALID_HID;
    if ((st = check_comm(path, comm, err)) != DTX_OK)
        return st;
    if (access(path, writable ? R_OK | W_OK : R_OK) != 0)
        return h5err_name(err, DTX_EIO, path, 0, "cannot open: %s", strerror(errno));
    /* H5Fis_hdf5 and H5Fopen block forever on a FIFO: refuse anything but a
     * regular file first. */
    if ((st = dtx_file_check_regular(path, err)) != DTX_OK)
        return st;
    is = H5Fis_hdf5(path);
    if (is == 0)
        return h5err_name(err, DTX_EFORMAT, path, 0, "not an HDF5 file");
    if (is < 0)
        return h5err_name(err, DTX_EIO, path, 1, "cannot read the file");
    fapl = make_fapl(comm);
    if (fapl < 0) {
        st = h5err_name(err, DTX_EIO, path, 1, "cannot set up file access");
        goto fail;
    }
    f = H5Fopen(path, writable ? H5F_ACC_RDWR : H5F_ACC_RDONLY, fapl);
    if (f < 0) {
        st = h5err_name(err, DTX_EIO, path, 1, "cannot open the HDF5 file");
        goto fail;
    }
    /* ------------------------------------------------ format identity */
    is = H5Aexists_by_name(f, ".", "format", H5P_DEFAULT);
    if (is <= 0) {
        st = h5err_name(err, DTX_EFORMAT, path, 0,
                        "not a dtx file: the root group has no attribute 'format' "
                        "(expected format = \"dtx\")");
        goto fail;
    }
    if ((st = dtx_h5_read_attr_str(f, ".", "format", &format, err)) != DTX_OK)
        goto fail;
    if (strcmp(format, DTX_H5_FORMAT) != 0) {
        st = h5err_name(err, DTX_EFORMAT, path, 0,
                        "not a dtx file: root attribute format is \"%.100s\", expected \"dtx\"",
                        format);
        goto fail;
    }
    if (H5Aexists_by_name(f, ".", "format_version", H5P_DEFAULT) <= 0) {
        st = h5err_name(err, DTX_EFORMAT, path, 0,
                        "the root group has no attribute 'format_version'");
        goto fail;
    }
    if ((st = dtx_h5_read_attr_int(f, ".", "format_version", &version, err)) != DTX_OK)
        goto fail;
    if (version != DTX_H5_FORMAT_VERSION) {
        st = h5err_name(err, DTX_EFORMAT, path, 0,
                        "format_version is %lld, but this dtx reads version %d only",
                        (long long)version, DTX_H5_FORMAT_VERSION);
        goto fail;
    }
    free(format);
    CLOSE_ID(H5Pclose, fapl);
    *file = f;
    return DTX_OK;
fail:
    free(format);
    CLOSE_ID(H5Fclose, f);
    CLOSE_ID(H5Pclose, fapl);
    return st;
}

dtx_status dtx_h5_close(hid_t *file, dtx_error *err)
{
    char name[400];
    if (*file < 0)
        return DTX_OK;
    dtx_h5_filename(*file, name, sizeof name);
    if (H5Fclose(*file) < 0) {
        *file = H5I_INVALID_HID;
        return h5err_name(err, DTX_EIO, name, 1, "cannot close the file");
    }
    *file = H5I_INVALID_HID;
    return DTX_OK;
}

dtx_status dtx_h5_flush(hid_t file, dtx_error *err)
{
    if (H5Fflush(file, H5F_SCOPE_GLOBAL) < 0)
        return h5err(err, file, NULL, "cannot flush the file");
    return DTX_OK;
}

/* ======================================================= paths and groups */

/* 1 when every link on path exists (the last one not necessarily
 * resolving), 0 when one is missing. */
static int link_exists(hid_t file, const char *path)
{
    char buf[DTX_H5_PATH_MAX];
    size_t n = strlen(path);
    if (n == 0 || n >= sizeof buf || path[0] != '/')
        return 0;
    if (n == 1)
        return 1;
    memcpy(buf, path, n + 1);
    for (size_t i = 1; i <= n; i++) {
        if (buf[i] == '/' || buf[i] == '\0') {
            char c = buf[i];
            htri_t e;
            if (i > 1 && buf[i - 1] == '/')
                return 0; /* "//" */
            buf[i] = '\0';
            e = H5Lexists(file, buf, H5P_DEFAULT);
            buf[i] = c;
            if (e <= 0)
                return 0;
        }
    }
    return 1;
}

int dtx_h5_path_exists(hid_t file, const char *path)
{
    if (!link_exists(file, path))
        return 0;
    if (strcmp(path, "/") == 0)
        return 1;
    return H5Oexists_by_name(file, path, H5P_DEFAULT) > 0;
}

/* H5O type of the object at path (resolving links), or -1. */
static int object_type(hid_t file, const char *path)
{
    H5O_info_t info;
    if (!dtx_h5_path_exists(file, path))
        return -1;
    if (H5Oget_info_by_name2(file, path, &info, H5O_INFO_BASIC, H5P_DEFAULT) < 0)
        return -1;
    return (int)info.type;
}

static hid_t intermediate_lcpl(void)
{
    hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
    if (lcpl < 0)
        return lcpl;
    if (H5Pset_create_intermediate_group(lcpl, 1) < 0 ||
        H5Pset_char_encoding(lcpl, H5T_CSET_UTF8) < 0) {
        CLOSE_ID(H5Pclose, lcpl);
        return H5I_INVALID_HID;
    }
    return lcpl;
}

dtx_status dtx_h5_create_groups(hid_t file, const char *path, dtx_error *err)
{
    hid_t lcpl = H5I_INVALID_HID, g = H5I_INVALID_HID;
    dtx_status st = DTX_OK;
    if (!path || path[0] != '/')
        return ferr(err, DTX_EINVAL, file, path ? path : "(null)",
                    "group paths must be absolute");
    if (dtx_h5_path_exists(file, path)) {
        if (object_type(file, path) != H5O_TYPE_GROUP)
            return ferr(err, DTX_EINVAL, file, path, "exists and is not a group");
        return DTX_OK;
    }
    lcpl = intermediate_lcpl();
    if (lcpl < 0)
        return h5err(err, file, path, "cannot set up group creation");
    g = H5Gcreate2(file, path, lcpl, H5P_DEFAULT, H5P_DEFAULT);
    if (g < 0)
        st = h5err(err, file, path, "cannot create the group");
    CLOSE_ID(H5Gclose, g);
    CLOSE_ID(H5Pclose, lcpl);
    return st;
}

dtx_status dtx_h5_check_name(const char *name, dtx_error *err)
{
    char shown[DTX_H5_NAME_MAX + 1];
    const char *why = NULL;
    size_t len, i;
    if (!name)
        return dtx_seterr(err, DTX_EINVAL, "no object name given");
    len = strlen(name);
    /* The name as printed: control characters would garble the terminal. */
    for (i = 0; i < len && i + 1 < sizeof shown; i++)
        shown[i] = (unsigned char)name[i] < 32 || name[i] == 127 ? '?' : name[i];
    shown[i] = '\0';
    if (len == 0)
        why = "it is empty";
    else if (strchr(name, '/'))
        why = "it contains '/' (a name is one part of an HDF5 path)";
    else if (strcmp(name, ".") == 0 || strcmp(name, "..") == 0)
        why = "HDF5 reads \".\" and \"..\" as the current and the parent group";
    else if (strncmp(name, DTX_H5_RESERVED_PREFIX, strlen(DTX_H5_RESERVED_PREFIX)) == 0)
        why = "names starting with \"" DTX_H5_RESERVED_PREFIX "\" are reserved for dtx's "
              "temporary objects";
    else if (len > DTX_H5_NAME_MAX)
        return dtx_seterr(err, DTX_EINVAL,
                          "\"%.60s...\" cannot name an HDF5 object: it is %zu bytes long, more "
                          "than %d", shown, len, DTX_H5_NAME_MAX);
    else
        for (i = 0; i < len; i++)
            if ((unsigned char)name[i] < 32 || name[i] == 127)
                return dtx_seterr(err, DTX_EINVAL,
                                  "\"%s\" cannot name an HDF5 object: it contains the control "
                                  "character 0x%02x (byte %zu)",
                                  shown, (unsigned)(unsigned char)name[i], i);
    if (why)
        return dtx_seterr(err, DTX_EINVAL, "\"%s\" cannot name an HDF5 object: %s", shown,
                          why);
    return DTX_OK;
}

dtx_status dtx_h5_tmp_path(const char *final, char *tmp, size_t n, dtx_error *err)
{
    const char *slash;
    int len;
    if (!final || final[0] != '/' || final[strlen(final) - 1] == '/')
        return dtx_seterr(err, DTX_EINVAL,
                          "HDF5 object path \"%s\" must be absolute and name an object",
                          final ? final : "(null)");
    slash = strrchr(final, '/');
    len = snprintf(tmp, n, "%.*s/%s%s", (int)(slash - final), final, DTX_H5_TMP_PREFIX,
                   slash + 1);
    if (len < 0 || (size_t)len >= n)
        return dtx_seterr(err, DTX_EINVAL, "HDF5 path \"%.200s...\" is too long", final);
    return DTX_OK;
}

/* The parent of path ("/a/b" -> "/a", "/a" -> "/"). */
static void parent_path(const char *path, char *out, size_t n)
{
    const char *slash = strrchr(path, '/');
    if (!slash || slash == path)
        snprintf(out, n, "/");
    else
        snprintf(out, n, "%.*s", (int)(slash - path), path);
}

dtx_status dtx_h5_remove(hid_t file, const char *path, dtx_error *err)
{
    if (!link_exists(file, path) || strcmp(path, "/") == 0)
        return DTX_OK;
    if (H5Ldelete(file, path, H5P_DEFAULT) < 0)
        return h5err(err, file, path, "cannot remove");
    return DTX_OK;
}

dtx_status dtx_h5_commit_group(hid_t file, const char *tmp, const char *final, int replace,
                               dtx_error *err)
{
    char parent[DTX_H5_PATH_MAX];
    dtx_status st;
    if (!final || final[0] != '/')
        return ferr(err, DTX_EINVAL, file, final ? final : "(null)",
                    "object paths must be absolute");
    if (!dtx_h5_path_exists(file, tmp))
        return ferr(err, DTX_EINVAL, file, tmp, "nothing to commit (no such group)");
    if (link_exists(file, final)) {
        if (!replace)
            return ferr(err, DTX_EINVAL, file, final, "already exists (remove it first: dtx rm)");
        if ((st = dtx_h5_remove(file, final, err)) != DTX_OK)
            return st;
    }
    parent_path(final, parent, sizeof parent);
    if ((st = dtx_h5_create_groups(file, parent, err)) != DTX_OK)
        return st;
    if (H5Lmove(file, tmp, file, final, H5P_DEFAULT, H5P_DEFAULT) < 0)
        return h5err(err, file, final, "cannot move %s here", tmp);
    return DTX_OK;
}

/* Starts writing a new object: refuses an existing final path (unless
 * allow_existing: results replace theirs on commit), removes a stale
 * temporary group, creates the parents and the temporary group.
 * tmp[DTX_H5_PATH_MAX] receives its name, *group its id. */
static dtx_status begin_group(hid_t file, const char *final, int allow_existing, char *tmp,
                              hid_t *group, dtx_error *err)
{
    char parent[DTX_H5_PATH_MAX];
    dtx_status st;
    *group = H5I_INVALID_HID;
    if ((st = dtx_h5_tmp_path(final, tmp, DTX_H5_PATH_MAX, err)) != DTX_OK) {
        dtx_error_prefix(err, "%s", dtx_h5_filename(file, parent, sizeof parent));
        return st;
    }
    /* Every writer comes through here: a name HDF5 would misread, or one
     * that looks like an interrupted writer's leftover, is refused before
     * anything is created. */
    if ((st = dtx_h5_check_name(strrchr(final, '/') + 1, err)) != DTX_OK) {
        dtx_error_prefix(err, "%s: %s", dtx_h5_filename(file, parent, sizeof parent), final);
        return st;
    }
    if (!allow_existing && link_exists(file, final))
        return ferr(err, DTX_EINVAL, file, final, "already exists (remove it first: dtx rm)");
    if ((st = dtx_h5_remove(file, tmp, err)) != DTX_OK)
        return st;
    parent_path(final, parent, sizeof parent);
    if ((st = dtx_h5_create_groups(file, parent, err)) != DTX_OK)
        return st;
    *group = H5Gcreate2(file, tmp, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    if (*group < 0)
        return h5err(err, file, tmp, "cannot create the group");
    return DTX_OK;
}

/* ============================================================= attributes */

static dtx_status write_attr(hid_t loc, const char *obj, const char *name, hid_t ftype,
                             hid_t mtype, const void *buf, dtx_error *err)
{
    hid_t sp = H5I_INVALID_HID, a = H5I_INVALID_HID;
    char where[DTX_H5_PATH_MAX];
    dtx_status st = DTX_OK;
    htri_t e = H5Aexists_by_name(loc, obj, name, H5P_DEFAULT);
    if (e < 0)
        return h5err(err, loc, obj_path(loc, obj, where, sizeof where),
                     "cannot look up attribute %s", name);
    if (e > 0 && H5Adelete_by_name(loc, obj, name, H5P_DEFAULT) < 0)
        return h5err(err, loc, obj_path(loc, obj, where, sizeof where),
                     "cannot replace attribute %s", name);
    sp = H5Screate(H5S_SCALAR);
    if (sp < 0) {
        st = h5err(err, loc, NULL, "cannot create a dataspace");
        goto done;
    }
    a = H5Acreate_by_name(loc, obj, name, ftype, sp, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    if (a < 0 || H5Awrite(a, mtype, buf) < 0)
        st = h5err(err, loc, obj_path(loc, obj, where, sizeof where),
                   "cannot write attribute %s", name);
done:
    CLOSE_ID(H5Aclose, a);
    CLOSE_ID(H5Sclose, sp);
    return st;
}

dtx_status dtx_h5_write_attr_str(hid_t loc, const char *obj, const char *name,
                                 const char *value, dtx_error *err)
{
    hid_t t = vlen_str_type();
    const char *v = value ? value : "";
    dtx_status st;
    if (t < 0)
        return h5err(err, loc, NULL, "cannot create a string type");
    st = write_attr(loc, obj, name, t, t, &v, err);
    CLOSE_ID(H5Tclose, t);
    return st;
}

dtx_status dtx_h5_write_attr_int(hid_t loc, const char *obj, const char *name, int64_t value,
                                 dtx_error *err)
{
    int32_t v = (int32_t)value;
    char where[DTX_H5_PATH_MAX];
    if (value < INT32_MIN || value > INT32_MAX)
        return ferr(err, DTX_ERANGE, loc, obj_path(loc, obj, where, sizeof where),
                    "attribute %s: value %lld does not fit int32", name, (long long)value);
    return write_attr(loc, obj, name, H5T_STD_I32LE, H5T_NATIVE_INT32, &v, err);
}

/* Opens attribute name of obj and checks it holds a single value of class
 * cls.  *a receives it. */
static dtx_status open_attr(hid_t loc, const char *obj, const char *name, H5T_class_t cls,
                            hid_t *a, hid_t *ftype, hid_t *space, dtx_error *err)
{
    char where[DTX_H5_PATH_MAX];
    htri_t e;
    hssize_t npts;
    H5T_class_t c;
    *a = *ftype = *space = H5I_INVALID_HID;
    e = H5Aexists_by_name(loc, obj, name, H5P_DEFAULT);
    if (e < 0)
        return h5err(err, loc, obj_path(loc, obj, where, sizeof where),
                     "cannot look up attribute %s", name);
    if (e == 0)
        return ferr(err, DTX_EFORMAT, loc, obj_path(loc, obj, where, sizeof where),
                    "has no attribute %s", name);
    *a = H5Aopen_by_name(loc, obj, name, H5P_DEFAULT, H5P_DEFAULT);
    if (*a < 0)
        return h5err(err, loc, obj_path(loc, obj, where, sizeof where),
                     "cannot open attribute %s", name);
    *ftype = H5Aget_type(*a);
    *space = H5Aget_space(*a);
    if (*ftype < 0 || *space < 0)
        return h5err(err, loc, obj_path(loc, obj, where, sizeof where),
                     "cannot inspect attribute %s", name);
    c = H5Tget_class(*ftype);
    if (c != cls)
        return ferr(err, DTX_EFORMAT, loc, obj_path(loc, obj, where, sizeof where),
                    "attribute %s: expected a%s %s, found %s", name,
                    cls == H5T_INTEGER ? "n" : "", class_name(cls), class_name(c));
    npts = H5Sget_simple_extent_npoints(*space);
    if (npts != 1)
        return ferr(err, DTX_EFORMAT, loc, obj_path(loc, obj, where, sizeof where),
                    "attribute %s: expected a single value, found %lld", name,
                    (long long)npts);
    return DTX_OK;
}

dtx_status dtx_h5_read_attr_str(hid_t loc, const char *obj, const char *name, char **value,
                                dtx_error *err)
{
    hid_t a, ft, sp, mt = H5I_INVALID_HID;
    char where[DTX_H5_PATH_MAX];
    dtx_status st;
    *value = NULL;
    if ((st = open_attr(loc, obj, name, H5T_STRING, &a, &ft, &sp, err)) != DTX_OK)
        goto done;
    mt = H5Tcopy(ft);
    if (mt < 0) {
        st = h5err(err, loc, NULL, "cannot copy a string type");
        goto done;
    }
    if (H5Tis_variable_str(ft) > 0) {
        char *p = NULL;
        if (H5Aread(a, mt, &p) < 0) {
            st = h5err(err, loc, obj_path(loc, obj, where, sizeof where),
                       "cannot read attribute %s", name);
            goto done;
        }
        *value = dup_str(p);
        (void)H5Dvlen_reclaim(mt, sp, H5P_DEFAULT, &p);
    } else {
        size_t n = H5Tget_size(ft);
        char *buf = dtx_alloc(n + 1, 1, 1);
        if (!buf || n == 0) {
            free(buf);
            st = ferr(err, DTX_ENOMEM, loc, NULL, "out of memory");
            goto done;
        }
        if (H5Aread(a, mt, buf) < 0) {
            free(buf);
            st = h5err(err, loc, obj_path(loc, obj, where, sizeof where),
                       "cannot read attribute %s", name);
            goto done;
        }
        buf[n] = '\0';
        if (H5Tget_strpad(ft) == H5T_STR_SPACEPAD)
            while (n > 0 && buf[n - 1] == ' ')
                buf[--n] = '\0';
        *value = buf;
    }
    if (!*value)
        st = ferr(err, DTX_ENOMEM, loc, NULL, "out of memory");
done:
    CLOSE_ID(H5Tclose, mt);
    CLOSE_ID(H5Sclose, sp);
    CLOSE_ID(H5Tclose, ft);
    CLOSE_ID(H5Aclose, a);
    return st;
}

dtx_status dtx_h5_read_attr_int(hid_t loc, const char *obj, const char *name, int64_t *value,
                                dtx_error *err)
{
    hid_t a, ft, sp;
    char where[DTX_H5_PATH_MAX];
    dtx_status st;
    long long v = 0;
    *value = 0;
    if ((st = open_attr(loc, obj, name, H5T_INTEGER, &a, &ft, &sp, err)) == DTX_OK) {
        if (H5Aread(a, H5T_NATIVE_LLONG, &v) < 0)
            st = h5err(err, loc, obj_path(loc, obj, where, sizeof where),
                       "cannot read attribute %s", name);
        else
            *value = (int64_t)v;
    }
    CLOSE_ID(H5Sclose, sp);
    CLOSE_ID(H5Tclose, ft);
    CLOSE_ID(H5Aclose, a);
    return st;
}

void dtx_h5_free_strings(char ***strs, int64_t n)
{
    if (!strs || !*strs)
        return;
    for (int64_t i = 0; i < n; i++)
        free((*strs)[i]);
    free(*strs);
    *strs = NULL;
}

/* ========================================================= dataset tools */

/* Creates dataset name in group with file type ftype and dims, and writes
 * data (memory type mtype) to all of it when data != NULL and the dataset
 * is not empty.  On a parallel file only rank 0 writes (the dataset is
 * allocated at creation, so an independent write is allowed). */
static dtx_status create_write(hid_t group, const char *name, hid_t ftype, hid_t mtype,
                               int rank, const hsize_t *dims, hid_t dcpl, const void *data,
                               dtx_error *err)
{
    hid_t sp = H5I_INVALID_HID, d = H5I_INVALID_HID;
    dtx_status st = DTX_OK;
    hsize_t npts = 1;
    for (int k = 0; k < rank; k++)
        npts *= dims[k];
    sp = H5Screate_simple(rank, dims, NULL);
    if (sp < 0) {
        st = h5err(err, group, name, "cannot create a dataspace");
        goto done;
    }
    d = H5Dcreate2(group, name, ftype, sp, H5P_DEFAULT, dcpl, H5P_DEFAULT);
    if (d < 0) {
        char where[DTX_H5_PATH_MAX];
        st = h5err(err, group, obj_path(group, name, where, sizeof where),
                   "cannot create the dataset");
        goto done;
    }
    if (data && npts > 0 && file_rank(group) == 0 &&
        H5Dwrite(d, mtype, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) {
        char where[DTX_H5_PATH_MAX];
        st = h5err(err, group, obj_path(group, name, where, sizeof where),
                   "cannot write the dataset");
    }
done:
    CLOSE_ID(H5Dclose, d);
    CLOSE_ID(H5Sclose, sp);
    return st;
}

/* Writes n strings as a 1-D variable-length UTF-8 dataset (NULL -> ""). */
static dtx_status create_write_strings(hid_t group, const char *name, const char *const *s,
                                       int64_t n, dtx_error *err)
{
    hid_t t = H5I_INVALID_HID;
    const char **v = NULL;
    hsize_t dim = (hsize_t)n;
    dtx_status st;
    v = dtx_alloc((size_t)n, sizeof *v, 0);
    if (!v)
        return ferr(err, DTX_ENOMEM, group, name, "out of memory for %lld strings",
                    (long long)n);
    for (int64_t i = 0; i < n; i++)
        v[i] = s && s[i] ? s[i] : "";
    t = vlen_str_type();
    if (t < 0)
        st = h5err(err, group, NULL, "cannot create a string type");
    else
        st = create_write(group, name, t, t, 1, &dim, H5P_DEFAULT, v, err);
    CLOSE_ID(H5Tclose, t);
    free(v);
    return st;
}

/* Opens the dataset path and checks its class (cls, or any when
 * H5T_NO_CLASS), rank and the fixed dimensions (want[k] != 0), that every
 * dimension is at most 2^31-1.  shape describes the expected shape in
 * messages ("nv x 3").  dims receives the dimensions. */
static dtx_status open_checked(hid_t file, const char *path, H5T_class_t cls, int rank,
                               const hsize_t *want, const char *shape, hid_t *dset,
                               hsize_t *dims, dtx_error *err)
{
    hid_t ft = H5I_INVALID_HID, sp = H5I_INVALID_HID;
    dtx_status st = DTX_OK;
    int r;
    hsize_t found[H5S_MAX_RANK];
    char text[200];
    *dset = H5I_INVALID_HID;
    if (!dtx_h5_path_exists(file, path))
        return ferr(err, DTX_EFORMAT, file, path, "missing (no such dataset)");
    if (object_type(file, path) != H5O_TYPE_DATASET)
        return ferr(err, DTX_EFORMAT, file, path, "is not a dataset");
    *dset = H5Dopen2(file, path, H5P_DEFAULT);
    if (*dset < 0)
        return h5err(err, file, path, "cannot open the dataset");
    ft = H5Dget_type(*dset);
    sp = H5Dget_space(*dset);
    if (ft < 0 || sp < 0) {
        st = h5err(err, file, path, "cannot inspect the dataset");
        goto fail;
    }
    if (cls != H5T_NO_CLASS && H5Tget_class(ft) != cls) {
        st = ferr(err, DTX_EFORMAT, file, path, "expected %s values, found %s",
                  class_name(cls), class_name(H5Tget_class(ft)));
        goto fail;
    }
    r = H5Sget_simple_extent_ndims(sp);
    if (r < 0 || H5Sget_simple_extent_dims(sp, found, NULL) < 0) {
        st = h5err(err, file, path, "cannot read the dataset's shape");
        goto fail;
    }
    if (r != rank) {
        st = ferr(err, DTX_EFORMAT, file, path, "expected %d dimension%s %s, found %d", rank,
                  rank == 1 ? "" : "s", shape, r);
        goto fail;
    }
    for (int k = 0; k < rank; k++)
        if (want && want[k] && found[k] != want[k]) {
            dims_text(found, rank, text, sizeof text);
            st = ferr(err, DTX_EFORMAT, file, path, "expected shape %s, found %s", shape, text);
            goto fail;
        }
    for (int k = 0; k < rank; k++)
        if (found[k] > (hsize_t)INT32_MAX) {
            st = ferr(err, DTX_ERANGE, file, path,
                      "dimension %d is %llu, more than the %d dtx supports", k,
                      (unsigned long long)found[k], (int)INT32_MAX);
            goto fail;
        }
    for (int k = 0; k < rank; k++)
        dims[k] = found[k];
    CLOSE_ID(H5Sclose, sp);
    CLOSE_ID(H5Tclose, ft);
    return DTX_OK;
fail:
    CLOSE_ID(H5Sclose, sp);
    CLOSE_ID(H5Tclose, ft);
    CLOSE_ID(H5Dclose, *dset);
    return st;
}

/* Before allocating memory for a whole dataset: checks the bytes stored in
 * the file can hold it (all of them for unfiltered data; at most the best
 * gzip ratio for filtered data).  Catches datasets whose dims were set but
 * whose data was never written, and absurd dims in a small file. */
static dtx_status check_storage(hid_t file, hid_t dset, const char *path, const hsize_t *dims,
                                int rank, dtx_error *err)
{
    hid_t ft = H5I_INVALID_HID, dcpl = H5I_INVALID_HID;
    dtx_status st = DTX_OK;
    uint64_t need, stored;
    size_t esz;
    int nfilt;
    ft = H5Dget_type(dset);
    dcpl = H5Dget_create_plist(dset);
    if (ft < 0 || dcpl < 0) {
        st = h5err(err, file, path, "cannot inspect the dataset");
        goto done;
    }
    /* A variable-length element is stored as a 16-byte heap reference. */
    esz = H5Tis_variable_str(ft) > 0 || H5Tget_class(ft) == H5T_VLEN ? 16 : H5Tget_size(ft);
    need = esz;
    for (int k = 0; k < rank; k++) {
        if (dims[k] != 0 && need > UINT64_MAX / dims[k]) {
            st = ferr(err, DTX_ERANGE, file, path, "dimensions overflow 64 bits");
            goto done;
        }
        need *= dims[k];
    }
    stored = H5Dget_storage_size(dset);
    nfilt = H5Pget_nfilters(dcpl);
    if (nfilt < 0) {
        st = h5err(err, file, path, "cannot inspect the dataset's filters");
        goto done;
    }
    if (dtx_h5_short_of_storage(need, stored, nfilt)) {
        char text[200];
        dims_text(dims, rank, text, sizeof text);
        st = ferr(err, DTX_EFORMAT, file, path,
                  "shape %s needs %llu bytes, but only %llu %sbytes are stored: the dataset "
                  "was never fully written",
                  text, (unsigned long long)need, (unsigned long long)stored,
                  nfilt > 0 ? "compressed " : "");
    }
done:
    CLOSE_ID(H5Pclose, dcpl);
    CLOSE_ID(H5Tclose, ft);
    return st;
}

/* Reads a 1-D string dataset of n entries into *out (n malloc'ed strings). */
static dtx_status read_strings(hid_t file, hid_t dset, const char *path, int64_t n,
                               char ***out, dtx_error *err)
{
    hid_t ft = H5I_INVALID_HID, mt = H5I_INVALID_HID, sp = H5I_INVALID_HID;
    char **s = NULL;
    char *raw = NULL;
    dtx_status st = DTX_OK;
    *out = NULL;
    ft = H5Dget_type(dset);
    sp = H5Dget_space(dset);
    mt = ft >= 0 ? H5Tcopy(ft) : H5I_INVALID_HID;
    if (mt < 0 || sp < 0) {
        st = h5err(err, file, path, "cannot inspect the dataset");
        goto done;
    }
    s = dtx_alloc((size_t)n, sizeof *s, 1);
    if (!s) {
        st = ferr(err, DTX_ENOMEM, file, path, "out of memory for %lld strings", (long long)n);
        goto done;
    }
    if (n == 0)
        goto done;
    if (H5Tis_variable_str(ft) > 0) {
        char **p = dtx_alloc((size_t)n, sizeof *p, 1);
        if (!p) {
            st = ferr(err, DTX_ENOMEM, file, path, "out of memory");
            goto done;
        }
        if (H5Dread(dset, mt, H5S_ALL, H5S_ALL, H5P_DEFAULT, p) < 0) {
            free(p);
            st = h5err(err, file, path, "cannot read the strings");
            goto done;
        }
        for (int64_t i = 0; i < n && st == DTX_OK; i++)
            if (!(s[i] = dup_str(p[i])))
                st = ferr(err, DTX_ENOMEM, file, path, "out of memory");
        (void)H5Dvlen_reclaim(mt, sp, H5P_DEFAULT, p);
        free(p);
    } else {
        size_t w = H5Tget_size(ft);
        raw = dtx_alloc((size_t)n, w, 0);
        if (!raw || w == 0) {
            st = ferr(err, DTX_ENOMEM, file, path, "out of memory");
            goto done;
        }
        if (H5Dread(dset, mt, H5S_ALL, H5S_ALL, H5P_DEFAULT, raw) < 0) {
            st = h5err(err, file, path, "cannot read the strings");
            goto done;
        }
        for (int64_t i = 0; i < n && st == DTX_OK; i++) {
            const char *e = raw + (size_t)i * w;
            size_t len = 0;
            while (len < w && e[len])
                len++;
            if (H5Tget_strpad(ft) == H5T_STR_SPACEPAD)
                while (len > 0 && e[len - 1] == ' ')
                    len--;
            s[i] = dtx_alloc(len + 1, 1, 0);
            if (!s[i]) {
                st = ferr(err, DTX_ENOMEM, file, path, "out of memory");
                break;
            }
            memcpy(s[i], e, len);
            s[i][len] = '\0';
        }
    }
done:
    free(raw);
    if (st != DTX_OK)
        dtx_h5_free_strings(&s, n);
    *out = s;
    CLOSE_ID(H5Sclose, sp);
    CLOSE_ID(H5Tclose, mt);
    CLOSE_ID(H5Tclose, ft);
    return st;
}

/* Reads a whole 1-D or 2-D numeric dataset (already shape-checked) after
 * the storage check: *out gets a malloc'ed array of npts elements of size
 * esz (memory type mtype). */
/* Reads an integer dataset (rank 1 or 2) into int32 without HDF5's silent
 * clamping: a value written by another program as int64 or uint32 that
 * does not fit in 32 bits (2^32 + 3 would become 2147483647) is reported
 * with its row (called noun) and its real value.  Wide types are read in
 * blocks of rows, so no second copy of the whole dataset is made. */
static dtx_status read_int32_exact(hid_t file, hid_t dset, const char *path,
                                   const hsize_t *dims, int rank, const char *noun, int32_t *out,
                                   dtx_error *err)
{
    enum { BLOCK_ROWS = 65536 };
    hid_t ft = H5Dget_type(dset), fs = H5I_INVALID_HID, ms = H5I_INVALID_HID;
    hsize_t cols = rank == 2 ? dims[1] : 1, start[2] = {0, 0}, count[2] = {0, cols};
    size_t size = ft >= 0 ? H5Tget_size(ft) : 0;
    int is_unsigned =
        ft >= 0 && H5Tget_class(ft) == H5T_INTEGER && H5Tget_sign(ft) == H5T_SGN_NONE;
    dtx_status st = DTX_OK;
    int64_t *buf = NULL;
    CLOSE_ID(H5Tclose, ft);
    if (size == 0)
        return h5err(err, file, path, "cannot inspect the dataset");
    if (size < 4 || (size == 4 && !is_unsigned)) {
        if (H5Dread(dset, H5T_NATIVE_INT32, H5S_ALL, H5S_ALL, H5P_DEFAULT, out) < 0)
            return h5err(err, file, path, "cannot read the dataset");
        return DTX_OK;
    }
    buf = dtx_alloc(BLOCK_ROWS, (size_t)cols * sizeof *buf, 0);
    fs = H5Dget_space(dset);
    if (!buf || fs < 0) {
        st = buf ? h5err(err, file, path, "cannot read the dataset")
                 : ferr(err, DTX_ENOMEM, file, path, "out of memory");
        goto done;
    }
    for (hsize_t r0 = 0; r0 < dims[0]; r0 += BLOCK_ROWS) {
        start[0] = r0;
        count[0] = dims[0] - r0 < BLOCK_ROWS ? dims[0] - r0 : BLOCK_ROWS;
        ms = H5Screate_simple(rank, count, NULL);
        if (ms < 0 || H5Sselect_hyperslab(fs, H5S_SELECT_SET, start, NULL, count, NULL) < 0 ||
            H5Dread(dset, is_unsigned ? H5T_NATIVE_UINT64 : H5T_NATIVE_INT64, ms, fs,
                    H5P_DEFAULT, buf) < 0) {
            st = h5err(err, file, path, "cannot read the dataset");
            goto done;
        }
        CLOSE_ID(H5Sclose, ms);
        for (size_t i = 0; i < (size_t)(count[0] * cols); i++) {
            uint64_t u = (uint64_t)buf[i];
            int bad = is_unsigned ? u > (uint64_t)INT32_MAX
                                  : buf[i] < INT32_MIN || buf[i] > INT32_MAX;
            if (bad) {
                st = ferr(err, DTX_ERANGE, file, path,
                          "%s %llu (0-based) holds %s%llu, which does not fit in the 32-bit "
                          "indices dtx reads",
                          noun, (unsigned long long)(r0 + i / cols),
                          !is_unsigned && buf[i] < 0 ? "-" : "",
                          (unsigned long long)(!is_unsigned && buf[i] < 0 ? 0 - u : u));
                goto done;
            }
            out[r0 * cols + i] = (int32_t)buf[i];
        }
    }
done:
    CLOSE_ID(H5Sclose, ms);
    CLOSE_ID(H5Sclose, fs);
    free(buf);
    return st;
}

static dtx_status read_whole(hid_t file, hid_t dset, const char *path, const hsize_t *dims,
                             int rank, hid_t mtype, size_t esz, void **out, dtx_error *err)
{
    size_t npts = 1;
    dtx_status st;
    *out = NULL;
    if ((st = check_storage(file, dset, path, dims, rank, err)) != DTX_OK)
        return st;
    for (int k = 0; k < rank; k++)
        npts *= (size_t)dims[k];
    *out = dtx_alloc(npts, esz, 0);
    if (!*out)
        return ferr(err, DTX_ENOMEM, file, path, "out of memory for %zu values", npts);
    if (npts > 0 && mtype == H5T_NATIVE_INT32) {
        if ((st = read_int32_exact(file, dset, path, dims, rank, "row", *out, err)) != DTX_OK) {
            free(*out);
            *out = NULL;
        }
        return st;
    }
    if (npts > 0 && H5Dread(dset, mtype, H5S_ALL, H5S_ALL, H5P_DEFAULT, *out) < 0) {
        free(*out);
        *out = NULL;
        return h5err(err, file, path, "cannot read the dataset");
    }
    return DTX_OK;
}

/* ================================================================= meshes */

dtx_status dtx_h5_write_mesh(hid_t file, const char *group, const dtx_mesh *m,
                             const char *source, dtx_error *err)
{
    return dtx_h5_write_mesh_with(file, group, m, NULL, source, err);
}

dtx_status dtx_h5_write_mesh_with(hid_t file, const char *group, const dtx_mesh *m,
                                  const dtx_mesh_attrs *attrs, const char *source,
                                  dtx_error *err)
{
    char tmp[DTX_H5_PATH_MAX], hex[17];
    hid_t g = H5I_INVALID_HID;
    hsize_t vd[2] = {(hsize_t)m->nv, 3}, fd[2] = {(hsize_t)m->nf, 3};
    dtx_status st;
    if (m->nv < 0 || m->nf < 0)
        return ferr(err, DTX_EINVAL, file, group, "negative mesh size");
    if ((st = begin_group(file, group, 0, tmp, &g, err)) != DTX_OK)
        goto done;
    dtx_hash_hex(dtx_mesh_hash(m), hex);
    if ((st = create_write(g, "vertices", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 2, vd,
                           H5P_DEFAULT, m->V, err)) != DTX_OK ||
        (st = create_write(g, "faces", H5T_STD_I32LE, H5T_NATIVE_INT32, 2, fd, H5P_DEFAULT,
                           m->F, err)) != DTX_OK ||
        (st = dtx_h5_write_attr_str(g, ".", "source", source, err)) != DTX_OK ||
        (st = dtx_h5_write_attr_int(g, ".", "nv", m->nv, err)) != DTX_OK ||
        (st = dtx_h5_write_attr_int(g, ".", "nf", m->nf, err)) != DTX_OK ||
        (st = dtx_h5_write_attr_str(g, ".", "content_hash", hex, err)) != DTX_OK ||
        (st = dtx_h5_write_mesh_attrs(g, group, attrs, m->nv, m->nf, err)) != DTX_OK)
        goto done;
    CLOSE_ID(H5Gclose, g);
    st = dtx_h5_commit_group(file, tmp, group, 0, err);
done:
    CLOSE_ID(H5Gclose, g);
    return st;
}

/* Opens group/vertices and group/faces with their shape checks. */
static dtx_status open_mesh_dsets(hid_t file, const char *group, hid_t *vd, hid_t *fd,
                                  hsize_t *vdims, hsize_t *fdims, char *vpath, char *fpath,
                                  dtx_error *err)
{
    static const hsize_t want[2] = {0, 3};
    dtx_status st;
    *vd = *fd = H5I_INVALID_HID;
    if (join_path(group, "vertices", vpath, DTX_H5_PATH_MAX) ||
        join_path(group, "faces", fpath, DTX_H5_PATH_MAX))
        return ferr(err, DTX_EINVAL, file, group, "path too long");
    if (!dtx_h5_path_exists(file, group))
        return ferr(err, DTX_EFORMAT, file, group, "missing (no such mesh group)");
    if ((st = open_checked(file, vpath, H5T_FLOAT, 2, want, "nv x 3", vd, vdims, err)) !=
        DTX_OK)
        return st;
    if ((st = open_checked(file, fpath, H5T_INTEGER, 2, want, "nf x 3", fd, fdims, err)) !=
        DTX_OK) {
        CLOSE_ID(H5Dclose, *vd);
        return st;
    }
    return DTX_OK;
}

dtx_status dtx_h5_mesh_size(hid_t file, const char *group, int32_t *nv, int32_t *nf,
                            dtx_error *err)
{
    hid_t vd, fd;
    hsize_t vdims[2] = {0, 0}, fdims[2] = {0, 0};
    char vpath[DTX_H5_PATH_MAX], fpath[DTX_H5_PATH_MAX];
    dtx_status st = open_mesh_dsets(file, group, &vd, &fd, vdims, fdims, vpath, fpath, err);
    if (st != DTX_OK)
        return st;
    *nv = (int32_t)vdims[0];
    *nf = (int32_t)fdims[0];
    CLOSE_ID(H5Dclose, fd);
    CLOSE_ID(H5Dclose, vd);
    return DTX_OK;
}

/* Checks an optional int attribute equals the value found in the data. */
static dtx_status check_count_attr(hid_t file, const char *group, const char *name,
                                   int64_t expect, const char *what, dtx_error *err)
{
    int64_t v;
    dtx_status st;
    if (H5Aexists_by_name(file, group, name, H5P_DEFAULT) <= 0)
        return DTX_OK;
    if ((st = dtx_h5_read_attr_int(file, group, name, &v, err)) != DTX_OK)
        return st;
    if (v != expect)
        return ferr(err, DTX_EFORMAT, file, group, "attribute %s is %lld, but %s has %lld",
                    name, (long long)v, what, (long long)expect);
    return DTX_OK;
}

dtx_status dtx_h5_read_mesh(hid_t file, const char *group, dtx_mesh *m, dtx_error *err)
{
    hid_t vd = H5I_INVALID_HID, fd = H5I_INVALID_HID;
    hsize_t vdims[2] = {0, 0}, fdims[2] = {0, 0};
    char vpath[DTX_H5_PATH_MAX], fpath[DTX_H5_PATH_MAX], what[DTX_H5_PATH_MAX + 400];
    char *hash = NULL;
    dtx_status st;
    memset(m, 0, sizeof *m);
    if ((st = open_mesh_dsets(file, group, &vd, &fd, vdims, fdims, vpath, fpath, err)) !=
        DTX_OK)
        return st;
    /* Sizes are checked against the stored bytes before allocating. */
    if ((st = check_storage(file, vd, vpath, vdims, 2, err)) != DTX_OK ||
        (st = check_storage(file, fd, fpath, fdims, 2, err)) != DTX_OK)
        goto fail;
    if ((st = dtx_mesh_alloc(m, (int32_t)vdims[0], (int32_t)fdims[0], err)) != DTX_OK) {
        dtx_error_prefix(err, "%s: %s", dtx_h5_filename(file, what, sizeof what), group);
        goto fail;
    }
    if (m->nv > 0 && H5Dread(vd, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, m->V) < 0) {
        st = h5err(err, file, vpath, "cannot read the vertices");
        goto fail;
    }
    if (m->nf > 0 &&
        (st = read_int32_exact(file, fd, fpath, fdims, 2, "face", m->F, err)) != DTX_OK)
        goto fail;
    if ((st = check_count_attr(file, group, "nv", m->nv, "vertices", err)) != DTX_OK ||
        (st = check_count_attr(file, group, "nf", m->nf, "faces", err)) != DTX_OK)
        goto fail;
    if (H5Aexists_by_name(file, group, "content_hash", H5P_DEFAULT) > 0) {
        char hex[17];
        if ((st = dtx_h5_read_attr_str(file, group, "content_hash", &hash, err)) != DTX_OK)
            goto fail;
        dtx_hash_hex(dtx_mesh_hash(m), hex);
        if (strcmp(hex, hash) != 0) {
            st = ferr(err, DTX_EFORMAT, file, group,
                      "content_hash is \"%.40s\" but the data hashes to %s (was the mesh "
                      "edited without updating or deleting content_hash?)",
                      hash, hex);
            goto fail;
        }
    }
    snprintf(what, sizeof what, "%s: %s", dtx_h5_filename(file, vpath, sizeof vpath), group);
    if ((st = dtx_mesh_validate(m, what, err)) != DTX_OK)
        goto fail;
    free(hash);
    CLOSE_ID(H5Dclose, fd);
    CLOSE_ID(H5Dclose, vd);
    return DTX_OK;
fail:
    free(hash);
    dtx_mesh_free(m);
    CLOSE_ID(H5Dclose, fd);
    CLOSE_ID(H5Dclose, vd);
    return st;
}

/* ====================================================== frame datasets */

/* Frames per chunk: the caller's choice (0 = default) clamped to [1, T] and
 * to the chunk size limit.  Returns 0 when one frame is already too big. */
static int pick_chunk_frames(int want, int64_t nframes, int32_t nv, int f64)
{
    uint64_t frame_bytes = (uint64_t)nv * 3u * (f64 ? 8u : 4u);
    int64_t cf = want > 0 ? want : DTX_H5_DEFAULT_CHUNK_FRAMES;
    if (frame_bytes == 0 || frame_bytes > CHUNK_MAX_BYTES)
        return 0;
    if (cf > nframes)
        cf = nframes;
    if ((uint64_t)cf > CHUNK_MAX_BYTES / frame_bytes)
        cf = (int64_t)(CHUNK_MAX_BYTES / frame_bytes);
    return cf < 1 ? 1 : (int)cf;
}

/* A dataset access list whose chunk cache holds one chunk of chunk_bytes. */
static hid_t chunk_cache_dapl(uint64_t chunk_bytes)
{
    hid_t dapl = H5Pcreate(H5P_DATASET_ACCESS);
    size_t nbytes = CACHE_MIN_BYTES;
    if (dapl < 0)
        return dapl;
    if (chunk_bytes + 4096 > nbytes)
        nbytes = chunk_bytes + 4096 > CACHE_MAX_BYTES ? CACHE_MAX_BYTES
                                                      : (size_t)chunk_bytes + 4096;
    if (H5Pset_chunk_cache(dapl, 521, nbytes, 1.0) < 0) {
        CLOSE_ID(H5Pclose, dapl);
        return H5I_INVALID_HID;
    }
    return dapl;
}

/* Creates a T x nv x 3 positions dataset in group. */
static dtx_status create_positions(hid_t group, int parallel, int64_t nframes, int32_t nv,
                                   int f64, int chunk_frames, int gzip, hid_t *dset,
                                   dtx_error *err)
{
    hid_t sp = H5I_INVALID_HID, dcpl = H5I_INVALID_HID, dapl = H5I_INVALID_HID;
    hsize_t dims[3] = {(hsize_t)nframes, (hsize_t)nv, 3};
    hsize_t chunk[3] = {(hsize_t)chunk_frames, (hsize_t)nv, 3};
    char where[DTX_H5_PATH_MAX];
    dtx_status st = DTX_OK;
    *dset = H5I_INVALID_HID;
    obj_path(group, "positions", where, sizeof where);
    sp = H5Screate_simple(3, dims, NULL);
    dcpl = H5Pcreate(H5P_DATASET_CREATE);
    dapl = chunk_cache_dapl((uint64_t)chunk_frames * (uint64_t)nv * 3u * (f64 ? 8u : 4u));
    if (sp < 0 || dcpl < 0 || dapl < 0 || H5Pset_chunk(dcpl, 3, chunk) < 0 ||
        /* Frames are always written before they are read; filling them
         * first would double the I/O of a parallel run. */
        H5Pset_fill_time(dcpl, H5D_FILL_TIME_NEVER) < 0 ||
        (parallel && H5Pset_alloc_time(dcpl, H5D_ALLOC_TIME_EARLY) < 0)) {
        st = h5err(err, group, where, "cannot set up the dataset");
        goto done;
    }
    if (gzip) {
        if (H5Zfilter_avail(H5Z_FILTER_DEFLATE) <= 0) {
            st = ferr(err, DTX_EIO, group, where, "this HDF5 has no gzip filter");
            goto done;
        }
        if (H5Pset_shuffle(dcpl) < 0 || H5Pset_deflate(dcpl, 4) < 0) {
            st = h5err(err, group, where, "cannot set up compression");
            goto done;
        }
    }
    *dset = H5Dcreate2(group, "positions", f64 ? H5T_IEEE_F64LE : H5T_IEEE_F32LE, sp,
                       H5P_DEFAULT, dcpl, dapl);
    if (*dset < 0)
        st = h5err(err, group, where, "cannot create the dataset");
done:
    CLOSE_ID(H5Pclose, dapl);
    CLOSE_ID(H5Pclose, dcpl);
    CLOSE_ID(H5Sclose, sp);
    return st;
}

/* Opens group/positions (float, T x nv x 3) with a chunk cache that holds
 * one chunk; fills nframes, nv, is_f64, chunk_frames. */
static dtx_status open_positions(hid_t file, const char *group, hid_t *dset, int64_t *nframes,
                                 int32_t *nv, int *is_f64, int *chunk_frames, dtx_error *err)
{
    static const hsize_t want[3] = {0, 0, 3};
    hid_t probe = H5I_INVALID_HID, dcpl = H5I_INVALID_HID, ft = H5I_INVALID_HID;
    hid_t dapl = H5I_INVALID_HID;
    hsize_t dims[3], chunk[3] = {0, 0, 0};
    char path[DTX_H5_PATH_MAX];
    dtx_status st;
    size_t esz;
    *dset = H5I_INVALID_HID;
    if (join_path(group, "positions", path, sizeof path))
        return ferr(err, DTX_EINVAL, file, group, "path too long");
    if ((st = open_checked(file, path, H5T_FLOAT, 3, want, "T x nv x 3", &probe, dims, err)) !=
        DTX_OK)
        return st;
    ft = H5Dget_type(probe);
    dcpl = H5Dget_create_plist(probe);
    if (ft < 0 || dcpl < 0) {
        st = h5err(err, file, path, "cannot inspect the dataset");
        goto done;
    }
    esz = H5Tget_size(ft);
    if (esz != 4 && esz != 8) {
        st = ferr(err, DTX_EFORMAT, file, path, "expected float32 or float64, found %zu-byte "
                  "floats", esz);
        goto done;
    }
    if (H5Pget_layout(dcpl) == H5D_CHUNKED && H5Pget_chunk(dcpl, 3, chunk) < 0) {
        st = h5err(err, file, path, "cannot read the chunk shape");
        goto done;
    }
    /* Reopen with a chunk cache sized for this dataset. */
    dapl = chunk_cache_dapl((uint64_t)chunk[0] * chunk[1] * chunk[2] * esz);
    if (dapl < 0 || (*dset = H5Dopen2(file, path, dapl)) < 0) {
        st = h5err(err, file, path, "cannot open the dataset");
        goto done;
    }
    *nframes = (int64_t)dims[0];
    *nv = (int32_t)dims[1];
    *is_f64 = esz == 8;
    *chunk_frames = (int)chunk[0];
    st = DTX_OK;
done:
    CLOSE_ID(H5Pclose, dapl);
    CLOSE_ID(H5Pclose, dcpl);
    CLOSE_ID(H5Tclose, ft);
    CLOSE_ID(H5Dclose, probe);
    return st;
}

/* Selects rows [first, first+count) of a dataset whose other dimensions
 * are inner[0..rank-1) in full, and does the read or write.  count == 0
 * selects nothing (a collective call with no data of this rank). */
static herr_t slab_io(hid_t dset, int write, int rank, int64_t first, int64_t count,
                      const hsize_t *inner, hid_t mtype, void *buf, hid_t dxpl)
{
    hid_t fs = H5I_INVALID_HID, ms = H5I_INVALID_HID;
    hsize_t start[3] = {0, 0, 0}, cnt[3];
    herr_t r = -1;
    static char dummy[8];
    fs = H5Dget_space(dset);
    if (fs < 0)
        goto done;
    start[0] = (hsize_t)first;
    cnt[0] = (hsize_t)count;
    for (int k = 1; k < rank; k++)
        cnt[k] = inner[k - 1];
    if (count > 0) {
        if (H5Sselect_hyperslab(fs, H5S_SELECT_SET, start, NULL, cnt, NULL) < 0)
            goto done;
        ms = H5Screate_simple(rank, cnt, NULL);
    } else {
        hsize_t one = 1;
        if (H5Sselect_none(fs) < 0)
            goto done;
        ms = H5Screate_simple(1, &one, NULL);
        if (ms >= 0 && H5Sselect_none(ms) < 0)
            goto done;
        buf = dummy;
    }
    if (ms < 0)
        goto done;
    r = write ? H5Dwrite(dset, mtype, ms, fs, dxpl, buf) : H5Dread(dset, mtype, ms, fs, dxpl, buf);
done:
    CLOSE_ID(H5Sclose, ms);
    CLOSE_ID(H5Sclose, fs);
    return r;
}

static dtx_status check_frames(hid_t file, const char *path, int64_t nframes, int64_t first,
                               int64_t count, dtx_error *err)
{
    if (first < 0 || count < 0 || first > nframes || count > nframes - first)
        return ferr(err, DTX_EINVAL, file, path,
                    "frames [%lld, %lld) are outside the %lld frames [0, %lld)",
                    (long long)first, (long long)(first + count), (long long)nframes,
                    (long long)nframes);
    return DTX_OK;
}

/* Frames per chunk of a per-frame dataset (1 when it is not chunked). */
static int64_t chunk_frames(hid_t dset)
{
    hid_t dcpl = H5Dget_create_plist(dset);
    hsize_t dims[3] = {1, 1, 1};
    int64_t cf = 1;
    if (dcpl >= 0 && H5Pget_layout(dcpl) == H5D_CHUNKED && H5Pget_chunk(dcpl, 3, dims) >= 1 &&
        dims[0] >= 1)
        cf = (int64_t)dims[0];
    CLOSE_ID(H5Pclose, dcpl);
    return cf;
}

/* Frames per strip of float32 frames (nv vertices each) read or written
 * one strip at a time: about 1 MiB, rounded up to whole chunks. */
static int64_t strip_frames(hid_t dset, int32_t nv)
{
    const size_t per = (size_t)nv * 3u;
    int64_t strip = (int64_t)((1u << 20) / (per * sizeof(float))), cf = chunk_frames(dset);
    strip = strip < 1 ? 1 : strip;
    return (strip + cf - 1) / cf * cf;
}

/* Writes frames of a positions dataset, converting to float32 in *scratch
 * ourselves when needed (a type conversion inside HDF5 would turn a
 * collective MPI-IO write into independent ones). */
static dtx_status write_frames(hid_t file, hid_t dset, const char *path, int parallel,
                               int64_t nframes, int32_t nv, int is_f64, float **scratch,
                               size_t *scratch_n, int64_t first, int64_t count,
                               const double *data, int collective, dtx_error *err)
{
    hsize_t inner[2] = {(hsize_t)nv, 3};
    size_t n = (size_t)count * (size_t)nv * 3u;
    const void *buf = data;
    hid_t mtype = H5T_NATIVE_DOUBLE, dxpl;
    dtx_status st;
    if ((st = check_frames(file, path, nframes, first, count, err)) != DTX_OK)
        return st;
    if (count > 0 && !data)
        return ferr(err, DTX_EINVAL, file, path, "no data given for %lld frames",
                    (long long)count);
    if (!parallel || !collective) {
        if (count == 0)
            return DTX_OK;
    }
    /* Every rank of a collective call uses the same memory type, also
     * those without frames, so that HDF5 keeps the transfer collective. */
    if (!is_f64)
        mtype = H5T_NATIVE_FLOAT;
    /* Independent float32 writes go in strips of about 1 MiB (whole
     * chunks), each converted just before its write, so that the kernel
     * copies the strip from cache rather than from memory (a block's frames
     * are tens of MB); two ranks writing at once lost about a fifth of
     * their write time to that traffic.  A collective call stays one call,
     * as every rank must make the same calls. */
    if (!is_f64 && count > 0 && !(parallel && collective)) {
        const size_t per = (size_t)nv * 3u;
        int64_t strip = strip_frames(dset, nv);
        strip = strip > count ? count : strip;
        if (*scratch_n < (size_t)strip * per) {
            float *p = dtx_alloc((size_t)strip * per, sizeof *p, 0);
            if (!p)
                return ferr(err, DTX_ENOMEM, file, path, "out of memory for %lld frames",
                            (long long)strip);
            free(*scratch);
            *scratch = p;
            *scratch_n = (size_t)strip * per;
        }
        for (int64_t f = 0; f < count; f += strip) {
            int64_t m = count - f < strip ? count - f : strip;
            const double *src = data + (size_t)f * per;
            for (size_t i = 0; i < (size_t)m * per; i++)
                (*scratch)[i] = (float)src[i];
            if (slab_io(dset, 1, 3, first + f, m, inner, mtype, *scratch, H5P_DEFAULT) < 0)
                return h5err(err, file, path, "cannot write frames [%lld, %lld)",
                             (long long)(first + f), (long long)(first + f + m));
        }
        return DTX_OK;
    }
    if (!is_f64 && count > 0) {
        if (*scratch_n < n) {
            float *p = dtx_alloc(n, sizeof *p, 0);
            if (!p)
                return ferr(err, DTX_ENOMEM, file, path, "out of memory for %lld frames",
                            (long long)count);
            free(*scratch);
            *scratch = p;
            *scratch_n = n;
        }
        for (size_t i = 0; i < n; i++)
            (*scratch)[i] = (float)data[i];
        buf = *scratch;
    }
    dxpl = make_dxpl(parallel, collective);
    if (dxpl < 0)
        return h5err(err, file, path, "cannot set up collective transfer");
    if (slab_io(dset, 1, 3, first, count, inner, mtype, (void *)buf, dxpl) < 0)
        st = h5err(err, file, path, "cannot write frames [%lld, %lld)", (long long)first,
                   (long long)(first + count));
    close_dxpl(dxpl);
    return st;
}

/* Reads frames of a positions dataset as doubles.  float32 frames are read
 * as they are stored into the upper half of out, then widened in place
 * from the front: HDF5's own conversion goes through its type-conversion
 * buffer and a scatter copy, which cost more than the read itself.  They
 * are read in strips of about 1 MiB (whole chunks, the strips' bounds on
 * multiples of the strip in the dataset), each widened right after its
 * read while the kernel's copy of it is still in cache: read whole, a
 * block's floats (several MB) went out to memory and came back for the
 * widening, as the writes' did before write_frames took strips. */
static dtx_status read_frames(hid_t file, hid_t dset, const char *path, int64_t nframes,
                              int32_t nv, int is_f64, int64_t first, int64_t count, double *out,
                              dtx_error *err)
{
    hsize_t inner[2] = {(hsize_t)nv, 3};
    const size_t per = (size_t)nv * 3u, n = (size_t)count * per;
    float *f = (float *)out + n; /* bytes [4n, 8n) of out */
    int64_t strip;
    dtx_status st;
    if ((st = check_frames(file, path, nframes, first, count, err)) != DTX_OK)
        return st;
    if (count == 0)
        return DTX_OK;
    if (is_f64) {
        if (slab_io(dset, 0, 3, first, count, inner, H5T_NATIVE_DOUBLE, out, H5P_DEFAULT) < 0)
            return h5err(err, file, path, "cannot read frames [%lld, %lld)", (long long)first,
                         (long long)(first + count));
        return DTX_OK;
    }
    strip = strip_frames(dset, nv);
    for (int64_t g = 0; g < count;) {
        /* Frames [first + g, first + g + m): to the next multiple of the
         * strip, or the end. */
        int64_t m = strip - (first + g) % strip;
        float *fs = f + (size_t)g * per;
        double *ds = out + (size_t)g * per;
        m = m > count - g ? count - g : m;
        if (slab_io(dset, 0, 3, first + g, m, inner, H5T_NATIVE_FLOAT, fs, H5P_DEFAULT) < 0)
            return h5err(err, file, path, "cannot read frames [%lld, %lld)", (long long)(first + g),
                         (long long)(first + g + m));
        /* Piece by piece through a local buffer: writing out[0, j + k)
         * overwrites floats below index 2(j + k) - n <= j + k only (j, k
         * from the front of out), which have been copied out already; the
         * strips after this one, above it, are not reached. */
        {
            float piece[1024];
            const size_t sn = (size_t)m * per;
            for (size_t i = 0; i < sn; i += 1024) {
                const size_t q = sn - i < 1024 ? sn - i : 1024;
                memcpy(piece, fs + i, q * sizeof *piece);
                for (size_t k = 0; k < q; k++)
                    ds[i + k] = (double)piece[k];
            }
        }
        g += m;
    }
    return DTX_OK;
}

/* Checks that mesh_group is a mesh of nv vertices (for links). */
static dtx_status check_linked_mesh(hid_t file, const char *owner, const char *what,
                                    const char *mesh_group, int32_t nv, dtx_error *err)
{
    int32_t mnv = 0, mnf = 0;
    dtx_status st;
    if (!mesh_group || mesh_group[0] != '/')
        return ferr(err, DTX_EINVAL, file, owner,
                    "%s must be the absolute HDF5 path of a mesh group in this file, got "
                    "\"%s\"",
                    what, mesh_group ? mesh_group : "(null)");
    if ((st = dtx_h5_mesh_size(file, mesh_group, &mnv, &mnf, err)) != DTX_OK) {
        /* Name the object being written, then why the mesh is unusable
         * (without repeating the file name). */
        char name[400], inner[sizeof err->msg];
        size_t n = strlen(dtx_h5_filename(file, name, sizeof name));
        const char *why = err ? err->msg : "";
        if (strncmp(why, name, n) == 0 && strncmp(why + n, ": ", 2) == 0)
            why += n + 2;
        snprintf(inner, sizeof inner, "%s", why);
        return ferr(err, st, file, owner, "%s %s cannot be used: %s", what, mesh_group, inner);
    }
    if (mnv != nv)
        return ferr(err, DTX_EINVAL, file, owner, "%s %s has %d vertices, but the data has %d",
                    what, mesh_group, (int)mnv, (int)nv);
    return DTX_OK;
}

/* The checks a group of frames (a sequence, a result) passes before it is
 * created: its size, gzip only in serial, and a chunk that fits HDF5's
 * limit.  kind names the group in the size message ("sequence", "result"),
 * gzip_case the parallel file in the gzip one.  Sets *parallel and
 * *chunk_out. */
static dtx_status check_new_frames(hid_t file, const char *group, const char *kind,
                                   const char *gzip_case, int64_t nframes, int32_t nv, int f64,
                                   int chunk_frames, int gzip, int *parallel, int *chunk_out,
                                   dtx_error *err)
{
    if (nframes < 1 || nframes > INT32_MAX || nv < 1)
        return ferr(err, DTX_EINVAL, file, group, "bad %s size: %lld frames of %d vertices", kind,
                    (long long)nframes, (int)nv);
    *parallel = dtx_h5_is_parallel(file);
    if (gzip && *parallel)
        return ferr(err, DTX_EINVAL, file, group,
                    "gzip cannot be used %s in parallel (HDF5 1.10 cannot write filtered "
                    "datasets through MPI-IO)",
                    gzip_case);
    *chunk_out = pick_chunk_frames(chunk_frames, nframes, nv, f64);
    if (*chunk_out == 0)
        return ferr(err, DTX_EINVAL, file, group,
                    "one frame of %d vertices exceeds HDF5's 4 GiB chunk limit", (int)nv);
    return DTX_OK;
}

/* The soft link name -> mesh_group in the group g (at path) of a sequence
 * or a result. */
static dtx_status link_mesh(hid_t file, hid_t g, const char *path, const char *name,
                            const char *mesh_group, dtx_error *err)
{
    hid_t lcpl = intermediate_lcpl();
    dtx_status st = DTX_OK;
    if (lcpl < 0 || H5Lcreate_soft(mesh_group, g, name, lcpl, H5P_DEFAULT) < 0)
        st = h5err(err, file, path, "cannot create the link %s -> %s", name, mesh_group);
    CLOSE_ID(H5Pclose, lcpl);
    return st;
}

/* ============================================================== sequences */

dtx_status dtx_h5_seq_create(hid_t file, const char *group, const char *rest_mesh_group,
                             int64_t nframes, int32_t nv, int f64, int chunk_frames, int gzip,
                             dtx_h5_seq *seq, dtx_error *err)
{
    dtx_status st;
    int made;
    memset(seq, 0, sizeof *seq);
    seq->file = file;
    seq->group = seq->dset = H5I_INVALID_HID;
    if ((st = check_new_frames(file, group, "sequence", "on a file opened", nframes, nv, f64,
                               chunk_frames, gzip, &seq->parallel, &seq->chunk_frames, err)) !=
        DTX_OK)
        return st;
    if ((st = check_linked_mesh(file, group, "rest mesh", rest_mesh_group, nv, err)) != DTX_OK)
        return st;
    if ((st = begin_group(file, group, 0, seq->path, &seq->group, err)) != DTX_OK)
        goto fail;
    snprintf(seq->final_path, sizeof seq->final_path, "%s", group);
    seq->nframes = nframes;
    seq->nv = nv;
    seq->is_f64 = f64 != 0;
    if ((st = create_positions(seq->group, seq->parallel, nframes, nv, f64, seq->chunk_frames,
                               gzip, &seq->dset, err)) != DTX_OK ||
        (st = dtx_h5_write_attr_str(seq->group, ".", "rest_mesh", rest_mesh_group, err)) !=
            DTX_OK ||
        (st = dtx_h5_write_attr_int(seq->group, ".", "nframes", nframes, err)) != DTX_OK ||
        (st = link_mesh(file, seq->group, seq->path, "rest", rest_mesh_group, err)) != DTX_OK)
        goto fail;
    return DTX_OK;
fail:
    made = seq->group >= 0;
    dtx_h5_seq_close(seq);
    if (made) { /* leave no temporary group behind */
        dtx_error e2;
        dtx_h5_remove(file, seq->path, &e2);
    }
    return st;
}

dtx_status dtx_h5_seq_open(hid_t file, const char *group, dtx_h5_seq *seq, dtx_error *err)
{
    dtx_status st;
    memset(seq, 0, sizeof *seq);
    seq->file = file;
    seq->group = seq->dset = H5I_INVALID_HID;
    if (object_type(file, group) != H5O_TYPE_GROUP)
        return ferr(err, DTX_EFORMAT, file, group, "missing (no such sequence group)");
    if ((st = open_positions(file, group, &seq->dset, &seq->nframes, &seq->nv, &seq->is_f64,
                             &seq->chunk_frames, err)) != DTX_OK)
        goto fail;
    seq->group = H5Gopen2(file, group, H5P_DEFAULT);
    if (seq->group < 0) {
        st = h5err(err, file, group, "cannot open the group");
        goto fail;
    }
    if ((st = check_count_attr(file, group, "nframes", seq->nframes, "positions", err)) !=
        DTX_OK)
        goto fail;
    seq->parallel = dtx_h5_is_parallel(file);
    seq->committed = 1;
    snprintf(seq->path, sizeof seq->path, "%s", group);
    snprintf(seq->final_path, sizeof seq->final_path, "%s", group);
    return DTX_OK;
fail:
    dtx_h5_seq_close(seq);
    return st;
}

dtx_status dtx_h5_seq_read(const dtx_h5_seq *seq, int64_t first, int64_t count, double *out,
                           dtx_error *err)
{
    char path[DTX_H5_PATH_MAX];
    join_path(seq->path, "positions", path, sizeof path);
    return read_frames(seq->file, seq->dset, path, seq->nframes, seq->nv, seq->is_f64, first,
                       count, out, err);
}

dtx_status dtx_h5_seq_write(dtx_h5_seq *seq, int64_t first, int64_t count, const double *data,
                            int collective, dtx_error *err)
{
    char path[DTX_H5_PATH_MAX];
    join_path(seq->path, "positions", path, sizeof path);
    return write_frames(seq->file, seq->dset, path, seq->parallel, seq->nframes, seq->nv,
                        seq->is_f64, &seq->scratch, &seq->scratch_n, first, count, data,
                        collective, err);
}

dtx_status dtx_h5_write_frame_names(dtx_h5_seq *seq, const char *const *names, int64_t n,
                                    dtx_error *err)
{
    if (seq->parallel)
        return ferr(err, DTX_EINVAL, seq->file, seq->path,
                    "frame_names cannot be written to a file opened in parallel (HDF5 1.10 "
                    "cannot write variable-length strings through MPI-IO)");
    if (n != seq->nframes)
        return ferr(err, DTX_EINVAL, seq->file, seq->path,
                    "%lld frame names given for %lld frames", (long long)n,
                    (long long)seq->nframes);
    if (H5Lexists(seq->group, "frame_names", H5P_DEFAULT) > 0)
        return ferr(err, DTX_EINVAL, seq->file, seq->path, "frame_names already written");
    return create_write_strings(seq->group, "frame_names", names, n, err);
}

dtx_status dtx_h5_read_frame_names(const dtx_h5_seq *seq, char ***names, dtx_error *err)
{
    static const hsize_t want[1] = {0};
    char path[DTX_H5_PATH_MAX];
    hid_t d;
    hsize_t dims[1] = {0};
    dtx_status st;
    *names = NULL;
    if (join_path(seq->path, "frame_names", path, sizeof path))
        return ferr(err, DTX_EINVAL, seq->file, seq->path, "path too long");
    if (!dtx_h5_path_exists(seq->file, path))
        return DTX_OK;
    if ((st = open_checked(seq->file, path, H5T_STRING, 1, want, "T", &d, dims, err)) !=
        DTX_OK)
        return st;
    if ((int64_t)dims[0] != seq->nframes)
        st = ferr(err, DTX_EFORMAT, seq->file, path, "has %llu names for %lld frames",
                  (unsigned long long)dims[0], (long long)seq->nframes);
    else if ((st = check_storage(seq->file, d, path, dims, 1, err)) == DTX_OK)
        st = read_strings(seq->file, d, path, (int64_t)dims[0], names, err);
    CLOSE_ID(H5Dclose, d);
    return st;
}

dtx_status dtx_h5_seq_commit(dtx_h5_seq *seq, dtx_error *err)
{
    dtx_status st;
    if (seq->committed)
        return DTX_OK;
    /* Cached chunks are compressed and written when flushed: do it before
     * the sequence becomes visible, so that a write error is reported here
     * and not lost in dtx_h5_seq_close. */
    if (H5Dflush(seq->dset) < 0)
        return h5err(err, seq->file, seq->path, "cannot flush the positions");
    if ((st = dtx_h5_commit_group(seq->file, seq->path, seq->final_path, 0, err)) != DTX_OK)
        return st;
    snprintf(seq->path, sizeof seq->path, "%s", seq->final_path);
    seq->committed = 1;
    return DTX_OK;
}

void dtx_h5_seq_close(dtx_h5_seq *seq)
{
    if (!seq)
        return;
    if (seq->dset > 0)
        CLOSE_ID(H5Dclose, seq->dset);
    if (seq->group > 0)
        CLOSE_ID(H5Gclose, seq->group);
    seq->dset = seq->group = H5I_INVALID_HID;
    free(seq->scratch);
    seq->scratch = NULL;
    seq->scratch_n = 0;
}

/* ================================================================ markers */

dtx_status dtx_h5_write_markers(hid_t file, const char *group, const dtx_markers *mk,
                                const char *src_mesh, const char *tgt_mesh, dtx_error *err)
{
    char tmp[DTX_H5_PATH_MAX];
    hid_t g = H5I_INVALID_HID;
    hsize_t dim = (hsize_t)(mk->n > 0 ? mk->n : 0);
    dtx_status st;
    if (mk->n < 0)
        return ferr(err, DTX_EINVAL, file, group, "negative marker count");
    if (dtx_h5_is_parallel(file))
        return ferr(err, DTX_EINVAL, file, group,
                    "markers cannot be written to a file opened in parallel (HDF5 1.10 cannot "
                    "write variable-length strings through MPI-IO)");
    if ((st = begin_group(file, group, 0, tmp, &g, err)) != DTX_OK)
        goto done;
    if ((st = create_write(g, "source_vertex", H5T_STD_I32LE, H5T_NATIVE_INT32, 1, &dim,
                           H5P_DEFAULT, mk->src, err)) != DTX_OK ||
        (st = create_write(g, "target_vertex", H5T_STD_I32LE, H5T_NATIVE_INT32, 1, &dim,
                           H5P_DEFAULT, mk->tgt, err)) != DTX_OK ||
        (st = create_write_strings(g, "label", (const char *const *)mk->labels, mk->n, err)) !=
            DTX_OK ||
        (st = dtx_h5_write_attr_str(g, ".", "source_mesh", src_mesh, err)) != DTX_OK ||
        (st = dtx_h5_write_attr_str(g, ".", "target_mesh", tgt_mesh, err)) != DTX_OK ||
        (st = dtx_h5_write_attr_int(g, ".", "index_base", 0, err)) != DTX_OK)
        goto done;
    CLOSE_ID(H5Gclose, g);
    st = dtx_h5_commit_group(file, tmp, group, 0, err);
done:
    CLOSE_ID(H5Gclose, g);
    return st;
}

/* Reads a 1-D integer dataset group/name of n entries (n < 0: any) into a
 * malloc'ed int32 array. */
static dtx_status read_index_1d(hid_t file, const char *group, const char *name, int64_t *n,
                                int32_t **out, dtx_error *err)
{
    static const hsize_t want[1] = {0};
    char path[DTX_H5_PATH_MAX];
    hid_t d;
    hsize_t dims[1] = {0};
    dtx_status st;
    *out = NULL;
    if (join_path(group, name, path, sizeof path))
        return ferr(err, DTX_EINVAL, file, group, "path too long");
    if ((st = open_checked(file, path, H5T_INTEGER, 1, want, "m", &d, dims, err)) != DTX_OK)
        return st;
    if (*n >= 0 && (int64_t)dims[0] != *n)
        st = ferr(err, DTX_EFORMAT, file, path, "has %llu entries, expected %lld",
                  (unsigned long long)dims[0], (long long)*n);
    else
        st = read_whole(file, d, path, dims, 1, H5T_NATIVE_INT32, sizeof(int32_t),
                        (void **)out, err);
    CLOSE_ID(H5Dclose, d);
    if (st == DTX_OK) {
        *n = (int64_t)dims[0];
        for (int64_t i = 0; i < *n; i++)
            if ((*out)[i] < 0) {
                st = ferr(err, DTX_ERANGE, file, path,
                          "entry %lld is %d; indices must be >= 0 (0-based)", (long long)i,
                          (int)(*out)[i]);
                free(*out);
                *out = NULL;
                break;
            }
    }
    return st;
}

dtx_status dtx_h5_read_markers(hid_t file, const char *group, dtx_markers *mk, dtx_error *err)
{
    static const hsize_t want[1] = {0};
    int32_t *src = NULL, *tgt = NULL;
    char **labels = NULL;
    int64_t n = -1, base = 0;
    char path[DTX_H5_PATH_MAX];
    hid_t d = H5I_INVALID_HID;
    hsize_t dims[1] = {0};
    dtx_status st;
    memset(mk, 0, sizeof *mk);
    if (object_type(file, group) != H5O_TYPE_GROUP)
        return ferr(err, DTX_EFORMAT, file, group, "missing (no such marker group)");
    if (H5Aexists_by_name(file, group, "index_base", H5P_DEFAULT) > 0) {
        if ((st = dtx_h5_read_attr_int(file, group, "index_base", &base, err)) != DTX_OK)
            return st;
        if (base != 0)
            return ferr(err, DTX_EFORMAT, file, group,
                        "index_base is %lld; the dtx layout stores markers 0-based",
                        (long long)base);
    }
    if ((st = read_index_1d(file, group, "source_vertex", &n, &src, err)) != DTX_OK ||
        (st = read_index_1d(file, group, "target_vertex", &n, &tgt, err)) != DTX_OK)
        goto fail;
    if (join_path(group, "label", path, sizeof path)) {
        st = ferr(err, DTX_EINVAL, file, group, "path too long");
        goto fail;
    }
    if (dtx_h5_path_exists(file, path)) {
        if ((st = open_checked(file, path, H5T_STRING, 1, want, "m", &d, dims, err)) != DTX_OK)
            goto fail;
        if ((int64_t)dims[0] != n) {
            st = ferr(err, DTX_EFORMAT, file, path, "has %llu entries, expected %lld",
                      (unsigned long long)dims[0], (long long)n);
            goto fail;
        }
        if ((st = check_storage(file, d, path, dims, 1, err)) != DTX_OK ||
            (st = read_strings(file, d, path, n, &labels, err)) != DTX_OK)
            goto fail;
        CLOSE_ID(H5Dclose, d);
    }
    if ((st = dtx_markers_alloc(mk, (int32_t)n, err)) != DTX_OK)
        goto fail;
    memcpy(mk->src, src, (size_t)n * sizeof *src);
    memcpy(mk->tgt, tgt, (size_t)n * sizeof *tgt);
    for (int64_t i = 0; i < n; i++) {
        mk->labels[i] = labels ? labels[i] : dup_str("");
        if (labels)
            labels[i] = NULL;
        if (!mk->labels[i]) {
            st = ferr(err, DTX_ENOMEM, file, group, "out of memory");
            goto fail;
        }
    }
    dtx_h5_free_strings(&labels, n);
    free(src);
    free(tgt);
    return DTX_OK;
fail:
    CLOSE_ID(H5Dclose, d);
    dtx_h5_free_strings(&labels, n);
    dtx_markers_free(mk);
    free(src);
    free(tgt);
    return st;
}

/* ============================================================= key points */

/* A scalar f64 attribute (eps, error of a key-point set). */
static dtx_status write_attr_double(hid_t loc, const char *name, double value, dtx_error *err)
{
    return write_attr(loc, ".", name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, &value, err);
}

static dtx_status read_attr_double(hid_t loc, const char *obj, const char *name, double *value,
                                   dtx_error *err)
{
    hid_t a, ft, sp;
    char where[DTX_H5_PATH_MAX];
    dtx_status st;
    *value = 0;
    if ((st = open_attr(loc, obj, name, H5T_FLOAT, &a, &ft, &sp, err)) == DTX_OK &&
        H5Aread(a, H5T_NATIVE_DOUBLE, value) < 0)
        st = h5err(err, loc, obj_path(loc, obj, where, sizeof where),
                   "cannot read attribute %s", name);
    CLOSE_ID(H5Sclose, sp);
    CLOSE_ID(H5Tclose, ft);
    CLOSE_ID(H5Aclose, a);
    return st;
}

dtx_status dtx_h5_write_keypoints(hid_t file, const char *group, const dtx_h5_keypoints *kp,
                                  dtx_error *err)
{
    char tmp[DTX_H5_PATH_MAX];
    hid_t g = H5I_INVALID_HID;
    hsize_t n = (hsize_t)(kp->n > 0 ? kp->n : 0), pd[2] = {n, 3};
    hsize_t ne = (hsize_t)(kp->nerror > 0 ? kp->nerror : 0);
    dtx_status st;
    if (kp->n < 1 || kp->nerror < 1 || !kp->vertex || !kp->position || !kp->error)
        return ferr(err, DTX_EINVAL, file, group,
                    "a key-point set needs at least one point and one error value");
    if (dtx_h5_is_parallel(file))
        return ferr(err, DTX_EINVAL, file, group,
                    "key points cannot be written to a file opened in parallel (HDF5 1.10 "
                    "cannot write variable-length strings through MPI-IO)");
    if ((st = begin_group(file, group, 0, tmp, &g, err)) != DTX_OK)
        goto done;
    if ((st = create_write(g, "vertex", H5T_STD_I32LE, H5T_NATIVE_INT32, 1, &n, H5P_DEFAULT,
                           kp->vertex, err)) != DTX_OK ||
        (st = create_write(g, "position", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 2, pd,
                           H5P_DEFAULT, kp->position, err)) != DTX_OK ||
        (st = create_write_strings(g, "label", (const char *const *)kp->label, kp->n, err)) !=
            DTX_OK ||
        (st = create_write(g, "error", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 1, &ne, H5P_DEFAULT,
                           kp->error, err)) != DTX_OK ||
        (st = dtx_h5_write_attr_str(g, ".", "source_mesh", kp->source_mesh, err)) != DTX_OK ||
        (st = dtx_h5_write_attr_str(g, ".", "source_sequences", kp->source_sequences, err)) !=
            DTX_OK ||
        (st = dtx_h5_write_attr_int(g, ".", "candidates", kp->candidates, err)) != DTX_OK ||
        (st = write_attr_double(g, "eps", kp->eps, err)) != DTX_OK ||
        (st = write_attr_double(g, "error", kp->final_error, err)) != DTX_OK ||
        (st = dtx_h5_write_attr_str(g, ".", "dtx_version", DTX_VERSION, err)) != DTX_OK)
        goto done;
    CLOSE_ID(H5Gclose, g);
    st = dtx_h5_commit_group(file, tmp, group, 0, err);
done:
    CLOSE_ID(H5Gclose, g);
    return st;
}

/* Reads the 1-D or n x 3 float dataset group/name into a malloc'ed array;
 * rows: the expected first dimension (< 0: any, set on return). */
static dtx_status read_float_rows(hid_t file, const char *group, const char *name, int cols,
                                  int64_t *rows, double **out, dtx_error *err)
{
    hsize_t want[2] = {0, (hsize_t)cols}, dims[2] = {0, 0};
    char path[DTX_H5_PATH_MAX];
    hid_t d;
    int rank = cols > 0 ? 2 : 1;
    dtx_status st;
    *out = NULL;
    if (join_path(group, name, path, sizeof path))
        return ferr(err, DTX_EINVAL, file, group, "path too long");
    if ((st = open_checked(file, path, H5T_FLOAT, rank, want, rank == 2 ? "n x 3" : "S", &d,
                           dims, err)) != DTX_OK)
        return st;
    if (*rows >= 0 && (int64_t)dims[0] != *rows)
        st = ferr(err, DTX_EFORMAT, file, path, "has %llu rows, expected %lld",
                  (unsigned long long)dims[0], (long long)*rows);
    else
        st = read_whole(file, d, path, dims, rank, H5T_NATIVE_DOUBLE, sizeof(double),
                        (void **)out, err);
    CLOSE_ID(H5Dclose, d);
    for (uint64_t i = 0; st == DTX_OK && i < dims[0] * (rank == 2 ? dims[1] : 1); i++)
        if (!isfinite((*out)[i]))
            st = ferr(err, DTX_ENONFINITE, file, path, "value %llu is not finite",
                      (unsigned long long)i);
    if (st != DTX_OK) {
        free(*out);
        *out = NULL;
    } else {
        *rows = (int64_t)dims[0];
    }
    return st;
}

dtx_status dtx_h5_read_keypoints(hid_t file, const char *group, dtx_h5_keypoints *kp,
                                 dtx_error *err)
{
    static const hsize_t want[1] = {0};
    char path[DTX_H5_PATH_MAX];
    hid_t d = H5I_INVALID_HID;
    hsize_t dims[1] = {0};
    int64_t n = -1, ne = -1, cand = 0;
    dtx_status st;
    memset(kp, 0, sizeof *kp);
    if (object_type(file, group) != H5O_TYPE_GROUP)
        return ferr(err, DTX_EFORMAT, file, group, "missing (no such key-point group)");
    if ((st = read_index_1d(file, group, "vertex", &n, &kp->vertex, err)) != DTX_OK)
        goto fail;
    if (n < 1) {
        st = ferr(err, DTX_EFORMAT, file, group, "holds no key points");
        goto fail;
    }
    kp->n = (int32_t)n;
    if ((st = read_float_rows(file, group, "position", 3, &n, &kp->position, err)) != DTX_OK ||
        (st = read_float_rows(file, group, "error", 0, &ne, &kp->error, err)) != DTX_OK)
        goto fail;
    if (ne < 1) {
        st = ferr(err, DTX_EFORMAT, file, group, "has no error values");
        goto fail;
    }
    kp->nerror = (int32_t)ne;
    if (join_path(group, "label", path, sizeof path)) {
        st = ferr(err, DTX_EINVAL, file, group, "path too long");
        goto fail;
    }
    if ((st = open_checked(file, path, H5T_STRING, 1, want, "n", &d, dims, err)) != DTX_OK)
        goto fail;
    if ((int64_t)dims[0] != n) {
        st = ferr(err, DTX_EFORMAT, file, path, "has %llu entries, expected %lld",
                  (unsigned long long)dims[0], (long long)n);
        goto fail;
    }
    if ((st = check_storage(file, d, path, dims, 1, err)) != DTX_OK ||
        (st = read_strings(file, d, path, n, &kp->label, err)) != DTX_OK)
        goto fail;
    CLOSE_ID(H5Dclose, d);
    if ((st = dtx_h5_read_attr_str(file, group, "source_mesh", &kp->source_mesh, err)) !=
            DTX_OK ||
        (st = dtx_h5_read_attr_str(file, group, "source_sequences", &kp->source_sequences,
                                   err)) != DTX_OK ||
        (st = dtx_h5_read_attr_int(file, group, "candidates", &cand, err)) != DTX_OK ||
        (st = read_attr_double(file, group, "eps", &kp->eps, err)) != DTX_OK ||
        (st = read_attr_double(file, group, "error", &kp->final_error, err)) != DTX_OK ||
        (st = dtx_h5_read_attr_str(file, group, "dtx_version", &kp->dtx_version, err)) != DTX_OK)
        goto fail;
    kp->candidates = (int32_t)cand;
    return DTX_OK;
fail:
    CLOSE_ID(H5Dclose, d);
    dtx_h5_keypoints_free(kp);
    return st;
}

void dtx_h5_keypoints_free(dtx_h5_keypoints *kp)
{
    if (!kp)
        return;
    free(kp->vertex);
    free(kp->position);
    dtx_h5_free_strings(&kp->label, kp->n);
    free(kp->error);
    free(kp->source_mesh);
    free(kp->source_sequences);
    free(kp->dtx_version);
    memset(kp, 0, sizeof *kp);
}

/* ======================================================== correspondences */

dtx_status dtx_h5_write_corr(hid_t file, const char *group, const int32_t *pairs,
                             int64_t npairs, const double *deformed_src, int32_t nv_s,
                             const dtx_h5_corr_meta *meta, dtx_error *err)
{
    char tmp[DTX_H5_PATH_MAX];
    hid_t g = H5I_INVALID_HID;
    hsize_t pd[2] = {(hsize_t)npairs, 2}, vd[2] = {(hsize_t)nv_s, 3};
    dtx_h5_corr_meta none = {NULL, NULL, NULL, NULL, NULL};
    dtx_status st;
    if (npairs < 0 || npairs > INT32_MAX || nv_s < 0)
        return ferr(err, DTX_EINVAL, file, group, "bad sizes: %lld pairs, %d vertices",
                    (long long)npairs, (int)nv_s);
    if (!meta)
        meta = &none;
    if ((st = begin_group(file, group, 0, tmp, &g, err)) != DTX_OK)
        goto done;
    if ((st = create_write(g, "pairs", H5T_STD_I32LE, H5T_NATIVE_INT32, 2, pd, H5P_DEFAULT,
                           pairs, err)) != DTX_OK ||
        (deformed_src &&
         (st = create_write(g, "deformed_source", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 2, vd,
                            H5P_DEFAULT, deformed_src, err)) != DTX_OK) ||
        (st = dtx_h5_write_attr_str(g, ".", "key", meta->key, err)) != DTX_OK ||
        (st = dtx_h5_write_attr_str(g, ".", "source_mesh", meta->source_mesh, err)) != DTX_OK ||
        (st = dtx_h5_write_attr_str(g, ".", "target_mesh", meta->target_mesh, err)) != DTX_OK ||
        (st = dtx_h5_write_attr_str(g, ".", "markers", meta->markers, err)) != DTX_OK ||
        (st = dtx_h5_write_attr_str(g, ".", "parameters", meta->parameters, err)) != DTX_OK ||
        (st = dtx_h5_write_attr_str(g, ".", "dtx_version", DTX_VERSION, err)) != DTX_OK)
        goto done;
    CLOSE_ID(H5Gclose, g);
    st = dtx_h5_commit_group(file, tmp, group, 0, err);
done:
    CLOSE_ID(H5Gclose, g);
    return st;
}

void dtx_h5_corr_free(dtx_h5_corr *c)
{
    if (!c)
        return;
    free(c->pairs);
    free(c->deformed_src);
    free(c->key);
    free(c->source_mesh);
    free(c->target_mesh);
    free(c->markers);
    free(c->parameters);
    free(c->dtx_version);
    memset(c, 0, sizeof *c);
}

dtx_status dtx_h5_read_corr(hid_t file, const char *group, int32_t src_nv, int32_t src_nf,
                            int32_t tgt_nf, dtx_h5_corr *c, dtx_error *err)
{
    static const hsize_t want_p[2] = {0, 2}, want_v[2] = {0, 3};
    char ppath[DTX_H5_PATH_MAX], vpath[DTX_H5_PATH_MAX];
    hid_t pd = H5I_INVALID_HID, vd = H5I_INVALID_HID;
    hsize_t pdims[2] = {0, 0}, vdims[2] = {0, 0};
    dtx_status st;
    int has_def;
    memset(c, 0, sizeof *c);
    if (object_type(file, group) != H5O_TYPE_GROUP)
        return ferr(err, DTX_EFORMAT, file, group, "missing (no such correspondence group)");
    if (join_path(group, "pairs", ppath, sizeof ppath) ||
        join_path(group, "deformed_source", vpath, sizeof vpath))
        return ferr(err, DTX_EINVAL, file, group, "path too long");
    /* deformed_source is absent from a multicomponent correspondence. */
    has_def = dtx_h5_path_exists(file, vpath);
    if ((st = open_checked(file, ppath, H5T_INTEGER, 2, want_p, "P x 2", &pd, pdims, err)) !=
            DTX_OK ||
        (has_def && (st = open_checked(file, vpath, H5T_FLOAT, 2, want_v, "nv_s x 3", &vd,
                                       vdims, err)) != DTX_OK))
        goto fail;
    if (has_def && src_nv >= 0 && (int64_t)vdims[0] != src_nv) {
        st = ferr(err, DTX_EFORMAT, file, vpath, "has %llu rows, but the source mesh has %d "
                  "vertices", (unsigned long long)vdims[0], (int)src_nv);
        goto fail;
    }
    if ((st = read_whole(file, pd, ppath, pdims, 2, H5T_NATIVE_INT32, sizeof(int32_t),
                         (void **)&c->pairs, err)) != DTX_OK ||
        (has_def && (st = read_whole(file, vd, vpath, vdims, 2, H5T_NATIVE_DOUBLE,
                                     sizeof(double), (void **)&c->deformed_src, err)) != DTX_OK))
        goto fail;
    c->npairs = (int64_t)pdims[0];
    c->nv_s = (int32_t)vdims[0];
    for (int64_t i = 0; i < c->npairs; i++) {
        int32_t s = c->pairs[2 * i], t = c->pairs[2 * i + 1];
        if (s < 0 || (src_nf >= 0 && s >= src_nf) || t < 0 || (tgt_nf >= 0 && t >= tgt_nf)) {
            st = ferr(err, DTX_ERANGE, file, ppath,
                      "pair %lld (%d, %d) is out of range (source has %d triangles, target "
                      "%d)",
                      (long long)i, (int)s, (int)t, (int)src_nf, (int)tgt_nf);
            goto fail;
        }
    }
    for (int32_t i = 0; i < c->nv_s * 3; i++)
        if (!isfinite(c->deformed_src[i])) {
            st = ferr(err, DTX_ENONFINITE, file, vpath, "vertex %d is not finite", (int)(i / 3));
            goto fail;
        }
    if ((st = dtx_h5_read_attr_str(file, group, "key", &c->key, err)) != DTX_OK ||
        (st = dtx_h5_read_attr_str(file, group, "source_mesh", &c->source_mesh, err)) !=
            DTX_OK ||
        (st = dtx_h5_read_attr_str(file, group, "target_mesh", &c->target_mesh, err)) !=
            DTX_OK ||
        (st = dtx_h5_read_attr_str(file, group, "markers", &c->markers, err)) != DTX_OK ||
        (st = dtx_h5_read_attr_str(file, group, "parameters", &c->parameters, err)) != DTX_OK ||
        (st = dtx_h5_read_attr_str(file, group, "dtx_version", &c->dtx_version, err)) != DTX_OK)
        goto fail;
    CLOSE_ID(H5Dclose, vd);
    CLOSE_ID(H5Dclose, pd);
    return DTX_OK;
fail:
    CLOSE_ID(H5Dclose, vd);
    CLOSE_ID(H5Dclose, pd);
    dtx_h5_corr_free(c);
    return st;
}

static herr_t collect_cb(hid_t g, const char *name, const H5L_info_t *info, void *data)
{
    dtx_h5_names *l = data;
    (void)g;
    (void)info;
    if (l->n == l->cap) {
        size_t cap = l->cap ? 2 * l->cap : 16;
        char **p = realloc(l->names, cap * sizeof *p);
        if (!p) {
            l->oom = 1;
            return -1;
        }
        l->names = p;
        l->cap = cap;
    }
    if (!(l->names[l->n] = dup_str(name))) {
        l->oom = 1;
        return -1;
    }
    l->n++;
    return 0;
}

void dtx_h5_names_free(dtx_h5_names *l)
{
    for (size_t i = 0; i < l->n; i++)
        free(l->names[i]);
    free(l->names);
    memset(l, 0, sizeof *l);
}

int dtx_h5_list_names(hid_t file, const char *path, dtx_h5_names *l)
{
    memset(l, 0, sizeof *l);
    if (H5Literate_by_name(file, path, H5_INDEX_NAME, H5_ITER_INC, NULL, collect_cb, l,
                           H5P_DEFAULT) < 0) {
        int oom = l->oom;
        dtx_h5_names_free(l);
        l->oom = oom;
        return -1;
    }
    return 0;
}

static int cmp_str(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

dtx_status dtx_h5_list_groups(hid_t file, const char *path, char ***names, int64_t *n,
                              dtx_error *err)
{
    dtx_h5_names l;
    char child[DTX_H5_PATH_MAX];
    size_t kept = 0;
    *names = NULL;
    *n = 0;
    if (object_type(file, path) != H5O_TYPE_GROUP)
        return ferr(err, DTX_EFORMAT, file, path, "missing (no such group)");
    if (dtx_h5_list_names(file, path, &l) < 0)
        return l.oom ? ferr(err, DTX_ENOMEM, file, path, "out of memory")
                     : h5err(err, file, path, "cannot list the group");
    for (size_t i = 0; i < l.n; i++) {
        if (strncmp(l.names[i], DTX_H5_TMP_PREFIX, strlen(DTX_H5_TMP_PREFIX)) != 0 &&
            !join_path(path, l.names[i], child, sizeof child) &&
            object_type(file, child) == H5O_TYPE_GROUP)
            l.names[kept++] = l.names[i];
        else
            free(l.names[i]);
    }
    if (kept > 1)
        qsort(l.names, kept, sizeof *l.names, cmp_str);
    if (kept == 0) {
        free(l.names);
        l.names = NULL;
    }
    *names = l.names;
    *n = (int64_t)kept;
    return DTX_OK;
}

/* The first group parent/<name> (temporaries skipped) whose attribute key
 * equals key: *group_out a malloc'ed path, or NULL. */
static dtx_status find_by_key(hid_t file, const char *parent, const char *key, char **group_out,
                              dtx_error *err)
{
    dtx_h5_names l;
    char path[DTX_H5_PATH_MAX];
    dtx_status st = DTX_OK;
    *group_out = NULL;
    if (object_type(file, parent) != H5O_TYPE_GROUP)
        return DTX_OK;
    if (dtx_h5_list_names(file, parent, &l) < 0)
        return l.oom ? ferr(err, DTX_ENOMEM, file, parent, "out of memory")
                     : h5err(err, file, parent, "cannot list the group");
    for (size_t i = 0; i < l.n && !*group_out; i++) {
        char *k = NULL;
        if (strncmp(l.names[i], DTX_H5_TMP_PREFIX, strlen(DTX_H5_TMP_PREFIX)) == 0 ||
            join_path(parent, l.names[i], path, sizeof path) ||
            object_type(file, path) != H5O_TYPE_GROUP ||
            H5Aexists_by_name(file, path, "key", H5P_DEFAULT) <= 0)
            continue;
        if ((st = dtx_h5_read_attr_str(file, path, "key", &k, err)) != DTX_OK)
            goto done;
        if (strcmp(k, key) == 0 && !(*group_out = dup_str(path)))
            st = ferr(err, DTX_ENOMEM, file, path, "out of memory");
        free(k);
    }
done:
    dtx_h5_names_free(&l);
    return st;
}

dtx_status dtx_h5_find_corr_by_key(hid_t file, const char *key, char **group_out,
                                   dtx_error *err)
{
    return find_by_key(file, "/correspondences", key, group_out, err);
}

/* ================================================================ weights */

dtx_status dtx_h5_write_weights(hid_t file, const char *group, const int32_t *handles, int32_t m,
                                const double *weights, int32_t nv, const char *key,
                                const char *mesh, dtx_error *err)
{
    char tmp[DTX_H5_PATH_MAX];
    hid_t g = H5I_INVALID_HID;
    hsize_t hd[1] = {(hsize_t)m}, wd[2] = {(hsize_t)nv, (hsize_t)m};
    dtx_status st;
    if (m < 1 || nv < 1 || !handles || !weights)
        return ferr(err, DTX_EINVAL, file, group, "bad sizes: %d handles, %d vertices", (int)m,
                    (int)nv);
    if ((st = begin_group(file, group, 0, tmp, &g, err)) != DTX_OK)
        goto done;
    if ((st = create_write(g, "handles", H5T_STD_I32LE, H5T_NATIVE_INT32, 1, hd, H5P_DEFAULT,
                           handles, err)) != DTX_OK ||
        (st = create_write(g, "weights", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 2, wd, H5P_DEFAULT,
                           weights, err)) != DTX_OK ||
        (st = dtx_h5_write_attr_str(g, ".", "key", key ? key : "", err)) != DTX_OK ||
        (st = dtx_h5_write_attr_str(g, ".", "mesh", mesh ? mesh : "", err)) != DTX_OK ||
        (st = dtx_h5_write_attr_str(g, ".", "dtx_version", DTX_VERSION, err)) != DTX_OK)
        goto done;
    CLOSE_ID(H5Gclose, g);
    st = dtx_h5_commit_group(file, tmp, group, 0, err);
done:
    CLOSE_ID(H5Gclose, g);
    return st;
}

void dtx_h5_weights_free(dtx_h5_weights *w)
{
    if (!w)
        return;
    free(w->handles);
    free(w->weights);
    free(w->key);
    free(w->mesh);
    free(w->dtx_version);
    memset(w, 0, sizeof *w);
}

dtx_status dtx_h5_read_weights(hid_t file, const char *group, int32_t nv, dtx_h5_weights *w,
                               dtx_error *err)
{
    static const hsize_t want_h[1] = {0}, want_w[2] = {0, 0};
    char hpath[DTX_H5_PATH_MAX], wpath[DTX_H5_PATH_MAX];
    hid_t hd = H5I_INVALID_HID, wd = H5I_INVALID_HID;
    hsize_t hdims[1] = {0}, wdims[2] = {0, 0};
    dtx_status st;
    memset(w, 0, sizeof *w);
    if (object_type(file, group) != H5O_TYPE_GROUP)
        return ferr(err, DTX_EFORMAT, file, group, "missing (no such weight group)");
    if (join_path(group, "handles", hpath, sizeof hpath) ||
        join_path(group, "weights", wpath, sizeof wpath))
        return ferr(err, DTX_EINVAL, file, group, "path too long");
    if ((st = open_checked(file, hpath, H5T_INTEGER, 1, want_h, "m", &hd, hdims, err)) !=
            DTX_OK ||
        (st = open_checked(file, wpath, H5T_FLOAT, 2, want_w, "nv x m", &wd, wdims, err)) !=
            DTX_OK)
        goto fail;
    if (hdims[0] < 1 || hdims[0] > INT32_MAX) {
        st = ferr(err, DTX_EFORMAT, file, hpath, "has %llu entries (at least 1 handle needed)",
                  (unsigned long long)hdims[0]);
        goto fail;
    }
    if (wdims[1] != hdims[0] || wdims[0] > INT32_MAX || (nv >= 0 && wdims[0] != (hsize_t)nv)) {
        if (nv >= 0)
            st = ferr(err, DTX_EFORMAT, file, wpath,
                      "is %llu x %llu, expected %d x %llu (the mesh's vertices x the handles)",
                      (unsigned long long)wdims[0], (unsigned long long)wdims[1], (int)nv,
                      (unsigned long long)hdims[0]);
        else
            st = ferr(err, DTX_EFORMAT, file, wpath,
                      "is %llu x %llu, expected one column per handle (%llu)",
                      (unsigned long long)wdims[0], (unsigned long long)wdims[1],
                      (unsigned long long)hdims[0]);
        goto fail;
    }
    if ((st = read_whole(file, hd, hpath, hdims, 1, H5T_NATIVE_INT32, sizeof(int32_t),
                         (void **)&w->handles, err)) != DTX_OK ||
        (st = read_whole(file, wd, wpath, wdims, 2, H5T_NATIVE_DOUBLE, sizeof(double),
                         (void **)&w->weights, err)) != DTX_OK)
        goto fail;
    w->m = (int32_t)hdims[0];
    w->nv = (int32_t)wdims[0];
    for (int32_t k = 0; k < w->m; k++)
        if (w->handles[k] < 0 || w->handles[k] >= w->nv) {
            st = ferr(err, DTX_ERANGE, file, hpath, "handle %d is vertex %d, out of range [0, %d)",
                      (int)k, (int)w->handles[k], (int)w->nv);
            goto fail;
        }
    for (int64_t i = 0; i < (int64_t)w->nv * w->m; i++)
        if (!(w->weights[i] >= 0.0 && w->weights[i] <= 1.0)) {
            st = ferr(err, DTX_ERANGE, file, wpath,
                      "vertex %lld, handle %lld: weight %g is not in [0, 1]",
                      (long long)(i / w->m), (long long)(i % w->m), w->weights[i]);
            goto fail;
        }
    if ((st = dtx_h5_read_attr_str(file, group, "key", &w->key, err)) != DTX_OK ||
        (st = dtx_h5_read_attr_str(file, group, "mesh", &w->mesh, err)) != DTX_OK ||
        (st = dtx_h5_read_attr_str(file, group, "dtx_version", &w->dtx_version, err)) != DTX_OK)
        goto fail;
    CLOSE_ID(H5Dclose, wd);
    CLOSE_ID(H5Dclose, hd);
    return DTX_OK;
fail:
    CLOSE_ID(H5Dclose, wd);
    CLOSE_ID(H5Dclose, hd);
    dtx_h5_weights_free(w);
    return st;
}

dtx_status dtx_h5_find_weights_by_key(hid_t file, const char *key, char **group_out,
                                      dtx_error *err)
{
    return find_by_key(file, "/weights", key, group_out, err);
}

/* ================================================================ results */

/* Creates a 1-D dataset of T entries with a fill value, allocated now. */
static dtx_status create_filled_1d(hid_t group, const char *name, hid_t ftype, hid_t mtype,
                                   const void *fill, int64_t n, dtx_error *err)
{
    hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
    hsize_t dim = (hsize_t)n;
    dtx_status st;
    if (dcpl < 0 || H5Pset_fill_value(dcpl, mtype, fill) < 0 ||
        H5Pset_alloc_time(dcpl, H5D_ALLOC_TIME_EARLY) < 0 ||
        H5Pset_fill_time(dcpl, H5D_FILL_TIME_ALLOC) < 0) {
        CLOSE_ID(H5Pclose, dcpl);
        return h5err(err, group, name, "cannot set up the dataset");
    }
    st = create_write(group, name, ftype, mtype, 1, &dim, dcpl, NULL, err);
    CLOSE_ID(H5Pclose, dcpl);
    return st;
}

static void result_init(dtx_h5_result *res, hid_t file)
{
    memset(res, 0, sizeof *res);
    res->file = file;
    res->group = res->positions = res->residual = res->frame_done = H5I_INVALID_HID;
    res->frame_stats = res->frame_grad_norm = H5I_INVALID_HID;
}

/* Opens residual and frame_done of an open result group and checks them. */
static dtx_status open_result_1d(dtx_h5_result *res, dtx_error *err)
{
    static const hsize_t want[1] = {0};
    char path[DTX_H5_PATH_MAX];
    hsize_t dims[1] = {0};
    dtx_status st;
    join_path(res->path, "residual", path, sizeof path);
    if ((st = open_checked(res->file, path, H5T_FLOAT, 1, want, "T", &res->residual, dims,
                           err)) != DTX_OK)
        return st;
    if ((int64_t)dims[0] != res->nframes)
        return ferr(err, DTX_EFORMAT, res->file, path, "has %llu entries for %lld frames",
                    (unsigned long long)dims[0], (long long)res->nframes);
    join_path(res->path, "frame_done", path, sizeof path);
    if ((st = open_checked(res->file, path, H5T_INTEGER, 1, want, "T", &res->frame_done, dims,
                           err)) != DTX_OK)
        return st;
    if ((int64_t)dims[0] != res->nframes)
        return ferr(err, DTX_EFORMAT, res->file, path, "has %llu entries for %lld frames",
                    (unsigned long long)dims[0], (long long)res->nframes);
    return DTX_OK;
}

dtx_status dtx_h5_result_create(hid_t file, const char *group, const dtx_h5_provenance *prov,
                                int64_t nframes, int32_t nv, int f64, int chunk_frames, int gzip,
                                dtx_h5_result *res, dtx_error *err)
{
    static const double nan_fill = NAN;
    static const uint8_t zero_fill = 0;
    dtx_status st;
    result_init(res, file);
    if (!prov || !prov->target_mesh)
        return ferr(err, DTX_EINVAL, file, group, "no target mesh given for the result");
    if ((st = check_new_frames(file, group, "result", "for a result written", nframes, nv, f64,
                               chunk_frames, gzip, &res->parallel, &res->chunk_frames, err)) !=
        DTX_OK)
        return st;
    if ((st = check_linked_mesh(file, group, "target mesh", prov->target_mesh, nv, err)) !=
        DTX_OK)
        return st;
    if ((st = begin_group(file, group, 1, res->path, &res->group, err)) != DTX_OK)
        goto fail;
    snprintf(res->final_path, sizeof res->final_path, "%s", group);
    res->nframes = nframes;
    res->nv = nv;
    res->is_f64 = f64 != 0;
    if ((st = create_positions(res->group, res->parallel, nframes, nv, f64, res->chunk_frames,
                               gzip, &res->positions, err)) != DTX_OK ||
        (st = create_filled_1d(res->group, "residual", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE,
                               &nan_fill, nframes, err)) != DTX_OK ||
        (st = create_filled_1d(res->group, "frame_done", H5T_STD_U8LE, H5T_NATIVE_UINT8,
                               &zero_fill, nframes, err)) != DTX_OK ||
        (st = open_result_1d(res, err)) != DTX_OK ||
        (st = link_mesh(file, res->group, res->path, "target", prov->target_mesh, err)) != DTX_OK)
        goto fail;
    if ((st = dtx_h5_write_attr_str(res->group, ".", "method", prov->method, err)) != DTX_OK ||
        (st = dtx_h5_write_attr_str(res->group, ".", "job", prov->job, err)) != DTX_OK ||
        (st = dtx_h5_write_attr_str(res->group, ".", "parameters", prov->parameters, err)) !=
            DTX_OK ||
        (st = dtx_h5_write_attr_str(res->group, ".", "dtx_version", DTX_VERSION, err)) !=
            DTX_OK ||
        (st = dtx_h5_write_attr_str(res->group, ".", "source_sequence", prov->source_sequence,
                                    err)) != DTX_OK ||
        (st = dtx_h5_write_attr_str(res->group, ".", "target_mesh", prov->target_mesh, err)) !=
            DTX_OK ||
        (st = dtx_h5_write_attr_str(res->group, ".", "correspondence", prov->correspondence,
                                    err)) != DTX_OK ||
        (st = dtx_h5_write_attr_int(res->group, ".", "complete", 0, err)) != DTX_OK)
        goto fail;
    return DTX_OK;
fail:
    dtx_h5_result_close(res);
    return st;
}

dtx_status dtx_h5_result_open(hid_t file, const char *group, int resume, dtx_h5_result *res,
                              dtx_error *err)
{
    dtx_status st;
    result_init(res, file);
    if (resume) {
        if ((st = dtx_h5_tmp_path(group, res->path, sizeof res->path, err)) != DTX_OK)
            return st;
    } else {
        snprintf(res->path, sizeof res->path, "%s", group);
    }
    snprintf(res->final_path, sizeof res->final_path, "%s", group);
    if (object_type(file, res->path) != H5O_TYPE_GROUP)
        return ferr(err, DTX_EFORMAT, file, res->path,
                    resume ? "missing (no interrupted result to resume)"
                           : "missing (no such result group)");
    if ((st = open_positions(file, res->path, &res->positions, &res->nframes, &res->nv,
                             &res->is_f64, &res->chunk_frames, err)) != DTX_OK ||
        (st = open_result_1d(res, err)) != DTX_OK)
        goto fail;
    {
        char path[DTX_H5_PATH_MAX];
        join_path(res->path, "frame_stats", path, sizeof path);
        if (link_exists(file, path)) {
            static const hsize_t want[2] = {0, DTX_H5_FRAME_STATS};
            hsize_t dims[2] = {0, 0};
            if ((st = open_checked(file, path, H5T_INTEGER, 2, want, "T x 3", &res->frame_stats,
                                   dims, err)) != DTX_OK)
                goto fail;
            if ((int64_t)dims[0] != res->nframes) {
                st = ferr(err, DTX_EFORMAT, file, path, "has %llu rows for %lld frames",
                          (unsigned long long)dims[0], (long long)res->nframes);
                goto fail;
            }
        }
        join_path(res->path, "frame_grad_norm", path, sizeof path);
        if (link_exists(file, path)) {
            static const hsize_t want[1] = {0};
            hsize_t dims[1] = {0};
            if ((st = open_checked(file, path, H5T_FLOAT, 1, want, "T", &res->frame_grad_norm, dims,
                                   err)) != DTX_OK)
                goto fail;
            if ((int64_t)dims[0] != res->nframes) {
                st = ferr(err, DTX_EFORMAT, file, path, "has %llu entries for %lld frames",
                          (unsigned long long)dims[0], (long long)res->nframes);
                goto fail;
            }
        }
    }
    res->group = H5Gopen2(file, res->path, H5P_DEFAULT);
    if (res->group < 0) {
        st = h5err(err, file, res->path, "cannot open the group");
        goto fail;
    }
    res->parallel = dtx_h5_is_parallel(file);
    res->committed = !resume;
    return DTX_OK;
fail:
    dtx_h5_result_close(res);
    return st;
}

dtx_status dtx_h5_result_write(dtx_h5_result *res, int64_t first, int64_t count,
                               const double *positions, const double *residual, int collective,
                               dtx_error *err)
{
    char path[DTX_H5_PATH_MAX];
    hid_t dxpl = H5I_INVALID_HID;
    dtx_status st;
    join_path(res->path, "positions", path, sizeof path);
    if ((st = write_frames(res->file, res->positions, path, res->parallel, res->nframes,
                           res->nv, res->is_f64, &res->scratch, &res->scratch_n, first, count,
                           positions, collective, err)) != DTX_OK)
        return st;
    if (count == 0 && (!res->parallel || !collective))
        return DTX_OK;
    if (res->ones_n < (size_t)count) {
        uint8_t *p = dtx_alloc((size_t)count, 1, 0);
        if (!p)
            return ferr(err, DTX_ENOMEM, res->file, res->path, "out of memory");
        memset(p, 1, (size_t)count);
        free(res->ones);
        res->ones = p;
        res->ones_n = (size_t)count;
    }
    dxpl = make_dxpl(res->parallel, collective);
    if (dxpl < 0)
        return h5err(err, res->file, res->path, "cannot set up collective transfer");
    /* Residuals, then frame_done strictly after the positions.  In a
     * collective call every rank makes the same calls; a rank with no
     * residuals selects nothing. */
    if ((residual || (res->parallel && collective)) &&
        slab_io(res->residual, 1, 1, first, residual ? count : 0, NULL, H5T_NATIVE_DOUBLE,
                (void *)residual, dxpl) < 0) {
        join_path(res->path, "residual", path, sizeof path);
        st = h5err(err, res->file, path, "cannot write frames [%lld, %lld)", (long long)first,
                   (long long)(first + count));
    } else if (slab_io(res->frame_done, 1, 1, first, count, NULL, H5T_NATIVE_UINT8, res->ones,
                       dxpl) < 0) {
        join_path(res->path, "frame_done", path, sizeof path);
        st = h5err(err, res->file, path, "cannot write frames [%lld, %lld)", (long long)first,
                   (long long)(first + count));
    }
    close_dxpl(dxpl);
    return st;
}

dtx_status dtx_h5_result_add_frame_stats(dtx_h5_result *res, dtx_error *err)
{
    static const int32_t fill = -1;
    hid_t dcpl;
    hsize_t dims[2] = {(hsize_t)res->nframes, DTX_H5_FRAME_STATS};
    char path[DTX_H5_PATH_MAX];
    dtx_status st;
    join_path(res->path, "frame_stats", path, sizeof path);
    if (res->frame_stats >= 0)
        return ferr(err, DTX_EINVAL, res->file, path, "already exists");
    dcpl = H5Pcreate(H5P_DATASET_CREATE);
    if (dcpl < 0 || H5Pset_fill_value(dcpl, H5T_NATIVE_INT32, &fill) < 0 ||
        H5Pset_alloc_time(dcpl, H5D_ALLOC_TIME_EARLY) < 0 ||
        H5Pset_fill_time(dcpl, H5D_FILL_TIME_ALLOC) < 0) {
        CLOSE_ID(H5Pclose, dcpl);
        return h5err(err, res->file, path, "cannot set up the dataset");
    }
    st = create_write(res->group, "frame_stats", H5T_STD_I32LE, H5T_NATIVE_INT32, 2, dims, dcpl,
                      NULL, err);
    CLOSE_ID(H5Pclose, dcpl);
    if (st == DTX_OK)
        st = dtx_h5_write_attr_str(res->group, "frame_stats", "columns",
                                   DTX_H5_FRAME_STATS_COLUMNS, err);
    if (st == DTX_OK && (res->frame_stats = H5Dopen2(res->group, "frame_stats", H5P_DEFAULT)) < 0)
        st = h5err(err, res->file, path, "cannot open");
    return st;
}

/* Frames [first, first + count) of a per-frame dataset of a result
 * (frame_stats: rank 2 with inner columns; frame_grad_norm: rank 1), read
 * or written (collective: as for the positions) in memory type mtype. */
static dtx_status per_frame_io(const dtx_h5_result *res, hid_t dset, const char *name, int write,
                               int rank, const hsize_t *inner, hid_t mtype, void *buf,
                               int64_t first, int64_t count, int collective, dtx_error *err)
{
    char path[DTX_H5_PATH_MAX];
    hid_t dxpl = H5P_DEFAULT;
    dtx_status st;
    join_path(res->path, name, path, sizeof path);
    if (dset < 0)
        return ferr(err, DTX_EINVAL, res->file, path, "the result has no %s", name);
    if ((st = check_frames(res->file, path, res->nframes, first, count, err)) != DTX_OK)
        return st;
    if (count == 0 && (!write || !res->parallel || !collective))
        return DTX_OK;
    if (write && (dxpl = make_dxpl(res->parallel, collective)) < 0)
        return h5err(err, res->file, path, "cannot set up collective transfer");
    if (slab_io(dset, write, rank, first, count, inner, mtype, buf, dxpl) < 0)
        st = h5err(err, res->file, path, "cannot %s frames [%lld, %lld)", write ? "write" : "read",
                   (long long)first, (long long)(first + count));
    if (write)
        close_dxpl(dxpl);
    return st;
}

dtx_status dtx_h5_result_write_frame_stats(dtx_h5_result *res, int64_t first, int64_t count,
                                           const int32_t *stats, int collective, dtx_error *err)
{
    static const hsize_t inner[1] = {DTX_H5_FRAME_STATS};
    return per_frame_io(res, res->frame_stats, "frame_stats", 1, 2, inner, H5T_NATIVE_INT32,
                        (void *)stats, first, count, collective, err);
}

dtx_status dtx_h5_result_read_frame_stats(const dtx_h5_result *res, int64_t first,
                                          int64_t count, int32_t *stats, dtx_error *err)
{
    static const hsize_t inner[1] = {DTX_H5_FRAME_STATS};
    return per_frame_io(res, res->frame_stats, "frame_stats", 0, 2, inner, H5T_NATIVE_INT32, stats,
                        first, count, 0, err);
}

dtx_status dtx_h5_result_add_frame_grad_norm(dtx_h5_result *res, dtx_error *err)
{
    static const double nan_fill = NAN;
    char path[DTX_H5_PATH_MAX];
    dtx_status st;
    join_path(res->path, "frame_grad_norm", path, sizeof path);
    if (res->frame_grad_norm >= 0)
        return ferr(err, DTX_EINVAL, res->file, path, "already exists");
    st = create_filled_1d(res->group, "frame_grad_norm", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE,
                          &nan_fill, res->nframes, err);
    if (st == DTX_OK &&
        (res->frame_grad_norm = H5Dopen2(res->group, "frame_grad_norm", H5P_DEFAULT)) < 0)
        st = h5err(err, res->file, path, "cannot open");
    return st;
}

dtx_status dtx_h5_result_write_frame_grad_norm(dtx_h5_result *res, int64_t first, int64_t count,
                                               const double *grad_norm, int collective,
                                               dtx_error *err)
{
    return per_frame_io(res, res->frame_grad_norm, "frame_grad_norm", 1, 1, NULL, H5T_NATIVE_DOUBLE,
                        (void *)grad_norm, first, count, collective, err);
}

dtx_status dtx_h5_result_read_frame_grad_norm(const dtx_h5_result *res, int64_t first,
                                              int64_t count, double *grad_norm, dtx_error *err)
{
    return per_frame_io(res, res->frame_grad_norm, "frame_grad_norm", 0, 1, NULL, H5T_NATIVE_DOUBLE,
                        grad_norm, first, count, 0, err);
}

int64_t dtx_h5_grad_norm_max_frame(const double *gn, const int32_t *fs, const uint8_t *done,
                                   int64_t T)
{
    int64_t tmax = -1;
    for (int64_t t = 0; t < T; t++)
        if (done[t] && (!fs || fs[DTX_H5_FRAME_STATS * t] >= 0) &&
            (tmax < 0 || (!isnan(gn[tmax]) && !(gn[t] <= gn[tmax]))))
            tmax = t;
    return tmax;
}

dtx_status dtx_h5_result_read(const dtx_h5_result *res, int64_t first, int64_t count,
                              double *positions, double *residual, dtx_error *err)
{
    char path[DTX_H5_PATH_MAX];
    dtx_status st;
    join_path(res->path, "positions", path, sizeof path);
    if ((st = read_frames(res->file, res->positions, path, res->nframes, res->nv, res->is_f64,
                          first, count, positions, err)) != DTX_OK)
        return st;
    if (residual && count > 0 &&
        slab_io(res->residual, 0, 1, first, count, NULL, H5T_NATIVE_DOUBLE, residual,
                H5P_DEFAULT) < 0) {
        join_path(res->path, "residual", path, sizeof path);
        return h5err(err, res->file, path, "cannot read frames [%lld, %lld)", (long long)first,
                     (long long)(first + count));
    }
    return DTX_OK;
}

dtx_status dtx_h5_result_read_done(const dtx_h5_result *res, uint8_t *done, dtx_error *err)
{
    if (H5Dread(res->frame_done, H5T_NATIVE_UINT8, H5S_ALL, H5S_ALL, H5P_DEFAULT, done) < 0) {
        char path[DTX_H5_PATH_MAX];
        join_path(res->path, "frame_done", path, sizeof path);
        return h5err(err, res->file, path, "cannot read");
    }
    return DTX_OK;
}

dtx_status dtx_h5_results_finish(dtx_h5_result *const *res, int n, int replace,
                                 dtx_error *err)
{
    uint8_t *done = NULL;
    dtx_status st = DTX_OK;
    MPI_Comm comm = MPI_COMM_NULL;
    hid_t file;
    if (n <= 0)
        return DTX_OK;
    file = res[0]->file;
    /* No flush (under MPI-IO a flush is an fsync, half a second at the end
     * of a 20,000-frame run, and it would make nothing more durable: a
     * killed process loses nothing the kernel already holds, and the
     * marks and the rename after this point are not synced either).  Each
     * rank reads frame_done after the barrier, which every rank reaches
     * only once its own writes have returned; a process always reads its
     * own writes, and the flags of earlier runs are in the file since it
     * was opened, so a frame is done when any rank reads it as done: the
     * ranks' readings are combined with a maximum. */
    if (res[0]->parallel && file_comm(file, &comm) == 1)
        MPI_Barrier(comm);
    for (int k = 0; k < n && st == DTX_OK; k++) {
        dtx_h5_result *r = res[k];
        int ok;
        free(done);
        done = dtx_alloc((size_t)r->nframes, 1, 0);
        if (!done)
            st = ferr(err, DTX_ENOMEM, r->file, r->path, "out of memory");
        else
            st = dtx_h5_result_read_done(r, done, err);
        /* Every rank gets here with the same results in the same order:
         * the ranks agree on the reads before combining them, so none is
         * left waiting when one of them failed. */
        ok = st == DTX_OK;
        if (comm != MPI_COMM_NULL)
            MPI_Allreduce(MPI_IN_PLACE, &ok, 1, MPI_INT, MPI_MIN, comm);
        if (!ok) {
            if (st == DTX_OK)
                st = ferr(err, DTX_EIO, r->file, r->path,
                          "another rank could not read frame_done");
            break;
        }
        for (int64_t i0 = 0; comm != MPI_COMM_NULL && i0 < r->nframes; i0 += 1 << 30) {
            int64_t m = r->nframes - i0 < (1 << 30) ? r->nframes - i0 : (1 << 30);
            MPI_Allreduce(MPI_IN_PLACE, done + i0, (int)m, MPI_UINT8_T, MPI_MAX, comm);
        }
        for (int64_t i = 0; i < r->nframes; i++)
            if (done[i] != 1) {
                st = ferr(err, DTX_EINVAL, r->file, r->path,
                          "cannot mark the result complete: frame %lld (0-based) was not written",
                          (long long)i);
                break;
            }
    }
    if (comm != MPI_COMM_NULL)
        MPI_Comm_free(&comm);
    free(done);
    /* Only when every result is whole: mark them and move them into place. */
    for (int k = 0; k < n && st == DTX_OK; k++)
        st = dtx_h5_write_attr_int(res[k]->group, ".", "complete", 1, err);
    for (int k = 0; k < n && st == DTX_OK; k++) {
        dtx_h5_result *r = res[k];
        if (r->committed)
            continue;
        if ((st = dtx_h5_commit_group(r->file, r->path, r->final_path, replace, err)) != DTX_OK)
            break;
        snprintf(r->path, sizeof r->path, "%s", r->final_path);
        r->committed = 1;
    }
    return st;
}

dtx_status dtx_h5_result_finish(dtx_h5_result *res, int replace, dtx_error *err)
{
    dtx_status st = dtx_h5_results_finish(&res, 1, replace, err);
    return st == DTX_OK ? dtx_h5_flush(res->file, err) : st;
}

void dtx_h5_result_close(dtx_h5_result *res)
{
    if (!res)
        return;
    CLOSE_ID(H5Dclose, res->frame_grad_norm);
    CLOSE_ID(H5Dclose, res->frame_stats);
    CLOSE_ID(H5Dclose, res->frame_done);
    CLOSE_ID(H5Dclose, res->residual);
    CLOSE_ID(H5Dclose, res->positions);
    CLOSE_ID(H5Gclose, res->group);
    free(res->scratch);
    free(res->ones);
    res->scratch = NULL;
    res->ones = NULL;
    res->scratch_n = res->ones_n = 0;
}

/* ------------------------------------------------------------ frame rate */

dtx_status dtx_h5_write_fps(hid_t loc, const char *obj, double fps, dtx_error *err)
{
    char where[DTX_H5_PATH_MAX];
    if (!(fps > 0.0) || !(fps <= DTX_H5_FPS_MAX))
        return ferr(err, DTX_EINVAL, loc, obj_path(loc, obj, where, sizeof where),
                    "frame rate %g: expected a number > 0 and <= %g", fps, DTX_H5_FPS_MAX);
    return write_attr(loc, obj, "fps", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, &fps, err);
}

dtx_status dtx_h5_read_fps(hid_t loc, const char *obj, double *fps, int *stored, dtx_error *err)
{
    hid_t a, ft, sp;
    char where[DTX_H5_PATH_MAX];
    dtx_status st;
    double v = 0.0;
    htri_t e = H5Aexists_by_name(loc, obj, "fps", H5P_DEFAULT);
    *fps = DTX_H5_DEFAULT_FPS;
    *stored = 0;
    if (e < 0)
        return h5err(err, loc, obj_path(loc, obj, where, sizeof where),
                     "cannot look up attribute fps");
    if (e == 0)
        return DTX_OK;
    if ((st = open_attr(loc, obj, "fps", H5T_FLOAT, &a, &ft, &sp, err)) == DTX_OK) {
        if (H5Aread(a, H5T_NATIVE_DOUBLE, &v) < 0)
            st = h5err(err, loc, obj_path(loc, obj, where, sizeof where),
                       "cannot read attribute fps");
        else if (!(v > 0.0) || !(v <= DTX_H5_FPS_MAX)) /* NaN fails */
            st = ferr(err, DTX_EFORMAT, loc, obj_path(loc, obj, where, sizeof where),
                      "attribute fps: %g frames per second (expected > 0 and <= %g)", v,
                      DTX_H5_FPS_MAX);
        else {
            *fps = v;
            *stored = 1;
        }
    }
    CLOSE_ID(H5Sclose, sp);
    CLOSE_ID(H5Tclose, ft);
    CLOSE_ID(H5Aclose, a);
    return st;
}

dtx_status dtx_h5_copy_fps(hid_t from, hid_t to, dtx_error *err)
{
    double fps;
    int stored;
    dtx_status st = dtx_h5_read_fps(from, ".", &fps, &stored, err);
    if (st == DTX_OK && stored)
        st = dtx_h5_write_fps(to, ".", fps, err);
    return st;
}
