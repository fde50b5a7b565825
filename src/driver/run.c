/*
 * run.c: `dtx run`, the batch run of a job across MPI ranks.
 *
 * Phases, in order (dtx_run_job reads as this list; the file that holds
 * each is named in brackets, their shared state is run_internal.h):
 *   1. load the job (rank 0 reads and checks it, every rank parses the same text)
 *      [run_inputs.c], then check the output paths and take OUTPUT.lock [run_output.c];
 *   2. read the inputs (every rank: source mesh, sequence shapes, targets, markers)
 *      [run_inputs.c];
 *   3. decide what the output file is: a fresh OUTPUT.partial, the partial of an
 *      interrupted run to continue (--resume), or nothing to do [run_output.c];
 *      (method springs: a target with the source's vertices and faces needs
 *      no markers and no correspondence; any other goes through a proxy,
 *      the source deformed by sp04's correspondence);
 *   3b. method biharmonic: every rank reads the training frames; with
 *      keypoints "auto" the ranks select the key points together, each
 *      evaluating its share of the candidates [run_corr.c];
 *   4. correspondences: reused from the partial or the old output when their key
 *      (a hash of both meshes, the markers and the parameters) matches, or
 *      taken from the correspondence store [run_store.c], else computed,
 *      different targets on different ranks, then broadcast and written into
 *      the store (none for biharmonic with markers as key points); then, for
 *      biharmonic, each
 *      target's key points: its markers, or the selected ones mapped through
 *      the correspondence [run_corr.c];
 *   5. open the output: create every mesh, correspondence, key-point set
 *      (biharmonic) and result up front
 *      (so the frame loop only writes raw data into allocated space), or reopen
 *      the partial and read which frames are done [run_output.c];
 *   6. per target: factor once (every rank); per sequence: the frame groups not
 *      yet done are dealt to the ranks and each rank reads, transfers and writes
 *      its groups in blocks (collective writes) [run_frames.c; the dealing
 *      of groups to ranks is run_schedule.c, free of MPI and HDF5];
 *   7. finish: mark results complete, close, rename OUTPUT.partial to OUTPUT
 *      [run_output.c];
 *   8. summary (JSON) and the last progress line [run_summary.c].
 *
 * --correspond-only runs phases 2 and 4 alone (into the store) and stops
 * before the output is looked at.
 *
 * Crash safety: every object of the output is created and flushed before the
 * first frame is written, with its space allocated, so a process killed in
 * the frame loop leaves metadata that was complete at the flush and raw
 * frames whose frame_done flag is written only after their positions.  The
 * real output name appears only by the final rename, after every result
 * passed its completeness check.
 *
 * Failure handling: after every phase the ranks agree on the outcome
 * (run_agree(), run_common.c), so a failure on one rank ends the job on
 * every rank with that rank's message, and no rank is left waiting in a
 * collective call.
 */
#include "run_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#endif

/* OpenBLAS's own call, when that is the BLAS we run on: BLAS stays
 * single-threaded because threads come from OpenMP and ranks. */
extern void openblas_set_num_threads(int n) __attribute__((weak));

/* ------------------------------------------------------------------ */
/* The job                                                             */
/* ------------------------------------------------------------------ */

static void release(run_state *r)
{
    run_close_results(r);
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
    run_bh_weights_free(r);
    free(r->tg);
    free(r->sq);
    free(r->rs);
    for (int s = 0; r->seq_paths && s < r->ns; s++)
        free(r->seq_paths[s]);
    free(r->seq_paths);
    dtx_job_free(&r->job);
}

/* --correspond-only: phases 2 and 4 alone, into the store; the output
 * and its lock are not touched. */
