/*
 * cmd_keypoints.c: `dtx keypoints FILE.h5 --mesh /meshes/SRC --sequence S
 * [...]`: automatic key points of a source animation (Yang, Gao, Lai,
 * Rosin & Xia 2018, Algorithm 1; src/core/keypoints.h) for the biharmonic
 * method.
 *
 * Phases (every rank unless said):
 *   1. arguments, checked before anything is read (exit 2);
 *   2. inputs: the source mesh, the sequences, the training frames (the
 *      same rule as a biharmonic job's "training_frames"), the markers and
 *      the target; rank 0 also checks that nothing it will write exists;
 *   3. the selection, the candidates split over the ranks;
 *   4. rank 0: labels (nearest source marker), the sp04 correspondence and
 *      the mapping onto the target (--target), the table on stdout, then
 *      the writes: /keypoints/NAME, /markers/NAME-T, the CSV.  A failure
 *      removes what this run wrote, so an error leaves no partial output.
 * The ranks agree on the outcome after each phase and return the same exit
 * status; only rank 0 prints.
 */
#include "cmd_keypoints.h"

#include "cli_util.h"
#include "options.h"

#include "atomic_file.h"
#include "dtx_core.h"
#include "file_util.h"
#include "h5layout.h"
#include "keypoint_setup.h"
#include "keypoints.h"
#include "mpi_util.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* OpenBLAS's own call, when that is the BLAS we run on (as in dtx run). */
extern void openblas_set_num_threads(int n) __attribute__((weak));

#define MAX_SEQ 256

typedef struct {
    const char *file, *mesh, *markers, *target, *out, *csv;
    const char *seq[MAX_SEQ];
    int nseq;
    char name[256];
    int32_t candidates, max_keys, training;
    double eps;
} kp_args;

typedef struct {
    dtx_mesh src, tgt;
    dtx_markers mk;
    int has_mk, has_tgt;
    int32_t ntrain;
    int64_t total_frames;
    double *X;
    dtx_kp_result kp;
    char mk_path[DTX_H5_PATH_MAX]; /* /markers/NAME-T */
    char kp_path[DTX_H5_PATH_MAX]; /* /keypoints/NAME */
} kp_state;

static int usage(int rank, const char *msg)
{
    if (rank == 0) {
        fprintf(stderr, "dtx: %s\n", msg);
        dtx_cli_print_usage(stderr, dtx_cli_find_name("keypoints"));
    }
    return 2;
}

/* The job's target-name characters, and the layout's name rule (not "." or
 * "..", not the reserved ".dtx-" prefix: dtx_h5_check_name). */
static int valid_name(const char *s)
{
    dtx_error e;
    if (!*s || dtx_h5_check_name(s, &e) != DTX_OK)
        return 0;
    for (; *s; s++)
        if (!((*s >= 'A' && *s <= 'Z') || (*s >= 'a' && *s <= 'z') || (*s >= '0' && *s <= '9') ||
              *s == '_' || *s == '.' || *s == '-'))
            return 0;
    return 1;
}

/* A whole-string integer in [lo, hi]. */
static int parse_int(const char *s, long lo, long hi, int32_t *out)
{
    char *end;
    long v;
    errno = 0;
    v = strtol(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi)
        return -1;
    *out = (int32_t)v;
    return 0;
}

/* ------------------------------------------------------------------ */
/* 1. Arguments                                                        */
/* ------------------------------------------------------------------ */

