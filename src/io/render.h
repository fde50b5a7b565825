/*
 * render.h: pictures of meshes without a GPU or a display.  A small
 * software rasteriser (z-buffer, Lambert shading with a key light, a fill
 * light and ambient, supersampled anti-aliasing) draws meshes into panels
 * of one RGB image with orthographic cameras, and a PNG writer (libpng)
 * stores the image.
 *
 * The picture.  The image is a grid of rows x cols panels; each mesh drawn
 * (a dtx_render_panel) fills one panel.  Panels belong to camera groups:
 * all panels of a group share one camera (the same centre and scale), so
 * the frames of one sequence line up and motion shows; the bounds a group
 * is fitted to are the caller's (typically every frame of the sequence, so
 * that separately rendered frames also line up) or, when not given, those
 * of its panels.  Groups share one scale too unless same_scale is 0, each
 * centred on its own bounds.
 *
 * The camera.  World coordinates with the up_axis (y by default) upward.
 * The camera looks at the scene from the direction
 *   toward = (sin(az) cos(el), sin(el), cos(az) cos(el))   (in y-up terms)
 * so azimuth 0, elevation 0 looks from +z at the x-y plane (x to the
 * right, y up: "front"); azimuth 90 looks from +x ("side"); elevation 90
 * looks down from above ("top", -z up on the picture at azimuth 0).
 * Orthographic projection: screen right = (cos az, 0, -sin az), screen up
 * = toward x right.
 *
 * Shading.  Both sides of every face are shaded (meshes may be open): the
 * side facing the camera is lit, whatever the winding.  Lights are fixed
 * to the camera (key from the upper left, fill from the right), so every
 * view reads the same.  smooth interpolates per-vertex intensities from
 * area-weighted vertex normals (Gouraud), otherwise each face is flat.
 * Faces are coloured by connected component (over shared vertices,
 * numbered in the order of their first face, cycling through a fixed
 * palette of DTX_RENDER_PALETTE_SIZE colours) or all in one colour.
 *
 * Determinism: the image depends only on the inputs, never on the number
 * of OpenMP threads (every pixel is written by one thread, which draws the
 * faces in index order; depth ties keep the earlier face).
 *
 * Thread-safety: reentrant (no global state); dtx_render_panels uses
 * OpenMP threads inside.  No printing.
 */
#ifndef DTX_RENDER_H
#define DTX_RENDER_H

#include "status.h"

#include <stdint.h>

/* Largest width or height accepted, in pixels. */
#define DTX_RENDER_MAX_SIZE 16384
/* Number of colours of the component palette. */
#define DTX_RENDER_PALETTE_SIZE 10

typedef struct {
    int width, height;      /* image size in pixels, 1..DTX_RENDER_MAX_SIZE */
    int rows, cols;         /* the panel grid, >= 1 each */
    double azimuth_deg;     /* camera direction, see above */
    double elevation_deg;   /* in [-90, 90] */
    int up_axis;            /* world axis drawn upward: 0 x, 1 y, 2 z */
    int color_by_component; /* 1: palette by connected component; 0: `color` */
    unsigned char color[3]; /* the single colour (sRGB) */
    unsigned char background[3]; /* sRGB */
    int smooth;             /* 1: Gouraud shading; 0: flat faces */
    int supersample;        /* samples per pixel along each axis, 1..4 */
    double margin;          /* empty border, fraction of the panel side, [0, 0.45] */
    int same_scale;         /* 1: one scale for all groups; 0: one per group */
    int outline;            /* 1: darken silhouettes and depth jumps */
    int separators;         /* 1: thin lines between panels */
    int block_rows;         /* > 0: the line under every block_rows-th row is darker
                               (rows drawn together, e.g. source and target) */
} dtx_render_opts;

/* One mesh to draw and where. */
typedef struct {
    const double *X;   /* nv x 3 positions, row-major */
    int32_t nv;
    const int32_t *F;  /* nf x 3 vertex indices, 0-based; nf == 0 leaves the panel empty */
    int32_t nf;
    int row, col;      /* the panel, 0-based; at most one mesh per panel */
    int group;         /* camera group, 0..ngroups-1 */
    int palette_offset; /* palette colour of component 0 (components cycle from it) */
    const char *label; /* drawn at the panel's top left, or NULL; letters, digits
                          and " -.:/_#>" (lowercase shown as uppercase, others
                          as blanks) */
} dtx_render_panel;

/* Fills *o with the defaults: 800 x 600, one panel, azimuth 60, elevation
 * 15, y up, colour by component, clay colour, white background, smooth,
 * supersample 2, margin 0.04, same_scale 1, outline 1, separators 1,
 * block_rows 0. */
void dtx_render_opts_default(dtx_render_opts *o);

/* The camera axes in world coordinates (unit vectors): right and up on
 * the screen, toward the viewer. */
void dtx_render_axes(const dtx_render_opts *o, double right[3], double up[3],
                     double toward[3]);

/* Sets box (4 doubles: xmin, xmax, ymin, ymax on the screen plane, in world
 * units) to the empty box. */
void dtx_render_bounds_init(double box[4]);

/* Grows box by the screen-plane projections of the n points X (n x 3)
 * under the camera of o.  Non-finite points are ignored. */
void dtx_render_bounds_add(const double *X, int32_t n, const dtx_render_opts *o,
                           double box[4]);

/* The image height that fits the bounds (ngroups x 4, as from
 * dtx_render_bounds_add) into o->rows rows of panels o->width / o->cols
 * pixels wide without empty space above and below them (the labels' band
 * included when labels != 0), clamped to [1, DTX_RENDER_MAX_SIZE]. */
int dtx_render_fit_height(const double *bounds, int ngroups, int labels,
                          const dtx_render_opts *o);

/* Draws the k panels into rgb (width x height x 3 bytes, row-major, top row
 * first, caller-allocated; every pixel is written).  bounds: ngroups x 4
 * doubles, the screen-plane box each camera group is fitted to, or NULL to
 * fit each group to its panels (ngroups then ignored and taken as 1 + the
 * largest group).  Checks, before drawing: options in range, panels inside
 * the grid and not sharing a panel, groups in range, face indices in [0,
 * nv) (DTX_EINVAL / DTX_ERANGE with a message naming the panel).  DTX_ENOMEM
 * when the supersampled buffers cannot be allocated (they take
 * width * height * supersample^2 * 7 bytes). */
dtx_status dtx_render_panels(const dtx_render_panel *panels, int k, const double *bounds,
                             int ngroups, const dtx_render_opts *o, unsigned char *rgb,
                             dtx_error *err);

/* Writes rgb (width x height x 3 bytes, top row first) as an 8-bit RGB PNG
 * file, atomically (a temporary file renamed over path when complete; on
 * any failure no file is left and an existing one is untouched).  DTX_EIO
 * naming path on failure, DTX_EINVAL for sizes outside
 * 1..DTX_RENDER_MAX_SIZE. */
dtx_status dtx_png_write(const char *path, const unsigned char *rgb, int width, int height,
                         dtx_error *err);

#endif /* DTX_RENDER_H */
