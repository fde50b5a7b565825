/*
 * run_store.c: the correspondence store in `dtx run` (src/io/corr_store.h):
 * rank 0 looks each target's correspondence up in the store after the
 * output's own caches and before computing it, and writes into the store
 * every correspondence it did not take from there.
 */
#include "run_internal.h"

#include "corr_store.h"
#include "file_util.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

const char *run_store_dir(const run_state *r)
{
    return r->opts->store_dir ? r->opts->store_dir : r->job.corr_store;
}

/* The store holds sp04's correspondences with their deformed source and
 * multicomponent's without. */
static int needs_deformed(const run_state *r)
{
    return r->method->correspondence != DTX_TRANSFER_CORR_MULTICOMPONENT;
}

void run_store_lookup(run_state *r, int *reused)
{
    const char *dir = run_store_dir(r);
    if (!dir || r->rank != 0)
        return;
    for (int t = 0; t < r->nt; t++) {
        target_ctx *tc = &r->tg[t];
        dtx_h5_corr c;
        dtx_error e;
        int found = 0;
        if (reused[t])
            continue;
        if (dtx_corr_store_read(dir, tc->key, r->src.nv, r->src.nf, tc->mesh.nf, needs_deformed(r),
                                &c, &found, &e) != DTX_OK) {
            /* Never used: computed again, and the file replaced by rename. */
            run_say(r,
                    "dtx: warning: target %s: correspondence store: %s; computing the "
                    "correspondence again (the store file is replaced)",
                    tc->tj->name, e.msg);
            continue;
        }
        if (!found)
            continue;
        dtx_corr_free(&tc->corr);
        memset(&tc->corr, 0, sizeof tc->corr);
        tc->corr.npairs = c.npairs;
        tc->corr.pairs = c.pairs;
        tc->corr.deformed_src = c.deformed_src;
        tc->corr.nv_src = r->src.nv;
        c.pairs = NULL;
        c.deformed_src = NULL;
        dtx_h5_corr_free(&c);
        reused[t] = RUN_CORR_STORE;
    }
}

/* 1 when path is one of the job's input files (never written). */
static int is_input(const run_state *r, const char *path)
{
    if (dtx_file_same_inode(path, r->job.source_file) == 1 ||
        (r->job.job_path && dtx_file_same_inode(path, r->job.job_path) == 1))
        return 1;
    for (int t = 0; t < r->nt; t++) {
        const dtx_job_target *tj = r->tg[t].tj;
        if (dtx_file_same_inode(path, tj->file) == 1 ||
            (tj->markers.csv && dtx_file_same_inode(path, tj->markers.csv) == 1) ||
            (tj->markers.file && dtx_file_same_inode(path, tj->markers.file) == 1))
            return 1;
    }
    return 0;
}

dtx_status run_store_save(run_state *r, dtx_error *err)
{
    const char *dir = run_store_dir(r);
    dtx_status st = DTX_OK;
    char *params = NULL;
    if (!dir || !run_uses_correspondence(r))
        return DTX_OK;
    if (r->rank == 0) {
        params = dtx_job_corr_params_json(&r->job, r->method->correspondence);
        st = params ? DTX_OK : dtx_seterr(err, DTX_ENOMEM, "out of memory");
        if (st == DTX_OK)
            st = run_make_dirs(dir, 0, err);
        if (st != DTX_OK)
            dtx_error_prefix(err, "correspondence store %s", dir);
    }
    for (int t = 0; r->rank == 0 && st == DTX_OK && t < r->nt; t++) {
        target_ctx *tc = &r->tg[t];
        const dtx_job_target *tj = tc->tj;
        char path[4400];
        run_corr_desc desc;
        dtx_h5_corr_meta meta;
        if (tc->same_conn || tc->reused == RUN_CORR_STORE)
            continue;
        if ((st = dtx_corr_store_path(dir, tc->key, path, sizeof path, err)) != DTX_OK)
            break;
        /* One taken from the output's cache may be in the store already. */
        if (tc->reused == RUN_CORR_CACHED && access(path, F_OK) == 0)
            continue;
        if (is_input(r, path)) {
            st = dtx_seterr(err, DTX_EJOB,
                            "correspondence store: %s is an input of the job; not written", path);
            break;
        }
        run_corr_meta(r, tc, params, &desc, &meta);
        st = dtx_corr_store_write(dir, tc->key, tc->corr.pairs, tc->corr.npairs,
                                  needs_deformed(r) ? tc->corr.deformed_src : NULL, r->src.nv,
                                  &meta, err);
        if (st != DTX_OK)
            dtx_error_prefix(err, "target \"%s\": correspondence store", tj->name);
        else
            run_say(r, "dtx: target %s: correspondence stored as %s", tj->name, path);
    }
    free(params);
    return run_agree(r->comm, st, err);
}
