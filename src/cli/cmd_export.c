/*
 * cmd_export.c: `dtx export`.  Opens a result (/results/T/S) or a sequence
 * (/sequences/S) of a dtx file with its mesh (the result's target, the
 * sequence's rest mesh), checks every argument, that a result has all its
 * frames and that every exported frame is finite (so an error leaves no
 * output at all), then writes what was asked, each file atomically and the
 * OBJ frames through a temporary directory:
 *
 *   --obj-rest FILE  the mesh as OBJ (what a PC2 cache is applied to)
 *   --pc2 FILE       a PC2 point cache, one sample per exported frame
 *   --mdd FILE       an MDD point cache, the same samples with their times
 *                    in seconds (k * K / fps)
 *   --glb FILE       glTF 2.0 binary: the mesh, the frames as morph targets
 *                    and an animation over them
 *   --obj-dir DIR    one OBJ per exported frame, DIR/<name>-NNNNN.obj with
 *                    the 1-based frame number
 *
 * --stride K exports frames 0, K, 2K, ... to every output (PC2: sample rate
 * K; glb and MDD: frame k at time k*K/fps).  fps is the item's stored frame
 * rate (attribute fps; 24 when it has none), or --fps.  A .glb holds at most
 * DTX_GLB_MAX_FRAMES frames (--max-frames sets a lower cap); more is refused
 * before anything is written, with the stride that would fit.
 */
#include "cmd_export.h"

#include "cli_util.h"
#include "options.h"

#include "glb_materials.h"
#include "gltf.h"
#include "h5mesh_attrs.h"
#include "h5layout.h"
#include "h5mesh_attrs.h"
#include "mdd.h"
#include "meshfile.h"
#include "obj_frames.h"
#include "path_guard.h"
#include "pc2.h"

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define DEFAULT_MAX_FRAMES DTX_GLB_MAX_FRAMES

typedef struct {
    const char *input, *item;
    const char *obj_dir, *obj_rest, *pc2, *glb, *mdd;
    const char *stride_s, *fps_s, *start_s, *max_s;
    int step;
    /* parsed */
    int64_t stride;
    double fps, start_frame;
    int max_frames;
} export_args;

/* The frames to export: an open result or sequence. */
typedef struct {
    int is_result;
    dtx_h5_seq seq;
    dtx_h5_result res;
    int64_t nframes; /* frames in the file */
    int32_t nv;
    int64_t stride;
    double fps;     /* frames per second: --fps, else the item's, else 24 */
    int fps_stored; /* the item stores its frame rate */
} frame_source;

/* ------------------------------------------------------------------ */
/* Arguments                                                           */
/* ------------------------------------------------------------------ */

/* Parses argv[2..] into *a.  Returns NULL, or a usage message (which may
 * point into buf). */
