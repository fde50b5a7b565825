/*
 * h5guard.c: a sec2-like HDF5 file driver that refuses corrupt global heap
 * collections before HDF5 1.10.8 loops over them (see h5guard.h).
 *
 * The driver is a plain POSIX one: one descriptor, pread/pwrite at the
 * address HDF5 asks for, reads past the end of the file give zeros (as
 * sec2), the file is truncated to HDF5's end of allocated space on flush
 * and close, and HDF5's file locking is flock, as in sec2.  Same-file
 * detection compares device and inode, so two opens of one file share one
 * HDF5 file object as they do under sec2.
 */
#define _GNU_SOURCE 1
#include "h5guard.h"

#include <errno.h>
#include <fcntl.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

/* Largest address: as sec2, what an off_t can hold. */
#define GUARD_MAXADDR ((haddr_t)(((uint64_t)1 << 62) - 1))
/* Layout constants of HDF5 1.10.8's global heap (H5HGpkg.h). */
#define GH_ALIGN(x) ((uint64_t)8 * (((uint64_t)(x) + 7) / 8))

typedef struct {
    H5FD_t pub; /* must stay first: HDF5 sees this part */
    int fd;
    haddr_t eoa;
    haddr_t eof;
    dev_t dev;
    ino_t ino;
    unsigned sizeof_size; /* from the superblock once read; 8 until then */
    /* HDF5 reads a collection larger than its first guess in two parts
     * (H5C_load_entry reads only the rest the second time): the first part
     * waits here until the rest arrives, so the whole is checked. */
    unsigned char *head;
    size_t head_n;
    haddr_t head_addr;
    uint64_t head_total;
} guard_file;

static hid_t guard_id = H5I_INVALID_HID;

static void push_error(H5E_major_t maj, H5E_minor_t min, const char *msg)
{
    (void)H5Epush2(H5E_DEFAULT, __FILE__, "dtx_h5_guard", __LINE__, H5E_ERR_CLS, maj, min, "%s",
                   msg);
}

static void push_errno(H5E_minor_t min, const char *what, int e)
{
    char msg[256];
    snprintf(msg, sizeof msg, "%s: %s", what, strerror(e));
    push_error(H5E_IO, min, msg);
}

/* ========================================================= heap checking */

/* Little-endian unsigned of n bytes; values beyond 64 bits saturate. */
static uint64_t decode_len(const unsigned char *p, unsigned n)
{
    uint64_t v = 0;
    for (unsigned k = n; k-- > 0;) {
        if (k >= 8) {
            if (p[k])
                return UINT64_MAX;
            continue;
        }
        v = (v << 8) | p[k];
    }
    return v;
}

int dtx_h5_guard_check_gheap(const unsigned char *buf, size_t n, unsigned sizeof_size,
                             char *why, size_t why_n)
{
    const uint64_t hdr = 8u + sizeof_size, objhdr = 8u + sizeof_size;
    uint64_t size, off;
    if (sizeof_size == 0 || sizeof_size > 16 || n < hdr || memcmp(buf, "GCOL", 4) != 0 ||
        buf[4] != 1)
        return 0;
    size = decode_len(buf + 8, sizeof_size);
    if (size > n)
        return 0; /* HDF5 reads the whole collection again; checked then */
    /* The walk of H5HG__cache_heap_deserialize, step by step. */
    for (off = hdr; off < size;) {
        uint64_t rem = size - off, osize, need;
        unsigned idx;
        if (rem < objhdr)
            break; /* a tail too small for a header is free space */
        idx = (unsigned)buf[off] | (unsigned)buf[off + 1] << 8;
        osize = decode_len(buf + off + 8, sizeof_size);
        if (idx == 0) {
            /* The free space: its size counts its own header. */
            if (osize == 0 || osize > rem) {
                snprintf(why, why_n,
                         "free space at offset %llu has size %llu, but %llu bytes are left",
                         (unsigned long long)off, (unsigned long long)osize,
                         (unsigned long long)rem);
                return -1;
            }
            need = osize;
        } else {
            if (osize > rem - objhdr) {
                snprintf(why, why_n,
                         "object %u at offset %llu has size %llu, but %llu bytes are left",
                         idx, (unsigned long long)off, (unsigned long long)osize,
                         (unsigned long long)(rem - objhdr));
                return -1;
            }
            need = objhdr + GH_ALIGN(osize);
        }
        if (need >= rem)
            break;
        off += need;
    }
    return 1;
}

/* The sizes of the file's lengths, from a superblock image (0 if buf is not
 * one): byte 14 in versions 0 and 1, byte 10 in versions 2 and 3. */
static unsigned superblock_sizeof_size(const unsigned char *buf, size_t n)
{
    static const unsigned char sig[8] = {0x89, 'H', 'D', 'F', '\r', '\n', 0x1a, '\n'};
    if (n < 15 || memcmp(buf, sig, 8) != 0)
        return 0;
    if (buf[8] <= 1)
        return buf[14];
    if (buf[8] <= 3)
        return buf[10];
    return 0;
}

/* ================================================================ driver */