/* Fills *a; returns NULL or the usage message. */
static const char *parse_args(int argc, char **argv, kp_args *a, char *buf, size_t n)
{
    dtx_kp_params d;
    const char *name = NULL;
    dtx_kp_params_default(&d);
    memset(a, 0, sizeof *a);
    a->candidates = d.candidates;
    a->max_keys = d.max_keys;
    a->eps = d.eps;
    a->training = 32; /* as a biharmonic job's training_frames */
    for (int i = 2; i < argc; i++) {
        const char *o = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (o[0] != '-') {
            if (a->file)
                return "keypoints takes one FILE.h5";
            a->file = o;
            continue;
        }
        if (!v) {
            snprintf(buf, n, "%s needs a value", o);
            return buf;
        }
        i++;
        if (strcmp(o, "--mesh") == 0)
            a->mesh = v;
        else if (strcmp(o, "--sequence") == 0) {
            if (a->nseq == MAX_SEQ)
                return "too many --sequence options";
            a->seq[a->nseq++] = v;
        } else if (strcmp(o, "--markers") == 0)
            a->markers = v;
        else if (strcmp(o, "--target") == 0)
            a->target = v;
        else if (strcmp(o, "--name") == 0)
            name = v;
        else if (strcmp(o, "-o") == 0)
            a->out = v;
        else if (strcmp(o, "--csv") == 0)
            a->csv = v;
        else if (strcmp(o, "--candidates") == 0) {
            if (parse_int(v, 1, 100000, &a->candidates))
                return "--candidates must be an integer from 1 to 100000";
        } else if (strcmp(o, "--max") == 0) {
            if (parse_int(v, 1, 10000, &a->max_keys))
                return "--max must be an integer from 1 to 10000";
        } else if (strcmp(o, "--training-frames") == 0) {
            if (parse_int(v, 1, 100000, &a->training))
                return "--training-frames must be an integer from 1 to 100000";
        } else if (strcmp(o, "--eps") == 0) {
            char *end;
            a->eps = strtod(v, &end);
            if (end == v || *end || !isfinite(a->eps) || a->eps < 0)
                return "--eps must be a number >= 0";
        } else {
            snprintf(buf, n, "unknown option %s", o);
            return buf;
        }
    }
    if (!a->file || !a->mesh || a->nseq == 0)
        return "keypoints needs FILE.h5, --mesh /meshes/SRC and at least one --sequence";
    if (a->mesh[0] != '/' || (a->markers && a->markers[0] != '/') ||
        (a->target && a->target[0] != '/'))
        return "--mesh, --markers and --target take HDF5 paths such as /meshes/cat";
    for (int s = 0; s < a->nseq; s++)
        if (a->seq[s][0] != '/')
            return "--sequence takes HDF5 paths such as /sequences/cat-poses";
    if (a->target && !a->markers)
        return "--target needs --markers (the correspondence that maps the key points onto "
               "the target starts from them)";
    if (name)
        snprintf(a->name, sizeof a->name, "%s", name);
    else
        snprintf(a->name, sizeof a->name, "%.200s-keys", dtx_path_base_name(a->mesh));
    if (!valid_name(a->name)) {
        snprintf(buf, n, "--name \"%.200s\" must be letters, digits, '_', '.' or '-', not . or .. and not starting with .dtx-%s", a->name,
                 name ? "" : " (it defaults to the mesh name + \"-keys\"; give --name)");
        return buf;
    }
    if (a->target && !valid_name(dtx_path_base_name(a->target)))
        return "the --target mesh's name must be letters, digits, '_', '.' or '-'";
    return NULL;
}

/* ------------------------------------------------------------------ */
/* 2. Inputs                                                           */
/* ------------------------------------------------------------------ */

static dtx_status read_frames(hid_t f, const kp_args *a, kp_state *s, dtx_error *err)
{
    dtx_h5_seq seqs[MAX_SEQ];
    const dtx_h5_seq *ptr[MAX_SEQ];
    int nopen = 0;
    dtx_status st = DTX_OK;
    memset(seqs, 0, sizeof seqs);
    for (int i = 0; i < a->nseq && st == DTX_OK; i++) {
        for (int j = 0; j < i; j++)
            if (strcmp(a->seq[i], a->seq[j]) == 0)
                return dtx_seterr(err, DTX_EINVAL, "%s is given twice", a->seq[i]);
        st = dtx_h5_seq_open(f, a->seq[i], &seqs[i], err);
        if (st != DTX_OK)
            break;
        nopen++;
        ptr[i] = &seqs[i];
        s->total_frames += seqs[i].nframes;
        if (seqs[i].nv != s->src.nv)
            st = dtx_seterr(err, DTX_EFORMAT,
                            "%s: %s has %d vertices per frame but the source mesh %s has %d",
                            a->file, a->seq[i], (int)seqs[i].nv, a->mesh, (int)s->src.nv);
    }
    if (st == DTX_OK)
        st = dtx_read_training_frames(ptr, a->nseq, a->training, &s->ntrain, &s->X, err);
    for (int i = 0; i < nopen; i++)
        dtx_h5_seq_close(&seqs[i]);
    return st;
}

