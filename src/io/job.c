/*
 * job.c: reading dtx job files (see job.h and schemas/job.schema.json).
 *
 * Parse, then validate, then fill, then cross-check, as separate passes:
 * cJSON parses the text, the schema validator rejects anything the schema
 * does not allow (so the filling code may rely on types and ranges), the
 * job struct is filled with resolved paths and defaults, and the rules a
 * schema cannot express (unique names, output differs from inputs, files
 * exist) are checked last.
 */

/* realpath() is an XSI function, not in _POSIX_C_SOURCE alone. */
#ifndef _XOPEN_SOURCE
#define _XOPEN_SOURCE 700
#endif

#include "job.h"

#include "dtx_core.h"
#include "keypoints.h"
#include "springs.h"
#include "transfer.h"

#include "h5layout.h"
#include "file_util.h"
#include "json_schema.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* Largest job file dtx_job_load reads. */
#define JOB_MAX_BYTES (16u << 20)

/* Defaults (they also appear as "default" in the schema; the unit test
 * checks that the two agree). */
#define DEFAULT_BLOCK_FRAMES 64
#define DEFAULT_TRAINING_FRAMES 32

static const char *const method_names[] = {"sp04", "multicomponent", "springs", "biharmonic"};
static const char *const translation_names[] = {"fixed", "follow", "pins"};

/* ------------------------------------------------------------------ */
/* Small helpers                                                       */
/* ------------------------------------------------------------------ */

static char *dup_str(const char *s)
{
    size_t n;
    char *d;
    if (!s)
        return NULL;
    n = strlen(s);
    d = malloc(n + 1);
    if (d)
        memcpy(d, s, n + 1);
    return d;
}

/* "at /pointer" as used in every message; the root pointer is "". */
static dtx_status job_err(dtx_error *err, dtx_status code, const char *name, const char *ptr,
                          const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 5, 6)))
#endif
    ;

static dtx_status job_err(dtx_error *err, dtx_status code, const char *name, const char *ptr,
                          const char *fmt, ...)
{
    char text[768];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    return dtx_seterr(err, code, "%s: at %s: %s", name, ptr[0] ? ptr : "the top level", text);
}

static const cJSON *get(const cJSON *obj, const char *key)
{
    return cJSON_GetObjectItemCaseSensitive(obj, key);
}

static const char *get_str(const cJSON *obj, const char *key)
{
    const cJSON *v = get(obj, key);
    return cJSON_IsString(v) ? v->valuestring : NULL;
}

static int enum_index(const char *s, const char *const *names, int n)
{
    int i;
    for (i = 0; s && i < n; i++)
        if (strcmp(s, names[i]) == 0)
            return i;
    return -1;
}

/* ------------------------------------------------------------------ */
/* Paths                                                               */
/* ------------------------------------------------------------------ */

/* A growable absolute path, built component by component. */
typedef struct {
    char *buf; /* the path being built, always starts with "/" */
    size_t len, cap;
} pathbuf;

static int pb_reserve(pathbuf *pb, size_t extra)
{
    char *nb;
    size_t cap;
    if (pb->len + extra + 1 <= pb->cap)
        return 0;
    cap = pb->cap ? pb->cap : 64;
    while (cap < pb->len + extra + 1) {
        if (cap > ((size_t)-1) / 2)
            return -1;
        cap *= 2;
    }
    nb = realloc(pb->buf, cap);
    if (!nb)
        return -1;
    pb->buf = nb;
    pb->cap = cap;
    return 0;
}

/* Appends "/" + the n bytes at comp. */
static int pb_push(pathbuf *pb, const char *comp, size_t n)
{
    if (pb_reserve(pb, n + 1))
        return -1;
    if (pb->len == 0 || pb->buf[pb->len - 1] != '/')
        pb->buf[pb->len++] = '/';
    memcpy(pb->buf + pb->len, comp, n);
    pb->len += n;
    pb->buf[pb->len] = '\0';
    return 0;
}

/* Removes the last component (never the root). */
static void pb_pop(pathbuf *pb)
{
    while (pb->len > 1 && pb->buf[pb->len - 1] != '/')
        pb->len--;
    if (pb->len > 1)
        pb->len--;
    pb->buf[pb->len] = '\0';
}

/* Appends the components of p to pb: "." and empty components are
 * dropped, and ".." removes a component only while no ordinary component
 * of p has been appended yet (the base is canonical, so going up from it is
 * exact; going up from a component of p could cross a symbolic link, so
 * such ".." are kept for the system to resolve). */
static int pb_append_path(pathbuf *pb, const char *p, int collapse_leading_dotdot)
{
    int leading = collapse_leading_dotdot;
    while (*p) {
        const char *q = p;
        size_t n;
        while (*q && *q != '/')
            q++;
        n = (size_t)(q - p);
        if (n == 0 || (n == 1 && p[0] == '.')) {
            /* skip */
        } else if (leading && n == 2 && p[0] == '.' && p[1] == '.') {
            pb_pop(pb);
        } else {
            leading = 0;
            if (pb_push(pb, p, n))
                return -1;
        }
        p = *q ? q + 1 : q;
    }
    return 0;
}

/* p resolved against the absolute directory base: absolute paths are kept
 * (only "." and repeated "/" removed), relative ones are appended to base
 * with their leading ".." applied.  Newly allocated; NULL when out of
 * memory. */
static char *resolve_path(const char *base, const char *p)
{
    pathbuf pb = {NULL, 0, 0};
    if (pb_reserve(&pb, strlen(base) + strlen(p) + 2))
        return NULL;
    pb.buf[0] = '/';
    pb.buf[1] = '\0';
    pb.len = 1;
    if (p[0] != '/' && pb_append_path(&pb, base, 0))
        goto fail;
    if (pb_append_path(&pb, p, p[0] != '/'))
        goto fail;
    return pb.buf;
fail:
    free(pb.buf);
    return NULL;
}

