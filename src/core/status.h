/*
 * status.h: the one status enum of dtx and the error record that carries a
 * message naming the file, the item and the problem.
 *
 * The core library never prints and never exits: every function that can
 * fail returns a dtx_status and, when given a non-NULL dtx_error, fills its
 * message.  Layers above decide what to print.
 */
#ifndef DTX_STATUS_H
#define DTX_STATUS_H

#include <stddef.h>
#include <stdint.h>

/* The table: one line per status, (NAME, "short description").  The enum,
 * the name function and the description function are all generated from it,
 * so they cannot disagree. */
#define DTX_STATUS_TABLE(X)                                                  \
    X(DTX_OK, "success")                                                     \
    X(DTX_ENOMEM, "out of memory")                                           \
    X(DTX_EINVAL, "invalid argument")                                        \
    X(DTX_EIO, "input/output error")                                         \
    X(DTX_EPARSE, "malformed input")                                         \
    X(DTX_ERANGE, "index or count out of range")                             \
    X(DTX_ENONFINITE, "NaN or infinite value")                               \
    X(DTX_EMESH, "mesh unsuitable for the method")                           \
    X(DTX_ESOLVE, "numerical solve failed")                                  \
    X(DTX_EFORMAT, "file does not follow the dtx layout")                    \
    X(DTX_EJOB, "invalid job")                                               \
    X(DTX_EMPI, "error reported by another rank or by MPI")

typedef enum {
#define DTX_STATUS_ENUM_(name, desc) name,
    DTX_STATUS_TABLE(DTX_STATUS_ENUM_)
#undef DTX_STATUS_ENUM_
    DTX_STATUS_COUNT
} dtx_status;

/* The error record.  msg holds a full sentence such as
 * "lion.obj:12: face index 5001 out of range (mesh has 5000 vertices)". */
typedef struct {
    dtx_status code;
    char msg[1024];
} dtx_error;

/* The enum's identifier ("DTX_EPARSE"); never NULL. */
const char *dtx_status_name(dtx_status s);
/* A short description ("malformed input"); never NULL. */
const char *dtx_status_desc(dtx_status s);

/* Sets err->code and formats err->msg (printf-style), then returns code.
 * err may be NULL, in which case only code is returned.  Thread-safe as long
 * as two threads do not share one dtx_error. */
dtx_status dtx_seterr(dtx_error *err, dtx_status code, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* Prefixes err->msg with "prefix: " (printf-style), used by callers that
 * know the context the callee did not (the file name, the job path). */
void dtx_error_prefix(dtx_error *err, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* Overflow-checked allocation of n * size bytes (zeroed when zero != 0).
 * Returns NULL on overflow or failure, and for n == 0 returns a valid
 * pointer to a 1-byte block so callers need not special-case empty arrays. */
void *dtx_alloc(size_t n, size_t size, int zero);

#endif /* DTX_STATUS_H */