static const char *parse_args(int argc, char **argv, export_args *a, char *buf, size_t n)
{
    static const dtx_cli_slot valued[] = {
        {"--obj-dir", offsetof(export_args, obj_dir)},
        {"--obj-rest", offsetof(export_args, obj_rest)},
        {"--pc2", offsetof(export_args, pc2)},
        {"--glb", offsetof(export_args, glb)},
        {"--mdd", offsetof(export_args, mdd)},
        {"--stride", offsetof(export_args, stride_s)},
        {"--fps", offsetof(export_args, fps_s)},
        {"--start-frame", offsetof(export_args, start_s)},
        {"--max-frames", offsetof(export_args, max_s)},
    };
    int npos = 0;
    memset(a, 0, sizeof *a);
    for (int i = 2; i < argc; i++) {
        const char *s = argv[i];
        int took = dtx_cli_take_slot("export", valued, sizeof valued / sizeof *valued, 1, a, argc,
                                     argv, &i, buf, n);
        if (took < 0)
            return buf;
        if (took > 0)
            continue;
        if (strcmp(s, "--step") == 0) {
            a->step = 1;
        } else if (s[0] == '-' && s[1] != '\0') {
            snprintf(buf, n, "export: unknown option %s", s);
            return buf;
        } else if (npos == 0) {
            a->input = s, npos++;
        } else if (npos == 1) {
            a->item = s, npos++;
        } else {
            snprintf(buf, n, "export: unexpected argument %s", s);
            return buf;
        }
    }
    if (!a->input || !a->item)
        return "export needs FILE.h5 and a result or sequence path";
    if (!a->obj_dir && !a->obj_rest && !a->pc2 && !a->glb && !a->mdd)
        return "export needs at least one of --obj-dir DIR, --obj-rest FILE, --pc2 FILE, "
               "--mdd FILE, --glb FILE";
    if (!a->pc2 && a->start_s)
        return "export: --start-frame goes with --pc2";
    if (!a->glb && (a->max_s || a->step))
        return "export: --step and --max-frames go with --glb";
    if (!a->glb && !a->mdd && a->fps_s)
        return "export: --fps goes with --glb or --mdd (the outputs with times in seconds)";

    a->stride = 1;
    a->fps = 0.0; /* the item's own frame rate unless --fps */
    a->start_frame = 0.0; /* Blender plays sample k at scene frame k */
    a->max_frames = DEFAULT_MAX_FRAMES;
    if (a->stride_s) {
        char *end;
        long long v;
        errno = 0;
        v = strtoll(a->stride_s, &end, 10);
        if (errno || *end || end == a->stride_s || v < 1 || v > INT32_MAX)
            return "export: --stride must be a whole number >= 1";
        a->stride = v;
    }
    if (a->max_s) {
        char *end;
        long v;
        errno = 0;
        v = strtol(a->max_s, &end, 10);
        if (errno || *end || end == a->max_s || v < 1 || v > DTX_GLB_MAX_FRAMES) {
            snprintf(buf, n, "export: --max-frames must be a whole number from 1 to %d",
                     DTX_GLB_MAX_FRAMES);
            return buf;
        }
        a->max_frames = (int)v;
    }
    if (a->fps_s) {
        char *end;
        errno = 0;
        a->fps = strtod(a->fps_s, &end);
        if (errno || *end || end == a->fps_s || !(a->fps > 0.0) || !(a->fps <= DTX_H5_FPS_MAX))
            return "export: --fps must be a number > 0 (at most 1e6)";
    }
    if (a->start_s) {
        char *end;
        errno = 0;
        a->start_frame = strtod(a->start_s, &end);
        if (errno || *end || end == a->start_s || !isfinite(a->start_frame) ||
            fabs(a->start_frame) > 1e7)
            return "export: --start-frame must be a number (|F| <= 1e7)";
    }
    return NULL;
}

/* ------------------------------------------------------------------ */
/* The frames                                                          */
/* ------------------------------------------------------------------ */

static int64_t exported_frames(const frame_source *s)
{
    return (s->nframes + s->stride - 1) / s->stride;
}

/* Exported frame k (file frame k * stride) into X (nv x 3). */
static dtx_status read_frame(void *ctx, int64_t k, double *X, dtx_error *err)
{
    frame_source *s = ctx;
    int64_t i = k * s->stride;
    return s->is_result ? dtx_h5_result_read(&s->res, i, 1, X, NULL, err)
                        : dtx_h5_seq_read(&s->seq, i, 1, X, err);
}

static void source_close(frame_source *s)
{
    dtx_h5_result_close(&s->res);
    dtx_h5_seq_close(&s->seq);
}

/* "/results/lion" is a group of results: names its members in the
 * message. */
static dtx_status namespace_error(hid_t f, const char *file, const char *path, const char *what,
                                  dtx_error *err)
{
    char **names = NULL, list[512] = "";
    int64_t n = 0;
    size_t used = 0;
    if (dtx_h5_list_groups(f, path, &names, &n, NULL) == DTX_OK) {
        for (int64_t i = 0; i < n && used + 8 < sizeof list; i++) {
            int w =
                snprintf(list + used, sizeof list - used, "%s%s/%s", i ? ", " : "", path, names[i]);
            used = w < 0 ? used : used + (size_t)w;
            if (used >= sizeof list)
                used = sizeof list - 1;
        }
        dtx_h5_free_strings(&names, n);
    }
    if (n == 0)
        return dtx_seterr(err, DTX_EINVAL, "%s: %s holds no %s", file, path, what);
    return dtx_seterr(err, DTX_EINVAL, "%s: %s is a group of %ss, not one; name one: %s", file,
                      path, what, list);
}

