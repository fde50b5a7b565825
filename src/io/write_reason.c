/*
 * write_reason.c: why a write failed (see write_reason.h).
 */
#include "write_reason.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/statvfs.h>

/* Below this much free space a failed write is put down to a full disk. */
#define NEARLY_FULL_BYTES ((unsigned long long)4 << 20)

const char *dtx_write_reason(const char *path, int saved_errno, char *buf, size_t n)
{
    struct statvfs vfs;
    struct rlimit rl;
    char dir[4096];
    char *slash;
    if (n == 0)
        return buf;
    buf[0] = '\0';
    if (saved_errno == ENOSPC || saved_errno == EDQUOT || saved_errno == EFBIG ||
        saved_errno == EROFS) {
        snprintf(buf, n, "%s", strerror(saved_errno));
        return buf;
    }
    snprintf(dir, sizeof dir, "%s", path && path[0] ? path : ".");
    slash = strrchr(dir, '/');
    if (!slash)
        snprintf(dir, sizeof dir, ".");
    else if (slash == dir)
        dir[1] = '\0';
    else
        *slash = '\0';
    if (statvfs(dir, &vfs) == 0) {
        unsigned long long avail = (unsigned long long)vfs.f_bavail * vfs.f_frsize;
        if (avail < NEARLY_FULL_BYTES) {
            snprintf(buf, n, "%s (%llu KiB free on the file system of %s)", strerror(ENOSPC),
                     avail / 1024, dir);
            return buf;
        }
        if (vfs.f_favail == 0 && vfs.f_files > 0) {
            snprintf(buf, n, "%s (no free inodes on the file system of %s)", strerror(ENOSPC),
                     dir);
            return buf;
        }
    }
    if (getrlimit(RLIMIT_FSIZE, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY) {
        snprintf(buf, n, "%s? (the file-size limit, ulimit -f, is %llu bytes)", strerror(EFBIG),
                 (unsigned long long)rl.rlim_cur);
        return buf;
    }
    if (saved_errno == EIO)
        snprintf(buf, n, "%s", strerror(saved_errno));
    return buf;
}
