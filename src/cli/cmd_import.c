/*
 * cmd_import.c: `dtx import mesh`, `dtx import sequence` and `dtx import
 * markers`, which add a mesh, a sequence of frames or a marker set to a dtx
 * file (creating it when missing).  An import checks its arguments, then
 * reads and checks every input before it writes; a file it created is
 * removed again when the import fails.
 */
#include "cmd_import.h"

#include "cli_util.h"
#include "options.h"

#include "assimp_import.h"
#include "dtx_core.h"
#include "h5frames.h"
#include "h5layout.h"
#include "h5mesh_attrs.h"
#include "mdd.h"
#include "meshfile.h"
#include "npy.h"
#include "path_guard.h"
#include "pc2.h"

#include <ctype.h>
#include <dirent.h>
#include <errno.h>
#include <fnmatch.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

/* A usage error of the import command of argv ("import mesh", ...). */
static int usage(int argc, char **argv, const char *msg)
{
    return dtx_cli_usage_rank0(dtx_cli_find(argc, argv), msg);
}

/* Before an import reads anything: OUT.h5 is none of the n input files
 * (path_guard.h) and not a directory or other special file. */
static dtx_status check_import_output(char *const *inputs, int n, const char *role, const char *out,
                                      dtx_error *err)
{
    dtx_path_guard g;
    dtx_status st = DTX_OK;
    dtx_path_guard_init(&g);
    for (int i = 0; i < n && st == DTX_OK; i++)
        st = dtx_path_guard_add(&g, inputs[i], role, err);
    if (st == DTX_OK)
        st = dtx_path_guard_check(&g, out, "the output, -o", err);
    dtx_path_guard_free(&g);
    return st == DTX_OK ? dtx_output_path_check(out, "the output, -o", err) : st;
}

/* Opens OUT.h5 for adding objects, creating it when missing (*created = 1). */
static dtx_status open_for_import(const char *path, hid_t *file, int *created, dtx_error *err)
{
    *created = access(path, F_OK) != 0;
    if (*created)
        return dtx_h5_create(path, MPI_COMM_NULL, file, err);
    return dtx_h5_open(path, MPI_COMM_NULL, 1, file, err);
}

static int finish_import(const char *path, hid_t *file, int created, dtx_status st, dtx_error *err)
{
    dtx_error e2;
    if (dtx_h5_close(file, &e2) != DTX_OK && st == DTX_OK) {
        *err = e2;
        st = e2.code;
    }
    if (st != DTX_OK) {
        if (created)
            remove(path); /* no half-written new file */
        return dtx_cli_fail(err);
    }
    return 0;
}

/* --name NAME of an import: checked before any file is read or opened, so
 * a bad name costs nothing and leaves nothing (the writers check it again). */
static dtx_status check_import_name(const char *name, dtx_error *err)
{
    dtx_status st = dtx_h5_check_name(name, err);
    if (st != DTX_OK)
        dtx_error_prefix(err, "--name");
    return st;
}

static dtx_status read_faces_arg(hid_t in, const char *input, const char *arg, int32_t nv,
                                 int32_t *nf, int32_t **F, dtx_error *err);
static void split_faces_arg(const char *arg, const char *input, char *file, size_t n,
                            const char **path);

/* A rest mesh from frame `frame` of an HDF5 dataset (any axis order) and
 * the faces --faces names (DFAUST: one frame of a sequence and /faces). */
static dtx_status mesh_from_dataset(const char *input, const char *dataset, const char *axes,
                                    int32_t frame, const char *faces, const char *out, dtx_mesh *m,
                                    dtx_error *err)
{
    dtx_h5_frames fr;
    hid_t in;
    dtx_status st;
    char file[4096];
    const char *path;
    memset(m, 0, sizeof *m);
    split_faces_arg(faces, input, file, sizeof file, &path);
    if (strcmp(file, input) != 0) {
        char *inputs[1] = {file};
        if ((st = check_import_output(inputs, 1, "the faces file", out, err)) != DTX_OK)
            return st;
    }
    if ((st = dtx_h5_foreign_open(input, &in, err)) != DTX_OK)
        return st;
    st = dtx_h5_frames_open(in, input, dataset, axes, &fr, err);
    if (st == DTX_OK && frame >= fr.nframes)
        st = dtx_seterr(err, DTX_EINVAL, "%s: --frame %d, but the dataset has %d frames", fr.name,
                        (int)frame, (int)fr.nframes);
    if (st == DTX_OK) {
        m->nv = fr.nv;
        if (!(m->V = dtx_alloc((size_t)fr.nv * 3, sizeof *m->V, 0)))
            st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
    }
    if (st == DTX_OK)
        st = dtx_h5_frames_read(&fr, frame, 1, m->V, err);
    if (st == DTX_OK)
        st = read_faces_arg(in, input, faces, fr.nv, &m->nf, &m->F, err);
    dtx_h5_frames_close(&fr);
    H5Fclose(in);
    if (st != DTX_OK)
        dtx_mesh_free(m);
    return st;
}