/* Opens the result or sequence at path and reads its mesh into *mesh. */
static dtx_status source_open(hid_t f, const char *file, const char *path, frame_source *s,
                              dtx_mesh *mesh, dtx_error *err)
{
    static const struct {
        const char *prefix, *what;
    } other[] = {{"/meshes/", "a mesh"},
                 {"/markers/", "a marker set"},
                 {"/correspondences/", "a correspondence"}};
    char sub[DTX_H5_PATH_MAX + 16];
    dtx_status st;
    int is_res = strncmp(path, "/results/", 9) == 0, is_seq = strncmp(path, "/sequences/", 11) == 0;
    if (strlen(path) >= DTX_H5_PATH_MAX)
        return dtx_seterr(err, DTX_EINVAL, "%s: path too long", file);
    if (!dtx_h5_path_exists(f, path))
        return dtx_seterr(err, DTX_EINVAL,
                          "%s: %s: no such object in the file (dtx inspect %s "
                          "lists what it holds)",
                          file, path, file);
    if (!is_res && !is_seq) {
        for (size_t i = 0; i < sizeof other / sizeof *other; i++)
            if (strncmp(path, other[i].prefix, strlen(other[i].prefix)) == 0)
                return dtx_seterr(err, DTX_EINVAL,
                                  "%s: %s is %s, not a result or a sequence: it has no frames to "
                                  "export",
                                  file, path, other[i].what);
        return dtx_seterr(err, DTX_EINVAL,
                          "%s: %s is not a result (/results/...) or a sequence (/sequences/...)",
                          file, path);
    }
    snprintf(sub, sizeof sub, "%s/positions", path);
    if (!dtx_h5_path_exists(f, sub))
        return namespace_error(f, file, path, is_res ? "result" : "sequence", err);
    s->is_result = is_res;
    if (is_res) {
        uint8_t *done;
        st = dtx_h5_result_open(f, path, 0, &s->res, err);
        if (st != DTX_OK)
            return st;
        s->nframes = s->res.nframes;
        s->nv = s->res.nv;
        done = dtx_alloc((size_t)s->nframes, 1, 0);
        if (!done)
            return dtx_seterr(err, DTX_ENOMEM, "out of memory");
        st = dtx_h5_result_read_done(&s->res, done, err);
        for (int64_t i = 0; st == DTX_OK && i < s->nframes; i++)
            if (!done[i])
                st = dtx_seterr(err, DTX_EINVAL,
                                "%s: %s is incomplete: frame %lld (0-based) is not done; finish "
                                "the run first (dtx run --resume)",
                                file, path, (long long)i);
        free(done);
        if (st != DTX_OK)
            return st;
        snprintf(sub, sizeof sub, "%s/target", path);
    } else {
        st = dtx_h5_seq_open(f, path, &s->seq, err);
        if (st != DTX_OK)
            return st;
        s->nframes = s->seq.nframes;
        s->nv = s->seq.nv;
        snprintf(sub, sizeof sub, "%s/rest", path);
    }
    st = dtx_h5_read_mesh(f, sub, mesh, err);
    if (st == DTX_OK && mesh->nv != s->nv)
        st = dtx_seterr(err, DTX_EFORMAT, "%s: %s has %d vertices but its mesh %s has %d", file,
                        path, (int)s->nv, sub, (int)mesh->nv);
    if (st == DTX_OK && s->nframes < 1)
        st = dtx_seterr(err, DTX_EFORMAT, "%s: %s has no frames", file, path);
    if (st == DTX_OK)
        st = dtx_h5_read_fps(f, path, &s->fps, &s->fps_stored, err);
    return st;
}

/* ------------------------------------------------------------------ */
/* Outputs                                                             */
/* ------------------------------------------------------------------ */

/* An output path must not be a directory (the rename would fail late). */
static dtx_status check_output(const char *path, dtx_error *err)
{
    struct stat sb;
    if (stat(path, &sb) == 0 && S_ISDIR(sb.st_mode))
        return dtx_seterr(err, DTX_EINVAL, "%s: is a directory (an output file was expected)",
                          path);
    return DTX_OK;
}

