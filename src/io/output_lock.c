/*
 * output_lock.c: OUTPUT.lock, created exclusively (see output_lock.h).
 */
#define _GNU_SOURCE
#include "output_lock.h"

#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

typedef struct {
    char host[256];
    long pid;
    char started[64];
    int parsed; /* host and pid were read */
    char text[1024];
} holder;

char *dtx_output_lock_path(const char *output)
{
    char *p = malloc(strlen(output) + sizeof ".lock");
    if (p)
        sprintf(p, "%s.lock", output);
    return p;
}

static void host_name(char *buf, size_t n)
{
    if (gethostname(buf, n) != 0)
        snprintf(buf, n, "?");
    buf[n - 1] = '\0';
}

/* Creates path exclusively, holding this process's details: they are
 * written to a temporary file first, which is then hard-linked to path, so
 * that the lock appears with its contents complete (link() fails with
 * EEXIST when path exists, atomically, on NFS too; there a lost reply is
 * recognised by the temporary file's link count).  0, or -1 with errno
 * (EEXIST: it exists). */
static int write_lock(const char *path, const char *output)
{
    char host[256], when[64], text[4400], *tmp;
    time_t now = time(NULL);
    struct tm tmv;
    struct stat sb;
    int fd, len, e = 0, r;
    host_name(host, sizeof host);
    if (localtime_r(&now, &tmv))
        strftime(when, sizeof when, "%Y-%m-%d %H:%M:%S %Z", &tmv);
    else
        snprintf(when, sizeof when, "?");
    tmp = malloc(strlen(path) + strlen(host) + 48);
    if (!tmp) {
        errno = ENOMEM;
        return -1;
    }
    sprintf(tmp, "%s.%s.%ld.tmp", path, host, (long)getpid());
    unlink(tmp); /* our own, left by an earlier attempt */
    fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (fd < 0) {
        e = errno;
        free(tmp);
        errno = e;
        return -1;
    }
    len = snprintf(text, sizeof text,
                   "dtx output lock\nhost: %s\npid: %ld\nstarted: %s\nepoch: %lld\noutput: %s\n",
                   host, (long)getpid(), when, (long long)now, output);
    if (len < 0 || (size_t)len >= sizeof text)
        len = (int)strlen(text);
    if (write(fd, text, (size_t)len) != (ssize_t)len || fsync(fd) != 0)
        e = errno ? errno : EIO;
    if (close(fd) != 0 && !e)
        e = errno;
    r = -1;
    if (!e) {
        r = link(tmp, path);
        if (r != 0) {
            e = errno;
            if (e != EEXIST && stat(tmp, &sb) == 0 && sb.st_nlink == 2)
                r = 0;
        }
    }
    unlink(tmp);
    free(tmp);
    if (r != 0)
        errno = e;
    return r;
}

/* Reads the lock at path.  0 (h filled; h->parsed says whether host and
 * pid were found), or -1 with errno (ENOENT: it is gone). */
static int read_holder(const char *path, holder *h)
{
    FILE *f = fopen(path, "r");
    size_t n;
    char *p;
    memset(h, 0, sizeof *h);
    if (!f)
        return -1;
    n = fread(h->text, 1, sizeof h->text - 1, f);
    fclose(f);
    h->text[n] = '\0';
    if ((p = strstr(h->text, "\nhost: ")) != NULL)
        sscanf(p + 7, "%255[^\n]", h->host);
    if ((p = strstr(h->text, "\npid: ")) != NULL && sscanf(p + 6, "%ld", &h->pid) == 1 &&
        h->host[0] && h->pid > 0)
        h->parsed = 1;
    if ((p = strstr(h->text, "\nstarted: ")) != NULL)
        sscanf(p + 10, "%63[^\n]", h->started);
    if (!h->started[0])
        snprintf(h->started, sizeof h->started, "unknown");
    return 0;
}

/* 1 when process pid is a zombie (killed, not yet reaped: a rank whose
 * mpirun was killed too waits for a parent that may never reap it). */
static int is_zombie(long pid)
{
    char path[64], buf[512], *p;
    size_t n;
    FILE *f;
    snprintf(path, sizeof path, "/proc/%ld/stat", pid);
    if (!(f = fopen(path, "r")))
        return 0;
    n = fread(buf, 1, sizeof buf - 1, f);
    fclose(f);
    buf[n] = '\0';
    /* "pid (comm) S ...": the command may hold spaces and parentheses. */
    p = strrchr(buf, ')');
    return p && (p[1] == ' ') && (p[2] == 'Z' || p[2] == 'X');
}

/* 1 when h was written on this host by a process that no longer exists
 * (or is a zombie). */
