/*
 * markers.h: source/target vertex correspondences given by the user.
 * Indices are always 0-based in memory, whatever base the file used.
 */
#ifndef DTX_MARKERS_H
#define DTX_MARKERS_H

#include "mesh.h"
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

/* Checks indices against the mesh sizes (DTX_ERANGE, the message asks
 * whether the index base is right) and rejects a source or target vertex
 * used by two markers (DTX_EINVAL, naming both markers and their labels),
 * and an empty set (DTX_EINVAL).  `what` names the marker set in messages;
 * markers are numbered from 0 in them, in the order of the set. */
dtx_status dtx_markers_validate(const dtx_markers *m, int32_t src_nv, int32_t tgt_nv,
                                const char *what, dtx_error *err);

/* After dtx_markers_validate against src: rejects (DTX_EINVAL) a marker
 * whose source vertex is in no face of src.  The correspondence moves the
 * marked source vertices onto their target vertices; a source vertex in no
 * face moves no triangle, so such a marker constrains nothing (usually a
 * wrong index base or the wrong mesh).  A target vertex in no face is
 * accepted: its position is still a place to move to.  DTX_ENOMEM when out
 * of memory.  Thread-safe. */
dtx_status dtx_markers_check_referenced(const dtx_markers *m, const dtx_mesh *src, const char *what,
                                        dtx_error *err);

#endif /* DTX_MARKERS_H */