/* The absolute directory relative paths are resolved against: base_dir
 * made canonical when it exists, else made absolute lexically (against the
 * current directory); the current directory when base_dir is NULL or "".
 * Newly allocated; NULL on failure (errno set). */
static char *absolute_dir(const char *base_dir)
{
    char cwd[4096], *res;
    if (base_dir && base_dir[0] && (res = realpath(base_dir, NULL)) != NULL)
        return res;
    if (!getcwd(cwd, sizeof cwd))
        return NULL;
    res = resolve_path(cwd, base_dir ? base_dir : "");
    if (!res)
        errno = ENOMEM;
    return res;
}

/* The absolute path p with every ".." applied lexically (right unless a
 * component is a symbolic link; used only to compare paths of files that
 * do not exist).  Newly allocated; NULL when out of memory. */
static char *lexical_path(const char *p)
{
    pathbuf pb = {NULL, 0, 0};
    const char *q;
    if (pb_reserve(&pb, strlen(p) + 1))
        return NULL;
    strcpy(pb.buf, "/");
    pb.len = 1;
    while (*p) {
        size_t n;
        for (q = p; *q && *q != '/'; q++)
            ;
        n = (size_t)(q - p);
        if (n == 2 && p[0] == '.' && p[1] == '.')
            pb_pop(&pb);
        else if (n > 0 && !(n == 1 && p[0] == '.') && pb_push(&pb, p, n)) {
            free(pb.buf);
            return NULL;
        }
        p = *q ? q + 1 : q;
    }
    return pb.buf;
}

/* A string that names the file p (absolute) refers to, for comparing two
 * paths: its canonical path when it exists, else its canonical directory
 * plus its name, else p made lexically canonical.  Newly allocated; NULL
 * when out of memory. */
static char *file_key(const char *p)
{
    char *real = realpath(p, NULL), *dir, *slash, *key;
    size_t n;
    if (real)
        return real;
    slash = strrchr(p, '/');
    if (!slash || slash == p)
        return lexical_path(p);
    n = (size_t)(slash - p);
    dir = malloc(n + 1);
    if (!dir)
        return NULL;
    memcpy(dir, p, n);
    dir[n] = '\0';
    real = realpath(dir, NULL);
    free(dir);
    if (!real)
        return lexical_path(p);
    key = malloc(strlen(real) + strlen(slash) + 1);
    if (key) {
        strcpy(key, real);
        strcat(key, slash);
    }
    free(real);
    return key;
}

/* 1 when a and b are the same file, 0 when not, -1 when out of memory. */
static int same_file(const char *a, const char *b)
{
    char *ka, *kb;
    int same = dtx_file_same_inode(a, b);
    if (same >= 0)
        return same;
    ka = file_key(a);
    kb = file_key(b);
    same = ka && kb ? strcmp(ka, kb) == 0 : -1;
    free(ka);
    free(kb);
    return same;
}

/* ------------------------------------------------------------------ */
/* Names                                                               */
/* ------------------------------------------------------------------ */

/* A target name: the schema's "name" pattern (letters, digits, _ . -) and
 * the rule every object name follows (dtx_h5_check_name: not "." or "..",
 * not starting with the reserved ".dtx-", at most DTX_H5_NAME_MAX bytes).
 * Returns 1 when valid; else 0 with the reason in err. */
static int valid_name(const char *s, dtx_error *err)
{
    const char *p;
    if (dtx_h5_check_name(s, err) != DTX_OK)
        return 0;
    for (p = s; *p; p++) {
        char ch = *p;
        if (!((ch >= 'A' && ch <= 'Z') || (ch >= 'a' && ch <= 'z') || (ch >= '0' && ch <= '9') ||
              ch == '_' || ch == '.' || ch == '-')) {
            dtx_seterr(err, DTX_EJOB,
                       "\"%.200s\" cannot name a target: use letters, digits, _ . and -", s);
            return 0;
        }
    }
    return 1;
}

/* The last component of an HDF5 path ("/meshes/lion/" gives "lion"), newly
 * allocated; "" when there is none. */
static char *base_name(const char *path)
{
    size_t end = strlen(path);
    char *s;
    /* Trailing slashes end the path; they do not make its last part "". */
    while (end > 0 && path[end - 1] == '/')
        end--;
    s = malloc(end + 1);
    if (s) {
        const char *b;
        memcpy(s, path, end);
        s[end] = '\0';
        b = dtx_path_base_name(s);
        memmove(s, b, strlen(b) + 1);
    }
    return s;
}

/* ------------------------------------------------------------------ */
/* Syntax errors                                                       */
/* ------------------------------------------------------------------ */

/* The message for a syntax error at byte pos of text: line and column
 * (1-based, columns in bytes) and the text found there.  what says what
 * went wrong when known, else NULL. */
static dtx_status syntax_error(const char *name, const char *text, size_t len, size_t pos,
                               const char *what, dtx_error *err)
{
    size_t i, line = 1, col = 1, k = 0;
    char near[64];
    if (pos > len)
        pos = len;
    for (i = 0; i < pos; i++) {
        if (text[i] == '\n') {
            line++;
            col = 1;
        } else {
            col++;
        }
    }
    for (i = pos; i < len && k + 5 < sizeof near && i < pos + 24 && text[i] != '\n'; i++) {
        unsigned char ch = (unsigned char)text[i];
        if (ch < 0x20 || ch == 0x7f)
            k += (size_t)snprintf(near + k, sizeof near - k, "\\x%02x", ch);
        else
            near[k++] = (char)ch;
    }
    near[k] = '\0';
    if (pos >= len || k == 0)
        return dtx_seterr(err, DTX_EPARSE, "%s:%zu:%zu: JSON syntax error: %s", name, line, col,
                          what ? what : "unexpected end of the text");
    return dtx_seterr(err, DTX_EPARSE, "%s:%zu:%zu: JSON syntax error: %s near '%s'", name,
                      line, col, what ? what : "unexpected text", near);
}

/* ------------------------------------------------------------------ */
/* Filling the job                                                     */
/* ------------------------------------------------------------------ */