static int is_stale(const holder *h)
{
    char host[256];
    if (!h->parsed)
        return 0;
    host_name(host, sizeof host);
    if (strcmp(host, h->host) != 0)
        return 0;
    if (kill((pid_t)h->pid, 0) != 0)
        return errno == ESRCH;
    return is_zombie(h->pid);
}

static dtx_status held(const char *output, const char *lockp, const holder *h, dtx_error *err)
{
    if (!h->parsed)
        return dtx_seterr(err, DTX_EIO,
                          "%s is locked by another dtx run (the lock file %s does not say which: "
                          "it is being written, or damaged); if no run is writing %s, remove "
                          "%s or run again with --break-lock",
                          output, lockp, output, lockp);
    return dtx_seterr(err, DTX_EIO,
                      "%s is being written by another dtx run: host %s, pid %ld, started %s "
                      "(lock file %s). Wait for it to finish; if that run is gone (killed or "
                      "crashed), check on host %s that process %ld is not dtx, then run again "
                      "with --break-lock (or remove %s)",
                      output, h->host, h->pid, h->started, lockp, h->host, h->pid, lockp);
}

dtx_status dtx_output_lock_acquire(const char *output, int break_lock, dtx_output_lock *lk,
                                   char *note, size_t n, dtx_error *err)
{
    char *lockp = dtx_output_lock_path(output), *breakp = NULL;
    holder h, h2;
    dtx_status st = DTX_OK;
    memset(lk, 0, sizeof *lk);
    if (note && n)
        note[0] = '\0';
    if (!lockp || !(breakp = malloc(strlen(lockp) + sizeof ".break"))) {
        free(lockp);
        return dtx_seterr(err, DTX_ENOMEM, "out of memory");
    }
    sprintf(breakp, "%s.break", lockp);
    if (break_lock) {
        if (read_holder(lockp, &h) == 0 && note && n)
            snprintf(note, n, "removed the lock %s (host %s, pid %ld, started %s) as asked by "
                     "--break-lock", lockp, h.parsed ? h.host : "?", h.parsed ? h.pid : 0L,
                     h.started);
        if (unlink(lockp) != 0 && errno != ENOENT) {
            st = dtx_seterr(err, DTX_EIO, "%s: cannot remove the lock: %s", lockp,
                            strerror(errno));
            goto done;
        }
        unlink(breakp);
    }
    /* A lock released between our create and our read is taken again; a
     * few rounds settle any such race. */
    for (int round = 0; round < 4; round++) {
        if (write_lock(lockp, output) == 0) {
            lk->path = lockp;
            lockp = NULL;
            goto done;
        }
        if (errno != EEXIST) {
            st = dtx_seterr(err, DTX_EIO,
                            "%s: cannot create the output's lock file: %s (is the output's "
                            "directory there and writable?)",
                            lockp, strerror(errno));
            goto done;
        }
        if (read_holder(lockp, &h) != 0) {
            if (errno == ENOENT)
                continue; /* released meanwhile */
            st = dtx_seterr(err, DTX_EIO, "%s: cannot read the lock file: %s", lockp,
                            strerror(errno));
            goto done;
        }
        if (!is_stale(&h)) {
            st = held(output, lockp, &h, err);
            goto done;
        }
        /* Stale: replace it under the second exclusive file, after
         * checking that it is still the same stale lock. */
        {
            int fd = open(breakp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
            int replaced = 0;
            if (fd < 0) {
                st = errno == EEXIST
                         ? dtx_seterr(err, DTX_EIO,
                                      "%s: another dtx run is replacing the stale lock of pid "
                                      "%ld (%s exists); if no run is starting on %s, remove %s "
                                      "or run again with --break-lock",
                                      lockp, h.pid, breakp, output, breakp)
                         : dtx_seterr(err, DTX_EIO, "%s: cannot create: %s", breakp,
                                      strerror(errno));
                goto done;
            }
            close(fd);
            if (read_holder(lockp, &h2) == 0 && strcmp(h.text, h2.text) == 0 &&
                unlink(lockp) == 0)
                replaced = write_lock(lockp, output) == 0;
            unlink(breakp);
            if (replaced) {
                if (note && n)
                    snprintf(note, n,
                             "replaced the stale lock %s of pid %ld (started %s), which is no "
                             "longer running on this host",
                             lockp, h.pid, h.started);
                lk->path = lockp;
                lockp = NULL;
                goto done;
            }
        }
    }
    if (read_holder(lockp, &h) == 0)
        st = held(output, lockp, &h, err);
    else
        st = dtx_seterr(err, DTX_EIO, "%s: cannot take the output's lock (it keeps changing)",
                        lockp);
done:
    free(lockp);
    free(breakp);
    return st;
}

int dtx_output_lock_release(dtx_output_lock *lk)
{
    int r = 0;
    if (lk->path && unlink(lk->path) != 0 && errno != ENOENT)
        r = -1;
    free(lk->path);
    lk->path = NULL;
    return r;
}
