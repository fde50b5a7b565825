/*
 * cmd_inspect.c: `dtx inspect FILE.h5 [--json]`.  Prints what the file
 * holds, kind by kind: meshes (vertices, faces, components, bounds),
 * sequences (frames, vertices, dtype, rest mesh), marker sets,
 * correspondences (pairs and provenance), results (frames done, method,
 * provenance: source, target, correspondence, a hash of the job text, dtx
 * version, residuals) and, when `dtx run` left one next to the file
 * (FILE.summary.json), the run's timings.  Attributes dtx does not know
 * are shown as they are.  Nothing is written.
 */
#include "cmd_inspect.h"

#include "cli_util.h"
#include "options.h"

#include "file_util.h"
#include "h5inspect.h"
#include "h5layout.h"

#include <cjson/cJSON.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Longest attribute value shown in full in the text output. */
#define SHOW_MAX 100

/* Attributes every object of a kind has and that the text output shows in
 * its own words; the others are listed as "name: value". */
static int known_attr(dtx_h5_kind k, const char *name)
{
    static const char *const common[] = {"nv",          "nf",
                                         "nframes",     "content_hash",
                                         "index_base",  "rest_mesh",
                                         "complete",    "method",
                                         "job",         "parameters",
                                         "dtx_version", "source_sequence",
                                         "target_mesh", "correspondence",
                                         "source",      "source_mesh",
                                         "markers",     "key",
                                         "fps"};
    if (k == DTX_H5_KIND_OTHER)
        return 0;
    for (size_t i = 0; i < sizeof common / sizeof *common; i++)
        if (strcmp(name, common[i]) == 0)
            return 1;
    return 0;
}

/* value with newlines as spaces, cut at SHOW_MAX characters. */
static void show(FILE *o, const char *value)
{
    size_t n = strlen(value);
    for (size_t i = 0; i < n && i < SHOW_MAX; i++)
        fputc(value[i] == '\n' || value[i] == '\r' || value[i] == '\t' ? ' ' : value[i], o);
    if (n > SHOW_MAX)
        fprintf(o, "... (%zu characters)", n);
}

static const char *attr(const dtx_h5_item *it, const char *name)
{
    const char *v = dtx_h5_attr_find(it->attrs, it->nattrs, name);
    return v && *v ? v : NULL;
}

static void detail(FILE *o, const char *label, const char *value)
{
    if (!value)
        return;
    fprintf(o, "      %-16s ", label);
    show(o, value);
    fputc('\n', o);
}

/* The frame rate of a sequence or result: its attribute fps, or the 24
 * that exports assume when it has none (files from before the attribute). */
static void frame_rate(FILE *o, const char *fps)
{
    if (fps)
        detail(o, "fps", fps);
    else
        fprintf(o, "      %-16s 24 (none stored; exports assume 24, or take --fps)\n", "fps");
}

static void job_hash(const char *job, char hex[17])
{
    dtx_hash_hex(dtx_hash_bytes(DTX_HASH_INIT, job, strlen(job)), hex);
}

static const char *plural(int64_t n, const char *one, const char *many)
{
    return n == 1 ? one : many;
}

/* ------------------------------------------------------------ text */

/* A sequence's frame file names: every one with all_frames, else the first
 * and last few. */
static void frame_names(FILE *o, const dtx_h5_item *it, int all_frames)
{
    const int64_t head = 4, tail = 2;
    if (!it->frame_names || it->nframes <= 0)
        return;
    fprintf(o, "      %-16s", "frame files");
    for (int64_t f = 0; f < it->nframes; f++) {
        const char *n = it->frame_names[f] ? it->frame_names[f] : "";
        if (all_frames) {
            fprintf(o, "%s%lld: %s", f ? "\n                       " : " ", (long long)f, n);
            continue;
        }
        if (f == head && it->nframes > head + tail + 1) {
            fprintf(o, ", ... (%lld more; dtx inspect --frames lists all)",
                    (long long)(it->nframes - head - tail));
            f = it->nframes - tail - 1;
            continue;
        }
        fprintf(o, "%s%s", f ? ", " : " ", n);
    }
    fputc('\n', o);
}