static dtx_status read_inputs(const kp_args *a, kp_state *s, dtx_error *err)
{
    hid_t f = H5I_INVALID_HID;
    char what[1200];
    dtx_status st = dtx_h5_open(a->file, MPI_COMM_NULL, 0, &f, err);
    if (st == DTX_OK)
        st = dtx_h5_read_mesh(f, a->mesh, &s->src, err);
    if (st == DTX_OK && a->target) {
        st = dtx_h5_read_mesh(f, a->target, &s->tgt, err);
        s->has_tgt = st == DTX_OK;
    }
    if (st == DTX_OK && a->markers) {
        st = dtx_h5_read_markers(f, a->markers, &s->mk, err);
        s->has_mk = st == DTX_OK;
        snprintf(what, sizeof what, "%.500s:%.500s", a->file, a->markers);
        if (st == DTX_OK)
            st = dtx_markers_validate(&s->mk, s->src.nv, s->has_tgt ? s->tgt.nv : INT32_MAX, what,
                                      err);
        if (st == DTX_OK)
            st = dtx_markers_check_referenced(&s->mk, &s->src, what, err);
    }
    if (st == DTX_OK)
        st = read_frames(f, a, s, err);
    if (f >= 0)
        dtx_h5_close(&f, NULL);
    return st;
}

/* 1 when a and b name the same existing file, or the same path. */
static int same_file(const char *a, const char *b)
{
    int same = dtx_file_same_inode(a, b);
    return same >= 0 ? same : strcmp(a, b) == 0;
}

/* Rank 0, before the work: the output is a dtx file (or can be made) and
 * holds none of the objects this run writes; the CSV's directory takes a
 * file. */
static dtx_status check_outputs(const kp_args *a, const kp_state *s, dtx_error *err)
{
    const char *out = a->out ? a->out : a->file;
    dtx_status st = DTX_OK;
    if (access(out, F_OK) == 0) {
        hid_t f = H5I_INVALID_HID;
        st = dtx_h5_open(out, MPI_COMM_NULL, 0, &f, err);
        if (st == DTX_OK && dtx_h5_path_exists(f, s->kp_path))
            st = dtx_seterr(err, DTX_EINVAL,
                            "%s: %s already exists (choose another --name, or "
                            "remove it first)",
                            out, s->kp_path);
        if (st == DTX_OK && a->target && dtx_h5_path_exists(f, s->mk_path))
            st = dtx_seterr(err, DTX_EINVAL,
                            "%s: %s already exists (choose another --name, or "
                            "remove it first)",
                            out, s->mk_path);
        if (f >= 0)
            dtx_h5_close(&f, NULL);
        if (st == DTX_OK && access(out, W_OK) != 0)
            st = dtx_seterr(err, DTX_EIO, "%s: cannot write: %s", out, strerror(errno));
    }
    if (st == DTX_OK && a->csv) {
        dtx_atomic_file af;
        if ((st = dtx_atomic_open(&af, a->csv, err)) == DTX_OK)
            dtx_atomic_abort(&af);
    }
    return st;
}

/* ------------------------------------------------------------------ */
/* 4. Results (rank 0)                                                 */
/* ------------------------------------------------------------------ */

/* The key points onto the target through the sp04 correspondence (default
 * parameters, the markers).  tv, dup: count entries. */
static dtx_status map_onto_target(const kp_args *a, const kp_state *s, int32_t *tv, int32_t *dup,
                                  dtx_error *err)
{
    dtx_corr_params prm;
    dtx_corr corr;
    dtx_status st;
    memset(&corr, 0, sizeof corr);
    dtx_corr_params_default(&prm);
    fprintf(stderr, "dtx: sp04 correspondence %s -> %s (%d markers) ...\n", a->mesh, a->target,
            (int)s->mk.n);
    st = dtx_sp04_correspond(&s->src, &s->tgt, &s->mk, &prm, &corr, err);
    if (st == DTX_OK)
        st = dtx_keypoints_map(corr.deformed_src, s->src.nv, &s->tgt, s->kp.keys, s->kp.count, tv,
                               dup, err);
    if (st != DTX_OK)
        dtx_error_prefix(err, "%s -> %s", a->mesh, a->target);
    dtx_corr_free(&corr);
    for (int32_t k = 0; st == DTX_OK && k < s->kp.count; k++)
        if (dup[k] >= 0)
            fprintf(stderr,
                    "dtx: warning: key points %d and %d both map to target vertex %d; key point "
                    "%d is left out of %s\n",
                    (int)dup[k] + 1, (int)k + 1, (int)tv[k], (int)k + 1, s->mk_path);
    return st;
}

