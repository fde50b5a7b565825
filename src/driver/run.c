/*
 * run.c: `dtx run`, the batch run of a job across MPI ranks.
 *
 * Phases, in order (dtx_run_job reads as this list):
 *   1. load the job (rank 0 reads and checks it, every rank parses the same text);
 *   2. read the inputs (every rank: source mesh, sequence shapes, targets, markers);
 *   3. decide what the output file is: a fresh OUTPUT.partial, the partial of an
 *      interrupted run to continue (--resume), or nothing to do;
 *      (method springs: a target with the source's vertices and faces needs
 *      no markers and no correspondence; any other goes through a proxy,
 *      the source deformed by sp04's correspondence);
 *   3b. method biharmonic: every rank reads the training frames; with
 *      keypoints "auto" the ranks select the key points together, each
 *      evaluating its share of the candidates;
 *   4. correspondences: reused from the partial or the old output when their key
 *      (a hash of both meshes, the markers and the parameters) matches, else
 *      computed, different targets on different ranks, then broadcast (none
 *      for biharmonic with markers as key points); then, for biharmonic, each
 *      target's key points: its markers, or the selected ones mapped through
 *      the correspondence;
 *   5. open the output: create every mesh, correspondence, key-point set
 *      (biharmonic) and result up front
 *      (so the frame loop only writes raw data into allocated space), or reopen
 *      the partial and read which frames are done;
 *   6. per target: factor once (every rank); per sequence: the frame groups not
 *      yet done are dealt to the ranks and each rank reads, transfers and writes
 *      its groups in blocks (collective writes);
 *   7. finish: mark results complete, close, rename OUTPUT.partial to OUTPUT;
 *   8. summary (JSON) and the last progress line.
 *
 * Crash safety: every object of the output is created and flushed before the
 * first frame is written, with its space allocated, so a process killed in
 * the frame loop leaves metadata that was complete at the flush and raw
 * frames whose frame_done flag is written only after their positions.  The
 * real output name appears only by the final rename, after every result
 * passed its completeness check.
 *
 * Failure handling: after every phase the ranks agree on the outcome
 * (agree()), so a failure on one rank ends the job on every rank with that
 * rank's message, and no rank is left waiting in a collective call.
 */
#include "driver.h"

#include "dtx_core.h"
#include "file_util.h"
#include "h5layout.h"
#include "job.h"
#include "keypoint_setup.h"
#include "keypoints.h"
#include "meshfile.h"
#include "mpi_util.h"
#include "weld_setup.h"
#include "output_lock.h"
#include "path_guard.h"
#include "progress.h"
#include "springs.h"
#include "transfer_bh.h"

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>
#ifdef _OPENMP
#include <omp.h>
#endif

/* OpenBLAS's own call, when that is the BLAS we run on: BLAS stays
 * single-threaded because threads come from OpenMP and ranks. */
extern void openblas_set_num_threads(int n) __attribute__((weak));

typedef struct {
    double read, keypoints, correspond, factor, transfer, write, total;
} phase_times;

/* Residual statistics of the frames transferred by this run. */
typedef struct {
    int64_t frames;
    double sum, sumsq, min, max;
} run_stats;

/* Methods springs (Newton) and multicomponent (Gauss-Newton): the solves of
 * a result's frames done by this run (reduced onto rank 0 at the end). */
typedef struct {
    int64_t frames, iterations;  /* frames solved, (fine-level) iterations summed */
    int64_t unconverged;         /* frames that stopped without meeting the test */
    int64_t first_unconverged;   /* the lowest of them, or INT64_MAX */
    int64_t inverted_frames;     /* frames with inverted triangles (springs only) */
    int64_t max_inverted;        /* most inverted triangles in a frame */
    int64_t max_inverted_frame;  /* that frame (the lowest on ties), or INT64_MAX */
    int64_t max_iterations;
} solve_stats;

typedef enum { OUT_FRESH, OUT_RESUME, OUT_DONE } out_mode;

typedef struct {
    const dtx_job_target *tj;
    dtx_mesh mesh;
    dtx_markers mk;
    dtx_corr corr;
    char key[17];
    int reused;      /* correspondence found in a cache */
    int same_conn;   /* method springs: the source's vertices and faces (no
                        correspondence, no markers needed) */
    int owner;       /* rank that computes it */
    char mesh_path[DTX_H5_PATH_MAX], corr_path[DTX_H5_PATH_MAX];
    /* method biharmonic: the key points (source -> target vertex) as a
     * marker set, stored in the output at kp_path */
    dtx_markers keys;
    char kp_path[DTX_H5_PATH_MAX];
    dtx_weld_ctx weld; /* the asset's vertices (mesh is welded along seams) */
} target_ctx;

typedef struct {
    const char *path; /* HDF5 path in the source file */
    const char *name; /* result name: the path's last component */
    dtx_h5_seq seq;
    int open;
} seq_ctx;

typedef struct {
    dtx_h5_result res;
    int open;
    int finished;   /* already complete in the resumed partial */
    run_stats st;
    solve_stats sv;
} result_ctx;

typedef struct {
    MPI_Comm comm;
    int rank, nranks, nthreads;
    int align; /* frames per group: rank ranges, blocks and result chunks are
                  whole groups (sp04's solve group; 1 for springs, whose
                  frames are independent and expensive, so that few frames
                  still spread over the ranks) */
    const dtx_run_opts *opts;
    dtx_job job;
    dtx_mesh src;
    dtx_weld_ctx src_weld; /* the source asset's vertices (src is welded) */
    hid_t src_file, out;
    char partial[4200];
    char run_key[17];
    dtx_output_lock lock; /* rank 0: OUTPUT.lock, held from take_output to the end */
    out_mode mode;
    int nt, ns;
    target_ctx *tg;
    seq_ctx *sq;
    char **seq_paths; /* the job's sequences, wildcards expanded: ns paths */
    result_ctx *rs; /* nt x ns, result of target t and sequence s at t * ns + s */
    phase_times tm;
    run_stats stats;
    /* method biharmonic: the training frames (every rank) and, with
     * keypoints "auto", the key points selected on them */
    int32_t ntrain;
    double *Xtrain;
    dtx_kp_result kp;
    int64_t frames_todo, frames_skipped, frames_done; /* global, known on rank 0 */
    dtx_progress prog;
} run_state;

#define RESULT(r, t, s) (&(r)->rs[(size_t)(t) * (size_t)(r)->ns + (size_t)(s)])

/* ------------------------------------------------------------------ */
/* Small helpers                                                       */
/* ------------------------------------------------------------------ */

/* Collective agreement on failures (mpi_util.h): DTX_OK when every rank
 * succeeded, else the status and message of the lowest failing rank, on
 * every rank, the other ranks naming it when it is not rank 0. */
static dtx_status agree(MPI_Comm comm, dtx_status st, dtx_error *err)
{
    return dtx_mpi_agree(st, DTX_AGREE_NAME_RANK, comm, err);
}

static double wtime(void) { return MPI_Wtime(); }

/* Fault injection for the tests: with DTX_FAULT=PHASE@RANK in the
 * environment, rank RANK fails at phase PHASE (read, correspondence,
 * output, transfer, finish) as a real error there would. */
static dtx_status injected_fault(const run_state *r, const char *phase, dtx_error *err)
{
    const char *f = getenv("DTX_FAULT");
    const char *at = f ? strchr(f, '@') : NULL;
    if (!at || (size_t)(at - f) != strlen(phase) || strncmp(f, phase, strlen(phase)) != 0 ||
        atoi(at + 1) != r->rank)
        return DTX_OK;
    return dtx_seterr(err, DTX_EIO, "injected fault at phase %s on rank %d (DTX_FAULT=%s)",
                      phase, r->rank, f);
}

