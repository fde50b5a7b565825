/*
 * run_frames.c: phase 6 of `dtx run`, the frame loop: per target, the
 * transfer plan (factored once on every rank); per result, the frame
 * groups not yet done are dealt to the ranks (run_schedule.h) and each
 * rank reads, transfers and writes its groups in blocks: with collective
 * writes every rank joins each write, also ranks with no frames left; with
 * independent writes (the default) ranks agree on each block one block
 * later, and a rank with several threads overlaps its I/O with its
 * transfers (transfer_team: the I/O thread joins the transfers when its
 * I/O is done; transfer_overlapped for methods that deal their own groups).
 */
#include "run_internal.h"

#include <math.h>
#include <sched.h>
#ifdef _OPENMP
#include <omp.h>
#endif
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------ */
/* 6. Frames                                                           */
/* ------------------------------------------------------------------ */

/* The groups (of align frames) of a result with a frame not done:
 * todo[0 .. *ntodo), increasing, from the result's frame_done flags
 * (run_groups_todo).  *skipped counts the frames already done in whole
 * groups. */
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
    if (st == DTX_OK)
        run_groups_todo(done, nframes, align, *todo, ntodo, skipped);
    free(done);
    return st;
}

typedef struct {
    int32_t block;         /* frames per block, a multiple of the run's align */
    double *Xs, *Xt, *res; /* block x nv_s x 3, block x nv_t x 3, block */
    dtx_frame_info *info;  /* block entries */
    int32_t *fstats;       /* iterative methods: block x DTX_H5_FRAME_STATS */
    double *gnorm;         /* methods that report it: block final gradient norms */
} frame_buffers;

/* run_agree, its time counted as the rank's wait (phase_times.wait): in the
 * frame loop a rank reaches an agreement early when its share was smaller
 * or faster than another's. */
static dtx_status agree_timed(run_state *r, dtx_status st, dtx_error *err)
{
    double t0 = run_wtime();
    st = run_agree(r->comm, st, err);
    r->tm.wait += run_wtime() - t0;
    return st;
}

static void progress_step(run_state *r, int64_t n)
{
    int64_t sum = 0;
    MPI_Reduce(&n, &sum, 1, MPI_INT64_T, MPI_SUM, 0, r->comm);
    if (r->rank == 0) {
        r->frames_done += sum;
        dtx_progress_update(&r->prog, r->frames_done, run_wtime());
    }
}

/* A block's outcome, agreed one block late with independent writes: each
 * rank posts {failed, frames} at the end of a block and waits for the sum
 * at the end of the next, so ranks are not held in step by a barrier per
 * block (which made them write at the same moment, into one file, and wait
 * for each other's slowest block).  Every rank posts the same number of
 * sums; when one shows a failure, every rank calls run_agree at the same
 * point to hear which. */
typedef struct {
    MPI_Request req;
    int64_t sum[2]; /* ranks failed, frames written */
    int pending;
} block_agree;

/* Waits for the sum posted last (if any): progress on rank 0, and
 * run_agree(st) on every rank when some rank failed. */
static dtx_status block_agree_wait(run_state *r, block_agree *ba, dtx_status st,
                                   dtx_error *err)
{
    double t0;
    if (!ba->pending)
        return st;
    t0 = run_wtime();
    MPI_Wait(&ba->req, MPI_STATUS_IGNORE);
    r->tm.wait += run_wtime() - t0;
    ba->pending = 0;
    if (ba->sum[0] > 0)
        return run_agree(r->comm, st, err);
    if (r->rank == 0) {
        r->frames_done += ba->sum[1];
        dtx_progress_update(&r->prog, r->frames_done, run_wtime());
    }
    return st;
}