static dtx_status write_pc2(frame_source *s, const export_args *a, double *X, dtx_error *err)
{
    dtx_pc2_writer w;
    int64_t T = exported_frames(s);
    dtx_status st;
    if (T > INT32_MAX)
        return dtx_seterr(err, DTX_ERANGE, "%s: %lld frames; PC2 holds at most %d", a->pc2,
                          (long long)T, (int)INT32_MAX);
    st = dtx_pc2_begin(&w, a->pc2, s->nv, (int32_t)T, (float)a->start_frame, (float)s->stride, err);
    for (int64_t k = 0; st == DTX_OK && k < T; k++) {
        st = read_frame(s, k, X, err);
        if (st == DTX_OK)
            st = dtx_pc2_write_sample(&w, X, err);
    }
    if (st == DTX_OK)
        st = dtx_pc2_finish(&w, err);
    else
        dtx_pc2_abort(&w);
    if (st == DTX_OK)
        fprintf(stderr, "dtx: %lld frames x %d points -> %s (PC2)\n", (long long)T, (int)s->nv,
                a->pc2);
    return st;
}

static dtx_status write_mdd(frame_source *s, const export_args *a, double *X, dtx_error *err)
{
    dtx_mdd_writer w;
    int64_t T = exported_frames(s);
    float *times;
    dtx_status st = DTX_OK;
    if (T > INT32_MAX)
        return dtx_seterr(err, DTX_ERANGE, "%s: %lld frames; MDD holds at most %d", a->mdd,
                          (long long)T, (int)INT32_MAX);
    times = dtx_alloc((size_t)T, sizeof *times, 0);
    if (!times)
        return dtx_seterr(err, DTX_ENOMEM, "%s: out of memory for %lld times", a->mdd,
                          (long long)T);
    for (int64_t k = 0; k < T; k++)
        times[k] = (float)((double)(k * s->stride) / s->fps);
    st = dtx_mdd_begin(&w, a->mdd, s->nv, (int32_t)T, times, err);
    free(times);
    for (int64_t k = 0; st == DTX_OK && k < T; k++) {
        st = read_frame(s, k, X, err);
        if (st == DTX_OK)
            st = dtx_mdd_write_sample(&w, X, err);
    }
    if (st == DTX_OK)
        st = dtx_mdd_finish(&w, err);
    else
        dtx_mdd_abort(&w);
    if (st == DTX_OK)
        fprintf(stderr, "dtx: %lld frames x %d points -> %s (MDD, %.4g s apart)\n", (long long)T,
                (int)s->nv, a->mdd, (double)s->stride / s->fps);
    return st;
}

/* The glb keeps the asset: the mesh's stored attributes (UVs, normals,
 * materials) and, from the .mtl its OBJ named, base colours and textures
 * (glb_materials.h); what is not found is a warning, not an error. */
static dtx_status write_glb(frame_source *s, const export_args *a, const dtx_mesh *mesh,
                            hid_t f, const char *file, dtx_error *err)
{
    dtx_glb_opts o;
    dtx_mesh_attrs attrs;
    dtx_glb_materials mats;
    char source[DTX_H5_PATH_MAX + 4096], group[DTX_H5_PATH_MAX + 16];
    const char *name = strrchr(a->item, '/');
    dtx_status st;
    memset(&o, 0, sizeof o);
    memset(&mats, 0, sizeof mats);
    o.seconds_per_frame = (double)s->stride / s->fps;
    o.step = a->step;
    o.name = name && name[1] ? name + 1 : a->item;
    o.label_first = 1;
    o.label_step = s->stride;
    snprintf(source, sizeof source, "%.4000s:%s", file, a->item);
    o.source = source;
    snprintf(group, sizeof group, "%s/%s", a->item, s->is_result ? "target" : "rest");
    st = dtx_h5_read_mesh_attrs(f, group, mesh->nv, mesh->nf, &attrs, err);
    if (st == DTX_OK)
        st = dtx_glb_materials_load(f, file, group, &attrs, &mats, err);
    if (st == DTX_OK && mats.note[0])
        fprintf(stderr, "dtx: warning: %s: %s\n", a->glb, mats.note);
    if (st == DTX_OK && mats.nimages > 0 && !attrs.uv)
        fprintf(stderr, "dtx: warning: %s: the mesh has no UVs, so its texture is not embedded\n",
                a->glb);
    if (st == DTX_OK) {
        o.attrs = &attrs;
        o.materials = mats.n ? mats.mat : NULL;
        o.nmaterials = mats.n;
        st = dtx_glb_write(a->glb, mesh, exported_frames(s), read_frame, s, &o, err);
    }
    if (st == DTX_OK)
        fprintf(stderr,
                "dtx: %lld frames as morph targets -> %s (glTF binary, %.4g s apart, %s%s%s%s)\n",
                (long long)exported_frames(s), a->glb, o.seconds_per_frame,
                a->step ? "STEP" : "LINEAR", attrs.uv ? ", UVs" : "",
                attrs.normals ? ", the asset's normals" : "",
                mats.n ? (mats.nimages ? ", materials with textures" : ", materials") : "");
    dtx_glb_materials_free(&mats);
    dtx_mesh_attrs_free(&attrs);
    return st;
}