typedef struct {
    const char *name; /* for messages */
    const char *base; /* absolute directory for relative paths */
    dtx_error *err;
} fillctx;

static dtx_status nomem(fillctx *f)
{
    return dtx_seterr(f->err, DTX_ENOMEM, "%s: out of memory", f->name);
}

/* *out = resolved path of the string obj[key], or NULL when absent. */
static dtx_status fill_path(fillctx *f, const cJSON *obj, const char *key, char **out)
{
    const char *s = get_str(obj, key);
    *out = NULL;
    if (!s)
        return DTX_OK;
    *out = resolve_path(f->base, s);
    return *out ? DTX_OK : nomem(f);
}

static dtx_status fill_str(fillctx *f, const cJSON *obj, const char *key, char **out)
{
    const char *s = get_str(obj, key);
    *out = NULL;
    if (!s)
        return DTX_OK;
    *out = dup_str(s);
    return *out ? DTX_OK : nomem(f);
}

static dtx_status fill_target(fillctx *f, const cJSON *t, int index, dtx_job_target *tg)
{
    const cJSON *markers = get(t, "markers"), *pins = get(t, "pins"), *ib, *pin;
    char ptr[64];
    dtx_error why;
    dtx_status st;
    int tr, i;

    snprintf(ptr, sizeof ptr, "/targets/%d", index);
    if ((st = fill_path(f, t, "file", &tg->file)) || (st = fill_str(f, t, "mesh", &tg->mesh)))
        return st;
    if ((st = fill_str(f, t, "name", &tg->name)))
        return st;
    if (!tg->name) {
        tg->name = base_name(tg->mesh);
        if (!tg->name)
            return nomem(f);
        if (!valid_name(tg->name, &why))
            return job_err(f->err, DTX_EJOB, f->name, ptr,
                           "the mesh path \"%s\" gives no usable target name (%s); give "
                           "\"name\" (letters, digits, _ . -)",
                           tg->mesh, why.msg);
    } else if (!valid_name(tg->name, &why)) {
        char p2[80];
        snprintf(p2, sizeof p2, "%s/name", ptr);
        return job_err(f->err, DTX_EJOB, f->name, p2, "%s", why.msg);
    }

    if ((st = fill_path(f, markers, "csv", &tg->markers.csv)) ||
        (st = fill_path(f, markers, "file", &tg->markers.file)) ||
        (st = fill_str(f, markers, "path", &tg->markers.path)))
        return st;
    ib = get(markers, "index_base");
    tg->markers.index_base = cJSON_IsNumber(ib) ? (int)ib->valuedouble : -1;

    {
        const cJSON *wt = get(t, "weld_tolerance");
        tg->weld_tolerance = cJSON_IsNumber(wt) ? wt->valuedouble : 0;
    }
    tr = enum_index(get_str(t, "translation"), translation_names, 3);
    tg->translation = tr < 0 ? DTX_TRANSLATION_FIXED : (dtx_translation)tr;

    tg->npins = (int32_t)cJSON_GetArraySize(pins);
    tg->pins = dtx_alloc((size_t)tg->npins, sizeof *tg->pins, 1);
    if (!tg->pins)
        return nomem(f);
    i = 0;
    cJSON_ArrayForEach(pin, pins) {
        const cJSON *v = get(pin, "vertex"), *pos = get(pin, "position"), *x;
        int d = 0;
        tg->pins[i].vertex = (int32_t)v->valuedouble;
        cJSON_ArrayForEach(x, pos) {
            if (d < 3)
                tg->pins[i].pos[d] = x->valuedouble;
            d++;
        }
        i++;
    }
    return DTX_OK;
}

/* ------------------------------------------------------------------ */
/* Method settings: read and written from the methods' tables          */
/* ------------------------------------------------------------------ */

_Static_assert(sizeof(int32_t) == sizeof(int), "DTX_SETTING_INT fields are int or int32_t");

/* The key-point selection's settings in the "biharmonic" object: the
 * run's, not the transfer's (whose rows are core's, transfer_bh.c). */
static const char *const bh_keys_names[] = {"markers", "auto", NULL};
static const dtx_setting bh_run_settings[] = {
    {"candidates", DTX_SETTING_INT, offsetof(dtx_bh_job_params, candidates), NULL},
    {"eps", DTX_SETTING_DOUBLE, offsetof(dtx_bh_job_params, eps), NULL},
    {"keypoints", DTX_SETTING_CHOICE, offsetof(dtx_bh_job_params, keypoints), bh_keys_names},
    {"max_keypoints", DTX_SETTING_INT, offsetof(dtx_bh_job_params, max_keypoints), NULL},
    {"training_frames", DTX_SETTING_INT, offsetof(dtx_bh_job_params, training_frames), NULL},
};

/* The settings of a method, as rows with the struct of job they fill:
 * the method's own table (transfer.h) over its parameter struct in the
 * job, and for biharmonic the run's key-point rows too.  Returns the
 * number of rows (at most cap). */
typedef struct {
    const dtx_setting *row;
    void *base;
} setting_ref;

static int method_settings(dtx_job *job, dtx_method method, setting_ref *refs, int cap)
{
    const dtx_transfer_method *m = dtx_transfer_method_named(method_names[method]);
    void *base = method == DTX_METHOD_MULTICOMPONENT ? (void *)&job->mc
                 : method == DTX_METHOD_SPRINGS      ? (void *)&job->springs
                 : method == DTX_METHOD_BIHARMONIC   ? (void *)&job->bh.transfer
                                                     : NULL;
    int n = 0;
    for (int i = 0; m && base && i < m->nsettings && n < cap; i++)
        refs[n++] = (setting_ref){&m->settings[i], base};
    if (method == DTX_METHOD_BIHARMONIC)
        for (size_t i = 0; i < sizeof bh_run_settings / sizeof *bh_run_settings && n < cap; i++)
            refs[n++] = (setting_ref){&bh_run_settings[i], &job->bh};
    return n;
}

/* Fills the settings obj names (the schema has checked their types and
 * ranges); the others keep their defaults. */
