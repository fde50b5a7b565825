/*
 * cmd_render.c: `dtx render`.  Reads what to draw (a mesh file, or a mesh,
 * a sequence or a result of a dtx HDF5 file), picks the frames, fits one
 * camera per row to the bounds of all the row's frames (every frame of the
 * sequence, not only the drawn ones, so pictures of different frames line
 * up), draws the panels (src/io/render.h) and writes the PNG atomically.
 *
 * A result is drawn as a contact sheet with the source sequence's frames
 * (found through the result's source_sequence attribute, "FILE:PATH") in a
 * row above the result's frames; both rows share one scale.
 */
#include "cmd_render.h"

#include "cli_util.h"
#include "options.h"

#include "file_util.h"
#include "h5layout.h"
#include "meshfile.h"
#include "path_guard.h"
#include "render.h"

#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

/* Most frames one picture shows. */
#define MAX_FRAMES 1024
/* Default number of frames of a contact sheet, and the default view: a
 * three-quarter view from the side and a little above, which shows the
 * legs and the head of the bundled animals (y up, facing +z). */
#define DEFAULT_COUNT 10
#define DEFAULT_AZIMUTH 55.0
#define DEFAULT_ELEVATION 15.0

typedef struct {
    const char *input, *item, *out;
    const char *frames, *count, *cols, *width, *height, *view, *up, *color, *supersample;
    int no_source, no_labels, flat;
    dtx_error *capture; /* dtx_render_sheet: errors go here, not to stderr */
} render_args;

/* What an HDF5 item is. */
enum { K_MESH, K_SEQ, K_RESULT };

/* A source of frames: an open sequence or result. */
typedef struct {
    int is_result;
    dtx_h5_seq seq;
    dtx_h5_result res;
    int64_t nframes;
    int32_t nv;
} frame_source;

/* One row of the picture: the faces, the drawn frames and the bounds of
 * every frame. */
typedef struct {
    char name[64];
    dtx_mesh mesh;  /* faces; vertices unused unless a single mesh */
    double *X;      /* nsel x nv x 3, the drawn frames */
    double box[4];
    int palette_offset;
    unsigned char *mark; /* nsel: MARK_* of each drawn frame */
    char where[DTX_H5_PATH_MAX + 512]; /* "FILE: PATH", for warnings */
} row;

/* Drawn frames that are not what they should be: their label says so. */
enum { MARK_OK, MARK_NONFINITE, MARK_NOT_DONE };

/* dtx_cli_fail() or, for dtx_render_sheet, the error kept in a->capture. */
static int fail_or_keep(const render_args *a, const dtx_error *err)
{
    if (!a->capture)
        return dtx_cli_fail(err);
    *a->capture = *err;
    return 1;
}

static int usage_or_keep(const render_args *a, const char *msg)
{
    if (!a->capture)
        return dtx_cli_usage(dtx_cli_find_name("render"), msg);
    dtx_seterr(a->capture, DTX_EINVAL, "%s", msg);
    return 2;
}

/* ------------------------------------------------------------------ */
/* Arguments                                                           */
/* ------------------------------------------------------------------ */

/* Parses argv[2..] into *a.  Returns NULL, or a usage message (which may
 * point into buf). */
static const char *parse_args(int argc, char **argv, render_args *a, char *buf, size_t n)
{
    static const dtx_cli_slot valued[] = {
        {"-o", offsetof(render_args, out)},
        {"--frames", offsetof(render_args, frames)},
        {"--count", offsetof(render_args, count)},
        {"--cols", offsetof(render_args, cols)},
        {"--width", offsetof(render_args, width)},
        {"--height", offsetof(render_args, height)},
        {"--view", offsetof(render_args, view)},
        {"--up", offsetof(render_args, up)},
        {"--color", offsetof(render_args, color)},
        {"--supersample", offsetof(render_args, supersample)},
    };
    int npos = 0;
    memset(a, 0, sizeof *a);
    for (int i = 2; i < argc; i++) {
        const char *s = argv[i];
        int took = dtx_cli_take_slot("render", valued, sizeof valued / sizeof *valued, 0, a, argc,
                                     argv, &i, buf, n);
        if (took < 0)
            return buf;
        if (took > 0)
            continue;
        if (strcmp(s, "--no-source") == 0) {
            a->no_source = 1;
        } else if (strcmp(s, "--no-labels") == 0) {
            a->no_labels = 1;
        } else if (strcmp(s, "--flat") == 0) {
            a->flat = 1;
        } else if (s[0] == '-' && s[1] != '\0') {
            snprintf(buf, n, "render: unknown option %s", s);
            return buf;
        } else if (npos == 0) {
            a->input = s, npos++;
        } else if (npos == 1) {
            a->item = s, npos++;
        } else {
            snprintf(buf, n, "render: unexpected argument %s (one input and one item at most)",
                     s);
            return buf;
        }
    }
    if (!a->input)
        return "render needs an input file";
    if (!a->out)
        return "render needs -o OUT.png";
    if (a->frames && a->count)
        return "render: give --frames or --count, not both";
    return NULL;
}

