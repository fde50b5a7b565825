/*
 * markers.h: source/target vertex correspondences given by the user.
 * Indices are always 0-based in memory, whatever base the file used.
 */
#ifndef DTX_MARKERS_H
#define DTX_MARKERS_H

#include "status.h"

#include <stdint.h>

typedef struct {
    int32_t n;
    int32_t *src;  /* n source vertex indices, owned */
    int32_t *tgt;  /* n target vertex indices, owned */
    char **labels; /* n NUL-terminated labels (may be ""), owned; may be NULL */
} dtx_markers;

/* Allocates room for n markers (labels all NULL). */
dtx_status dtx_markers_alloc(dtx_markers *m, int32_t n, dtx_error *err);

/* Frees everything and zeroes the struct.  Accepts NULL. */
void dtx_markers_free(dtx_markers *m);

/* Checks indices against the mesh sizes and rejects a source or target
 * vertex used by two markers.  `what` names the marker set in messages. */
dtx_status dtx_markers_validate(const dtx_markers *m, int32_t src_nv, int32_t tgt_nv,
                                const char *what, dtx_error *err);

#endif /* DTX_MARKERS_H */