static int import_mesh(int argc, char **argv)
{
    char *pos[2];
    const char *out = dtx_cli_opt_value(argc, argv, "-o"),
               *name = dtx_cli_opt_value(argc, argv, "--name");
    dtx_error err;
    dtx_mesh m;
    dtx_warner w = {dtx_cli_print_warning, NULL};
    hid_t f = H5I_INVALID_HID;
    int created = 0;
    char group[DTX_H5_PATH_MAX];
    dtx_mesh_attrs attrs = {0};
    dtx_status st;
    const char *dataset = dtx_cli_opt_value(argc, argv, "--dataset"),
               *faces = dtx_cli_opt_value(argc, argv, "--faces"),
               *axes = dtx_cli_opt_value(argc, argv, "--axes"),
               *frame_s = dtx_cli_opt_value(argc, argv, "--frame");
    long frame = 0;
    if (dtx_cli_positionals(argc, argv, 3, pos, 2) != 1 || !out || !name)
        return usage(argc, argv, "import mesh needs one mesh file, -o OUT.h5 and --name NAME");
    if (!dataset && (faces || axes || frame_s))
        return usage(argc, argv, "--faces, --axes and --frame go with --dataset (an HDF5 input)");
    if (dataset && !faces)
        return usage(argc, argv,
                     "a mesh from an HDF5 dataset needs --faces [FILE:]PATH (its triangles)");
    if (frame_s) {
        char *end;
        errno = 0;
        frame = strtol(frame_s, &end, 10);
        if (*end || end == frame_s || errno || frame < 0 || frame > INT32_MAX)
            return usage(argc, argv, "--frame must be a frame number >= 0");
    }
    if (check_import_name(name, &err) != DTX_OK)
        return dtx_cli_fail(&err);
    if ((st = check_import_output(pos, 1, "the mesh file", out, &err)) != DTX_OK)
        return dtx_cli_fail(&err);
    /* glTF 2.0 and FBX through assimp, with their UVs, normals, materials;
     * one frame of an HDF5 dataset with its faces. */
    if (dataset)
        st = mesh_from_dataset(pos[0], dataset, axes, (int32_t)frame, faces, out, &m, &err);
    else
        st = dtx_assimp_handles(pos[0]) ? dtx_assimp_read(pos[0], &m, &attrs, &w, &err)
                                        : dtx_mesh_read(pos[0], &m, &w, &err);
    if (st != DTX_OK)
        return dtx_cli_fail(&err);
    /* What dtx run and dtx validate would reject is not written. */
    if ((st = dtx_mesh_validate(&m, pos[0], &err)) != DTX_OK) {
        dtx_mesh_free(&m);
        dtx_mesh_attrs_free(&attrs);
        return dtx_cli_fail(&err);
    }
    snprintf(group, sizeof group, "/meshes/%s", name);
    {
        /* OBJ attributes (vt, vn, usemtl, mtllib) are kept with the mesh. */
        size_t n = strlen(pos[0]);
        if (!dataset && n > 4 && strcasecmp(pos[0] + n - 4, ".obj") == 0 &&
            (st = dtx_obj_read_attrs(pos[0], m.nf, &attrs, &err)) != DTX_OK) {
            dtx_mesh_free(&m);
            return dtx_cli_fail(&err);
        }
        /* PLY vertex colours, normals and texture coordinates likewise. */
        if (!dataset && n > 4 && strcasecmp(pos[0] + n - 4, ".ply") == 0 &&
            (st = dtx_ply_read_attrs(pos[0], m.nf, &attrs, &w, &err)) != DTX_OK) {
            dtx_mesh_free(&m);
            return dtx_cli_fail(&err);
        }
    }
    st = open_for_import(out, &f, &created, &err);
    if (st == DTX_OK) {
        /* The mesh's source: the file, and for a dataset which frame. */
        char source[4096];
        if (dataset)
            snprintf(source, sizeof source, "%s:%s frame %ld", pos[0], dataset, frame);
        else
            snprintf(source, sizeof source, "%s", pos[0]);
        st = dtx_h5_write_mesh_with(f, group, &m, &attrs, source, &err);
    }
    dtx_mesh_free(&m);
    dtx_mesh_attrs_free(&attrs);
    if (st == DTX_OK && dataset)
        fprintf(stderr, "dtx: %s:%s frame %ld -> %s:%s\n", pos[0], dataset, frame, out, group);
    else if (st == DTX_OK)
        fprintf(stderr, "dtx: %s -> %s:%s\n", pos[0], out, group);
    return finish_import(out, &f, created, st, &err);
}

/* Natural order: digit runs compare by value ("cat-2" < "cat-10"). */
static int natural_cmp(const void *a, const void *b)
{
    const char *x = *(const char *const *)a, *y = *(const char *const *)b;
    while (*x && *y) {
        if (isdigit((unsigned char)*x) && isdigit((unsigned char)*y)) {
            const char *xs = x, *ys = y;
            size_t lx, ly;
            while (*xs == '0')
                xs++;
            while (*ys == '0')
                ys++;
            x = xs;
            y = ys;
            while (isdigit((unsigned char)*x))
                x++;
            while (isdigit((unsigned char)*y))
                y++;
            lx = (size_t)(x - xs);
            ly = (size_t)(y - ys);
            if (lx != ly)
                return lx < ly ? -1 : 1;
            {
                int c = strncmp(xs, ys, lx);
                if (c)
                    return c;
            }
        } else {
            if (*x != *y)
                return (unsigned char)*x < (unsigned char)*y ? -1 : 1;
            x++;
            y++;
        }
    }
    return (*x != 0) - (*y != 0);
}

static int has_mesh_ext(const char *name)
{
    const char *dot = strrchr(name, '.');
    return dot && (strcasecmp(dot, ".obj") == 0 || strcasecmp(dot, ".ply") == 0 ||
                   strcasecmp(dot, ".off") == 0);
}

/* Which frame files a sequence import takes: --glob (the file name must
 * match; default every .obj, .ply and .off file) and every --exclude (the
 * file name must match none). */
typedef struct {
    const char *glob;
    const char *exclude[64];
    int nexclude;
} frame_filter;

static int frame_wanted(const frame_filter *ff, const char *path)
{
    const char *base = strrchr(path, '/');
    base = base ? base + 1 : path;
    if (ff->glob && fnmatch(ff->glob, base, 0) != 0)
        return 0;
    for (int i = 0; i < ff->nexclude; i++)
        if (fnmatch(ff->exclude[i], base, 0) == 0)
            return 0;
    return 1;
}

/* The frame files: the mesh files of a directory in natural order, or the
 * files given.  Returns a malloc'ed array of malloc'ed paths. */