static void block_agree_post(run_state *r, block_agree *ba, dtx_status st, int64_t n)
{
    int64_t mine[2] = {st != DTX_OK, st == DTX_OK ? n : 0};
    MPI_Iallreduce(mine, ba->sum, 2, MPI_INT64_T, MPI_SUM, r->comm, &ba->req);
    ba->pending = 1;
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

/* A transferred block's residuals checked and counted, in frame order:
 * frames f0 .. f0 + n, from sources Xs, residuals res, solver figures
 * info, frame_stats filled for iterative methods and gnorm for those that
 * report the final gradient norm. */
static dtx_status check_block(run_state *r, result_ctx *rc, const target_ctx *tc, const seq_ctx *sc,
                              int64_t f0, int64_t n, const double *Xs, const double *res,
                              const dtx_frame_info *info, int32_t *fstats, double *gnorm,
                              dtx_error *err)
{
    const int with_gnorm = r->method->reports_grad_norm;
    for (int64_t i = 0; i < n; i++) {
        if (!isfinite(res[i]) || (with_gnorm && !isfinite(info[i].grad_norm))) {
            /* Name the source coordinate when one is to blame. */
            dtx_status st = check_frames_finite(r, sc, f0 + i, 1,
                                                Xs + (size_t)i * 3 * (size_t)r->src.nv, err);
            if (st == DTX_OK)
                st = dtx_seterr(err, DTX_ENONFINITE,
                                "%s:%s frame %lld: the transfer onto \"%s\" produced "
                                "non-finite values",
                                r->job.source_file, sc->path, (long long)(f0 + i),
                                tc->tj->name);
            return st;
        }
        run_stats_add(&rc->st, res[i]);
        if (r->method->iterative) /* inverted -1 where not counted */
            run_solves_add(&rc->sv, f0 + i, info[i].iterations, info[i].converged, info[i].inverted,
                           with_gnorm ? info[i].grad_norm : NAN, fstats + DTX_H5_FRAME_STATS * i);
        if (with_gnorm)
            gnorm[i] = info[i].grad_norm;
    }
    return DTX_OK;
}

static int omp_max_threads(void)
{
#ifdef _OPENMP
    return omp_get_max_threads();
#else
    return 1;
#endif
}

/* One set of frame buffers of fb->block frames. */
static dtx_status buffers_alloc(const run_state *r, int32_t maxnv, frame_buffers *fb,
                                dtx_error *err)
{
    const int with_gnorm = r->method->reports_grad_norm;
    fb->Xs = dtx_alloc((size_t)fb->block * (size_t)r->src_weld.nv, 3 * sizeof *fb->Xs, 0);
    fb->Xt = dtx_alloc((size_t)fb->block * (size_t)maxnv, 3 * sizeof *fb->Xt, 0);
    fb->res = dtx_alloc((size_t)fb->block, sizeof *fb->res, 0);
    fb->info = dtx_alloc((size_t)fb->block, sizeof *fb->info, 1);
    if (r->method->iterative)
        fb->fstats = dtx_alloc((size_t)fb->block, DTX_H5_FRAME_STATS * sizeof *fb->fstats, 1);
    if (with_gnorm)
        fb->gnorm = dtx_alloc((size_t)fb->block, sizeof *fb->gnorm, 1);
    return fb->Xs && fb->Xt && fb->res && fb->info && (!r->method->iterative || fb->fstats) &&
                   (!with_gnorm || fb->gnorm)
               ? DTX_OK
               : dtx_seterr(err, DTX_ENOMEM, "out of memory for frames");
}

/* Frames [*f0, *f0 + *n) of this rank's block k (none past its last). */
static void block_range(const run_state *r, const int64_t *todo, const int64_t *seg,
                        int64_t nseg, int64_t nframes, int64_t k, int64_t *f0, int64_t *n)
{
    *f0 = *n = 0;
    if (k < nseg) {
        *f0 = todo[seg[k]] * r->align;
        *n = (todo[seg[k + 1] - 1] + 1) * r->align - *f0;
        *n = *f0 + *n > nframes ? nframes - *f0 : *n;
    }
}

/* Block fb (n frames, read into fb->Xs) transferred into fb->Xt, fb->res
 * and fb->info.  No MPI or HDF5: any thread may run it. */
/* What follows a block's transfer: the residuals out of the frame infos,
 * and the seam twins of the results made identical, in the asset's order. */
static void block_transferred(const target_ctx *tc, frame_buffers *fb, int64_t n)
{
    for (int64_t i = 0; i < n; i++)
        fb->res[i] = fb->info[i].residual;
    dtx_weld_result_frames(&tc->weld, fb->Xt, n);
}

static dtx_status transfer_block(run_state *r, const target_ctx *tc, void *plan, int64_t n,
                                 frame_buffers *fb, dtx_error *err)
{
    dtx_status st;
    dtx_weld_source_frames(&r->src_weld, fb->Xs, n);
    st = r->method->apply(plan, n, fb->Xs, fb->Xt, fb->info, err);
    if (st == DTX_OK)
        block_transferred(tc, fb, n);
    return st;
}

/* Block fb (frames f0 .. f0 + n) written: the solver figures first, as
 * dtx_h5_result_write marks the frames done (after their positions). */
static dtx_status write_block(run_state *r, result_ctx *rc, const target_ctx *tc,
                              const seq_ctx *sc, int64_t f0, int64_t n, const frame_buffers *fb,
                              int coll, dtx_error *err)
{
    dtx_status st = DTX_OK;
    if (r->method->iterative)
        st = dtx_h5_result_write_frame_stats(&rc->res, n > 0 ? f0 : 0, n, fb->fstats, coll,
                                             err);
    if (st == DTX_OK && r->method->reports_grad_norm)
        st = dtx_h5_result_write_frame_grad_norm(&rc->res, n > 0 ? f0 : 0, n, fb->gnorm, coll, err);
    if (st == DTX_OK)
        st = dtx_h5_result_write(&rc->res, n > 0 ? f0 : 0, n, fb->Xt, fb->res, coll, err);
    if (st == DTX_OK && r->job.export_obj_dir)
        st = export_obj(r, tc, sc, f0, n, fb->Xt, err);
    return st;
}

#ifdef _OPENMP
/* With more than one thread per rank and independent writes, a rank's I/O
 * overlaps its transfers.  In step k the main thread (the one that makes
 * the MPI and HDF5 calls) writes block k - 1 and reads block k + 1 while a
 * second thread transfers block k with the method's own threads (nested),
 * each block in its own set of buffers (fb[k % 2]: block k + 1 is read
 * into Xs of the set whose Xt is being written).  Blocks, frames and their
 * arithmetic are those of the plain loop, so results are bitwise the same;
 * residuals are checked and counted in frame order on the main thread. */
static dtx_status transfer_overlapped(run_state *r, int t, int s, void *plan, frame_buffers *fb,
                                      const int64_t *todo, const int64_t *seg, int64_t nseg,
                                      int64_t nseg_max, dtx_error *err)
{
    result_ctx *rc = RESULT(r, t, s);
    const target_ctx *tc = &r->tg[t];
    const seq_ctx *sc = &r->sq[s];
    const int64_t nframes = rc->res.nframes;
    const int levels = omp_get_max_active_levels(), nthreads = omp_get_max_threads();
    block_agree ba;
    int64_t f0, n;
    double t0 = run_wtime();
    dtx_status st;
    memset(&ba, 0, sizeof ba);
    block_range(r, todo, seg, nseg, nframes, 0, &f0, &n);
    st = n > 0 ? dtx_h5_seq_read(&sc->seq, f0, n, fb[0].Xs, err) : DTX_OK;
    r->tm.read += run_wtime() - t0;
    omp_set_max_active_levels(levels > 2 ? levels : 2);
    for (int64_t k = 0; k <= nseg_max; k++) {
        frame_buffers *cur = &fb[k % 2], *other = &fb[(k + 1) % 2];
        int64_t pf0 = 0, pn = 0, nf0 = 0, nn = 0;
        dtx_status st_io = DTX_OK, st_tr = DTX_OK;
        dtx_error err_tr;
        double s_rd = 0, s_wr = 0, s_tr = 0;
        memset(&err_tr, 0, sizeof err_tr);
        if (st == DTX_OK) {
            if (k > 0)
                block_range(r, todo, seg, nseg, nframes, k - 1, &pf0, &pn);
            block_range(r, todo, seg, nseg, nframes, k, &f0, &n);
            block_range(r, todo, seg, nseg, nframes, k + 1, &nf0, &nn);
#pragma omp parallel num_threads(2)
            {
                const int tid = omp_get_thread_num(), nt = omp_get_num_threads();
                if (tid == 0) {
                    double a = run_wtime(), b;
                    if (pn > 0)
                        st_io = write_block(r, rc, tc, sc, pf0, pn, other, 0, err);
                    b = run_wtime();
                    if (st_io == DTX_OK && nn > 0)
                        st_io = dtx_h5_seq_read(&sc->seq, nf0, nn, other->Xs, err);
                    s_wr = b - a;
                    s_rd = run_wtime() - b;
                }
                if ((tid == 1 || nt == 1) && n > 0) {
                    /* No MPI off the main thread (MPI_THREAD_FUNNELED),
                     * not even MPI_Wtime. */
                    double a = omp_get_wtime();
                    /* The method's threads and the I/O thread together as
                     * many as the rank was given: more would make the
                     * method's threads wait for one another's groups. */
                    omp_set_num_threads(nt > 1 && nthreads > 2 ? nthreads - 1 : 1);
                    st_tr = transfer_block(r, tc, plan, n, cur, &err_tr);
                    s_tr = omp_get_wtime() - a;
                }
            }
            r->tm.read += s_rd;
            r->tm.write += s_wr;
            r->tm.transfer += s_tr;
            st = st_io;
            if (st == DTX_OK && st_tr != DTX_OK) {
                *err = err_tr;
                st = st_tr;
            }
            if (st == DTX_OK && n > 0)
                st = check_block(r, rc, tc, sc, f0, n, cur->Xs, cur->res, cur->info, cur->fstats,
                                 cur->gnorm, err);
            if (st == DTX_OK && k == nseg_max / 2)
                st = run_injected_fault(r, "transfer", err);
        }
        /* A rank that failed goes on through the loop doing nothing until
         * the others have heard of it, one step later. */
        if ((st = block_agree_wait(r, &ba, st, err)) != DTX_OK && ba.sum[0] > 0)
            break;
        block_agree_post(r, &ba, st, st == DTX_OK ? pn : 0);
    }
    st = block_agree_wait(r, &ba, st, err);
    omp_set_max_active_levels(levels);
    return st;
}

/* transfer_overlapped for a method whose groups the caller may deal
 * (team_apply), without a pause between blocks: one parallel region for
 * the whole result, and three sets of block buffers.  Every thread calls
 * team_apply on each of the rank's blocks in turn (taking the block's
 * groups from its own counter while any are left); the main thread (the
 * one that makes the MPI and HDF5 calls) in step b first reads block b + 1
 * (into the set that block b - 2 was written from), then joins the
 * transfer of block b, then, once every thread's call on block b - 1 has
 * returned, checks and writes block b - 1.  The other threads go on to
 * block b + 1 as soon as block b has no group left, so no thread waits for
 * the slowest group of a block, as at the end of a parallel region per
 * block; the main thread rarely waits, as block b - 1 has had a whole
 * block's time to finish.  With one thread doing the I/O and the method's
 * threads the others (transfer_overlapped), a rank with two threads
 * transferred on one of them and the I/O thread sat idle for most of each
 * block when I/O was a small share (horse -> camel).  The welding of a
 * block's source frames (after its read) and of its results (before its
 * write) is the main thread's.  Steps, agreements and fault points are
 * those of transfer_overlapped (step k writes block k - 1), blocks, groups
 * and their arithmetic those of the plain loop, so results are bitwise
 * the same whichever thread takes a group. */
static dtx_status transfer_team(run_state *r, int t, int s, void *plan, frame_buffers *fb,
                                const int64_t *todo, const int64_t *seg, int64_t nseg,
                                int64_t nseg_max, dtx_error *err)
{
    result_ctx *rc = RESULT(r, t, s);
    const target_ctx *tc = &r->tg[t];
    const seq_ctx *sc = &r->sq[s];
    const int64_t nframes = rc->res.nframes;
    const int nthreads = omp_get_max_threads();
    /* Per block: the group counter team_apply takes from, and the threads
     * whose call on it has returned. */
    int64_t *next = dtx_alloc((size_t)nseg + 1, sizeof *next, 1);
    int *finished = dtx_alloc((size_t)nseg + 1, sizeof *finished, 1);
    int64_t ready = 0; /* blocks read, published by the main thread */
    int abort_all = 0; /* the main thread stopped: the others stop too */
    block_agree ba;
    double t0 = run_wtime(), s_rd = 0, s_wr = 0, wait0 = r->tm.wait;
    dtx_status st;
    memset(&ba, 0, sizeof ba);
    st = next && finished ? r->method->team_prepare(plan, err)
                          : dtx_seterr(err, DTX_ENOMEM, "out of memory");
    if (st == DTX_OK && nseg > 0) {
        int64_t f0, n;
        block_range(r, todo, seg, nseg, nframes, 0, &f0, &n);
        st = dtx_h5_seq_read(&sc->seq, f0, n, fb[0].Xs, err);
        if (st == DTX_OK) {
            dtx_weld_source_frames(&r->src_weld, fb[0].Xs, n);
            ready = 1;
        }
    }
    r->tm.read += run_wtime() - t0;
    t0 = run_wtime();
#pragma omp parallel num_threads(nthreads)
    {
        const int nt = omp_get_num_threads();
        if (omp_get_thread_num() != 0) {
            /* The other threads: each block's groups as it becomes ready. */
            for (int64_t b = 0; b < nseg; b++) {
                int64_t f0, n, rd;
                int stop;
                for (;;) {
#pragma omp atomic read seq_cst
                    rd = ready;
#pragma omp atomic read seq_cst
                    stop = abort_all;
                    if (rd > b || stop)
                        break;
                    sched_yield();
                }
                if (stop)
                    break;
                block_range(r, todo, seg, nseg, nframes, b, &f0, &n);
                r->method->team_apply(plan, n, fb[b % 3].Xs, fb[b % 3].Xt, fb[b % 3].info,
                                      &next[b]);
#pragma omp atomic update seq_cst
                finished[b]++;
            }
        } else {
            /* The main thread: step k reads block k + 1, transfers block
             * k with the others, and writes block k - 1. */
            for (int64_t k = 0; k <= nseg_max; k++) {
                int64_t f0 = 0, n = 0, pf0 = 0, pn = 0;
                if (st == DTX_OK && k + 1 < nseg) {
                    frame_buffers *nx = &fb[(k + 1) % 3];
                    double a = omp_get_wtime();
                    block_range(r, todo, seg, nseg, nframes, k + 1, &f0, &n);
                    st = dtx_h5_seq_read(&sc->seq, f0, n, nx->Xs, err);
                    if (st == DTX_OK) {
                        dtx_weld_source_frames(&r->src_weld, nx->Xs, n);
#pragma omp atomic write seq_cst
                        ready = k + 2;
                    }
                    s_rd += omp_get_wtime() - a;
                }
                if (st == DTX_OK && k < nseg) {
                    block_range(r, todo, seg, nseg, nframes, k, &f0, &n);
                    r->method->team_apply(plan, n, fb[k % 3].Xs, fb[k % 3].Xt, fb[k % 3].info,
                                          &next[k]);
#pragma omp atomic update seq_cst
                    finished[k]++;
                }
                if (st == DTX_OK && k > 0 && k - 1 < nseg) {
                    frame_buffers *pv = &fb[(k - 1) % 3];
                    double a;
                    for (;;) {
                        int fin;
#pragma omp atomic read seq_cst
                        fin = finished[k - 1];
                        if (fin >= nt)
                            break;
                        sched_yield();
                    }
                    a = omp_get_wtime();
                    block_range(r, todo, seg, nseg, nframes, k - 1, &pf0, &pn);
                    block_transferred(tc, pv, pn);
                    st = check_block(r, rc, tc, sc, pf0, pn, pv->Xs, pv->res, pv->info, pv->fstats,
                                     pv->gnorm, err);
                    if (st == DTX_OK)
                        st = write_block(r, rc, tc, sc, pf0, pn, pv, 0, err);
                    s_wr += omp_get_wtime() - a;
                }
                if (st == DTX_OK && k == nseg_max / 2)
                    st = run_injected_fault(r, "transfer", err);
                if (st != DTX_OK) {
#pragma omp atomic write seq_cst
                    abort_all = 1;
                }
                /* A rank that failed goes on through the steps doing
                 * nothing until the others have heard of it, one step
                 * later. */
                if ((st = block_agree_wait(r, &ba, st, err)) != DTX_OK && ba.sum[0] > 0) {
#pragma omp atomic write seq_cst
                    abort_all = 1;
                    break;
                }
                block_agree_post(r, &ba, st, st == DTX_OK ? pn : 0);
            }
        }
    }
    /* Read and write: the main thread's I/O; transfer: the rest of the
     * region (every thread transferring, the main thread too when not in
     * I/O). */
    r->tm.read += s_rd;
    r->tm.write += s_wr;
    r->tm.transfer += run_wtime() - t0 - s_rd - s_wr - (r->tm.wait - wait0);
    st = block_agree_wait(r, &ba, st, err);
    free(next);
    free(finished);
    return st;
}
#else
static dtx_status transfer_overlapped(run_state *r, int t, int s, void *plan, frame_buffers *fb,
                                      const int64_t *todo, const int64_t *seg, int64_t nseg,
                                      int64_t nseg_max, dtx_error *err)
{
    (void)r, (void)t, (void)s, (void)plan, (void)fb, (void)todo, (void)seg, (void)nseg;
    (void)nseg_max;
    return dtx_seterr(err, DTX_EINVAL, "no threads to overlap I/O with");
}

static dtx_status transfer_team(run_state *r, int t, int s, void *plan, frame_buffers *fb,
                                const int64_t *todo, const int64_t *seg, int64_t nseg,
                                int64_t nseg_max, dtx_error *err)
{
    return transfer_overlapped(r, t, s, plan, fb, todo, seg, nseg, nseg_max, err);
}
#endif

/* Transfers the frames of result (t, s) not yet done, each rank its share,
 * in blocks, through plan (of r->method); with collective I/O every rank
 * makes the same number of writes (ranks without frames write nothing). */
static dtx_status transfer_result(run_state *r, int t, int s, void *plan, frame_buffers *fb,
                                  int nsets, dtx_error *err)
{
    result_ctx *rc = RESULT(r, t, s);
    const target_ctx *tc = &r->tg[t];
    const seq_ctx *sc = &r->sq[s];
    int64_t *todo = NULL, *seg = NULL, ntodo = 0, skipped = 0, a, b, nseg, nseg_max = 0;
    int64_t gpb = fb->block / r->align, nframes = rc->res.nframes;
    int rot = (int)(((int64_t)t * r->ns + s) % r->nranks);
    dtx_status st;

    run_stats_init(&rc->st);
    run_solves_init(&rc->sv);
    st = groups_todo(rc, r->align, &todo, &ntodo, &skipped, err);
    if ((st = run_agree(r->comm, st, err)) != DTX_OK)
        goto done;
    for (int q = 0; q < r->nranks; q++) {
        int64_t qa, qb, n;
        run_rank_range(ntodo, r->nranks, q, rot, &qa, &qb);
        n = run_segments(todo, qa, qb, gpb, NULL);
        nseg_max = n > nseg_max ? n : nseg_max;
    }
    run_rank_range(ntodo, r->nranks, r->rank, rot, &a, &b);
    seg = dtx_alloc((size_t)(b - a) + 1, sizeof *seg, 0);
    st = seg ? DTX_OK : dtx_seterr(err, DTX_ENOMEM, "out of memory");
    if ((st = run_agree(r->comm, st, err)) != DTX_OK)
        goto done;
    nseg = run_segments(todo, a, b, gpb, seg);
    if (r->job.export_obj_dir && ntodo > 0) {
        char dir[4096];
        snprintf(dir, sizeof dir, "%s/%s/%s", r->job.export_obj_dir, tc->tj->name, sc->name);
        st = r->rank == 0 ? run_make_dirs(dir, 0, err) : DTX_OK;
        if ((st = run_agree(r->comm, st, err)) != DTX_OK)
            goto done;
    }

    if (nsets >= 2) {
        st = r->method->team_apply
                 ? transfer_team(r, t, s, plan, fb, todo, seg, nseg, nseg_max, err)
                 : transfer_overlapped(r, t, s, plan, fb, todo, seg, nseg, nseg_max, err);
        goto done;
    }
    /* Collective writes need every rank there and none failed: a blocking
     * agreement before and after each write.  Independent writes need
     * only block_agree. */
    const int coll = r->job.collective_io;
    block_agree ba;
    memset(&ba, 0, sizeof ba);
    for (int64_t k = 0; k < nseg_max; k++) {
        int64_t f0 = 0, n = 0;
        double t0, t1, t2;
        if (st == DTX_OK)
            block_range(r, todo, seg, nseg, nframes, k, &f0, &n);
        t0 = run_wtime();
        st = st == DTX_OK && n > 0 ? dtx_h5_seq_read(&sc->seq, f0, n, fb->Xs, err) : st;
        t1 = run_wtime();
        if (st == DTX_OK && n > 0)
            st = transfer_block(r, tc, plan, n, fb, err);
        if (st == DTX_OK && k == nseg_max / 2)
            st = run_injected_fault(r, "transfer", err);
        t2 = run_wtime();
        if (st == DTX_OK)
            st = check_block(r, rc, tc, sc, f0, n, fb->Xs, fb->res, fb->info, fb->fstats, fb->gnorm,
                             err);
        if (coll && (st = agree_timed(r, st, err)) != DTX_OK)
            goto done;
        if (st == DTX_OK)
            st = write_block(r, rc, tc, sc, f0, n, fb, coll, err);
        r->tm.read += t1 - t0;
        r->tm.transfer += t2 - t1;
        r->tm.write += run_wtime() - t2;
        if (coll) {
            if ((st = agree_timed(r, st, err)) != DTX_OK)
                goto done;
            progress_step(r, n);
        } else {
            /* A rank that failed goes on through the loop doing nothing
             * until the others have heard of it, one block later. */
            if ((st = block_agree_wait(r, &ba, st, err)) != DTX_OK && ba.sum[0] > 0)
                goto done;
            block_agree_post(r, &ba, st, n);
        }
    }
    if (!coll)
        st = block_agree_wait(r, &ba, st, err);
done:
    free(todo);
    free(seg);
    return st;
}

/* Frames still to do over all results (rank 0's count is the one used). */
dtx_status run_count_todo(run_state *r, dtx_error *err)
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
    return run_agree(r->comm, st, err);
}

