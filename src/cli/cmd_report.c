/*
 * cmd_report.c: `dtx report FILE.h5`, a Markdown page a person can read
 * after a batch run: the run's phases and speed (from the run summary that
 * `dtx run` writes next to its output, FILE.h5.summary.json), then one
 * section per result with its provenance (method, target, source sequence,
 * correspondence, completeness), a contact sheet (drawn by `dtx render`:
 * source row above the result row) and its per-frame residuals: every
 * frame for sequences of up to TABLE_MAX frames, otherwise quantiles and
 * the worst frames.
 *
 * The page and each picture are written atomically; on an error no report
 * is left (pictures already written stay: they are complete files).
 */
#include "cmd_report.h"

#include "cli_util.h"
#include "options.h"

#include "atomic_file.h"
#include "file_util.h"
#include "cmd_render.h"
#include "cmd_view.h"
#include "h5layout.h"
#include "job.h"
#include "path_guard.h"
#include "transfer.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* Sequences up to this many frames get a row per frame. */
#define TABLE_MAX 100
/* Worst frames listed for longer sequences. */
#define WORST_N 10
/* Results reported at most (a larger file gets a note). */
#define RESULTS_MAX 4096

typedef struct {
    const char *input, *out, *summary, *count;
    int no_pictures;
} report_args;

static const char *parse_args(int argc, char **argv, report_args *a)
{
    memset(a, 0, sizeof *a);
    for (int i = 2; i < argc; i++) {
        const char *s = argv[i];
        const char **slot = NULL;
        if (strcmp(s, "-o") == 0)
            slot = &a->out;
        else if (strcmp(s, "--summary") == 0)
            slot = &a->summary;
        else if (strcmp(s, "--count") == 0)
            slot = &a->count;
        else if (strcmp(s, "--no-pictures") == 0) {
            a->no_pictures = 1;
            continue;
        } else if (s[0] == '-')
            return "report: unknown option";
        else if (!a->input) {
            a->input = s;
            continue;
        } else
            return "report: more than one input file";
        if (i + 1 >= argc)
            return "report: an option is missing its value";
        *slot = argv[++i];
    }
    if (!a->input)
        return "report needs FILE.h5";
    if (a->count) {
        char *end;
        long n = strtol(a->count, &end, 10);
        if (*end || end == a->count || n < 1 || n > 1024)
            return "report: --count must be a number of frames in 1..1024";
    }
    return NULL;
}

/* path minus a final ".h5" (or ".hdf5"), plus suffix, into out. */
static int derive(const char *path, const char *suffix, char *out, size_t n)
{
    size_t len = strlen(path);
    if (len > 3 && strcmp(path + len - 3, ".h5") == 0)
        len -= 3;
    else if (len > 5 && strcmp(path + len - 5, ".hdf5") == 0)
        len -= 5;
    return (size_t)snprintf(out, n, "%.*s%s", (int)len, path, suffix) < n ? 0 : -1;
}

/* A file name from an HDF5 path: "/results/lion/cat-poses" ->
 * "lion-cat-poses"; characters other than letters, digits, '-', '_', '.'
 * become '_'. */
static void file_name_of(const char *path, char *out, size_t n)
{
    const char *p = strncmp(path, "/results/", 9) == 0 ? path + 9 : path;
    size_t k = 0;
    for (; *p && k + 1 < n; p++) {
        char c = *p;
        if (c == '/')
            c = '-';
        else if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                   c == '-' || c == '_' || c == '.'))
            c = '_';
        out[k++] = c;
    }
    out[k] = 0;
}

/* Markdown-safe text: '|' and newlines would break a table cell. */
static void md_text(FILE *f, const char *s)
{
    for (; s && *s; s++) {
        if (*s == '|')
            fputs("\\|", f);
        else if (*s == '\n' || *s == '\r')
            fputc(' ', f);
        else
            fputc(*s, f);
    }
}

/* The results of the file: /results/<target>/<sequence> (and results
 * directly under /results), skipping temporary groups ("." names). */