static void read_settings(const cJSON *obj, const setting_ref *refs, int n)
{
    for (int i = 0; obj && i < n; i++) {
        const dtx_setting *s = refs[i].row;
        const cJSON *x = get(obj, s->name);
        char *p = (char *)refs[i].base + s->offset;
        if (!x)
            continue;
        if (s->type == DTX_SETTING_DOUBLE && cJSON_IsNumber(x))
            *(double *)p = x->valuedouble;
        else if (s->type == DTX_SETTING_INT && cJSON_IsNumber(x))
            *(int *)p = (int)x->valuedouble;
        else if (s->type == DTX_SETTING_BOOL && cJSON_IsBool(x))
            *(int *)p = cJSON_IsTrue(x);
        else if (s->type == DTX_SETTING_CHOICE && cJSON_IsString(x))
            for (int c = 0; s->choices[c]; c++)
                if (strcmp(s->choices[c], x->valuestring) == 0)
                    *(int *)p = c;
    }
}

const dtx_transfer_method *dtx_job_params_read(const char *params_json, dtx_transfer_params *prm)
{
    cJSON *doc = params_json ? cJSON_Parse(params_json) : NULL;
    const cJSON *name = doc ? get(doc, "method") : NULL;
    const dtx_transfer_method *m =
        cJSON_IsString(name) ? dtx_transfer_method_named(name->valuestring) : NULL;
    if (m) {
        const cJSON *obj = get(doc, m->name);
        dtx_transfer_params_default(prm, m->kind);
        /* The method's settings are offsets into its member of the union,
         * and every member starts at the union's address. */
        for (int i = 0; i < m->nsettings; i++) {
            setting_ref ref = {&m->settings[i], &prm->u};
            read_settings(obj, &ref, 1);
        }
    }
    cJSON_Delete(doc);
    return m;
}

static dtx_status fill_job(fillctx *f, const cJSON *doc, dtx_job *job)
{
    const cJSON *src = get(doc, "source"), *tgts = get(doc, "targets"), *out = get(doc, "output");
    const cJSON *sp = get(doc, "sp04"), *mc = get(doc, "multicomponent"), *x;
    dtx_status st;
    int i, m;

    job->version = (int)get(doc, "dtx_job")->valuedouble;
    m = enum_index(get_str(doc, "method"), method_names, 4);
    job->method = (dtx_method)(m < 0 ? 0 : m);

    /* ---- source ---- */
    if ((st = fill_path(f, src, "file", &job->source_file)) ||
        (st = fill_str(f, src, "mesh", &job->source_mesh)))
        return st;
    {
        const cJSON *wt = get(src, "weld_tolerance");
        job->source_weld_tolerance = cJSON_IsNumber(wt) ? wt->valuedouble : 0;
    }
    x = get(src, "sequences");
    job->sequences = dtx_alloc((size_t)cJSON_GetArraySize(x), sizeof *job->sequences, 1);
    if (!job->sequences)
        return nomem(f);
    for (x = x->child; x; x = x->next) {
        job->sequences[job->nsequences] = dup_str(x->valuestring);
        if (!job->sequences[job->nsequences])
            return nomem(f);
        job->nsequences++;
    }

    /* ---- targets ---- */
    job->targets = dtx_alloc((size_t)cJSON_GetArraySize(tgts), sizeof *job->targets, 1);
    if (!job->targets)
        return nomem(f);
    i = 0;
    cJSON_ArrayForEach(x, tgts) {
        job->ntargets++; /* so that dtx_job_free frees a half-filled target */
        if ((st = fill_target(f, x, i, &job->targets[i])))
            return st;
        i++;
    }

    /* ---- output ---- */
    if ((st = fill_path(f, out, "file", &job->output_file)) ||
        (st = fill_path(f, out, "export_obj_dir", &job->export_obj_dir)) ||
        (st = fill_path(f, doc, "correspondence_store", &job->corr_store)))
        return st;
    x = get(out, "dtype");
    job->output_dtype = cJSON_IsString(x) && strcmp(x->valuestring, "float64") == 0
                            ? DTX_DTYPE_FLOAT64
                            : DTX_DTYPE_FLOAT32;
    x = get(out, "block_frames");
    job->block_frames = cJSON_IsNumber(x) ? (int32_t)x->valuedouble : DEFAULT_BLOCK_FRAMES;
    x = get(out, "io");
    job->collective_io = cJSON_IsString(x) && strcmp(x->valuestring, "collective") == 0;

    /* ---- sp04 parameters ---- */
    /* sp04 defaults come from the core library, the one place they live. */
    {
        dtx_corr_params d;
        dtx_corr_params_default(&d);
        job->sp04.w_smooth = d.w_smooth;
        job->sp04.w_identity = d.w_identity;
        job->sp04.n_closest = d.n_closest;
        memcpy(job->sp04.w_closest, d.w_closest, sizeof job->sp04.w_closest);
        job->sp04.max_distance = d.max_distance;
        job->sp04.max_angle_deg = d.max_angle_deg;
        job->sp04.weights = d.weights;
    }
    if (sp) {
        if (cJSON_IsNumber(x = get(sp, "w_smooth")))
            job->sp04.w_smooth = x->valuedouble;
        if (cJSON_IsNumber(x = get(sp, "w_identity")))
            job->sp04.w_identity = x->valuedouble;
        if (cJSON_IsNumber(x = get(sp, "max_distance")))
            job->sp04.max_distance = x->valuedouble;
        if (cJSON_IsNumber(x = get(sp, "max_angle_deg")))
            job->sp04.max_angle_deg = x->valuedouble;
        if (cJSON_IsString(x = get(sp, "weights")))
            job->sp04.weights = strcmp(x->valuestring, "element") == 0
                                    ? DTX_CORR_WEIGHTS_ELEMENT
                                    : DTX_CORR_WEIGHTS_AREA;
        if (cJSON_IsArray(x = get(sp, "w_closest"))) {
            const cJSON *w;
            job->sp04.n_closest = 0;
            cJSON_ArrayForEach(w, x) {
                if (job->sp04.n_closest < 16)
                    job->sp04.w_closest[job->sp04.n_closest++] = w->valuedouble;
            }
        }
    }

    /* ---- multicomponent parameters (defaults from the core) ---- */
    dtx_mc_params_default(&job->mc);
    /* ---- biharmonic parameters (defaults from the core) ---- */
    {
        dtx_kp_params d;
        dtx_kp_params_default(&d);
        job->bh.keypoints = DTX_BH_KEYS_MARKERS;
        job->bh.candidates = d.candidates;
        job->bh.eps = d.eps;
        job->bh.max_keypoints = d.max_keys;
        job->bh.training_frames = DEFAULT_TRAINING_FRAMES;
        dtx_bh_params_default(&job->bh.transfer);
        job->bh.transfer.skin.lambda = d.skin.lambda;
        job->bh.transfer.skin.gamma_logr = d.skin.gamma_logr;
        job->bh.transfer.skin.gamma_s = d.skin.gamma_s;
    }

    /* ---- springs parameters (defaults from the core) ---- */
    dtx_springs_params_default(&job->springs);

    /* ---- each method's object, as its table names the settings ---- */
    for (int k = 0; k < 4; k++) {
        setting_ref refs[64];
        int n = method_settings(job, (dtx_method)k, refs, 64);
        read_settings(get(doc, method_names[k]), refs, n);
    }
    /* The paper's absolute lengths come with the paper's weight unless
     * w_proximity is given. */
    if (job->mc.lengths == DTX_MC_LENGTHS_DIAGONAL && !get(mc, "w_proximity"))
        job->mc.w_proximity = DTX_MC_W_PROXIMITY_DIAGONAL;
    return DTX_OK;
}