/* The plan of target tc through r->method (every rank: each needs the
 * factor for its solves), saying what it holds. */
static dtx_status target_plan(run_state *r, const target_ctx *tc, void **plan, dtx_error *err)
{
    const dtx_job_target *tj = tc->tj;
    dtx_transfer_inputs in;
    int32_t *pin_idx = NULL;
    double *pin_pos = NULL;
    char text[2048];
    dtx_status st;
    *plan = NULL;
    if (r->method->uses_proxy && !tc->same_conn && tj->npins > 0)
        return dtx_seterr(err, DTX_EJOB,
                          "%s: target \"%s\": method %s holds pins only on a target with the "
                          "source's vertices and faces (this one goes through a proxy)",
                          r->job.job_path ? r->job.job_path : "job", tj->name, r->method->name);
    if (tj->npins > 0) {
        pin_idx = dtx_alloc((size_t)tj->npins, sizeof *pin_idx, 0);
        pin_pos = dtx_alloc((size_t)tj->npins, 3 * sizeof *pin_pos, 0);
        if (pin_idx && pin_pos)
            for (int32_t i = 0; i < tj->npins; i++) {
                pin_idx[i] = dtx_weld_index(&tc->weld, tj->pins[i].vertex);
                memcpy(pin_pos + 3 * i, tj->pins[i].pos, 3 * sizeof *pin_pos);
            }
    }
    memset(&in, 0, sizeof in);
    in.src = &r->src;
    in.tgt = &tc->mesh;
    in.pairs = tc->corr.pairs;
    in.npairs = tc->corr.npairs;
    in.proxy = tc->same_conn ? NULL : tc->corr.deformed_src;
    in.src_keys = tc->keys.src;
    in.tgt_keys = tc->keys.tgt;
    in.nkeys = tc->keys.n;
    in.ntrain = r->ntrain;
    in.Xtrain = r->Xtrain;
    in.src_weights = tc->Ws;
    in.tgt_weights = tc->Wt;
    in.anchor =
        tj->translation == DTX_TRANSLATION_FOLLOW
            ? DTX_ANCHOR_FOLLOW
            : (tj->translation == DTX_TRANSLATION_PINS ? DTX_ANCHOR_PINS : DTX_ANCHOR_FIXED);
    in.pins = pin_idx;
    in.pin_pos = pin_pos;
    in.npins = tj->npins;
    st = r->method->plan_create(&in, &r->prm, plan, err);
    free(pin_idx);
    free(pin_pos);
    if (st != DTX_OK)
        return st;
    /* One message line per line of the method's description. */
    r->method->describe(*plan, text, sizeof text);
    for (char *line = text, *next; *line; line = next) {
        next = strchr(line, '\n');
        if (next)
            *next++ = '\0';
        else
            next = line + strlen(line);
        run_say(r, "dtx: target %s: %s", tj->name, line);
    }
    return DTX_OK;
}