static char **frame_list(char **pos, int npos, const frame_filter *ff, int *n, dtx_error *err)
{
    struct stat sb;
    char **list = NULL;
    *n = 0;
    if (npos == 1 && stat(pos[0], &sb) == 0 && S_ISDIR(sb.st_mode)) {
        DIR *d = opendir(pos[0]);
        struct dirent *e;
        int cap = 0;
        if (!d) {
            dtx_seterr(err, DTX_EIO, "%s: cannot read directory: %s", pos[0], strerror(errno));
            return NULL;
        }
        while ((e = readdir(d))) {
            if (e->d_name[0] == '.' || !has_mesh_ext(e->d_name) || !frame_wanted(ff, e->d_name))
                continue;
            if (*n == cap) {
                char **nl;
                cap = cap ? 2 * cap : 64;
                nl = realloc(list, (size_t)cap * sizeof *list);
                if (!nl)
                    break;
                list = nl;
            }
            list[*n] = malloc(strlen(pos[0]) + strlen(e->d_name) + 2);
            if (!list[*n])
                break;
            sprintf(list[*n], "%s/%s", pos[0], e->d_name);
            (*n)++;
        }
        closedir(d);
        if (*n == 0) {
            free(list);
            dtx_seterr(err, DTX_EINVAL, "%s: no .obj, .ply or .off files%s", pos[0],
                       ff->glob || ff->nexclude ? " left by --glob and --exclude" : "");
            return NULL;
        }
        qsort(list, (size_t)*n, sizeof *list, natural_cmp);
        return list;
    }
    list = calloc((size_t)npos + 1, sizeof *list);
    if (!list) {
        dtx_seterr(err, DTX_ENOMEM, "out of memory");
        return NULL;
    }
    for (int i = 0; i < npos; i++) {
        /* A path that is not there is said so (rather than "unknown mesh
         * file type" from a reader dispatching on the extension). */
        if (stat(pos[i], &sb) != 0) {
            dtx_seterr(err, DTX_EIO, "%s: %s", pos[i],
                       errno == ENOENT ? "no such file or directory" : strerror(errno));
            for (int j = 0; j < i; j++)
                free(list[j]);
            free(list);
            return NULL;
        }
        if (frame_wanted(ff, pos[i]))
            list[(*n)++] = strdup(pos[i]);
    }
    if (*n == 0) {
        free(list);
        dtx_seterr(err, DTX_EINVAL, "no frame file left by --glob and --exclude");
        return NULL;
    }
    return list;
}

/* Frames read and checked by the first pass are kept in memory up to this
 * many bytes, so that most imports read each file once. */
#define IMPORT_FRAME_CACHE_BYTES ((size_t)256 << 20)

/* Reads frame i from path and checks it against the rest mesh (vertex count,
 * identical faces; the readers reject non-finite coordinates); copies its
 * positions (nv x 3 doubles) to dst when dst is not NULL.  Warnings are
 * printed unless quiet (a frame read the second time). */
static dtx_status read_frame(const char *path, int i, const dtx_mesh *rest, const char *mesh,
                             double *dst, int quiet, dtx_error *err)
{
    dtx_warner w = {dtx_cli_print_warning, NULL};
    dtx_mesh fr;
    dtx_status st = dtx_mesh_read(path, &fr, quiet ? NULL : &w, err);
    if (st != DTX_OK)
        return st;
    if (fr.nv != rest->nv)
        st =
            dtx_seterr(err, DTX_EFORMAT, "%s: frame %d has %d vertices but the rest mesh %s has %d",
                       path, i, (int)fr.nv, mesh, (int)rest->nv);
    else if (fr.nf != rest->nf ||
             memcmp(fr.F, rest->F, (size_t)rest->nf * 3 * sizeof *rest->F) != 0)
        st = dtx_seterr(err, DTX_EFORMAT,
                        "%s: frame %d has different faces from the rest mesh %s (%d faces "
                        "vs %d): every frame must share the rest mesh's connectivity",
                        path, i, mesh, (int)fr.nf, (int)rest->nf);
    else if (dst)
        memcpy(dst, fr.V, (size_t)rest->nv * 3 * sizeof *dst);
    /* A folder of poses often holds the reference pose too, which would
     * become an extra frame. */
    if (st == DTX_OK && !quiet && memcmp(fr.V, rest->V, (size_t)rest->nv * 3 * sizeof *fr.V) == 0)
        fprintf(stderr,
                "dtx: warning: %s: frame %d is identical to the rest mesh %s (the reference "
                "pose? --exclude '%s' leaves it out)\n",
                path, i, mesh, strrchr(path, '/') ? strrchr(path, '/') + 1 : path);
    dtx_mesh_free(&fr);
    return st;
}

/* ------------------------------------------------------------------ */
/* Dataset layouts: .npy, PC2, MDD, HDF5 datasets of any axis order    */
/* ------------------------------------------------------------------ */

/* Where a sequence's frames come from when they are not mesh files. */
typedef enum { LAYOUT_NONE, LAYOUT_NPY, LAYOUT_PC2, LAYOUT_MDD, LAYOUT_HDF5 } layout_kind;

static int has_ext(const char *path, const char *ext)
{
    size_t n = strlen(path), e = strlen(ext);
    return n > e && strcasecmp(path + n - e, ext) == 0;
}

/* The layout of the inputs of `import sequence`: an HDF5 dataset when
 * --dataset is given, else one .npy, .pc2 or .mdd file; LAYOUT_NONE for
 * mesh files and folders. */
static layout_kind layout_of(char **pos, int npos, const char *dataset)
{
    if (dataset)
        return LAYOUT_HDF5;
    if (npos != 1)
        return LAYOUT_NONE;
    if (has_ext(pos[0], ".npy"))
        return LAYOUT_NPY;
    if (has_ext(pos[0], ".pc2"))
        return LAYOUT_PC2;
    if (has_ext(pos[0], ".mdd"))
        return LAYOUT_MDD;
    return LAYOUT_NONE;
}