static void print_item(FILE *o, const dtx_h5_item *it, int all_frames)
{
    fprintf(o, "  %s", it->path);
    if (it->temporary)
        fputs(" (temporary name: a run in progress or interrupted)", o);
    fputs(":", o);
    switch (it->kind) {
    case DTX_H5_KIND_MESH:
        if (it->nv >= 0)
            fprintf(o, " %d vertices, %d faces", (int)it->nv, (int)it->nf);
        if (it->components >= 0)
            fprintf(o, ", %d %s", (int)it->components,
                    plural(it->components, "component", "components"));
        fputc('\n', o);
        if (isfinite(it->bounds[0]))
            fprintf(o, "      %-16s [%.6g, %.6g] x [%.6g, %.6g] x [%.6g, %.6g]\n", "bounds",
                    it->bounds[0], it->bounds[3], it->bounds[1], it->bounds[4], it->bounds[2],
                    it->bounds[5]);
        detail(o, "source", attr(it, "source"));
        detail(o, "content hash", attr(it, "content_hash"));
        break;
    case DTX_H5_KIND_SEQUENCE:
        if (it->nframes >= 0)
            fprintf(o, " %lld frames of %d vertices (%s)", (long long)it->nframes, (int)it->nv,
                    it->is_f64 ? "float64" : "float32");
        fputc('\n', o);
        detail(o, "rest mesh", it->mesh);
        frame_rate(o, attr(it, "fps"));
        frame_names(o, it, all_frames);
        break;
    case DTX_H5_KIND_MARKERS:
        if (it->count >= 0)
            fprintf(o, " %lld markers", (long long)it->count);
        fputc('\n', o);
        detail(o, "source mesh", attr(it, "source_mesh"));
        detail(o, "target mesh", attr(it, "target_mesh"));
        break;
    case DTX_H5_KIND_CORRESPONDENCE:
        if (it->count >= 0)
            fprintf(o, " %lld triangle pairs, source of %d vertices", (long long)it->count,
                    (int)it->nv);
        fputc('\n', o);
        detail(o, "source mesh", attr(it, "source_mesh"));
        detail(o, "target mesh", attr(it, "target_mesh"));
        detail(o, "markers", attr(it, "markers"));
        detail(o, "key", attr(it, "key"));
        detail(o, "parameters", attr(it, "parameters"));
        detail(o, "dtx version", attr(it, "dtx_version"));
        break;
    case DTX_H5_KIND_RESULT: {
        const char *c = attr(it, "complete"), *job = attr(it, "job");
        if (it->nframes >= 0)
            fprintf(o, " %lld of %lld frames done%s, %d vertices (%s)", (long long)it->frames_done,
                    (long long)it->nframes,
                    c && strcmp(c, "1") == 0 ? " (complete)" : " (not complete)", (int)it->nv,
                    it->is_f64 ? "float64" : "float32");
        fputc('\n', o);
        detail(o, "method", attr(it, "method"));
        frame_rate(o, attr(it, "fps"));
        detail(o, "source sequence", attr(it, "source_sequence"));
        detail(o, "target mesh", it->mesh);
        detail(o, "correspondence", attr(it, "correspondence"));
        if (job) {
            char hex[17];
            job_hash(job, hex);
            fprintf(o, "      %-16s %zu bytes, hash %s (FNV-1a 64 of the job text)\n", "job",
                    strlen(job), hex);
        }
        detail(o, "parameters", attr(it, "parameters"));
        detail(o, "dtx version", attr(it, "dtx_version"));
        if (isfinite(it->residual_mean))
            fprintf(o, "      %-16s min %.3g, mean %.3g, max %.3g (frames done)\n", "residual",
                    it->residual_min, it->residual_mean, it->residual_max);
        if (it->frames_converged >= 0) {
            fprintf(o, "      %-16s %lld of %lld frames done converged", "solves",
                    (long long)it->frames_converged, (long long)it->frames_done);
            if (it->grad_norm_max_frame >= 0)
                fprintf(o, "; final gradient norm at most %.3g (frame %lld)", it->grad_norm_max,
                        (long long)it->grad_norm_max_frame);
            fputc('\n', o);
        }
        break;
    }
    default:
        if (it->count >= 0)
            fprintf(o, " %lld %s", (long long)it->count, plural(it->count, "entry", "entries"));
        fputc('\n', o);
        detail(o, "datasets", it->datasets);
    }
    for (int64_t i = 0; i < it->nattrs; i++)
        if (!known_attr(it->kind, it->attrs[i].name))
            detail(o, it->attrs[i].name, it->attrs[i].value);
    detail(o, "problem", it->problem);
}