/* Every exported frame is read once before any output is written: a frame
 * that cannot be exported (a non-finite coordinate, or with --pc2 or --glb
 * one beyond float32) stops the export before the first file, so no output
 * is left half-done and none is written while another fails. */
static dtx_status check_frames(frame_source *s, const export_args *a, double *X, dtx_error *err)
{
    const int f32 = a->pc2 || a->glb;
    const int64_t T = exported_frames(s), n = (int64_t)s->nv * 3;
    for (int64_t k = 0; k < T; k++) {
        dtx_status st = read_frame(s, k, X, err);
        if (st != DTX_OK)
            return st;
        for (int64_t i = 0; i < n; i++)
            if (!(isfinite(X[i]) && (!f32 || fabs(X[i]) <= FLT_MAX)))
                return dtx_seterr(err, DTX_EFORMAT,
                                  "%s: %s: frame %lld (0-based), vertex %lld has %s "
                                  "coordinate (%g); nothing was exported",
                                  a->input, a->item, (long long)(k * s->stride),
                                  (long long)(i / 3),
                                  isfinite(X[i]) ? "a float32-overflowing" : "a non-finite",
                                  X[i]);
    }
    return DTX_OK;
}

/* The rest mesh as OBJ with its attributes as stored (UVs, materials,
 * mtllib, the asset's own normals: they are the rest shape's). */
static dtx_status write_obj_rest(hid_t f, const frame_source *s, const export_args *a,
                                 const dtx_mesh *mesh, dtx_error *err)
{
    char path[DTX_H5_PATH_MAX + 16];
    dtx_mesh_attrs attrs;
    dtx_status st;
    snprintf(path, sizeof path, "%s/%s", a->item, s->is_result ? "target" : "rest");
    st = dtx_h5_read_mesh_attrs(f, path, mesh->nv, mesh->nf, &attrs, err);
    if (st == DTX_OK)
        st = dtx_obj_write_attrs(a->obj_rest, mesh->V, NULL, mesh->nv, mesh->F, mesh->nf, &attrs,
                                 "rest mesh exported by dtx (apply the PC2 cache to it)", err);
    dtx_mesh_attrs_free(&attrs);
    return st;
}

/* Removes the first n frame files of dir (written by write_obj_dir), then
 * dir itself: only what this export created. */
static void remove_frames(const char *dir, const char *base, const frame_source *s, int64_t n)
{
    char path[8192];
    for (int64_t k = 0; k < n; k++) {
        snprintf(path, sizeof path, "%.4000s/%.1000s-%05lld.obj", dir, base,
                 (long long)(k * s->stride + 1));
        remove(path);
    }
    rmdir(dir);
}

/* The frames go to a temporary directory and are moved into place when all
 * are written, so an error (a full disk, say) leaves none of them: a new
 * DIR is the temporary directory renamed; into an existing DIR (whose other
 * files stay) each frame is renamed from a temporary directory inside it. */