/* One sequence's frames: all in memory (X, from .npy, PC2, MDD) or read a
 * block at a time from an HDF5 dataset (h5). */
typedef struct {
    const char *name; /* for messages: the file, or FILE:/dataset */
    int32_t nframes, nv;
    double *X; /* nframes x nv x 3, or NULL */
    dtx_h5_frames h5;
} frame_src;

static dtx_status frame_src_read(const frame_src *s, int32_t first, int32_t n, double *dst,
                                 dtx_error *err)
{
    if (s->X) {
        memcpy(dst, s->X + (size_t)first * 3 * s->nv, (size_t)n * 3 * s->nv * sizeof *dst);
        return DTX_OK;
    }
    return dtx_h5_frames_read(&s->h5, first, n, dst, err);
}

static void frame_src_free(frame_src *s)
{
    free(s->X);
    s->X = NULL;
    dtx_h5_frames_close(&s->h5);
}

/* Point caches hold float32: every value becomes a double (exactly). */
static double *floats_to_doubles(const float *P, size_t n)
{
    double *X = dtx_alloc(n, sizeof *X, 0);
    for (size_t i = 0; X && i < n; i++)
        X[i] = (double)P[i];
    return X;
}

/* Loads a .npy, PC2 or MDD file into s (all frames in memory). */
static dtx_status frame_src_load_file(layout_kind kind, const char *path, frame_src *s,
                                      dtx_error *err)
{
    dtx_status st;
    float *P = NULL, *times = NULL;
    memset(s, 0, sizeof *s);
    s->h5.dset = H5I_INVALID_HID;
    s->name = path;
    if (kind == LAYOUT_NPY)
        return dtx_npy_read_frames(path, &s->nframes, &s->nv, &s->X, err);
    if (kind == LAYOUT_PC2) {
        dtx_pc2_header h;
        if ((st = dtx_pc2_read(path, &h, &P, err)) != DTX_OK)
            return st;
        s->nframes = h.num_samples;
        s->nv = h.num_points;
    } else {
        st = dtx_mdd_read(path, &s->nframes, &s->nv, &times, &P, err);
        free(times);
        if (st != DTX_OK)
            return st;
    }
    s->X = floats_to_doubles(P, (size_t)s->nframes * (size_t)s->nv * 3);
    free(P);
    if (!s->X)
        return dtx_seterr(err, DTX_ENOMEM, "%s: out of memory", path);
    return DTX_OK;
}

/* Pass 1 of a layout import: the vertex count against the rest mesh, and
 * every coordinate finite (read in blocks of buf's nframes). */
static dtx_status frame_src_check(const frame_src *s, const dtx_mesh *rest, const char *mesh,
                                  double *buf, int chunk, dtx_error *err)
{
    if (s->nv != rest->nv)
        return dtx_seterr(err, DTX_EFORMAT,
                          "%s: %d vertices per frame but the rest mesh %s has %d (the same "
                          "vertices in the same order are needed)",
                          s->name, (int)s->nv, mesh, (int)rest->nv);
    for (int32_t f0 = 0; f0 < s->nframes; f0 += chunk) {
        int32_t n = s->nframes - f0 < chunk ? s->nframes - f0 : chunk;
        const double *X;
        dtx_status st;
        if (s->X) {
            X = s->X + (size_t)f0 * 3 * s->nv;
        } else {
            if ((st = frame_src_read(s, f0, n, buf, err)) != DTX_OK)
                return st;
            X = buf;
        }
        for (size_t i = 0; i < (size_t)n * 3 * s->nv; i++)
            if (!isfinite(X[i]))
                return dtx_seterr(err, DTX_ENONFINITE,
                                  "%s: frame %lld (0-based), vertex %lld has a non-finite "
                                  "coordinate (%g)",
                                  s->name, (long long)(f0 + (int32_t)(i / 3 / s->nv)),
                                  (long long)(i / 3 % s->nv), X[i]);
    }
    return DTX_OK;
}

/* Pass 2: writes s as the sequence group (already checked) of rest mesh
 * `mesh`; on failure nothing of it stays in the file. */
static dtx_status frame_src_write(hid_t f, const char *out, const frame_src *s, const char *group,
                                  const char *mesh, int f64, int gzip, double fps, double *buf,
                                  int chunk, dtx_error *err)
{
    dtx_h5_seq seq;
    dtx_error e2;
    dtx_status st;
    int made;
    memset(&seq, 0, sizeof seq);
    st = dtx_h5_seq_create(f, group, mesh, s->nframes, s->nv, f64, chunk, gzip, &seq, err);
    made = st == DTX_OK;
    for (int32_t f0 = 0; st == DTX_OK && f0 < s->nframes; f0 += chunk) {
        int32_t n = s->nframes - f0 < chunk ? s->nframes - f0 : chunk;
        if (s->X) {
            st = dtx_h5_seq_write(&seq, f0, n, s->X + (size_t)f0 * 3 * s->nv, 0, err);
        } else {
            st = frame_src_read(s, f0, n, buf, err);
            /* Read again: the file may have changed since pass 1. */
            for (size_t i = 0; st == DTX_OK && i < (size_t)n * 3 * s->nv; i++)
                if (!isfinite(buf[i]))
                    st = dtx_seterr(err, DTX_ENONFINITE,
                                    "%s: frame %lld (0-based) became non-finite while importing",
                                    s->name, (long long)(f0 + (int32_t)(i / 3 / s->nv)));
            if (st == DTX_OK)
                st = dtx_h5_seq_write(&seq, f0, n, buf, 0, err);
        }
    }
    if (st == DTX_OK && fps > 0.0)
        st = dtx_h5_write_fps(seq.group, ".", fps, err);
    if (st == DTX_OK)
        st = dtx_h5_seq_commit(&seq, err);
    dtx_h5_seq_close(&seq);
    if (st != DTX_OK && made && !seq.committed)
        dtx_h5_remove(f, seq.path, &e2);
    if (st == DTX_OK)
        fprintf(stderr, "dtx: %s: %d frames -> %s:%s (%s)\n", s->name, (int)s->nframes, out, group,
                f64 ? "float64" : "float32");
    return st;
}