static double jnum(const cJSON *o, const char *key)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
    return cJSON_IsNumber(v) ? v->valuedouble : NAN;
}

/* The run summary `dtx run` writes next to its output, when present. */
static cJSON *read_run_summary(const char *file, char *path, size_t n)
{
    char *text = NULL;
    size_t len = 0;
    dtx_error e;
    cJSON *j = NULL;
    snprintf(path, n, "%s.summary.json", file);
    /* A summary is a few kilobytes; anything much larger, or not a regular
     * file (a FIFO would block), is not one. */
    if (dtx_file_read_regular(path, (size_t)1 << 24, &text, &len, &e) != DTX_OK)
        return NULL;
    j = cJSON_ParseWithLength(text, len);
    free(text);
    if (j && !cJSON_IsObject(j)) {
        cJSON_Delete(j);
        j = NULL;
    }
    return j;
}

static void print_run_summary(FILE *o, const cJSON *j, const char *path)
{
    static const char *const phases[] = {"read",     "keypoints", "correspondence",
                                         "factor",   "output",    "transfer",
                                         "write",    "finish",    "wait"};
    const cJSON *mode = cJSON_GetObjectItemCaseSensitive(j, "mode"),
                *sec = cJSON_GetObjectItemCaseSensitive(j, "seconds");
    fprintf(o, "run summary (%s):\n", path);
    fprintf(o, "  mode %s, ranks %.0f, threads per rank %.0f, frames computed %.0f, skipped %.0f\n",
            cJSON_IsString(mode) ? mode->valuestring : "?", jnum(j, "ranks"),
            jnum(j, "threads_per_rank"), jnum(j, "frames"), jnum(j, "frames_skipped"));
    if (cJSON_IsObject(sec)) {
        fprintf(o, "  seconds: total %.3g (", jnum(sec, "total"));
        int n = 0;
        /* A phase the summary lacks (an older summary's) is left out. */
        for (size_t i = 0; i < sizeof phases / sizeof *phases; i++)
            if (isfinite(jnum(sec, phases[i])))
                fprintf(o, "%s%s %.3g", n++ ? ", " : "", phases[i], jnum(sec, phases[i]));
        fprintf(o, "), %.3g frames/s\n", jnum(j, "frames_per_second"));
    }
    if (isfinite(jnum(j, "peak_rss_mb")))
        fprintf(o, "  peak memory: %.1f MB\n", jnum(j, "peak_rss_mb"));
}

static void print_text(FILE *o, const char *file, const dtx_h5_summary *s, const cJSON *run,
                       const char *run_path, int all_frames)
{
    const char *v = dtx_h5_attr_find(s->attrs, s->nattrs, "format_version"),
               *by = dtx_h5_attr_find(s->attrs, s->nattrs, "created_by");
    int64_t ntmp = 0;
    fprintf(o, "%s: dtx layout v%s, created by %s\n", file, v ? v : "?", by ? by : "?");
    for (int64_t i = 0; i < s->nattrs; i++) {
        const char *n = s->attrs[i].name;
        if (strcmp(n, "format") == 0 || strcmp(n, "format_version") == 0 ||
            strcmp(n, "created_by") == 0)
            continue;
        if (strcmp(n, "dtx_run_key") == 0)
            fprintf(o, "  written by dtx run; run key %s (hash of the job and its inputs)\n",
                    s->attrs[i].value);
        else {
            fprintf(o, "  %s: ", n);
            show(o, s->attrs[i].value);
            fputc('\n', o);
        }
    }
    for (int64_t i = 0; i < s->nitems; i++)
        ntmp += s->items[i].temporary;
    if (ntmp > 0)
        fprintf(o,
                "  unfinished: %lld %s under a temporary name (a run in progress or "
                "interrupted; dtx run --resume JOB continues it)\n",
                (long long)ntmp, plural(ntmp, "object", "objects"));
    /* Every kind of the layout, in its order; kinds dtx reads in full are
     * listed even when empty, the others only when present. */
    for (int64_t k = 0; k < s->nkinds; k++) {
        int64_t n = 0;
        for (int64_t i = 0; i < s->nitems; i++)
            n += s->items[i].kind_index == k;
        if (n == 0 && s->kinds[k].kind == DTX_H5_KIND_OTHER)
            continue;
        fprintf(o, "%s: %lld\n", s->kinds[k].name, (long long)n);
        for (int64_t i = 0; i < s->nitems; i++)
            if (s->items[i].kind_index == k)
                print_item(o, &s->items[i], all_frames);
    }
    for (int64_t i = 0; i < s->nother; i++)
        fprintf(o, "/%s: not part of the dtx layout\n", s->other[i]);
    if (run)
        print_run_summary(o, run, run_path);
}

