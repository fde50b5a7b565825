/* atomic_file.c: temporary file + fsync + rename, so that no partial file is
 * ever visible at the final path. */
#include "atomic_file.h"

#include <errno.h>
#include <fcntl.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

/* Distinguishes temporary names made by concurrent calls in one process. */
static atomic_uint dtx_atomic_counter_;

static char *dup_str(const char *s)
{
    size_t n = strlen(s) + 1;
    char *d = malloc(n);
    if (d)
        memcpy(d, s, n);
    return d;
}

/* The directory part of path ("." when it has none), as a new string. */
static char *dir_of(const char *path)
{
    const char *slash = strrchr(path, '/');
    char *d;
    size_t n;
    if (!slash)
        return dup_str(".");
    n = slash == path ? 1 : (size_t)(slash - path);
    d = malloc(n + 1);
    if (d) {
        memcpy(d, path, n);
        d[n] = '\0';
    }
    return d;
}

dtx_status dtx_atomic_open(dtx_atomic_file *af, const char *path, dtx_error *err)
{
    const char *slash = strrchr(path, '/');
    const char *base = slash ? slash + 1 : path;
    size_t dirlen = slash ? (size_t)(slash - path + 1) : 0;
    size_t cap;
    int fd = -1;
    dtx_status st;

    memset(af, 0, sizeof *af);
    if (*base == '\0')
        return dtx_seterr(err, DTX_EINVAL, "%s: not a file name", path);
    af->path = dup_str(path);
    cap = strlen(path) + 64;
    af->tmp_path = malloc(cap);
    if (!af->path || !af->tmp_path) {
        st = dtx_seterr(err, DTX_ENOMEM, "%s: out of memory", path);
        goto fail;
    }
    for (int attempt = 0; attempt < 100; attempt++) {
        struct timespec ts;
        unsigned k = atomic_fetch_add(&dtx_atomic_counter_, 1u);
        clock_gettime(CLOCK_REALTIME, &ts);
        snprintf(af->tmp_path, cap, "%.*s.%s.tmp-%ld-%u-%lx", (int)dirlen, path, base,
                 (long)getpid(), k, (unsigned long)ts.tv_nsec);
        /* O_EXCL: never reuse (or follow a link at) an existing name; 0666
         * so the umask decides the final permissions like for fopen. */
        fd = open(af->tmp_path, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (fd >= 0 || errno != EEXIST)
            break;
    }
    if (fd < 0) {
        st = dtx_seterr(err, DTX_EIO, "%s: cannot create a temporary file next to it: %s", path,
                        strerror(errno));
        goto fail;
    }
    af->fp = fdopen(fd, "wb");
    if (!af->fp) {
        st = dtx_seterr(err, DTX_EIO, "%s: cannot open a stream: %s", path, strerror(errno));
        close(fd);
        unlink(af->tmp_path);
        goto fail;
    }
    setvbuf(af->fp, NULL, _IOFBF, 1 << 16);
    return DTX_OK;

fail:
    free(af->path);
    free(af->tmp_path);
    memset(af, 0, sizeof *af);
    return st;
}

void dtx_atomic_abort(dtx_atomic_file *af)
{
    if (af->fp)
        fclose(af->fp);
    if (af->tmp_path)
        unlink(af->tmp_path);
    free(af->path);
    free(af->tmp_path);
    memset(af, 0, sizeof *af);
}

dtx_status dtx_atomic_commit(dtx_atomic_file *af, dtx_error *err)
{
    FILE *fp = af->fp;
    char *dir;
    int dfd;
    dtx_status st;

    if (!fp)
        return dtx_seterr(err, DTX_EINVAL, "atomic file committed twice or never opened");
    af->fp = NULL;
    if (fflush(fp) != 0 || ferror(fp)) {
        st = dtx_seterr(err, DTX_EIO, "%s: write error: %s", af->path, strerror(errno));
        fclose(fp);
        goto fail;
    }
    if (fsync(fileno(fp)) != 0) {
        st = dtx_seterr(err, DTX_EIO, "%s: fsync failed: %s", af->path, strerror(errno));
        fclose(fp);
        goto fail;
    }
    if (fclose(fp) != 0) {
        st = dtx_seterr(err, DTX_EIO, "%s: close failed: %s", af->path, strerror(errno));
        goto fail;
    }
    if (rename(af->tmp_path, af->path) != 0) {
        st = dtx_seterr(err, DTX_EIO, "%s: cannot rename the temporary file into place: %s",
                        af->path, strerror(errno));
        goto fail;
    }
    /* Make the rename itself durable.  Some file systems refuse fsync on a
     * directory; the data is written by then, so that is not an error. */
    dir = dir_of(af->path);
    if (dir) {
        dfd = open(dir, O_RDONLY | O_CLOEXEC);
        if (dfd >= 0) {
            (void)fsync(dfd);
            close(dfd);
        }
        free(dir);
    }
    free(af->path);
    free(af->tmp_path);
    memset(af, 0, sizeof *af);
    return DTX_OK;

fail:
    unlink(af->tmp_path);
    free(af->path);
    free(af->tmp_path);
    memset(af, 0, sizeof *af);
    return st;
}