static void csv_label(FILE *f, const char *l)
{
    fputc('"', f);
    for (; *l; l++) {
        if (*l == '"')
            fputc('"', f);
        fputc(*l == '\n' || *l == '\r' ? ' ' : *l, f);
    }
    fputc('"', f);
}

/* The marker CSV: the mapped target vertices, or an empty column to fill
 * in.  Written to a temporary file, committed by the caller. */
static dtx_status write_csv(const kp_args *a, const kp_state *s, const dtx_markers *set,
                            const int32_t *tv, const int32_t *dup, dtx_atomic_file *af,
                            dtx_error *err)
{
    dtx_status st = dtx_atomic_open(af, a->csv, err);
    int32_t j = 0;
    if (st != DTX_OK)
        return st;
    fprintf(af->fp, "# dtx keypoints: %d key points of %s:%s\n", (int)s->kp.count, a->file,
            a->mesh);
    if (!tv)
        fprintf(af->fp,
                "# Fill in target_vertex: the 0-based vertex of your target mesh at each key "
                "point (the\n# labels name the nearest source marker). Then: dtx import markers "
                "THIS.csv --index-base 0\n# -o FILE.h5 --name NAME --source %s --target "
                "/meshes/TARGET, and a biharmonic job\n# with \"keypoints\": \"markers\" and "
                "that marker set.\n",
                a->mesh);
    fprintf(af->fp, "# index_base: 0\nsource_vertex,target_vertex,label\n");
    for (int32_t k = 0; k < s->kp.count; k++) {
        if (dup && dup[k] >= 0)
            continue;
        fprintf(af->fp, "%d,", (int)s->kp.keys[k]);
        if (tv)
            fprintf(af->fp, "%d", (int)tv[k]);
        fputc(',', af->fp);
        csv_label(af->fp, set->labels[j++]);
        fputc('\n', af->fp);
    }
    return DTX_OK;
}

/* Writes /keypoints/NAME and (with a target) /markers/NAME-T; on failure
 * removes what it wrote (and a file it created). */
