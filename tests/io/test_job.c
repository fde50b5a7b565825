/* test_job.c: job files: the embedded schema, values and defaults of a
 * parsed job, path resolution, every class of error, and the canonical
 * parameter text. */

/* realpath() is an XSI function, not in _POSIX_C_SOURCE alone. */
#ifndef _XOPEN_SOURCE
#define _XOPEN_SOURCE 700
#endif

#include "check.h"
#include "dtx_core.h"
#include "h5layout.h"
#include "job.h"
#include "json_schema.h"

#include <cjson/cJSON.h>
#include <dirent.h>
#include <stdint.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

/* ------------------------------------------------------------------ */
/* Helpers                                                             */
/* ------------------------------------------------------------------ */

#define SRC_OK "{\"file\":\"in.h5\",\"mesh\":\"/meshes/cat\",\"sequences\":[\"/sequences/walk\"]}"
#define TGT_OK                                                                                 \
    "[{\"file\":\"in.h5\",\"mesh\":\"/meshes/lion\",\"markers\":{\"file\":\"in.h5\","          \
    "\"path\":\"/markers/cat-lion\"}}]"
#define OUT_OK "{\"file\":\"out.h5\"}"

/* A job from its parts (NULL = the valid default part); extra is appended
 * after the output object (e.g. ",\"sp04\":{...}"). */
static const char *job_text(const char *source, const char *targets, const char *output,
                            const char *extra)
{
    static char buf[8192];
    snprintf(buf, sizeof buf,
             "{\"dtx_job\":1,\"method\":\"sp04\",\"source\":%s,\"targets\":%s,\"output\":%s%s}",
             source ? source : SRC_OK, targets ? targets : TGT_OK, output ? output : OUT_OK,
             extra ? extra : "");
    return buf;
}

static dtx_status parse(const char *text, const char *base, int check_files, dtx_job *job,
                        dtx_error *err)
{
    return dtx_job_parse(text, strlen(text), "job.json", base, check_files, job, err);
}

/* The text must be rejected with code, and the message must contain want. */
static void expect_fail_(const char *text, const char *base, int check_files, dtx_status code,
                         const char *want, const char *file, int line)
{
    dtx_job job;
    dtx_error err_, *err = &err_;
    dtx_status st;
    memset(err, 0, sizeof *err);
    memset(&job, 0xab, sizeof job); /* must come back zeroed */
    st = parse(text, base, check_files, &job, err);
    if (st == code && strstr(err->msg, want) && job.text == NULL && job.targets == NULL &&
        job.ntargets == 0) {
        check_passed_++;
    } else {
        check_failed_++;
        fprintf(stderr, "%s:%d: %s\n  expected %s containing: %s\n  got      %s: %s\n", file,
                line, text, dtx_status_name(code), want, dtx_status_name(st), err->msg);
    }
    dtx_job_free(&job);
}

#define EXPECT_FAIL(text, want)                                                                \
    expect_fail_(text, "/data/jobs", 0, DTX_EJOB, want, __FILE__, __LINE__)

static char *read_file(const char *path, size_t *len)
{
    FILE *fp = fopen(path, "rb");
    char *buf;
    long n;
    if (!fp)
        return NULL;
    fseek(fp, 0, SEEK_END);
    n = ftell(fp);
    fseek(fp, 0, SEEK_SET);
    buf = malloc((size_t)n + 1);
    if (buf && fread(buf, 1, (size_t)n, fp) != (size_t)n) {
        free(buf);
        buf = NULL;
    }
    fclose(fp);
    if (buf) {
        buf[n] = '\0';
        *len = (size_t)n;
    }
    return buf;
}

static void write_file(const char *path, const char *text)
{
    FILE *fp = fopen(path, "wb");
    CHECK(fp != NULL);
    if (fp) {
        fputs(text, fp);
        fclose(fp);
    }
}

/* ------------------------------------------------------------------ */
/* The schema                                                          */
/* ------------------------------------------------------------------ */

static void test_embedded_schema(void)
{
    size_t len = 0;
    char *file = read_file(DTX_SRC "/schemas/job.schema.json", &len);
    char *embedded = dtx_job_schema_text();
    cJSON *schema, *job;
    char msg[1024];
    CHECK(file != NULL);
    CHECK(embedded != NULL);
    if (file && embedded) {
        CHECK_EQ_INT(strlen(embedded), len);
        CHECK(strcmp(file, embedded) == 0);
        if (strcmp(file, embedded) != 0)
            fprintf(stderr, "the schema built into dtx differs from schemas/job.schema.json: "
                            "re-run the build (cmake/embed.cmake embeds it)\n");
    }
    /* The schema is one the validator fully understands. */
    schema = embedded ? cJSON_Parse(embedded) : NULL;
    job = cJSON_Parse(job_text(NULL, NULL, NULL, NULL));
    CHECK(schema != NULL);
    CHECK_EQ_INT(dtx_json_validate(schema, job, msg, sizeof msg), DTX_OK);
    cJSON_Delete(job);
    cJSON_Delete(schema);
    free(file);
    free(embedded);
}

/* The "default" values the schema documents are the ones the parser fills
 * in. */
static void test_schema_defaults(void)
{
    char *text = dtx_job_schema_text();
    cJSON *schema = text ? cJSON_Parse(text) : NULL;
    const cJSON *defs = cJSON_GetObjectItemCaseSensitive(schema, "$defs");
    const cJSON *sp = cJSON_GetObjectItemCaseSensitive(
        cJSON_GetObjectItemCaseSensitive(defs, "sp04"), "properties");
    const cJSON *out = cJSON_GetObjectItemCaseSensitive(
        cJSON_GetObjectItemCaseSensitive(defs, "output"), "properties");
    const cJSON *tgt = cJSON_GetObjectItemCaseSensitive(
        cJSON_GetObjectItemCaseSensitive(defs, "target"), "properties");
    const cJSON *d, *w;
    dtx_job job;
    dtx_error err_, *err = &err_;
    int i = 0;

#define DEFAULT_OF(props, key)                                                                 \
    cJSON_GetObjectItemCaseSensitive(cJSON_GetObjectItemCaseSensitive(props, key), "default")

    CHECK(sp != NULL && out != NULL && tgt != NULL);
    CHECK_OK(parse(job_text(NULL, NULL, NULL, NULL), "/data/jobs", 0, &job, err), err);
    d = DEFAULT_OF(sp, "w_smooth");
    CHECK(cJSON_IsNumber(d) && d->valuedouble == job.sp04.w_smooth);
    d = DEFAULT_OF(sp, "w_identity");
    CHECK(cJSON_IsNumber(d) && d->valuedouble == job.sp04.w_identity);
    d = DEFAULT_OF(sp, "max_distance");
    CHECK(cJSON_IsNumber(d) && d->valuedouble == job.sp04.max_distance);
    d = DEFAULT_OF(sp, "max_angle_deg");
    CHECK(cJSON_IsNumber(d) && d->valuedouble == job.sp04.max_angle_deg);
    d = DEFAULT_OF(sp, "weights");
    CHECK(cJSON_IsString(d) && strcmp(d->valuestring, "area") == 0 &&
          job.sp04.weights == DTX_CORR_WEIGHTS_AREA);
    d = DEFAULT_OF(sp, "w_closest");
    CHECK(cJSON_IsArray(d));
    CHECK_EQ_INT(cJSON_GetArraySize(d), job.sp04.n_closest);
    cJSON_ArrayForEach(w, d) {
        CHECK(i < job.sp04.n_closest && w->valuedouble == job.sp04.w_closest[i]);
        i++;
    }
    d = DEFAULT_OF(out, "block_frames");
    CHECK(cJSON_IsNumber(d) && d->valuedouble == job.block_frames);
    d = DEFAULT_OF(out, "dtype");
    CHECK(cJSON_IsString(d) && strcmp(d->valuestring, "float32") == 0);
    CHECK_EQ_INT(job.output_dtype, DTX_DTYPE_FLOAT32);
    d = DEFAULT_OF(tgt, "translation");
    CHECK(cJSON_IsString(d) && strcmp(d->valuestring, "fixed") == 0);
    CHECK_EQ_INT(job.targets[0].translation, DTX_TRANSLATION_FIXED);
#undef DEFAULT_OF
    dtx_job_free(&job);
    cJSON_Delete(schema);
    free(text);
}

/* ------------------------------------------------------------------ */
/* Valid jobs                                                          */
/* ------------------------------------------------------------------ */

