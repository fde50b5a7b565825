/*
 * run.c: `dtx run`, the batch run of a job across MPI ranks.
 *
 * Phases, in order: load the job (rank 0, then broadcast) -> read and check
 * the inputs (every rank, read-only) -> per target: correspondence (rank 0,
 * or the output's cache; broadcast) -> factor (every rank) -> per sequence:
 * frame loop (each rank its own frames, in blocks: read, transfer, write
 * collectively) -> finish (mark complete, rename the temporary output over
 * the real one) -> summary.
 *
 * Failure handling: after every phase the ranks agree on the outcome
 * (agree()), so a failure on one rank ends the job on every rank with that
 * rank's message, and no rank is left waiting in a collective call.
 */
#include "driver.h"

#include "dtx_core.h"
#include "h5layout.h"
#include "job.h"
#include "meshfile.h"

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#ifdef _OPENMP
#include <omp.h>
#endif

/* OpenBLAS's own call, when that is the BLAS we run on: BLAS stays
 * single-threaded because threads come from OpenMP and ranks. */
extern void openblas_set_num_threads(int n) __attribute__((weak));

typedef struct {
    double read, correspond, factor, transfer, write, total;
} phase_times;

typedef struct {
    int64_t frames;
    double res_sum, res_max;
} run_stats;

/* ------------------------------------------------------------------ */
/* Collective agreement on failures                                    */
/* ------------------------------------------------------------------ */

static dtx_status agree(MPI_Comm comm, dtx_status st, dtx_error *err)
{
    int rank, mine, first;
    struct {
        int code;
        char msg[sizeof err->msg];
    } buf;
    MPI_Comm_rank(comm, &rank);
    mine = st != DTX_OK ? rank : INT_MAX;
    MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, comm);
    if (first == INT_MAX)
        return DTX_OK;
    memset(&buf, 0, sizeof buf);
    if (rank == first) {
        buf.code = (int)err->code;
        memcpy(buf.msg, err->msg, sizeof buf.msg);
    }
    MPI_Bcast(&buf, (int)sizeof buf, MPI_BYTE, first, comm);
    err->code = (dtx_status)buf.code;
    memcpy(err->msg, buf.msg, sizeof err->msg);
    err->msg[sizeof err->msg - 1] = '\0';
    if (rank != first && first != 0)
        dtx_error_prefix(err, "rank %d", first);
    return err->code != DTX_OK ? err->code : DTX_EMPI;
}

static double wtime(void) { return MPI_Wtime(); }

/* mkdir -p of the directory part of path (dir_only == 0) or of path. */
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

