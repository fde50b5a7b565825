/*
 * run_summary.c: what a run of `dtx run` reports: residual statistics and
 * the (Gauss-)Newton solves of the frames it transferred (gathered on rank
 * 0 in a fixed order), the run summary JSON and the last lines on stderr.
 */
#include "run_internal.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

void run_stats_init(run_stats *s)
{
    memset(s, 0, sizeof *s);
    s->min = INFINITY;
    s->max = -INFINITY;
}

void run_stats_add(run_stats *s, double v)
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

void run_solves_init(solve_stats *s)
{
    memset(s, 0, sizeof *s);
    s->first_unconverged = s->max_inverted_frame = s->max_grad_norm_frame = INT64_MAX;
    s->max_grad_norm = -1.0;
}

/* Frame f's solve: into s, and as its frame_stats row (inverted: -1 where
 * the method does not count them; grad_norm: NaN where it reports none). */
void run_solves_add(solve_stats *s, int64_t f, int32_t iterations, int converged, int32_t inverted,
                    double grad_norm, int32_t row[DTX_H5_FRAME_STATS])
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
    if (grad_norm > s->max_grad_norm ||
        (grad_norm == s->max_grad_norm && f < s->max_grad_norm_frame)) {
        s->max_grad_norm = grad_norm;
        s->max_grad_norm_frame = f;
    }
}

/* The solves of all ranks, on rank 0. */
static void solves_reduce(MPI_Comm comm, const solve_stats *mine, solve_stats *all)
{
    int64_t sums[4] = {mine->frames, mine->iterations, mine->unconverged, mine->inverted_frames};
    int64_t maxs[2] = {mine->max_iterations, mine->max_inverted}, sum_all[4], max_all[2];
    int64_t frame = INT64_MAX;
    run_solves_init(all);
    MPI_Reduce(sums, sum_all, 4, MPI_INT64_T, MPI_SUM, 0, comm);
    MPI_Reduce(&mine->first_unconverged, &all->first_unconverged, 1, MPI_INT64_T, MPI_MIN, 0,
               comm);
    MPI_Allreduce(maxs, max_all, 2, MPI_INT64_T, MPI_MAX, comm);
    /* The lowest frame with the most inversions, over the ranks. */
    if (mine->max_inverted == max_all[1] && max_all[1] > 0)
        frame = mine->max_inverted_frame;
    MPI_Reduce(&frame, &all->max_inverted_frame, 1, MPI_INT64_T, MPI_MIN, 0, comm);
    /* The lowest frame with the largest gradient norm, likewise (a maximum
     * of doubles is exact, so the ranks agree on which is largest). */
    MPI_Allreduce(&mine->max_grad_norm, &all->max_grad_norm, 1, MPI_DOUBLE, MPI_MAX, comm);
    frame = mine->max_grad_norm == all->max_grad_norm && all->max_grad_norm >= 0.0
                ? mine->max_grad_norm_frame
                : INT64_MAX;
    MPI_Reduce(&frame, &all->max_grad_norm_frame, 1, MPI_INT64_T, MPI_MIN, 0, comm);
    all->frames = sum_all[0];
    all->iterations = sum_all[1];
    all->unconverged = sum_all[2];
    all->inverted_frames = sum_all[3];
    all->max_iterations = max_all[0];
    all->max_inverted = max_all[1];
}

/* Rank 0, iterative methods (springs' Newton, multicomponent's
 * Gauss-Newton): how the solves of result (t, s) went. */
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
    run_say(r, "dtx: result %s/%s: %s %.1f iterations per frame (at most %lld)%s%s",
            r->tg[t].tj->name, r->sq[s].name, dtx_transfer_solver_name(r->method, &r->prm),
            (double)sp->iterations / (double)sp->frames, (long long)sp->max_iterations, more,
            sp->unconverged || sp->inverted_frames ? " (per frame: frame_stats in the output)"
                                                   : "");
}

/* The solves of an iterative method's result as the summary's object
 * named after the method, its keys after the solver of the run's parameters
 * ("Gauss-Newton": "gauss_newton_iterations_mean"), with the inverted
 * triangles where the method counts them. */
static void json_solves(FILE *f, const dtx_transfer_method *m, const dtx_transfer_params *prm,
                        const solve_stats *sv)
{
    const char *solver = dtx_transfer_solver_name(m, prm);
    char key[64];
    size_t i;
    for (i = 0; solver[i] && i + 1 < sizeof key; i++)
        key[i] = solver[i] == '-' ? '_' : (char)tolower((unsigned char)solver[i]);
    key[i] = '\0';
    fprintf(f,
            ", \"%s\": {\"%s_iterations_mean\": %.4g, \"%s_iterations_max\": %lld, "
            "\"unconverged_frames\": %lld",
            m->name, key, (double)sv->iterations / (double)sv->frames, key,
            (long long)sv->max_iterations, (long long)sv->unconverged);
    if (m->counts_inverted)
        fprintf(f, ", \"frames_with_inverted_triangles\": %lld, \"inverted_triangles_max\": %lld",
                (long long)sv->inverted_frames, (long long)sv->max_inverted);
    if (m->reports_grad_norm && sv->max_grad_norm >= 0.0)
        fprintf(f, ", \"grad_norm_max\": %.6g, \"grad_norm_max_frame\": %lld", sv->max_grad_norm,
                (long long)sv->max_grad_norm_frame);
    fputc('}', f);
}