static dtx_status list_results(hid_t f, char (*found)[DTX_H5_PATH_MAX], int *n, dtx_error *err)
{
    char **tn = NULL;
    int64_t nt = 0;
    dtx_status st;
    *n = 0;
    if (!dtx_h5_path_exists(f, "/results"))
        return DTX_OK;
    st = dtx_h5_list_groups(f, "/results", &tn, &nt, err);
    for (int64_t i = 0; st == DTX_OK && i < nt; i++) {
        char tp[DTX_H5_PATH_MAX], probe[DTX_H5_PATH_MAX + 16];
        char **sn = NULL;
        int64_t ns = 0;
        if (tn[i][0] == '.' ||
            (size_t)snprintf(tp, sizeof tp, "/results/%s", tn[i]) >= sizeof tp)
            continue;
        snprintf(probe, sizeof probe, "%s/frame_done", tp);
        if (dtx_h5_path_exists(f, probe)) {
            if (*n < RESULTS_MAX)
                memcpy(found[*n], tp, sizeof tp);
            (*n)++;
            continue;
        }
        st = dtx_h5_list_groups(f, tp, &sn, &ns, err);
        for (int64_t j = 0; st == DTX_OK && j < ns; j++) {
            char rp[DTX_H5_PATH_MAX];
            if (sn[j][0] == '.' ||
                (size_t)snprintf(rp, sizeof rp, "%s/%s", tp, sn[j]) >= sizeof rp)
                continue;
            snprintf(probe, sizeof probe, "%s/frame_done", rp);
            if (!dtx_h5_path_exists(f, probe))
                continue;
            if (*n < RESULTS_MAX)
                memcpy(found[*n], rp, sizeof rp);
            (*n)++;
        }
        dtx_h5_free_strings(&sn, ns);
    }
    dtx_h5_free_strings(&tn, nt);
    return st;
}

/* The run summary (cJSON tree) or NULL when absent; a summary that exists
 * but does not parse is an error naming it. */
static dtx_status load_summary(const char *path, int required, cJSON **out, dtx_error *err)
{
    char *text = NULL;
    size_t len = 0;
    struct stat sb;
    dtx_status st;
    *out = NULL;
    if (!required && stat(path, &sb) != 0 && errno == ENOENT)
        return DTX_OK;
    /* A regular file of at most 64 MiB: a FIFO would block the report. */
    if ((st = dtx_file_read_regular(path, (size_t)64 << 20, &text, &len, err)) != DTX_OK) {
        dtx_error_prefix(err, "the run summary");
        return st;
    }
    *out = cJSON_ParseWithLength(text, len);
    free(text);
    if (!*out)
        return dtx_seterr(err, DTX_EPARSE, "%s: the run summary is not valid JSON", path);
    return DTX_OK;
}

static double num(const cJSON *o, const char *key)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
    return cJSON_IsNumber(v) ? v->valuedouble : NAN;
}

/* A table cell: the number with fmt, or "-" when the summary lacks it. */
static void cell(FILE *f, const char *fmt, double v)
{
    fputs("| ", f);
    if (isfinite(v))
        fprintf(f, fmt, v);
    else
        fputc('-', f);
    fputc(' ', f);
}

/* Every rank's phases (the summary's seconds_per_rank), a row per rank:
 * where one rank waits for another or does work the others do not, and
 * the phases the Run table leaves out (creating the output, finishing it,
 * waiting in the frame loop, CPU seconds).  Nothing for a summary without
 * them (an older dtx's summary). */
static void write_ranks(FILE *f, const cJSON *sum)
{
    static const char *const keys[] = {"total", "read",     "keypoints", "correspondence",
                                       "factor", "output",  "transfer",  "write",
                                       "finish", "wait",    "cpu"};
    const cJSON *per = cJSON_GetObjectItemCaseSensitive(sum, "seconds_per_rank");
    const cJSON *r;
    int q = 0;
    if (!cJSON_IsArray(per) || cJSON_GetArraySize(per) < 1)
        return;
    fputs("Phases per rank, in seconds (`write` is the frame loop's writes; `finish` marks the "
          "results complete, closes and renames the output; `wait` is the frame loop waiting "
          "for the other ranks; `cpu` is the process's user + system time):\n\n| rank |",
          f);
    for (size_t i = 0; i < sizeof keys / sizeof *keys; i++)
        fprintf(f, " %s |", keys[i]);
    fputs("\n|---:|", f);
    for (size_t i = 0; i < sizeof keys / sizeof *keys; i++)
        fputs("---:|", f);
    fputc('\n', f);
    cJSON_ArrayForEach(r, per)
    {
        fprintf(f, "| %d ", q++);
        for (size_t i = 0; i < sizeof keys / sizeof *keys; i++)
            cell(f, "%.3f", num(r, keys[i]));
        fputs("|\n", f);
    }
    fputc('\n', f);
}