/* ------------------------------------------------------------------ */
/* Cross-field rules                                                   */
/* ------------------------------------------------------------------ */

typedef struct {
    int32_t vertex;
    int32_t index;
} pinrec;

static int pinrec_cmp(const void *a, const void *b)
{
    const pinrec *x = a, *y = b;
    if (x->vertex != y->vertex)
        return (x->vertex > y->vertex) - (x->vertex < y->vertex);
    return (x->index > y->index) - (x->index < y->index);
}

static dtx_status check_pins(fillctx *f, const dtx_job_target *tg, int t)
{
    char ptr[96];
    pinrec *recs;
    int32_t i, first = -1, other = -1, vertex = 0;
    if (tg->translation == DTX_TRANSLATION_PINS && tg->npins == 0) {
        snprintf(ptr, sizeof ptr, "/targets/%d/translation", t);
        return job_err(f->err, DTX_EJOB, f->name, ptr,
                       "translation \"pins\" needs at least one pin in \"pins\"");
    }
    if (tg->translation == DTX_TRANSLATION_FOLLOW && tg->npins > 0) {
        snprintf(ptr, sizeof ptr, "/targets/%d/pins", t);
        return job_err(f->err, DTX_EJOB, f->name, ptr,
                       "pins cannot be used with translation \"follow\" (use \"fixed\" or "
                       "\"pins\")");
    }
    if (tg->npins < 2)
        return DTX_OK;
    recs = dtx_alloc((size_t)tg->npins, sizeof *recs, 0);
    if (!recs)
        return nomem(f);
    for (i = 0; i < tg->npins; i++) {
        recs[i].vertex = tg->pins[i].vertex;
        recs[i].index = i;
    }
    qsort(recs, (size_t)tg->npins, sizeof *recs, pinrec_cmp);
    for (i = 1; i < tg->npins; i++)
        if (recs[i].vertex == recs[i - 1].vertex && (first < 0 || recs[i].index < first)) {
            first = recs[i].index;
            other = recs[i - 1].index;
            vertex = recs[i].vertex;
        }
    free(recs);
    if (first >= 0) {
        /* Sorted by (vertex, index), the chosen repetition is the second
         * of its run, so other is the vertex's first pin. */
        snprintf(ptr, sizeof ptr, "/targets/%d/pins/%d/vertex", t, (int)first);
        return job_err(f->err, DTX_EJOB, f->name, ptr,
                       "vertex %d is pinned twice (also /targets/%d/pins/%d)", (int)vertex, t,
                       (int)other);
    }
    return DTX_OK;
}

/* Checks that the file at path exists and is a readable file. */
static dtx_status check_input_file(fillctx *f, const char *ptr, const char *path)
{
    struct stat sb;
    if (stat(path, &sb) != 0) {
        if (errno == ENOENT || errno == ENOTDIR)
            return job_err(f->err, DTX_EJOB, f->name, ptr, "no such file: %s", path);
        return job_err(f->err, DTX_EJOB, f->name, ptr, "cannot access %s: %s", path,
                       strerror(errno));
    }
    if (S_ISDIR(sb.st_mode))
        return job_err(f->err, DTX_EJOB, f->name, ptr, "is a directory, not a file: %s", path);
    if (!S_ISREG(sb.st_mode)) /* a FIFO would block the run when it is read */
        return job_err(f->err, DTX_EJOB, f->name, ptr, "not a regular file (%s): %s",
                       dtx_file_kind(sb.st_mode), path);
    if (access(path, R_OK) != 0)
        return job_err(f->err, DTX_EJOB, f->name, ptr, "cannot read %s: %s", path,
                       strerror(errno));
    return DTX_OK;
}

typedef struct {
    char ptr[96];
    const char *path;
} input_file;