static dtx_status correspond_only(run_state *r, dtx_error *err)
{
    dtx_status st;
    const char *dir = run_store_dir(r);
    if (!dir)
        return dtx_seterr(err, DTX_EJOB,
                          "%s: --correspond-only needs a correspondence store (--store DIR or "
                          "the job's correspondence_store)",
                          r->job.job_path ? r->job.job_path : "job");
    if ((st = run_read_inputs(r, err)) != DTX_OK || (st = run_correspondences(r, err)) != DTX_OK)
        return st;
    if (!run_uses_correspondence(r))
        run_say(r, "dtx: the job's method needs no correspondence: nothing stored");
    else
        run_say(r, "dtx: the correspondences of the job's %d target(s) are in store %s", r->nt,
                dir);
    return DTX_OK;
}

dtx_status dtx_run_job(const char *job_path, MPI_Comm comm, const dtx_run_opts *opts,
                       dtx_error *err)
{
    run_state r;
    dtx_status st;
    double t_start = run_wtime(), t_phase;
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
    run_stats_init(&r.stats);
    err->code = DTX_OK;
    err->msg[0] = '\0';

    /* 1. The job; the output's paths checked and OUTPUT.lock taken. */
    if ((st = run_load_job(comm, job_path, &r.job, err)) != DTX_OK)
        return st;
    snprintf(r.partial, sizeof r.partial, "%s.partial", r.job.output_file);
    snprintf(r.partial_new, sizeof r.partial_new, "%s.new", r.partial);
    dtx_job_transfer_params(&r.job, &r.prm);
    r.method = dtx_transfer_method_of(r.prm.kind);
    r.align = r.method->solve_group;
    if (opts->correspond_only) {
        st = correspond_only(&r, err);
        release(&r);
        return st;
    }
    if ((st = run_take_output(&r, err)) != DTX_OK)
        goto fail;
    /* 2. The inputs. */
    if ((st = run_read_inputs(&r, err)) != DTX_OK)
        goto fail;
    /* 3. What the output is: fresh, a resume, or done already. */
    run_choose_mode(&r);
    if (r.mode != OUT_DONE) {
        /* 3b. Key points; 4. correspondences and each target's key points. */
        if ((st = run_select_keypoints(&r, err)) != DTX_OK ||
            (st = run_correspondences(&r, err)) != DTX_OK ||
            (st = run_target_keys(&r, err)) != DTX_OK || (st = run_bh_weights(&r, err)) != DTX_OK)
            goto fail;
        /* 5. The output, created or reopened, and the frames still to do. */
        out_started = 1;
        t_phase = run_wtime();
        if ((st = run_open_output(&r, err)) != DTX_OK || (st = run_count_todo(&r, err)) != DTX_OK)
            goto fail;
        r.tm.output = run_wtime() - t_phase;
        /* 6. The frame loop. */
        if (r.rank == 0 && !opts->quiet) {
            if (r.frames_skipped)
                run_say(&r, "dtx: resuming %s: %lld frames already done, %lld to do", r.partial,
                        (long long)r.frames_skipped, (long long)r.frames_todo);
            dtx_progress_start(&r.prog, stderr, -1, 10.0, r.frames_todo, run_wtime());
        }
        if ((st = run_transfer_all(&r, err)) != DTX_OK)
            goto fail;
        run_add_result_stats(&r);
        /* 7. Finish: results complete, OUTPUT.partial renamed to OUTPUT. */
        if ((st = run_finish_output(&r, err)) != DTX_OK)
            goto fail;
        if (r.rank == 0)
            dtx_progress_finish(&r.prog, run_wtime());
        memset(&r.prog, 0, sizeof r.prog);
    }
    /* 8. The summary. */
    r.tm.total = run_wtime() - t_start;
    run_gather_results(&r);
    run_summarise(&r);
    if (r.rank == 0)
        dtx_output_lock_release(&r.lock);
    release(&r);
    return DTX_OK;

fail:
    if (r.rank == 0 && r.prog.out)
        dtx_progress_message(&r.prog, "");
    memset(&r.prog, 0, sizeof r.prog);
    run_close_results(&r);
    if (r.out >= 0)
        dtx_h5_close(&r.out, NULL);
    if (out_started && r.rank == 0)
        run_partial_fate(&r, job_path, err);
    if (r.rank == 0)
        dtx_output_lock_release(&r.lock);
    release(&r);
    return st != DTX_OK ? st : err->code;
}