static dtx_status write_h5(const kp_args *a, const kp_state *s, const dtx_markers *labels,
                           const dtx_markers *mapped, dtx_error *err)
{
    const char *out = a->out ? a->out : a->file;
    int created = access(out, F_OK) != 0, same = same_file(out, a->file), wrote_kp = 0;
    char src_ref[2400], tgt_ref[2400], seqs[4096] = "";
    double *steps = dtx_alloc((size_t)s->kp.ntrace + 1, sizeof *steps, 0);
    double *pos = dtx_alloc((size_t)s->kp.count, 3 * sizeof *pos, 0);
    dtx_h5_keypoints g;
    hid_t f = H5I_INVALID_HID;
    dtx_status st = steps && pos ? DTX_OK : dtx_seterr(err, DTX_ENOMEM, "out of memory");
    /* References to objects in another file are FILE:PATH. */
    snprintf(src_ref, sizeof src_ref, "%s%s%s", same ? "" : a->file, same ? "" : ":", a->mesh);
    snprintf(tgt_ref, sizeof tgt_ref, "%s%s%s", same ? "" : a->file, same ? "" : ":",
             a->target ? a->target : "");
    for (int i = 0; i < a->nseq; i++) {
        size_t len = strlen(seqs);
        snprintf(seqs + len, sizeof seqs - len, "%s%s", i ? ", " : "", a->seq[i]);
    }
    memset(&g, 0, sizeof g);
    if (st == DTX_OK) {
        for (int32_t k = 0; k < s->kp.count; k++)
            memcpy(pos + 3 * (size_t)k, s->src.V + 3 * (size_t)s->kp.keys[k], 3 * sizeof *pos);
        g.n = s->kp.count;
        g.vertex = s->kp.keys;
        g.position = pos;
        g.label = labels->labels;
        g.nerror = dtx_keypoints_steps(&s->kp, steps);
        g.error = steps;
        g.source_mesh = src_ref;
        g.source_sequences = seqs;
        g.candidates = s->kp.ncand;
        g.eps = a->eps;
        g.final_error = s->kp.error;
        st = created ? dtx_h5_create(out, MPI_COMM_NULL, &f, err)
                     : dtx_h5_open(out, MPI_COMM_NULL, 1, &f, err);
    }
    if (st == DTX_OK)
        st = dtx_h5_write_keypoints(f, s->kp_path, &g, err);
    wrote_kp = st == DTX_OK;
    if (st == DTX_OK && mapped)
        st = dtx_h5_write_markers(f, s->mk_path, mapped, src_ref, tgt_ref, err);
    if (st != DTX_OK && wrote_kp && !created)
        dtx_h5_remove(f, s->kp_path, NULL);
    if (f >= 0) {
        dtx_error e2;
        if (dtx_h5_close(&f, &e2) != DTX_OK && st == DTX_OK) {
            *err = e2;
            st = e2.code;
        }
    }
    if (st != DTX_OK && created)
        remove(out);
    free(steps);
    free(pos);
    return st;
}

static dtx_status finish(const kp_args *a, kp_state *s, dtx_error *err)
{
    int32_t m = s->kp.count, *tv = NULL, *dup = NULL;
    dtx_markers labels, mapped;
    dtx_atomic_file af;
    dtx_status st = DTX_OK;
    double near = DTX_KP_NEAR_EDGES * dtx_mesh_mean_edge(&s->src);
    memset(&labels, 0, sizeof labels);
    memset(&mapped, 0, sizeof mapped);
    memset(&af, 0, sizeof af);
    if (s->has_tgt) {
        tv = dtx_alloc((size_t)m, sizeof *tv, 0);
        dup = dtx_alloc((size_t)m, sizeof *dup, 0);
        st = tv && dup ? DTX_OK : dtx_seterr(err, DTX_ENOMEM, "out of memory");
        if (st == DTX_OK)
            st = map_onto_target(a, s, tv, dup, err);
        if (st == DTX_OK)
            st = dtx_keypoints_marker_set(&s->src, s->kp.keys, tv, dup, m, &s->mk, &mapped, err);
    }
    /* The key-point group's labels: the nearest marker's own label when it
     * is near (every key, none dropped). */
    if (st == DTX_OK)
        st = dtx_markers_alloc(&labels, m, err);
    if (st == DTX_OK) {
        int32_t *mi = dtx_alloc((size_t)m, sizeof *mi, 0);
        double *dist = dtx_alloc((size_t)m, sizeof *dist, 0);
        st = mi && dist ? DTX_OK : dtx_seterr(err, DTX_ENOMEM, "out of memory");
        if (st == DTX_OK)
            dtx_keypoints_nearest_markers(&s->src, s->has_mk ? &s->mk : NULL, s->kp.keys, m, mi,
                                          dist);
        for (int32_t k = 0; st == DTX_OK && k < m; k++) {
            const char *l =
                mi[k] >= 0 && dist[k] <= near && s->mk.labels ? s->mk.labels[mi[k]] : "";
            labels.src[k] = s->kp.keys[k];
            labels.tgt[k] = -1;
            if (!(labels.labels[k] = strdup(l ? l : "")))
                st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
        }
        free(mi);
        free(dist);
    }
    if (st == DTX_OK) {
        printf("key points of %s:%s (%d training frames of %lld):\n", a->file, a->mesh,
               (int)s->ntrain, (long long)s->total_frames);
        dtx_keypoints_print_table(stdout, "", &s->src, s->kp.keys, m, s->has_mk ? &s->mk : NULL, tv,
                                  dup);
        dtx_keypoints_print_steps(stdout, "", &s->kp, a->eps);
        fflush(stdout);
    }
    if (st == DTX_OK && a->csv) {
        /* The CSV's labels say "key K near L", as the run's marker sets. */
        dtx_markers keyed;
        st = s->has_tgt ? DTX_OK
                        : dtx_keypoints_marker_set(&s->src, s->kp.keys, NULL, NULL, m,
                                                   s->has_mk ? &s->mk : NULL, &keyed, err);
        if (st == DTX_OK)
            st = write_csv(a, s, s->has_tgt ? &mapped : &keyed, tv, dup, &af, err);
        if (!s->has_tgt)
            dtx_markers_free(&keyed);
    }
    if (st == DTX_OK)
        st = write_h5(a, s, &labels, s->has_tgt ? &mapped : NULL, err);
    if (st == DTX_OK && a->csv)
        st = dtx_atomic_commit(&af, err);
    else
        dtx_atomic_abort(&af);
    if (st == DTX_OK) {
        const char *out = a->out ? a->out : a->file;
        fprintf(stderr, "dtx: %d key points -> %s:%s", (int)m, out, s->kp_path);
        if (s->has_tgt)
            fprintf(stderr, ", %d mapped onto %s -> %s:%s", (int)mapped.n, a->target, out,
                    s->mk_path);
        if (a->csv)
            fprintf(stderr, ", %s", a->csv);
        fprintf(stderr, "\n");
    }
    dtx_markers_free(&labels);
    dtx_markers_free(&mapped);
    free(tv);
    free(dup);
    return st;
}