static dtx_status cross_check(fillctx *f, const dtx_job *job, int check_files)
{
    input_file *inputs;
    int32_t i, j, n = 0;
    dtx_status st = DTX_OK;

    /* ---- sequence names: each becomes a result's name
     * (/results/TARGET/NAME), so it follows the object name rule; a "*"
     * stands for the sequences found, which are listed without temporary
     * groups. ---- */
    for (i = 0; i < job->nsequences; i++) {
        char *b = base_name(job->sequences[i]), ptr[64];
        dtx_error why;
        int bad;
        if (!b)
            return nomem(f);
        bad = strcmp(b, "*") != 0 && dtx_h5_check_name(b, &why) != DTX_OK;
        free(b);
        if (bad) {
            snprintf(ptr, sizeof ptr, "/source/sequences/%d", (int)i);
            return job_err(f->err, DTX_EJOB, f->name, ptr,
                           "the sequence path \"%.300s\" gives no usable result name: %s",
                           job->sequences[i], why.msg);
        }
    }

    /* ---- repeated sequences ---- */
    for (i = 1; i < job->nsequences; i++)
        for (j = 0; j < i; j++)
            if (strcmp(job->sequences[i], job->sequences[j]) == 0) {
                char ptr[64];
                snprintf(ptr, sizeof ptr, "/source/sequences/%d", (int)i);
                return job_err(f->err, DTX_EJOB, f->name, ptr,
                               "sequence \"%s\" is listed twice (also /source/sequences/%d)",
                               job->sequences[i], (int)j);
            }

    /* ---- targets ---- */
    for (i = 0; i < job->ntargets; i++) {
        const dtx_job_target *tg = &job->targets[i];
        if (tg->markers.csv && tg->markers.index_base != 0 && tg->markers.index_base != 1) {
            char ptr[64];
            snprintf(ptr, sizeof ptr, "/targets/%d/markers", (int)i);
            return job_err(f->err, DTX_EJOB, f->name, ptr,
                           "csv markers need \"index_base\" (0 or 1)");
        }
        if (!tg->markers.csv && !tg->markers.file && job->method != DTX_METHOD_SPRINGS) {
            char ptr[64];
            snprintf(ptr, sizeof ptr, "/targets/%d", (int)i);
            return job_err(f->err, DTX_EJOB, f->name, ptr,
                           "missing required key \"markers\" (only method springs, onto a "
                           "target with the source's own connectivity, works without them)");
        }
        if (job->method == DTX_METHOD_BIHARMONIC &&
            (tg->npins > 0 || tg->translation == DTX_TRANSLATION_PINS)) {
            char ptr[64];
            snprintf(ptr, sizeof ptr, "/targets/%d/%s", (int)i,
                     tg->translation == DTX_TRANSLATION_PINS ? "translation" : "pins");
            return job_err(f->err, DTX_EJOB, f->name, ptr,
                           "method biharmonic does not support pins (the key points place "
                           "the target; use translation \"fixed\" or \"follow\")");
        }
        if ((st = check_pins(f, tg, (int)i)))
            return st;
        for (j = 0; j < i; j++)
            if (strcmp(tg->name, job->targets[j].name) == 0) {
                char ptr[64];
                snprintf(ptr, sizeof ptr, "/targets/%d", (int)i);
                return job_err(f->err, DTX_EJOB, f->name, ptr,
                               "target name \"%s\" is already used by /targets/%d (names "
                               "default to the mesh path's last part; give \"name\")",
                               tg->name, (int)j);
            }
    }

    /* ---- the input files, in document order ---- */
    inputs = dtx_alloc(1 + 2 * (size_t)job->ntargets, sizeof *inputs, 1);
    if (!inputs)
        return nomem(f);
    snprintf(inputs[n].ptr, sizeof inputs[n].ptr, "/source/file");
    inputs[n++].path = job->source_file;
    for (i = 0; i < job->ntargets; i++) {
        const dtx_job_target *tg = &job->targets[i];
        snprintf(inputs[n].ptr, sizeof inputs[n].ptr, "/targets/%d/file", (int)i);
        inputs[n++].path = tg->file;
        snprintf(inputs[n].ptr, sizeof inputs[n].ptr, "/targets/%d/markers/%s", (int)i,
                 tg->markers.csv ? "csv" : "file");
        inputs[n++].path = tg->markers.csv ? tg->markers.csv : tg->markers.file;
    }

    for (i = 0; i < n; i++) {
        int same;
        if (!inputs[i].path)
            continue;
        same = same_file(job->output_file, inputs[i].path);
        if (same < 0) {
            st = nomem(f);
            goto done;
        }
        if (same) {
            st = job_err(f->err, DTX_EJOB, f->name, "/output/file",
                         "the output file %s is also an input (%s); results must go to a "
                         "separate file",
                         job->output_file, inputs[i].ptr);
            goto done;
        }
    }
    if (check_files)
        for (i = 0; i < n; i++)
            if (inputs[i].path && (st = check_input_file(f, inputs[i].ptr, inputs[i].path)))
                goto done;
done:
    free(inputs);
    return st;
}

/* ------------------------------------------------------------------ */
/* Public functions                                                    */
/* ------------------------------------------------------------------ */