static H5FD_t *guard_open(const char *name, unsigned flags, hid_t fapl, haddr_t maxaddr)
{
    int o = (flags & H5F_ACC_RDWR) ? O_RDWR : O_RDONLY;
    guard_file *f;
    struct stat sb;
    int fd;
    (void)fapl;
    if (!name || !*name || maxaddr == 0 || maxaddr == HADDR_UNDEF || maxaddr > GUARD_MAXADDR) {
        push_error(H5E_ARGS, H5E_BADVALUE, "invalid file name or address space");
        return NULL;
    }
    if (flags & H5F_ACC_TRUNC)
        o |= O_TRUNC;
    if (flags & H5F_ACC_CREAT)
        o |= O_CREAT;
    if (flags & H5F_ACC_EXCL)
        o |= O_EXCL;
    fd = open(name, o | O_CLOEXEC, 0666);
    if (fd < 0) {
        push_errno(H5E_CANTOPENFILE, "cannot open the file", errno);
        return NULL;
    }
    if (fstat(fd, &sb) != 0) {
        push_errno(H5E_BADFILE, "cannot fstat the file", errno);
        close(fd);
        return NULL;
    }
    f = calloc(1, sizeof *f);
    if (!f) {
        push_error(H5E_RESOURCE, H5E_NOSPACE, "out of memory");
        close(fd);
        return NULL;
    }
    f->fd = fd;
    f->eof = (haddr_t)sb.st_size;
    f->dev = sb.st_dev;
    f->ino = sb.st_ino;
    f->sizeof_size = 8;
    return &f->pub;
}

static herr_t guard_close(H5FD_t *file)
{
    guard_file *f = (guard_file *)file;
    int r = close(f->fd);
    int e = errno;
    free(f->head);
    free(f);
    if (r != 0) {
        push_errno(H5E_CANTCLOSEFILE, "cannot close the file", e);
        return -1;
    }
    return 0;
}

static int guard_cmp(const H5FD_t *a, const H5FD_t *b)
{
    const guard_file *f = (const guard_file *)a, *g = (const guard_file *)b;
    if (f->dev != g->dev)
        return f->dev < g->dev ? -1 : 1;
    if (f->ino != g->ino)
        return f->ino < g->ino ? -1 : 1;
    return 0;
}

static herr_t guard_query(const H5FD_t *file, unsigned long *flags)
{
    (void)file;
    /* As sec2. */
    *flags = H5FD_FEAT_AGGREGATE_METADATA | H5FD_FEAT_ACCUMULATE_METADATA |
             H5FD_FEAT_DATA_SIEVE | H5FD_FEAT_AGGREGATE_SMALLDATA;
    return 0;
}

static haddr_t guard_get_eoa(const H5FD_t *file, H5FD_mem_t type)
{
    (void)type;
    return ((const guard_file *)file)->eoa;
}

static herr_t guard_set_eoa(H5FD_t *file, H5FD_mem_t type, haddr_t addr)
{
    (void)type;
    ((guard_file *)file)->eoa = addr;
    return 0;
}

static haddr_t guard_get_eof(const H5FD_t *file, H5FD_mem_t type)
{
    (void)type;
    return ((const guard_file *)file)->eof;
}

static herr_t guard_get_handle(H5FD_t *file, hid_t fapl, void **handle)
{
    (void)fapl;
    *handle = &((guard_file *)file)->fd;
    return 0;
}

static int bad_region(haddr_t addr, size_t size)
{
    return addr == HADDR_UNDEF || addr > GUARD_MAXADDR || (haddr_t)size > GUARD_MAXADDR - addr;
}

static herr_t heap_error(haddr_t addr, const char *why)
{
    char msg[300];
    snprintf(msg, sizeof msg, "corrupt global heap collection at address %llu: %s",
             (unsigned long long)addr, why);
    push_error(H5E_HEAP, H5E_BADVALUE, msg);
    return -1;
}

/* Checks a raw-data read that is (the first or the second part of) a
 * global heap collection. */
static herr_t check_draw(guard_file *f, haddr_t addr, size_t size, const unsigned char *buf)
{
    char why[200];
    int r;
    if (f->head && addr == f->head_addr + f->head_n && size == f->head_total - f->head_n) {
        /* The rest of the collection whose start waits in f->head. */
        unsigned char *all = malloc(f->head_total);
        haddr_t start = f->head_addr;
        if (!all) {
            push_error(H5E_RESOURCE, H5E_NOSPACE, "out of memory");
            return -1;
        }
        memcpy(all, f->head, f->head_n);
        memcpy(all + f->head_n, buf, size);
        r = dtx_h5_guard_check_gheap(all, f->head_total, f->sizeof_size, why, sizeof why);
        free(all);
        free(f->head);
        f->head = NULL;
        return r < 0 ? heap_error(start, why) : 0;
    }
    r = dtx_h5_guard_check_gheap(buf, size, f->sizeof_size, why, sizeof why);
    if (r < 0)
        return heap_error(addr, why);
    if (r == 0 && size >= 8u + f->sizeof_size && memcmp(buf, "GCOL\x01", 5) == 0) {
        /* The start of a collection larger than this read: keep it. */
        uint64_t total = decode_len(buf + 8, f->sizeof_size);
        if (total > size && total <= f->eoa - addr) {
            free(f->head);
            f->head = malloc(size);
            if (!f->head) {
                push_error(H5E_RESOURCE, H5E_NOSPACE, "out of memory");
                return -1;
            }
            memcpy(f->head, buf, size);
            f->head_n = size;
            f->head_addr = addr;
            f->head_total = total;
        }
    }
    return 0;
}