static void test_full_job(void)
{
    const char *text =
        "{\n"
        "  \"dtx_job\": 1,\n"
        "  \"method\": \"sp04\",\n"
        "  \"source\": {\"file\": \"../data/anim.h5\", \"mesh\": \"/meshes/cat\",\n"
        "             \"sequences\": [\"/sequences/walk\", \"/sequences/run\"]},\n"
        "  \"targets\": [\n"
        "    {\"name\": \"big-lion\", \"file\": \"/abs/lion.h5\", \"mesh\": \"/meshes/lion\",\n"
        "     \"markers\": {\"csv\": \"./m/./lion.csv\", \"index_base\": 1},\n"
        "     \"translation\": \"pins\",\n"
        "     \"pins\": [{\"vertex\": 7, \"position\": [1, -2.5, 3e-3]},\n"
        "              {\"vertex\": 0, \"position\": [0, 0, 0]}]},\n"
        "    {\"file\": \"horse.h5\", \"mesh\": \"/meshes/horse/\",\n"
        "     \"markers\": {\"file\": \"m.h5\", \"path\": \"/markers/cat-horse\"},\n"
        "     \"translation\": \"follow\"}\n"
        "  ],\n"
        "  \"output\": {\"file\": \"out/result.h5\", \"dtype\": \"float64\",\n"
        "             \"export_obj_dir\": \"objs\", \"block_frames\": 16},\n"
        "  \"correspondence_store\": \"../store\",\n"
        "  \"sp04\": {\"w_smooth\": 2.5, \"w_identity\": 0.5, \"w_closest\": [3, 4],\n"
        "           \"max_distance\": 0.25, \"max_angle_deg\": 180, \"weights\": \"element\"}\n"
        "}\n";
    dtx_job job;
    dtx_error err_, *err = &err_;
    const dtx_job_target *t;
    CHECK_OK(parse(text, "/data/jobs", 0, &job, err), err);
    CHECK_EQ_INT(job.version, 1);
    CHECK_EQ_INT(job.method, DTX_METHOD_SP04);
    CHECK(job.text && strcmp(job.text, text) == 0);
    CHECK(job.job_path && strcmp(job.job_path, "job.json") == 0);
    /* Relative paths are resolved against the base directory; leading ".."
     * goes up from it, "." disappears, absolute paths stay. */
    CHECK(strcmp(job.source_file, "/data/data/anim.h5") == 0);
    CHECK(strcmp(job.source_mesh, "/meshes/cat") == 0);
    CHECK_EQ_INT(job.nsequences, 2);
    CHECK(strcmp(job.sequences[0], "/sequences/walk") == 0);
    CHECK(strcmp(job.sequences[1], "/sequences/run") == 0);
    CHECK_EQ_INT(job.ntargets, 2);

    t = &job.targets[0];
    CHECK(strcmp(t->name, "big-lion") == 0);
    CHECK(strcmp(t->file, "/abs/lion.h5") == 0);
    CHECK(strcmp(t->mesh, "/meshes/lion") == 0);
    CHECK(t->markers.csv && strcmp(t->markers.csv, "/data/jobs/m/lion.csv") == 0);
    CHECK_EQ_INT(t->markers.index_base, 1);
    CHECK(t->markers.file == NULL && t->markers.path == NULL);
    CHECK_EQ_INT(t->translation, DTX_TRANSLATION_PINS);
    CHECK_EQ_INT(t->npins, 2);
    CHECK_EQ_INT(t->pins[0].vertex, 7);
    CHECK(t->pins[0].pos[0] == 1.0 && t->pins[0].pos[1] == -2.5 && t->pins[0].pos[2] == 3e-3);
    CHECK_EQ_INT(t->pins[1].vertex, 0);

    t = &job.targets[1];
    /* The name defaults to the mesh path's base name. */
    CHECK(strcmp(t->name, "horse") == 0);
    CHECK(strcmp(t->file, "/data/jobs/horse.h5") == 0);
    CHECK(t->markers.csv == NULL);
    CHECK(t->markers.file && strcmp(t->markers.file, "/data/jobs/m.h5") == 0);
    CHECK(t->markers.path && strcmp(t->markers.path, "/markers/cat-horse") == 0);
    CHECK_EQ_INT(t->translation, DTX_TRANSLATION_FOLLOW);
    CHECK_EQ_INT(t->npins, 0);

    CHECK(strcmp(job.output_file, "/data/jobs/out/result.h5") == 0);
    CHECK_EQ_INT(job.output_dtype, DTX_DTYPE_FLOAT64);
    CHECK(job.export_obj_dir && strcmp(job.export_obj_dir, "/data/jobs/objs") == 0);
    /* A leading ".." goes up from the job's (canonical) directory. */
    CHECK(job.corr_store && strcmp(job.corr_store, "/data/store") == 0);
    CHECK_EQ_INT(job.block_frames, 16);
    CHECK(job.sp04.w_smooth == 2.5);
    CHECK(job.sp04.w_identity == 0.5);
    CHECK_EQ_INT(job.sp04.n_closest, 2);
    CHECK(job.sp04.w_closest[0] == 3.0 && job.sp04.w_closest[1] == 4.0);
    CHECK(job.sp04.max_distance == 0.25);
    CHECK(job.sp04.max_angle_deg == 180.0);
    CHECK_EQ_INT(job.sp04.weights, DTX_CORR_WEIGHTS_ELEMENT);
    dtx_job_free(&job);
    /* dtx_job_free zeroes, so a second call is harmless. */
    CHECK(job.text == NULL && job.targets == NULL && job.ntargets == 0);
    dtx_job_free(&job);
    dtx_job_free(NULL);
}

static void test_defaults(void)
{
    dtx_job job;
    dtx_error err_, *err = &err_;
    CHECK_OK(parse(job_text(NULL, NULL, NULL, NULL), "/data/jobs", 0, &job, err), err);
    CHECK_EQ_INT(job.output_dtype, DTX_DTYPE_FLOAT32);
    CHECK_EQ_INT(job.block_frames, 64);
    CHECK(job.export_obj_dir == NULL);
    CHECK(job.corr_store == NULL);
    CHECK_EQ_INT(job.targets[0].translation, DTX_TRANSLATION_FIXED);
    CHECK(strcmp(job.targets[0].name, "lion") == 0);
    CHECK(job.sp04.w_smooth == 1.0);
    CHECK(job.sp04.w_identity == 0.3);
    CHECK_EQ_INT(job.sp04.n_closest, 6);
    CHECK(job.sp04.w_closest[0] == 1 && job.sp04.w_closest[1] == 100 &&
          job.sp04.w_closest[2] == 5000 && job.sp04.w_closest[5] == 5000);
    CHECK(job.sp04.max_distance == 0.1);
    CHECK(job.sp04.max_angle_deg == 90.0);
    dtx_job_free(&job);

    /* Given sp04 keys override one by one; the others keep defaults. */
    CHECK_OK(parse(job_text(NULL, NULL, NULL, ",\"sp04\":{\"max_distance\":0.05}"), "/data/jobs",
                   0, &job, err),
             err);
    CHECK(job.sp04.max_distance == 0.05);
    CHECK(job.sp04.w_smooth == 1.0);
    CHECK_EQ_INT(job.sp04.n_closest, 6);
    dtx_job_free(&job);

    /* No name, no base directory: messages say "job", paths are relative
     * to the current directory. */
    {
        const char *t = job_text(NULL, NULL, NULL, NULL);
        char cwd[4096], want[4200];
        CHECK(getcwd(cwd, sizeof cwd) != NULL);
        CHECK_OK(dtx_job_parse(t, strlen(t), NULL, NULL, 0, &job, err), err);
        CHECK(job.job_path == NULL);
        snprintf(want, sizeof want, "%s/in.h5", strcmp(cwd, "/") ? cwd : "");
        CHECK(job.source_file && strcmp(job.source_file, want) == 0);
        dtx_job_free(&job);
        t = "{\"dtx_job\":3}";
        CHECK_EQ_INT(dtx_job_parse(t, strlen(t), NULL, NULL, 0, &job, err), DTX_EJOB);
        CHECK(strcmp(err->msg, "job: at /dtx_job: expected 1, got 3") == 0);
    }

    /* The springs object: parsed, unknown keys and bad values rejected. */
    CHECK_OK(parse(job_text(NULL, NULL, NULL,
                            ",\"springs\":{\"levels\":2,\"start\":\"rest\",\"bending\":false,"
                            "\"tol\":1e-6},\"multicomponent\":{}"),
                   "/data/jobs", 0, &job, err),
             err);
    CHECK_EQ_INT(job.springs.levels, 2);
    CHECK_EQ_INT(job.springs.start, DTX_SPRINGS_START_REST);
    CHECK_EQ_INT(job.springs.bending, 0);
    CHECK_EQ_INT(job.springs.internal, 1);
    CHECK(job.springs.tol == 1e-6);
    CHECK_EQ_INT(job.springs.max_iter, 100);
    CHECK_EQ_INT(job.springs.barrier, 1);
    dtx_job_free(&job);
    CHECK_OK(
        parse(job_text(NULL, NULL, NULL, ",\"springs\":{\"start\":\"sp04\",\"barrier\":false}"),
              "/data/jobs", 0, &job, err),
        err);
    CHECK_EQ_INT(job.springs.start, DTX_SPRINGS_START_SP04);
    CHECK_EQ_INT(job.springs.barrier, 0);
    dtx_job_free(&job);
    EXPECT_FAIL(job_text(NULL, NULL, NULL, ",\"springs\":{\"anything\":1}"),
                "at /springs: unknown key \"anything\"");
    EXPECT_FAIL(job_text(NULL, NULL, NULL, ",\"springs\":{\"levels\":9}"),
                "at /springs/levels:");
    EXPECT_FAIL(job_text(NULL, NULL, NULL, ",\"springs\":{\"start\":\"coarse\"}"),
                "at /springs/start: expected one of sp04, linear, rest");
}