/* --faces [FILE:]/PATH: the file (the input itself when the value starts
 * with '/') and the dataset path. */
static void split_faces_arg(const char *arg, const char *input, char *file, size_t n,
                            const char **path)
{
    const char *c = strstr(arg, ":/");
    if (arg[0] == '/' || !c) {
        snprintf(file, n, "%s", input);
        *path = arg;
    } else {
        snprintf(file, n, "%.*s", (int)(c - arg), arg);
        *path = c + 1;
    }
}

/* Reads the faces --faces names (nv: the vertex count they index). */
static dtx_status read_faces_arg(hid_t in, const char *input, const char *arg, int32_t nv,
                                 int32_t *nf, int32_t **F, dtx_error *err)
{
    char file[4096];
    const char *path;
    hid_t h = in;
    dtx_status st;
    split_faces_arg(arg, input, file, sizeof file, &path);
    if (strcmp(file, input) != 0 && (st = dtx_h5_foreign_open(file, &h, err)) != DTX_OK) {
        dtx_error_prefix(err, "--faces");
        return st;
    }
    st = dtx_h5_read_faces(h, file, path, nv, nf, F, err);
    if (h != in)
        H5Fclose(h);
    return st;
}

/* The group and name pattern of a --dataset with a wildcard ('*', '?' or
 * '[') after its last '/'; 0 when it has none. */
static int dataset_wildcard(const char *dataset, char *group, size_t n, const char **pattern)
{
    const char *sl = strrchr(dataset, '/');
    const char *last = sl ? sl + 1 : dataset;
    if (!strpbrk(last, "*?["))
        return 0;
    if (!sl || sl == dataset)
        snprintf(group, n, "/");
    else
        snprintf(group, n, "%.*s", (int)(sl - dataset), dataset);
    *pattern = last;
    return 1;
}

/* The same dataset path, with or without the leading '/'. */
static int same_dataset(const char *a, const char *b)
{
    while (*a == '/')
        a++;
    while (*b == '/')
        b++;
    return strcmp(a, b) == 0;
}

/* `import sequence` of a .npy, PC2 or MDD file, or of one or every
 * matching dataset of an HDF5 file.  Every sequence is read and checked
 * before the output changes; a wildcard's sequences are all checked before
 * the first is written. */