/* A whole-string integer in [lo, hi]. */
static int parse_int(const char *s, long lo, long hi, int *out)
{
    char *end;
    long v;
    errno = 0;
    v = strtol(s, &end, 10);
    if (errno || end == s || *end != '\0' || v < lo || v > hi)
        return -1;
    *out = (int)v;
    return 0;
}

static int parse_double(const char *s, char **end, double *out)
{
    errno = 0;
    *out = strtod(s, end);
    return errno || *end == s ? -1 : 0;
}

/* side, front, back, top or "AZ,EL" in degrees. */
static int parse_view(const char *s, double *az, double *el)
{
    static const struct {
        const char *name;
        double az, el;
    } named[] = {{"side", 90, 0}, {"front", 0, 0}, {"back", 180, 0}, {"top", 0, 90}};
    char *end;
    for (size_t i = 0; i < sizeof named / sizeof *named; i++)
        if (strcmp(s, named[i].name) == 0) {
            *az = named[i].az, *el = named[i].el;
            return 0;
        }
    if (parse_double(s, &end, az) != 0 || *end != ',')
        return -1;
    if (parse_double(end + 1, &end, el) != 0 || *end != '\0')
        return -1;
    return isfinite(*az) && *el >= -90.0 && *el <= 90.0 ? 0 : -1;
}

/* "component" or RRGGBB (with or without '#'). */
static int parse_color(const char *s, dtx_render_opts *o)
{
    unsigned v = 0;
    if (strcmp(s, "component") == 0) {
        o->color_by_component = 1;
        return 0;
    }
    if (*s == '#')
        s++;
    if (strlen(s) != 6)
        return -1;
    for (int i = 0; i < 6; i++) {
        char c = s[i];
        int d = c >= '0' && c <= '9' ? c - '0'
                : c >= 'a' && c <= 'f' ? c - 'a' + 10
                : c >= 'A' && c <= 'F' ? c - 'A' + 10
                                       : -1;
        if (d < 0)
            return -1;
        v = v * 16 + (unsigned)d;
    }
    o->color_by_component = 0;
    o->color[0] = (unsigned char)(v >> 16);
    o->color[1] = (unsigned char)(v >> 8);
    o->color[2] = (unsigned char)v;
    return 0;
}

/* The options that do not depend on the input; a usage message or NULL. */
static const char *make_opts(const render_args *a, dtx_render_opts *o)
{
    int v;
    dtx_render_opts_default(o);
    o->azimuth_deg = DEFAULT_AZIMUTH;
    o->elevation_deg = DEFAULT_ELEVATION;
    if (a->view && parse_view(a->view, &o->azimuth_deg, &o->elevation_deg) != 0)
        return "render: --view must be side, front, back, top or AZ,EL in degrees "
               "(elevation in [-90, 90])";
    if (a->up) {
        if (strcmp(a->up, "x") == 0)
            o->up_axis = 0;
        else if (strcmp(a->up, "y") == 0)
            o->up_axis = 1;
        else if (strcmp(a->up, "z") == 0)
            o->up_axis = 2;
        else
            return "render: --up must be x, y or z";
    }
    if (a->color && parse_color(a->color, o) != 0)
        return "render: --color must be component or a colour RRGGBB (hex)";
    if (a->supersample) {
        if (parse_int(a->supersample, 1, 4, &v) != 0)
            return "render: --supersample must be 1, 2, 3 or 4";
        o->supersample = v;
    }
    if (a->width) {
        if (parse_int(a->width, 1, DTX_RENDER_MAX_SIZE, &v) != 0)
            return "render: --width must be a whole number of pixels in 1..16384";
        o->width = v;
    }
    if (a->height) {
        if (parse_int(a->height, 1, DTX_RENDER_MAX_SIZE, &v) != 0)
            return "render: --height must be a whole number of pixels in 1..16384";
        o->height = v;
    }
    o->smooth = !a->flat;
    return NULL;
}

/* The frames to draw, out of T: --frames (a list), --count (evenly
 * spaced, first and last included) or the default count.  *nsel receives
 * their number; a usage message, an error (DTX_ERANGE in err, then "" is
 * returned) or NULL. */