/* A message from rank 0 on stderr (not with --quiet). */
static void say(run_state *r, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void say(run_state *r, const char *fmt, ...)
{
    char line[2048];
    va_list ap;
    if (r->rank != 0 || r->opts->quiet)
        return;
    va_start(ap, fmt);
    vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
    if (r->prog.out)
        dtx_progress_message(&r->prog, line);
    else
        fprintf(stderr, "%s\n", line);
}

/* A mesh split along seams (vertices at the position of another) is welded
 * for the solve; its results keep every vertex of the asset. */
static void say_welded(run_state *r, const char *role, const char *what, const dtx_weld_ctx *w)
{
    int n = (int)(w->nv - w->nw);
    say(r, "dtx: %s mesh %s: %d %s at the position of another vertex (seams) welded for the "
           "solve; results keep its %d vertices, twins moving together",
        role, what, n, n == 1 ? "vertex" : "vertices", (int)w->nv);
}

/* mkdir -p of the directory part of path (dir_only != 0) or of path. */
static dtx_status make_dirs(const char *path, int dir_only, dtx_error *err)
{
    char buf[4096];
    size_t n = strlen(path);
    if (n >= sizeof buf)
        return dtx_seterr(err, DTX_EINVAL, "%s: path too long", path);
    memcpy(buf, path, n + 1);
    if (dir_only) {
        char *slash = strrchr(buf, '/');
        if (!slash)
            return DTX_OK;
        *slash = '\0';
    }
    for (char *p = buf + 1; *p; p++) {
        if (*p != '/')
            continue;
        *p = '\0';
        if (mkdir(buf, 0777) != 0 && errno != EEXIST)
            return dtx_seterr(err, DTX_EIO, "%s: cannot create directory: %s", buf,
                              strerror(errno));
        *p = '/';
    }
    if (buf[0] && mkdir(buf, 0777) != 0 && errno != EEXIST)
        return dtx_seterr(err, DTX_EIO, "%s: cannot create directory: %s", buf, strerror(errno));
    return DTX_OK;
}

static void stats_init(run_stats *s)
{
    memset(s, 0, sizeof *s);
    s->min = INFINITY;
    s->max = -INFINITY;
}

static void stats_add(run_stats *s, double v)
{
    s->frames++;
    s->sum += v;
    s->sumsq += v * v;
    s->min = v < s->min ? v : s->min;
    s->max = v > s->max ? v : s->max;
}

/* Adds the frames of b to a. */
static void stats_merge(run_stats *a, const run_stats *b)
{
    a->frames += b->frames;
    a->sum += b->sum;
    a->sumsq += b->sumsq;
    a->min = b->min < a->min ? b->min : a->min;
    a->max = b->max > a->max ? b->max : a->max;
}

/* The statistics of all ranks, on rank 0. */
static void stats_reduce(MPI_Comm comm, const run_stats *mine, run_stats *all)
{
    MPI_Reduce(&mine->frames, &all->frames, 1, MPI_INT64_T, MPI_SUM, 0, comm);
    MPI_Reduce(&mine->sum, &all->sum, 1, MPI_DOUBLE, MPI_SUM, 0, comm);
    MPI_Reduce(&mine->sumsq, &all->sumsq, 1, MPI_DOUBLE, MPI_SUM, 0, comm);
    MPI_Reduce(&mine->min, &all->min, 1, MPI_DOUBLE, MPI_MIN, 0, comm);
    MPI_Reduce(&mine->max, &all->max, 1, MPI_DOUBLE, MPI_MAX, 0, comm);
}

/* Methods whose frames are iterative solves with per-frame figures
 * (frame_stats in the output). */
static int iterative_method(const dtx_job *job)
{
    return job->method == DTX_METHOD_SPRINGS || job->method == DTX_METHOD_MULTICOMPONENT;
}

static void solves_init(solve_stats *s)
{
    memset(s, 0, sizeof *s);
    s->first_unconverged = s->max_inverted_frame = INT64_MAX;
}

/* Frame f's solve: into s, and as its frame_stats row (inverted: -1 where
 * the method does not count them). */
static void solves_add(solve_stats *s, int64_t f, int32_t iterations, int converged,
                       int32_t inverted, int32_t row[DTX_H5_FRAME_STATS])
{
    row[0] = iterations;
    row[1] = converged ? 1 : 0;
    row[2] = inverted;
    s->frames++;
    s->iterations += iterations;
    s->max_iterations = iterations > s->max_iterations ? iterations : s->max_iterations;
    if (!converged) {
        s->unconverged++;
        s->first_unconverged = f < s->first_unconverged ? f : s->first_unconverged;
    }
    if (inverted > 0)
        s->inverted_frames++;
    if (inverted > s->max_inverted ||
        (inverted == s->max_inverted && inverted > 0 && f < s->max_inverted_frame)) {
        s->max_inverted = inverted;
        s->max_inverted_frame = f;
    }
}

/* The solves of all ranks, on rank 0. */
static void solves_reduce(MPI_Comm comm, const solve_stats *mine, solve_stats *all)
{
    int64_t sums[4] = {mine->frames, mine->iterations, mine->unconverged, mine->inverted_frames};
    int64_t maxs[2] = {mine->max_iterations, mine->max_inverted}, sum_all[4], max_all[2];
    int64_t frame = INT64_MAX;
    solves_init(all);
    MPI_Reduce(sums, sum_all, 4, MPI_INT64_T, MPI_SUM, 0, comm);
    MPI_Reduce(&mine->first_unconverged, &all->first_unconverged, 1, MPI_INT64_T, MPI_MIN, 0,
               comm);
    MPI_Allreduce(maxs, max_all, 2, MPI_INT64_T, MPI_MAX, comm);
    /* The lowest frame with the most inversions, over the ranks. */
    if (mine->max_inverted == max_all[1] && max_all[1] > 0)
        frame = mine->max_inverted_frame;
    MPI_Reduce(&frame, &all->max_inverted_frame, 1, MPI_INT64_T, MPI_MIN, 0, comm);
    all->frames = sum_all[0];
    all->iterations = sum_all[1];
    all->unconverged = sum_all[2];
    all->inverted_frames = sum_all[3];
    all->max_iterations = max_all[0];
    all->max_inverted = max_all[1];
}

/* ------------------------------------------------------------------ */
/* Inputs                                                              */
/* ------------------------------------------------------------------ */

static dtx_status read_mesh_from(const char *file, const char *group, dtx_mesh *m,
                                 dtx_error *err)
{
    hid_t f = H5I_INVALID_HID;
    dtx_status st = dtx_h5_open(file, MPI_COMM_NULL, 0, &f, err);
    if (st != DTX_OK)
        return st;
    st = dtx_h5_read_mesh(f, group, m, err);
    dtx_h5_close(&f, NULL);
    return st;
}

static dtx_status read_markers(const dtx_job_target *t, dtx_markers *mk, dtx_error *err)
{
    dtx_status st;
    if (t->markers.csv)
        return dtx_markers_read_csv(t->markers.csv, t->markers.index_base, mk, err);
    if (t->markers.file) {
        hid_t f = H5I_INVALID_HID;
        st = dtx_h5_open(t->markers.file, MPI_COMM_NULL, 0, &f, err);
        if (st != DTX_OK)
            return st;
        st = dtx_h5_read_markers(f, t->markers.path, mk, err);
        dtx_h5_close(&f, NULL);
        return st;
    }
    return dtx_seterr(err, DTX_EJOB, "target \"%s\": no markers given", t->name);
}

/* The cache key of a correspondence: everything that determines it. */
static void corr_key(const dtx_mesh *src, const dtx_mesh *tgt, const dtx_markers *mk,
                     const char *params, char out[17])
{
    uint64_t h = DTX_HASH_INIT, hs = dtx_mesh_hash(src), ht = dtx_mesh_hash(tgt);
    static const char tag[] = "dtx-sp04-correspondence-v1";
    h = dtx_hash_bytes(h, tag, sizeof tag);
    h = dtx_hash_bytes(h, &hs, sizeof hs);
    h = dtx_hash_bytes(h, &ht, sizeof ht);
    h = dtx_hash_bytes(h, &mk->n, sizeof mk->n);
    h = dtx_hash_bytes(h, mk->src, (size_t)mk->n * sizeof *mk->src);
    h = dtx_hash_bytes(h, mk->tgt, (size_t)mk->n * sizeof *mk->tgt);
    h = dtx_hash_bytes(h, params, strlen(params));
    dtx_hash_hex(h, out);
}

static void corr_params_from_job(const dtx_job *job, dtx_corr_params *p)
{
    dtx_corr_params_default(p);
    p->w_smooth = job->sp04.w_smooth;
    p->w_identity = job->sp04.w_identity;
    p->n_closest = job->sp04.n_closest;
    for (int i = 0; i < job->sp04.n_closest && i < 16; i++)
        p->w_closest[i] = job->sp04.w_closest[i];
    p->max_distance = job->sp04.max_distance;
    p->max_angle_deg = job->sp04.max_angle_deg;
}

/* Broadcast of a correspondence from root (the other ranks allocate). */
static dtx_status bcast_corr(MPI_Comm comm, int root, dtx_corr *c, int32_t nv_s, dtx_error *err)
{
    int rank, has_def = c->deformed_src != NULL;
    long long np = c->npairs;
    int ok = 1;
    MPI_Comm_rank(comm, &rank);
    MPI_Bcast(&np, 1, MPI_LONG_LONG, root, comm);
    /* The multicomponent correspondence deforms the target instead; the
     * transfer needs only the pairs. */
    MPI_Bcast(&has_def, 1, MPI_INT, root, comm);
    if (rank != root) {
        dtx_corr_free(c);
        memset(c, 0, sizeof *c);
        c->npairs = np;
        c->nv_src = nv_s;
        c->pairs = dtx_alloc((size_t)np, 2 * sizeof *c->pairs, 0);
        c->deformed_src =
            has_def ? dtx_alloc((size_t)nv_s, 3 * sizeof *c->deformed_src, 0) : NULL;
        ok = c->pairs && (c->deformed_src || !has_def);
    }
    if (agree(comm, ok ? DTX_OK : dtx_seterr(err, DTX_ENOMEM, "out of memory"), err) != DTX_OK)
        return err->code;
    /* Chunks below 2^31 elements for MPI's int counts. */
    for (long long off = 0; off < 2 * np; off += 1 << 30) {
        long long n = 2 * np - off < (1 << 30) ? 2 * np - off : (1 << 30);
        MPI_Bcast(c->pairs + off, (int)n, MPI_INT32_T, root, comm);
    }
    if (has_def)
        MPI_Bcast(c->deformed_src, 3 * nv_s, MPI_DOUBLE, root, comm);
    return DTX_OK;
}

/* ------------------------------------------------------------------ */
/* 1. The job                                                          */
/* ------------------------------------------------------------------ */

static dtx_status load_job(MPI_Comm comm, const char *path, dtx_job *job, dtx_error *err)
{
    int rank;
    dtx_status st = DTX_OK;
    long long len = 0;
    char *text = NULL;
    MPI_Comm_rank(comm, &rank);
    memset(job, 0, sizeof *job);
    if (rank == 0) {
        st = dtx_job_load(path, job, err);
        if (st == DTX_OK)
            len = (long long)strlen(job->text);
    }
    if (agree(comm, st, err) != DTX_OK) {
        dtx_job_free(job);
        return err->code;
    }
    /* The other ranks parse the very text rank 0 read. */
    MPI_Bcast(&len, 1, MPI_LONG_LONG, 0, comm);
    if (rank != 0) {
        char dir[4096];
        const char *slash = strrchr(path, '/');
        size_t dn = slash ? (size_t)(slash - path) : 0;
        text = malloc((size_t)len + 1);
        if (dn >= sizeof dir)
            dn = sizeof dir - 1;
        memcpy(dir, path, dn);
        dir[dn] = '\0';
        if (!slash)
            strcpy(dir, ".");
        if (text) {
            MPI_Bcast(text, (int)len, MPI_CHAR, 0, comm);
            text[len] = '\0';
            st = dtx_job_parse(text, (size_t)len, path, dir, 0, job, err);
            if (st == DTX_OK && !job->job_path)
                job->job_path = strdup(path);
        } else {
            char dummy;
            MPI_Bcast(&dummy, 0, MPI_CHAR, 0, comm);
            st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
        }
        free(text);
    } else {
        MPI_Bcast(job->text, (int)len, MPI_CHAR, 0, comm);
    }
    if (agree(comm, st, err) != DTX_OK) {
        dtx_job_free(job);
        return err->code;
    }
    return DTX_OK;
}

/* ------------------------------------------------------------------ */
/* 2. Inputs (every rank, read-only)                                   */
/* ------------------------------------------------------------------ */

/* The job's sequence list with every entry whose last component is "*"
 * (a wildcard) replaced by the groups directly under its parent group, in
 * name order: r->seq_paths[0 .. r->ns). */
static dtx_status expand_sequences(run_state *r, dtx_error *err)
{
    int64_t n = 0, cap = 0;
    dtx_status st = DTX_OK;
    for (int32_t i = 0; i < r->job.nsequences && st == DTX_OK; i++) {
        const char *p = r->job.sequences[i];
        size_t len = strlen(p);
        char **names = NULL, parent[DTX_H5_PATH_MAX];
        int64_t nn = 1;
        if (len >= 2 && strcmp(p + len - 2, "/*") == 0) {
            snprintf(parent, sizeof parent, "%.*s", (int)(len - 2), p);
            if (!parent[0])
                strcpy(parent, "/");
            st = dtx_h5_list_groups(r->src_file, parent, &names, &nn, err);
            if (st == DTX_OK && nn == 0)
                st = dtx_seterr(err, DTX_EJOB, "%s: /source/sequences/%d: %s has no groups in %s",
                                r->job.job_path ? r->job.job_path : "job", (int)i, parent,
                                r->job.source_file);
            if (st != DTX_OK)
                break;
        }
        if (n + nn > cap) {
            int64_t nc = (n + nn) * 2;
            char **q = realloc(r->seq_paths, (size_t)nc * sizeof *q);
            if (!q) {
                dtx_h5_free_strings(&names, nn);
                st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
                break;
            }
            r->seq_paths = q;
            cap = nc;
        }
        for (int64_t k = 0; k < nn && st == DTX_OK; k++) {
            char full[DTX_H5_PATH_MAX];
            int plen = names ? snprintf(full, sizeof full, "%s/%s",
                                       strcmp(parent, "/") ? parent : "", names[k])
                            : snprintf(full, sizeof full, "%s", p);
            if (plen < 0 || (size_t)plen >= sizeof full)
                st = dtx_seterr(err, DTX_EJOB, "%s: sequence path %s/%s is too long",
                                r->job.source_file, parent, names ? names[k] : "");
            else if (!(r->seq_paths[n] = strdup(full)))
                st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
            else
                n++;
        }
        dtx_h5_free_strings(&names, nn);
    }
    r->ns = (int)n;
    if (st == DTX_OK && n > INT_MAX / 2)
        st = dtx_seterr(err, DTX_EJOB, "too many sequences");
    return st;
}

static dtx_status read_sequences(run_state *r, dtx_error *err)
{
    dtx_status st = expand_sequences(r, err);
    if (st == DTX_OK && !(r->sq = calloc((size_t)r->ns, sizeof *r->sq)))
        st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
    if (st == DTX_OK && !(r->rs = dtx_alloc((size_t)r->nt * (size_t)r->ns, sizeof *r->rs, 1)))
        st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
    for (int s = 0; s < r->ns && st == DTX_OK; s++) {
        seq_ctx *sc = &r->sq[s];
        sc->path = r->seq_paths[s];
        sc->name = dtx_path_base_name(sc->path);
        for (int s2 = 0; s2 < s; s2++)
            if (strcmp(r->sq[s2].name, sc->name) == 0)
                return dtx_seterr(err, DTX_EJOB,
                                  "%s: /source/sequences: %s and %s would both give results "
                                  "named \"%s\" (results are named after the last component "
                                  "of the sequence path)",
                                  r->job.job_path ? r->job.job_path : "job", r->sq[s2].path,
                                  sc->path, sc->name);
        st = dtx_h5_seq_open(r->src_file, sc->path, &sc->seq, err);
        if (st != DTX_OK)
            break;
        sc->open = 1;
        if (sc->seq.nframes < 1)
            st = dtx_seterr(err, DTX_EFORMAT, "%s: %s has no frames (0 frames); a sequence needs "
                            "at least 1", r->job.source_file, sc->path);
        else if (sc->seq.nv != r->src_weld.nv)
            st = dtx_seterr(err, DTX_EFORMAT,
                            "%s: %s has %d vertices per frame but the source mesh %s has %d",
                            r->job.source_file, sc->path, (int)sc->seq.nv, r->job.source_mesh,
                            (int)r->src_weld.nv);
    }
    return st;
}

/* Mesh checks beyond dtx_mesh_validate (which the reader ran): what sp04
 * cannot use is an error, what it accepts but a user may not expect is a
 * warning from rank 0.  Every rank checks, so every rank fails alike.  A
 * target must be one connected piece: sp04 fixes a single translation, so a
 * second piece would float (a singular system), and saying so here is
 * cheaper than failing after the correspondence. */
static dtx_status check_mesh(run_state *r, const char *file, const char *path,
                             const dtx_mesh *m, int is_target, dtx_error *err)
{
    dtx_mesh_report rep;
    char notes[1024], seams[200] = "";
    dtx_status st = dtx_mesh_inspect(m, &rep, err);
    if (st != DTX_OK)
        return st;
    if (rep.duplicate_positions > 0)
        snprintf(seams, sizeof seams,
                 "; %d of its vertices sit at the position of another vertex (vertices %d and "
                 "%d first): split along seams? a weld_tolerance >= 0 welds them",
                 (int)rep.duplicate_positions, (int)rep.dup_vertex[0], (int)rep.dup_vertex[1]);
    if (is_target && rep.components > 1 && r->job.method == DTX_METHOD_BIHARMONIC &&
        r->job.bh.keypoints == DTX_BH_KEYS_AUTO)
        return dtx_seterr(err, DTX_EMESH,
                          "%s:%s: the target mesh has %d connected components (vertex %d is not "
                          "connected to vertex %d) and the sp04 correspondence that maps "
                          "keypoints \"auto\" needs one (give every piece key points with "
                          "keypoints \"markers\")%s",
                          file, path, (int)rep.components, (int)rep.other_component,
                          (int)m->F[0], seams);
    if (is_target && rep.components > 1 && r->job.method != DTX_METHOD_MULTICOMPONENT &&
        r->job.method != DTX_METHOD_BIHARMONIC)
        return dtx_seterr(err, DTX_EMESH,
                          "%s:%s: the target mesh has %d connected components (vertex %d is not "
                          "connected to vertex %d) and method %s needs one (separate pieces "
                          "need method \"multicomponent\", or one target per piece)%s",
                          file, path, (int)rep.components, (int)rep.other_component,
                          (int)m->F[0], r->job.method == DTX_METHOD_SPRINGS ? "springs" : "sp04",
                          seams);
    if (dtx_mesh_report_notes(&rep, notes, sizeof notes) > 0)
        say(r, "dtx: warning: %s mesh %s:%s: %s; accepted", is_target ? "target" : "source",
            file, path, notes);
    return DTX_OK;
}

/* 1 when tgt has src's vertex count and the same faces in the same order. */
static int same_connectivity(const dtx_mesh *src, const dtx_mesh *tgt)
{
    return src->nv == tgt->nv && src->nf == tgt->nf &&
           memcmp(src->F, tgt->F, (size_t)src->nf * 3 * sizeof *src->F) == 0;
}

static dtx_status read_targets(run_state *r, const char *params, dtx_error *err)
{
    dtx_status st = DTX_OK;
    for (int t = 0; t < r->nt && st == DTX_OK; t++) {
        target_ctx *tc = &r->tg[t];
        char what[4400];
        tc->tj = &r->job.targets[t];
        snprintf(tc->mesh_path, sizeof tc->mesh_path, "/meshes/%s", tc->tj->name);
        snprintf(tc->corr_path, sizeof tc->corr_path, "/correspondences/%s", tc->tj->name);
        /* Messages about the markers name where they came from. */
        if (tc->tj->markers.csv)
            snprintf(what, sizeof what, "%s (markers of target \"%s\")", tc->tj->markers.csv,
                     tc->tj->name);
        else
            snprintf(what, sizeof what, "%s:%s (markers of target \"%s\")",
                     tc->tj->markers.file ? tc->tj->markers.file : "?",
                     tc->tj->markers.path ? tc->tj->markers.path : "?", tc->tj->name);
        st = read_mesh_from(tc->tj->file, tc->tj->mesh, &tc->mesh, err);
        if (st == DTX_OK) {
            char wwhat[4400];
            snprintf(wwhat, sizeof wwhat, "%s:%s", tc->tj->file, tc->tj->mesh);
            st = dtx_weld_setup(&tc->mesh, tc->tj->weld_tolerance, wwhat, &tc->weld, err);
            if (st == DTX_OK && tc->weld.nw < tc->weld.nv)
                say_welded(r, "target", wwhat, &tc->weld);
        }
        if (st == DTX_OK)
            st = check_mesh(r, tc->tj->file, tc->tj->mesh, &tc->mesh, 1, err);
        if (st == DTX_OK && r->job.method == DTX_METHOD_SPRINGS) {
            tc->same_conn = same_connectivity(&r->src, &tc->mesh);
            if (tc->same_conn) {
                /* The paper's setting: vertex i of the target is vertex i
                 * of the source; markers would add nothing. */
                if (tc->tj->markers.csv || tc->tj->markers.file)
                    say(r, "dtx: target %s has the source's vertices and faces: its markers "
                           "are not needed and not used",
                        tc->tj->name);
                corr_key(&r->src, &tc->mesh, &tc->mk, params, tc->key);
                continue;
            }
            if (!tc->tj->markers.csv && !tc->tj->markers.file)
                st = dtx_seterr(err, DTX_EJOB,
                                "%s: target \"%s\" (%s:%s): has %d vertices and %d faces, not "
                                "the source's %d and %d with the same faces, so method springs "
                                "needs its markers (for the sp04 correspondence that deforms "
                                "the source into a proxy of the target)",
                                r->job.job_path ? r->job.job_path : "job", tc->tj->name,
                                tc->tj->file, tc->tj->mesh, (int)tc->mesh.nv, (int)tc->mesh.nf,
                                (int)r->src.nv, (int)r->src.nf);
        }
        if (st == DTX_OK)
            st = read_markers(tc->tj, &tc->mk, err);
        if (st == DTX_OK)
            st = dtx_markers_validate(&tc->mk, r->src_weld.nv, tc->weld.nv, what, err);
        if (st == DTX_OK) /* markers name the assets' vertices */
            dtx_weld_markers(&tc->mk, &r->src_weld, &tc->weld);
        if (st == DTX_OK)
            st = dtx_markers_check_referenced(&tc->mk, &r->src, what, err);
        if (st == DTX_OK)
            corr_key(&r->src, &tc->mesh, &tc->mk, params, tc->key);
    }
    return st;
}

/* The key of the whole run: the job text and everything read from the
 * inputs.  A partial output continues only a run with the same key. */
static void run_key(run_state *r)
{
    static const char tag[] = "dtx-run-v1";
    uint64_t h = DTX_HASH_INIT, hs = dtx_mesh_hash(&r->src);
    struct stat sb;
    h = dtx_hash_bytes(h, tag, sizeof tag);
    h = dtx_hash_bytes(h, r->job.text, strlen(r->job.text));
    h = dtx_hash_bytes(h, &hs, sizeof hs);
    for (int t = 0; t < r->nt; t++)
        h = dtx_hash_bytes(h, r->tg[t].key, 16);
    for (int s = 0; s < r->ns; s++) {
        int64_t shape[2] = {r->sq[s].seq.nframes, r->sq[s].seq.nv};
        h = dtx_hash_bytes(h, r->sq[s].path, strlen(r->sq[s].path) + 1);
        h = dtx_hash_bytes(h, shape, sizeof shape);
    }
    /* The frames themselves are not hashed (too big): a source file that
     * was rewritten since shows in its size and modification time. */
    if (stat(r->job.source_file, &sb) == 0) {
        int64_t id[3] = {(int64_t)sb.st_size, (int64_t)sb.st_mtim.tv_sec,
                         (int64_t)sb.st_mtim.tv_nsec};
        h = dtx_hash_bytes(h, id, sizeof id);
    }
    dtx_hash_hex(h, r->run_key);
}

static dtx_status read_inputs(run_state *r, dtx_error *err)
{
    dtx_status st = DTX_OK;
    double t0 = wtime();
    char *params;
    /* The biharmonic method's key points and the springs method's proxies
     * come from sp04's correspondence: its cache key is sp04's, so changing
     * their own parameters does not recompute it. */
    {
        dtx_job as_sp04 = r->job;
        if (as_sp04.method == DTX_METHOD_BIHARMONIC || as_sp04.method == DTX_METHOD_SPRINGS)
            as_sp04.method = DTX_METHOD_SP04;
        params = dtx_job_params_json(&as_sp04);
    }
    r->nt = r->job.ntargets;
    r->tg = calloc((size_t)r->nt, sizeof *r->tg);
    if (!params || !r->tg)
        st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
    if (st == DTX_OK)
        st = dtx_h5_open(r->job.source_file, MPI_COMM_NULL, 0, &r->src_file, err);
    if (st == DTX_OK)
        st = dtx_h5_read_mesh(r->src_file, r->job.source_mesh, &r->src, err);
    if (st == DTX_OK) {
        char wwhat[4400];
        snprintf(wwhat, sizeof wwhat, "%s:%s", r->job.source_file, r->job.source_mesh);
        st = dtx_weld_setup(&r->src, r->job.source_weld_tolerance, wwhat, &r->src_weld, err);
        if (st == DTX_OK && r->src_weld.nw < r->src_weld.nv)
            say_welded(r, "source", wwhat, &r->src_weld);
    }
    if (st == DTX_OK)
        st = check_mesh(r, r->job.source_file, r->job.source_mesh, &r->src, 0, err);
    if (st == DTX_OK)
        st = read_targets(r, params, err);
    if (st == DTX_OK)
        st = read_sequences(r, err);
    if (st == DTX_OK)
        run_key(r);
    if (st == DTX_OK)
        st = injected_fault(r, "read", err);
    free(params);
    r->tm.read += wtime() - t0;
    return agree(r->comm, st, err);
}

/* ------------------------------------------------------------------ */
/* 3. What the output is                                               */
/* ------------------------------------------------------------------ */

/* 1 when the file at path was written by a run with key `key` (and, with
 * need_complete, every result of the job in it is complete); else 0 with
 * the reason in why. */
static int file_matches(run_state *r, const char *path, int need_complete, char *why, size_t n)
{
    hid_t f = H5I_INVALID_HID;
    dtx_error e;
    char *key = NULL;
    int ok = 0;
    if (dtx_h5_open(path, MPI_COMM_NULL, 0, &f, &e) != DTX_OK) {
        snprintf(why, n, "%s", e.msg);
        return 0;
    }
    if (dtx_h5_read_attr_str(f, ".", "dtx_run_key", &key, &e) != DTX_OK)
        snprintf(why, n, "it was not written by a resumable run");
    else if (strcmp(key, r->run_key) != 0)
        snprintf(why, n, "it belongs to a different job or different inputs");
    else
        ok = 1;
    for (int t = 0; ok && need_complete && t < r->nt; t++)
        for (int s = 0; ok && s < r->ns; s++) {
            char p[DTX_H5_PATH_MAX];
            int64_t c = 0;
            snprintf(p, sizeof p, "/results/%s/%s", r->tg[t].tj->name, r->sq[s].name);
            if (dtx_h5_read_attr_int(f, p, "complete", &c, &e) != DTX_OK || c != 1) {
                snprintf(why, n, "%s is not complete", p);
                ok = 0;
            }
        }
    free(key);
    dtx_h5_close(&f, NULL);
    return ok;
}

/* The mark of a partial output that dtx run created: written and flushed
 * right after the file is created, so that a later run may delete or
 * continue it.  Anything else named OUTPUT.partial is left alone. */
#define PARTIAL_MARK "dtx_partial_of"

static dtx_status mark_partial(run_state *r, hid_t f, dtx_error *err)
{
    dtx_status st = dtx_h5_write_attr_str(f, ".", PARTIAL_MARK, r->job.output_file, err);
    return st == DTX_OK ? dtx_h5_flush(f, err) : st;
}

/* Rank 0: the paths dtx run writes (OUTPUT, OUTPUT.partial, OUTPUT.lock,
 * the summary) are none of the job's inputs and not directories or other
 * special files.  Nothing is created yet. */
static dtx_status check_output_paths(run_state *r, dtx_error *err)
{
    const dtx_job *j = &r->job;
    dtx_path_guard g;
    char lockp[4300], breakp[4400], summary[4200], sumtmp[4300];
    dtx_status st;
    struct { const char *path, *use; } w[7];
    int nw = 0;
    snprintf(lockp, sizeof lockp, "%s.lock", j->output_file);
    snprintf(breakp, sizeof breakp, "%s.break", lockp);
    snprintf(summary, sizeof summary, "%s",
             r->opts->summary_path ? r->opts->summary_path : j->output_file);
    if (!r->opts->summary_path)
        snprintf(summary, sizeof summary, "%s.summary.json", j->output_file);
    snprintf(sumtmp, sizeof sumtmp, "%.4200s.tmp", summary);
    w[nw].path = j->output_file, w[nw++].use = "the output";
    w[nw].path = r->partial, w[nw++].use = "the output's temporary file";
    w[nw].path = lockp, w[nw++].use = "the output's lock file";
    w[nw].path = breakp, w[nw++].use = "the output's lock file";
    w[nw].path = summary, w[nw++].use = "the run summary";
    w[nw].path = sumtmp, w[nw++].use = "the run summary's temporary file";
    dtx_path_guard_init(&g);
    st = dtx_path_guard_add(&g, j->job_path, "the job file", err);
    if (st == DTX_OK)
        st = dtx_path_guard_add(&g, j->source_file, "/source/file", err);
    for (int t = 0; t < j->ntargets && st == DTX_OK; t++) {
        const dtx_job_target *tg = &j->targets[t];
        char role[3][64];
        snprintf(role[0], sizeof role[0], "/targets/%d/file", t);
        snprintf(role[1], sizeof role[1], "/targets/%d/markers/csv", t);
        snprintf(role[2], sizeof role[2], "/targets/%d/markers/file", t);
        st = dtx_path_guard_add(&g, tg->file, role[0], err);
        if (st == DTX_OK)
            st = dtx_path_guard_add(&g, tg->markers.csv, role[1], err);
        if (st == DTX_OK)
            st = dtx_path_guard_add(&g, tg->markers.file, role[2], err);
    }
    int from_summary = 0; /* the failing path came from --summary */
    for (int i = 0; i < nw && st == DTX_OK; i++)
        if ((st = dtx_path_guard_check(&g, w[i].path, w[i].use, err)) != DTX_OK)
            from_summary = i >= 4 && r->opts->summary_path;
    dtx_path_guard_free(&g);
    if (st == DTX_OK)
        st = dtx_output_path_check(j->output_file, "the output", err);
    if (st == DTX_OK)
        st = dtx_output_path_check(r->partial, "the output's temporary file", err);
    if (st == DTX_OK && (st = dtx_output_path_check(summary, "the run summary", err)) != DTX_OK)
        from_summary = r->opts->summary_path != NULL;
    if (st != DTX_OK && from_summary)
        dtx_error_prefix(err, "--summary");
    else if (st != DTX_OK && j->job_path)
        dtx_error_prefix(err, "%s: /output/file", j->job_path);
    return st;
}

/* Rank 0, holding the lock: an OUTPUT.partial found is one that dtx run
 * created (it has the mark, or the run key of older versions); anything
 * else there is refused, neither deleted nor continued. */
static dtx_status check_partial_ours(run_state *r, dtx_error *err)
{
    struct stat sb;
    hid_t f = H5I_INVALID_HID;
    dtx_error e;
    char *v = NULL;
    int ours = 0;
    if (lstat(r->partial, &sb) != 0)
        return DTX_OK;
    if (S_ISLNK(sb.st_mode))
        return dtx_seterr(err, DTX_EIO,
                          "%s is a symbolic link, not a partial output of dtx run: dtx does "
                          "not delete or write through it; remove it or choose another output",
                          r->partial);
    if (dtx_h5_open(r->partial, MPI_COMM_NULL, 0, &f, &e) != DTX_OK)
        return dtx_seterr(err, DTX_EIO,
                          "%s exists and is not a partial output dtx can read (%s): dtx does not "
                          "delete files it cannot recognise as its own; if it is what is left of "
                          "a killed dtx run, remove it",
                          r->partial, e.msg);
    if (dtx_h5_read_attr_str(f, ".", PARTIAL_MARK, &v, &e) == DTX_OK ||
        dtx_h5_read_attr_str(f, ".", "dtx_run_key", &v, &e) == DTX_OK)
        ours = 1;
    free(v);
    dtx_h5_close(&f, NULL);
    if (!ours)
        return dtx_seterr(err, DTX_EIO,
                          "%s exists but was not created by dtx run (no %s mark): dtx does not "
                          "delete or overwrite it; move it away or choose another output",
                          r->partial, PARTIAL_MARK);
    return DTX_OK;
}

/* Before any input is read: the output paths are safe to write (rank 0
 * checks, creates the output's directory and takes OUTPUT.lock), and a
 * partial found there is dtx run's own.  Every rank gets the outcome. */
static dtx_status take_output(run_state *r, dtx_error *err)
{
    dtx_status st = DTX_OK;
    char note[1600];
    if (r->rank == 0) {
        st = check_output_paths(r, err);
        if (st == DTX_OK)
            st = make_dirs(r->job.output_file, 1, err);
        if (st == DTX_OK)
            st = dtx_output_lock_acquire(r->job.output_file, r->opts->break_lock, &r->lock,
                                         note, sizeof note, err);
        if (st == DTX_OK && note[0])
            fprintf(stderr, "dtx: %s\n", note);
        if (st == DTX_OK)
            st = check_partial_ours(r, err);
    }
    return agree(r->comm, st, err);
}

/* Rank 0, after a failure once the output was started (files closed):
 * tells truthfully what is left.  A partial that reads back with this
 * run's key is kept (its frames for --resume when the failure can go away,
 * such as a full disk; its correspondences for a new run otherwise); one
 * that does not read back is this run's own, useless, and removed.  The
 * sentence is added to err's message as its second line, so that it
 * follows the error itself. */
static void partial_fate(run_state *r, const char *job_path, dtx_error *err)
{
    char note[12000];
    size_t len;
    hid_t f = H5I_INVALID_HID;
    dtx_error e;
    char *key = NULL, why[1200] = "";
    int64_t done = 0, total = 0;
    int readable = 0, cause_can_pass = err->code == DTX_EIO || err->code == DTX_ENOMEM ||
                                       err->code == DTX_EMPI;
    struct stat sb;
    if (lstat(r->partial, &sb) != 0)
        return;
    if (dtx_h5_open(r->partial, MPI_COMM_NULL, 0, &f, &e) != DTX_OK) {
        snprintf(why, sizeof why, "%s", e.msg);
    } else if (dtx_h5_read_attr_str(f, ".", "dtx_run_key", &key, &e) != DTX_OK ||
               strcmp(key, r->run_key) != 0) {
        snprintf(why, sizeof why, "its setup was not finished");
    } else {
        readable = 1;
        for (int t = 0; readable && t < r->nt; t++)
            for (int s = 0; readable && s < r->ns; s++) {
                char p[DTX_H5_PATH_MAX];
                dtx_h5_result res;
                int64_t c = 0;
                uint8_t *flags;
                snprintf(p, sizeof p, "/results/%s/%s", r->tg[t].tj->name, r->sq[s].name);
                total += r->sq[s].seq.nframes;
                if (dtx_h5_read_attr_int(f, p, "complete", &c, &e) == DTX_OK && c == 1) {
                    done += r->sq[s].seq.nframes;
                    continue;
                }
                /* An unfinished result is under its temporary name. */
                if (dtx_h5_result_open(f, p, 1, &res, &e) != DTX_OK) {
                    snprintf(why, sizeof why, "%s", e.msg);
                    readable = 0;
                    break;
                }
                flags = dtx_alloc((size_t)res.nframes, 1, 0);
                if (!flags || dtx_h5_result_read_done(&res, flags, &e) != DTX_OK) {
                    snprintf(why, sizeof why, "%s", flags ? e.msg : "out of memory");
                    readable = 0;
                }
                for (int64_t i = 0; readable && i < res.nframes; i++)
                    done += flags[i] == 1;
                free(flags);
                dtx_h5_result_close(&res);
            }
    }
    free(key);
    if (f >= 0)
        dtx_h5_close(&f, NULL);
    if (!readable && strstr(why, "already open")) {
        /* HDF5 still holds it (it could not close it after the failure):
         * the reopen judged nothing.  Left as it is; the next run reads
         * it, or refuses it with a message. */
        snprintf(note, sizeof note, "dtx: %s is left as it is: it could not be checked (%s)",
                 r->partial, why);
    } else if (!readable) {
        /* Read back from disk after the failure: what is there now is
         * what any later run would find. */
        if (remove(r->partial) == 0)
            snprintf(note, sizeof note, "dtx: removed %s, which this run created: it does not "
                     "read back (%s), so no run could continue it", r->partial, why);
        else
            snprintf(note, sizeof note, "dtx: %s does not read back (%s) and cannot be removed "
                     "(%s): remove it before the next run", r->partial, why, strerror(errno));
    } else if (cause_can_pass) {
        snprintf(note, sizeof note, "dtx: %s is kept: %lld of %lld frames done; once the cause "
                 "above is fixed, `dtx run --resume %s` continues from there",
                 r->partial, (long long)done, (long long)total, job_path);
    } else {
        snprintf(note, sizeof note, "dtx: %s is kept (%lld of %lld frames done, and its "
                 "correspondences): `dtx run --resume` would meet the same error; once the input "
                 "is corrected, `dtx run %s` starts the frames over and reuses the "
                 "correspondences",
                 r->partial, (long long)done, (long long)total, job_path);
    }
    len = strlen(err->msg);
    snprintf(err->msg + len, sizeof err->msg - len, "\n%s", note);
}

/* Rank 0: fresh, resume or done. */
static out_mode decide_mode(run_state *r)
{
    char why[1200];
    int has_partial = access(r->partial, F_OK) == 0;
    if (r->opts->resume) {
        if (has_partial) {
            if (file_matches(r, r->partial, 0, why, sizeof why))
                return OUT_RESUME;
            say(r, "dtx: cannot continue %s (%s): starting over", r->partial, why);
            return OUT_FRESH;
        }
        if (access(r->job.output_file, F_OK) == 0 &&
            file_matches(r, r->job.output_file, 1, why, sizeof why))
            return OUT_DONE;
        return OUT_FRESH;
    }
    if (has_partial)
        say(r, "dtx: discarding %s, left by an interrupted run (`dtx run --resume` continues one)",
            r->partial);
    return OUT_FRESH;
}

/* ------------------------------------------------------------------ */
/* 3b. Key points (method biharmonic)                                  */
/* ------------------------------------------------------------------ */

/* Every rank reads the training frames (the clustering features of the
 * fit); with keypoints "auto" the ranks then select the key points on them
 * together, each evaluating its share of the candidates. */
static dtx_status select_keypoints(run_state *r, dtx_error *err)
{
    double t0 = wtime();
    const dtx_h5_seq **seqs;
    const dtx_bh_job_params *bh = &r->job.bh;
    dtx_kp_params kp;
    dtx_status st = DTX_OK;
    if (r->job.method != DTX_METHOD_BIHARMONIC)
        return DTX_OK;
    seqs = dtx_alloc((size_t)r->ns, sizeof *seqs, 0);
    if (!seqs)
        st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
    for (int s = 0; seqs && s < r->ns; s++)
        seqs[s] = &r->sq[s].seq;
    if (st == DTX_OK)
        st = dtx_read_training_frames(seqs, r->ns, bh->training_frames, &r->ntrain, &r->Xtrain,
                                      err);
    if (st == DTX_OK)
        dtx_weld_source_frames(&r->src_weld, r->Xtrain, r->ntrain);
    free(seqs);
    if (st != DTX_OK)
        dtx_error_prefix(err, "%s: training frames", r->job.source_file);
    if ((st = agree(r->comm, st, err)) != DTX_OK)
        return st;
    if (bh->keypoints != DTX_BH_KEYS_AUTO) {
        r->tm.keypoints += wtime() - t0;
        return DTX_OK;
    }
    dtx_kp_params_default(&kp);
    kp.candidates = bh->candidates;
    kp.eps = bh->eps;
    kp.max_keys = bh->max_keypoints;
    kp.skin.lambda = bh->lambda;
    kp.skin.gamma_logr = bh->gamma_logr;
    kp.skin.gamma_s = bh->gamma_s;
    say(r, "dtx: selecting key points on %s:%s from %d training frames (%d candidates, %d "
           "rank(s) x %d thread(s))",
        r->job.source_file, r->job.source_mesh, (int)r->ntrain, (int)kp.candidates, r->nranks,
        r->nthreads);
    st = dtx_keypoints_select_comm(&r->src, r->ntrain, r->Xtrain, &kp, r->comm, &r->kp, err);
    if (st != DTX_OK) {
        /* Every rank holds the same message: prefix it alike. */
        dtx_error_prefix(err, "%s:%s: key points", r->job.source_file, r->job.source_mesh);
        return st;
    }
    r->tm.keypoints += wtime() - t0;
    say(r, "dtx: key points selected in %.2f s", r->tm.keypoints);
    if (r->rank == 0 && !r->opts->quiet)
        dtx_keypoints_print_steps(stderr, "dtx:   ", &r->kp, bh->eps);
    return DTX_OK;
}

static dtx_status copy_markers(const dtx_markers *a, dtx_markers *b, dtx_error *err)
{
    dtx_status st = dtx_markers_alloc(b, a->n, err);
    for (int32_t i = 0; st == DTX_OK && i < a->n; i++) {
        const char *l = a->labels && a->labels[i] ? a->labels[i] : "";
        b->src[i] = a->src[i];
        b->tgt[i] = a->tgt[i];
        if (!(b->labels[i] = strdup(l)))
            st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
    }
    if (st != DTX_OK)
        dtx_markers_free(b);
    return st;
}

/* The key points of each target (every rank: cheap, and the same on
 * every rank): its markers (keypoints "markers"), or the selected key
 * points moved to the target vertex nearest to where the correspondence's
 * deformed source puts them (keypoints "auto"; a key point landing on a
 * target vertex already taken is dropped, with a warning).  Rank 0 prints
 * them as a table a user can check and edit. */
static dtx_status target_keys(run_state *r, dtx_error *err)
{
    dtx_status st = DTX_OK;
    if (r->job.method != DTX_METHOD_BIHARMONIC)
        return DTX_OK;
    for (int t = 0; t < r->nt && st == DTX_OK; t++) {
        target_ctx *tc = &r->tg[t];
        int32_t m = r->kp.count, *tv = NULL, *dup = NULL;
        snprintf(tc->kp_path, sizeof tc->kp_path, "/markers/%s-keypoints", tc->tj->name);
        if (r->job.bh.keypoints == DTX_BH_KEYS_MARKERS) {
            st = copy_markers(&tc->mk, &tc->keys, err);
            say(r, "dtx: target %s: its %d markers are the key points", tc->tj->name,
                (int)tc->mk.n);
            continue;
        }
        tv = dtx_alloc((size_t)m, sizeof *tv, 0);
        dup = dtx_alloc((size_t)m, sizeof *dup, 0);
        st = tv && dup ? DTX_OK : dtx_seterr(err, DTX_ENOMEM, "out of memory");
        if (st == DTX_OK && !tc->corr.deformed_src)
            st = dtx_seterr(err, DTX_EINVAL, "no deformed source to map the key points with");
        if (st == DTX_OK)
            st = dtx_keypoints_map(tc->corr.deformed_src, r->src.nv, &tc->mesh, r->kp.keys, m,
                                   tv, dup, err);
        if (st == DTX_OK)
            st = dtx_keypoints_marker_set(&r->src, r->kp.keys, tv, dup, m, &tc->mk, &tc->keys,
                                          err);
        if (st == DTX_OK && r->rank == 0 && !r->opts->quiet) {
            for (int32_t k = 0; k < m; k++)
                if (dup[k] >= 0)
                    say(r, "dtx: warning: target %s: key points %d and %d both map to target "
                           "vertex %d; key point %d is dropped",
                        tc->tj->name, (int)dup[k] + 1, (int)k + 1, (int)tv[k], (int)k + 1);
            fprintf(stderr,
                    "dtx: target %s: key points mapped through the sp04 correspondence "
                    "(stored as marker set %s; edit and use it with keypoints \"markers\"):\n",
                    tc->tj->name, tc->kp_path);
            dtx_keypoints_print_table(stderr, "dtx:   ", &r->src, r->kp.keys, m, &tc->mk, tv,
                                      dup);
        }
        free(tv);
        free(dup);
        if (st != DTX_OK)
            dtx_error_prefix(err, "target \"%s\" (%s:%s)", tc->tj->name, tc->tj->file,
                             tc->tj->mesh);
    }
    return agree(r->comm, st, err);
}

/* ------------------------------------------------------------------ */
/* 4. Correspondences                                                  */
/* ------------------------------------------------------------------ */

/* Rank 0: correspondences whose key matches one in the cache file. */
static void find_cached(run_state *r, const char *cache, int *reused)
{
    hid_t f = H5I_INVALID_HID;
    dtx_error e;
    if (!cache || access(cache, R_OK) != 0 ||
        dtx_h5_open(cache, MPI_COMM_NULL, 0, &f, &e) != DTX_OK)
        return;
    for (int t = 0; t < r->nt; t++) {
        target_ctx *tc = &r->tg[t];
        char *group = NULL;
        dtx_h5_corr c;
        if (reused[t])
            continue;
        if (dtx_h5_find_corr_by_key(f, tc->key, &group, &e) == DTX_OK && group &&
            dtx_h5_read_corr(f, group, r->src.nv, r->src.nf, tc->mesh.nf, &c, &e) == DTX_OK) {
            memset(&tc->corr, 0, sizeof tc->corr);
            tc->corr.npairs = c.npairs;
            tc->corr.pairs = c.pairs;
            tc->corr.deformed_src = c.deformed_src;
            tc->corr.nv_src = c.nv_s;
            c.pairs = NULL;
            c.deformed_src = NULL;
            dtx_h5_corr_free(&c);
            reused[t] = 1;
        }
        free(group);
    }
    dtx_h5_close(&f, NULL);
}

/* Targets to compute go to ranks biggest first, each onto the rank with the
 * least work so far (ties: the lowest rank), so several targets are
 * corresponded at once. */
static void assign_owners(run_state *r, const int *reused)
{
    double *load = calloc((size_t)r->nranks, sizeof *load);
    int *done = calloc((size_t)r->nt, sizeof *done);
    for (int t = 0; t < r->nt; t++)
        r->tg[t].owner = 0;
    if (!load || !done) {
        free(load);
        free(done);
        return; /* everything on rank 0: slower, still right */
    }
    for (;;) {
        int best = -1, q = 0;
        double cost = 0;
        for (int t = 0; t < r->nt; t++) {
            double c = (double)r->tg[t].mesh.nf + (double)r->src.nf;
            if (!reused[t] && !done[t] && (best < 0 || c > cost)) {
                best = t;
                cost = c;
            }
        }
        if (best < 0)
            break;
        for (int k = 1; k < r->nranks; k++)
            if (load[k] < load[q])
                q = k;
        r->tg[best].owner = q;
        load[q] += cost;
        done[best] = 1;
    }
    free(load);
    free(done);
}

static dtx_status correspondences(run_state *r, dtx_error *err)
{
    double t0 = wtime();
    dtx_status st = DTX_OK;
    dtx_corr_params prm;
    int *reused, ncomputed = 0;
    /* Markers as key points need no correspondence. */
    if (r->job.method == DTX_METHOD_BIHARMONIC && r->job.bh.keypoints == DTX_BH_KEYS_MARKERS)
        return DTX_OK;
    reused = calloc((size_t)r->nt, sizeof *reused);
    if (agree(r->comm, reused ? DTX_OK : dtx_seterr(err, DTX_ENOMEM, "out of memory"), err) !=
        DTX_OK) {
        free(reused);
        return err->code;
    }
    /* reused[t]: 0 to compute, 1 found in a cache, 2 not needed (springs
     * onto a target of the source's connectivity). */
    for (int t = 0; t < r->nt; t++)
        reused[t] = r->tg[t].same_conn ? 2 : 0;
    /* The partial of an interrupted run holds correspondences too, even
     * when it is discarded. */
    if (r->rank == 0 && (r->job.method == DTX_METHOD_SP04 ||
                         r->job.method == DTX_METHOD_BIHARMONIC ||
                         r->job.method == DTX_METHOD_SPRINGS)) {
        find_cached(r, r->partial, reused);
        find_cached(r, r->job.output_file, reused);
    }
    MPI_Bcast(reused, r->nt, MPI_INT, 0, r->comm);
    assign_owners(r, reused);
    corr_params_from_job(&r->job, &prm);
    st = injected_fault(r, "correspondence", err);
    for (int t = 0; t < r->nt && st == DTX_OK; t++) {
        target_ctx *tc = &r->tg[t];
        tc->reused = reused[t] == 1;
        ncomputed += !reused[t];
        if (reused[t] || tc->owner != r->rank)
            continue;
        if (r->job.method == DTX_METHOD_MULTICOMPONENT)
            st = dtx_mc_correspond(&r->src, &tc->mesh, &tc->mk, &prm, r->job.mc.eps_factor,
                                   &tc->corr, err);
        else
            st = dtx_sp04_correspond(&r->src, &tc->mesh, &tc->mk, &prm, &tc->corr, err);
        if (st != DTX_OK)
            dtx_error_prefix(err, "target \"%s\" (%s:%s)", tc->tj->name, tc->tj->file,
                             tc->tj->mesh);
    }
    free(reused);
    if (agree(r->comm, st, err) != DTX_OK)
        return err->code;
    for (int t = 0; t < r->nt; t++)
        if (!r->tg[t].same_conn &&
            (st = bcast_corr(r->comm, r->tg[t].owner, &r->tg[t].corr, r->src.nv, err)) != DTX_OK)
            return st;
    r->tm.correspond += wtime() - t0;
    for (int t = 0; t < r->nt; t++)
        if (r->tg[t].same_conn)
            say(r, "dtx: target %s: the source's vertices and faces: no correspondence needed",
                r->tg[t].tj->name);
        else
            say(r, "dtx: target %s: correspondence %s: %lld triangle pairs%s", r->tg[t].tj->name,
                r->tg[t].reused ? "reused from the output's cache" : "computed",
                (long long)r->tg[t].corr.npairs,
                r->job.method == DTX_METHOD_SPRINGS ? " (the springs solve on the source "
                                                      "deformed by it, a proxy of the target)"
                                                    : "");
    if (ncomputed > 1 && r->nranks > 1)
        say(r, "dtx: %d correspondences computed on %d ranks in %.2f s", ncomputed,
            ncomputed < r->nranks ? ncomputed : r->nranks, r->tm.correspond);
    return DTX_OK;
}

/* ------------------------------------------------------------------ */
/* 5. The output                                                       */
/* ------------------------------------------------------------------ */

/* Rank 0: the new output file, serial, holding each target's key points
 * (method biharmonic) as the marker set /markers/TARGET-keypoints. */
static dtx_status write_keypoint_sets(run_state *r, dtx_error *err)
{
    hid_t f = H5I_INVALID_HID;
    char srcdesc[4200];
    dtx_status st = dtx_h5_create(r->partial, MPI_COMM_NULL, &f, err);
    if (st == DTX_OK)
        st = mark_partial(r, f, err);
    snprintf(srcdesc, sizeof srcdesc, "%s:%s", r->job.source_file, r->job.source_mesh);
    for (int t = 0; t < r->nt && st == DTX_OK; t++)
        st = dtx_h5_write_markers(f, r->tg[t].kp_path, &r->tg[t].keys, srcdesc,
                                  r->tg[t].mesh_path, err);
    if (f >= 0) {
        dtx_error e2;
        if (dtx_h5_close(&f, &e2) != DTX_OK && st == DTX_OK) {
            *err = e2;
            st = e2.code;
        }
    }
    return st;
}

static dtx_status create_output(run_state *r, dtx_error *err)
{
    dtx_status st = DTX_OK;
    char *params = dtx_job_params_json(&r->job);
    char srcdesc[4200];
    if (r->rank == 0) {
        st = make_dirs(r->job.output_file, 1, err);
        if (st == DTX_OK && remove(r->partial) != 0 && errno != ENOENT)
            st = dtx_seterr(err, DTX_EIO, "%s: cannot remove: %s", r->partial, strerror(errno));
    }
    if ((st = agree(r->comm, st, err)) != DTX_OK)
        goto done;
    if (r->job.method == DTX_METHOD_BIHARMONIC) {
        /* Marker sets have variable-length labels, which parallel HDF5
         * cannot write: rank 0 creates the file with the key points
         * serially, then every rank opens it. */
        st = r->rank == 0 ? write_keypoint_sets(r, err) : DTX_OK;
        if ((st = agree(r->comm, st, err)) != DTX_OK)
            goto done;
        st = dtx_h5_open(r->partial, r->comm, 1, &r->out, err);
    } else {
        st = dtx_h5_create(r->partial, r->comm, &r->out, err);
        if (agree(r->comm, st, err) == DTX_OK)
            st = mark_partial(r, r->out, err);
    }
    if ((st = agree(r->comm, st, err)) != DTX_OK)
        goto done;
    st = params ? DTX_OK : dtx_seterr(err, DTX_ENOMEM, "out of memory");
    snprintf(srcdesc, sizeof srcdesc, "%s:%s", r->job.source_file, r->job.source_mesh);
    for (int t = 0; t < r->nt && st == DTX_OK; t++) {
        target_ctx *tc = &r->tg[t];
        const dtx_job_target *tj = tc->tj;
        char tgtdesc[4200], mkdesc[4200];
        dtx_h5_corr_meta meta;
        snprintf(tgtdesc, sizeof tgtdesc, "%s:%s", tj->file, tj->mesh);
        if (tj->markers.csv)
            /* Not starting with '/': the validator follows in-file paths. */
            snprintf(mkdesc, sizeof mkdesc, "CSV file %s (index base %d)", tj->markers.csv,
                     tj->markers.index_base);
        else if (tj->markers.file)
            snprintf(mkdesc, sizeof mkdesc, "%s:%s", tj->markers.file, tj->markers.path);
        else
            snprintf(mkdesc, sizeof mkdesc, "none");
        meta.key = tc->key;
        meta.source_mesh = srcdesc;
        meta.target_mesh = tgtdesc;
        meta.markers = mkdesc;
        meta.parameters = params;
        st = dtx_weld_write_asset(r->out, tc->mesh_path, &tc->weld, &tc->mesh, tj->file,
                                  tj->mesh, tgtdesc, err);
        /* Only sp04's correspondence has a place in the layout (with its
         * deformed source); the multicomponent one is recomputed per run. */
        if (st == DTX_OK && tc->corr.deformed_src)
            st = dtx_h5_write_corr(r->out, tc->corr_path, tc->corr.pairs, tc->corr.npairs,
                                   tc->corr.deformed_src, r->src.nv, &meta, err);
        for (int s = 0; s < r->ns && st == DTX_OK; s++) {
            result_ctx *rc = RESULT(r, t, s);
            char res_path[DTX_H5_PATH_MAX], seqdesc[4200];
            dtx_h5_provenance prov;
            snprintf(res_path, sizeof res_path, "/results/%s/%s", tj->name, r->sq[s].name);
            /* The source file by a path relative to the output where they
             * share a folder, so both can move together (readers look
             * relative to the result's file). */
            char relsrc[4096];
            dtx_path_relative(r->job.source_file, r->job.output_file, relsrc, sizeof relsrc);
            snprintf(seqdesc, sizeof seqdesc, "%s:%s", relsrc, r->sq[s].path);
            prov.method = r->job.method == DTX_METHOD_MULTICOMPONENT ? "multicomponent"
                          : r->job.method == DTX_METHOD_BIHARMONIC   ? "biharmonic"
                          : r->job.method == DTX_METHOD_SPRINGS      ? "springs"
                                                                     : "sp04";
            prov.job = r->job.text;
            prov.parameters = params;
            prov.source_sequence = seqdesc;
            prov.target_mesh = tc->mesh_path;
            prov.correspondence = tc->corr.deformed_src ? tc->corr_path : "";
            st = dtx_h5_result_create(r->out, res_path, &prov, r->sq[s].seq.nframes,
                                      tc->weld.nv, r->job.output_dtype == DTX_DTYPE_FLOAT64,
                                      r->align, 0, &rc->res, err);
            rc->open = st == DTX_OK;
            if (st == DTX_OK) /* the source sequence's frame rate, when it has one */
                st = dtx_h5_copy_fps(r->sq[s].seq.group, rc->res.group, err);
            if (st == DTX_OK && iterative_method(&r->job))
                st = dtx_h5_result_add_frame_stats(&rc->res, err);
        }
    }
    /* The key that lets --resume continue this file goes in last, once
     * every object exists; everything the frame loop needs is on disk
     * before any frame. */
    if (st == DTX_OK)
        st = dtx_h5_write_attr_str(r->out, ".", "dtx_run_key", r->run_key, err);
    if (st == DTX_OK)
        st = dtx_h5_flush(r->out, err);
    if (st == DTX_OK && r->rank == 0)
        st = dtx_h5_preallocate(r->out, err);
    if (st == DTX_OK)
        st = injected_fault(r, "output", err);
done:
    free(params);
    return agree(r->comm, st, err);
}

static dtx_status reopen_output(run_state *r, dtx_error *err)
{
    dtx_status st = dtx_h5_open(r->partial, r->comm, 1, &r->out, err);
    for (int t = 0; t < r->nt && st == DTX_OK; t++)
        for (int s = 0; s < r->ns && st == DTX_OK; s++) {
            result_ctx *rc = RESULT(r, t, s);
            char final[DTX_H5_PATH_MAX], tmp[DTX_H5_PATH_MAX];
            int64_t complete = 0;
            snprintf(final, sizeof final, "/results/%s/%s", r->tg[t].tj->name, r->sq[s].name);
            st = dtx_h5_tmp_path(final, tmp, sizeof tmp, err);
            if (st != DTX_OK)
                break;
            if (dtx_h5_path_exists(r->out, tmp)) {
                st = dtx_h5_result_open(r->out, final, 1, &rc->res, err);
                rc->open = st == DTX_OK;
                if (st == DTX_OK && (rc->res.nframes != r->sq[s].seq.nframes ||
                                     rc->res.nv != r->tg[t].weld.nv))
                    st = dtx_seterr(err, DTX_EFORMAT,
                                    "%s: %s has %lld frames of %d vertices, the job needs %lld "
                                    "of %d: cannot resume",
                                    r->partial, tmp, (long long)rc->res.nframes, (int)rc->res.nv,
                                    (long long)r->sq[s].seq.nframes, (int)r->tg[t].weld.nv);
            } else if (dtx_h5_read_attr_int(r->out, final, "complete", &complete, err) ==
                           DTX_OK &&
                       complete == 1) {
                rc->finished = 1;
            } else {
                st = dtx_seterr(err, DTX_EFORMAT,
                                "%s: neither %s nor a finished %s: cannot resume", r->partial,
                                tmp, final);
            }
        }
    return agree(r->comm, st, err);
}

/* ------------------------------------------------------------------ */
/* 6. Frames                                                           */
/* ------------------------------------------------------------------ */

/* The groups (of align frames) of a result with a frame not done:
 * todo[0 .. *ntodo), increasing.  *skipped counts the frames already done
 * in whole groups. */
static dtx_status groups_todo(const result_ctx *rc, int align, int64_t **todo, int64_t *ntodo,
                              int64_t *skipped, dtx_error *err)
{
    int64_t nframes = rc->res.nframes, ng = (nframes + align - 1) / align;
    uint8_t *done = dtx_alloc((size_t)nframes, 1, 0);
    dtx_status st;
    *ntodo = *skipped = 0;
    *todo = dtx_alloc((size_t)ng, sizeof **todo, 0);
    if (!done || !*todo) {
        free(done);
        free(*todo);
        *todo = NULL;
        return dtx_seterr(err, DTX_ENOMEM, "out of memory");
    }
    st = dtx_h5_result_read_done(&rc->res, done, err);
    for (int64_t g = 0; st == DTX_OK && g < ng; g++) {
        int64_t f0 = g * align, f1 = f0 + align, all = 1;
        f1 = f1 < nframes ? f1 : nframes;
        for (int64_t f = f0; f < f1; f++)
            all &= done[f] == 1;
        if (all)
            *skipped += f1 - f0;
        else
            (*todo)[(*ntodo)++] = g;
    }
    free(done);
    return st;
}

/* The groups todo[a .. b) of one rank cut into segments: runs of
 * consecutive groups of at most gpb groups.  Returns the number of
 * segments; with seg != NULL stores segment k's first index into todo in
 * seg[k] (seg[nseg] = b). */
static int64_t segments(const int64_t *todo, int64_t a, int64_t b, int64_t gpb, int64_t *seg)
{
    int64_t n = 0, len = 0;
    for (int64_t k = a; k < b; k++) {
        if (k == a || todo[k] != todo[k - 1] + 1 || len == gpb) {
            if (seg)
                seg[n] = k;
            n++;
            len = 0;
        }
        len++;
    }
    if (seg)
        seg[n] = b;
    return n;
}

/* The range [a, b) of todo that rank q deals with.  The ranks are rotated
 * by `rot` so that the remainders of many short sequences do not all land
 * on the first ranks. */
static void rank_range(int64_t ntodo, int nranks, int q, int rot, int64_t *a, int64_t *b)
{
    int64_t first, count;
    dtx_partition_frames(ntodo, 1, nranks, (q - rot % nranks + nranks) % nranks, &first, &count);
    *a = first;
    *b = first + count;
}

typedef struct {
    int32_t block;         /* frames per block, a multiple of the run's align */
    double *Xs, *Xt, *res; /* block x nv_s x 3, block x nv_t x 3, block */
    dtx_springs_frame_info *sinfo; /* method springs: block entries */
    dtx_mc_frame_info *minfo;      /* method multicomponent: block entries */
    int32_t *fstats;       /* iterative methods: block x DTX_H5_FRAME_STATS */
} frame_buffers;

static void progress_step(run_state *r, int64_t n)
{
    int64_t sum = 0;
    MPI_Reduce(&n, &sum, 1, MPI_INT64_T, MPI_SUM, 0, r->comm);
    if (r->rank == 0) {
        r->frames_done += sum;
        dtx_progress_update(&r->prog, r->frames_done, wtime());
    }
}

static dtx_status export_obj(run_state *r, const target_ctx *tc, const seq_ctx *sc,
                             int64_t f0, int64_t n, const double *Xt, dtx_error *err)
{
    char dir[4096];
    dtx_status st = DTX_OK;
    snprintf(dir, sizeof dir, "%s/%s/%s", r->job.export_obj_dir, tc->tj->name, sc->name);
    for (int64_t i = 0; st == DTX_OK && i < n; i++) {
        char path[4200];
        snprintf(path, sizeof path, "%s/%s-%05lld.obj", dir, tc->tj->name,
                 (long long)(f0 + i + 1));
        /* With the asset's UVs, materials and per-frame normals (issue 17). */
        target_ctx *mt = &r->tg[tc - r->tg];
        st = dtx_weld_write_obj(&mt->weld, &mt->mesh, tc->tj->file, tc->tj->mesh, path,
                                Xt + (size_t)i * 3 * tc->weld.nv,
                                "deformation transfer result (dtx)", err);
    }
    return st;
}

/* Source frames may come from files other programs wrote: when a frame's
 * transfer is not finite, this names the non-finite source coordinate
 * behind it (frames f0 .. f0 + n at Xs).  Only called on failure, so the
 * frame loop pays nothing for it. */
static dtx_status check_frames_finite(const run_state *r, const seq_ctx *sc, int64_t f0,
                                      int64_t n, const double *Xs, dtx_error *err)
{
    const size_t per = 3 * (size_t)r->src.nv;
    for (int64_t i = 0; i < n; i++)
        for (size_t k = 0; k < per; k++)
            if (!isfinite(Xs[(size_t)i * per + k]))
                return dtx_seterr(err, DTX_ENONFINITE,
                                  "%s: %s/positions: frame %lld (0-based), vertex %d has a "
                                  "non-finite coordinate",
                                  r->job.source_file, sc->path, (long long)(f0 + i),
                                  (int)(k / 3));
    return DTX_OK;
}

/* Transfers the frames of result (t, s) not yet done, each rank its share,
 * in blocks; with collective I/O every rank makes the same number of
 * writes (ranks without frames write nothing). */
/* The factored transfer of one target, by method. */
typedef struct {
    dtx_sp04_plan *sp04;
    dtx_mc_plan *mc;
    dtx_bh_plan *bh;
    dtx_springs_plan *springs;
    int recentre;      /* bh with translation "fixed": move each frame's centroid */
    double centre[3];  /* to the target's rest centroid */
} plan_ref;

/* Moves each of the n frames X (n x nv x 3) so that its vertex centroid is
 * c (per frame, in vertex order: the same bits however frames are split). */
static void recentre(double *X, int64_t n, int32_t nv, const double c[3])
{
    for (int64_t f = 0; f < n; f++) {
        double *Y = X + (size_t)f * 3 * (size_t)nv, m[3] = {0, 0, 0};
        for (int32_t i = 0; i < nv; i++)
            for (int k = 0; k < 3; k++)
                m[k] += Y[3 * (size_t)i + k];
        for (int k = 0; k < 3; k++)
            m[k] = c[k] - m[k] / nv;
        for (int32_t i = 0; i < nv; i++)
            for (int k = 0; k < 3; k++)
                Y[3 * (size_t)i + k] += m[k];
    }
}

static dtx_status plan_apply(const plan_ref *p, int64_t n, const double *Xs, double *Xt,
                             double *res, frame_buffers *fb, dtx_error *err)
{
    if (p->springs) {
        dtx_status st = dtx_springs_apply(p->springs, n, Xs, Xt, fb->sinfo, err);
        for (int64_t i = 0; st == DTX_OK && i < n; i++)
            res[i] = fb->sinfo[i].residual;
        return st;
    }
    if (p->mc)
        return dtx_mc_apply(p->mc, n, Xs, Xt, res, fb->minfo, err);
    if (p->bh) {
        dtx_status st = dtx_bh_apply(p->bh, n, Xs, Xt, res, err);
        if (st == DTX_OK && p->recentre)
            recentre(Xt, n, dtx_bh_plan_nv_tgt(p->bh), p->centre);
        return st;
    }
    return dtx_sp04_apply(p->sp04, n, Xs, Xt, res, err);
}

static dtx_status transfer_result(run_state *r, int t, int s, const plan_ref *plan,
                                  frame_buffers *fb, dtx_error *err)
{
    result_ctx *rc = RESULT(r, t, s);
    const target_ctx *tc = &r->tg[t];
    const seq_ctx *sc = &r->sq[s];
    int64_t *todo = NULL, *seg = NULL, ntodo = 0, skipped = 0, a, b, nseg, nseg_max = 0;
    int64_t gpb = fb->block / r->align, nframes = rc->res.nframes;
    int rot = (int)(((int64_t)t * r->ns + s) % r->nranks);
    dtx_status st;

    stats_init(&rc->st);
    solves_init(&rc->sv);
    st = groups_todo(rc, r->align, &todo, &ntodo, &skipped, err);
    if ((st = agree(r->comm, st, err)) != DTX_OK)
        goto done;
    for (int q = 0; q < r->nranks; q++) {
        int64_t qa, qb, n;
        rank_range(ntodo, r->nranks, q, rot, &qa, &qb);
        n = segments(todo, qa, qb, gpb, NULL);
        nseg_max = n > nseg_max ? n : nseg_max;
    }
    rank_range(ntodo, r->nranks, r->rank, rot, &a, &b);
    seg = dtx_alloc((size_t)(b - a) + 1, sizeof *seg, 0);
    st = seg ? DTX_OK : dtx_seterr(err, DTX_ENOMEM, "out of memory");
    if ((st = agree(r->comm, st, err)) != DTX_OK)
        goto done;
    nseg = segments(todo, a, b, gpb, seg);
    if (r->job.export_obj_dir && ntodo > 0) {
        char dir[4096];
        snprintf(dir, sizeof dir, "%s/%s/%s", r->job.export_obj_dir, tc->tj->name, sc->name);
        st = r->rank == 0 ? make_dirs(dir, 0, err) : DTX_OK;
        if ((st = agree(r->comm, st, err)) != DTX_OK)
            goto done;
    }

    for (int64_t k = 0; k < nseg_max; k++) {
        int64_t f0 = 0, n = 0;
        double t0, t1, t2;
        if (k < nseg) {
            f0 = todo[seg[k]] * r->align;
            n = (todo[seg[k + 1] - 1] + 1) * r->align - f0;
            n = f0 + n > nframes ? nframes - f0 : n;
        }
        t0 = wtime();
        st = n > 0 ? dtx_h5_seq_read(&sc->seq, f0, n, fb->Xs, err) : DTX_OK;
        t1 = wtime();
        if (st == DTX_OK && n > 0) {
            dtx_weld_source_frames(&r->src_weld, fb->Xs, n);
            st = plan_apply(plan, n, fb->Xs, fb->Xt, fb->res, fb, err);
            if (st == DTX_OK) /* twins identical, in the asset's order */
                dtx_weld_result_frames(&tc->weld, fb->Xt, n);
        }
        if (st == DTX_OK && k == nseg_max / 2)
            st = injected_fault(r, "transfer", err);
        t2 = wtime();
        for (int64_t i = 0; st == DTX_OK && i < n; i++) {
            if (!isfinite(fb->res[i])) {
                /* Name the source coordinate when one is to blame. */
                st = check_frames_finite(r, sc, f0 + i, 1,
                                         fb->Xs + (size_t)i * 3 * (size_t)r->src.nv, err);
                if (st == DTX_OK)
                    st = dtx_seterr(err, DTX_ENONFINITE,
                                    "%s:%s frame %lld: the transfer onto \"%s\" produced "
                                    "non-finite values",
                                    r->job.source_file, sc->path, (long long)(f0 + i),
                                    tc->tj->name);
                break;
            }
            stats_add(&rc->st, fb->res[i]);
            if (plan->springs)
                solves_add(&rc->sv, f0 + i, fb->sinfo[i].iterations, fb->sinfo[i].converged,
                           fb->sinfo[i].inverted, fb->fstats + DTX_H5_FRAME_STATS * i);
            else if (plan->mc) /* inverted triangles are not counted */
                solves_add(&rc->sv, f0 + i, fb->minfo[i].iterations, fb->minfo[i].converged, -1,
                           fb->fstats + DTX_H5_FRAME_STATS * i);
        }
        if ((st = agree(r->comm, st, err)) != DTX_OK)
            goto done;
        /* The solver figures first: dtx_h5_result_write marks frames done. */
        if (plan->springs || plan->mc)
            st = dtx_h5_result_write_frame_stats(&rc->res, n > 0 ? f0 : 0, n, fb->fstats,
                                                 r->job.collective_io, err);
        if (st == DTX_OK)
            st = dtx_h5_result_write(&rc->res, n > 0 ? f0 : 0, n, fb->Xt, fb->res,
                                 r->job.collective_io, err);
        if (st == DTX_OK && r->job.export_obj_dir)
            st = export_obj(r, tc, sc, f0, n, fb->Xt, err);
        r->tm.read += t1 - t0;
        r->tm.transfer += t2 - t1;
        r->tm.write += wtime() - t2;
        if ((st = agree(r->comm, st, err)) != DTX_OK)
            goto done;
        progress_step(r, n);
    }
done:
    free(todo);
    free(seg);
    return st;
}

/* Frames still to do over all results (rank 0's count is the one used). */
static dtx_status count_todo(run_state *r, dtx_error *err)
{
    dtx_status st = DTX_OK;
    r->frames_todo = r->frames_skipped = 0;
    for (int t = 0; t < r->nt && st == DTX_OK; t++)
        for (int s = 0; s < r->ns && st == DTX_OK; s++) {
            result_ctx *rc = RESULT(r, t, s);
            int64_t *todo = NULL, ntodo = 0, skipped = 0;
            if (rc->finished) {
                r->frames_skipped += r->sq[s].seq.nframes;
                continue;
            }
            st = groups_todo(rc, r->align, &todo, &ntodo, &skipped, err);
            r->frames_todo += rc->res.nframes - skipped;
            r->frames_skipped += skipped;
            free(todo);
        }
    return agree(r->comm, st, err);
}

/* Method springs: the plan of one target (on the target itself, or on the
 * proxy for another connectivity). */
static dtx_status springs_plan(run_state *r, const target_ctx *tc, dtx_anchor anchor,
                               const int32_t *pins, const double *pin_pos, plan_ref *plan,
                               dtx_error *err)
{
    const dtx_springs_job_params *q = &r->job.springs;
    dtx_springs_params sp;
    dtx_springs_info info;
    dtx_status st;
    dtx_springs_params_default(&sp);
    sp.bending = q->bending;
    sp.internal = q->internal;
    sp.levels = q->levels;
    sp.coarse_min = q->coarse_min;
    sp.start = q->start_rest ? DTX_SPRINGS_START_REST : DTX_SPRINGS_START_LINEAR;
    sp.max_iter = q->max_iter;
    sp.tol = q->tol;
    sp.coarse_max_iter = q->coarse_max_iter;
    sp.coarse_tol = q->coarse_tol;
    if (!tc->same_conn && tc->tj->npins > 0)
        return dtx_seterr(err, DTX_EJOB,
                          "%s: target \"%s\": method springs holds pins only on a target with the "
                          "source's vertices and faces (this one goes through a proxy)",
                          r->job.job_path ? r->job.job_path : "job", tc->tj->name);
    st = dtx_springs_plan_create(&r->src, &tc->mesh, tc->same_conn ? NULL : tc->corr.deformed_src,
                                 &sp, anchor, pins, pin_pos, tc->tj->npins, &plan->springs, err);
    if (st != DTX_OK)
        return st;
    dtx_springs_plan_info(plan->springs, &info);
    say(r, "dtx: target %s: %d edge, %d bending and %d internal springs%s; %d levels (%d "
           "vertices on the coarsest); factor %lld entries; %.2f s",
        tc->tj->name, (int)info.springs[DTX_SPRING_EDGE], (int)info.springs[DTX_SPRING_BENDING],
        (int)info.springs[DTX_SPRING_INTERNAL], info.proxy ? " on the proxy" : "", info.levels,
        (int)info.level_vertices[info.levels - 1], (long long)info.factor_nnz,
        info.setup_seconds);
    if (info.proxy)
        say(r, "dtx: target %s: its vertices lie %.3g%% of its diagonal (RMS) from the proxy",
            tc->tj->name, 100 * info.proxy_rms);
    return DTX_OK;
}

/* Rank 0, methods springs and multicomponent: how the (Gauss-)Newton solves
 * of result (t, s) went. */
static void say_solves(run_state *r, int t, int s)
{
    const solve_stats *sp = &RESULT(r, t, s)->sv;
    char more[400] = "";
    if (sp->frames == 0)
        return;
    if (sp->unconverged > 0)
        snprintf(more, sizeof more, "; %lld frame%s stopped before converging (the first: "
                                    "frame %lld)",
                 (long long)sp->unconverged, sp->unconverged == 1 ? "" : "s",
                 (long long)sp->first_unconverged);
    if (sp->inverted_frames > 0)
        snprintf(more + strlen(more), sizeof more - strlen(more),
                 "; %lld frames have inverted triangles (most: %lld in frame %lld)",
                 (long long)sp->inverted_frames, (long long)sp->max_inverted,
                 (long long)sp->max_inverted_frame);
    say(r, "dtx: result %s/%s: %s %.1f iterations per frame (at most %lld)%s%s",
        r->tg[t].tj->name, r->sq[s].name,
        r->job.method == DTX_METHOD_MULTICOMPONENT ? "Gauss-Newton" : "Newton",
        (double)sp->iterations / (double)sp->frames,
        (long long)sp->max_iterations, more,
        sp->unconverged || sp->inverted_frames ? " (per frame: frame_stats in the output)" : "");
}

/* The biharmonic transfer of one target: both meshes' bounded biharmonic
 * weights of their key points and the source fit's clustering (on the
 * training frames). */
static dtx_status bh_plan(run_state *r, const target_ctx *tc, plan_ref *plan, dtx_error *err)
{
    dtx_bh_params bp;
    dtx_bh_info info;
    dtx_status st;
    dtx_bh_params_default(&bp);
    bp.skin.lambda = r->job.bh.lambda;
    bp.skin.gamma_logr = r->job.bh.gamma_logr;
    bp.skin.gamma_s = r->job.bh.gamma_s;
    st = dtx_bh_plan_create(&r->src, &tc->mesh, tc->keys.src, tc->keys.tgt, tc->keys.n, &bp,
                            r->ntrain, r->Xtrain, &plan->bh, err);
    if (st != DTX_OK)
        return st;
    plan->recentre = tc->tj->translation == DTX_TRANSLATION_FIXED;
    for (int k = 0; k < 3; k++) {
        plan->centre[k] = 0;
        for (int32_t i = 0; i < tc->mesh.nv; i++)
            plan->centre[k] += tc->mesh.V[3 * (size_t)i + k];
        plan->centre[k] /= tc->mesh.nv;
    }
    dtx_bh_plan_info(plan->bh, &info);
    say(r, "dtx: target %s: %d key points, %d rotation clusters, biharmonic weights %.2f s; "
           "key points %.2f%% of the source diagonal apart after aligning the target",
        tc->tj->name, (int)info.keys, (int)info.clusters, info.weights_seconds,
        100 * info.align_rms);
    return DTX_OK;
}

static dtx_status transfer_all(run_state *r, dtx_error *err)
{
    dtx_status st = DTX_OK;
    int32_t maxnv = 0;
    frame_buffers fb;
    memset(&fb, 0, sizeof fb);
    /* Blocks are whole solve groups, so frame arithmetic never depends on
     * how frames are split over ranks or calls. */
    fb.block = r->job.block_frames;
    if (fb.block % r->align)
        fb.block += r->align - fb.block % r->align;
    for (int t = 0; t < r->nt; t++)
        maxnv = r->tg[t].weld.nv > maxnv ? r->tg[t].weld.nv : maxnv;
    fb.Xs = dtx_alloc((size_t)fb.block * (size_t)r->src_weld.nv, 3 * sizeof *fb.Xs, 0);
    fb.Xt = dtx_alloc((size_t)fb.block * (size_t)maxnv, 3 * sizeof *fb.Xt, 0);
    fb.res = dtx_alloc((size_t)fb.block, sizeof *fb.res, 0);
    if (r->job.method == DTX_METHOD_SPRINGS)
        fb.sinfo = dtx_alloc((size_t)fb.block, sizeof *fb.sinfo, 1);
    if (r->job.method == DTX_METHOD_MULTICOMPONENT)
        fb.minfo = dtx_alloc((size_t)fb.block, sizeof *fb.minfo, 1);
    if (iterative_method(&r->job))
        fb.fstats = dtx_alloc((size_t)fb.block, DTX_H5_FRAME_STATS * sizeof *fb.fstats, 1);
    st = fb.Xs && fb.Xt && fb.res && (r->job.method != DTX_METHOD_SPRINGS || fb.sinfo) &&
                 (r->job.method != DTX_METHOD_MULTICOMPONENT || fb.minfo) &&
                 (!iterative_method(&r->job) || fb.fstats)
             ? DTX_OK
             : dtx_seterr(err, DTX_ENOMEM, "out of memory for frames");
    if ((st = agree(r->comm, st, err)) != DTX_OK)
        goto done;

    for (int t = 0; t < r->nt; t++) {
        target_ctx *tc = &r->tg[t];
        const dtx_job_target *tj = tc->tj;
        plan_ref plan;
        dtx_anchor anchor;
        int32_t *pin_idx = NULL;
        double *pin_pos = NULL, t0 = wtime();
        int needed = 0;
        for (int s = 0; s < r->ns; s++)
            needed |= !RESULT(r, t, s)->finished;
        if (!needed)
            continue;
        memset(&plan, 0, sizeof plan);
        /* Factor (every rank: each needs the factor for its solves). */
        if (tj->npins > 0) {
            pin_idx = dtx_alloc((size_t)tj->npins, sizeof *pin_idx, 0);
            pin_pos = dtx_alloc((size_t)tj->npins, 3 * sizeof *pin_pos, 0);
            if (pin_idx && pin_pos)
                for (int32_t i = 0; i < tj->npins; i++) {
                    pin_idx[i] = dtx_weld_index(&tc->weld, tj->pins[i].vertex);
                    memcpy(pin_pos + 3 * i, tj->pins[i].pos, 3 * sizeof *pin_pos);
                }
        }
        anchor = tj->translation == DTX_TRANSLATION_FOLLOW
                     ? DTX_ANCHOR_FOLLOW
                     : (tj->translation == DTX_TRANSLATION_PINS ? DTX_ANCHOR_PINS
                                                                : DTX_ANCHOR_FIXED);
        if (r->job.method == DTX_METHOD_MULTICOMPONENT) {
            dtx_mc_params mp;
            dtx_mc_params_default(&mp);
            mp.w_match = r->job.mc.w_match;
            mp.w_orphan = r->job.mc.w_orphan;
            mp.w_proximity = r->job.mc.w_proximity;
            mp.lengths = (dtx_mc_lengths)r->job.mc.lengths;
            mp.w_laplacian = r->job.mc.w_laplacian;
            mp.eps_factor = r->job.mc.eps_factor;
            mp.max_iter = r->job.mc.max_iter;
            mp.tol = r->job.mc.tol;
            st = dtx_mc_plan_create(&r->src, &tc->mesh, tc->corr.pairs, tc->corr.npairs, &mp,
                                    anchor, pin_idx, pin_pos, tj->npins, &plan.mc, err);
            if (st == DTX_OK) {
                dtx_mc_info info;
                dtx_mc_plan_info(plan.mc, &info);
                say(r,
                    "dtx: target %s: %d components, %d proximity edges with %lld vertex pairs, "
                    "%d orphan triangles, %d orphan components",
                    tj->name, (int)info.components, (int)info.proximity_edges,
                    (long long)info.proximity_pairs, (int)info.orphan_triangles,
                    (int)info.orphan_components);
            }
        } else if (r->job.method == DTX_METHOD_BIHARMONIC) {
            st = bh_plan(r, tc, &plan, err);
        } else if (r->job.method == DTX_METHOD_SPRINGS) {
            st = springs_plan(r, tc, anchor, pin_idx, pin_pos, &plan, err);
        } else {
            st = dtx_sp04_plan_create(&r->src, &tc->mesh, tc->corr.pairs, tc->corr.npairs, anchor,
                                      pin_idx, pin_pos, tj->npins, &plan.sp04, err);
        }
        if (st != DTX_OK)
            dtx_error_prefix(err, "target \"%s\" (%s:%s)", tj->name, tj->file, tj->mesh);
        free(pin_idx);
        free(pin_pos);
        r->tm.factor += wtime() - t0;
        if ((st = agree(r->comm, st, err)) != DTX_OK)
            goto done;
        for (int s = 0; s < r->ns && st == DTX_OK; s++)
            if (!RESULT(r, t, s)->finished)
                st = transfer_result(r, t, s, &plan, &fb, err);
        dtx_sp04_plan_free(&plan.sp04);
        dtx_mc_plan_free(&plan.mc);
        dtx_bh_plan_free(&plan.bh);
        dtx_springs_plan_free(&plan.springs);
        if (st != DTX_OK)
            goto done;
    }
done:
    free(fb.Xs);
    free(fb.Xt);
    free(fb.res);
    free(fb.sinfo);
    free(fb.minfo);
    free(fb.fstats);
    return st;
}

/* ------------------------------------------------------------------ */
/* 7. Finish                                                           */
/* ------------------------------------------------------------------ */

/* Closes every open result handle (not collective). */
static void close_results(run_state *r)
{
    for (int t = 0; r->rs && t < r->nt; t++)
        for (int s = 0; s < r->ns; s++)
            if (RESULT(r, t, s)->open) {
                dtx_h5_result_close(&RESULT(r, t, s)->res);
                RESULT(r, t, s)->open = 0;
            }
}

static dtx_status finish_output(run_state *r, dtx_error *err)
{
    dtx_status st = DTX_OK;
    double t0 = wtime();
    if (agree(r->comm, injected_fault(r, "finish", err), err) != DTX_OK)
        return err->code;
    {
        /* All results at once: one flush (an fsync under MPI-IO) per run,
         * not three per result. */
        dtx_h5_result **open = dtx_alloc((size_t)r->nt * (size_t)r->ns, sizeof *open, 0);
        int n = 0;
        st = open ? DTX_OK : dtx_seterr(err, DTX_ENOMEM, "out of memory");
        for (int t = 0; open && t < r->nt; t++)
            for (int s = 0; s < r->ns; s++)
                if (RESULT(r, t, s)->open)
                    open[n++] = &RESULT(r, t, s)->res;
        if ((st = agree(r->comm, st, err)) == DTX_OK)
            st = dtx_h5_results_finish(open, n, 1, err);
        free(open);
        if (agree(r->comm, st, err) != DTX_OK)
            return err->code;
    }
    close_results(r);
    if (agree(r->comm, dtx_h5_close(&r->out, err), err) != DTX_OK)
        return err->code;
    if (r->rank == 0 && rename(r->partial, r->job.output_file) != 0)
        st = dtx_seterr(err, DTX_EIO, "%s: cannot rename the finished output into place: %s",
                        r->job.output_file, strerror(errno));
    r->tm.write += wtime() - t0;
    return agree(r->comm, st, err);
}

/* ------------------------------------------------------------------ */
/* 8. Summary                                                          */
/* ------------------------------------------------------------------ */

static void json_str(FILE *f, const char *s)
{
    fputc('"', f);
    for (; s && *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\')
            fprintf(f, "\\%c", c);
        else if (c < 0x20)
            fprintf(f, "\\u%04x", c);
        else
            fputc(c, f);
    }
    fputc('"', f);
}

static double mean_of(const run_stats *s) { return s->frames ? s->sum / (double)s->frames : 0; }

static void json_stats(FILE *f, const run_stats *s)
{
    double m = mean_of(s), var = s->frames ? s->sumsq / (double)s->frames - m * m : 0;
    fprintf(f, "{\"mean\": %.9g, \"std\": %.9g, \"min\": %.9g, \"max\": %.9g}", m,
            var > 0 ? sqrt(var) : 0.0, s->frames ? s->min : 0.0, s->frames ? s->max : 0.0);
}

/* Peak resident memory of this process, MiB. */
static double peak_rss_mb(void)
{
    struct rusage ru;
    if (getrusage(RUSAGE_SELF, &ru) != 0)
        return 0;
    return (double)ru.ru_maxrss / 1024.0; /* Linux: kilobytes */
}

static void write_summary(run_state *r, const char *path, const run_stats *all,
                          const double *rss)
{
    static const char *const mode_name[] = {"fresh", "resumed", "already complete"};
    char tmp[4300];
    double rss_max = 0;
    FILE *f;
    snprintf(tmp, sizeof tmp, "%.4200s.tmp", path);
    f = fopen(tmp, "w");
    if (!f) {
        say(r, "dtx: warning: cannot write the run summary %s: %s", tmp, strerror(errno));
        return;
    }
    for (int q = 0; q < r->nranks; q++)
        rss_max = rss[q] > rss_max ? rss[q] : rss_max;
    fprintf(f, "{\n  \"dtx_version\": \"%s\",\n  \"job\": ", DTX_VERSION);
    json_str(f, r->job.job_path);
    fprintf(f, ",\n  \"output\": ");
    json_str(f, r->job.output_file);
    fprintf(f,
            ",\n  \"mode\": \"%s\",\n  \"ranks\": %d,\n  \"threads_per_rank\": %d,\n"
            "  \"frames\": %lld,\n  \"frames_skipped\": %lld,\n"
            "  \"seconds\": {\"read\": %.6f, \"keypoints\": %.6f, \"correspondence\": %.6f, "
            "\"factor\": %.6f, \"transfer\": %.6f, \"write\": %.6f, \"total\": %.6f},\n"
            "  \"frames_per_second\": %.3f,\n  \"residual\": ",
            mode_name[r->mode], r->nranks, r->nthreads, (long long)all->frames,
            (long long)r->frames_skipped, r->tm.read, r->tm.keypoints, r->tm.correspond,
            r->tm.factor,
            r->tm.transfer, r->tm.write, r->tm.total,
            r->tm.total > 0 ? (double)all->frames / r->tm.total : 0.0);
    json_stats(f, all);
    fprintf(f, ",\n  \"peak_rss_mb\": %.1f,\n  \"peak_rss_mb_per_rank\": [", rss_max);
    for (int q = 0; q < r->nranks; q++)
        fprintf(f, "%s%.1f", q ? ", " : "", rss[q]);
    fprintf(f, "],\n  \"correspondences\": {");
    for (int t = 0; t < r->nt; t++) {
        fprintf(f, "%s", t ? ", " : "");
        json_str(f, r->tg[t].tj->name);
        fprintf(f, ": \"%s\"",
                r->mode == OUT_DONE || r->tg[t].same_conn ||
                        (r->job.method == DTX_METHOD_BIHARMONIC &&
                         r->job.bh.keypoints == DTX_BH_KEYS_MARKERS)
                    ? "not needed"
                    : (r->tg[t].reused ? "reused" : "computed"));
    }
    fprintf(f, "},\n  \"results\": [");
    for (int t = 0; t < r->nt; t++)
        for (int s = 0; s < r->ns; s++) {
            const result_ctx *rc = RESULT(r, t, s);
            fprintf(f, "%s\n    {\"target\": ", t + s ? "," : "");
            json_str(f, r->tg[t].tj->name);
            fprintf(f, ", \"sequence\": ");
            json_str(f, r->sq[s].path);
            fprintf(f, ", \"frames\": %lld, \"residual\": ", (long long)rc->st.frames);
            json_stats(f, &rc->st);
            if (r->job.method == DTX_METHOD_MULTICOMPONENT && rc->sv.frames > 0)
                fprintf(f,
                        ", \"multicomponent\": {\"gauss_newton_iterations_mean\": %.4g, "
                        "\"gauss_newton_iterations_max\": %lld, \"unconverged_frames\": %lld}",
                        (double)rc->sv.iterations / (double)rc->sv.frames,
                        (long long)rc->sv.max_iterations, (long long)rc->sv.unconverged);
            if (r->job.method == DTX_METHOD_SPRINGS && rc->sv.frames > 0)
                fprintf(f,
                        ", \"springs\": {\"newton_iterations_mean\": %.4g, "
                        "\"newton_iterations_max\": %lld, \"unconverged_frames\": %lld, "
                        "\"frames_with_inverted_triangles\": %lld, \"inverted_triangles_max\": "
                        "%lld}",
                        (double)rc->sv.iterations / (double)rc->sv.frames,
                        (long long)rc->sv.max_iterations, (long long)rc->sv.unconverged,
                        (long long)rc->sv.inverted_frames, (long long)rc->sv.max_inverted);
            fputc('}', f);
        }
    fprintf(f, "\n  ]\n}\n");
    if (fclose(f) != 0 || rename(tmp, path) != 0) {
        say(r, "dtx: warning: cannot write the run summary %s", path);
        remove(tmp);
    }
}

static void summarise(run_state *r)
{
    run_stats all;
    double mine = peak_rss_mb(), *rss = NULL;
    char kp_time[64] = "";
    stats_init(&all);
    stats_reduce(r->comm, &r->stats, &all);
    if (r->rank == 0)
        rss = calloc((size_t)r->nranks, sizeof *rss);
    MPI_Gather(&mine, 1, MPI_DOUBLE, rss, 1, MPI_DOUBLE, 0, r->comm);
    if (r->rank != 0 || !rss) {
        free(rss);
        return;
    }
    /* A run that found nothing to do keeps the summary of the run that did
     * the work, unless a summary file was asked for. */
    if (r->mode != OUT_DONE || r->opts->summary_path) {
        char sp[4200];
        if (r->opts->summary_path)
            snprintf(sp, sizeof sp, "%s", r->opts->summary_path);
        else
            snprintf(sp, sizeof sp, "%s.summary.json", r->job.output_file);
        write_summary(r, sp, &all, rss);
    }
    if (r->tm.keypoints > 0)
        snprintf(kp_time, sizeof kp_time, "key points %.3f s, ", r->tm.keypoints);
    if (r->mode == OUT_DONE)
        say(r, "dtx: %s is already complete for this job: nothing to do", r->job.output_file);
    else
        say(r,
            "dtx: %lld frames in %.3f s (%.1f frames/s) on %d rank(s) x %d thread(s)%s; "
            "read %.3f s, %scorrespondence %.3f s, factor %.3f s, transfer %.3f s, write %.3f "
            "s; mean residual %.4g\ndtx: result: %s",
            (long long)all.frames, r->tm.total,
            r->tm.total > 0 ? (double)all.frames / r->tm.total : 0.0, r->nranks, r->nthreads,
            r->frames_skipped ? " (frames done before were kept)" : "", r->tm.read, kp_time,
            r->tm.correspond, r->tm.factor, r->tm.transfer, r->tm.write, mean_of(&all),
            r->job.output_file);
    free(rss);
}

/* ------------------------------------------------------------------ */
/* The job                                                             */
/* ------------------------------------------------------------------ */

static void release(run_state *r)
{
    close_results(r);
    if (r->out >= 0)
        dtx_h5_close(&r->out, NULL);
    for (int s = 0; r->sq && s < r->ns; s++)
        if (r->sq[s].open)
            dtx_h5_seq_close(&r->sq[s].seq);
    for (int t = 0; r->tg && t < r->nt; t++) {
        dtx_markers_free(&r->tg[t].keys);
        dtx_corr_free(&r->tg[t].corr);
        dtx_markers_free(&r->tg[t].mk);
        dtx_mesh_free(&r->tg[t].mesh);
        dtx_weld_ctx_free(&r->tg[t].weld);
    }
    if (r->src_file >= 0)
        dtx_h5_close(&r->src_file, NULL);
    dtx_mesh_free(&r->src);
    dtx_weld_ctx_free(&r->src_weld);
    free(r->Xtrain);
    dtx_kp_result_free(&r->kp);
    free(r->tg);
    free(r->sq);
    free(r->rs);
    for (int s = 0; r->seq_paths && s < r->ns; s++)
        free(r->seq_paths[s]);
    free(r->seq_paths);
    dtx_job_free(&r->job);
}

dtx_status dtx_run_job(const char *job_path, MPI_Comm comm, const dtx_run_opts *opts,
                       dtx_error *err)
{
    run_state r;
    dtx_status st;
    double t_start = wtime();
    int out_started = 0;

    memset(&r, 0, sizeof r);
    r.comm = comm;
    r.opts = opts;
    r.src_file = r.out = H5I_INVALID_HID;
    r.nthreads = 1;
    MPI_Comm_rank(comm, &r.rank);
    MPI_Comm_size(comm, &r.nranks);
#ifdef _OPENMP
    r.nthreads = omp_get_max_threads();
#endif
    if (openblas_set_num_threads)
        openblas_set_num_threads(1);
    dtx_h5_init();
    stats_init(&r.stats);
    err->code = DTX_OK;
    err->msg[0] = '\0';

    if ((st = load_job(comm, job_path, &r.job, err)) != DTX_OK)
        return st;
    snprintf(r.partial, sizeof r.partial, "%s.partial", r.job.output_file);
    r.align = r.job.method == DTX_METHOD_SPRINGS ? 1 : DTX_FRAME_ALIGN;
    if ((st = take_output(&r, err)) != DTX_OK)
        goto fail;
    if ((st = read_inputs(&r, err)) != DTX_OK)
        goto fail;
    {
        int mode = r.rank == 0 ? (int)decide_mode(&r) : 0;
        MPI_Bcast(&mode, 1, MPI_INT, 0, comm);
        r.mode = (out_mode)mode;
    }
    if (r.mode != OUT_DONE) {
        if ((st = select_keypoints(&r, err)) != DTX_OK ||
            (st = correspondences(&r, err)) != DTX_OK || (st = target_keys(&r, err)) != DTX_OK)
            goto fail;
        out_started = 1;
        st = r.mode == OUT_RESUME ? reopen_output(&r, err) : create_output(&r, err);
        if (st != DTX_OK && r.mode == OUT_RESUME) {
            /* A partial killed while it was being set up can carry the key
             * and still miss objects: start over rather than fail. */
            say(&r, "dtx: cannot continue %s (%s): starting over", r.partial, err->msg);
            close_results(&r);
            memset(r.rs, 0, (size_t)r.nt * (size_t)r.ns * sizeof *r.rs);
            if (r.out >= 0)
                dtx_h5_close(&r.out, NULL);
            r.mode = OUT_FRESH;
            err->code = DTX_OK;
            err->msg[0] = '\0';
            st = create_output(&r, err);
        }
        if (st == DTX_OK)
            st = count_todo(&r, err);
        if (st != DTX_OK)
            goto fail;
        if (r.rank == 0 && !opts->quiet) {
            if (r.frames_skipped)
                say(&r, "dtx: resuming %s: %lld frames already done, %lld to do", r.partial,
                    (long long)r.frames_skipped, (long long)r.frames_todo);
            dtx_progress_start(&r.prog, stderr, -1, 10.0, r.frames_todo, wtime());
        }
        if ((st = transfer_all(&r, err)) != DTX_OK)
            goto fail;
        for (int t = 0; t < r.nt; t++)
            for (int s = 0; s < r.ns; s++)
                stats_merge(&r.stats, &RESULT(&r, t, s)->st);
        if ((st = finish_output(&r, err)) != DTX_OK)
            goto fail;
        if (r.rank == 0)
            dtx_progress_finish(&r.prog, wtime());
        memset(&r.prog, 0, sizeof r.prog);
    }
    r.tm.total = wtime() - t_start;
    /* Per-result statistics of all ranks, on rank 0. */
    for (int t = 0; t < r.nt; t++)
        for (int s = 0; s < r.ns; s++) {
            run_stats all;
            stats_init(&all);
            stats_reduce(comm, &RESULT(&r, t, s)->st, &all);
            if (r.rank == 0)
                RESULT(&r, t, s)->st = all;
            if (iterative_method(&r.job)) {
                solve_stats sv;
                solves_reduce(comm, &RESULT(&r, t, s)->sv, &sv);
                if (r.rank == 0)
                    RESULT(&r, t, s)->sv = sv;
                say_solves(&r, t, s);
            }
        }
    summarise(&r);
    if (r.rank == 0)
        dtx_output_lock_release(&r.lock);
    release(&r);
    return DTX_OK;

fail:
    if (r.rank == 0 && r.prog.out)
        dtx_progress_message(&r.prog, "");
    memset(&r.prog, 0, sizeof r.prog);
    close_results(&r);
    if (r.out >= 0)
        dtx_h5_close(&r.out, NULL);
    if (out_started && r.rank == 0)
        partial_fate(&r, job_path, err);
    if (r.rank == 0)
        dtx_output_lock_release(&r.lock);
    release(&r);
    return st != DTX_OK ? st : err->code;
}