static int import_layout(layout_kind kind, const char *input, const char *out, const char *name,
                         const char *mesh, const char *dataset, const char *axes, const char *faces,
                         int f64, int gzip, double fps)
{
    const int chunk = DTX_H5_DEFAULT_CHUNK_FRAMES;
    char **dsets = NULL, wgroup[DTX_H5_PATH_MAX], faces_file[4096];
    const char *pattern = NULL, *faces_path = NULL;
    int ndsets = 0, created = 0, wild = 0;
    char *inputs[1];
    hid_t f = H5I_INVALID_HID, in = H5I_INVALID_HID;
    dtx_mesh rest;
    dtx_error err;
    dtx_status st;
    double *buf = NULL;
    frame_src s;
    memset(&rest, 0, sizeof rest);
    memset(&s, 0, sizeof s);
    s.h5.dset = H5I_INVALID_HID;
    inputs[0] = (char *)input;
    if ((st = check_import_output(inputs, 1, "the input file", out, &err)) != DTX_OK)
        return dtx_cli_fail(&err);
    if (faces) {
        split_faces_arg(faces, input, faces_file, sizeof faces_file, &faces_path);
        if (strcmp(faces_file, input) != 0) {
            inputs[0] = faces_file;
            if ((st = check_import_output(inputs, 1, "the faces file", out, &err)) != DTX_OK)
                return dtx_cli_fail(&err);
        }
    }
    /* ---- the input's sequences (HDF5: which datasets) */
    if (kind == LAYOUT_HDF5) {
        if ((st = dtx_h5_foreign_open(input, &in, &err)) != DTX_OK)
            return dtx_cli_fail(&err);
        wild = dataset_wildcard(dataset, wgroup, sizeof wgroup, &pattern);
        if (wild) {
            st = dtx_h5_match_datasets(in, input, wgroup, pattern, &dsets, &ndsets, &err);
            /* The faces dataset of the same file is not a sequence. */
            if (st == DTX_OK && faces_path && strcmp(faces_file, input) == 0) {
                int k = 0;
                for (int i = 0; i < ndsets; i++) {
                    if (same_dataset(dsets[i], faces_path))
                        free(dsets[i]);
                    else
                        dsets[k++] = dsets[i];
                }
                ndsets = k;
            }
            if (st == DTX_OK && ndsets == 0)
                st = dtx_seterr(&err, DTX_EINVAL, "%s: no dataset in %s matches '%s'%s", input,
                                wgroup, pattern, faces_path ? " (besides the faces)" : "");
        } else if (!(dsets = calloc(1, sizeof *dsets)) || !(dsets[0] = strdup(dataset))) {
            st = dtx_seterr(&err, DTX_ENOMEM, "out of memory");
        } else {
            ndsets = 1;
        }
    } else {
        ndsets = 1;
    }
    if (st != DTX_OK)
        goto done;
    /* ---- the sequence names, before any file is written */
    for (int i = 0; wild && i < ndsets; i++) {
        const char *base = strrchr(dsets[i], '/') ? strrchr(dsets[i], '/') + 1 : dsets[i];
        if ((st = dtx_h5_check_name(base, &err)) != DTX_OK) {
            dtx_error_prefix(&err, "%s:%s: the dataset's name cannot name a sequence", input,
                             dsets[i]);
            goto done;
        }
    }
    st = open_for_import(out, &f, &created, &err);
    if (st == DTX_OK)
        st = dtx_h5_read_mesh(f, mesh, &rest, &err);
    if (st == DTX_OK && !(buf = dtx_alloc((size_t)chunk * 3, (size_t)rest.nv * sizeof *buf, 0)))
        st = dtx_seterr(&err, DTX_ENOMEM, "out of memory");
    if (st != DTX_OK)
        goto done;
    /* ---- the faces must be the rest mesh's */
    if (faces) {
        int32_t nf = 0, *F = NULL;
        st = read_faces_arg(in, input, faces, rest.nv, &nf, &F, &err);
        if (st == DTX_OK && (nf != rest.nf || memcmp(F, rest.F, (size_t)nf * 3 * sizeof *F) != 0))
            st = dtx_seterr(&err, DTX_EFORMAT,
                            "faces %s:%s differ from the rest mesh %s's (%d faces vs %d%s): the "
                            "frames must share the rest mesh's connectivity and vertex order",
                            faces_file, faces_path, mesh, (int)nf, (int)rest.nf,
                            nf == rest.nf ? ", not the same triangles" : "");
        free(F);
        if (st != DTX_OK)
            goto done;
    }
    /* ---- pass 1: every sequence read and checked; nothing written yet */
    for (int i = 0; st == DTX_OK && i < ndsets; i++) {
        char group[DTX_H5_PATH_MAX];
        const char *base = wild ? strrchr(dsets[i], '/') + 1 : name;
        snprintf(group, sizeof group, "/sequences/%s", base);
        if (dtx_h5_path_exists(f, group)) {
            st =
                dtx_seterr(&err, DTX_EINVAL, "%s:%s exists already (dtx rm %s %s removes it first)",
                           out, group, out, group);
            break;
        }
        if (kind == LAYOUT_HDF5)
            st = dtx_h5_frames_open(in, input, dsets[i], axes, &s.h5, &err);
        else
            st = frame_src_load_file(kind, input, &s, &err);
        if (kind == LAYOUT_HDF5) {
            s.name = s.h5.name;
            s.nframes = s.h5.nframes;
            s.nv = s.h5.nv;
        }
        if (st == DTX_OK)
            st = frame_src_check(&s, &rest, mesh, buf, chunk, &err);
        if (st != DTX_OK && wild)
            dtx_error_prefix(&err,
                             "--dataset '%s' matched it (name the faces with --faces, or "
                             "narrow the pattern)",
                             dataset);
        /* A file's frames stay in memory for pass 2; datasets are read again. */
        if (kind == LAYOUT_HDF5)
            frame_src_free(&s);
    }
    /* ---- pass 2: write */
    for (int i = 0; st == DTX_OK && i < ndsets; i++) {
        char group[DTX_H5_PATH_MAX];
        const char *base = wild ? strrchr(dsets[i], '/') + 1 : name;
        snprintf(group, sizeof group, "/sequences/%s", base);
        if (kind == LAYOUT_HDF5) {
            st = dtx_h5_frames_open(in, input, dsets[i], axes, &s.h5, &err);
            s.name = s.h5.name;
            s.nframes = s.h5.nframes;
            s.nv = s.h5.nv;
        }
        if (st == DTX_OK)
            st = frame_src_write(f, out, &s, group, mesh, f64, gzip, fps, buf, chunk, &err);
        if (kind == LAYOUT_HDF5)
            frame_src_free(&s);
        /* A wildcard import that fails after writing some sequences says
         * which are in the file (each is whole). */
        if (st != DTX_OK && i > 0 && !created)
            dtx_error_prefix(&err, "after writing %d of the %d sequences (those stay in %s)", i,
                             ndsets, out);
    }
done:
    frame_src_free(&s);
    for (int i = 0; dsets && i < ndsets; i++)
        free(dsets[i]);
    free(dsets);
    free(buf);
    dtx_mesh_free(&rest);
    if (in >= 0)
        H5Fclose(in);
    return finish_import(out, &f, created, st, &err);
}