/* Adds this rank's statistics of every result to r->stats. */
void run_add_result_stats(run_state *r)
{
    for (int t = 0; t < r->nt; t++)
        for (int s = 0; s < r->ns; s++)
            stats_merge(&r->stats, &RESULT(r, t, s)->st);
}

/* Per-result statistics (and solves) of all ranks, on rank 0. */
void run_gather_results(run_state *r)
{
    for (int t = 0; t < r->nt; t++)
        for (int s = 0; s < r->ns; s++) {
            run_stats all;
            run_stats_init(&all);
            stats_reduce(r->comm, &RESULT(r, t, s)->st, &all);
            if (r->rank == 0)
                RESULT(r, t, s)->st = all;
            if (r->method->iterative) {
                solve_stats sv;
                solves_reduce(r->comm, &RESULT(r, t, s)->sv, &sv);
                if (r->rank == 0)
                    RESULT(r, t, s)->sv = sv;
                say_solves(r, t, s);
            }
        }
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

/* CPU seconds of this process so far (user + system, every thread). */
static double cpu_seconds(void)
{
    struct rusage ru;
    if (getrusage(RUSAGE_SELF, &ru) != 0)
        return 0;
    return (double)ru.ru_utime.tv_sec + 1e-6 * (double)ru.ru_utime.tv_usec +
           (double)ru.ru_stime.tv_sec + 1e-6 * (double)ru.ru_stime.tv_usec;
}

/* Peak resident memory of this process, MiB. */
static double peak_rss_mb(void)
{
    struct rusage ru;
    if (getrusage(RUSAGE_SELF, &ru) != 0)
        return 0;
    return (double)ru.ru_maxrss / 1024.0; /* Linux: kilobytes */
}

/* The phases of phase_times by their names in the summary, in its order. */
static const struct {
    const char *name;
    size_t off;
} phase_keys[] = {
    {"read", offsetof(phase_times, read)},
    {"keypoints", offsetof(phase_times, keypoints)},
    {"correspondence", offsetof(phase_times, correspond)},
    {"factor", offsetof(phase_times, factor)},
    {"output", offsetof(phase_times, output)},
    {"transfer", offsetof(phase_times, transfer)},
    {"write", offsetof(phase_times, write)},
    {"finish", offsetof(phase_times, finish)},
    {"wait", offsetof(phase_times, wait)},
    {"total", offsetof(phase_times, total)},
    {"cpu", offsetof(phase_times, cpu)},
};
enum { NPHASES = sizeof phase_keys / sizeof phase_keys[0] };
/* Up to this many ranks, the end of a run prints a line per rank. */
enum { RANK_LINES_MAX = 8 };

static double phase_of(const phase_times *tm, int i)
{
    return *(const double *)((const char *)tm + phase_keys[i].off);
}

/* {"read": s, ..., "total": s} of one rank's phases. */
static void json_phases(FILE *f, const phase_times *tm)
{
    for (int i = 0; i < NPHASES; i++)
        fprintf(f, "%s\"%s\": %.6f", i ? ", " : "{", phase_keys[i].name, phase_of(tm, i));
    fputc('}', f);
}

static void write_summary(run_state *r, const char *path, const run_stats *all, const double *rss,
                          const phase_times *tms)
{
    static const char *const mode_name[] = {"fresh", "resumed", "already complete"};
    char tmp[4300];
    double rss_max = 0;
    FILE *f;
    snprintf(tmp, sizeof tmp, "%.4200s.tmp", path);
    f = fopen(tmp, "w");
    if (!f) {
        run_say(r, "dtx: warning: cannot write the run summary %s: %s", tmp, strerror(errno));
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
            "  \"frames\": %lld,\n  \"frames_skipped\": %lld,\n  \"seconds\": ",
            mode_name[r->mode], r->nranks, r->nthreads, (long long)all->frames,
            (long long)r->frames_skipped);
    json_phases(f, &r->tm);
    /* Every rank's phases: where one rank waits for another, or does
     * work the others do not. */
    fprintf(f, ",\n  \"seconds_per_rank\": [");
    for (int q = 0; q < r->nranks; q++) {
        fprintf(f, "%s\n    ", q ? "," : "");
        json_phases(f, &tms[q]);
    }
    fprintf(f, "\n  ],\n  \"frames_per_second\": %.3f,\n  \"residual\": ",
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
                r->mode == OUT_DONE || r->tg[t].same_conn || !run_uses_correspondence(r)
                    ? "not needed"
                    : r->tg[t].reused == RUN_CORR_STORE  ? "store"
                    : r->tg[t].reused == RUN_CORR_CACHED ? "reused"
                                                         : "computed");
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
            if (r->method->iterative && rc->sv.frames > 0)
                json_solves(f, r->method, &r->prm, &rc->sv);
            fputc('}', f);
        }
    fprintf(f, "\n  ]\n}\n");
    if (fclose(f) != 0 || rename(tmp, path) != 0) {
        run_say(r, "dtx: warning: cannot write the run summary %s", path);
        remove(tmp);
    }
}