/* Every other example job parses, with its method (files need not exist). */
static void test_example_jobs(void)
{
    static const struct {
        const char *file;
        dtx_method method;
    } ex[] = {{"cat-lion-biharmonic.json", DTX_METHOD_BIHARMONIC},
              {"cat-lion-springs.json", DTX_METHOD_SPRINGS}};
    for (size_t i = 0; i < sizeof ex / sizeof *ex; i++) {
        char path[4096];
        size_t len = 0;
        char *text;
        dtx_job job;
        dtx_error err_, *err = &err_;
        snprintf(path, sizeof path, "%s/jobs/%s", DTX_SRC, ex[i].file);
        text = read_file(path, &len);
        CHECK(text != NULL);
        if (!text)
            continue;
        CHECK_OK(dtx_job_parse(text, len, path, DTX_SRC "/jobs", 0, &job, err), err);
        CHECK_EQ_INT(job.method, ex[i].method);
        dtx_job_free(&job);
        free(text);
    }
}

/* jobs/cat-lion.json, the demo job, parses (its files need not exist). */
static void test_demo_job(void)
{
    size_t len = 0;
    char *text = read_file(DTX_SRC "/jobs/cat-lion.json", &len);
    char *src = realpath(DTX_SRC, NULL), want[4096];
    dtx_job job;
    dtx_error err_, *err = &err_;
    CHECK(text != NULL && src != NULL);
    if (!text || !src) {
        free(text);
        free(src);
        return;
    }
    CHECK_OK(dtx_job_parse(text, len, "jobs/cat-lion.json", DTX_SRC "/jobs", 0, &job, err),
             err);
    CHECK_EQ_INT(job.method, DTX_METHOD_SP04);
    snprintf(want, sizeof want, "%s/build/demo/cat-lion.h5", src);
    CHECK(job.source_file && strcmp(job.source_file, want) == 0);
    CHECK(strcmp(job.source_mesh, "/meshes/cat") == 0);
    CHECK_EQ_INT(job.nsequences, 1);
    CHECK(strcmp(job.sequences[0], "/sequences/cat-poses") == 0);
    CHECK_EQ_INT(job.ntargets, 1);
    CHECK(strcmp(job.targets[0].name, "lion") == 0);
    CHECK(strcmp(job.targets[0].file, want) == 0);
    CHECK(strcmp(job.targets[0].mesh, "/meshes/lion") == 0);
    CHECK(job.targets[0].markers.file && strcmp(job.targets[0].markers.file, want) == 0);
    CHECK(job.targets[0].markers.path &&
          strcmp(job.targets[0].markers.path, "/markers/cat-lion") == 0);
    snprintf(want, sizeof want, "%s/build/demo/cat-lion-result.h5", src);
    CHECK(strcmp(job.output_file, want) == 0);
    snprintf(want, sizeof want, "%s/build/demo/lion-obj", src);
    CHECK(job.export_obj_dir && strcmp(job.export_obj_dir, want) == 0);
    CHECK_EQ_INT(job.output_dtype, DTX_DTYPE_FLOAT32);
    CHECK(job.sp04.w_identity == 0.001);
    dtx_job_free(&job);
    free(text);
    free(src);
}

/* ------------------------------------------------------------------ */
/* Errors                                                              */
/* ------------------------------------------------------------------ */

static void test_unknown_keys(void)
{
    char text[8192];
    snprintf(text, sizeof text, "%s", job_text(NULL, NULL, NULL, ",\"methd\":\"sp04\""));
    EXPECT_FAIL(text, "job.json: at the top level: unknown key \"methd\" (allowed: dtx_job, "
                      "method, source, targets, output, correspondence_store, sp04, "
                      "multicomponent, springs, biharmonic)");
    EXPECT_FAIL(job_text("{\"file\":\"a.h5\",\"mesh\":\"/m\",\"sequences\":[\"/s\"],"
                         "\"frames\":3}",
                         NULL, NULL, NULL),
                "job.json: at /source: unknown key \"frames\" (allowed: file, mesh, sequences, weld_tolerance)");
    EXPECT_FAIL(job_text(NULL,
                         "[{\"file\":\"a.h5\",\"mesh\":\"/m\",\"markers\":{\"csv\":\"m.csv\","
                         "\"idx_base\":0}}]",
                         NULL, NULL),
                "job.json: at /targets/0/markers: unknown key \"idx_base\" (allowed: csv, "
                "index_base, file, path)");
    EXPECT_FAIL(job_text(NULL,
                         "[{\"file\":\"a.h5\",\"mesh\":\"/m\",\"markers\":{\"file\":\"a.h5\","
                         "\"path\":\"/k\"},\"pins\":[{\"vertex\":1,\"position\":[0,0,0],"
                         "\"weight\":2}]}]",
                         NULL, NULL),
                "at /targets/0/pins/0: unknown key \"weight\" (allowed: vertex, position)");
    EXPECT_FAIL(job_text(NULL, NULL, "{\"file\":\"o.h5\",\"format\":\"h5\"}", NULL),
                "at /output: unknown key \"format\" (allowed: file, dtype, export_obj_dir, "
                "block_frames, io)");
    EXPECT_FAIL(job_text(NULL, NULL, NULL, ",\"sp04\":{\"w_smoth\":1}"),
                "at /sp04: unknown key \"w_smoth\"");
}