static int import_sequence(int argc, char **argv)
{
    char *pos[100000];
    int npos = dtx_cli_positionals(argc, argv, 3, pos, 100000), nframes = 0, created = 0;
    const char *out = dtx_cli_opt_value(argc, argv, "-o"),
               *name = dtx_cli_opt_value(argc, argv, "--name"),
               *mesh = dtx_cli_opt_value(argc, argv, "--mesh"),
               *dtype = dtx_cli_opt_value(argc, argv, "--dtype"),
               *compress = dtx_cli_opt_value(argc, argv, "--compress"),
               *fps_s = dtx_cli_opt_value(argc, argv, "--fps");
    char **files = NULL, group[DTX_H5_PATH_MAX];
    double fps = 0.0; /* 0: not given, none stored (readers assume 24) */
    frame_filter ff;
    dtx_error err, e2;
    dtx_status st;
    dtx_mesh rest;
    dtx_h5_seq seq;
    hid_t f = H5I_INVALID_HID;
    double *buf = NULL, *cache = NULL;
    const int chunk = DTX_H5_DEFAULT_CHUNK_FRAMES;
    int f64 = 0, gzip = 0, ncached = 0, seq_made = 0;
    size_t frame_bytes;
    const char *dataset = dtx_cli_opt_value(argc, argv, "--dataset"),
               *axes = dtx_cli_opt_value(argc, argv, "--axes"),
               *faces = dtx_cli_opt_value(argc, argv, "--faces");
    const layout_kind kind = layout_of(pos, npos, dataset);
    char wgroup[DTX_H5_PATH_MAX];
    const char *wpattern;
    /* A wildcard --dataset names each sequence after its dataset. */
    const int wild = dataset && dataset_wildcard(dataset, wgroup, sizeof wgroup, &wpattern);
    if (npos < 1 || npos > 100000 || !out || (!name && !wild) || !mesh)
        return usage(argc, argv,
                     "import sequence needs frame files, a directory, a .npy, .pc2 or .mdd "
                     "file or an HDF5 file with --dataset, -o OUT.h5, --name NAME and "
                     "--mesh /meshes/MESH");
    if (wild && name)
        return usage(argc, argv,
                     "--name goes with one sequence: a --dataset wildcard names each sequence "
                     "after its dataset");
    if (kind == LAYOUT_HDF5 && npos != 1)
        return usage(argc, argv, "--dataset reads one HDF5 file");
    for (int i = 0; kind == LAYOUT_NONE && npos > 1 && i < npos && i < 100000; i++)
        if (has_ext(pos[i], ".npy") || has_ext(pos[i], ".pc2") || has_ext(pos[i], ".mdd"))
            return usage(argc, argv,
                         "a .npy, .pc2 or .mdd file is a whole sequence: import one at a time");
    if (kind != LAYOUT_HDF5 && (axes || faces))
        return usage(argc, argv, "--axes and --faces go with --dataset (an HDF5 input)");
    if (kind != LAYOUT_NONE &&
        (dtx_cli_opt_value(argc, argv, "--glob") || dtx_cli_opt_value(argc, argv, "--exclude")))
        return usage(argc, argv, "--glob and --exclude choose mesh files of a folder or list");
    if (dtype && strcmp(dtype, "float64") == 0)
        f64 = 1;
    else if (dtype && strcmp(dtype, "float32") != 0)
        return usage(argc, argv, "--dtype must be float32 or float64");
    /* Not compressed by default: gzip shrinks float32 positions only about
     * 1.4:1 and inflating them costs more than transferring the frame. */
    if (compress && strcmp(compress, "gzip") == 0)
        gzip = 1;
    else if (compress && strcmp(compress, "none") != 0)
        return usage(argc, argv, "--compress must be none or gzip");
    if (fps_s) {
        char *end;
        fps = strtod(fps_s, &end);
        if (*end || end == fps_s || !(fps > 0.0) || !(fps <= DTX_H5_FPS_MAX))
            return usage(argc, argv, "--fps must be a number > 0 (frames per second, at most 1e6)");
    }
    if (name && check_import_name(name, &err) != DTX_OK)
        return dtx_cli_fail(&err);
    if (kind != LAYOUT_NONE)
        return import_layout(kind, pos[0], out, name, mesh, dataset, axes, faces, f64, gzip, fps);
    memset(&rest, 0, sizeof rest);
    memset(&seq, 0, sizeof seq);
    memset(&ff, 0, sizeof ff);
    ff.glob = dtx_cli_opt_value(argc, argv, "--glob");
    for (int i = 3; i + 1 < argc; i++)
        if (strcmp(argv[i], "--exclude") == 0) {
            if (ff.nexclude == (int)(sizeof ff.exclude / sizeof *ff.exclude))
                return usage(argc, argv, "--exclude given more than 64 times");
            ff.exclude[ff.nexclude++] = argv[++i];
        }
    files = frame_list(pos, npos, &ff, &nframes, &err);
    if (!files)
        return dtx_cli_fail(&err);
    if ((st = check_import_output(files, nframes, "a frame file", out, &err)) != DTX_OK) {
        for (int i = 0; i < nframes; i++)
            free(files[i]);
        free(files);
        return dtx_cli_fail(&err);
    }
    snprintf(group, sizeof group, "/sequences/%s", name);
    st = open_for_import(out, &f, &created, &err);
    if (st == DTX_OK)
        st = dtx_h5_read_mesh(f, mesh, &rest, &err);
    if (st != DTX_OK)
        goto done;
    frame_bytes = (size_t)rest.nv * 3 * sizeof(double);

    /* ---- pass 1: every frame is read and checked before the file changes.
     * A sequence that fails half-way must leave an existing file as it was,
     * and HDF5 does not give freed space back: chunks written before a bad
     * frame and then unlinked would stay in the file as dead bytes (only an
     * h5repack rewrite recovers them).  Checking first avoids allocating at
     * all; a temporary file copied in on success would cost a second write
     * of every frame, and a file-space strategy (H5Pset_file_space_strategy)
     * can only be chosen when a file is created, not for the existing files
     * this appends to.  Frames are kept for pass 2 up to
     * IMPORT_FRAME_CACHE_BYTES; the rest are read again. */
    ncached = frame_bytes ? (int)(IMPORT_FRAME_CACHE_BYTES / frame_bytes) : 0;
    if (ncached > nframes)
        ncached = nframes;
    {
        /* For the tests: DTX_IMPORT_CACHE_FRAMES=N keeps at most N frames,
         * so that small sequences go through the second reading too. */
        const char *cf = getenv("DTX_IMPORT_CACHE_FRAMES");
        if (cf && atoi(cf) >= 0 && atoi(cf) < ncached)
            ncached = atoi(cf);
    }
    if (ncached > 0 && !(cache = dtx_alloc((size_t)ncached, frame_bytes, 0)))
        ncached = 0; /* no memory to spare: read every frame twice */
    for (int i = 0; st == DTX_OK && i < nframes; i++)
        st = read_frame(files[i], i, &rest, mesh,
                        i < ncached ? cache + (size_t)i * 3 * rest.nv : NULL, 0, &err);
    if (st != DTX_OK)
        goto done;

    /* ---- pass 2: write, in chunk-sized blocks. */
    st = dtx_h5_seq_create(f, group, mesh, nframes, rest.nv, f64, chunk, gzip, &seq, &err);
    seq_made = st == DTX_OK;
    if (st == DTX_OK && ncached < nframes && !(buf = dtx_alloc((size_t)chunk, frame_bytes, 0)))
        st = dtx_seterr(&err, DTX_ENOMEM, "out of memory");
    for (int i0 = 0; st == DTX_OK && i0 < nframes; i0 += chunk) {
        int n = nframes - i0 < chunk ? nframes - i0 : chunk;
        const double *src = buf;
        if (i0 + n <= ncached) {
            src = cache + (size_t)i0 * 3 * rest.nv;
        } else {
            /* A file read again is checked again: it may have changed. */
            for (int j = 0; st == DTX_OK && j < n; j++) {
                double *dst = buf + (size_t)j * 3 * rest.nv;
                if (i0 + j < ncached)
                    memcpy(dst, cache + (size_t)(i0 + j) * 3 * rest.nv, frame_bytes);
                else
                    st = read_frame(files[i0 + j], i0 + j, &rest, mesh, dst, 1, &err);
            }
        }
        if (st == DTX_OK)
            st = dtx_h5_seq_write(&seq, i0, n, src, 0, &err);
    }
    if (st == DTX_OK) {
        const char **names = calloc((size_t)nframes, sizeof *names);
        if (!names)
            st = dtx_seterr(&err, DTX_ENOMEM, "out of memory");
        for (int i = 0; names && i < nframes; i++) {
            const char *sl = strrchr(files[i], '/');
            names[i] = sl ? sl + 1 : files[i];
        }
        if (st == DTX_OK)
            st = dtx_h5_write_frame_names(&seq, names, nframes, &err);
        free(names);
    }
    if (st == DTX_OK && fps > 0.0)
        st = dtx_h5_write_fps(seq.group, ".", fps, &err);
    if (st == DTX_OK)
        st = dtx_h5_seq_commit(&seq, &err);
    dtx_h5_seq_close(&seq);
    /* A failure after pass 1 (a frame file changed under us, a full disk)
     * still leaves no temporary group; its space may stay in the file. */
    if (st != DTX_OK && seq_made && !seq.committed)
        dtx_h5_remove(f, seq.path, &e2);
    if (st == DTX_OK)
        fprintf(stderr, "dtx: %d frames -> %s:%s (%s)\n", nframes, out, group,
                f64 ? "float64" : "float32");
done:
    for (int i = 0; i < nframes; i++)
        free(files[i]);
    free(files);
    free(buf);
    free(cache);
    dtx_mesh_free(&rest);
    return finish_import(out, &f, created, st, &err);
}