static const char *select_frames(const render_args *a, int64_t T, const char *what,
                                 int64_t *sel, int *nsel, dtx_error *err)
{
    int n = 0;
    if (a->frames) {
        const char *s = a->frames;
        while (*s) {
            char *end;
            long long v;
            errno = 0;
            v = strtoll(s, &end, 10);
            if (errno || end == s || (*end != ',' && *end != '\0') || v < 0)
                return "render: --frames must be a comma-separated list of frame numbers "
                       "(0-based), e.g. 0,4,8";
            if (n == MAX_FRAMES)
                return "render: at most 1024 frames in one picture";
            if (v >= T) {
                dtx_seterr(err, DTX_ERANGE, "%s has %lld frames (0..%lld): frame %lld is out "
                           "of range", what, (long long)T, (long long)T - 1, v);
                return "";
            }
            sel[n++] = v;
            s = *end ? end + 1 : end;
            if (*end == ',' && *s == '\0')
                return "render: --frames must not end with a comma";
        }
    } else {
        int count = DEFAULT_COUNT;
        if (a->count && parse_int(a->count, 1, MAX_FRAMES, &count) != 0)
            return "render: --count must be a number of frames in 1..1024";
        if (count > T)
            count = (int)T;
        for (int i = 0; i < count; i++)
            sel[n++] = count == 1 ? 0 : (int64_t)((double)i * (double)(T - 1) / (count - 1) + 0.5);
    }
    if (n == 0)
        return "render: --frames is empty";
    *nsel = n;
    return NULL;
}

/* ------------------------------------------------------------------ */
/* Finding what to draw in an HDF5 file                                */
/* ------------------------------------------------------------------ */

static int kind_of(hid_t f, const char *path, int *kind)
{
    char p[DTX_H5_PATH_MAX + 16];
    snprintf(p, sizeof p, "%s/frame_done", path);
    if (dtx_h5_path_exists(f, p))
        return *kind = K_RESULT, 0;
    snprintf(p, sizeof p, "%s/positions", path);
    if (dtx_h5_path_exists(f, p))
        return *kind = K_SEQ, 0;
    snprintf(p, sizeof p, "%s/vertices", path);
    if (dtx_h5_path_exists(f, p))
        return *kind = K_MESH, 0;
    return -1;
}

/* The results directly under group (paths appended to found, n of cap). */
static dtx_status results_under(hid_t f, const char *group, char (*found)[DTX_H5_PATH_MAX],
                                int *n, int cap, dtx_error *err)
{
    char **names = NULL;
    int64_t m = 0;
    dtx_status st = dtx_h5_list_groups(f, group, &names, &m, err);
    for (int64_t i = 0; st == DTX_OK && i < m; i++) {
        char p[DTX_H5_PATH_MAX];
        int kind;
        if ((size_t)snprintf(p, sizeof p, "%s/%s", strcmp(group, "/") ? group : "", names[i]) >=
            sizeof p)
            continue;
        if (kind_of(f, p, &kind) == 0 && kind == K_RESULT) {
            if (*n < cap)
                memcpy(found[*n], p, sizeof p);
            (*n)++;
        }
    }
    dtx_h5_free_strings(&names, m);
    return st;
}

/* "a, b, c and N more" of the first entries of found into buf. */
static void list_paths(char (*found)[DTX_H5_PATH_MAX], int n, int cap, char *buf, size_t len)
{
    size_t used = 0;
    buf[0] = '\0';
    for (int i = 0; i < n && i < cap && used < len; i++)
        used += (size_t)snprintf(buf + used, len - used, "%s%s", i ? ", " : "", found[i]);
    if (n > cap && used < len)
        snprintf(buf + used, len - used, " and %d more", n - cap);
}

/* Resolves the item (or, when NULL, the file's only result or sequence)
 * to a path and a kind. */