/* ------------------------------------------------------------------ */
/* The command                                                         */
/* ------------------------------------------------------------------ */

static dtx_status run(const kp_args *a, MPI_Comm comm, kp_state *s, dtx_error *err)
{
    int rank;
    dtx_status st;
    dtx_kp_params p;
    MPI_Comm_rank(comm, &rank);
    snprintf(s->kp_path, sizeof s->kp_path, "/keypoints/%s", a->name);
    snprintf(s->mk_path, sizeof s->mk_path, "/markers/%s-%s", a->name,
             a->target ? dtx_path_base_name(a->target) : "");
    st = read_inputs(a, s, err);
    if (st == DTX_OK && rank == 0)
        st = check_outputs(a, s, err);
    if ((st = dtx_mpi_agree(st, 0, comm, err)) != DTX_OK)
        return st;
    dtx_kp_params_default(&p);
    p.candidates = a->candidates;
    p.eps = a->eps;
    p.max_keys = a->max_keys;
    if (rank == 0) {
        int n = 1;
        MPI_Comm_size(comm, &n);
        fprintf(stderr,
                "dtx: selecting key points on %d of %lld frames (%d candidates, %d "
                "rank(s))...\n",
                (int)s->ntrain, (long long)s->total_frames, (int)p.candidates, n);
    }
    st = dtx_keypoints_select_comm(&s->src, s->ntrain, s->X, &p, comm, &s->kp, err);
    if (st != DTX_OK) {
        dtx_error_prefix(err, "%s:%s: key points", a->file, a->mesh);
        return st;
    }
    if (rank == 0)
        st = finish(a, s, err);
    return dtx_mpi_agree(st, 0, comm, err);
}

int dtx_cmd_keypoints(int argc, char **argv)
{
    kp_args a;
    kp_state s;
    dtx_error err;
    dtx_status st;
    const char *why;
    char buf[512];
    int rank = 0;
    dtx_cli_mpi_init(&argc, &argv);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    if ((why = parse_args(argc, argv, &a, buf, sizeof buf)) != NULL) {
        MPI_Finalize();
        return usage(rank, why);
    }
    if (openblas_set_num_threads)
        openblas_set_num_threads(1);
    memset(&s, 0, sizeof s);
    err.code = DTX_OK;
    err.msg[0] = '\0';
    st = run(&a, MPI_COMM_WORLD, &s, &err);
    if (st != DTX_OK && rank == 0)
        dtx_cli_fail(&err);
    dtx_kp_result_free(&s.kp);
    dtx_markers_free(&s.mk);
    dtx_mesh_free(&s.src);
    dtx_mesh_free(&s.tgt);
    free(s.X);
    return dtx_cli_mpi_finish(st);
}