/* ------------------------------------------------------------ JSON */

/* Adds v to o under key; marks *oom when anything failed. */
static void jput(cJSON *o, const char *key, cJSON *v, int *oom)
{
    if (!v || !o || !cJSON_AddItemToObject(o, key, v)) {
        cJSON_Delete(v);
        *oom = 1;
    }
}

static cJSON *jattrs(const dtx_h5_attr_text *a, int64_t n, int *oom)
{
    cJSON *o = cJSON_CreateObject();
    for (int64_t i = 0; o && i < n; i++)
        jput(o, a[i].name, cJSON_CreateString(a[i].value ? a[i].value : ""), oom);
    if (!o)
        *oom = 1;
    return o;
}

static cJSON *jcount(int64_t v)
{
    return v >= 0 ? cJSON_CreateNumber((double)v) : cJSON_CreateNull();
}

static cJSON *jdouble(double v) { return isfinite(v) ? cJSON_CreateNumber(v) : cJSON_CreateNull(); }

static cJSON *item_json(const dtx_h5_item *it, int *oom)
{
    cJSON *o = cJSON_CreateObject();
    if (!o) {
        *oom = 1;
        return NULL;
    }
    jput(o, "path", cJSON_CreateString(it->path), oom);
    jput(o, "temporary", cJSON_CreateBool(it->temporary), oom);
    switch (it->kind) {
    case DTX_H5_KIND_MESH: {
        cJSON *b = cJSON_CreateArray();
        jput(o, "vertices", jcount(it->nv), oom);
        jput(o, "faces", jcount(it->nf), oom);
        jput(o, "components", jcount(it->components), oom);
        for (int k = 0; b && k < 6; k++)
            if (!cJSON_AddItemToArray(b, jdouble(it->bounds[k])))
                *oom = 1;
        jput(o, "bounds", b, oom);
        break;
    }
    case DTX_H5_KIND_SEQUENCE:
    case DTX_H5_KIND_RESULT:
        jput(o, "frames", jcount(it->nframes), oom);
        jput(o, "frames_done", jcount(it->frames_done), oom);
        jput(o, "vertices", jcount(it->nv), oom);
        jput(o, "dtype",
             it->nframes >= 0 ? cJSON_CreateString(it->is_f64 ? "float64" : "float32")
                              : cJSON_CreateNull(),
             oom);
        jput(o, "chunk_frames", jcount(it->chunk_frames), oom);
        jput(o, "mesh", it->mesh ? cJSON_CreateString(it->mesh) : cJSON_CreateNull(), oom);
        if (it->frame_names) {
            cJSON *names = cJSON_CreateArray();
            for (int64_t f = 0; names && f < it->nframes; f++)
                if (!cJSON_AddItemToArray(names, cJSON_CreateString(it->frame_names[f]
                                                                        ? it->frame_names[f]
                                                                        : "")))
                    *oom = 1;
            jput(o, "frame_names", names, oom);
        }
        if (it->kind == DTX_H5_KIND_RESULT) {
            const char *job = dtx_h5_attr_find(it->attrs, it->nattrs, "job");
            cJSON *r = cJSON_CreateObject();
            jput(r, "min", jdouble(it->residual_min), oom);
            jput(r, "mean", jdouble(it->residual_mean), oom);
            jput(r, "max", jdouble(it->residual_max), oom);
            jput(o, "residual", r, oom);
            if (it->frames_converged >= 0) {
                cJSON *sv = cJSON_CreateObject();
                jput(sv, "converged_frames", cJSON_CreateNumber((double)it->frames_converged), oom);
                if (it->grad_norm_max_frame >= 0) {
                    jput(sv, "grad_norm_max", jdouble(it->grad_norm_max), oom);
                    jput(sv, "grad_norm_max_frame",
                         cJSON_CreateNumber((double)it->grad_norm_max_frame), oom);
                }
                jput(o, "solves", sv, oom);
            }
            if (job) {
                char hex[17];
                job_hash(job, hex);
                jput(o, "job_hash", cJSON_CreateString(hex), oom);
            }
        }
        break;
    case DTX_H5_KIND_MARKERS:
        jput(o, "markers", jcount(it->count), oom);
        break;
    case DTX_H5_KIND_CORRESPONDENCE:
        jput(o, "pairs", jcount(it->count), oom);
        jput(o, "source_vertices", jcount(it->nv), oom);
        break;
    default:
        jput(o, "entries", jcount(it->count), oom);
        jput(o, "datasets", it->datasets ? cJSON_CreateString(it->datasets) : cJSON_CreateNull(),
             oom);
        break;
    }
    jput(o, "attributes", jattrs(it->attrs, it->nattrs, oom), oom);
    jput(o, "problem", it->problem ? cJSON_CreateString(it->problem) : cJSON_CreateNull(), oom);
    return o;
}