static dtx_status resolve_item(hid_t f, const char *file, const char *item, char *path,
                               int *kind, dtx_error *err)
{
    enum { CAP = 6 };
    char found[CAP][DTX_H5_PATH_MAX], list[1024];
    int n = 0;
    dtx_status st;
    if (item) {
        if (item[0] != '/' || strlen(item) >= DTX_H5_PATH_MAX)
            return dtx_seterr(err, DTX_EINVAL, "%s: %s is not an absolute HDF5 path "
                              "(e.g. /results/lion/cat-poses)", file, item);
        if (!dtx_h5_path_exists(f, item))
            return dtx_seterr(err, DTX_EINVAL, "%s: no object %s", file, item);
        if (kind_of(f, item, kind) == 0) {
            snprintf(path, DTX_H5_PATH_MAX, "%s", item);
            return DTX_OK;
        }
        /* A target's group (/results/lion) with one result under it. */
        if ((st = results_under(f, item, found, &n, CAP, err)) != DTX_OK)
            return dtx_seterr(err, DTX_EINVAL, "%s: %s is not a mesh, a sequence or a result",
                              file, item);
    } else {
        char **targets = NULL;
        int64_t nt = 0;
        if (dtx_h5_path_exists(f, "/results")) {
            if ((st = dtx_h5_list_groups(f, "/results", &targets, &nt, err)) != DTX_OK)
                return st;
            for (int64_t i = 0; i < nt && st == DTX_OK; i++) {
                char g[DTX_H5_PATH_MAX];
                snprintf(g, sizeof g, "/results/%s", targets[i]);
                st = results_under(f, g, found, &n, CAP, err);
            }
            dtx_h5_free_strings(&targets, nt);
            if (st != DTX_OK)
                return st;
        }
        if (n == 0 && dtx_h5_path_exists(f, "/sequences")) {
            char **seqs = NULL;
            int64_t ns = 0;
            if ((st = dtx_h5_list_groups(f, "/sequences", &seqs, &ns, err)) != DTX_OK)
                return st;
            for (int64_t i = 0; i < ns; i++, n++)
                if (n < CAP)
                    snprintf(found[n], DTX_H5_PATH_MAX, "/sequences/%s", seqs[i]);
            dtx_h5_free_strings(&seqs, ns);
        }
        if (n == 0)
            return dtx_seterr(err, DTX_EINVAL,
                              "%s: holds no result or sequence; name what to draw "
                              "(e.g. /meshes/NAME)", file);
    }
    if (n == 1) {
        memcpy(path, found[0], DTX_H5_PATH_MAX);
        return kind_of(f, path, kind) == 0
                   ? DTX_OK
                   : dtx_seterr(err, DTX_EFORMAT, "%s: %s is not a mesh, a sequence or a result",
                                file, path);
    }
    if (n == 0)
        return dtx_seterr(err, DTX_EINVAL, "%s: %s is not a mesh, a sequence or a result", file,
                          item);
    list_paths(found, n, CAP, list, sizeof list);
    return dtx_seterr(err, DTX_EINVAL, "%s%s%s holds %d results or sequences (%s): name one",
                      file, item ? ": " : "", item ? item : "", n, list);
}

/* The last component of an HDF5 path; for a result /results/T/S the target
 * name T. */
static void short_name(const char *path, int kind, char *out, size_t n)
{
    const char *end = path + strlen(path), *start;
    if (kind == K_RESULT) {
        const char *slash = strrchr(path, '/');
        if (slash && slash > path)
            end = slash;
    }
    start = end;
    while (start > path && start[-1] != '/')
        start--;
    snprintf(out, n, "%.*s", (int)(end - start), start);
}

/* Splits a result's source_sequence "FILE:PATH" and finds FILE: as stored,
 * then (when relative) resolved against the result file's folder, then its
 * base name in the result file's folder (the files were moved together).
 * PATH starts with '/'; the last ":/" that gives an existing file wins.
 * When none exists, the message names the file and the places looked at. */
static dtx_status find_source(const char *result_file, const char *where, const char *ref,
                              char *file, size_t fn, char *path, dtx_error *err)
{
    const char *dir_end = strrchr(result_file, '/');
    int dlen = dir_end ? (int)(dir_end - result_file) : 0;
    char want[4096] = "", tried[3 * 4096 + 16] = "";
    for (const char *p = ref + strlen(ref); p > ref;) {
        const char *c = p - 1, *base;
        while (c > ref && !(c[0] == ':' && c[1] == '/'))
            c--;
        if (c <= ref)
            break;
        p = c;
        if ((size_t)(c - ref) >= fn || strlen(c + 1) >= DTX_H5_PATH_MAX)
            continue;
        snprintf(path, DTX_H5_PATH_MAX, "%s", c + 1);
        snprintf(file, fn, "%.*s", (int)(c - ref), ref);
        if (!want[0])
            snprintf(want, sizeof want, "%s", file);
        if (access(file, R_OK) == 0)
            return DTX_OK;
        if (file[0] != '/' && dir_end &&
            (size_t)snprintf(file, fn, "%.*s/%.*s", dlen, result_file, (int)(c - ref), ref) <
                fn &&
            access(file, R_OK) == 0)
            return DTX_OK;
        base = c;
        while (base > ref && base[-1] != '/')
            base--;
        if ((size_t)snprintf(file, fn, "%.*s%s%.*s", dlen, result_file, dir_end ? "/" : "",
                             (int)(c - base), base) < fn &&
            access(file, R_OK) == 0)
            return DTX_OK;
        if (!tried[0] && want[0]) {
            char rel[4096 + 8];
            snprintf(rel, sizeof rel, "%.*s%s", dlen, result_file, dir_end ? "/" : "./");
            snprintf(tried, sizeof tried, "%s%s%s%.*s", want[0] != '/' ? rel : "",
                     want[0] != '/' ? want : "", want[0] != '/' ? ", " : "", (int)(fn - 1),
                     file);
        }
    }
    if (ref[0] == '/' && strchr(ref, ':') == NULL) {
        /* A path in the result's own file. */
        snprintf(file, fn, "%s", result_file);
        snprintf(path, DTX_H5_PATH_MAX, "%s", ref);
        return DTX_OK;
    }
    if (want[0])
        return dtx_seterr(err, DTX_EIO,
                          "%s: the file of the source sequence \"%s\" is missing or unreadable: "
                          "%s (also looked for %s)",
                          where, ref, want, tried);
    return dtx_seterr(err, DTX_EIO,
                      "%s: the source sequence \"%s\" names no file (expected FILE:/PATH)",
                      where, ref);
}

