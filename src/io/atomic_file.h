/*
 * atomic_file.h: writing a file so that readers see either the old file or
 * the complete new one, never a partial file.
 *
 * The data goes to a temporary file created in the directory of the final
 * path (so the rename cannot cross file systems); commit flushes it, fsyncs
 * it, renames it over the final path and fsyncs the directory.  abort (or a
 * failed commit) removes the temporary file.
 *
 * Usage:
 *   dtx_atomic_file af;
 *   if ((st = dtx_atomic_open(&af, path, err)) != DTX_OK) return st;
 *   fprintf(af.fp, ...);                      // any stdio output
 *   return dtx_atomic_commit(&af, err);       // or dtx_atomic_abort(&af)
 *
 * Write errors on af.fp need not be checked one by one: commit checks the
 * stream's error flag and fails (removing the temporary file) if any write
 * failed.  Thread-safe for distinct dtx_atomic_file objects (temporary names
 * are unique per process, thread and call).
 */
#ifndef DTX_ATOMIC_FILE_H
#define DTX_ATOMIC_FILE_H

#include "status.h"

#include <stdio.h>

typedef struct {
    FILE *fp;       /* the temporary file, open for writing */
    char *path;     /* final path (owned copy) */
    char *tmp_path; /* temporary path (owned) */
} dtx_atomic_file;

/* Creates the temporary file "<dir>/.<name>.tmp-<unique>" with mode 0666
 * minus the umask, and opens af->fp on it (fully buffered).  DTX_EIO (the
 * message names path and the reason) when the directory does not exist or
 * is not writable; af is then zeroed. */
dtx_status dtx_atomic_open(dtx_atomic_file *af, const char *path, dtx_error *err);

/* Flushes, fsyncs and closes the temporary file, renames it to the final
 * path and fsyncs the directory.  On any failure removes the temporary file
 * and returns DTX_EIO.  af is zeroed in both cases. */
dtx_status dtx_atomic_commit(dtx_atomic_file *af, dtx_error *err);

/* Closes and removes the temporary file; af is zeroed.  Accepts a zeroed
 * (already committed or aborted) af. */
void dtx_atomic_abort(dtx_atomic_file *af);

#endif /* DTX_ATOMIC_FILE_H */
