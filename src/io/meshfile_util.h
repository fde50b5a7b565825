/*
 * meshfile_util.h: internal helpers shared by the mesh and marker readers
 * (obj.c, ply.c, off.c, markers_csv.c).  Not part of the public API.
 *
 * The text helpers work on a bounded buffer [begin, end) that need not be
 * NUL-terminated, and never read outside it.  All functions are reentrant.
 */
#ifndef DTX_MESHFILE_UTIL_H
#define DTX_MESHFILE_UTIL_H

#include "meshfile.h"
#include "status.h"

#include <stddef.h>
#include <stdint.h>

/* Numbers (and integers) longer than this many characters are rejected as
 * malformed: no real coordinate needs more, and the parsers copy each token
 * into a fixed stack buffer to give strtod a terminated string. */
#define DTX_MAX_NUMBER_LEN 127

/* Reads the whole file at path into a new buffer *buf (malloc'd, freed by
 * the caller with free) of *len bytes, plus one NUL byte at (*buf)[*len].
 * Only a regular file is read: a FIFO, a device or a directory is DTX_EIO
 * with "path: not a regular file (a FIFO)" before anything is read
 * (dtx_file_read_regular in file_util.h).  DTX_EIO with "path: cannot open:
 * reason" and the like on failure, in which case *buf is NULL. */
dtx_status dtx_file_read_all(const char *path, char **buf, size_t *len, dtx_error *err);

/* Appends triangle (a, b, c) to the growable array *F of *cap triangles of
 * which *nt are used (doubling the capacity when full, from 8 when empty).
 * Returns 0, or -1 on overflow or allocation failure (*F left intact). */
int dtx_tri_push(int32_t **F, size_t *cap, int64_t *nt, int32_t a, int32_t b, int32_t c);

/* A reader's in-memory parser (dtx_obj_parse and its PLY/OFF twins). */
typedef dtx_status (*dtx_mesh_parse_fn)(const char *name, const char *buf, size_t len,
                                        dtx_mesh *out, const dtx_warner *w, dtx_error *err);

/* Reads the whole file at path and hands it to parse (named by path in
 * messages); *out is zeroed first and left empty on failure. */
dtx_status dtx_mesh_read_with(const char *path, dtx_mesh_parse_fn parse, dtx_mesh *out,
                              const dtx_warner *w, dtx_error *err);

/* The OBJ and OFF readers' warning that npoly polygons (the first at line
 * first_line) were fan-triangulated; nothing when npoly is 0. */
void dtx_warn_fanned(const dtx_warner *w, const char *name, int64_t npoly, long first_line);

/* Hands a parsed mesh to out: V (nv x 3) and F (nf x 3), now out's. */
void dtx_mesh_take(dtx_mesh *out, int64_t nv, int64_t nf, double *V, int32_t *F);

/* Formats a warning (printf-style) and hands it to w->fn; does nothing when
 * w or w->fn is NULL. */
void dtx_warnf(const dtx_warner *w, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* 1 if the len bytes at buf contain a NUL byte. */
int dtx_has_nul(const char *buf, size_t len);

/* Line iterator over [begin, end).  Lines end at "\n", "\r\n" or a lone
 * "\r" (Unix, Windows and classic Mac OS line ends, mixed freely); the end
 * of line is not part of the line.  A UTF-8 byte-order mark at the start of
 * the buffer is skipped. */
typedef struct {
    const char *cur; /* start of the next line */
    const char *end; /* end of the buffer */
    long line;       /* 1-based number of the line last returned */
} dtx_lines;

void dtx_lines_init(dtx_lines *it, const char *buf, size_t len);

/* Sets [*b, *e) to the next line (end of line excluded) and returns 1, or
 * returns 0 when the buffer is exhausted. */
int dtx_lines_next(dtx_lines *it, const char **b, const char **e);

/* 1 for the blanks that separate tokens: space, \t, \r, \v, \f. */
static inline int dtx_is_blank(char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}

/* Skips blanks from *p; returns the start of the next token in [*p, e) and
 * sets *n to its length (a token ends at a blank or at e), advancing *p past
 * it.  Returns NULL (and leaves *p at e) when no token remains. */
const char *dtx_next_token(const char **p, const char *e, size_t *n);

/* Parses the n characters at s as a whole floating-point number with
 * strtod (nothing may follow it).  Returns 0 on success, -1 when it is not a
 * number.  "nan", "inf" and overflowing values are accepted here (they give
 * non-finite values, which the callers reject with DTX_ENONFINITE). */
int dtx_parse_double(const char *s, size_t n, double *out);

/* Parses the n characters at s as a whole decimal integer with an optional
 * sign.  Returns 0 on success, -1 when it is not an integer, -2 when it is
 * an integer outside the int64 range (*out is then clamped). */
int dtx_parse_int64(const char *s, size_t n, int64_t *out);

/* Copies the n characters at s into out (size outsz >= 8) for quoting in a
 * message: truncated with "..." when long, non-printable bytes as '?'.
 * Returns out. */
const char *dtx_show_token(const char *s, size_t n, char *out, size_t outsz);

#endif /* DTX_MESHFILE_UTIL_H */