/* ------------------------------------------------------------------ */
/* Reading frames                                                      */
/* ------------------------------------------------------------------ */

static dtx_status read_frame(const frame_source *s, int64_t t, double *X, dtx_error *err)
{
    return s->is_result ? dtx_h5_result_read(&s->res, t, 1, X, NULL, err)
                        : dtx_h5_seq_read(&s->seq, t, 1, X, err);
}

/* Up to 8 frame numbers "2, 7, ..." of the drawn frames marked `mark`. */
static void marked_list(const row *r, const int64_t *sel, int nsel, int mark, char *buf,
                        size_t n)
{
    size_t used = 0;
    int shown = 0;
    buf[0] = '\0';
    for (int j = 0; j < nsel; j++) {
        int w;
        if (r->mark[j] != mark)
            continue;
        w = shown < 8 ? snprintf(buf + used, n - used, "%s%lld", shown ? ", " : "",
                                 (long long)sel[j])
                      : snprintf(buf + used, n - used, ", ...");
        if (w < 0 || (size_t)w >= n - used || shown++ == 8)
            break;
        used += (size_t)w;
    }
    if (!shown)
        snprintf(buf, n, "none");
}

/* Reads every frame of s: grows r->box by each, keeps the selected ones
 * in r->X.  Frames of a result not marked done hold undefined values: they
 * are not read, add nothing to the bounds and are drawn as empty panels
 * labelled NOT DONE.  Frames with non-finite coordinates are drawn without
 * the triangles that touch them and labelled NAN.  Both are warned about,
 * naming the object and the frames. */
static dtx_status load_row(const frame_source *s, const int64_t *sel, int nsel,
                           const dtx_render_opts *o, row *r, dtx_error *err)
{
    size_t fsz = (size_t)s->nv * 3;
    double *buf = dtx_alloc(fsz, sizeof *buf, 0);
    uint8_t *done = s->is_result ? dtx_alloc((size_t)s->nframes, 1, 0) : NULL;
    dtx_status st = DTX_OK;
    int64_t nbad = 0, bad_f = -1, bad_v = -1, nundone = 0, undone_f = -1;
    char w[1024], list[128];
    r->X = dtx_alloc((size_t)nsel, fsz * sizeof *r->X, 0);
    r->mark = dtx_alloc((size_t)nsel, 1, 1);
    if (!buf || !r->X || !r->mark || (s->is_result && !done)) {
        free(buf);
        free(done);
        return dtx_seterr(err, DTX_ENOMEM, "out of memory for %d frames of %d vertices", nsel,
                          (int)s->nv);
    }
    if (done)
        st = dtx_h5_result_read_done(&s->res, done, err);
    dtx_render_bounds_init(r->box);
    for (int64_t t = 0; t < s->nframes && st == DTX_OK; t++) {
        int mark = MARK_OK;
        if (done && done[t] != 1) {
            mark = MARK_NOT_DONE;
            if (nundone++ == 0)
                undone_f = t;
        } else {
            if ((st = read_frame(s, t, buf, err)) != DTX_OK)
                break;
            for (size_t i = 0; i < fsz; i++)
                if (!isfinite(buf[i])) {
                    mark = MARK_NONFINITE;
                    if (nbad++ == 0)
                        bad_f = t, bad_v = (int64_t)(i / 3);
                    break;
                }
            dtx_render_bounds_add(buf, s->nv, o, r->box);
        }
        for (int j = 0; j < nsel; j++)
            if (sel[j] == t) {
                r->mark[j] = (unsigned char)mark;
                if (mark != MARK_NOT_DONE)
                    memcpy(r->X + (size_t)j * fsz, buf, fsz * sizeof *buf);
            }
    }
    if (st == DTX_OK && nbad > 0) {
        marked_list(r, sel, nsel, MARK_NONFINITE, list, sizeof list);
        snprintf(w, sizeof w,
                 "%s: %lld of %lld frames have non-finite positions (first: frame %lld, "
                 "vertex %lld); drawn frames among them: %s, labelled NAN, their triangles "
                 "that touch a non-finite vertex left out",
                 r->where, (long long)nbad, (long long)s->nframes, (long long)bad_f,
                 (long long)bad_v, list);
        dtx_cli_print_warning(NULL, w);
    }
    if (st == DTX_OK && nundone > 0) {
        marked_list(r, sel, nsel, MARK_NOT_DONE, list, sizeof list);
        snprintf(w, sizeof w,
                 "%s: %lld of %lld frames are not done (first: frame %lld), their positions "
                 "undefined; drawn frames among them: %s, left empty and labelled NOT DONE",
                 r->where, (long long)nundone, (long long)s->nframes, (long long)undone_f, list);
        dtx_cli_print_warning(NULL, w);
    }
    free(buf);
    free(done);
    return st;
}

