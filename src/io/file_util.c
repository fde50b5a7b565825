/* file_util.c: open input files only when they are regular files, without
 * ever blocking on a FIFO. */
/* realpath() is XSI, outside _POSIX_C_SOURCE; renameat2() is GNU. */
#define _GNU_SOURCE

#include "file_util.h"

#include <errno.h>
#include <fcntl.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

const char *dtx_file_kind(mode_t mode)
{
    if (S_ISREG(mode))
        return "a regular file";
    if (S_ISDIR(mode))
        return "a directory";
    if (S_ISFIFO(mode))
        return "a FIFO";
    if (S_ISCHR(mode))
        return "a character device";
    if (S_ISBLK(mode))
        return "a block device";
    if (S_ISSOCK(mode))
        return "a socket";
    if (S_ISLNK(mode))
        return "a symbolic link";
    return "of an unknown type";
}

dtx_status dtx_file_open_regular(const char *path, int *fd, struct stat *sb, dtx_error *err)
{
    struct stat s;
    int d, fl;
    *fd = -1;
    /* O_NONBLOCK: a FIFO opened for reading without it waits for a writer,
     * possibly forever; with it the open returns at once and fstat below
     * refuses the FIFO.  A socket cannot be opened at all (ENXIO). */
    d = open(path, O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
    if (d < 0) {
        if (errno == ENXIO && stat(path, &s) == 0 && !S_ISREG(s.st_mode))
            return dtx_seterr(err, DTX_EIO, "%s: not a regular file (%s)", path,
                              dtx_file_kind(s.st_mode));
        return dtx_seterr(err, DTX_EIO, "%s: cannot open: %s", path, strerror(errno));
    }
    if (fstat(d, &s) != 0) {
        int e = errno;
        close(d);
        return dtx_seterr(err, DTX_EIO, "%s: cannot stat: %s", path, strerror(e));
    }
    if (!S_ISREG(s.st_mode)) {
        close(d);
        return dtx_seterr(err, DTX_EIO, "%s: not a regular file (%s)", path,
                          dtx_file_kind(s.st_mode));
    }
    fl = fcntl(d, F_GETFL);
    if (fl < 0 || fcntl(d, F_SETFL, fl & ~O_NONBLOCK) != 0) {
        int e = errno;
        close(d);
        return dtx_seterr(err, DTX_EIO, "%s: cannot open: %s", path, strerror(e));
    }
    *fd = d;
    if (sb)
        *sb = s;
    return DTX_OK;
}

dtx_status dtx_file_check_regular(const char *path, dtx_error *err)
{
    int fd;
    dtx_status st = dtx_file_open_regular(path, &fd, NULL, err);
    if (st == DTX_OK)
        close(fd);
    return st;
}

dtx_status dtx_file_read_regular(const char *path, size_t max_bytes, char **buf, size_t *len,
                                 dtx_error *err)
{
    struct stat sb;
    char *b;
    size_t size, n = 0;
    int fd;
    dtx_status st;

    *buf = NULL;
    *len = 0;
    if ((st = dtx_file_open_regular(path, &fd, &sb, err)) != DTX_OK)
        return st;
    /* The size comes from fstat, so the limit is checked before anything is
     * allocated; only a file that grows while it is read could be larger,
     * and the read below stops at the size seen here. */
    if (sb.st_size < 0 || (uintmax_t)sb.st_size > (uintmax_t)max_bytes ||
        (uintmax_t)sb.st_size >= (uintmax_t)SIZE_MAX) {
        close(fd);
        if (max_bytes == SIZE_MAX)
            return dtx_seterr(err, DTX_ENOMEM, "%s: file too large (%jd bytes)", path,
                              (intmax_t)sb.st_size);
        return dtx_seterr(err, DTX_EIO, "%s: file too large (%jd bytes; the limit is %zu)", path,
                          (intmax_t)sb.st_size, max_bytes);
    }
    size = (size_t)sb.st_size;
    b = malloc(size + 1);
    if (!b) {
        close(fd);
        return dtx_seterr(err, DTX_ENOMEM, "%s: cannot allocate %zu bytes to read it", path,
                          size + 1);
    }
    while (n < size) {
        ssize_t got = read(fd, b + n, size - n);
        if (got < 0 && errno == EINTR)
            continue;
        if (got < 0) {
            int e = errno;
            free(b);
            close(fd);
            return dtx_seterr(err, DTX_EIO, "%s: read error: %s", path, strerror(e));
        }
        if (got == 0)
            break; /* the file shrank while it was read: keep what is there */
        n += (size_t)got;
    }
    close(fd);
    b[n] = '\0';
    *buf = b;
    *len = n;
    return DTX_OK;
}

void dtx_path_relative(const char *target, const char *from, char *out, size_t n)
{
    char *t = realpath(target, NULL), *dir = NULL, *fcopy = strdup(from), *slash;
    const char *tp, *dp;
    size_t common = 0, len = 0;
    int ups = 0, ok = 0;
    if (fcopy) {
        slash = strrchr(fcopy, '/');
        if (slash == fcopy)
            dir = realpath("/", NULL);
        else {
            if (slash)
                *slash = '\0';
            dir = realpath(slash ? fcopy : ".", NULL);
        }
    }
    if (t && dir) {
        /* The longest common leading run of whole components. */
        for (size_t i = 0;; i++) {
            if ((t[i] == '/' || t[i] == '\0') && (dir[i] == '/' || dir[i] == '\0'))
                common = i;
            if (t[i] != dir[i] || t[i] == '\0')
                break;
        }
        tp = t + common;
        dp = dir + common;
        /* Components of dir below the common part: one "../" each. */
        for (const char *c = dp; *c; c++)
            if (*c == '/')
                ups++;
        if (common > 0 && tp[0] == '/') {
            out[0] = '\0';
            ok = 1;
            for (int u = 0; u < ups && ok; u++) {
                ok = len + 3 < n;
                if (ok) {
                    memcpy(out + len, "../", 4);
                    len += 3;
                }
            }
            ok = ok && len + strlen(tp + 1) < n;
            if (ok)
                memcpy(out + len, tp + 1, strlen(tp + 1) + 1);
        }
    }
    if (!ok)
        snprintf(out, n, "%s", target);
    free(t);
    free(dir);
    free(fcopy);
}

int dtx_file_same_inode(const char *a, const char *b)
{
    struct stat sa, sb;
    if (stat(a, &sa) != 0 || stat(b, &sb) != 0)
        return -1;
    return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
}

const char *dtx_path_base_name(const char *path)
{
    const char *s = strrchr(path, '/');
    return s ? s + 1 : path;
}

dtx_status dtx_file_replace(const char *from, const char *to, int *old_left, dtx_error *err)
{
    *old_left = 0;
#ifdef RENAME_EXCHANGE
    /* rename() over an existing file makes ext4 write the new file's dirty
     * pages out and wait (its guard for programs that replace a file
     * without fsync: half a second for a 1.2 GB output).  Exchanging the
     * two names is as atomic for readers of `to` and starts no writeback;
     * the replaced file, now at `from`, is removed after. */
    struct stat sb;
    /* Only a regular file is exchanged: anything else at `to` (a directory,
     * a socket) gets rename()'s own refusal, as before, rather than being
     * moved to `from`. */
    if (lstat(to, &sb) == 0 && S_ISREG(sb.st_mode) &&
        renameat2(AT_FDCWD, from, AT_FDCWD, to, RENAME_EXCHANGE) == 0) {
        if (unlink(from) != 0)
            *old_left = 1;
        return DTX_OK;
    }
    /* ENOENT: nothing to replace; EINVAL, ENOSYS, ...: a file system or
     * kernel without exchange.  A plain rename either way. */
#endif
    if (rename(from, to) != 0)
        return dtx_seterr(err, DTX_EIO, "%s: cannot rename to %s: %s", from, to, strerror(errno));
    return DTX_OK;
}