static dtx_status write_obj_dir(hid_t f, frame_source *s, const export_args *a,
                                const dtx_mesh *mesh, double *X, dtx_error *err)
{
    char dir[4096], tmp[4200], path[8192], final[8192];
    const char *base = strrchr(a->item, '/'), *slash;
    dtx_status st = DTX_OK;
    int64_t T = exported_frames(s), k, moved = 0;
    size_t len;
    struct stat sb;
    int exists;
    dtx_mesh_attrs attrs;
    dtx_obj_frames w;
    base = base ? base + 1 : a->item;
    /* The frames carry the mesh's attributes (UVs, materials, mtllib;
     * per-frame normals when the mesh had normals: io/obj_frames.h). */
    snprintf(path, sizeof path, "%.4000s/%s", a->item, s->is_result ? "target" : "rest");
    st = dtx_h5_read_mesh_attrs(f, path, mesh->nv, mesh->nf, &attrs, err);
    if (st == DTX_OK)
        st = dtx_obj_frames_begin(&w, mesh, &attrs, err);
    dtx_mesh_attrs_free(&attrs);
    if (st != DTX_OK)
        return st;
    len = strlen(a->obj_dir);
    while (len > 1 && a->obj_dir[len - 1] == '/')
        len--;
    if (len >= sizeof dir)
        return dtx_seterr(err, DTX_EINVAL, "%.200s...: path too long", a->obj_dir);
    memcpy(dir, a->obj_dir, len);
    dir[len] = '\0';
    exists = stat(dir, &sb) == 0;
    if (exists && !S_ISDIR(sb.st_mode)) {
        dtx_obj_frames_end(&w);
        return dtx_seterr(err, DTX_EINVAL, "%s: is not a directory", a->obj_dir);
    }
    slash = strrchr(dir, '/');
    if (exists)
        snprintf(tmp, sizeof tmp, "%s/.dtx-export.tmp-%ld", dir, (long)getpid());
    else
        snprintf(tmp, sizeof tmp, "%.*s.%s.tmp-%ld", slash ? (int)(slash - dir + 1) : 0, dir,
                 slash ? slash + 1 : dir, (long)getpid());
    if (mkdir(tmp, 0777) != 0) {
        dtx_obj_frames_end(&w);
        return dtx_seterr(err, DTX_EIO, "%s: cannot create directory: %s",
                          exists ? a->obj_dir : dir, strerror(errno));
    }
    for (k = 0; st == DTX_OK && k < T; k++) {
        st = read_frame(s, k, X, err);
        snprintf(path, sizeof path, "%.4000s/%.1000s-%05lld.obj", tmp, base,
                 (long long)(k * s->stride + 1));
        if (st == DTX_OK)
            st = dtx_obj_frames_write(&w, path, X, NULL, "exported by dtx", err);
    }
    dtx_obj_frames_end(&w);
    if (st != DTX_OK) {
        remove_frames(tmp, base, s, k);
        return st;
    }
    if (!exists) {
        if (rename(tmp, dir) != 0) {
            st = dtx_seterr(err, DTX_EIO, "%s: cannot rename %s to it: %s", dir, tmp,
                            strerror(errno));
            remove_frames(tmp, base, s, T);
            return st;
        }
    } else {
        for (moved = 0; moved < T; moved++) {
            snprintf(path, sizeof path, "%.4000s/%.1000s-%05lld.obj", tmp, base,
                     (long long)(moved * s->stride + 1));
            snprintf(final, sizeof final, "%.4000s/%.1000s-%05lld.obj", dir, base,
                     (long long)(moved * s->stride + 1));
            if (rename(path, final) != 0) {
                st = dtx_seterr(err, DTX_EIO, "%s: cannot move %s here: %s", final, path,
                                strerror(errno));
                break;
            }
        }
        if (st != DTX_OK) {
            /* Frames already moved replaced old ones and stay; the rest go. */
            for (int64_t j = moved; j < T; j++) {
                snprintf(path, sizeof path, "%.4000s/%.1000s-%05lld.obj", tmp, base,
                         (long long)(j * s->stride + 1));
                remove(path);
            }
            rmdir(tmp);
            return st;
        }
        rmdir(tmp);
    }
    fprintf(stderr, "dtx: %lld frames -> %s/\n", (long long)T, a->obj_dir);
    return DTX_OK;
}

/* ------------------------------------------------------------------ */
/* The command                                                         */
/* ------------------------------------------------------------------ */

/* Every output is checked before the input is read: none may be the input
 * file (dtx never writes over its inputs), and a file output may not be a
 * directory or a special file. */
static dtx_status check_outputs(const export_args *a, dtx_error *err)
{
    const char *files[4] = {a->obj_rest, a->pc2, a->mdd, a->glb};
    const char *uses[4] = {"--obj-rest", "--pc2", "--mdd", "--glb"};
    dtx_status st = DTX_OK;
    for (int i = 0; i < 4 && st == DTX_OK; i++)
        if (files[i]) {
            st = dtx_path_guard_check_pair(a->input, "the input file", files[i], uses[i], err);
            if (st == DTX_OK)
                st = dtx_output_path_check(files[i], uses[i], err);
        }
    if (st == DTX_OK && a->obj_dir)
        st = dtx_path_guard_check_pair(a->input, "the input file", a->obj_dir, "--obj-dir", err);
    return st;
}