/* Opens the sequence or result at path with its faces into s and r. */
static dtx_status open_frames(hid_t f, const char *file, const char *path, int kind,
                              frame_source *s, row *r, dtx_error *err)
{
    char mp[DTX_H5_PATH_MAX + 16];
    dtx_status st;
    s->is_result = kind == K_RESULT;
    if (kind == K_RESULT) {
        st = dtx_h5_result_open(f, path, 0, &s->res, err);
        s->nframes = s->res.nframes, s->nv = s->res.nv;
        snprintf(mp, sizeof mp, "%s/target", path);
    } else {
        st = dtx_h5_seq_open(f, path, &s->seq, err);
        s->nframes = s->seq.nframes, s->nv = s->seq.nv;
        snprintf(mp, sizeof mp, "%s/rest", path);
    }
    snprintf(r->where, sizeof r->where, "%s: %s", file, path);
    if (st == DTX_OK)
        st = dtx_h5_read_mesh(f, mp, &r->mesh, err);
    if (st == DTX_OK && r->mesh.nv != s->nv)
        st = dtx_seterr(err, DTX_EFORMAT, "%s: %s has %d vertices per frame but its mesh %d",
                        file, path, (int)s->nv, (int)r->mesh.nv);
    if (st == DTX_OK && s->nframes < 1)
        st = dtx_seterr(err, DTX_EFORMAT, "%s: %s has no frames", file, path);
    return st;
}

static void close_frames(frame_source *s)
{
    dtx_h5_seq_close(&s->seq);
    dtx_h5_result_close(&s->res);
}

/* ------------------------------------------------------------------ */
/* Drawing                                                             */
/* ------------------------------------------------------------------ */

/* Lays out nrows rows of nsel frames in blocks of `cols` columns (a block
 * per line of frames, each with the rows one above the other), draws and
 * writes the picture. */
static dtx_status draw(row *rows, int nrows, const int64_t *sel, int nsel, int cols,
                       const render_args *a, dtx_render_opts *o, int labels, dtx_error *err)
{
    int blocks = (nsel + cols - 1) / cols, k = nrows * nsel;
    dtx_render_panel *panels = dtx_alloc((size_t)k, sizeof *panels, 1);
    char (*text)[96] = dtx_alloc((size_t)k, sizeof *text, 0);
    double *bounds = dtx_alloc((size_t)nrows, 4 * sizeof *bounds, 0);
    unsigned char *rgb = NULL;
    dtx_status st;
    if (!panels || !text || !bounds) {
        st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
        goto done;
    }
    o->cols = cols;
    o->rows = blocks * nrows;
    o->block_rows = nrows > 1 ? nrows : 0;
    if (!a->width)
        o->width = cols == 1 ? 800 : cols * 200 < 2000 ? cols * 200 : 2000;
    for (int r = 0; r < nrows; r++)
        memcpy(bounds + 4 * r, rows[r].box, sizeof rows[r].box);
    if (!a->height)
        o->height = dtx_render_fit_height(bounds, nrows, labels, o);
    for (int r = 0; r < nrows; r++)
        for (int j = 0; j < nsel; j++) {
            dtx_render_panel *p = panels + r * nsel + j;
            const row *rw = rows + r;
            p->X = rw->X ? rw->X + (size_t)j * rw->mesh.nv * 3 : rw->mesh.V;
            p->nv = rw->mesh.nv;
            p->F = rw->mesh.F;
            p->nf = rw->mesh.nf;
            p->row = (j / cols) * nrows + r;
            p->col = j % cols;
            p->group = r;
            p->palette_offset = rw->palette_offset;
            if (rw->mark && rw->mark[j] == MARK_NOT_DONE)
                p->nf = 0; /* undefined positions: an empty panel */
            if (labels) {
                const char *note = !rw->mark                         ? ""
                                   : rw->mark[j] == MARK_NONFINITE ? " NAN"
                                   : rw->mark[j] == MARK_NOT_DONE  ? " NOT DONE"
                                                                   : "";
                if (j == 0)
                    snprintf(text[r * nsel + j], sizeof text[0], "%.63s %lld%s", rw->name,
                             (long long)sel[j], note);
                else
                    snprintf(text[r * nsel + j], sizeof text[0], "%lld%s", (long long)sel[j],
                             note);
                p->label = text[r * nsel + j];
            }
        }
    rgb = dtx_alloc((size_t)o->width * (size_t)o->height, 3, 0);
    if (!rgb) {
        st = dtx_seterr(err, DTX_ENOMEM, "out of memory for a %d x %d picture", o->width,
                        o->height);
        goto done;
    }
    st = dtx_render_panels(panels, k, bounds, nrows, o, rgb, err);
    if (st != DTX_OK)
        dtx_error_prefix(err, "%s", a->out);
    if (st == DTX_OK)
        st = dtx_png_write(a->out, rgb, o->width, o->height, err);
    if (st == DTX_OK)
        fprintf(stderr, "dtx: %d frame%s x %d row%s -> %s (%d x %d)\n", nsel,
                nsel == 1 ? "" : "s", nrows, nrows == 1 ? "" : "s", a->out, o->width,
                o->height);
done:
    free(panels);
    free(text);
    free(bounds);
    free(rgb);
    return st;
}