void run_summarise(run_state *r)
{
    run_stats all;
    double mine = peak_rss_mb(), *rss = NULL, tm_mine[NPHASES], *tm_all = NULL;
    phase_times *tms = NULL;
    char kp_time[64] = "";
    run_stats_init(&all);
    stats_reduce(r->comm, &r->stats, &all);
    if (r->rank == 0) {
        rss = calloc((size_t)r->nranks, sizeof *rss);
        tm_all = calloc((size_t)r->nranks * NPHASES, sizeof *tm_all);
        tms = calloc((size_t)r->nranks, sizeof *tms);
    }
    r->tm.cpu = cpu_seconds();
    for (int i = 0; i < NPHASES; i++)
        tm_mine[i] = phase_of(&r->tm, i);
    MPI_Gather(&mine, 1, MPI_DOUBLE, rss, 1, MPI_DOUBLE, 0, r->comm);
    MPI_Gather(tm_mine, NPHASES, MPI_DOUBLE, tm_all, NPHASES, MPI_DOUBLE, 0, r->comm);
    if (r->rank != 0 || !rss || !tm_all || !tms) {
        free(rss);
        free(tm_all);
        free(tms);
        return;
    }
    for (int q = 0; q < r->nranks; q++)
        for (int i = 0; i < NPHASES; i++)
            *(double *)((char *)&tms[q] + phase_keys[i].off) = tm_all[(size_t)q * NPHASES + i];
    /* A run that found nothing to do keeps the summary of the run that did
     * the work, unless a summary file was asked for. */
    if (r->mode != OUT_DONE || r->opts->summary_path) {
        char sp[4200];
        if (r->opts->summary_path)
            snprintf(sp, sizeof sp, "%s", r->opts->summary_path);
        else
            snprintf(sp, sizeof sp, "%s.summary.json", r->job.output_file);
        write_summary(r, sp, &all, rss, tms);
    }
    if (r->tm.keypoints > 0)
        snprintf(kp_time, sizeof kp_time, "key points %.3f s, ", r->tm.keypoints);
    if (r->mode == OUT_DONE)
        run_say(r, "dtx: %s is already complete for this job: nothing to do", r->job.output_file);
    else
        run_say(r,
                "dtx: %lld frames in %.3f s (%.1f frames/s) on %d rank(s) x %d thread(s)%s; "
                "read %.3f s, %scorrespondence %.3f s, factor %.3f s, output %.3f s, transfer "
                "%.3f s, write %.3f s, finish %.3f s; mean residual %.4g\ndtx: result: %s",
                (long long)all.frames, r->tm.total,
                r->tm.total > 0 ? (double)all.frames / r->tm.total : 0.0, r->nranks, r->nthreads,
                r->frames_skipped ? " (frames done before were kept)" : "", r->tm.read, kp_time,
                r->tm.correspond, r->tm.factor, r->tm.output, r->tm.transfer, r->tm.write,
                r->tm.finish, mean_of(&all), r->job.output_file);
    /* With several ranks, how each spent the run (the line above is rank
     * 0's), so that a rank waiting for another shows; with more than
     * RANK_LINES_MAX ranks, each phase's least and most over the ranks (and
     * which), every rank's being in the summary's seconds_per_rank. */
    if (r->mode != OUT_DONE && r->nranks > RANK_LINES_MAX)
        for (int i = 0; i < NPHASES; i++) {
            int lo = 0, hi = 0;
            for (int q = 1; q < r->nranks; q++) {
                if (phase_of(&tms[q], i) < phase_of(&tms[lo], i))
                    lo = q;
                if (phase_of(&tms[q], i) > phase_of(&tms[hi], i))
                    hi = q;
            }
            run_say(r, "dtx: %s over %d ranks (s): least %.3f (rank %d), most %.3f (rank %d)",
                    phase_keys[i].name, r->nranks, phase_of(&tms[lo], i), lo,
                    phase_of(&tms[hi], i), hi);
        }
    else if (r->mode != OUT_DONE && r->nranks > 1)
        for (int q = 0; q < r->nranks; q++) {
            char line[600];
            size_t len = 0;
            for (int i = 0; i < NPHASES && len < sizeof line; i++)
                len += (size_t)snprintf(line + len, sizeof line - len, "%s %s %.3f", i ? "," : "",
                                        phase_keys[i].name, phase_of(&tms[q], i));
            run_say(r, "dtx: rank %d (s):%s", q, line);
        }
    free(rss);
    free(tm_all);
    free(tms);
}
