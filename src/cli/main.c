/*
 * main.c: the `dtx` command.  Parses the command line, calls the I/O layer
 * and the driver, prints messages.  Exit status 0 on success, 1 on any
 * error (with "dtx: error: ..." on stderr), 2 on a usage error.
 */
#include "assimp_import.h"
#include "cmd_export.h"
#include "cmd_generate.h"
#include "cmd_inspect.h"
#include "cmd_keypoints.h"
#include "cmd_render.h"
#include "cmd_report.h"
#include "cmd_rm.h"
#include "driver.h"
#include "dtx_core.h"
#include "h5layout.h"
#include "job.h"
#include "meshfile.h"
#include "h5mesh_attrs.h"
#include "options.h"

#include <dirent.h>
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>


/* The command being run (for its usage text), set by main(). */
static const dtx_cli_cmd *current_cmd;

/* Under mpirun every rank would print the same usage error: only rank 0 does. */
static int quiet_rank(void)
{
    const char *r = getenv("OMPI_COMM_WORLD_RANK");
    return r && strcmp(r, "0") != 0;
}

static int usage(const char *msg)
{
    if (quiet_rank())
        return 2;
    if (msg)
        fprintf(stderr, "dtx: %s\n", msg);
    if (current_cmd)
        dtx_cli_print_usage(stderr, current_cmd);
    else
        dtx_cli_print_overview(stderr);
    return 2;
}

/* dtx help [COMMAND...], dtx --help */
static int cmd_help(int argc, char **argv)
{
    const dtx_cli_cmd *c;
    if (argc <= 2 || argv[1][0] == '-') {
        dtx_cli_print_overview(stdout);
        return 0;
    }
    /* "help import mesh" finds "import mesh"; "help import" the first import. */
    if (!(c = dtx_cli_find(argc - 1, argv + 1)) && !(c = dtx_cli_find_name(argv[2]))) {
        fprintf(stderr, "dtx: help: unknown command '%s'\n", argv[2]);
        dtx_cli_print_overview(stderr);
        return 2;
    }
    dtx_cli_print_help(stdout, c);
    return 0;
}

/* Checks the options of argv against its command's table: 0 to go on, or the
 * exit status (0 after --help, 2 after a usage error) with *done set. */
static int check_options(int argc, char **argv, int *done)
{
    char msg[512];
    int r;
    *done = 0;
    if (!(current_cmd = dtx_cli_find(argc, argv)))
        return 0;
    r = dtx_cli_check(current_cmd, argc, argv, msg, sizeof msg);
    if (r == 0)
        return 0;
    *done = 1;
    if (r == 1) {
        if (!quiet_rank())
            dtx_cli_print_help(stdout, current_cmd);
        return 0;
    }
    if (!quiet_rank()) {
        fprintf(stderr, "%s\n", msg);
        dtx_cli_print_usage(stderr, current_cmd);
    }
    return 2;
}

static int fail(const dtx_error *err)
{
    fprintf(stderr, "dtx: error: %s\n", err->msg);
    return 1;
}

static void print_warning(void *ctx, const char *msg)
{
    (void)ctx;
    fprintf(stderr, "dtx: warning: %s\n", msg);
}

/* Option lookup: returns the value following `name`, or NULL. */
static const char *opt(int argc, char **argv, const char *name)
{
    for (int i = 0; i < argc - 1; i++)
        if (strcmp(argv[i], name) == 0)
            return argv[i + 1];
    return NULL;
}

static int is_flag_with_value(const char *a)
{
    static const char *const names[] = {"-o",       "--name",   "--mesh",    "--dtype",
                                        "--index-base", "--source", "--target",
                                        "--summary", "--tol", "--compress"};
    for (size_t i = 0; i < sizeof names / sizeof *names; i++)
        if (strcmp(a, names[i]) == 0)
            return 1;
    return 0;
}

/* Positional arguments (not options or option values), from index `from`. */
static int positionals(int argc, char **argv, int from, char **out, int cap)
{
    int n = 0;
    for (int i = from; i < argc; i++) {
        if (is_flag_with_value(argv[i])) {
            i++;
            continue;
        }
        if (argv[i][0] == '-' && argv[i][1] == '-')
            continue;
        if (n < cap)
            out[n] = argv[i];
        n++;
    }
    return n;
}