static int import_markers(int argc, char **argv)
{
    char *pos[2];
    const char *out = dtx_cli_opt_value(argc, argv, "-o"),
               *name = dtx_cli_opt_value(argc, argv, "--name"),
               *base = dtx_cli_opt_value(argc, argv, "--index-base"),
               *src = dtx_cli_opt_value(argc, argv, "--source"),
               *tgt = dtx_cli_opt_value(argc, argv, "--target");
    dtx_error err;
    dtx_status st;
    dtx_markers mk;
    hid_t f = H5I_INVALID_HID;
    int created = 0, ib = -1;
    char group[DTX_H5_PATH_MAX];
    if (dtx_cli_positionals(argc, argv, 3, pos, 2) != 1 || !out || !name)
        return usage(argc, argv,
                     "import markers needs one CSV file, -o OUT.h5 and --name NAME (and "
                     "--index-base 0|1 unless the file has a '# index_base: 0|1' line)");
    /* Without --index-base the file's `# index_base:` line decides (-1), and
     * a file without one is an error; with both they must agree. */
    if (base && strcmp(base, "0") == 0)
        ib = 0;
    else if (base && strcmp(base, "1") == 0)
        ib = 1;
    else if (base)
        return usage(argc, argv, "--index-base must be 0 or 1");
    if ((st = check_import_output(pos, 1, "the markers file", out, &err)) != DTX_OK)
        return dtx_cli_fail(&err);
    st = dtx_markers_read_csv(pos[0], ib, &mk, &err);
    if (st != DTX_OK)
        return dtx_cli_fail(&err);
    snprintf(group, sizeof group, "/markers/%s", name);
    st = open_for_import(out, &f, &created, &err);
    /* When both meshes are named and present, check the ranges now. */
    if (st == DTX_OK && src && tgt && dtx_h5_path_exists(f, src) && dtx_h5_path_exists(f, tgt)) {
        int32_t snv, snf, tnv, tnf;
        st = dtx_h5_mesh_size(f, src, &snv, &snf, &err);
        if (st == DTX_OK)
            st = dtx_h5_mesh_size(f, tgt, &tnv, &tnf, &err);
        if (st == DTX_OK)
            st = dtx_markers_validate(&mk, snv, tnv, pos[0], &err);
    } else if (st == DTX_OK) {
        /* No mesh sizes to check against: still no vertex used twice. */
        st = dtx_markers_validate(&mk, INT32_MAX, INT32_MAX, pos[0], &err);
    }
    if (st == DTX_OK)
        st = dtx_h5_write_markers(f, group, &mk, src, tgt, &err);
    if (st == DTX_OK)
        fprintf(stderr, "dtx: %d markers -> %s:%s\n", (int)mk.n, out, group);
    dtx_markers_free(&mk);
    return finish_import(out, &f, created, st, &err);
}

int dtx_cmd_import(int argc, char **argv)
{
    if (argc >= 3 && strcmp(argv[2], "mesh") == 0)
        return import_mesh(argc, argv);
    if (argc >= 3 && strcmp(argv[2], "sequence") == 0)
        return import_sequence(argc, argv);
    if (argc >= 3 && strcmp(argv[2], "markers") == 0)
        return import_markers(argc, argv);
    /* Every import command's usage. */
    fputs("dtx: import what? mesh, sequence or markers\n", stderr);
    for (const dtx_cli_cmd *const *c = dtx_cli_commands(); *c; c++)
        if (strncmp((*c)->name, "import ", 7) == 0)
            dtx_cli_print_usage(stderr, *c);
    return 2;
}