static void write_run(FILE *f, const cJSON *sum, const char *sum_path)
{
    const cJSON *sec = cJSON_GetObjectItemCaseSensitive(sum, "seconds");
    const cJSON *mode = cJSON_GetObjectItemCaseSensitive(sum, "mode");
    fprintf(f, "## Run\n\nFrom `%s`", dtx_path_base_name(sum_path));
    if (cJSON_IsString(mode))
        fprintf(f, " (%s run)", mode->valuestring);
    fprintf(f,
            ".\n\n| ranks | threads per rank | frames | total s | frames/s | read s | "
            "key points s | correspondence s | factor s | transfer s | write s | "
            "peak memory MiB |\n"
            "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    cell(f, "%.0f", num(sum, "ranks"));
    cell(f, "%.0f", num(sum, "threads_per_rank"));
    cell(f, "%.0f", num(sum, "frames"));
    cell(f, "%.3f", num(sec, "total"));
    cell(f, "%.1f", num(sum, "frames_per_second"));
    cell(f, "%.3f", num(sec, "read"));
    cell(f, "%.3f", num(sec, "keypoints"));
    cell(f, "%.3f", num(sec, "correspondence"));
    cell(f, "%.3f", num(sec, "factor"));
    cell(f, "%.3f", num(sec, "transfer"));
    cell(f, "%.3f", num(sec, "write"));
    cell(f, "%.1f", num(sum, "peak_rss_mb"));
    fputs("|\n\n", f);
    write_ranks(f, sum);
}

static int cmp_dbl(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Keeps worst[0 .. *nw) (at most WORST_N frames) the frames with the
 * largest key, largest first (ties: lower frame first), as frames t are
 * offered in increasing order. */
static void keep_worst(int64_t *worst, int *nw, int64_t t, double (*key)(const void *, int64_t),
                       const void *ctx)
{
    int k;
    double kt = key(ctx, t);
    for (k = *nw; k > 0 && key(ctx, worst[k - 1]) < kt; k--)
        if (k < WORST_N)
            worst[k] = worst[k - 1];
    if (k < WORST_N) {
        worst[k] = t;
        if (*nw < WORST_N)
            (*nw)++;
    }
}

static double residual_key(const void *r, int64_t t) { return ((const double *)r)[t]; }

static double inverted_key(const void *fs, int64_t t)
{
    return ((const int32_t *)fs)[DTX_H5_FRAME_STATS * t + 2];
}

/* What a method's per-frame residual is, and its unit (the definitions are
 * those of src/core: dtx_core.h, transfer_bh.h, springs.h). */
static const char *residual_meaning(const char *method)
{
    if (!method)
        return "the method's per-frame solver residual";
    if (strcmp(method, "sp04") == 0)
        return "sqrt(E / pairs), E the minimised deformation-gradient mismatch: the RMS over "
               "triangle pairs of the Frobenius norm of (source gradient - target gradient); "
               "dimensionless (gradients are length ratios), 0 for a perfect transfer";
    if (strcmp(method, "multicomponent") == 0)
        return "sqrt(E / pairs) of the final Gauss-Newton iterate, E the whole energy "
               "(gradient mismatch, smoothness and proximity terms); dimensionless";
    if (strcmp(method, "springs") == 0)
        return "sqrt(E / sum_e k_e r_e^2): the RMS relative error of the spring lengths "
               "against their stretch-ratio rest lengths; a fraction (0.01 = 1%)";
    if (strcmp(method, "biharmonic") == 0)
        return "the RMS distance between the key-point fit of the source frame and the source "
               "frame, as a fraction of the source's bounding-box diagonal";
    return "the method's per-frame solver residual";
}

/* Per-frame residuals: a row per frame, or quantiles and the worst frames. */
static void write_residuals(FILE *f, const double *r, const uint8_t *done, int64_t T,
                            const char *method)
{
    double *s = NULL;
    int64_t n = 0;
    s = dtx_alloc((size_t)T, sizeof *s, 0);
    if (!s)
        return;
    for (int64_t t = 0; t < T; t++)
        if (done[t] && isfinite(r[t]))
            s[n++] = r[t];
    qsort(s, (size_t)n, sizeof *s, cmp_dbl);
    fprintf(f, "Residual per frame (");
    md_text(f, residual_meaning(method));
    fprintf(f, "):");
    if (n == 0) {
        fprintf(f, " none written.\n\n");
        free(s);
        return;
    }
    fprintf(f, " min %.4g, median %.4g, max %.4g over %lld frames.\n\n", s[0], s[n / 2],
            s[n - 1], (long long)n);
    if (T <= TABLE_MAX) {
        fprintf(f, "| frame | residual |\n|---:|---:|\n");
        for (int64_t t = 0; t < T; t++) {
            if (done[t])
                fprintf(f, "| %lld | %.6g |\n", (long long)t, r[t]);
            else
                fprintf(f, "| %lld | not done |\n", (long long)t);
        }
    } else {
        /* The worst frames, largest first (ties: lower frame first). */
        int64_t worst[WORST_N];
        int nw = 0;
        for (int64_t t = 0; t < T; t++)
            if (done[t] && isfinite(r[t]))
                keep_worst(worst, &nw, t, residual_key, r);
        fprintf(f, "| quantile | residual |\n|---|---:|\n");
        for (int q = 0; q <= 4; q++)
            fprintf(f, "| %d%% | %.6g |\n", 25 * q, s[(n - 1) * q / 4]);
        fprintf(f, "\nWorst frames:\n\n| frame | residual |\n|---:|---:|\n");
        for (int k = 0; k < nw; k++)
            fprintf(f, "| %lld | %.6g |\n", (long long)worst[k], r[worst[k]]);
    }
    fputc('\n', f);
    free(s);
}

static double grad_norm_key(const void *gn, int64_t t) { return ((const double *)gn)[t]; }

/* Methods springs and multicomponent (solver "Newton" or "Gauss-Newton"):
 * the per-frame solver figures (frame_stats rows of T x DTX_H5_FRAME_STATS),
 * summed up, with the frames that did not converge and the frames with the
 * most inverted triangles (where the method counts them: column 2 >= 0).
 * gn: the final gradient norms (frame_grad_norm, T), or NULL when the
 * result has none; with them, the largest in the summary and a table of
 * every frame (up to TABLE_MAX frames) or of the largest. */
static void write_frame_stats(FILE *f, const int32_t *fs, const double *gn, const uint8_t *done,
                              int64_t T, const char *solver)
{
    int64_t n = 0, iters = 0, maxit = 0, unconv = 0, inv_frames = 0, inv_counted = 0;
    int64_t worst[WORST_N], first_unconv[WORST_N];
    int nw = 0, nu = 0;
    for (int64_t t = 0; t < T; t++) {
        const int32_t *row = fs + DTX_H5_FRAME_STATS * t;
        if (!done[t] || row[0] < 0)
            continue;
        n++;
        iters += row[0];
        maxit = row[0] > maxit ? row[0] : maxit;
        if (row[1] == 0) {
            unconv++;
            if (nu < WORST_N)
                first_unconv[nu++] = t;
        }
        inv_counted += row[2] >= 0;
        if (row[2] > 0) {
            inv_frames++;
            keep_worst(worst, &nw, t, inverted_key, fs);
        }
    }
    if (n == 0)
        return;
    fprintf(f, "%s solves (frame_stats): %.1f iterations per frame on average, at most %lld; "
               "%lld of %lld frames stopped before converging",
            solver, (double)iters / (double)n, (long long)maxit, (long long)unconv, (long long)n);
    for (int k = 0; k < nu; k++)
        fprintf(f, "%s%lld", k ? ", " : (unconv == 1 ? " (frame " : " (frames "),
                (long long)first_unconv[k]);
    fprintf(f, "%s", nu ? (unconv > nu ? ", ...)" : ")") : "");
    if (inv_counted > 0)
        fprintf(f, "; %lld frames have inverted triangles", (long long)inv_frames);
    if (gn) {
        const int64_t tmax = dtx_h5_grad_norm_max_frame(gn, fs, done, T);
        if (tmax >= 0)
            fprintf(f, "; final gradient norm at most %.3g (frame %lld)", gn[tmax],
                    (long long)tmax);
    }
    fprintf(f, ".\n\n");
    if (nw > 0) {
        fprintf(f, "| frame | inverted triangles | %s iterations | converged |\n"
                   "|---:|---:|---:|---|\n",
                solver);
        for (int k = 0; k < nw; k++) {
            const int32_t *row = fs + DTX_H5_FRAME_STATS * worst[k];
            fprintf(f, "| %lld | %d | %d | %s |\n", (long long)worst[k], (int)row[2],
                    (int)row[0], row[1] ? "yes" : "no");
        }
        fputc('\n', f);
    }
    if (gn) {
        int64_t order[WORST_N];
        int no = 0;
        if (T > TABLE_MAX)
            for (int64_t t = 0; t < T; t++)
                if (done[t] && fs[DTX_H5_FRAME_STATS * t] >= 0)
                    keep_worst(order, &no, t, grad_norm_key, gn);
        fprintf(f,
                "%s\n\n| frame | final gradient norm | %s iterations | converged |\n"
                "|---:|---:|---:|---|\n",
                T > TABLE_MAX ? "Largest final gradient norms:" : "Final gradient norm per frame:",
                solver);
        for (int64_t k = 0; k < (T > TABLE_MAX ? no : T); k++) {
            const int64_t t = T > TABLE_MAX ? order[k] : k;
            const int32_t *row = fs + DTX_H5_FRAME_STATS * t;
            if (!done[t] || row[0] < 0)
                fprintf(f, "| %lld | not done | | |\n", (long long)t);
            else
                fprintf(f, "| %lld | %.4g | %d | %s |\n", (long long)t, gn[t], (int)row[0],
                        row[1] ? "yes" : "no");
        }
        fputc('\n', f);
    }
}

static void write_attr(FILE *f, hid_t h, const char *path, const char *name, const char *label)
{
    char *v = NULL;
    dtx_error e;
    if (dtx_h5_read_attr_str(h, path, name, &v, &e) == DTX_OK && v && *v) {
        fprintf(f, "- %s: ", label);
        md_text(f, v);
        fputc('\n', f);
    }
    free(v);
}

/* One result's section. */
static dtx_status write_result(FILE *f, hid_t h, const report_args *a, const char *path,
                               const char *pic_dir, const char *pic_link, dtx_error *err)
{
    dtx_h5_result res;
    double *r = NULL;
    uint8_t *done = NULL;
    int64_t complete = 0, ndone = 0;
    int32_t nv = 0, nf = 0;
    char tgt[DTX_H5_PATH_MAX + 16], *tmesh = NULL;
    dtx_status st;
    dtx_error rerr;

    memset(&res, 0, sizeof res);
    if ((st = dtx_h5_result_open(h, path, 0, &res, err)) != DTX_OK)
        return st;
    r = dtx_alloc((size_t)res.nframes, sizeof *r, 0);
    done = dtx_alloc((size_t)res.nframes, 1, 1);
    if (!r || !done) {
        st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
        goto done;
    }
    if ((st = dtx_h5_result_read_done(&res, done, err)) != DTX_OK)
        goto done;
    if (H5Dread(res.residual, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, r) < 0) {
        st = dtx_seterr(err, DTX_EIO, "%s: cannot read the residuals", path);
        goto done;
    }
    for (int64_t t = 0; t < res.nframes; t++)
        ndone += done[t] != 0;
    dtx_h5_read_attr_int(h, path, "complete", &complete, NULL);
    snprintf(tgt, sizeof tgt, "%s/target", path);
    dtx_h5_mesh_size(h, tgt, &nv, &nf, NULL);
    dtx_h5_read_attr_str(h, path, "target_mesh", &tmesh, NULL);

    fprintf(f, "## %s\n\n", path);
    write_attr(f, h, path, "method", "method");
    fprintf(f, "- target: %s (%d vertices, %d faces)\n", tmesh ? tmesh : "?", (int)nv, (int)nf);
    write_attr(f, h, path, "source_sequence", "source sequence");
    write_attr(f, h, path, "correspondence", "correspondence");
    write_attr(f, h, path, "parameters", "parameters");
    write_attr(f, h, path, "dtx_version", "written by dtx");
    fprintf(f, "- frames: %lld, %lld done, %s\n\n", (long long)res.nframes, (long long)ndone,
            complete == 1 ? "complete" : "**not complete** (an interrupted run: `dtx run --resume`)");

    if (!a->no_pictures) {
        char name[DTX_H5_PATH_MAX], png[8192];
        char *argv[9];
        int argc = 0, rc;
        file_name_of(path, name, sizeof name);
        snprintf(png, sizeof png, "%s/%s.png", pic_dir, name);
        argv[argc++] = "dtx";
        argv[argc++] = "render";
        argv[argc++] = (char *)a->input;
        argv[argc++] = (char *)path;
        argv[argc++] = "-o";
        argv[argc++] = png;
        if (a->count) {
            argv[argc++] = "--count";
            argv[argc++] = (char *)a->count;
        }
        argv[argc] = NULL;
        /* A picture that cannot be drawn (the source sequence's file moved
         * away, say) is left out with a warning and a note on the page: the
         * rest of the report is still true, so the report is written. */
        rc = ndone == res.nframes ? dtx_render_sheet(argc, argv, &rerr) : -1;
        if (rc == 0) {
            fprintf(f, "![%s: source above, result below](%s/%s.png)\n\n", path, pic_link, name);
        } else if (rc < 0) {
            fprintf(f, "(No contact sheet: frames missing.)\n\n");
        } else {
            fprintf(stderr, "dtx: warning: %s; the contact sheet of %s is left out of the "
                    "report\n", rerr.msg, path);
            fprintf(f, "(No contact sheet: ");
            md_text(f, rerr.msg);
            fprintf(f, ".)\n\n");
        }
    }
    {
        char *method = NULL;
        dtx_h5_read_attr_str(h, path, "method", &method, NULL);
        write_residuals(f, r, done, res.nframes, method);
        free(method);
    }
    if (res.frame_stats >= 0) {
        int32_t *fs = dtx_alloc((size_t)res.nframes, DTX_H5_FRAME_STATS * sizeof *fs, 0);
        if (!fs) {
            st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
            goto done;
        }
        char *method = NULL, *params = NULL;
        double *gn = NULL;
        const dtx_transfer_method *m;
        const char *solver;
        dtx_transfer_params prm;
        dtx_h5_read_attr_str(h, path, "method", &method, NULL);
        dtx_h5_read_attr_str(h, path, "parameters", &params, NULL);
        /* The solver the result's parameters chose (the method's default one
         * when they do not parse); a result of an unknown method with
         * frame_stats: say "Newton". */
        m = dtx_transfer_method_named(method);
        solver = m && m->solver_name ? m->solver_name : "Newton";
        if (m && dtx_job_params_read(params, &prm) == m && dtx_transfer_solver_name(m, &prm))
            solver = dtx_transfer_solver_name(m, &prm);
        if (res.frame_grad_norm >= 0 && !(gn = dtx_alloc((size_t)res.nframes, sizeof *gn, 0)))
            st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
        if (st == DTX_OK)
            st = dtx_h5_result_read_frame_stats(&res, 0, res.nframes, fs, err);
        if (st == DTX_OK && gn)
            st = dtx_h5_result_read_frame_grad_norm(&res, 0, res.nframes, gn, err);
        if (st == DTX_OK)
            write_frame_stats(f, fs, gn, done, res.nframes, solver);
        free(params);
        free(method);
        free(fs);
        free(gn);
    }
done:
    free(tmesh);
    free(r);
    free(done);
    dtx_h5_result_close(&res);
    return st;
}

int dtx_cmd_report(int argc, char **argv)
{
    report_args a;
    const char *msg;
    char out[4096], sum_path[4096], pic_dir[4096], (*found)[DTX_H5_PATH_MAX] = NULL;
    const char *pic_link;
    hid_t h = H5I_INVALID_HID;
    cJSON *sum = NULL;
    dtx_atomic_file af = {0};
    dtx_error err;
    dtx_status st;
    int n = 0, html;
    char *md = NULL;
    size_t md_n = 0;

    if ((msg = parse_args(argc, argv, &a)) != NULL)
        return dtx_cli_usage(dtx_cli_find_name("report"), msg);
    html = a.out && strlen(a.out) > 5 && strcmp(a.out + strlen(a.out) - 5, ".html") == 0;
    if (html)
        a.no_pictures = 1;
    if (a.out)
        snprintf(out, sizeof out, "%s", a.out);
    else if (derive(a.input, ".report.md", out, sizeof out) != 0)
        return dtx_cli_usage(dtx_cli_find_name("report"), "report: the file name is too long");
    if ((size_t)snprintf(sum_path, sizeof sum_path, "%s.summary.json", a.input) >= sizeof sum_path)
        return dtx_cli_usage(dtx_cli_find_name("report"), "report: the file name is too long");
    if (a.summary)
        snprintf(sum_path, sizeof sum_path, "%s", a.summary);
    {
        size_t len = strlen(out);
        if (len > 3 && strcmp(out + len - 3, ".md") == 0)
            len -= 3;
        if ((size_t)snprintf(pic_dir, sizeof pic_dir, "%.*s-pictures", (int)len, out) >=
            sizeof pic_dir)
            return dtx_cli_usage(dtx_cli_find_name("report"),
                                 "report: the report name is too long");
    }
    pic_link = dtx_path_base_name(pic_dir);
    {
        /* The page and its pictures never replace an input (the result
         * file, the run summary): dtx never writes over its inputs. */
        dtx_path_guard g;
        dtx_path_guard_init(&g);
        st = dtx_path_guard_add(&g, a.input, "the result file", &err);
        if (st == DTX_OK)
            st = dtx_path_guard_add(&g, sum_path, "the run summary", &err);
        if (st == DTX_OK)
            st = dtx_path_guard_check(&g, out, "the report page", &err);
        if (st == DTX_OK && !a.no_pictures)
            st = dtx_path_guard_check(&g, pic_dir, "the pictures folder", &err);
        dtx_path_guard_free(&g);
        if (st == DTX_OK)
            st = dtx_output_path_check(out, "the report page", &err);
        if (st != DTX_OK)
            return dtx_cli_fail(&err);
    }

    found = dtx_alloc(RESULTS_MAX, sizeof *found, 0);
    if (!found) {
        st = dtx_seterr(&err, DTX_ENOMEM, "out of memory");
        goto done;
    }
    if ((st = dtx_h5_open(a.input, MPI_COMM_NULL, 0, &h, &err)) != DTX_OK ||
        (st = list_results(h, found, &n, &err)) != DTX_OK ||
        (st = load_summary(sum_path, a.summary != NULL, &sum, &err)) != DTX_OK)
        goto done;
    if (n == 0) {
        st = dtx_seterr(&err, DTX_EFORMAT, "%s: no results under /results to report on", a.input);
        goto done;
    }
    if (!a.no_pictures && mkdir(pic_dir, 0777) != 0 && errno != EEXIST) {
        st = dtx_seterr(&err, DTX_EIO, "%s: cannot create the pictures directory: %s", pic_dir,
                        strerror(errno));
        goto done;
    }
    if (html) {
        /* REPORT.html: the same text, below a player of the results (which
         * takes the place of the contact sheets); cmd_view.h writes it. */
        if (!(af.fp = open_memstream(&md, &md_n))) {
            st = dtx_seterr(&err, DTX_ENOMEM, "out of memory");
            goto done;
        }
    } else if ((st = dtx_atomic_open(&af, out, &err)) != DTX_OK)
        goto done;
    fprintf(af.fp, "# dtx report: %s\n\n", dtx_path_base_name(a.input));
    fprintf(af.fp, "File `%s`, %d result(s). Written by `dtx report` (dtx %s).\n\n", a.input, n,
            DTX_VERSION);
    if (n > RESULTS_MAX)
        fprintf(af.fp, "Only the first %d results are shown.\n\n", RESULTS_MAX);
    if (sum)
        write_run(af.fp, sum, sum_path);
    else
        fprintf(af.fp, "No run summary (`%s`) next to the file: timings not shown.\n\n",
                dtx_path_base_name(sum_path));
    for (int i = 0; i < n && i < RESULTS_MAX && st == DTX_OK; i++)
        st = write_result(af.fp, h, &a, found[i], pic_dir, pic_link, &err);
    if (html) {
        int bad = fclose(af.fp) != 0;
        af.fp = NULL;
        if (st == DTX_OK && bad)
            st = dtx_seterr(&err, DTX_ENOMEM, "out of memory");
        if (st == DTX_OK && dtx_view_report(a.input, out, md) != 0) {
            free(md);
            md = NULL;
            cJSON_Delete(sum);
            free(found);
            dtx_h5_close(&h, NULL);
            return 1; /* dtx_view_report printed the message */
        }
    } else if (st == DTX_OK)
        st = dtx_atomic_commit(&af, &err);
    else
        dtx_atomic_abort(&af);
    if (st == DTX_OK)
        fprintf(stderr, "dtx: report: %s\n", out);
done:
    free(md);
    cJSON_Delete(sum);
    free(found);
    dtx_h5_close(&h, NULL);
    return st == DTX_OK ? 0 : dtx_cli_fail(&err);
}