/* A mesh file (OBJ, PLY, OFF): one panel. */
static int render_mesh_file(const render_args *a, dtx_render_opts *o)
{
    dtx_error err;
    dtx_warner w = {dtx_cli_print_warning, NULL};
    row r;
    int64_t sel = 0;
    dtx_status st;
    if (a->item)
        return usage_or_keep(a, "render: a mesh file takes no item path");
    if (a->frames || a->count || a->cols)
        return usage_or_keep(a, "render: --frames, --count and --cols need a sequence or a "
                                "result");
    memset(&r, 0, sizeof r);
    if ((st = dtx_mesh_read(a->input, &r.mesh, &w, &err)) != DTX_OK)
        return fail_or_keep(a, &err);
    dtx_render_bounds_init(r.box);
    dtx_render_bounds_add(r.mesh.V, r.mesh.nv, o, r.box);
    st = draw(&r, 1, &sel, 1, 1, a, o, 0, &err);
    dtx_mesh_free(&r.mesh);
    return st == DTX_OK ? 0 : fail_or_keep(a, &err);
}

static int has_mesh_extension(const char *path)
{
    const char *dot = strrchr(path, '.');
    return dot && (strcasecmp(dot, ".obj") == 0 || strcasecmp(dot, ".ply") == 0 ||
                   strcasecmp(dot, ".off") == 0);
}

/* The rows of a result (its source sequence above it unless --no-source)
 * or of a sequence, opened into src[] and rows[]; *nrows receives their
 * number. */
static dtx_status open_rows(hid_t f, const render_args *a, const char *path, int kind,
                            const char *where, hid_t *fs, frame_source *src, row *rows,
                            int *nrows, dtx_error *err)
{
    char *ref = NULL, sfile[4096], spath[DTX_H5_PATH_MAX];
    dtx_status st = DTX_OK;
    int n = 0;
    if (kind == K_RESULT && !a->no_source) {
        if ((st = dtx_h5_read_attr_str(f, path, "source_sequence", &ref, err)) != DTX_OK)
            goto done;
        if ((st = find_source(a->input, where, ref, sfile, sizeof sfile, spath, err)) != DTX_OK) {
            size_t len = strlen(err->msg);
            if (!a->capture)
                snprintf(err->msg + len, sizeof err->msg - len,
                         "; use --no-source to draw the result alone");
            goto done;
        }
        /* A source in the result's own file is read through f. */
        if (dtx_file_same_inode(sfile, a->input) != 1 &&
            (st = dtx_h5_open(sfile, MPI_COMM_NULL, 0, fs, err)) != DTX_OK) {
            dtx_error_prefix(err, "%s: source sequence", where);
            goto done;
        }
        if ((st = open_frames(*fs >= 0 ? *fs : f, sfile, spath, K_SEQ, &src[0], &rows[0],
                              err)) != DTX_OK)
            goto done;
        short_name(spath, K_SEQ, rows[0].name, sizeof rows[0].name);
        rows[0].palette_offset = 1;
        n = 1;
    }
    if ((st = open_frames(f, a->input, path, kind, &src[n], &rows[n], err)) != DTX_OK)
        goto done;
    short_name(path, kind, rows[n].name, sizeof rows[n].name);
    n++;
    if (n == 2 && src[0].nframes != src[1].nframes)
        st = dtx_seterr(err, DTX_EFORMAT,
                        "%s has %lld frames but its source sequence %lld; use --no-source to "
                        "draw the result alone",
                        where, (long long)src[1].nframes, (long long)src[0].nframes);
done:
    *nrows = n;
    free(ref);
    return st;
}