static void test_schema_violations(void)
{
    /* Wrong types. */
    EXPECT_FAIL(job_text("{\"file\":5,\"mesh\":\"/m\",\"sequences\":[\"/s\"]}", NULL, NULL, NULL),
                "job.json: at /source/file: expected a string, got 5");
    EXPECT_FAIL(job_text("{\"file\":\"a\",\"mesh\":\"/m\",\"sequences\":\"/s\"}", NULL, NULL,
                         NULL),
                "at /source/sequences: expected an array, got \"/s\"");
    EXPECT_FAIL(job_text(NULL, "{}", NULL, NULL), "at /targets: expected an array, got an object");
    EXPECT_FAIL(job_text(NULL, NULL, "{\"file\":\"o.h5\",\"block_frames\":8.5}", NULL),
                "at /output/block_frames: expected an integer, got 8.5");
    EXPECT_FAIL("[1]", "job.json: at the top level: expected an object, got an array");
    /* Missing required fields. */
    EXPECT_FAIL("{\"dtx_job\":1,\"method\":\"sp04\"}",
                "job.json: at the top level: missing required key \"source\"");
    EXPECT_FAIL(job_text("{\"file\":\"a.h5\",\"sequences\":[\"/s\"]}", NULL, NULL, NULL),
                "job.json: at /source: missing required key \"mesh\"");
    EXPECT_FAIL(job_text(NULL, NULL, "{\"dtype\":\"float32\"}", NULL),
                "at /output: missing required key \"file\"");
    /* Markers: required except with method springs. */
    EXPECT_FAIL(job_text(NULL, "[{\"file\":\"a.h5\",\"mesh\":\"/m\"}]", NULL, NULL),
                "job.json: at /targets/0: missing required key \"markers\" (only method "
                "springs");
    {
        char t[8192];
        dtx_job job;
        dtx_error e;
        char *m;
        snprintf(t, sizeof t, "%s", job_text(NULL, "[{\"file\":\"a.h5\",\"mesh\":\"/m\"}]", NULL, NULL));
        m = strstr(t, "\"sp04\"");
        CHECK(m != NULL);
        if (m) {
            char u[8192];
            snprintf(u, sizeof u, "%.*s\"springs\"%s", (int)(m - t), t, m + 6);
            CHECK_OK(parse(u, "/data", 0, &job, &e), &e);
            CHECK(job.targets && !job.targets[0].markers.csv && !job.targets[0].markers.file);
            dtx_job_free(&job);
        }
    }
    EXPECT_FAIL(job_text(NULL, "[{\"file\":\"a.h5\",\"mesh\":\"/m\",\"markers\":{}}]", NULL, NULL),
                "at /targets/0/markers: matches none of the allowed forms: CSV markers");
    /* Bad enums and constants. */
    EXPECT_FAIL(job_text(NULL, NULL, "{\"file\":\"o.h5\",\"dtype\":\"float16\"}", NULL),
                "job.json: at /output/dtype: expected one of float32, float64, got \"float16\"");
    EXPECT_FAIL("{\"dtx_job\":2}", "job.json: at /dtx_job: expected 1, got 2");
    EXPECT_FAIL("{\"dtx_job\":1.5,\"method\":\"sp04\"}",
                "job.json: at /dtx_job: expected an integer, got 1.5");
    EXPECT_FAIL("{\"dtx_job\":1,\"method\":\"sp05\"}",
                "at /method: expected one of sp04, multicomponent, springs, biharmonic, got "
                "\"sp05\"");
    EXPECT_FAIL(job_text(NULL,
                         "[{\"file\":\"a.h5\",\"mesh\":\"/m\",\"translation\":\"float\","
                         "\"markers\":{\"file\":\"a\",\"path\":\"/p\"}}]",
                         NULL, NULL),
                "at /targets/0/translation: expected one of fixed, follow, pins, got \"float\"");
    /* Out of range numbers. */
    EXPECT_FAIL(job_text(NULL, NULL, "{\"file\":\"o.h5\",\"block_frames\":0}", NULL),
                "at /output/block_frames: expected an integer in [1, 65536], got 0");
    EXPECT_FAIL(job_text(NULL, NULL, "{\"file\":\"o.h5\",\"block_frames\":65537}", NULL),
                "at /output/block_frames: expected an integer in [1, 65536], got 65537");
    EXPECT_FAIL(job_text(NULL, NULL, NULL, ",\"sp04\":{\"w_smooth\":0}"),
                "at /sp04/w_smooth: expected a number > 0, got 0");
    EXPECT_FAIL(job_text(NULL, NULL, NULL, ",\"sp04\":{\"max_angle_deg\":180.5}"),
                "at /sp04/max_angle_deg: expected a number in (0, 180], got 180.5");
    EXPECT_FAIL(job_text(NULL, NULL, NULL, ",\"sp04\":{\"w_closest\":[1,-1]}"),
                "at /sp04/w_closest/1: expected a number >= 0, got -1");
    EXPECT_FAIL(job_text(NULL, NULL, NULL,
                         ",\"sp04\":{\"w_closest\":[1,2,3,4,5,6,7,8,9,10,11,12,13,14,15,16,17]}"),
                "at /sp04/w_closest: expected an array of 1 to 16 numbers, got 17 items");
    EXPECT_FAIL(job_text(NULL, NULL, NULL, ",\"sp04\":{\"w_closest\":[]}"),
                "at /sp04/w_closest: expected an array of 1 to 16 numbers, got 0 items");
    EXPECT_FAIL(job_text(NULL,
                         "[{\"file\":\"a.h5\",\"mesh\":\"/m\",\"markers\":{\"file\":\"a\","
                         "\"path\":\"/p\"},\"pins\":[{\"vertex\":-1,\"position\":[0,0,0]}]}]",
                         NULL, NULL),
                "at /targets/0/pins/0/vertex: expected an integer in [0, 2147483647], got -1");
    EXPECT_FAIL(job_text(NULL,
                         "[{\"file\":\"a.h5\",\"mesh\":\"/m\",\"markers\":{\"file\":\"a\","
                         "\"path\":\"/p\"},\"pins\":[{\"vertex\":1,\"position\":[0,0,0]},"
                         "{\"vertex\":2,\"position\":[0,0]}]}]",
                         NULL, NULL),
                "at /targets/0/pins/1/position: expected an array of 3 numbers, got 2 items");
    EXPECT_FAIL(job_text(NULL, NULL, NULL, ",\"sp04\":{\"max_distance\":1e400}"),
                "at /sp04/max_distance: number out of range (not finite)");
    /* Empty lists and strings, bad names. */
    EXPECT_FAIL(job_text(NULL, "[]", NULL, NULL),
                "at /targets: expected a non-empty array of objects, got an empty array");
    EXPECT_FAIL(job_text("{\"file\":\"a.h5\",\"mesh\":\"/m\",\"sequences\":[]}", NULL, NULL, NULL),
                "at /source/sequences: expected a non-empty array of strings, got an empty "
                "array");
    EXPECT_FAIL(job_text(NULL, NULL, "{\"file\":\"\"}", NULL),
                "at /output/file: expected a non-empty string, got \"\"");
    EXPECT_FAIL(job_text(NULL,
                         "[{\"name\":\"big lion\",\"file\":\"a.h5\",\"mesh\":\"/m\","
                         "\"markers\":{\"file\":\"a\",\"path\":\"/p\"}}]",
                         NULL, NULL),
                "[A-Za-su-z0-9_.-][A-Za-z0-9_.-]*)?)$, got \"big lion\"");
    /* Repeated keys would otherwise be silently ignored by a lookup. */
    EXPECT_FAIL(job_text(NULL, NULL, "{\"file\":\"o.h5\",\"file\":\"p.h5\"}", NULL),
                "at /output: duplicate key \"file\"");
}

static void test_syntax_errors(void)
{
    const char *missing_colon = "{\n  \"dtx_job\": 1,\n  \"method\" \"sp04\"\n}\n";
    const char *trailing = "{\"dtx_job\": 1}\n\n  x";
    dtx_job job;
    dtx_error err_, *err = &err_;
    expect_fail_(missing_colon, "/data", 0, DTX_EPARSE, "job.json:3:", __FILE__, __LINE__);
    expect_fail_(missing_colon, "/data", 0, DTX_EPARSE, "JSON syntax error", __FILE__,
                 __LINE__);
    expect_fail_("{\"dtx_job\": 1,\n\"method\": \"sp04\",\n\n\"source\": {,}}", "/data", 0,
                 DTX_EPARSE, "job.json:4:", __FILE__, __LINE__);
    expect_fail_(trailing, "/data", 0, DTX_EPARSE,
                 "job.json:3:3: JSON syntax error: text after the end of the JSON value near 'x'",
                 __FILE__, __LINE__);
    expect_fail_("{\"dtx_job\": 1,\n \"method\": \"sp", "/data", 0, DTX_EPARSE, "job.json:2:",
                 __FILE__, __LINE__);
    expect_fail_("", "/data", 0, DTX_EPARSE, "job.json: empty job file", __FILE__, __LINE__);
    expect_fail_(" \n\t ", "/data", 0, DTX_EPARSE, "job.json: empty job file", __FILE__, __LINE__);
    /* Control bytes are shown escaped. */
    expect_fail_("{\"a\" 1\x01}", "/data", 0, DTX_EPARSE, "job.json:1:6: JSON syntax error: "
                 "unexpected text near '1\\x01}'", __FILE__, __LINE__);
    /* A length that stops inside the text is honoured (no reading past it). */
    memset(err, 0, sizeof *err);
    CHECK_EQ_INT(dtx_job_parse("{\"dtx_job\": 1}", 5, "job.json", "/data", 0, &job, err),
                 DTX_EPARSE);
    CHECK(strstr(err->msg, "job.json:1:") != NULL);
}