/* Prints the JSON document; returns 0, or -1 when out of memory. */
static int print_json(FILE *o, const char *file, const dtx_h5_summary *s, cJSON *run)
{
    int oom = 0;
    char *text;
    cJSON *root = cJSON_CreateObject(), *other = cJSON_CreateArray();
    cJSON **arr = calloc(s->nkinds > 0 ? (size_t)s->nkinds : 1, sizeof *arr);
    if (!arr) {
        cJSON_Delete(root);
        cJSON_Delete(other);
        cJSON_Delete(run);
        return -1;
    }
    jput(root, "file", cJSON_CreateString(file), &oom);
    jput(root, "attributes", jattrs(s->attrs, s->nattrs, &oom), &oom);
    /* One array per kind of the layout, named after it, empty ones included. */
    for (int64_t k = 0; k < s->nkinds; k++) {
        arr[k] = cJSON_CreateArray();
        jput(root, s->kinds[k].name, arr[k], &oom);
        if (oom)
            arr[k] = NULL;
    }
    for (int64_t i = 0; !oom && i < s->nitems; i++) {
        cJSON *it = item_json(&s->items[i], &oom);
        if (!it || !cJSON_AddItemToArray(arr[s->items[i].kind_index], it)) {
            cJSON_Delete(it);
            oom = 1;
        }
    }
    for (int64_t i = 0; other && i < s->nother; i++)
        if (!cJSON_AddItemToArray(other, cJSON_CreateString(s->other[i])))
            oom = 1;
    jput(root, "other", other, &oom);
    if (run)
        jput(root, "run_summary", run, &oom); /* root owns it now */
    text = oom ? NULL : cJSON_Print(root);
    cJSON_Delete(root);
    free(arr);
    if (!text)
        return -1;
    fprintf(o, "%s\n", text);
    cJSON_free(text);
    return 0;
}

/* ------------------------------------------------------------ command */

int dtx_cmd_inspect(int argc, char **argv)
{
    const char *file = NULL;
    int as_json = 0, all_frames = 0, rc = 0;
    dtx_h5_summary s;
    dtx_error err;
    cJSON *run;
    char run_path[4200];
    for (int i = 2; i < argc; i++) {
        if (strcmp(argv[i], "--json") == 0)
            as_json = 1;
        else if (strcmp(argv[i], "--frames") == 0)
            all_frames = 1;
        else if (argv[i][0] == '-' && argv[i][1] != '\0') {
            char m[256];
            snprintf(m, sizeof m, "inspect: unknown option %.200s", argv[i]);
            return dtx_cli_usage(dtx_cli_find_name("inspect"), m);
        } else if (file)
            return dtx_cli_usage(dtx_cli_find_name("inspect"), "inspect takes one file");
        else
            file = argv[i];
    }
    if (!file)
        return dtx_cli_usage(dtx_cli_find_name("inspect"), "inspect needs a file");
    if (dtx_h5_inspect(file, &s, &err) != DTX_OK)
        return dtx_cli_fail(&err);
    run = read_run_summary(file, run_path, sizeof run_path);
    if (as_json) {
        if (print_json(stdout, file, &s, run) != 0) {
            fprintf(stderr, "dtx: error: out of memory printing the summary\n");
            rc = 1;
        }
        /* print_json took run into its document and freed it. */
    } else {
        print_text(stdout, file, &s, run, run_path, all_frames);
        cJSON_Delete(run);
    }
    dtx_h5_summary_free(&s);
    if (fflush(stdout) != 0) {
        fprintf(stderr, "dtx: error: cannot write the summary to stdout\n");
        rc = 1;
    }
    return rc;
}