static const char *base_name(const char *path)
{
    const char *s = strrchr(path, '/');
    return s ? s + 1 : path;
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

static dtx_status read_markers(const dtx_job_target *t, const char *what, dtx_markers *mk,
                               dtx_error *err)
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
    return dtx_seterr(err, DTX_EJOB, "%s: no markers given", what);
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

/* Rank 0: the correspondence of one target, from the old output's cache
 * when its key matches, else computed. */
static dtx_status rank0_correspondence(const dtx_job *job, const dtx_mesh *src,
                                       const dtx_mesh *tgt, const dtx_markers *mk,
                                       const char *key, dtx_corr *corr, int *cached,
                                       dtx_error *err)
{
    dtx_corr_params prm;
    *cached = 0;
    if (access(job->output_file, R_OK) == 0) {
        hid_t f = H5I_INVALID_HID;
        dtx_error e2;
        if (dtx_h5_open(job->output_file, MPI_COMM_NULL, 0, &f, &e2) == DTX_OK) {
            char *group = NULL;
            if (dtx_h5_find_corr_by_key(f, key, &group, &e2) == DTX_OK && group) {
                dtx_h5_corr c;
                if (dtx_h5_read_corr(f, group, src->nv, src->nf, tgt->nf, &c, &e2) == DTX_OK) {
                    memset(corr, 0, sizeof *corr);
                    corr->npairs = c.npairs;
                    corr->pairs = c.pairs;
                    corr->deformed_src = c.deformed_src;
                    corr->nv_src = c.nv_s;
                    c.pairs = NULL;
                    c.deformed_src = NULL;
                    dtx_h5_corr_free(&c);
                    *cached = 1;
                }
            }
            free(group);
            dtx_h5_close(&f, NULL);
        }
        if (*cached)
            return DTX_OK;
    }
    corr_params_from_job(job, &prm);
    return dtx_sp04_correspond(src, tgt, mk, &prm, corr, err);
}

/* Broadcast of a correspondence from rank 0 (other ranks allocate). */
static dtx_status bcast_corr(MPI_Comm comm, dtx_corr *c, int32_t nv_s, dtx_error *err)
{
    int rank;
    long long np = c->npairs;
    int ok = 1;
    MPI_Comm_rank(comm, &rank);
    MPI_Bcast(&np, 1, MPI_LONG_LONG, 0, comm);
    if (rank != 0) {
        memset(c, 0, sizeof *c);
        c->npairs = np;
        c->nv_src = nv_s;
        c->pairs = dtx_alloc((size_t)np, 2 * sizeof *c->pairs, 0);
        c->deformed_src = dtx_alloc((size_t)nv_s, 3 * sizeof *c->deformed_src, 0);
        ok = c->pairs && c->deformed_src;
    }
    if (agree(comm, ok ? DTX_OK : dtx_seterr(err, DTX_ENOMEM, "out of memory"), err) != DTX_OK)
        return err->code;
    /* Chunks below 2^31 elements for MPI's int counts. */
    for (long long off = 0; off < 2 * np; off += 1 << 30) {
        long long n = 2 * np - off < (1 << 30) ? 2 * np - off : (1 << 30);
        MPI_Bcast(c->pairs + off, (int)n, MPI_INT32_T, 0, comm);
    }
    MPI_Bcast(c->deformed_src, 3 * nv_s, MPI_DOUBLE, 0, comm);
    return DTX_OK;
}

/* ------------------------------------------------------------------ */
/* One sequence onto one target                                        */
/* ------------------------------------------------------------------ */

static dtx_status transfer_sequence(MPI_Comm comm, const dtx_job *job, hid_t src_file,
                                    const char *seq_path, const dtx_mesh *src,
                                    const dtx_job_target *tgtj, const dtx_mesh *tgt,
                                    dtx_sp04_plan *plan, hid_t out, const char *corr_path,
                                    phase_times *tm, run_stats *stats, dtx_error *err)
{
    int rank, nranks;
    dtx_status st = DTX_OK;
    dtx_h5_seq seq;
    dtx_h5_result res;
    char res_path[DTX_H5_PATH_MAX], tgt_path[DTX_H5_PATH_MAX], src_desc[4096], *params = NULL;
    char objdir[4096];
    int64_t first = 0, count = 0, maxcount = 0;
    int32_t block = job->block_frames;
    double *Xs = NULL, *Xt = NULL, *resid = NULL;
    int have_res = 0;

    MPI_Comm_rank(comm, &rank);
    MPI_Comm_size(comm, &nranks);
    memset(&seq, 0, sizeof seq);
    memset(&res, 0, sizeof res);
    /* One group per target holding one result per sequence. */
    snprintf(res_path, sizeof res_path, "/results/%s/%s", tgtj->name, base_name(seq_path));
    snprintf(tgt_path, sizeof tgt_path, "/meshes/%s", tgtj->name);
    snprintf(src_desc, sizeof src_desc, "%s:%s", job->source_file, seq_path);
    objdir[0] = '\0';

    st = dtx_h5_seq_open(src_file, seq_path, &seq, err);
    if (st == DTX_OK && seq.nv != src->nv)
        st = dtx_seterr(err, DTX_EFORMAT,
                        "%s: %s has %d vertices per frame but the source mesh %s has %d",
                        job->source_file, seq_path, (int)seq.nv, job->source_mesh, (int)src->nv);
    if (agree(comm, st, err) != DTX_OK)
        goto done;

    /* Blocks are whole solve groups, so frame arithmetic never depends on
     * how frames are split over ranks. */
    if (block % DTX_FRAME_ALIGN)
        block += DTX_FRAME_ALIGN - block % DTX_FRAME_ALIGN;
    dtx_partition_frames(seq.nframes, DTX_FRAME_ALIGN, nranks, rank, &first, &count);
    for (int r = 0; r < nranks; r++) {
        int64_t f0, c0;
        dtx_partition_frames(seq.nframes, DTX_FRAME_ALIGN, nranks, r, &f0, &c0);
        maxcount = c0 > maxcount ? c0 : maxcount;
    }

    if (job->export_obj_dir) {
        snprintf(objdir, sizeof objdir, "%s/%s/%s", job->export_obj_dir, tgtj->name,
                 base_name(seq_path));
        st = rank == 0 ? make_dirs(objdir, 0, err) : DTX_OK;
        if (agree(comm, st, err) != DTX_OK)
            goto done;
    }

    params = dtx_job_params_json(job);
    {
        dtx_h5_provenance prov;
        prov.method = "sp04";
        prov.job = job->text;
        prov.parameters = params ? params : "{}";
        prov.source_sequence = src_desc;
        prov.target_mesh = tgt_path;
        prov.correspondence = corr_path;
        st = dtx_h5_result_create(out, res_path, &prov, seq.nframes, tgt->nv,
                                  job->output_dtype == DTX_DTYPE_FLOAT64, DTX_FRAME_ALIGN, 0,
                                  &res, err);
    }
    if (agree(comm, st, err) != DTX_OK)
        goto done;
    have_res = 1;

    Xs = dtx_alloc((size_t)block * src->nv, 3 * sizeof *Xs, 0);
    Xt = dtx_alloc((size_t)block * tgt->nv, 3 * sizeof *Xt, 0);
    resid = dtx_alloc((size_t)block, sizeof *resid, 0);
    st = Xs && Xt && resid ? DTX_OK : dtx_seterr(err, DTX_ENOMEM, "out of memory for frames");
    if (agree(comm, st, err) != DTX_OK)
        goto done;

    /* Every rank makes the same number of collective write calls. */
    for (int64_t b = 0; b * block < maxcount; b++) {
        int64_t f0 = first + b * block;
        int64_t n = count - b * block;
        double t0, t1, t2;
        n = n < 0 ? 0 : (n > block ? block : n);
        t0 = wtime();
        st = n > 0 ? dtx_h5_seq_read(&seq, f0, n, Xs, err) : DTX_OK;
        t1 = wtime();
        if (st == DTX_OK && n > 0)
            st = dtx_sp04_apply(plan, n, Xs, Xt, resid, err);
        t2 = wtime();
        for (int64_t i = 0; st == DTX_OK && i < n; i++) {
            if (!isfinite(resid[i])) {
                st = dtx_seterr(err, DTX_ENONFINITE,
                                "%s frame %lld: the transfer produced non-finite values",
                                src_desc, (long long)(f0 + i));
                break;
            }
            stats->frames++;
            stats->res_sum += resid[i];
            stats->res_max = resid[i] > stats->res_max ? resid[i] : stats->res_max;
        }
        if (agree(comm, st, err) != DTX_OK)
            goto done;
        st = dtx_h5_result_write(&res, n > 0 ? f0 : 0, n, Xt, resid, 1, err);
        for (int64_t i = 0; st == DTX_OK && objdir[0] && i < n; i++) {
            char path[4200];
            snprintf(path, sizeof path, "%s/%s-%05lld.obj", objdir, tgtj->name,
                     (long long)(f0 + i + 1));
            st = dtx_obj_write(path, Xt + (size_t)i * 3 * tgt->nv, tgt->nv, tgt->F, tgt->nf,
                               "deformation transfer result (dtx)", err);
        }
        tm->read += t1 - t0;
        tm->transfer += t2 - t1;
        tm->write += wtime() - t2;
        if (agree(comm, st, err) != DTX_OK)
            goto done;
    }
    st = dtx_h5_result_finish(&res, 1, err);
    st = agree(comm, st, err);

done:
    if (have_res)
        dtx_h5_result_close(&res);
    dtx_h5_seq_close(&seq);
    free(params);
    free(Xs);
    free(Xt);
    free(resid);
    return st;
}

/* ------------------------------------------------------------------ */
/* The job                                                             */
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
        if (st == DTX_OK && job->method != DTX_METHOD_SP04)
            st = dtx_seterr(err, DTX_EJOB, "%s: /method: this build of dtx runs method sp04 only",
                            path);
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

static dtx_anchor anchor_of(dtx_translation t)
{
    return t == DTX_TRANSLATION_FOLLOW ? DTX_ANCHOR_FOLLOW
                                       : (t == DTX_TRANSLATION_PINS ? DTX_ANCHOR_PINS
                                                                    : DTX_ANCHOR_FIXED);
}

static void write_summary(const char *path, const dtx_job *job, int nranks, int nthreads,
                          const phase_times *tm, const run_stats *st)
{
    char tmp[4300];
    FILE *f;
    snprintf(tmp, sizeof tmp, "%.4200s.tmp", path);
    f = fopen(tmp, "w");
    if (!f)
        return;
    fprintf(f,
            "{\n  \"dtx_version\": \"%s\",\n  \"job\": \"%s\",\n  \"output\": \"%s\",\n"
            "  \"ranks\": %d,\n  \"threads_per_rank\": %d,\n  \"frames\": %lld,\n"
            "  \"seconds\": {\"read\": %.6f, \"correspondence\": %.6f, \"factor\": %.6f, "
            "\"transfer\": %.6f, \"write\": %.6f, \"total\": %.6f},\n"
            "  \"frames_per_second\": %.3f,\n"
            "  \"residual\": {\"mean\": %.9g, \"max\": %.9g}\n}\n",
            DTX_VERSION, job->job_path ? job->job_path : "", job->output_file, nranks, nthreads,
            (long long)st->frames, tm->read, tm->correspond, tm->factor, tm->transfer, tm->write,
            tm->total, tm->total > 0 ? st->frames / tm->total : 0.0,
            st->frames ? st->res_sum / st->frames : 0.0, st->res_max);
    if (fclose(f) == 0)
        rename(tmp, path);
    else
        remove(tmp);
}

dtx_status dtx_run_job(const char *job_path, MPI_Comm comm, const dtx_run_opts *opts,
                       dtx_error *err)
{
    int rank, nranks, nthreads = 1;
    dtx_status st;
    dtx_job job;
    dtx_mesh src;
    hid_t src_file = H5I_INVALID_HID, out = H5I_INVALID_HID;
    char tmp_out[4200];
    phase_times tm;
    run_stats stats, total;
    double t_start = wtime(), t0;

    MPI_Comm_rank(comm, &rank);
    MPI_Comm_size(comm, &nranks);
#ifdef _OPENMP
    nthreads = omp_get_max_threads();
#endif
    if (openblas_set_num_threads)
        openblas_set_num_threads(1);
    dtx_h5_init();
    memset(&tm, 0, sizeof tm);
    memset(&stats, 0, sizeof stats);
    memset(&src, 0, sizeof src);
    tmp_out[0] = '\0';
    err->code = DTX_OK;
    err->msg[0] = '\0';

    st = load_job(comm, job_path, &job, err);
    if (st != DTX_OK)
        return st;

    /* Inputs: every rank reads them (read-only, independent). */
    t0 = wtime();
    st = dtx_h5_open(job.source_file, MPI_COMM_NULL, 0, &src_file, err);
    if (st == DTX_OK)
        st = dtx_h5_read_mesh(src_file, job.source_mesh, &src, err);
    if (agree(comm, st, err) != DTX_OK)
        goto fail;
    tm.read += wtime() - t0;

    /* The output goes to a temporary file renamed at the end. */
    if (rank == 0) {
        snprintf(tmp_out, sizeof tmp_out, "%s.tmp-%ld", job.output_file, (long)getpid());
        st = make_dirs(job.output_file, 1, err);
    }
    MPI_Bcast(tmp_out, (int)sizeof tmp_out, MPI_CHAR, 0, comm);
    if (agree(comm, st, err) != DTX_OK)
        goto fail;
    st = dtx_h5_create(tmp_out, comm, &out, err);
    if (agree(comm, st, err) != DTX_OK)
        goto fail;

    for (int32_t ti = 0; ti < job.ntargets; ti++) {
        const dtx_job_target *tj = &job.targets[ti];
        dtx_mesh tgt;
        dtx_markers mk;
        dtx_corr corr;
        dtx_sp04_plan *plan = NULL;
        char key[17] = "", *params = NULL, corr_path[DTX_H5_PATH_MAX], mesh_path[DTX_H5_PATH_MAX];
        int cached = 0;
        double *pin_pos = NULL;
        int32_t *pin_idx = NULL;
        memset(&tgt, 0, sizeof tgt);
        memset(&mk, 0, sizeof mk);
        memset(&corr, 0, sizeof corr);

        t0 = wtime();
        st = read_mesh_from(tj->file, tj->mesh, &tgt, err);
        if (st == DTX_OK)
            st = read_markers(tj, tj->name, &mk, err);
        if (st == DTX_OK) {
            char what[600];
            snprintf(what, sizeof what, "markers of target \"%s\"", tj->name);
            st = dtx_markers_validate(&mk, src.nv, tgt.nv, what, err);
        }
        tm.read += wtime() - t0;
        if (agree(comm, st, err) != DTX_OK)
            goto target_fail;

        /* Correspondence: rank 0 computes or finds it, then broadcasts. */
        t0 = wtime();
        if (rank == 0) {
            params = dtx_job_params_json(&job);
            corr_key(&src, &tgt, &mk, params ? params : "", key);
            st = rank0_correspondence(&job, &src, &tgt, &mk, key, &corr, &cached, err);
            if (st == DTX_OK && !opts->quiet)
                fprintf(stderr,
                        "dtx: target %s: correspondence %s: %lld triangle pairs (%.2f s)\n",
                        tj->name, cached ? "reused from the output's cache" : "computed",
                        (long long)corr.npairs, wtime() - t0);
        }
        if (agree(comm, st, err) != DTX_OK)
            goto target_fail;
        MPI_Bcast(key, (int)sizeof key, MPI_CHAR, 0, comm);
        st = bcast_corr(comm, &corr, src.nv, err);
        if (st != DTX_OK)
            goto target_fail;
        tm.correspond += wtime() - t0;

        /* Factor (every rank: each needs the factor for its solves). */
        t0 = wtime();
        if (tj->npins > 0) {
            pin_idx = dtx_alloc((size_t)tj->npins, sizeof *pin_idx, 0);
            pin_pos = dtx_alloc((size_t)tj->npins, 3 * sizeof *pin_pos, 0);
            if (pin_idx && pin_pos)
                for (int32_t i = 0; i < tj->npins; i++) {
                    pin_idx[i] = tj->pins[i].vertex;
                    memcpy(pin_pos + 3 * i, tj->pins[i].pos, 3 * sizeof *pin_pos);
                }
        }
        st = dtx_sp04_plan_create(&src, &tgt, corr.pairs, corr.npairs, anchor_of(tj->translation),
                                  pin_idx, pin_pos, tj->npins, &plan, err);
        if (st != DTX_OK)
            dtx_error_prefix(err, "target \"%s\" (%s:%s)", tj->name, tj->file, tj->mesh);
        tm.factor += wtime() - t0;
        if (agree(comm, st, err) != DTX_OK)
            goto target_fail;

        /* The target mesh and its correspondence go into the output. */
        t0 = wtime();
        snprintf(mesh_path, sizeof mesh_path, "/meshes/%s", tj->name);
        snprintf(corr_path, sizeof corr_path, "/correspondences/%s", tj->name);
        {
            char srcdesc[4200], tgtdesc[4200], mkdesc[4200];
            dtx_h5_corr_meta meta;
            snprintf(srcdesc, sizeof srcdesc, "%s:%s", job.source_file, job.source_mesh);
            snprintf(tgtdesc, sizeof tgtdesc, "%s:%s", tj->file, tj->mesh);
            if (tj->markers.csv)
                snprintf(mkdesc, sizeof mkdesc, "%s (index base %d)", tj->markers.csv,
                         tj->markers.index_base);
            else
                snprintf(mkdesc, sizeof mkdesc, "%s:%s", tj->markers.file, tj->markers.path);
            meta.key = key;
            meta.source_mesh = srcdesc;
            meta.target_mesh = tgtdesc;
            meta.markers = mkdesc;
            st = dtx_h5_write_mesh(out, mesh_path, &tgt, tgtdesc, err);
            if (agree(comm, st, err) != DTX_OK)
                goto target_fail;
            /* Attributes must be identical on every rank: share the params. */
            {
                long long plen = rank == 0 && params ? (long long)strlen(params) : 0;
                MPI_Bcast(&plen, 1, MPI_LONG_LONG, 0, comm);
                if (rank != 0) {
                    params = calloc((size_t)plen + 1, 1);
                    if (!params)
                        MPI_Abort(comm, 1);
                }
                MPI_Bcast(params, (int)plen, MPI_CHAR, 0, comm);
                meta.parameters = params;
            }
            st = dtx_h5_write_corr(out, corr_path, corr.pairs, corr.npairs, corr.deformed_src,
                                   src.nv, &meta, err);
            if (agree(comm, st, err) != DTX_OK)
                goto target_fail;
        }
        tm.write += wtime() - t0;

        for (int32_t si = 0; si < job.nsequences; si++) {
            st = transfer_sequence(comm, &job, src_file, job.sequences[si], &src, tj, &tgt, plan,
                                   out, corr_path, &tm, &stats, err);
            if (st != DTX_OK)
                goto target_fail;
            if (rank == 0 && !opts->quiet)
                fprintf(stderr, "dtx: target %s: sequence %s done\n", tj->name,
                        job.sequences[si]);
        }

    target_fail:
        dtx_sp04_plan_free(&plan);
        dtx_corr_free(&corr);
        dtx_markers_free(&mk);
        dtx_mesh_free(&tgt);
        free(params);
        free(pin_idx);
        free(pin_pos);
        if (st != DTX_OK)
            goto fail;
    }

    st = dtx_h5_close(&out, err);
    if (agree(comm, st, err) != DTX_OK)
        goto fail;
    if (rank == 0 && rename(tmp_out, job.output_file) != 0)
        st = dtx_seterr(err, DTX_EIO, "%s: cannot rename the finished output into place: %s",
                        job.output_file, strerror(errno));
    if (agree(comm, st, err) != DTX_OK)
        goto fail;
    tm.total = wtime() - t_start;

    /* Summary: frames and residuals summed over ranks, times of rank 0. */
    MPI_Reduce(&stats.frames, &total.frames, 1, MPI_INT64_T, MPI_SUM, 0, comm);
    MPI_Reduce(&stats.res_sum, &total.res_sum, 1, MPI_DOUBLE, MPI_SUM, 0, comm);
    MPI_Reduce(&stats.res_max, &total.res_max, 1, MPI_DOUBLE, MPI_MAX, 0, comm);
    if (rank == 0) {
        char sp[4200];
        if (opts->summary_path)
            snprintf(sp, sizeof sp, "%s", opts->summary_path);
        else
            snprintf(sp, sizeof sp, "%s.summary.json", job.output_file);
        write_summary(sp, &job, nranks, nthreads, &tm, &total);
        if (!opts->quiet)
            fprintf(stderr,
                    "dtx: %lld frames in %.3f s (%.1f frames/s) on %d rank(s) x %d thread(s); "
                    "read %.3f s, correspondence %.3f s, factor %.3f s, transfer %.3f s, "
                    "write %.3f s; mean residual %.4g\n"
                    "dtx: result: %s\n",
                    (long long)total.frames, tm.total, tm.total > 0 ? total.frames / tm.total : 0,
                    nranks, nthreads, tm.read, tm.correspond, tm.factor, tm.transfer, tm.write,
                    total.frames ? total.res_sum / total.frames : 0.0, job.output_file);
    }
    dtx_h5_close(&src_file, NULL);
    dtx_mesh_free(&src);
    dtx_job_free(&job);
    return DTX_OK;

fail:
    if (out >= 0)
        dtx_h5_close(&out, NULL);
    if (rank == 0 && tmp_out[0])
        remove(tmp_out);
    if (src_file >= 0)
        dtx_h5_close(&src_file, NULL);
    dtx_mesh_free(&src);
    dtx_job_free(&job);
    return st != DTX_OK ? st : err->code;
}