static void test_cross_field(void)
{
    /* csv markers need index_base (the schema's CSV form requires it). */
    EXPECT_FAIL(job_text(NULL,
                         "[{\"file\":\"a.h5\",\"mesh\":\"/m\",\"markers\":{\"csv\":\"m.csv\"}}]",
                         NULL, NULL),
                "job.json: at /targets/0/markers: missing required key \"index_base\" (for CSV "
                "markers)");
    /* csv and HDF5 markers cannot be mixed. */
    EXPECT_FAIL(job_text(NULL,
                         "[{\"file\":\"a.h5\",\"mesh\":\"/m\",\"markers\":{\"csv\":\"m.csv\","
                         "\"index_base\":0,\"file\":\"a.h5\"}}]",
                         NULL, NULL),
                "at /targets/0/markers: key \"file\" is not allowed here (for CSV markers)");
    /* Translation and pins. */
    EXPECT_FAIL(job_text(NULL,
                         "[{\"file\":\"a.h5\",\"mesh\":\"/m\",\"translation\":\"pins\","
                         "\"markers\":{\"file\":\"a\",\"path\":\"/p\"}}]",
                         NULL, NULL),
                "job.json: at /targets/0/translation: translation \"pins\" needs at least one "
                "pin");
    EXPECT_FAIL(job_text(NULL,
                         "[{\"file\":\"a.h5\",\"mesh\":\"/m\",\"translation\":\"pins\",\"pins\":[],"
                         "\"markers\":{\"file\":\"a\",\"path\":\"/p\"}}]",
                         NULL, NULL),
                "at /targets/0/translation: translation \"pins\" needs at least one pin");
    EXPECT_FAIL(job_text(NULL,
                         "[{\"file\":\"a.h5\",\"mesh\":\"/m\",\"translation\":\"follow\","
                         "\"pins\":[{\"vertex\":3,\"position\":[0,0,0]}],"
                         "\"markers\":{\"file\":\"a\",\"path\":\"/p\"}}]",
                         NULL, NULL),
                "at /targets/0/pins: pins cannot be used with translation \"follow\"");
    EXPECT_FAIL(job_text(NULL,
                         "[{\"file\":\"a.h5\",\"mesh\":\"/m\",\"pins\":["
                         "{\"vertex\":3,\"position\":[0,0,0]},{\"vertex\":4,\"position\":[0,0,0]},"
                         "{\"vertex\":3,\"position\":[1,0,0]},{\"vertex\":4,\"position\":[0,0,0]}],"
                         "\"markers\":{\"file\":\"a\",\"path\":\"/p\"}}]",
                         NULL, NULL),
                "at /targets/0/pins/2/vertex: vertex 3 is pinned twice (also /targets/0/pins/0)");
    /* Target names: unique, defaulted from the mesh path. */
    EXPECT_FAIL(job_text(NULL,
                         "[{\"file\":\"a.h5\",\"mesh\":\"/a/lion\",\"markers\":{\"file\":\"a\","
                         "\"path\":\"/p\"}},{\"file\":\"b.h5\",\"mesh\":\"/b/lion\","
                         "\"markers\":{\"file\":\"a\",\"path\":\"/p\"}}]",
                         NULL, NULL),
                "job.json: at /targets/1: target name \"lion\" is already used by /targets/0");
    EXPECT_FAIL(job_text(NULL,
                         "[{\"file\":\"a.h5\",\"mesh\":\"/a/lion\",\"markers\":{\"file\":\"a\","
                         "\"path\":\"/p\"}},{\"name\":\"lion\",\"file\":\"b.h5\",\"mesh\":\"/b/x\","
                         "\"markers\":{\"file\":\"a\",\"path\":\"/p\"}}]",
                         NULL, NULL),
                "at /targets/1: target name \"lion\" is already used by /targets/0");
    EXPECT_FAIL(job_text(NULL,
                         "[{\"file\":\"a.h5\",\"mesh\":\"/meshes/big lion\","
                         "\"markers\":{\"file\":\"a\",\"path\":\"/p\"}}]",
                         NULL, NULL),
                "at /targets/0: the mesh path \"/meshes/big lion\" gives no usable target name");
    EXPECT_FAIL(job_text(NULL,
                         "[{\"file\":\"a.h5\",\"mesh\":\"/\",\"markers\":{\"file\":\"a\","
                         "\"path\":\"/p\"}}]",
                         NULL, NULL),
                "at /targets/0: the mesh path \"/\" gives no usable target name");
    EXPECT_FAIL(job_text(NULL,
                         "[{\"name\":\"..\",\"file\":\"a.h5\",\"mesh\":\"/m\","
                         "\"markers\":{\"file\":\"a\",\"path\":\"/p\"}}]",
                         NULL, NULL),
                "at /targets/0/name: expected a string matching ^(");
    /* A name from the mesh path goes through the same rule in job.c. */
    EXPECT_FAIL(job_text(NULL,
                         "[{\"file\":\"a.h5\",\"mesh\":\"/meshes/.dtx-tmp-lion\","
                         "\"markers\":{\"file\":\"a\",\"path\":\"/p\"}}]",
                         NULL, NULL),
                "at /targets/0: the mesh path \"/meshes/.dtx-tmp-lion\" gives no usable target "
                "name (\".dtx-tmp-lion\" cannot name an HDF5 object: names starting with "
                "\".dtx-\" are reserved");
    /* A sequence's last part names its results. */
    EXPECT_FAIL(job_text("{\"file\":\"a.h5\",\"mesh\":\"/m\",\"sequences\":[\"/s\",\"/s/..\"]}",
                         NULL, NULL, NULL),
                "at /source/sequences/1: the sequence path \"/s/..\" gives no usable result name: "
                "\"..\" cannot name an HDF5 object");
    EXPECT_FAIL(job_text("{\"file\":\"a.h5\",\"mesh\":\"/m\","
                         "\"sequences\":[\"/sequences/.dtx-tmp-walk\"]}",
                         NULL, NULL, NULL),
                "at /source/sequences/0: the sequence path \"/sequences/.dtx-tmp-walk\" gives "
                "no usable result name");
    EXPECT_FAIL(job_text("{\"file\":\"a.h5\",\"mesh\":\"/m\",\"sequences\":[\"/s\",\"/t\",\"/s\"]}",
                         NULL, NULL, NULL),
                "at /source/sequences/2: sequence \"/s\" is listed twice (also "
                "/source/sequences/0)");
}

static void test_output_vs_inputs(void)
{
    char dir[1024], path[1200], text[8192];
    dtx_job job;
    dtx_error err_, *err = &err_;

    /* Same name, different spellings (files need not exist). */
    EXPECT_FAIL(job_text(NULL, NULL, "{\"file\":\"in.h5\"}", NULL),
                "job.json: at /output/file: the output file /data/jobs/in.h5 is also an input "
                "(/source/file)");
    EXPECT_FAIL(job_text(NULL, NULL, "{\"file\":\"./sub/../in.h5\"}", NULL),
                "at /output/file: the output file /data/jobs/sub/../in.h5 is also an input "
                "(/source/file)");
    EXPECT_FAIL(job_text(NULL, NULL, "{\"file\":\"/data/jobs/in.h5\"}", NULL),
                "at /output/file: the output file /data/jobs/in.h5 is also an input "
                "(/source/file)");
    EXPECT_FAIL(job_text(NULL,
                               "[{\"file\":\"t.h5\",\"mesh\":\"/m\",\"markers\":{\"csv\":\"m.csv\","
                               "\"index_base\":0}}]",
                               "{\"file\":\"../jobs/m.csv\"}", NULL),
                "(/targets/0/markers/csv)");
    EXPECT_FAIL(job_text(NULL,
                         "[{\"file\":\"t.h5\",\"mesh\":\"/m\",\"markers\":{\"file\":\"t.h5\","
                         "\"path\":\"/p\"}}]",
                         "{\"file\":\"t.h5\"}", NULL),
                "(/targets/0/file)");

    /* Existing files: the same file under another name (a symbolic link)
     * is still the same file. */
    snprintf(dir, sizeof dir, "%s/outin", DTX_TEST_SCRATCH);
    mkdir(dir, 0777);
    snprintf(path, sizeof path, "%s/in.h5", dir);
    write_file(path, "x");
    snprintf(path, sizeof path, "%s/alias.h5", dir);
    unlink(path);
    CHECK_EQ_INT(symlink("in.h5", path), 0);
    snprintf(text, sizeof text, "%s", job_text(NULL, NULL, "{\"file\":\"alias.h5\"}", NULL));
    expect_fail_(text, dir, 0, DTX_EJOB, "is also an input (/source/file)", __FILE__, __LINE__);
    /* A distinct output file is fine. */
    CHECK_OK(parse(job_text(NULL, NULL, "{\"file\":\"new.h5\"}", NULL), dir, 0, &job, err),
             err);
    dtx_job_free(&job);
}