int dtx_cmd_export(int argc, char **argv)
{
    export_args a;
    char ubuf[256];
    const char *msg = parse_args(argc, argv, &a, ubuf, sizeof ubuf);
    dtx_error err;
    dtx_status st;
    hid_t f = H5I_INVALID_HID;
    frame_source s;
    dtx_mesh mesh;
    double *X = NULL;
    int new_rest, new_pc2, new_glb;
    if (msg)
        return dtx_cli_usage(dtx_cli_find_name("export"), msg);
    memset(&s, 0, sizeof s);
    memset(&mesh, 0, sizeof mesh);
    s.stride = a.stride;

    /* ---- input, then every check before the first output */
    st = check_outputs(&a, &err);
    if (st == DTX_OK)
        st = dtx_h5_open(a.input, MPI_COMM_NULL, 0, &f, &err);
    if (st == DTX_OK)
        st = source_open(f, a.input, a.item, &s, &mesh, &err);
    if (st == DTX_OK && a.glb && exported_frames(&s) > a.max_frames) {
        int64_t T = exported_frames(&s), k = (s.nframes + a.max_frames - 1) / a.max_frames;
        st = dtx_seterr(&err, DTX_EINVAL,
                        "%s: %lld frames to export, more than --max-frames %d; export one "
                        "frame in %lld with --stride %lld, or raise --max-frames (a .glb holds "
                        "at most %d)",
                        a.glb, (long long)T, a.max_frames, (long long)k, (long long)k,
                        DTX_GLB_MAX_FRAMES);
    }
    if (st == DTX_OK && a.obj_rest)
        st = check_output(a.obj_rest, &err);
    if (st == DTX_OK && a.pc2)
        st = check_output(a.pc2, &err);
    if (st == DTX_OK && a.glb)
        st = check_output(a.glb, &err);
    if (st == DTX_OK && a.mdd)
        st = check_output(a.mdd, &err);
    if (st == DTX_OK && a.fps > 0.0)
        s.fps = a.fps; /* --fps overrides the stored rate */
    if (st == DTX_OK && (a.glb || a.mdd))
        fprintf(stderr, "dtx: %.6g frames per second (%s)\n", s.fps,
                a.fps > 0.0      ? "--fps"
                : s.fps_stored ? "stored with the frames"
                               : "none stored: 24 assumed; set it with --fps");
    if (st == DTX_OK) {
        X = dtx_alloc((size_t)s.nv, 3 * sizeof *X, 0);
        if (!X)
            st = dtx_seterr(&err, DTX_ENOMEM, "out of memory");
    }
    if (st == DTX_OK)
        st = check_frames(&s, &a, X, &err);

    /* ---- outputs (each file is atomic; which ones are new is noted so
     * that a later failure, such as a full disk, removes them again) */
    new_rest = a.obj_rest && access(a.obj_rest, F_OK) != 0;
    new_pc2 = a.pc2 && access(a.pc2, F_OK) != 0;
    new_glb = a.glb && access(a.glb, F_OK) != 0;
    if (st == DTX_OK && a.obj_rest) {
        st = write_obj_rest(f, &s, &a, &mesh, &err);
        if (st == DTX_OK)
            fprintf(stderr, "dtx: mesh (%d vertices, %d faces) -> %s\n", (int)mesh.nv, (int)mesh.nf,
                    a.obj_rest);
    }
    if (st == DTX_OK && a.pc2)
        st = write_pc2(&s, &a, X, &err);
    if (st == DTX_OK && a.mdd)
        st = write_mdd(&s, &a, X, &err);
    if (st == DTX_OK && a.glb)
        st = write_glb(&s, &a, &mesh, f, a.input, &err);
    if (st == DTX_OK && a.obj_dir)
        st = write_obj_dir(f, &s, &a, &mesh, X, &err);
    if (st != DTX_OK) {
        const char *made[3] = {new_rest ? a.obj_rest : NULL, new_pc2 ? a.pc2 : NULL,
                               new_glb ? a.glb : NULL};
        for (int i = 0; i < 3; i++)
            if (made[i] && remove(made[i]) == 0)
                fprintf(stderr, "dtx: %s removed again (the export failed)\n", made[i]);
    }

    free(X);
    dtx_mesh_free(&mesh);
    source_close(&s);
    dtx_h5_close(&f, NULL);
    return st == DTX_OK ? 0 : dtx_cli_fail(&err);
}
