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
#include "h5layout.h"
#include "h5mesh_attrs.h"
#include "meshfile.h"
#include "path_guard.h"

#include <ctype.h>
#include <dirent.h>
#include <errno.h>
#include <fnmatch.h>
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
    if (dtx_cli_positionals(argc, argv, 3, pos, 2) != 1 || !out || !name)
        return usage(argc, argv, "import mesh needs one mesh file, -o OUT.h5 and --name NAME");
    if (check_import_name(name, &err) != DTX_OK)
        return dtx_cli_fail(&err);
    if ((st = check_import_output(pos, 1, "the mesh file", out, &err)) != DTX_OK)
        return dtx_cli_fail(&err);
    /* glTF 2.0 and FBX through assimp, with their UVs, normals, materials. */
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
        if (n > 4 && strcasecmp(pos[0] + n - 4, ".obj") == 0 &&
            (st = dtx_obj_read_attrs(pos[0], m.nf, &attrs, &err)) != DTX_OK) {
            dtx_mesh_free(&m);
            return dtx_cli_fail(&err);
        }
        /* PLY vertex colours, normals and texture coordinates likewise. */
        if (n > 4 && strcasecmp(pos[0] + n - 4, ".ply") == 0 &&
            (st = dtx_ply_read_attrs(pos[0], m.nf, &attrs, &w, &err)) != DTX_OK) {
            dtx_mesh_free(&m);
            return dtx_cli_fail(&err);
        }
    }
    st = open_for_import(out, &f, &created, &err);
    if (st == DTX_OK)
        st = dtx_h5_write_mesh_with(f, group, &m, &attrs, pos[0], &err);
    dtx_mesh_free(&m);
    dtx_mesh_attrs_free(&attrs);
    if (st == DTX_OK)
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
    if (npos < 1 || npos > 100000 || !out || !name || !mesh)
        return usage(argc, argv,
                     "import sequence needs frame files or a directory, -o OUT.h5, --name NAME "
                     "and --mesh /meshes/MESH");
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
    if (check_import_name(name, &err) != DTX_OK)
        return dtx_cli_fail(&err);
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