static void test_files(void)
{
    char dir[1024], path[1200], want[1400], *real;
    char text[8192];
    dtx_job job;
    dtx_error err_, *err = &err_;

    snprintf(dir, sizeof dir, "%s/files", DTX_TEST_SCRATCH);
    mkdir(dir, 0777);
    snprintf(path, sizeof path, "%s/in.h5", dir);
    write_file(path, "x");
    snprintf(path, sizeof path, "%s/markers.csv", dir);
    write_file(path, "0,0\n");
    real = realpath(dir, NULL);
    CHECK(real != NULL);
    if (!real)
        return;

    /* All inputs exist. */
    CHECK_OK(parse(job_text(NULL, NULL, NULL, NULL), dir, 1, &job, err), err);
    dtx_job_free(&job);

    /* A missing target file, named with its absolute path. */
    snprintf(text, sizeof text, "%s",
             job_text(NULL,
                      "[{\"file\":\"lion.h5\",\"mesh\":\"/m\",\"markers\":{\"file\":\"in.h5\","
                      "\"path\":\"/p\"}}]",
                      NULL, NULL));
    snprintf(want, sizeof want, "job.json: at /targets/0/file: no such file: %s/lion.h5", real);
    expect_fail_(text, dir, 1, DTX_EJOB, want, __FILE__, __LINE__);
    /* Without check_files the same job is accepted. */
    CHECK_OK(parse(text, dir, 0, &job, err), err);
    dtx_job_free(&job);

    /* Missing source file and marker files. */
    snprintf(text, sizeof text, "%s",
             job_text("{\"file\":\"nope/src.h5\",\"mesh\":\"/m\",\"sequences\":[\"/s\"]}", NULL,
                      NULL, NULL));
    snprintf(want, sizeof want, "at /source/file: no such file: %s/nope/src.h5", real);
    expect_fail_(text, dir, 1, DTX_EJOB, want, __FILE__, __LINE__);
    snprintf(text, sizeof text, "%s",
             job_text(NULL,
                      "[{\"file\":\"in.h5\",\"mesh\":\"/m\",\"markers\":{\"csv\":\"m2.csv\","
                      "\"index_base\":1}}]",
                      NULL, NULL));
    snprintf(want, sizeof want, "at /targets/0/markers/csv: no such file: %s/m2.csv", real);
    expect_fail_(text, dir, 1, DTX_EJOB, want, __FILE__, __LINE__);
    snprintf(text, sizeof text, "%s",
             job_text(NULL,
                      "[{\"file\":\"in.h5\",\"mesh\":\"/m\",\"markers\":{\"csv\":\"markers.csv\","
                      "\"index_base\":1}},{\"file\":\"in.h5\",\"mesh\":\"/n\",\"markers\":{"
                      "\"file\":\"mk.h5\",\"path\":\"/p\"}}]",
                      NULL, NULL));
    snprintf(want, sizeof want, "at /targets/1/markers/file: no such file: %s/mk.h5", real);
    expect_fail_(text, dir, 1, DTX_EJOB, want, __FILE__, __LINE__);
    /* A directory is not an input file. */
    snprintf(text, sizeof text, "%s",
             job_text("{\"file\":\".\",\"mesh\":\"/m\",\"sequences\":[\"/s\"]}", NULL, NULL,
                      NULL));
    expect_fail_(text, dir, 1, DTX_EJOB, "at /source/file: is a directory", __FILE__, __LINE__);
    /* Nor is a FIFO (reading it would block the run). */
    snprintf(path, sizeof path, "%s/fifo.h5", dir);
    unlink(path);
    CHECK(mkfifo(path, 0600) == 0);
    snprintf(text, sizeof text, "%s",
             job_text("{\"file\":\"fifo.h5\",\"mesh\":\"/m\",\"sequences\":[\"/s\"]}", NULL,
                      NULL, NULL));
    expect_fail_(text, dir, 1, DTX_EJOB, "at /source/file: not a regular file (a FIFO)", __FILE__,
                 __LINE__);
    unlink(path);

    /* dtx_job_load: relative paths are relative to the job file. */
    snprintf(path, sizeof path, "%s/job.json", dir);
    write_file(path, job_text(NULL, NULL, NULL, NULL));
    CHECK_OK(dtx_job_load(path, &job, err), err);
    snprintf(want, sizeof want, "%s/in.h5", real);
    CHECK(job.source_file && strcmp(job.source_file, want) == 0);
    CHECK(job.job_path && strcmp(job.job_path, path) == 0);
    CHECK(job.text && strcmp(job.text, job_text(NULL, NULL, NULL, NULL)) == 0);
    dtx_job_free(&job);
    /* ... and it checks the files. */
    write_file(path, job_text(NULL, NULL, NULL, ",\"sp04\":{}") /* valid */);
    CHECK_OK(dtx_job_load(path, &job, err), err);
    dtx_job_free(&job);
    write_file(path, job_text("{\"file\":\"gone.h5\",\"mesh\":\"/m\",\"sequences\":[\"/s\"]}",
                              NULL, NULL, NULL));
    CHECK_EQ_INT(dtx_job_load(path, &job, err), DTX_EJOB);
    snprintf(want, sizeof want, "%s: at /source/file: no such file: %s/gone.h5", path, real);
    CHECK(strcmp(err->msg, want) == 0);
    /* Syntax errors name the file, line and column. */
    write_file(path, "{\n\"dtx_job\": 1\n\"method\": 1}");
    CHECK_EQ_INT(dtx_job_load(path, &job, err), DTX_EPARSE);
    snprintf(want, sizeof want, "%s:3:1: JSON syntax error", path);
    CHECK(strstr(err->msg, want) == err->msg);
    /* A missing job file. */
    snprintf(path, sizeof path, "%s/absent.json", dir);
    CHECK_EQ_INT(dtx_job_load(path, &job, err), DTX_EIO);
    CHECK(strstr(err->msg, path) == err->msg);
    CHECK(strstr(err->msg, "cannot open") != NULL);
    CHECK_EQ_INT(dtx_job_load(dir, &job, err), DTX_EIO); /* a directory */
    CHECK(strstr(err->msg, dir) == err->msg);
    free(real);
}

/* ------------------------------------------------------------------ */
/* Parameter text                                                      */
/* ------------------------------------------------------------------ */

static void test_params_json(void)
{
    dtx_job job;
    dtx_error err_, *err = &err_;
    char *p, *q;
    cJSON *parsed;

    CHECK_OK(parse(job_text(NULL, NULL, NULL, NULL), "/data", 0, &job, err), err);
    p = dtx_job_params_json(&job);
    CHECK(p != NULL);
    if (p)
        CHECK(strcmp(p, "{\"method\":\"sp04\",\"sp04\":{\"max_angle_deg\":90,"
                        "\"max_distance\":0.10000000000000001,"
                        "\"w_closest\":[1,100,5000,5000,5000,5000],"
                        "\"w_identity\":0.29999999999999999,\"w_smooth\":1,"
                        "\"weights\":\"area\"}}") == 0);
    /* It is JSON, and the numbers read back exactly. */
    parsed = p ? cJSON_Parse(p) : NULL;
    CHECK(parsed != NULL);
    if (parsed) {
        const cJSON *sp = cJSON_GetObjectItemCaseSensitive(parsed, "sp04");
        CHECK(cJSON_GetObjectItemCaseSensitive(sp, "max_distance")->valuedouble ==
              job.sp04.max_distance);
    }
    cJSON_Delete(parsed);
    dtx_job_free(&job);

    /* The same parameters written differently give the same text. */
    CHECK_OK(parse(job_text(NULL, NULL, NULL,
                            ",\"sp04\":{\"w_closest\":[1,1e2,5000,5e3,5000.0,5000],"
                            "\"max_distance\":0.1,\"w_smooth\":1.0,\"w_identity\":0.3,"
                            "\"weights\":\"area\"}"),
                   "/data", 0, &job, err),
             err);
    q = dtx_job_params_json(&job);
    CHECK(p && q && strcmp(p, q) == 0);
    free(q);
    dtx_job_free(&job);
    /* Different parameters give different text. */
    CHECK_OK(parse(job_text(NULL, NULL, NULL, ",\"sp04\":{\"w_closest\":[1,500,1000]}"), "/data",
                   0, &job, err),
             err);
    q = dtx_job_params_json(&job);
    CHECK(p && q && strcmp(p, q) != 0);
    free(q);
    dtx_job_free(&job);
    CHECK_OK(parse(job_text(NULL, NULL, NULL, ",\"sp04\":{\"weights\":\"element\"}"), "/data", 0,
                   &job, err),
             err);
    q = dtx_job_params_json(&job);
    CHECK(p && q && strcmp(p, q) != 0 && strstr(q, "\"weights\":\"element\"") != NULL);
    free(q);
    free(p);
    dtx_job_free(&job);

    /* springs: sp04's object (the proxy's correspondence), then its own. */
    {
        char text[8192];
        snprintf(text, sizeof text, "%s",
                 job_text(NULL, NULL, NULL, ",\"springs\":{\"levels\":0,\"internal\":false}"));
        char *m = strstr(text, "\"method\":\"sp04\"");
        char springs[4096];
        CHECK(m != NULL);
        if (!m)
            return;
        snprintf(springs, sizeof springs, "%.*s\"method\":\"springs\"%s", (int)(m - text), text,
                 m + strlen("\"method\":\"sp04\""));
        CHECK_OK(parse(springs, "/data", 0, &job, err), err);
        CHECK_EQ_INT(job.method, DTX_METHOD_SPRINGS);
        p = dtx_job_params_json(&job);
        CHECK(p && strstr(p, "{\"method\":\"springs\",\"sp04\":{\"max_angle_deg\":90,") == p);
        CHECK(p && strstr(p, "},\"springs\":{\"barrier\":true,\"bending\":true,"
                             "\"coarse_max_iter\":50,\"coarse_min\":150,"
                             "\"coarse_tol\":1.0000000000000001e-05,\"internal\":false,"
                             "\"levels\":0,\"max_iter\":100,\"start\":\"sp04\",\"tol\":1e-08}}") !=
                       NULL);
        free(p);
        dtx_job_free(&job);
    }
    CHECK(dtx_job_params_json(NULL) == NULL);
}