static herr_t guard_read(H5FD_t *file, H5FD_mem_t type, hid_t dxpl, haddr_t addr, size_t size,
                         void *buffer)
{
    guard_file *f = (guard_file *)file;
    unsigned char *p = buffer;
    size_t left = size;
    haddr_t at = addr;
    (void)dxpl;
    if (bad_region(addr, size) || addr + size > f->eoa) {
        push_error(H5E_ARGS, H5E_OVERFLOW, "read beyond the end of allocated space");
        return -1;
    }
    while (left > 0) {
        ssize_t got = pread(f->fd, p, left > ((size_t)1 << 30) ? (size_t)1 << 30 : left,
                            (off_t)at);
        if (got < 0 && errno == EINTR)
            continue;
        if (got < 0) {
            push_errno(H5E_READERROR, "cannot read the file", errno);
            return -1;
        }
        if (got == 0) {
            memset(p, 0, left); /* past the end of the file: zeros, as sec2 */
            break;
        }
        p += got;
        left -= (size_t)got;
        at += (haddr_t)got;
    }
    if (type == H5FD_MEM_SUPER) {
        unsigned s = superblock_sizeof_size(buffer, size);
        if (s == 2 || s == 4 || s == 8 || s == 16)
            f->sizeof_size = s;
    } else if (type == H5FD_MEM_DRAW) {
        return check_draw(f, addr, size, buffer);
    }
    return 0;
}

static herr_t guard_write(H5FD_t *file, H5FD_mem_t type, hid_t dxpl, haddr_t addr, size_t size,
                          const void *buffer)
{
    guard_file *f = (guard_file *)file;
    const unsigned char *p = buffer;
    size_t left = size;
    haddr_t at = addr;
    (void)type;
    (void)dxpl;
    if (bad_region(addr, size) || addr + size > f->eoa) {
        push_error(H5E_ARGS, H5E_OVERFLOW, "write beyond the end of allocated space");
        return -1;
    }
    while (left > 0) {
        ssize_t put = pwrite(f->fd, p, left > ((size_t)1 << 30) ? (size_t)1 << 30 : left,
                             (off_t)at);
        if (put < 0 && errno == EINTR)
            continue;
        if (put <= 0) {
            push_errno(H5E_WRITEERROR, "cannot write the file", put < 0 ? errno : EIO);
            return -1;
        }
        p += put;
        left -= (size_t)put;
        at += (haddr_t)put;
    }
    if (at > f->eof)
        f->eof = at;
    return 0;
}

static herr_t guard_truncate(H5FD_t *file, hid_t dxpl, hbool_t closing)
{
    guard_file *f = (guard_file *)file;
    (void)dxpl;
    (void)closing;
    if (f->eoa == f->eof)
        return 0;
    if (ftruncate(f->fd, (off_t)f->eoa) != 0) {
        push_errno(H5E_SEEKERROR, "cannot set the file's size", errno);
        return -1;
    }
    f->eof = f->eoa;
    return 0;
}

static herr_t guard_lock(H5FD_t *file, hbool_t rw)
{
    guard_file *f = (guard_file *)file;
    if (flock(f->fd, (rw ? LOCK_EX : LOCK_SH) | LOCK_NB) != 0 && errno != ENOSYS) {
        push_errno(H5E_CANTLOCKFILE, "unable to lock the file", errno);
        return -1;
    }
    return 0;
}

static herr_t guard_unlock(H5FD_t *file)
{
    guard_file *f = (guard_file *)file;
    if (flock(f->fd, LOCK_UN) != 0 && errno != ENOSYS) {
        push_errno(H5E_CANTUNLOCKFILE, "unable to unlock the file", errno);
        return -1;
    }
    return 0;
}

static const H5FD_class_t guard_class = {
    .name = "dtx_guard",
    .maxaddr = GUARD_MAXADDR,
    .fc_degree = H5F_CLOSE_WEAK,
    .open = guard_open,
    .close = guard_close,
    .cmp = guard_cmp,
    .query = guard_query,
    .get_eoa = guard_get_eoa,
    .set_eoa = guard_set_eoa,
    .get_eof = guard_get_eof,
    .get_handle = guard_get_handle,
    .read = guard_read,
    .write = guard_write,
    .truncate = guard_truncate,
    .lock = guard_lock,
    .unlock = guard_unlock,
    .fl_map = H5FD_FLMAP_DICHOTOMY,
};

herr_t dtx_h5_guard_set_fapl(hid_t fapl)
{
    if (guard_id < 0 || H5Iis_valid(guard_id) <= 0)
        guard_id = H5FDregister(&guard_class);
    if (guard_id < 0)
        return -1;
    return H5Pset_driver(fapl, guard_id, NULL);
}