dtx_status dtx_job_parse(const char *text, size_t len, const char *name, const char *base_dir,
                         int check_files, dtx_job *job, dtx_error *err)
{
    cJSON *doc = NULL, *schema = NULL;
    char *schema_text = NULL, *base = NULL, msg[1024];
    const char *end = NULL;
    size_t i;
    fillctx f;
    dtx_status st;
    const char *given = name;

    if (!job)
        return dtx_seterr(err, DTX_EINVAL, "dtx_job_parse: job is NULL");
    memset(job, 0, sizeof *job);
    if (!name)
        name = "job";
    if (!text)
        return dtx_seterr(err, DTX_EINVAL, "%s: no text", name);

    job->text = malloc(len + 1);
    job->job_path = given ? dup_str(given) : NULL;
    if (!job->text || (given && !job->job_path)) {
        st = dtx_seterr(err, DTX_ENOMEM, "%s: out of memory", name);
        goto fail;
    }
    memcpy(job->text, text, len);
    job->text[len] = '\0';

    /* ---- syntax ---- */
    for (i = 0; i < len && (text[i] == ' ' || text[i] == '\t' || text[i] == '\n' ||
                            text[i] == '\r');
         i++)
        ;
    if (i == len) {
        st = dtx_seterr(err, DTX_EPARSE, "%s: empty job file (expected a JSON object)", name);
        goto fail;
    }
    /* cJSON copies a NUL byte inside a string and the C string then ends
     * there: "in.h5\0junk" would silently read as "in.h5". */
    {
        const char *nul = memchr(text, '\0', len);
        if (nul) {
            st = syntax_error(name, text, len, (size_t)(nul - text), "NUL byte (not a text file)",
                              err);
            goto fail;
        }
    }
    /* cJSON gives up past its own nesting limit with what reads as a plain
     * syntax error: say what is wrong, and where, first. */
    {
        size_t deep = dtx_json_find_too_deep(text, len, DTX_JSON_MAX_DEPTH), line, col;
        if (deep != (size_t)-1) {
            dtx_json_line_col(text, len, deep, &line, &col);
            st = dtx_seterr(err, DTX_EPARSE, "%s:%zu:%zu: JSON nesting deeper than %d levels",
                            name, line, col, DTX_JSON_MAX_DEPTH);
            goto fail;
        }
    }
    doc = cJSON_ParseWithLengthOpts(text, len, &end, 0);
    if (!doc) {
        st = syntax_error(name, text, len, end ? (size_t)(end - text) : len, NULL, err);
        goto fail;
    }
    /* cJSON decodes \u0000 to a NUL byte and the C string ends there:
     * "sp04\u0000x" would compare equal to "sp04". */
    {
        char ptr[256];
        if (dtx_json_find_nul_escape(text, len, ptr, sizeof ptr) != (size_t)-1) {
            st = dtx_seterr(err, DTX_EJOB,
                            "%s: at %s: a string holding \\u0000 (a NUL character) is not "
                            "allowed",
                            name, ptr[0] ? ptr : "the top level");
            goto fail;
        }
    }
    for (i = (size_t)(end - text); i < len; i++)
        if (!(text[i] == ' ' || text[i] == '\t' || text[i] == '\n' || text[i] == '\r')) {
            st = syntax_error(name, text, len, i, "text after the end of the JSON value", err);
            goto fail;
        }

    /* ---- schema ---- */
    schema_text = dtx_job_schema_text();
    if (!schema_text) {
        st = dtx_seterr(err, DTX_ENOMEM, "%s: out of memory", name);
        goto fail;
    }
    schema = cJSON_Parse(schema_text);
    if (!schema) {
        st = dtx_seterr(err, DTX_EINVAL, "internal error: the built-in job schema is not JSON");
        goto fail;
    }
    st = dtx_json_validate(schema, doc, msg, sizeof msg);
    if (st != DTX_OK) {
        dtx_seterr(err, st, "%s: %s", name, msg);
        goto fail;
    }

    /* ---- fill, then the rules the schema cannot express ---- */
    base = absolute_dir(base_dir);
    if (!base) {
        st = dtx_seterr(err, DTX_EIO, "%s: cannot find the absolute path of %s: %s", name,
                        base_dir && base_dir[0] ? base_dir : "the current directory",
                        strerror(errno));
        goto fail;
    }
    f.name = name;
    f.base = base;
    f.err = err;
    if ((st = fill_job(&f, doc, job)) != DTX_OK)
        goto fail;
    if ((st = cross_check(&f, job, check_files)) != DTX_OK)
        goto fail;

    free(base);
    cJSON_Delete(schema);
    free(schema_text);
    cJSON_Delete(doc);
    return DTX_OK;

fail:
    free(base);
    cJSON_Delete(schema);
    free(schema_text);
    cJSON_Delete(doc);
    dtx_job_free(job);
    return st;
}

dtx_status dtx_job_load(const char *path, dtx_job *job, dtx_error *err)
{
    char *text = NULL, *dir = NULL;
    const char *slash;
    size_t len = 0;
    dtx_status st;

    if (!job)
        return dtx_seterr(err, DTX_EINVAL, "dtx_job_load: job is NULL");
    memset(job, 0, sizeof *job);
    if (!path)
        return dtx_seterr(err, DTX_EINVAL, "dtx_job_load: path is NULL");

    /* Only a regular file, and its size checked before reading: a FIFO
     * would block and a device such as /dev/zero would never end. */
    st = dtx_file_read_regular(path, JOB_MAX_BYTES, &text, &len, err);
    if (st != DTX_OK)
        return st;

    /* Relative paths in the job are relative to the job file's directory. */
    slash = strrchr(path, '/');
    if (slash) {
        size_t n = slash == path ? 1 : (size_t)(slash - path);
        dir = malloc(n + 1);
        if (!dir) {
            st = dtx_seterr(err, DTX_ENOMEM, "%s: out of memory", path);
            goto fail;
        }
        memcpy(dir, path, n);
        dir[n] = '\0';
    }
    st = dtx_job_parse(text ? text : "", len, path, dir ? dir : ".", 1, job, err);
    free(dir);
    free(text);
    return st;

fail:
    free(text);
    return st;
}

void dtx_job_free(dtx_job *job)
{
    int32_t i;
    if (!job)
        return;
    free(job->text);
    free(job->job_path);
    free(job->source_file);
    free(job->source_mesh);
    if (job->sequences)
        for (i = 0; i < job->nsequences; i++)
            free(job->sequences[i]);
    free(job->sequences);
    if (job->targets)
        for (i = 0; i < job->ntargets; i++) {
            dtx_job_target *t = &job->targets[i];
            free(t->name);
            free(t->file);
            free(t->mesh);
            free(t->markers.csv);
            free(t->markers.file);
            free(t->markers.path);
            free(t->pins);
        }
    free(job->targets);
    free(job->output_file);
    free(job->export_obj_dir);
    free(job->corr_store);
    memset(job, 0, sizeof *job);
}

/* ------------------------------------------------------------------ */
/* Canonical parameter text                                            */
/* ------------------------------------------------------------------ */

typedef struct {
    char *buf;
    size_t len, cap;
    int failed;
} sbuf;