/* The multicomponent object: E3's measure and the weight that goes with it. */
static void test_multicomponent_params(void)
{
    static const struct {
        const char *obj;
        int lengths;
        double w;
        int solver;
    } cases[] = {
        {"{}", DTX_MC_LENGTHS_RELATIVE, 3.0, DTX_MC_SOLVER_FIXED_POINT},
        {"{\"proximity_lengths\":\"diagonal\"}", DTX_MC_LENGTHS_DIAGONAL, 0.1,
         DTX_MC_SOLVER_FIXED_POINT},
        {"{\"w_proximity\":2,\"proximity_lengths\":\"diagonal\",\"solver\":\"newton\"}",
         DTX_MC_LENGTHS_DIAGONAL, 2.0, DTX_MC_SOLVER_NEWTON},
        {"{\"proximity_lengths\":\"relative\",\"w_proximity\":0.5,\"solver\":\"fixed-point\"}",
         DTX_MC_LENGTHS_RELATIVE, 0.5, DTX_MC_SOLVER_FIXED_POINT},
    };
    dtx_job job;
    dtx_error err_, *err = &err_;
    char text[8192], tail[256], mc[8192], *m, *p;
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        snprintf(tail, sizeof tail, ",\"multicomponent\":%s", cases[i].obj);
        snprintf(text, sizeof text, "%s", job_text(NULL, NULL, NULL, tail));
        m = strstr(text, "\"method\":\"sp04\"");
        CHECK(m != NULL);
        if (!m)
            return;
        snprintf(mc, sizeof mc, "%.*s\"method\":\"multicomponent\"%s", (int)(m - text), text,
                 m + strlen("\"method\":\"sp04\""));
        CHECK_OK(parse(mc, "/data", 0, &job, err), err);
        CHECK_EQ_INT(job.mc.lengths, cases[i].lengths);
        CHECK(job.mc.w_proximity == cases[i].w);
        CHECK_EQ_INT(job.mc.solver, cases[i].solver);
        p = dtx_job_params_json(&job);
        CHECK(p && strstr(p, cases[i].lengths == DTX_MC_LENGTHS_DIAGONAL
                                 ? "\"proximity_lengths\":\"diagonal\""
                                 : "\"proximity_lengths\":\"relative\"") != NULL);
        CHECK(p && strstr(p, cases[i].solver == DTX_MC_SOLVER_NEWTON
                                 ? "\"solver\":\"newton\""
                                 : "\"solver\":\"fixed-point\"") != NULL);
        free(p);
        dtx_job_free(&job);
    }
    EXPECT_FAIL(job_text(NULL, NULL, NULL, ",\"multicomponent\":{\"proximity_lengths\":\"absolute\"}"),
                "at /multicomponent/proximity_lengths:");
    EXPECT_FAIL(job_text(NULL, NULL, NULL, ",\"multicomponent\":{\"solver\":\"lm\"}"),
                "at /multicomponent/solver:");
}

/* The fuzzer's seed inputs: bad-*.json are rejected with a message that
 * starts with the file name, the others parse. */
static void test_corpus(void)
{
    const char *dir = DTX_SRC "/tests/io/corpus/job";
    DIR *dp = opendir(dir);
    struct dirent *de;
    int n = 0;
    CHECK(dp != NULL);
    if (!dp)
        return;
    while ((de = readdir(dp)) != NULL) {
        char path[2048];
        size_t len = 0, nl = strlen(de->d_name);
        char *text;
        int bad = strncmp(de->d_name, "bad-", 4) == 0;
        dtx_job job;
        dtx_error err_, *err = &err_;
        dtx_status st;
        if (nl < 6 || strcmp(de->d_name + nl - 5, ".json") != 0)
            continue;
        snprintf(path, sizeof path, "%s/%s", dir, de->d_name);
        text = read_file(path, &len);
        CHECK(text != NULL);
        if (!text)
            continue;
        st = dtx_job_parse(text, len, de->d_name, "/data/jobs", 0, &job, err);
        if (bad) {
            CHECK(st != DTX_OK);
            CHECK(st == DTX_OK || strncmp(err->msg, de->d_name, nl) == 0);
        } else {
            CHECK_OK(st, err);
        }
        dtx_job_free(&job);
        free(text);
        n++;
    }
    closedir(dp);
    CHECK_INT(n, >=, 5);
}

/* Inputs found by the fuzzer (tests/fuzz/fuzz_job.c).  Keys and values
 * made of control characters are quoted in messages as 6-byte \u escapes;
 * 20 or more of them overran the validator's 128-byte quoting buffer (a
 * stack overflow).  Now they are shortened with "...". */
static void test_fuzz_regressions(void)
{
    char ctl[121], src[400], extra[400];
    memset(ctl, '\r', 120);
    ctl[120] = '\0';
    /* The fuzzer's input, reduced: an unknown key in /source. */
    snprintf(src, sizeof src, "{\"%s\":\"x\",\"file\":\"in.h5\"}", ctl);
    EXPECT_FAIL(job_text(src, NULL, NULL, NULL), "job.json: at /source: unknown key \"\\u000d");
    EXPECT_FAIL(job_text(src, NULL, NULL, NULL), "\\u000d...\" (allowed: file, mesh, sequences, weld_tolerance)");
    /* A value (in "got ...") and a top-level key. */
    snprintf(extra, sizeof extra, ",\"sp04\":{\"w_smooth\":\"%s\"}", ctl);
    EXPECT_FAIL(job_text(NULL, NULL, NULL, extra),
                "job.json: at /sp04/w_smooth: expected a number, got \"\\u000d");
    snprintf(extra, sizeof extra, ",\"%s\":1", ctl);
    EXPECT_FAIL(job_text(NULL, NULL, NULL, extra), "job.json: at the top level: unknown key");

    /* A NUL byte inside a string once cut the value short silently
     * ("/meshes/cat\0junk" read as "/meshes/cat"); now the text is refused
     * at the NUL. */
    {
        const char t[] = "{\"dtx_job\":1,\"method\":\"sp04\",\n\"source\":{\"file\":\"in.h5\","
                         "\"mesh\":\"/meshes/cat\0junk\",\"sequences\":[\"/s\"]}}";
        dtx_job job;
        dtx_error err_, *err = &err_;
        memset(err, 0, sizeof *err);
        CHECK_EQ_INT(dtx_job_parse(t, sizeof t - 1, "job.json", "/data", 0, &job, err), DTX_EPARSE);
        CHECK(strstr(err->msg, "job.json:2:45: JSON syntax error: NUL byte (not a text file) "
                               "near '\\x00junk") != NULL);
        if (!strstr(err->msg, "job.json:2:45:"))
            fprintf(stderr, "  message: %s\n", err->msg);
        CHECK(job.text == NULL);
    }
}

