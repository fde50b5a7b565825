/*
 * run_common.c: the small helpers every phase of `dtx run` uses: agreeing
 * on a phase's outcome across the ranks, the clock, the injected faults of
 * the tests, rank 0's messages and creating directories.
 */
#include "run_internal.h"

#include "mpi_util.h"

#include <errno.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* ------------------------------------------------------------------ */
/* Small helpers                                                       */
/* ------------------------------------------------------------------ */

/* Collective agreement on failures (mpi_util.h): DTX_OK when every rank
 * succeeded, else the status and message of the lowest failing rank, on
 * every rank, the other ranks naming it when it is not rank 0. */
dtx_status run_agree(MPI_Comm comm, dtx_status st, dtx_error *err)
{
    return dtx_mpi_agree(st, DTX_AGREE_NAME_RANK, comm, err);
}

double run_wtime(void) { return MPI_Wtime(); }

/* Fault injection for the tests: with DTX_FAULT=PHASE@RANK in the
 * environment, rank RANK fails at phase PHASE (read, correspondence,
 * output, transfer, finish) as a real error there would; with
 * DTX_FAULT=PHASE@RANK:kill it dies there of SIGKILL instead, a crash at a
 * known point (in the frame loop: half of its blocks written). */
dtx_status run_injected_fault(const run_state *r, const char *phase, dtx_error *err)
{
    const char *f = getenv("DTX_FAULT");
    const char *at = f ? strchr(f, '@') : NULL;
    char *end = NULL;
    if (!at || (size_t)(at - f) != strlen(phase) || strncmp(f, phase, strlen(phase)) != 0 ||
        strtol(at + 1, &end, 10) != r->rank)
        return DTX_OK;
    if (strcmp(end, ":kill") == 0)
        raise(SIGKILL);
    return dtx_seterr(err, DTX_EIO, "injected fault at phase %s on rank %d (DTX_FAULT=%s)",
                      phase, r->rank, f);
}

/* A message from rank 0 on stderr (not with --quiet). */
void run_say(run_state *r, const char *fmt, ...)
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

int run_uses_correspondence(const run_state *r)
{
    return r->method->uses_pairs || r->method->uses_proxy ||
           (r->method->uses_keypoints && r->job.bh.keypoints == DTX_BH_KEYS_AUTO);
}

void run_corr_meta(const run_state *r, const target_ctx *tc, const char *params,
                   run_corr_desc *d, dtx_h5_corr_meta *meta)
{
    const dtx_job_target *tj = tc->tj;
    snprintf(d->source, sizeof d->source, "%s:%s", r->job.source_file, r->job.source_mesh);
    snprintf(d->target, sizeof d->target, "%s:%s", tj->file, tj->mesh);
    if (tj->markers.csv)
        /* Not starting with '/': the validator follows in-file paths. */
        snprintf(d->markers, sizeof d->markers, "CSV file %s (index base %d)", tj->markers.csv,
                 tj->markers.index_base);
    else if (tj->markers.file)
        snprintf(d->markers, sizeof d->markers, "%s:%s", tj->markers.file, tj->markers.path);
    else
        snprintf(d->markers, sizeof d->markers, "none");
    meta->key = tc->key;
    meta->source_mesh = d->source;
    meta->target_mesh = d->target;
    meta->markers = d->markers;
    meta->parameters = params;
}

/* mkdir -p of the directory part of path (dir_only != 0) or of path. */
dtx_status run_make_dirs(const char *path, int dir_only, dtx_error *err)
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