static void sb_printf(sbuf *b, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

static void sb_printf(sbuf *b, const char *fmt, ...)
{
    va_list ap;
    int n;
    if (b->failed)
        return;
    va_start(ap, fmt);
    n = vsnprintf(b->buf ? b->buf + b->len : NULL, b->buf ? b->cap - b->len : 0, fmt, ap);
    va_end(ap);
    if (n < 0) {
        b->failed = 1;
        return;
    }
    if (!b->buf || b->len + (size_t)n + 1 > b->cap) {
        size_t cap = b->cap ? b->cap : 256;
        char *nb;
        while (cap < b->len + (size_t)n + 1)
            cap *= 2;
        nb = realloc(b->buf, cap);
        if (!nb) {
            b->failed = 1;
            return;
        }
        b->buf = nb;
        b->cap = cap;
        va_start(ap, fmt);
        vsnprintf(b->buf + b->len, b->cap - b->len, fmt, ap);
        va_end(ap);
    }
    b->len += (size_t)n;
}

/* The method's settings as a JSON object, keys sorted (the canonical
 * form the run key is made of). */
static void write_settings(sbuf *b, const dtx_job *job)
{
    setting_ref refs[64];
    int n = method_settings((dtx_job *)job, job->method, refs, 64);
    for (int i = 1; i < n; i++) /* insertion sort by name; n is small */
        for (int j = i; j > 0 && strcmp(refs[j - 1].row->name, refs[j].row->name) > 0; j--) {
            setting_ref t = refs[j];
            refs[j] = refs[j - 1];
            refs[j - 1] = t;
        }
    sb_printf(b, "{");
    for (int i = 0; i < n; i++) {
        const dtx_setting *s = refs[i].row;
        const char *p = (const char *)refs[i].base + s->offset;
        sb_printf(b, "%s\"%s\":", i ? "," : "", s->name);
        if (s->type == DTX_SETTING_DOUBLE)
            sb_printf(b, "%.17g", *(const double *)p);
        else if (s->type == DTX_SETTING_INT)
            sb_printf(b, "%d", *(const int *)p);
        else if (s->type == DTX_SETTING_BOOL)
            sb_printf(b, "%s", *(const int *)p ? "true" : "false");
        else
            sb_printf(b, "\"%s\"", s->choices[*(const int *)p]);
    }
    sb_printf(b, "}");
}

char *dtx_job_params_json(const dtx_job *job)
{
    sbuf b = {NULL, 0, 0, 0};
    const char *method;
    if (!job || (int)job->method < 0 || (int)job->method >= 4)
        return NULL;
    method = method_names[job->method];
    /* "biharmonic" sorts before "method"; the others after it. */
    if (job->method != DTX_METHOD_BIHARMONIC && job->method != DTX_METHOD_SPRINGS)
        sb_printf(&b, "{\"method\":\"%s\",\"%s\":", method, method);
    if (job->method == DTX_METHOD_MULTICOMPONENT) {
        write_settings(&b, job);
        sb_printf(&b, ",\"sp04\":");
    }
    if (job->method == DTX_METHOD_BIHARMONIC) {
        sb_printf(&b, "{\"biharmonic\":");
        write_settings(&b, job);
        sb_printf(&b, ",\"method\":\"biharmonic\"");
        /* The automatic key points are mapped through sp04's correspondence. */
        if (job->bh.keypoints == DTX_BH_KEYS_AUTO)
            sb_printf(&b, ",\"sp04\":");
    }
    if (job->method == DTX_METHOD_SPRINGS)
        sb_printf(&b, "{\"method\":\"springs\",\"sp04\":");
    if (job->method == DTX_METHOD_SP04 || job->method == DTX_METHOD_MULTICOMPONENT ||
        job->method == DTX_METHOD_SPRINGS ||
        (job->method == DTX_METHOD_BIHARMONIC && job->bh.keypoints == DTX_BH_KEYS_AUTO)) {
        const dtx_sp04_params *p = &job->sp04;
        int i;
        sb_printf(&b, "{\"max_angle_deg\":%.17g,\"max_distance\":%.17g,\"w_closest\":[",
                  p->max_angle_deg, p->max_distance);
        for (i = 0; i < p->n_closest && i < 16; i++)
            sb_printf(&b, "%s%.17g", i ? "," : "", p->w_closest[i]);
        sb_printf(&b, "],\"w_identity\":%.17g,\"w_smooth\":%.17g,\"weights\":\"%s\"}",
                  p->w_identity, p->w_smooth,
                  p->weights == DTX_CORR_WEIGHTS_ELEMENT ? "element" : "area");
        if (job->method == DTX_METHOD_SPRINGS) {
            sb_printf(&b, ",\"springs\":");
            write_settings(&b, job);
        }
    }
    sb_printf(&b, "}");
    if (b.failed) {
        free(b.buf);
        return NULL;
    }
    return b.buf;
}

char *dtx_job_corr_params_json(const dtx_job *job, dtx_transfer_corr corr)
{
    dtx_job as;
    if (!job)
        return NULL;
    as = *job; /* shallow: only read */
    if (corr == DTX_TRANSFER_CORR_SP04)
        as.method = DTX_METHOD_SP04;
    return dtx_job_params_json(&as);
}

void dtx_job_transfer_params(const dtx_job *job, dtx_transfer_params *p)
{
    static const dtx_transfer_kind kinds[] = {
        [DTX_METHOD_SP04] = DTX_TRANSFER_SP04,
        [DTX_METHOD_MULTICOMPONENT] = DTX_TRANSFER_MULTICOMPONENT,
        [DTX_METHOD_SPRINGS] = DTX_TRANSFER_SPRINGS,
        [DTX_METHOD_BIHARMONIC] = DTX_TRANSFER_BIHARMONIC,
    };
    dtx_transfer_params_default(p, kinds[job->method]);
    if (job->method == DTX_METHOD_MULTICOMPONENT)
        p->u.mc = job->mc;
    else if (job->method == DTX_METHOD_SPRINGS)
        p->u.springs = job->springs;
    else if (job->method == DTX_METHOD_BIHARMONIC)
        p->u.bh = job->bh.transfer;
}
