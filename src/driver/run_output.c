/*
 * run_output.c: the life of the output file of `dtx run`: the checks of
 * the paths it writes and OUTPUT.lock (before the inputs are read), what
 * the output is (fresh, the partial of an interrupted run to continue, or
 * nothing to do), creating every object up front or reopening the
 * partial, and at the end marking the results complete and renaming
 * OUTPUT.partial to OUTPUT; on failure, what becomes of the partial.
 */
#include "run_internal.h"

#include "file_util.h"
#include "path_guard.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

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
    struct { const char *path, *use; } w[8];
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
    w[nw].path = r->partial_new, w[nw++].use = "the output's temporary file";
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
            from_summary = i >= 5 && r->opts->summary_path;
    dtx_path_guard_free(&g);
    if (st == DTX_OK)
        st = dtx_output_path_check(j->output_file, "the output", err);
    if (st == DTX_OK)
        st = dtx_output_path_check(r->partial, "the output's temporary file", err);
    if (st == DTX_OK)
        st = dtx_output_path_check(r->partial_new, "the output's temporary file", err);
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
dtx_status run_take_output(run_state *r, dtx_error *err)
{
    dtx_status st = DTX_OK;
    char note[1600];
    if (r->rank == 0) {
        st = check_output_paths(r, err);
        if (st == DTX_OK)
            st = run_make_dirs(r->job.output_file, 1, err);
        if (st == DTX_OK)
            st = dtx_output_lock_acquire(r->job.output_file, r->opts->break_lock, &r->lock,
                                         note, sizeof note, err);
        if (st == DTX_OK && note[0])
            fprintf(stderr, "dtx: %s\n", note);
        if (st == DTX_OK)
            st = check_partial_ours(r, err);
    }
    return run_agree(r->comm, st, err);
}

/* Rank 0, after a failure once the output was started (files closed):
 * tells truthfully what is left.  A partial that reads back with this
 * run's key is kept (its frames for --resume when the failure can go away,
 * such as a full disk; its correspondences for a new run otherwise); one
 * that does not read back is this run's own, useless, and removed.  The
 * sentence is added to err's message as its second line, so that it
 * follows the error itself. */
void run_partial_fate(run_state *r, const char *job_path, dtx_error *err)
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
            run_say(r, "dtx: cannot continue %s (%s): starting over", r->partial, why);
            return OUT_FRESH;
        }
        if (access(r->job.output_file, F_OK) == 0 &&
            file_matches(r, r->job.output_file, 1, why, sizeof why))
            return OUT_DONE;
        return OUT_FRESH;
    }
    if (has_partial)
        run_say(r,
                "dtx: discarding %s, left by an interrupted run (`dtx run --resume` continues one)",
                r->partial);
    return OUT_FRESH;
}

/* Rank 0 decides what the output is; every rank gets it in r->mode. */
void run_choose_mode(run_state *r)
{
    int mode = r->rank == 0 ? (int)decide_mode(r) : 0;
    MPI_Bcast(&mode, 1, MPI_INT, 0, r->comm);
    r->mode = (out_mode)mode;
}

/* ------------------------------------------------------------------ */
/* 5. The output                                                       */
/* ------------------------------------------------------------------ */

/* Rank 0: the new output file, created serially under the temporary name
 * OUTPUT.partial.new with its mark (and, for a method with key points,
 * each target's key points as the marker set /markers/TARGET-keypoints:
 * variable-length labels, which parallel HDF5 cannot write; and their
 * weights, /weights/TARGET-source and -target, a cache), closed, then
 * renamed to OUTPUT.partial.  So an OUTPUT.partial always carries the mark,
 * however early a run is killed; a kill before the rename leaves only
 * OUTPUT.partial.new, which the next run that creates a partial removes. */
static dtx_status create_marked_partial(run_state *r, dtx_error *err)
{
    hid_t f = H5I_INVALID_HID;
    char srcdesc[4200];
    dtx_status st = dtx_h5_create(r->partial_new, MPI_COMM_NULL, &f, err);
    if (st == DTX_OK)
        st = mark_partial(r, f, err);
    snprintf(srcdesc, sizeof srcdesc, "%s:%s", r->job.source_file, r->job.source_mesh);
    for (int t = 0; t < r->nt && st == DTX_OK && r->method->uses_keypoints; t++)
        st = dtx_h5_write_markers(f, r->tg[t].kp_path, &r->tg[t].keys, srcdesc,
                                  r->tg[t].mesh_path, err);
    if (st == DTX_OK && r->method->uses_keypoints)
        st = run_weights_write(r, f, err);
    if (f >= 0) {
        dtx_error e2;
        if (dtx_h5_close(&f, &e2) != DTX_OK && st == DTX_OK) {
            *err = e2;
            st = e2.code;
        }
    }
    if (st == DTX_OK && rename(r->partial_new, r->partial) != 0)
        st = dtx_seterr(err, DTX_EIO, "%s: cannot rename to %s: %s", r->partial_new, r->partial,
                        strerror(errno));
    if (st != DTX_OK)
        remove(r->partial_new);
    return st;
}

