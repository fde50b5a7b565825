/*
 * write_reason.h: the system's reason for a failed write, when the library
 * that failed (HDF5, MPI-IO) did not pass it on.
 *
 * HDF5 over MPI-IO often reports only "file write failed", and errno may
 * have been overwritten by the time the error reaches dtx.  These checks
 * look at the state that made the write fail instead: the errno saved
 * right after the failing call when it is one that only writes give, the
 * free space of the file system holding the file, and the process's
 * file-size limit.
 */
#ifndef DTX_WRITE_REASON_H
#define DTX_WRITE_REASON_H

#include <stddef.h>

/* Writes into buf (n bytes) the likely reason a write to path failed, as a
 * phrase such as "No space left on device (12 KiB free on the file system
 * of PATH)" or "File too large (the file-size limit, ulimit -f, is 1024000
 * bytes)", or "" when none is seen.  saved_errno is errno as saved right
 * after the failure (0 when unknown).  Returns buf.  Thread-safe. */
const char *dtx_write_reason(const char *path, int saved_errno, char *buf, size_t n);

#endif /* DTX_WRITE_REASON_H */
