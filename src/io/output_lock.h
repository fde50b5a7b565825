/*
 * output_lock.h: one writer per output file, on local disks and on cluster
 * file systems alike.
 *
 * The lock is the file OUTPUT.lock beside the output, created exclusively:
 * its contents are written to a temporary file (O_CREAT | O_EXCL) that is
 * then hard-linked to OUTPUT.lock, so the lock never exists half-written.
 * link() fails with EEXIST atomically on local file systems, NFS (v2 on),
 * Lustre, GPFS and BeeGFS, unlike flock/fcntl locks, which some of them
 * ignore or keep per node.  It holds the host name, the process id and the start time of
 * the run that holds it, so that a refused run can name it.  A run killed
 * with SIGKILL leaves the file behind:
 *   - on the host that wrote it, a lock whose process no longer exists is
 *     recognised as stale and replaced (the caller is told, to say so);
 *   - elsewhere (another host of a cluster) staleness cannot be seen: the
 *     user checks that the named run is gone, then breaks the lock
 *     (break_lock = 1, `dtx run --break-lock`) or removes the file.
 * Replacing a stale lock goes through a second exclusive file
 * (OUTPUT.lock.break), so two runs that find the same stale lock cannot
 * both take it.
 *
 * Not thread-safe for one lock object; meant for one process (rank 0).
 */
#ifndef DTX_OUTPUT_LOCK_H
#define DTX_OUTPUT_LOCK_H

#include "status.h"

#include <stddef.h>

typedef struct {
    char *path; /* OUTPUT.lock (owned), NULL when not held */
} dtx_output_lock;

/* The lock file's name for output: "OUTPUT.lock" (malloc'ed; NULL when out
 * of memory). */
char *dtx_output_lock_path(const char *output);

/* Takes the lock of output.  break_lock = 1 first removes an existing lock
 * whoever holds it (the user has checked that its run is gone).  On
 * success lk holds the lock, and `note` (n bytes, may be NULL) receives a
 * sentence to show the user when a stale or broken lock was replaced,
 * else "".  Fails with DTX_EIO and a message that names the other run
 * (host, pid, start time), the lock file and how to break a stale lock
 * when the lock is held, or the system's reason when the lock file cannot
 * be created (no directory, no write permission).  lk is zeroed on
 * failure. */
dtx_status dtx_output_lock_acquire(const char *output, int break_lock, dtx_output_lock *lk,
                                   char *note, size_t n, dtx_error *err);

/* Removes the lock file if lk holds it; lk is zeroed.  Accepts a zeroed
 * lk.  Returns 0, or -1 when the file could not be removed (errno set). */
int dtx_output_lock_release(dtx_output_lock *lk);

#endif /* DTX_OUTPUT_LOCK_H */