/* An HDF5 file: a mesh (one panel), a sequence (one row) or a result (the
 * source row above the result row). */
static int render_h5(const render_args *a, dtx_render_opts *o, int cols)
{
    char path[DTX_H5_PATH_MAX], where[DTX_H5_PATH_MAX + 512];
    const char *msg = NULL;
    hid_t f = H5I_INVALID_HID, fs = H5I_INVALID_HID;
    frame_source src[2];
    row rows[2];
    int64_t *sel = NULL;
    int kind, nrows = 0, nsel = 0;
    dtx_error err;
    dtx_status st;

    memset(src, 0, sizeof src);
    memset(rows, 0, sizeof rows);
    if ((st = dtx_h5_open(a->input, MPI_COMM_NULL, 0, &f, &err)) != DTX_OK ||
        (st = resolve_item(f, a->input, a->item, path, &kind, &err)) != DTX_OK)
        goto done;
    snprintf(where, sizeof where, "%s: %s", a->input, path);
    sel = dtx_alloc(MAX_FRAMES, sizeof *sel, 1);
    if (!sel) {
        st = dtx_seterr(&err, DTX_ENOMEM, "out of memory");
        goto done;
    }

    if (kind == K_MESH) {
        if (a->frames || a->count || a->cols) {
            msg = "render: --frames, --count and --cols need a sequence or a result";
            goto done;
        }
        if ((st = dtx_h5_read_mesh(f, path, &rows[0].mesh, &err)) == DTX_OK) {
            dtx_render_bounds_init(rows[0].box);
            dtx_render_bounds_add(rows[0].mesh.V, rows[0].mesh.nv, o, rows[0].box);
            st = draw(rows, 1, sel, 1, 1, a, o, 0, &err);
        }
        goto done;
    }

    if ((st = open_rows(f, a, path, kind, where, &fs, src, rows, &nrows, &err)) != DTX_OK)
        goto done;
    msg = select_frames(a, src[nrows - 1].nframes, where, sel, &nsel, &err);
    if (msg) {
        if (!*msg) /* not a usage error: err holds the message */
            st = err.code, msg = NULL;
        goto done;
    }
    if (!cols)
        cols = nsel < DEFAULT_COUNT ? nsel : DEFAULT_COUNT;
    if (cols > nsel)
        cols = nsel;
    for (int r = 0; r < nrows && st == DTX_OK; r++)
        st = load_row(&src[r], sel, nsel, o, &rows[r], &err);
    if (st == DTX_OK)
        st = draw(rows, nrows, sel, nsel, cols, a, o, !a->no_labels, &err);
done:
    for (int r = 0; r < 2; r++) {
        close_frames(&src[r]);
        dtx_mesh_free(&rows[r].mesh);
        free(rows[r].X);
        free(rows[r].mark);
    }
    free(sel);
    dtx_h5_close(&fs, NULL);
    dtx_h5_close(&f, NULL);
    if (msg)
        return usage_or_keep(a, msg);
    return st == DTX_OK ? 0 : fail_or_keep(a, &err);
}

static int run_render(int argc, char **argv, dtx_error *capture)
{
    render_args a;
    dtx_render_opts o;
    char msgbuf[256];
    const char *msg;
    int cols = 0;
    msg = parse_args(argc, argv, &a, msgbuf, sizeof msgbuf);
    a.capture = capture;
    if (msg || (msg = make_opts(&a, &o)) != NULL)
        return usage_or_keep(&a, msg);
    if (a.cols && parse_int(a.cols, 1, MAX_FRAMES, &cols) != 0)
        return usage_or_keep(&a, "render: --cols must be a number of columns in 1..1024");
    {
        /* The picture never replaces the input (dtx never writes over its
         * inputs), a directory or a special file. */
        dtx_error err;
        if (dtx_path_guard_check_pair(a.input, "the input file", a.out, "the picture, -o",
                                      &err) != DTX_OK ||
            dtx_output_path_check(a.out, "the picture, -o", &err) != DTX_OK)
            return fail_or_keep(&a, &err);
    }
    if (has_mesh_extension(a.input))
        return render_mesh_file(&a, &o);
    return render_h5(&a, &o, cols);
}

int dtx_cmd_render(int argc, char **argv)
{
    return run_render(argc, argv, NULL);
}

int dtx_render_sheet(int argc, char **argv, dtx_error *err)
{
    return run_render(argc, argv, err);
}
