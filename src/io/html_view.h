/*
 * html_view.h: the browser workbench page of `dtx view`: one self-contained
 * HTML file (three.js, the viewer's code and the data inlined) that works
 * opened from disk with no server and no network.
 *
 * Two modes:
 * - player: panes side by side (a source sequence, results), synchronised,
 *   with play/pause, a frame slider, speed, loop, a shared orbit camera,
 *   wireframe and flat/smooth shading, colouring by the frame's residual or
 *   by the distance to another pane of the same mesh, markers as labelled
 *   balls;
 * - pick: a source and a target mesh; clicks make marker pairs (snapped to
 *   the nearest vertex of the triangle hit), listed, selectable, movable,
 *   deletable, undoable; "Download CSV" writes what `dtx import markers`
 *   reads (with its "# index_base: 0" line).  Key points of the source are
 *   offered as the source side of the next pairs.
 *
 * Safety with data from elsewhere: every text from the files (paths, names,
 * labels, attributes) goes into the page only as JSON inside
 * <script type="application/json"> with '<', '>' and '&' written as \u003c,
 * \u003e, \u0026, and the page inserts text only through textContent.  The
 * page's Content-Security-Policy allows no network access (default-src
 * 'none', connect-src 'none') and runs only its own script, named by its
 * SHA-256 hash (script-src 'sha256-...'; no 'unsafe-inline').
 *
 * Frame data: faces as int32 and rest positions as float32, little-endian,
 * base64; frames quantised per pane and axis to 16 bits over the pane's
 * bounding box of the embedded frames (error at most half a step:
 * extent / 131070 per axis), each frame stored as its difference to the one
 * before (modulo 2^16), low bytes then high bytes, gzip-compressed (the page
 * inflates them with the browser's DecompressionStream).
 */
#ifndef DTX_HTML_VIEW_H
#define DTX_HTML_VIEW_H

#include "markers.h"
#include "mesh.h"
#include "status.h"

#include <stddef.h>
#include <stdint.h>

/* One pane.  Nothing is taken over; everything must outlive the call. */
typedef struct {
    const char *title;      /* shown above the pane (an HDF5 path; any bytes) */
    const char *kind;       /* "sequence", "result" or "mesh" */
    const char *info;       /* one line of provenance, or NULL */
    const char *group;      /* panes of equal group (their mesh's path) can be
                               compared vertex by vertex; NULL: none */
    const dtx_mesh *mesh;   /* faces and rest positions */
    int64_t nframes;        /* frames given (0: the rest mesh only) */
    const int64_t *frame;   /* nframes file frame numbers */
    const double *frames;   /* nframes x nv x 3 doubles, or NULL */
    const double *residual; /* nframes residuals, or NULL */
    int marker_side;        /* markers drawn on this pane: 0 none, 1 their
                               source vertices, 2 their target vertices */
} dtx_view_pane;

typedef struct {
    int pick;                    /* 0: player; 1: picking (panes[0] source,
                                    panes[1] target) */
    const char *file;            /* the input file's name, shown */
    const dtx_view_pane *panes;
    int npanes;                  /* 1..16 */
    int64_t file_frames;         /* frames of the longest sequence in the file */
    int64_t stride;              /* every stride-th frame embedded */
    int64_t max_frames;          /* the frame budget, stated on the page */
    const dtx_markers *markers;  /* NULL: none */
    const char *markers_name;    /* where they came from, or NULL */
    const int32_t *keypoints;    /* nkeypoints source vertices, or NULL */
    char *const *keypoint_labels; /* nkeypoints labels, or NULL */
    int32_t nkeypoints;
    const char *keypoints_name;
    const char *report;          /* Markdown text shown below the player (its
                                    headings, lists and tables drawn as such,
                                    everything else as text), or NULL */
} dtx_view_page;

/* 1 when this dtx carries three.js (it was found at build time), else 0;
 * without it dtx_view_write fails with DTX_EINVAL and a message saying how
 * to get it. */
int dtx_view_available(void);

/* Writes the page to path atomically (atomic_file.h).  DTX_EINVAL for a
 * page that breaks the rules above (panes, counts, marker indices out of
 * range of the meshes they are drawn on), DTX_ENONFINITE for a NaN or
 * infinite coordinate, DTX_EIO when the file cannot be written; the message
 * names path and the problem, and nothing is left at path then. */
dtx_status dtx_view_write(const char *path, const dtx_view_page *pg, dtx_error *err);

/* Helpers, exposed for tests.  Base64 (RFC 4648, with padding) of n bytes
 * into out, which must hold 4 * ((n + 2) / 3) + 1 bytes; returns the
 * length written (without the NUL). */
size_t dtx_base64(const void *data, size_t n, char *out);

/* SHA-256 of n bytes into digest[32]. */
void dtx_sha256(const void *data, size_t n, unsigned char digest[32]);

/* A JSON string literal of s (quotes included) safe inside an HTML
 * <script> element: '"', '\\' and control characters escaped as JSON
 * requires, and '<', '>', '&' as \u003c, \u003e, \u0026.  Invalid UTF-8
 * bytes become U+FFFD.  Returns a malloc'ed string (caller frees) or NULL
 * when out of memory. */
char *dtx_json_html_string(const char *s);

#endif /* DTX_HTML_VIEW_H */