/* The schema's pattern for target names and job.c's rule (the characters
 * plus dtx_h5_check_name) accept the same names: the schema mirrors the
 * rule, so an editor validating against it sees what dtx run will say. */
static void test_target_name_rule(void)
{
    static const char *const names[] = {
        "lion", "Lion_2.v-1", "a", "-", "_", ".x", ".d", ".dt", ".dtx", ".dtxa", ".dtx.",
        "..x", "...", "a.dtx-", "x..", ".e", ".c",
        /* rejected */
        ".", "..", ".dtx-", ".dtx-tmp-lion", ".dtx-x", "", "big lion", "a/b", "tab\there"};
    char targets[2048], longname[300];
    size_t k;
    for (k = 0; k < sizeof names / sizeof *names + 2; k++) {
        const char *nm;
        dtx_job job;
        dtx_error err, why;
        int want, got;
        const char *p;
        if (k < sizeof names / sizeof *names) {
            nm = names[k];
        } else { /* 255 and 256 bytes */
            size_t len = k == sizeof names / sizeof *names ? 255 : 256;
            memset(longname, 'n', len);
            longname[len] = '\0';
            nm = longname;
        }
        want = dtx_h5_check_name(nm, &why) == DTX_OK;
        for (p = nm; *p; p++)
            if (!((*p >= 'A' && *p <= 'Z') || (*p >= 'a' && *p <= 'z') ||
                  (*p >= '0' && *p <= '9') || *p == '_' || *p == '.' || *p == '-'))
                want = 0;
        snprintf(targets, sizeof targets,
                 "[{\"name\":\"%s\",\"file\":\"a.h5\",\"mesh\":\"/m\","
                 "\"markers\":{\"file\":\"a\",\"path\":\"/p\"}}]",
                 strcmp(nm, "tab\there") == 0 ? "tab\\there" : nm);
        got = parse(job_text(NULL, targets, NULL, NULL), "/data/jobs", 0, &job, &err) == DTX_OK;
        if (got)
            dtx_job_free(&job);
        if (got != want)
            fprintf(stderr, "target name \"%.40s\": the rule says %s, the job parser says %s%s%s\n",
                    nm, want ? "valid" : "invalid", got ? "valid" : "invalid",
                    got ? "" : ": ", got ? "" : err.msg);
        CHECK_EQ_INT(got, want);
        /* The schema alone (before job.c's check) already rejects a bad
         * name, naming the pointer. */
        if (!want && !got && nm[0])
            CHECK(strstr(err.msg, "at /targets/0/name: expected a string") != NULL);
    }
}

/* A FIFO or a device as the job file: refused before reading.  The load
 * runs in a child under a 20 s alarm, so a regression (a blocking open)
 * fails the test instead of hanging it. */
static void test_special_job_files(void)
{
    char fifo[1024], zero[1024];
    const char *paths[2] = {fifo, zero}, *kinds[2] = {"a FIFO", "a character device"};
    snprintf(fifo, sizeof fifo, "%s/fifo.json", DTX_TEST_SCRATCH);
    snprintf(zero, sizeof zero, "%s/zero.json", DTX_TEST_SCRATCH);
    unlink(fifo);
    unlink(zero);
    CHECK(mkfifo(fifo, 0600) == 0);
    CHECK(symlink("/dev/zero", zero) == 0);
    for (int i = 0; i < 2; i++) {
        pid_t pid;
        int ws = 0;
        fflush(NULL);
        pid = fork();
        if (pid == 0) {
            dtx_job job;
            dtx_error err;
            char want[1200];
            dtx_status st;
            alarm(20);
            st = dtx_job_load(paths[i], &job, &err);
            snprintf(want, sizeof want, "%s: not a regular file (%s)", paths[i], kinds[i]);
            if (st == DTX_EIO && strstr(err.msg, want) == err.msg)
                _exit(0);
            fprintf(stderr, "  %s: %s: %s\n", paths[i], dtx_status_name(st), err.msg);
            _exit(1);
        }
        CHECK(pid > 0 && waitpid(pid, &ws, 0) == pid);
        CHECK(WIFEXITED(ws) && WEXITSTATUS(ws) == 0);
    }
    unlink(fifo);
    unlink(zero);
}

/* A string holding \u0000 anywhere (values and member names, at any depth)
 * is refused naming its JSON pointer: cJSON would cut the C string there,
 * so "sp04\u0000x" read as "sp04". */
static void test_nul_escapes(void)
{
    char text[8192];
    const char *t = job_text(NULL, NULL, NULL, NULL), *m = strstr(t, "\"sp04\"");
    CHECK(m != NULL);
    if (!m)
        return;
    snprintf(text, sizeof text, "%.*s\"sp04\\u0000x\"%s", (int)(m - t), t, m + 6);
    EXPECT_FAIL(text, "job.json: at /method: a string holding \\u0000 (a NUL character) is not "
                      "allowed");
    EXPECT_FAIL(job_text("{\"file\":\"in.h5\\u0000.txt\",\"mesh\":\"/meshes/cat\","
                         "\"sequences\":[\"/sequences/walk\"]}",
                         NULL, NULL, NULL),
                "at /source/file: a string holding \\u0000");
    EXPECT_FAIL(job_text("{\"file\":\"in.h5\",\"mesh\":\"/meshes/cat\","
                         "\"sequences\":[\"/sequences/a\",\"/sequences/walk\\u0000\"]}",
                         NULL, NULL, NULL),
                "at /source/sequences/1: a string holding \\u0000");
    EXPECT_FAIL(job_text(NULL, NULL, NULL, ",\"no\\u0000te\":1"),
                "at /no\\u0000te: a string holding \\u0000");
    /* \\u0000 is a backslash and "u0000", not a NUL: it reaches the schema */
    EXPECT_FAIL(job_text(NULL, NULL, "{\"file\":\"out\\\\u0000.h5\",\"dtype\":\"float16\"}", NULL),
                "at /output/dtype");
}

/* Nesting deeper than DTX_JSON_MAX_DEPTH levels is refused with its line
 * and column, not as a bare syntax error (cJSON's own limit). */
static void test_deep_nesting(void)
{
    size_t n = 10000;
    char *text = malloc(n + 32);
    dtx_job job;
    dtx_error err;
    char want[128];
    CHECK(text != NULL);
    if (!text)
        return;
    text[0] = '\n';
    memset(text + 1, '[', n);
    strcpy(text + 1 + n, "");
    CHECK_EQ_INT(dtx_job_parse(text, n + 1, "deep.json", ".", 0, &job, &err), DTX_EPARSE);
    snprintf(want, sizeof want, "deep.json:2:%d: JSON nesting deeper than %d levels",
             DTX_JSON_MAX_DEPTH + 1, DTX_JSON_MAX_DEPTH);
    CHECK(strcmp(err.msg, want) == 0);
    if (strcmp(err.msg, want) != 0)
        fprintf(stderr, "  got: %s\n  want: %s\n", err.msg, want);
    /* Just at the limit, the depth is fine (the schema then says what is
     * wrong), and brackets inside strings do not count. */
    memset(text, '[', DTX_JSON_MAX_DEPTH);
    memset(text + DTX_JSON_MAX_DEPTH, ']', DTX_JSON_MAX_DEPTH);
    CHECK_EQ_INT(dtx_job_parse(text, 2 * DTX_JSON_MAX_DEPTH, "ok.json", ".", 0, &job, &err),
                 DTX_EJOB);
    CHECK(strstr(err.msg, "nesting") == NULL);
    snprintf(text, n, "{\"a\":\"");
    memset(text + 6, '[', 200);
    strcpy(text + 206, "\"}");
    CHECK_EQ_INT(dtx_job_parse(text, strlen(text), "str.json", ".", 0, &job, &err), DTX_EJOB);
    CHECK(strstr(err.msg, "nesting") == NULL);
    free(text);
}

int main(void)
{
    test_embedded_schema();
    test_schema_defaults();
    test_full_job();
    test_defaults();
    test_demo_job();
    test_example_jobs();
    test_unknown_keys();
    test_schema_violations();
    test_syntax_errors();
    test_cross_field();
    test_output_vs_inputs();
    test_files();
    test_params_json();
    test_multicomponent_params();
    test_corpus();
    test_fuzz_regressions();
    test_target_name_rule();
    test_special_job_files();
    test_nul_escapes();
    test_deep_nesting();
    return check_report();
}