dtx_status run_transfer_all(run_state *r, dtx_error *err)
{
    dtx_status st = DTX_OK;
    int32_t maxnv = 0;
    frame_buffers fb[3];
    int nsets;
    memset(fb, 0, sizeof fb);
    /* Blocks are whole solve groups, so frame arithmetic never depends on
     * how frames are split over ranks or calls. */
    fb[0].block = r->job.block_frames;
    if (fb[0].block % r->align)
        fb[0].block += r->align - fb[0].block % r->align;
    for (int t = 0; t < r->nt; t++)
        maxnv = r->tg[t].weld.nv > maxnv ? r->tg[t].weld.nv : maxnv;
    fb[1].block = fb[2].block = fb[0].block;
    /* A second set of buffers when a rank's I/O overlaps its transfers
     * (a third when the method lets the rank's threads deal its groups,
     * see transfer_team):
     * methods that solve frames in groups (sp04 and the methods built on
     * its solve), whose blocks take milliseconds, so that I/O is a large
     * share.  A method that deals single frames (springs: seconds each)
     * keeps all of the rank's threads for them: overlapped, its frames ran
     * on the one remaining thread, and 1 rank x 2 threads of driver.springs
     * took 282 s instead of 10 s. */
    nsets = !r->job.collective_io && omp_max_threads() > 1 && r->align > 1
                ? (r->method->team_apply ? 3 : 2)
                : 1;
    st = DTX_OK;
    for (int b = 0; b < nsets && st == DTX_OK; b++)
        st = buffers_alloc(r, maxnv, &fb[b], err);
    if ((st = run_agree(r->comm, st, err)) != DTX_OK)
        goto done;

    for (int t = 0; t < r->nt; t++) {
        target_ctx *tc = &r->tg[t];
        const dtx_job_target *tj = tc->tj;
        void *plan = NULL;
        double t0 = run_wtime();
        int needed = 0;
        for (int s = 0; s < r->ns; s++)
            needed |= !RESULT(r, t, s)->finished;
        if (!needed)
            continue;
        st = target_plan(r, tc, &plan, err);
        if (st != DTX_OK)
            dtx_error_prefix(err, "target \"%s\" (%s:%s)", tj->name, tj->file, tj->mesh);
        r->tm.factor += run_wtime() - t0;
        if ((st = agree_timed(r, st, err)) != DTX_OK) {
            r->method->plan_free(&plan);
            goto done;
        }
        for (int s = 0; s < r->ns && st == DTX_OK; s++)
            if (!RESULT(r, t, s)->finished)
                st = transfer_result(r, t, s, plan, fb, nsets, err);
        r->method->plan_free(&plan);
        if (st != DTX_OK)
            goto done;
    }
done:
    for (int b = 0; b < 3; b++) {
        free(fb[b].Xs);
        free(fb[b].Xt);
        free(fb[b].res);
        free(fb[b].info);
        free(fb[b].fstats);
        free(fb[b].gnorm);
    }
    return st;
}