static dtx_status create_output(run_state *r, dtx_error *err)
{
    dtx_status st = DTX_OK;
    char *params = dtx_job_params_json(&r->job);
    if (r->rank == 0) {
        st = run_make_dirs(r->job.output_file, 1, err);
        if (st == DTX_OK && remove(r->partial) != 0 && errno != ENOENT)
            st = dtx_seterr(err, DTX_EIO, "%s: cannot remove: %s", r->partial, strerror(errno));
        if (st == DTX_OK && remove(r->partial_new) != 0 && errno != ENOENT)
            st = dtx_seterr(err, DTX_EIO, "%s: cannot remove: %s", r->partial_new,
                            strerror(errno));
        if (st == DTX_OK)
            st = create_marked_partial(r, err);
    }
    if ((st = run_agree(r->comm, st, err)) != DTX_OK)
        goto done;
    /* Every rank opens what rank 0 created. */
    st = dtx_h5_open(r->partial, r->comm, 1, &r->out, err);
    if ((st = run_agree(r->comm, st, err)) != DTX_OK)
        goto done;
    st = params ? DTX_OK : dtx_seterr(err, DTX_ENOMEM, "out of memory");
    for (int t = 0; t < r->nt && st == DTX_OK; t++) {
        target_ctx *tc = &r->tg[t];
        const dtx_job_target *tj = tc->tj;
        run_corr_desc desc;
        dtx_h5_corr_meta meta;
        run_corr_meta(r, tc, params, &desc, &meta);
        st = dtx_weld_write_asset(r->out, tc->mesh_path, &tc->weld, &tc->mesh, tj->file,
                                  tj->mesh, desc.target, err);
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
            prov.method = r->method->name;
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
            if (st == DTX_OK && r->method->iterative) /* frame_stats */
                st = dtx_h5_result_add_frame_stats(&rc->res, err);
            if (st == DTX_OK && r->method->reports_grad_norm)
                st = dtx_h5_result_add_frame_grad_norm(&rc->res, err);
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
        st = run_injected_fault(r, "output", err);
done:
    free(params);
    return run_agree(r->comm, st, err);
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
                /* A partial from a dtx that did not write the solver
                 * figures is started over (a result holds them for every
                 * frame or for none). */
                if (st == DTX_OK && r->method->iterative &&
                    (rc->res.frame_stats < 0 ||
                     (r->method->reports_grad_norm && rc->res.frame_grad_norm < 0)))
                    st = dtx_seterr(err, DTX_EFORMAT, "%s: %s has no %s: cannot resume", r->partial,
                                    tmp,
                                    rc->res.frame_stats < 0 ? "frame_stats" : "frame_grad_norm");
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
    return run_agree(r->comm, st, err);
}

/* The output of r->mode: created, or the partial reopened; a partial that
 * cannot be continued is started over. */
dtx_status run_open_output(run_state *r, dtx_error *err)
{
    dtx_status st = r->mode == OUT_RESUME ? reopen_output(r, err) : create_output(r, err);
    if (st != DTX_OK && r->mode == OUT_RESUME) {
        /* A partial killed while it was being set up can carry the key
         * and still miss objects: start over rather than fail. */
        run_say(r, "dtx: cannot continue %s (%s): starting over", r->partial, err->msg);
        run_close_results(r);
        memset(r->rs, 0, (size_t)r->nt * (size_t)r->ns * sizeof *r->rs);
        if (r->out >= 0)
            dtx_h5_close(&r->out, NULL);
        r->mode = OUT_FRESH;
        err->code = DTX_OK;
        err->msg[0] = '\0';
        st = create_output(r, err);
    }
    return st;
}

/* ------------------------------------------------------------------ */
/* 7. Finish                                                           */
/* ------------------------------------------------------------------ */

/* Closes every open result handle (not collective). */
void run_close_results(run_state *r)
{
    for (int t = 0; r->rs && t < r->nt; t++)
        for (int s = 0; s < r->ns; s++)
            if (RESULT(r, t, s)->open) {
                dtx_h5_result_close(&RESULT(r, t, s)->res);
                RESULT(r, t, s)->open = 0;
            }
}

dtx_status run_finish_output(run_state *r, dtx_error *err)
{
    dtx_status st = DTX_OK;
    double t0 = run_wtime();
    if (run_agree(r->comm, run_injected_fault(r, "finish", err), err) != DTX_OK)
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
        if ((st = run_agree(r->comm, st, err)) == DTX_OK)
            st = dtx_h5_results_finish(open, n, 1, err);
        free(open);
        if (run_agree(r->comm, st, err) != DTX_OK)
            return err->code;
    }
    run_close_results(r);
    if (run_agree(r->comm, dtx_h5_close(&r->out, err), err) != DTX_OK)
        return err->code;
    if (r->rank == 0) {
        int old_left = 0;
        st = dtx_file_replace(r->partial, r->job.output_file, &old_left, err);
        if (st != DTX_OK)
            dtx_error_prefix(err, "cannot move the finished output into place");
        else if (old_left)
            fprintf(stderr, "dtx: warning: %s is in place; the output it replaced is left as %s "
                    "and could not be removed: remove it\n", r->job.output_file, r->partial);
    }
    r->tm.finish += run_wtime() - t0;
    return run_agree(r->comm, st, err);
}