/* Opens OUT.h5 for adding objects, creating it when missing (*created = 1). */
static dtx_status open_for_import(const char *path, hid_t *file, int *created, dtx_error *err)
{
    *created = access(path, F_OK) != 0;
    if (*created)
        return dtx_h5_create(path, MPI_COMM_NULL, file, err);
    return dtx_h5_open(path, MPI_COMM_NULL, 1, file, err);
}

static int finish_import(const char *path, hid_t *file, int created, dtx_status st,
                         dtx_error *err)
{
    dtx_error e2;
    if (dtx_h5_close(file, &e2) != DTX_OK && st == DTX_OK) {
        *err = e2;
        st = e2.code;
    }
    if (st != DTX_OK) {
        if (created)
            remove(path); /* no half-written new file */
        return fail(err);
    }
    return 0;
}

static int cmd_import_mesh(int argc, char **argv)
{
    char *pos[2];
    const char *out = opt(argc, argv, "-o"), *name = opt(argc, argv, "--name");
    dtx_error err;
    dtx_mesh m;
    dtx_warner w = {print_warning, NULL};
    hid_t f = H5I_INVALID_HID;
    int created = 0;
    char group[DTX_H5_PATH_MAX];
    dtx_mesh_attrs attrs = {0};
    dtx_status st;
    if (positionals(argc, argv, 3, pos, 2) != 1 || !out || !name)
        return usage("import mesh needs one mesh file, -o OUT.h5 and --name NAME");
    /* glTF 2.0 and FBX through assimp, with their UVs, normals, materials. */
    st = dtx_assimp_handles(pos[0]) ? dtx_assimp_read(pos[0], &m, &attrs, &w, &err)
                                    : dtx_mesh_read(pos[0], &m, &w, &err);
    if (st != DTX_OK)
        return fail(&err);
    /* What dtx run and dtx validate would reject is not written. */
    if ((st = dtx_mesh_validate(&m, pos[0], &err)) != DTX_OK) {
        dtx_mesh_free(&m);
        dtx_mesh_attrs_free(&attrs);
        return fail(&err);
    }
    snprintf(group, sizeof group, "/meshes/%s", name);
    {
        /* OBJ attributes (vt, vn, usemtl, mtllib) are kept with the mesh. */
        size_t n = strlen(pos[0]);
        if (n > 4 && strcasecmp(pos[0] + n - 4, ".obj") == 0 &&
            (st = dtx_obj_read_attrs(pos[0], m.nf, &attrs, &err)) != DTX_OK) {
            dtx_mesh_free(&m);
            return fail(&err);
        }
        /* PLY vertex colours, normals and texture coordinates likewise. */
        if (n > 4 && strcasecmp(pos[0] + n - 4, ".ply") == 0 &&
            (st = dtx_ply_read_attrs(pos[0], m.nf, &attrs, &w, &err)) != DTX_OK) {
            dtx_mesh_free(&m);
            return fail(&err);
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

/* The frame files: the mesh files of a directory in natural order, or the
 * files given.  Returns a malloc'ed array of malloc'ed paths. */
static char **frame_list(char **pos, int npos, int *n, dtx_error *err)
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
            if (e->d_name[0] == '.' || !has_mesh_ext(e->d_name))
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
            dtx_seterr(err, DTX_EINVAL, "%s: no .obj, .ply or .off files", pos[0]);
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
    for (int i = 0; i < npos; i++)
        list[i] = strdup(pos[i]);
    *n = npos;
    return list;
}

static int cmd_import_sequence(int argc, char **argv)
{
    char *pos[100000];
    int npos = positionals(argc, argv, 3, pos, 100000), nframes = 0, created = 0;
    const char *out = opt(argc, argv, "-o"), *name = opt(argc, argv, "--name"),
               *mesh = opt(argc, argv, "--mesh"), *dtype = opt(argc, argv, "--dtype"),
               *compress = opt(argc, argv, "--compress");
    char **files = NULL, group[DTX_H5_PATH_MAX];
    dtx_error err;
    dtx_status st;
    dtx_mesh rest, fr;
    dtx_h5_seq seq;
    dtx_warner w = {print_warning, NULL};
    hid_t f = H5I_INVALID_HID;
    double *buf = NULL;
    const int chunk = DTX_H5_DEFAULT_CHUNK_FRAMES;
    int f64 = 0, nbuf = 0, gzip = 0;
    if (npos < 1 || npos > 100000 || !out || !name || !mesh)
        return usage("import sequence needs frame files or a directory, -o OUT.h5, --name NAME "
                     "and --mesh /meshes/MESH");
    if (dtype && strcmp(dtype, "float64") == 0)
        f64 = 1;
    else if (dtype && strcmp(dtype, "float32") != 0)
        return usage("--dtype must be float32 or float64");
    /* Not compressed by default: gzip shrinks float32 positions only about
     * 1.4:1 and inflating them costs more than transferring the frame. */
    if (compress && strcmp(compress, "gzip") == 0)
        gzip = 1;
    else if (compress && strcmp(compress, "none") != 0)
        return usage("--compress must be none or gzip");
    memset(&rest, 0, sizeof rest);
    memset(&seq, 0, sizeof seq);
    files = frame_list(pos, npos, &nframes, &err);
    if (!files)
        return fail(&err);
    snprintf(group, sizeof group, "/sequences/%s", name);
    st = open_for_import(out, &f, &created, &err);
    if (st == DTX_OK)
        st = dtx_h5_read_mesh(f, mesh, &rest, &err);
    if (st == DTX_OK)
        st = dtx_h5_seq_create(f, group, mesh, nframes, rest.nv, f64, chunk, gzip, &seq, &err);
    if (st == DTX_OK) {
        buf = dtx_alloc((size_t)chunk * rest.nv, 3 * sizeof *buf, 0);
        if (!buf)
            st = dtx_seterr(&err, DTX_ENOMEM, "out of memory");
    }
    for (int i = 0; st == DTX_OK && i < nframes; i++) {
        st = dtx_mesh_read(files[i], &fr, &w, &err);
        if (st != DTX_OK)
            break;
        if (fr.nv != rest.nv)
            st = dtx_seterr(&err, DTX_EFORMAT,
                            "%s: frame %d has %d vertices but the rest mesh %s has %d", files[i],
                            i, (int)fr.nv, mesh, (int)rest.nv);
        else if (fr.nf != rest.nf ||
                 memcmp(fr.F, rest.F, (size_t)rest.nf * 3 * sizeof *rest.F) != 0)
            st = dtx_seterr(&err, DTX_EFORMAT,
                            "%s: frame %d has different faces from the rest mesh %s (%d faces "
                            "vs %d): every frame must share the rest mesh's connectivity",
                            files[i], i, mesh, (int)fr.nf, (int)rest.nf);
        else
            memcpy(buf + (size_t)nbuf * 3 * rest.nv, fr.V, (size_t)rest.nv * 3 * sizeof *buf);
        dtx_mesh_free(&fr);
        if (st == DTX_OK && ++nbuf == chunk) {
            st = dtx_h5_seq_write(&seq, i + 1 - nbuf, nbuf, buf, 0, &err);
            nbuf = 0;
        }
    }
    if (st == DTX_OK && nbuf > 0)
        st = dtx_h5_seq_write(&seq, nframes - nbuf, nbuf, buf, 0, &err);
    if (st == DTX_OK) {
        const char **names = calloc((size_t)nframes, sizeof *names);
        if (!names)
            st = dtx_seterr(&err, DTX_ENOMEM, "out of memory");
        for (int i = 0; names && i < nframes; i++) {
            const char *s = strrchr(files[i], '/');
            names[i] = s ? s + 1 : files[i];
        }
        if (st == DTX_OK)
            st = dtx_h5_write_frame_names(&seq, names, nframes, &err);
        free(names);
    }
    if (st == DTX_OK)
        st = dtx_h5_seq_commit(&seq, &err);
    dtx_h5_seq_close(&seq);
    if (st == DTX_OK)
        fprintf(stderr, "dtx: %d frames -> %s:%s (%s)\n", nframes, out, group,
                f64 ? "float64" : "float32");
    for (int i = 0; i < nframes; i++)
        free(files[i]);
    free(files);
    free(buf);
    dtx_mesh_free(&rest);
    return finish_import(out, &f, created, st, &err);
}

static int cmd_import_markers(int argc, char **argv)
{
    char *pos[2];
    const char *out = opt(argc, argv, "-o"), *name = opt(argc, argv, "--name"),
               *base = opt(argc, argv, "--index-base"), *src = opt(argc, argv, "--source"),
               *tgt = opt(argc, argv, "--target");
    dtx_error err;
    dtx_status st;
    dtx_markers mk;
    hid_t f = H5I_INVALID_HID;
    int created = 0, ib;
    char group[DTX_H5_PATH_MAX];
    if (positionals(argc, argv, 3, pos, 2) != 1 || !out || !name || !base)
        return usage("import markers needs one CSV file, --index-base 0|1, -o OUT.h5 and "
                     "--name NAME");
    if (strcmp(base, "0") == 0)
        ib = 0;
    else if (strcmp(base, "1") == 0)
        ib = 1;
    else
        return usage("--index-base must be 0 or 1");
    st = dtx_markers_read_csv(pos[0], ib, &mk, &err);
    if (st != DTX_OK)
        return fail(&err);
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

static int cmd_validate(int argc, char **argv)
{
    char *report = NULL;
    dtx_error err;
    dtx_status st;
    if (argc != 3)
        return usage("validate needs one file");
    st = dtx_h5_validate(argv[2], &report, &err);
    if (report)
        fputs(report, stdout);
    free(report);
    return st == DTX_OK ? 0 : fail(&err);
}

/* Compares the positions of one result in two files: prints the largest
 * difference relative to the largest coordinate magnitude. */
static int cmd_diff(int argc, char **argv)
{
    char *pos[4];
    const char *tols = opt(argc, argv, "--tol");
    double tol = tols ? strtod(tols, NULL) : 1e-12, maxd = 0.0, maxv = 0.0;
    dtx_error err;
    dtx_status st;
    hid_t fa = H5I_INVALID_HID, fb = H5I_INVALID_HID;
    dtx_h5_result ra, rb;
    double *a = NULL, *b = NULL;
    if (positionals(argc, argv, 2, pos, 4) != 3)
        return usage("diff needs two files and a result path");
    memset(&ra, 0, sizeof ra);
    memset(&rb, 0, sizeof rb);
    st = dtx_h5_open(pos[0], MPI_COMM_NULL, 0, &fa, &err);
    if (st == DTX_OK)
        st = dtx_h5_open(pos[1], MPI_COMM_NULL, 0, &fb, &err);
    if (st == DTX_OK)
        st = dtx_h5_result_open(fa, pos[2], 0, &ra, &err);
    if (st == DTX_OK)
        st = dtx_h5_result_open(fb, pos[2], 0, &rb, &err);
    if (st == DTX_OK && (ra.nframes != rb.nframes || ra.nv != rb.nv))
        st = dtx_seterr(&err, DTX_EFORMAT, "%s: shapes differ (%lld x %d vs %lld x %d)", pos[2],
                        (long long)ra.nframes, (int)ra.nv, (long long)rb.nframes, (int)rb.nv);
    if (st == DTX_OK) {
        a = dtx_alloc((size_t)ra.nv, 3 * sizeof *a, 0);
        b = dtx_alloc((size_t)ra.nv, 3 * sizeof *b, 0);
        if (!a || !b)
            st = dtx_seterr(&err, DTX_ENOMEM, "out of memory");
    }
    for (int64_t f = 0; st == DTX_OK && f < ra.nframes; f++) {
        st = dtx_h5_result_read(&ra, f, 1, a, NULL, &err);
        if (st == DTX_OK)
            st = dtx_h5_result_read(&rb, f, 1, b, NULL, &err);
        for (size_t i = 0; st == DTX_OK && i < 3 * (size_t)ra.nv; i++) {
            double d = fabs(a[i] - b[i]);
            maxd = d > maxd ? d : maxd;
            maxv = fabs(a[i]) > maxv ? fabs(a[i]) : maxv;
        }
    }
    free(a);
    free(b);
    dtx_h5_result_close(&ra);
    dtx_h5_result_close(&rb);
    dtx_h5_close(&fa, NULL);
    dtx_h5_close(&fb, NULL);
    if (st != DTX_OK)
        return fail(&err);
    printf("max difference %.3g (relative %.3g) over %lld frames\n", maxd,
           maxv > 0 ? maxd / maxv : maxd, (long long)ra.nframes);
    return maxd <= tol * (maxv > 0 ? maxv : 1.0) ? 0 : 1;
}

static int cmd_run(int argc, char **argv)
{
    dtx_run_opts o;
    dtx_error err;
    dtx_status st;
    char *pos[2];
    int rank = 0, provided, stuck;
    memset(&o, 0, sizeof o);
    if (positionals(argc, argv, 2, pos, 2) != 1)
        return usage("run needs one job file");
    for (int i = 2; i < argc; i++)
        if (strcmp(argv[i], "--quiet") == 0)
            o.quiet = 1;
        else if (strcmp(argv[i], "--resume") == 0)
            o.resume = 1;
    o.summary_path = opt(argc, argv, "--summary");
    MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    st = dtx_run_job(pos[0], MPI_COMM_WORLD, &o, &err);
    if (st != DTX_OK && rank == 0)
        fail(&err);
    /* After a failed write (disk full) HDF5 can hold a file it could not
     * close, and its exit handler would crash closing it again after
     * MPI_Finalize: leave without running exit handlers then. */
    stuck = H5Fget_obj_count(H5F_OBJ_ALL, H5F_OBJ_ALL) > 0;
    MPI_Finalize();
    if (stuck) {
        fflush(NULL);
        _exit(st == DTX_OK ? 0 : 1);
    }
    return st == DTX_OK ? 0 : 1;
}

int main(int argc, char **argv)
{
    int done, rc;
    if (argc < 2)
        return usage(NULL);
    if (strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0 ||
        (strcmp(argv[1], "help") == 0 && argc > 2 && argv[2][0] != '-'))
        return cmd_help(argc, argv);
    rc = check_options(argc, argv, &done);
    if (done)
        return rc;
    if (strcmp(argv[1], "version") == 0 || strcmp(argv[1], "--version") == 0) {
        printf("dtx %s\n", DTX_VERSION);
        return 0;
    }
    if (strcmp(argv[1], "help") == 0)
        return cmd_help(argc, argv);
    /* A file-size limit (ulimit -f) must make a write fail with EFBIG and
     * a message, not kill the process half-way. */
    signal(SIGXFSZ, SIG_IGN);
    dtx_h5_init();
    if (strcmp(argv[1], "import") == 0) {
        if (argc >= 3 && strcmp(argv[2], "mesh") == 0)
            return cmd_import_mesh(argc, argv);
        if (argc >= 3 && strcmp(argv[2], "sequence") == 0)
            return cmd_import_sequence(argc, argv);
        if (argc >= 3 && strcmp(argv[2], "markers") == 0)
            return cmd_import_markers(argc, argv);
        /* Every import command's usage. */
        fputs("dtx: import what? mesh, sequence or markers\n", stderr);
        for (const dtx_cli_cmd *const *c = dtx_cli_commands(); *c; c++)
            if (strncmp((*c)->name, "import ", 7) == 0)
                dtx_cli_print_usage(stderr, *c);
        return 2;
    }
    if (strcmp(argv[1], "run") == 0)
        return cmd_run(argc, argv);
    if (strcmp(argv[1], "keypoints") == 0)
        return dtx_cmd_keypoints(argc, argv);
    if (strcmp(argv[1], "export") == 0)
        return dtx_cmd_export(argc, argv);
    if (strcmp(argv[1], "inspect") == 0)
        return dtx_cmd_inspect(argc, argv);
    if (strcmp(argv[1], "validate") == 0)
        return cmd_validate(argc, argv);
    if (strcmp(argv[1], "diff") == 0)
        return cmd_diff(argc, argv);
    if (strcmp(argv[1], "render") == 0)
        return dtx_cmd_render(argc, argv);
    if (strcmp(argv[1], "report") == 0)
        return dtx_cmd_report(argc, argv);
    if (strcmp(argv[1], "generate") == 0)
        return dtx_cmd_generate(argc, argv);
    if (strcmp(argv[1], "rm") == 0)
        return dtx_cmd_rm(argc, argv);
    fprintf(stderr, "dtx: unknown command '%s'\n\n", argv[1]);
    dtx_cli_print_overview(stderr);
    return 2;
}
