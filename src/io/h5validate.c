/*
 * h5validate.c: checks a file against the dtx HDF5 layout description
 * (schemas/hdf5-layout-v1.json, compiled in as dtx_h5_layout_json()).
 *
 * The description lists, per kind of group (meshes, sequences, markers,
 * key points, correspondences, results), the datasets with their dtype class, sizes and
 * dims (numbers or symbols such as "nv"), the attributes, the references
 * to other groups (soft links and path attributes) and a list of checks.
 * The walk goes kind by kind in the order of the description, so a
 * referenced group (a sequence's rest mesh) is checked, and its symbols
 * known, before the groups that refer to it.
 *
 * Every problem becomes one report line "PATH: problem"; a group without
 * problems gets "PATH: ok".  Data is read only for the value checks (face
 * ranges, finiteness, frame_done), and only after the stored bytes have
 * been found able to hold the dataset's shape.
 */
#include "file_util.h"
#include "h5layout.h"
#include "h5guard.h"
#include "h5mesh_attrs.h"
#include "h5util.h"

#include <cjson/cJSON.h>

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define MAX_SYMS 16
#define MAX_DSETS 8
#define MAX_ATTRS 24
#define MAX_REFS 8

typedef struct {
    char name[32];
    int64_t value;
    char from[64]; /* the dataset or attribute that bound it */
} vsym;

/* A checked group and the symbols found in it. */
typedef struct {
    char path[DTX_H5_PATH_MAX];
    char kind[32];
    int nsym;
    vsym sym[MAX_SYMS];
} vobj;

/* A dataset of the current group as found in the file. */
typedef struct {
    char name[64];
    int usable; /* present, with the expected class and rank */
    int rank;
    hsize_t dims[3];
    H5T_class_t cls;
} vdset;

typedef struct {
    char name[64];
    int is_int;
    int64_t ival;
    char *sval;
} vattr;

typedef struct {
    char name[64];
    long obj; /* index into objs, or -1 when unresolved */
} vref;

typedef struct {
    hid_t file;
    char fname[512];
    /* the report */
    char *buf;
    size_t len, cap;
    int oom;
    int nproblems, nobjects, nbad;
    /* frames of results / sequences whose coordinates were read */
    int nres, nseq;
    long long res_frames, res_checked, seq_frames, seq_checked;
    char first[sizeof(((dtx_error *)0)->msg)];
    /* groups checked so far */
    vobj *objs;
    size_t nobjs, capobjs;
    /* the group being checked */
    vobj cur;
    int cur_problems;
    vdset dsets[MAX_DSETS];
    int ndsets;
    vattr attrs[MAX_ATTRS];
    int nattrs;
    vref refs[MAX_REFS];
    int nrefs;
} vctx;

/* ======================================================== small helpers */

/* out = a b c d e (NULL parts skipped), truncated to n; -1 if truncated.
 * (Hand-written so that the compiler's truncation warnings stay quiet.) */
static int cat5(char *o, size_t n, const char *a, const char *b, const char *c, const char *d,
                const char *e)
{
    const char *parts[5] = {a, b, c, d, e};
    size_t used = 0;
    int trunc = 0;
    for (int i = 0; i < 5; i++)
        for (const char *p = parts[i]; p && *p; p++) {
            if (used + 1 >= n) {
                trunc = 1;
                break;
            }
            o[used++] = *p;
        }
    if (n > 0)
        o[used] = '\0';
    return trunc ? -1 : 0;
}

static int join(const char *group, const char *name, char *out_path, size_t n)
{
    return cat5(out_path, n, group, strcmp(group, "/") == 0 ? "" : "/", name, NULL, NULL);
}

/* ================================================================ report */

#if defined(__GNUC__)
#define DTX_PRINTF(a, b) __attribute__((format(printf, a, b)))
#else
#define DTX_PRINTF(a, b)
#endif

static void DTX_PRINTF(2, 3) out(vctx *c, const char *fmt, ...)
{
    va_list ap;
    int n;
    if (c->oom)
        return;
    va_start(ap, fmt);
    n = vsnprintf(NULL, 0, fmt, ap);
    va_end(ap);
    if (n < 0)
        return;
    if (c->len + (size_t)n + 1 > c->cap) {
        size_t cap = c->cap ? c->cap : 1024;
        char *p;
        while (cap < c->len + (size_t)n + 1)
            cap *= 2;
        p = realloc(c->buf, cap);
        if (!p) {
            c->oom = 1;
            return;
        }
        c->buf = p;
        c->cap = cap;
    }
    va_start(ap, fmt);
    vsnprintf(c->buf + c->len, c->cap - c->len, fmt, ap);
    va_end(ap);
    c->len += (size_t)n;
}

/* Reports a problem of the object at where (a group or dataset path). */
static void DTX_PRINTF(3, 4) problem(vctx *c, const char *where, const char *fmt, ...)
{
    char msg[800];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    out(c, "%s: %s\n", where, msg);
    if (c->nproblems == 0)
        (void)cat5(c->first, sizeof c->first, c->fname, ": ", where, ": ", msg);
    c->nproblems++;
    c->cur_problems++;
}

/* Opens the dataset at full with its type, creation list and, when sp is
 * not NULL, its dataspace.  Returns 0 after reporting "cannot be opened"
 * when any of them fails; what did open is left in the ids for the caller
 * to close. */
static int open_dataset(vctx *c, const char *full, hid_t *d, hid_t *ft, hid_t *sp, hid_t *dcpl)
{
    *d = H5Dopen2(c->file, full, H5P_DEFAULT);
    *ft = *d > 0 ? H5Dget_type(*d) : H5I_INVALID_HID;
    *dcpl = *d > 0 ? H5Dget_create_plist(*d) : H5I_INVALID_HID;
    if (sp)
        *sp = *d > 0 ? H5Dget_space(*d) : H5I_INVALID_HID;
    if (*d < 0 || *ft < 0 || *dcpl < 0 || (sp && *sp < 0)) {
        problem(c, full, "cannot be opened");
        return 0;
    }
    return 1;
}

/* The message of a dtx_error without its leading "FILE: " and "PATH: ". */
static const char *strip_prefix(const vctx *c, const char *msg, const char *path)
{
    size_t n = strlen(c->fname);
    if (strncmp(msg, c->fname, n) == 0 && strncmp(msg + n, ": ", 2) == 0)
        msg += n + 2;
    n = strlen(path);
    if (strncmp(msg, path, n) == 0 && strncmp(msg + n, ": ", 2) == 0)
        msg += n + 2;
    return msg;
}

static const char *jstr(const cJSON *o, const char *key)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
    return cJSON_IsString(v) ? v->valuestring : NULL;
}

static int jbool(const cJSON *o, const char *key)
{
    return cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(o, key));
}

static int jnum(const cJSON *o, const char *key, int64_t *v)
{
    const cJSON *n = cJSON_GetObjectItemCaseSensitive(o, key);
    if (!cJSON_IsNumber(n))
        return 0;
    *v = (int64_t)n->valuedouble;
    return 1;
}

/* "T x nv x 3" from a dims array. */
static void dims_spec_text(const cJSON *dims, char *buf, size_t n)
{
    const cJSON *d;
    size_t used = 0;
    buf[0] = '\0';
    cJSON_ArrayForEach(d, dims)
    {
        int w;
        if (cJSON_IsNumber(d))
            w = snprintf(buf + used, n - used, "%s%d", used ? " x " : "", (int)d->valuedouble);
        else
            w = snprintf(buf + used, n - used, "%s%s", used ? " x " : "",
                         cJSON_IsString(d) ? d->valuestring : "?");
        if (w < 0 || (size_t)w >= n - used)
            break;
        used += (size_t)w;
    }
}

static void dims_found_text(const hsize_t *dims, int rank, char *buf, size_t n)
{
    size_t used = 0;
    buf[0] = '\0';
    for (int k = 0; k < rank; k++) {
        int w = snprintf(buf + used, n - used, "%s%llu", k ? " x " : "",
                         (unsigned long long)dims[k]);
        if (w < 0 || (size_t)w >= n - used)
            break;
        used += (size_t)w;
    }
}

static const char *class_text(H5T_class_t cls, H5T_sign_t sign)
{
    switch (cls) {
    case H5T_INTEGER: return sign == H5T_SGN_NONE ? "unsigned integer" : "signed integer";
    case H5T_FLOAT: return "float";
    case H5T_STRING: return "string";
    case H5T_COMPOUND: return "compound";
    case H5T_ENUM: return "enum";
    case H5T_VLEN: return "variable-length sequence";
    case H5T_ARRAY: return "array";
    case H5T_OPAQUE: return "opaque";
    case H5T_REFERENCE: return "reference";
    case H5T_BITFIELD: return "bitfield";
    default: return "unknown";
    }
}

/* =============================================================== symbols */

static vsym *find_sym(vobj *o, const char *name)
{
    for (int i = 0; i < o->nsym; i++)
        if (strcmp(o->sym[i].name, name) == 0)
            return &o->sym[i];
    return NULL;
}

/* Binds symbol name to value, or reports a disagreement with its earlier
 * binding.  where/what describe the new occurrence. */
static void bind(vctx *c, const char *name, int64_t value, const char *where, const char *what)
{
    vsym *s = find_sym(&c->cur, name);
    if (s) {
        if (s->value != value)
            problem(c, where, "%s is %lld, but %s is %lld (from %s)", what, (long long)value,
                    name, (long long)s->value, s->from);
        return;
    }
    if (c->cur.nsym < MAX_SYMS) {
        s = &c->cur.sym[c->cur.nsym++];
        snprintf(s->name, sizeof s->name, "%s", name);
        snprintf(s->from, sizeof s->from, "%s", what);
        s->value = value;
    }
}

/* Value of "nv" (current group) or "rest.nv" (a referenced group).
 * Returns 0 when unknown; *desc names where it came from. */
static int lookup(vctx *c, const char *name, int64_t *value, char *desc, size_t n)
{
    const char *dot = strchr(name, '.');
    vsym *s;
    if (!dot) {
        s = find_sym(&c->cur, name);
        if (!s)
            return 0;
        *value = s->value;
        snprintf(desc, n, "%s (from %s)", name, s->from);
        return 1;
    }
    for (int i = 0; i < c->nrefs; i++)
        if (strlen(c->refs[i].name) == (size_t)(dot - name) &&
            strncmp(c->refs[i].name, name, (size_t)(dot - name)) == 0) {
            vobj *o;
            if (c->refs[i].obj < 0)
                return 0;
            o = &c->objs[c->refs[i].obj];
            s = find_sym(o, dot + 1);
            if (!s)
                return 0;
            *value = s->value;
            snprintf(desc, n, "%s of %s", dot + 1, o->path);
            return 1;
        }
    return 0;
}

static vdset *find_dset(vctx *c, const char *name)
{
    for (int i = 0; i < c->ndsets; i++)
        if (strcmp(c->dsets[i].name, name) == 0)
            return &c->dsets[i];
    return NULL;
}

static vattr *find_attr(vctx *c, const char *name)
{
    for (int i = 0; i < c->nattrs; i++)
        if (strcmp(c->attrs[i].name, name) == 0)
            return &c->attrs[i];
    return NULL;
}

/* ============================================================== datasets */

static int dtype_matches(const char *want, H5T_class_t cls, H5T_sign_t sign)
{
    if (strcmp(want, "float") == 0)
        return cls == H5T_FLOAT;
    if (strcmp(want, "int") == 0)
        return cls == H5T_INTEGER && sign == H5T_SGN_2;
    if (strcmp(want, "uint") == 0)
        return cls == H5T_INTEGER && sign == H5T_SGN_NONE;
    if (strcmp(want, "string") == 0)
        return cls == H5T_STRING;
    return 0;
}

static const char *dtype_text(const char *want)
{
    if (strcmp(want, "float") == 0)
        return "float";
    if (strcmp(want, "int") == 0)
        return "signed integer";
    if (strcmp(want, "uint") == 0)
        return "unsigned integer";
    return want;
}

static void check_dataset(vctx *c, const char *group, const cJSON *spec)
{
    const char *name = spec->string, *dtype = jstr(spec, "dtype"), *layout = jstr(spec, "layout");
    const cJSON *dims = cJSON_GetObjectItemCaseSensitive(spec, "dims");
    const cJSON *sizes = cJSON_GetObjectItemCaseSensitive(spec, "sizes");
    char full[DTX_H5_PATH_MAX], shape[200], found[200];
    hid_t d = H5I_INVALID_HID, ft = H5I_INVALID_HID, sp = H5I_INVALID_HID;
    hid_t dcpl = H5I_INVALID_HID;
    H5O_info_t info;
    vdset *rec;
    int rank, want_rank = cJSON_GetArraySize(dims), k = 0;
    H5T_class_t cls;
    H5T_sign_t sign = H5T_SGN_ERROR;
    const cJSON *dim;

    if (c->ndsets >= MAX_DSETS || join(group, name, full, sizeof full))
        return;
    rec = &c->dsets[c->ndsets++];
    memset(rec, 0, sizeof *rec);
    snprintf(rec->name, sizeof rec->name, "%s", name);
    dims_spec_text(dims, shape, sizeof shape);

    if (H5Lexists(c->file, full, H5P_DEFAULT) <= 0) {
        if (jbool(spec, "required"))
            problem(c, group, "missing dataset %s (%s %s)", name, dtype ? dtype : "", shape);
        return;
    }
    if (H5Oexists_by_name(c->file, full, H5P_DEFAULT) <= 0) {
        problem(c, full, "link does not resolve to an object");
        return;
    }
    if (H5Oget_info_by_name2(c->file, full, &info, H5O_INFO_BASIC, H5P_DEFAULT) < 0 ||
        info.type != H5O_TYPE_DATASET) {
        problem(c, full, "is not a dataset");
        return;
    }
    if (!open_dataset(c, full, &d, &ft, &sp, &dcpl))
        goto done;
    cls = H5Tget_class(ft);
    if (cls == H5T_INTEGER)
        sign = H5Tget_sign(ft);
    rec->cls = cls;
    rank = H5Sget_simple_extent_ndims(sp);
    rec->rank = rank < 0 ? 0 : rank;
    if (rank > 3 || H5Sget_simple_extent_dims(sp, rec->dims, NULL) < 0) {
        problem(c, full, "expected %d dimension%s %s, found %d", want_rank,
                want_rank == 1 ? "" : "s", shape, rank);
        goto done;
    }
    /* ---------------------------------------------------- dtype */
    if (dtype && !dtype_matches(dtype, cls, sign)) {
        problem(c, full, "expected %s values, found %s", dtype_text(dtype), class_text(cls, sign));
        goto done;
    }
    if (sizes && cls != H5T_STRING) {
        const cJSON *s;
        size_t size = H5Tget_size(ft);
        int ok = 0;
        char list[64] = "";
        size_t used = 0;
        cJSON_ArrayForEach(s, sizes)
        {
            int w;
            if (cJSON_IsNumber(s) && (size_t)s->valuedouble == size)
                ok = 1;
            w = snprintf(list + used, sizeof list - used, "%s%d", used ? " or " : "",
                         8 * (int)s->valuedouble);
            if (w > 0 && (size_t)w < sizeof list - used)
                used += (size_t)w;
        }
        if (!ok) {
            problem(c, full, "expected %s-bit %s values, found %d-bit", list,
                    dtype_text(dtype ? dtype : "?"), 8 * (int)size);
            goto done;
        }
    }
    /* ---------------------------------------------------- shape */
    if (rank != want_rank) {
        problem(c, full, "expected %d dimension%s %s, found %d", want_rank,
                want_rank == 1 ? "" : "s", shape, rank);
        goto done;
    }
    dims_found_text(rec->dims, rank, found, sizeof found);
    rec->usable = 1;
    cJSON_ArrayForEach(dim, dims)
    {
        if (cJSON_IsNumber(dim) && rec->dims[k] != (hsize_t)dim->valuedouble) {
            problem(c, full, "expected shape %s, found %s", shape, found);
            rec->usable = 0;
        } else if (cJSON_IsString(dim)) {
            char what[128];
            if (rec->dims[k] > (hsize_t)INT32_MAX) {
                problem(c, full, "dimension %d is %llu, more than the %d dtx supports", k,
                        (unsigned long long)rec->dims[k], (int)INT32_MAX);
                rec->usable = 0;
            }
            snprintf(what, sizeof what, "dimension %d of %s", k, name);
            bind(c, dim->valuestring, (int64_t)rec->dims[k], full, what);
        }
        k++;
    }
    if (layout && strcmp(layout, "chunked") == 0 && H5Pget_layout(dcpl) != H5D_CHUNKED)
        problem(c, full, "expected a chunked layout (chunks along the frame dimension)");
done:
    CLOSE_ID(H5Pclose, dcpl);
    CLOSE_ID(H5Sclose, sp);
    CLOSE_ID(H5Tclose, ft);
    CLOSE_ID(H5Dclose, d);
}

/* Reads a whole usable dataset as mtype (esz bytes per value), after
 * checking the stored bytes can hold it.  Returns NULL (with a problem
 * reported, or silently when the dataset was already reported) on
 * failure. */
static void *read_values(vctx *c, const char *group, const vdset *rec, hid_t mtype, size_t esz,
                         size_t *npts)
{
    char full[DTX_H5_PATH_MAX];
    hid_t d = H5I_INVALID_HID, ft = H5I_INVALID_HID, dcpl = H5I_INVALID_HID;
    void *buf = NULL;
    uint64_t need;
    hsize_t stored;
    int nfilt;
    *npts = 1;
    if (!rec->usable || join(group, rec->name, full, sizeof full))
        return NULL;
    for (int k = 0; k < rec->rank; k++)
        *npts *= (size_t)rec->dims[k];
    if (!open_dataset(c, full, &d, &ft, NULL, &dcpl))
        goto done;
    need = (uint64_t)*npts * H5Tget_size(ft);
    stored = H5Dget_storage_size(d);
    nfilt = H5Pget_nfilters(dcpl);
    if (dtx_h5_short_of_storage(need, stored, nfilt)) {
        problem(c, full, "needs %llu bytes, but only %llu %sbytes are stored: the dataset was "
                "never fully written", (unsigned long long)need, (unsigned long long)stored,
                nfilt > 0 ? "compressed " : "");
        goto done;
    }
    buf = dtx_alloc(*npts, esz, 0);
    if (!buf) {
        problem(c, full, "out of memory reading %zu values", *npts);
        goto done;
    }
    if (*npts > 0 && H5Dread(d, mtype, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf) < 0) {
        problem(c, full, "cannot be read");
        free(buf);
        buf = NULL;
    }
done:
    CLOSE_ID(H5Pclose, dcpl);
    CLOSE_ID(H5Tclose, ft);
    CLOSE_ID(H5Dclose, d);
    return buf;
}

/* ============================================================ attributes */

/* A float attribute: one finite value of a floating-point type. */
static void check_float_attribute(vctx *c, const char *obj, const char *name)
{
    hid_t a = H5Aopen_by_name(c->file, obj, name, H5P_DEFAULT, H5P_DEFAULT);
    hid_t t = a >= 0 ? H5Aget_type(a) : H5I_INVALID_HID;
    hid_t sp = a >= 0 ? H5Aget_space(a) : H5I_INVALID_HID;
    double v = 0;
    if (a < 0 || t < 0 || sp < 0)
        problem(c, obj, "cannot open attribute %s", name);
    else if (H5Tget_class(t) != H5T_FLOAT || H5Sget_simple_extent_npoints(sp) != 1)
        problem(c, obj, "attribute %s: expected a single floating-point value", name);
    else if (H5Aread(a, H5T_NATIVE_DOUBLE, &v) < 0)
        problem(c, obj, "cannot read attribute %s", name);
    else if (!isfinite(v))
        problem(c, obj, "attribute %s is not finite", name);
    CLOSE_ID(H5Sclose, sp);
    CLOSE_ID(H5Tclose, t);
    CLOSE_ID(H5Aclose, a);
}

static void check_attribute(vctx *c, const char *obj, const cJSON *spec)
{
    const char *name = spec->string, *type = jstr(spec, "type");
    const cJSON *oneof = cJSON_GetObjectItemCaseSensitive(spec, "one_of");
    const cJSON *value = cJSON_GetObjectItemCaseSensitive(spec, "value");
    const char *equals = jstr(spec, "equals");
    dtx_error e;
    vattr *a;
    htri_t ex;
    int64_t hexlen;

    ex = H5Aexists_by_name(c->file, obj, name, H5P_DEFAULT);
    if (ex <= 0) {
        if (jbool(spec, "required"))
            problem(c, obj, "missing attribute %s (%s)", name, type ? type : "");
        return;
    }
    if (c->nattrs >= MAX_ATTRS)
        return;
    a = &c->attrs[c->nattrs];
    memset(a, 0, sizeof *a);
    snprintf(a->name, sizeof a->name, "%s", name);
    if (type && strcmp(type, "int") == 0) {
        if (dtx_h5_read_attr_int(c->file, obj, name, &a->ival, &e) != DTX_OK) {
            problem(c, obj, "%s", strip_prefix(c, e.msg, obj));
            return;
        }
        a->is_int = 1;
        c->nattrs++;
        if (cJSON_IsNumber(value) && a->ival != (int64_t)value->valuedouble)
            problem(c, obj, "attribute %s is %lld, expected %lld", name, (long long)a->ival,
                    (long long)value->valuedouble);
        if (cJSON_IsArray(oneof)) {
            const cJSON *o;
            int ok = 0;
            cJSON_ArrayForEach(o, oneof) ok |= cJSON_IsNumber(o) &&
                                               (int64_t)o->valuedouble == a->ival;
            if (!ok)
                problem(c, obj, "attribute %s is %lld, not one of the allowed values", name,
                        (long long)a->ival);
        }
        if (equals) {
            char what[96];
            snprintf(what, sizeof what, "attribute %s", name);
            bind(c, equals, a->ival, obj, what);
        }
        return;
    }
    if (type && strcmp(type, "float") == 0) {
        check_float_attribute(c, obj, name);
        return;
    }
    if (dtx_h5_read_attr_str(c->file, obj, name, &a->sval, &e) != DTX_OK) {
        problem(c, obj, "%s", strip_prefix(c, e.msg, obj));
        return;
    }
    c->nattrs++;
    if (cJSON_IsString(value) && strcmp(a->sval, value->valuestring) != 0)
        problem(c, obj, "attribute %s is \"%.100s\", expected \"%s\"", name, a->sval,
                value->valuestring);
    if (jbool(spec, "json") && a->sval[0]) {
        cJSON *j = cJSON_Parse(a->sval);
        if (!j)
            problem(c, obj, "attribute %s is not valid JSON", name);
        cJSON_Delete(j);
    }
    if (jnum(spec, "hex", &hexlen)) {
        size_t n = strlen(a->sval);
        int ok = (int64_t)n == hexlen;
        for (size_t i = 0; i < n && ok; i++)
            ok = (a->sval[i] >= '0' && a->sval[i] <= '9') ||
                 (a->sval[i] >= 'a' && a->sval[i] <= 'f');
        if (!ok)
            problem(c, obj, "attribute %s is \"%.40s\", expected %d lowercase hex digits", name,
                    a->sval, (int)hexlen);
    }
}

/* ============================================================ references */

static long find_obj(vctx *c, const char *path)
{
    for (size_t i = 0; i < c->nobjs; i++)
        if (strcmp(c->objs[i].path, path) == 0)
            return (long)i;
    return -1;
}

static void check_reference(vctx *c, const char *group, const cJSON *spec)
{
    const char *link = jstr(spec, "link"), *attr = jstr(spec, "attribute");
    const char *kind = jstr(spec, "kind");
    int required = jbool(spec, "required");
    char full[DTX_H5_PATH_MAX], target[DTX_H5_PATH_MAX] = "";
    vref *r;
    long idx;

    if (c->nrefs >= MAX_REFS)
        return;
    r = &c->refs[c->nrefs++];
    snprintf(r->name, sizeof r->name, "%s", spec->string);
    r->obj = -1;

    /* ------------------------------------------------- soft link */
    if (link && join(group, link, full, sizeof full) == 0) {
        H5L_info_t li;
        if (H5Lexists(c->file, full, H5P_DEFAULT) <= 0) {
            if (required)
                problem(c, group, "missing soft link %s (to a %s group)", link,
                        kind ? kind : "");
            return;
        }
        if (H5Lget_info(c->file, full, &li, H5P_DEFAULT) < 0) {
            problem(c, full, "cannot read the link");
            return;
        }
        if (li.type != H5L_TYPE_SOFT) {
            problem(c, full, "expected a soft link to a %s group", kind ? kind : "");
            return;
        }
        if (li.u.val_size == 0 || li.u.val_size >= sizeof target ||
            H5Lget_val(c->file, full, target, sizeof target, H5P_DEFAULT) < 0) {
            problem(c, full, "cannot read the link's target");
            return;
        }
        target[li.u.val_size - 1] = '\0';
        if (H5Oexists_by_name(c->file, full, H5P_DEFAULT) <= 0) {
            problem(c, full, "soft link to %s does not resolve", target);
            return;
        }
    }
    /* ------------------------------------------------- path attribute */
    if (attr) {
        vattr *a = find_attr(c, attr);
        if (!a || a->is_int)
            return; /* missing or mistyped: reported with the attributes */
        if (target[0]) {
            if (strcmp(a->sval, target) != 0)
                problem(c, group, "attribute %s is \"%.200s\", but link %s points to %s", attr,
                        a->sval, link, target);
        } else if (a->sval[0] == '/' && !strstr(a->sval, ":/")) {
            /* An in-file path; "FILE:/PATH" (the file part may itself be
             * absolute) names an object in another file and is not followed. */
            snprintf(target, sizeof target, "%s", a->sval);
            if (!dtx_h5_path_exists(c->file, target)) {
                problem(c, group, "attribute %s names %s, which does not exist in this file",
                        attr, target);
                return;
            }
        } else if (a->sval[0] == '\0') {
            if (required)
                problem(c, group, "attribute %s is empty", attr);
            return;
        } else {
            return; /* "FILE:PATH": another file, not followed */
        }
    }
    if (!target[0])
        return;
    idx = find_obj(c, target);
    if (idx < 0 || (kind && strcmp(c->objs[idx].kind, kind) != 0))
        problem(c, group, "%s %s is not a checked %s group (/%s/NAME)", spec->string, target,
                kind ? kind : "", kind ? kind : "");
    else
        r->obj = idx;
}

/* ================================================================ checks */

static void check_range(vctx *c, const char *group, const cJSON *spec)
{
    const char *dname = jstr(spec, "dataset"), *below = jstr(spec, "below");
    vdset *rec = dname ? find_dset(c, dname) : NULL;
    int64_t min = INT64_MIN, max = INT64_MAX, column = -1, bad = 0, first_i = -1, first_v = 0;
    char desc[DTX_H5_PATH_MAX + 64] = "", full[DTX_H5_PATH_MAX];
    size_t npts, ncols;
    int64_t *v;
    if (!rec || !rec->usable || rec->cls != H5T_INTEGER)
        return;
    jnum(spec, "min", &min);
    jnum(spec, "column", &column);
    if (below && !lookup(c, below, &max, desc, sizeof desc))
        max = INT64_MAX; /* unknown bound: only the minimum is checked */
    if (!below && jnum(spec, "max", &max)) {
        snprintf(desc, sizeof desc, "at most %lld", (long long)max);
        max = max < INT64_MAX ? max + 1 : max;
    }
    v = read_values(c, group, rec, H5T_NATIVE_INT64, sizeof(int64_t), &npts);
    if (!v)
        return;
    ncols = rec->rank == 2 && rec->dims[1] > 0 ? (size_t)rec->dims[1] : 1;
    for (size_t i = 0; i < npts; i++) {
        if (column >= 0 && (int64_t)(i % ncols) != column)
            continue;
        if (v[i] < min || v[i] >= max) {
            if (bad++ == 0) {
                first_i = (int64_t)i;
                first_v = v[i];
            }
        }
    }
    free(v);
    if (bad) {
        join(group, dname, full, sizeof full);
        if (max == INT64_MAX)
            problem(c, full, "%lld value%s below %lld; first %lld at [%lld, %lld]",
                    (long long)bad, bad == 1 ? "" : "s", (long long)min, (long long)first_v,
                    (long long)(first_i / (int64_t)ncols), (long long)(first_i % (int64_t)ncols));
        else
            problem(c, full,
                    "%lld value%s out of range [%lld, %lld) (%s); first %lld at [%lld, %lld]",
                    (long long)bad, bad == 1 ? "" : "s", (long long)min, (long long)max, desc,
                    (long long)first_v, (long long)(first_i / (int64_t)ncols),
                    (long long)(first_i % (int64_t)ncols));
    }
}

/* Every value of a float dataset is finite (and, with "min", at least
 * that: written so that NaN fails).  With "done", a dataset of one entry
 * per frame is checked in the frames whose entry in that dataset is 1 (the
 * others hold the fill value); the flags are checked with the datasets. */
static void check_finite(vctx *c, const char *group, const cJSON *spec)
{
    const char *dname = jstr(spec, "dataset"), *dn = jstr(spec, "done");
    vdset *rec = dname ? find_dset(c, dname) : NULL, *drec = dn ? find_dset(c, dn) : NULL;
    char full[DTX_H5_PATH_MAX];
    size_t npts, ncols, nflags = 0;
    int64_t min = 0, *flags = NULL;
    const int has_min = jnum(spec, "min", &min);
    double *v;
    if (!rec || !rec->usable || rec->cls != H5T_FLOAT)
        return;
    if (dn && (!drec || !drec->usable || rec->rank != 1 || drec->rank != 1 ||
               drec->dims[0] != rec->dims[0]))
        return; /* missing or misshapen: reported with the datasets */
    if (dn && !(flags = read_values(c, group, drec, H5T_NATIVE_INT64, sizeof(int64_t), &nflags)))
        return;
    v = read_values(c, group, rec, H5T_NATIVE_DOUBLE, sizeof(double), &npts);
    if (!v) {
        free(flags);
        return;
    }
    ncols = rec->rank == 2 && rec->dims[1] > 0 ? (size_t)rec->dims[1] : 1;
    for (size_t i = 0; i < npts; i++) {
        if (flags && (i >= nflags || flags[i] != 1))
            continue;
        if (!isfinite(v[i])) {
            join(group, dname, full, sizeof full);
            if (flags)
                problem(c, full, "value at [%zu] is not finite (%g) although %s[%zu] = 1", i, v[i],
                        dn, i);
            else
                problem(c, full, "value at [%zu, %zu] is not finite (%g)", i / ncols, i % ncols,
                        v[i]);
            break;
        }
        if (has_min && !(v[i] >= (double)min)) {
            join(group, dname, full, sizeof full);
            problem(c, full, "value at [%zu, %zu] is %g, below %lld", i / ncols, i % ncols, v[i],
                    (long long)min);
            break;
        }
    }
    free(v);
    free(flags);
}

/* Every coordinate of a T x nv x 3 dataset is finite: in every frame, or,
 * with "done", in the frames whose entry in that dataset is 1 (the others
 * hold undefined values).  Frames are read a block at a time, so a result
 * of 20,000 frames never sits in memory whole.  Counts the frames for the
 * summary. */
static void check_finite_frames(vctx *c, const char *group, const cJSON *spec)
{
    enum { BLOCK_VALUES = 1 << 21 }; /* 16 MiB of doubles */
    const char *dname = jstr(spec, "dataset"), *dn = jstr(spec, "done");
    vdset *rec = dname ? find_dset(c, dname) : NULL, *drec = dn ? find_dset(c, dn) : NULL;
    char full[DTX_H5_PATH_MAX];
    hid_t d = H5I_INVALID_HID, ft = H5I_INVALID_HID, dcpl = H5I_INVALID_HID;
    hid_t fs = H5I_INVALID_HID, ms = H5I_INVALID_HID;
    int64_t *flags = NULL;
    double *buf = NULL;
    size_t nflags = 0, fvals, block;
    hsize_t T, ndone = 0, nbad = 0, first_f = 0, first_v = 0;
    double first_x = 0;
    uint64_t need;
    int is_res = strcmp(c->cur.kind, "results") == 0, nfilt;

    if (!rec || !rec->usable || rec->cls != H5T_FLOAT || rec->rank != 3 ||
        join(group, dname, full, sizeof full))
        return;
    if (dn && (!drec || !drec->usable || drec->rank != 1 || drec->dims[0] != rec->dims[0]))
        return; /* the flags are missing or misshapen: reported with the datasets */
    T = rec->dims[0];
    fvals = (size_t)rec->dims[1] * (size_t)rec->dims[2];
    if (dn) {
        flags = read_values(c, group, drec, H5T_NATIVE_INT64, sizeof(int64_t), &nflags);
        if (!flags)
            return;
    }
    for (hsize_t f = 0; f < T; f++)
        ndone += !flags || flags[f] == 1;
    if (!open_dataset(c, full, &d, &ft, &fs, &dcpl))
        goto done;
    /* The frames to read must be stored: a forged shape cannot make the
     * check read terabytes of fill values. */
    need = (uint64_t)ndone * fvals * H5Tget_size(ft);
    nfilt = H5Pget_nfilters(dcpl);
    if (dtx_h5_short_of_storage(need, H5Dget_storage_size(d), nfilt)) {
        problem(c, full, "%llu frame%s%s need %llu bytes, but only %llu %sbytes are stored",
                (unsigned long long)ndone, ndone == 1 ? "" : "s", dn ? " marked done" : "",
                (unsigned long long)need, (unsigned long long)H5Dget_storage_size(d),
                nfilt > 0 ? "compressed " : "");
        goto done;
    }
    block = fvals > 0 && fvals < BLOCK_VALUES ? BLOCK_VALUES / fvals : 1;
    buf = dtx_alloc(block, fvals * sizeof *buf, 0);
    if (!buf && fvals > 0) {
        problem(c, full, "out of memory reading %zu frames", block);
        goto done;
    }
    for (hsize_t f0 = 0; fvals > 0 && f0 < T; f0 += block) {
        hsize_t n = T - f0 < block ? T - f0 : block, any = 0;
        hsize_t start[3] = {f0, 0, 0}, count[3] = {n, rec->dims[1], rec->dims[2]};
        for (hsize_t f = f0; f < f0 + n; f++)
            any += !flags || flags[f] == 1;
        if (!any)
            continue;
        ms = H5Screate_simple(3, count, NULL);
        if (ms < 0 || H5Sselect_hyperslab(fs, H5S_SELECT_SET, start, NULL, count, NULL) < 0 ||
            H5Dread(d, H5T_NATIVE_DOUBLE, ms, fs, H5P_DEFAULT, buf) < 0) {
            problem(c, full, "frames %llu to %llu cannot be read", (unsigned long long)f0,
                    (unsigned long long)(f0 + n - 1));
            goto done;
        }
        CLOSE_ID(H5Sclose, ms);
        for (hsize_t f = f0; f < f0 + n; f++) {
            const double *x = buf + (size_t)(f - f0) * fvals;
            if (flags && flags[f] != 1)
                continue;
            for (size_t i = 0; i < fvals; i++)
                if (!isfinite(x[i])) {
                    if (nbad++ == 0) {
                        first_f = f;
                        first_v = i / 3;
                        first_x = x[i];
                    }
                    break;
                }
        }
    }
    if (nbad)
        problem(c, full, "%llu of %llu frame%s%s hold%s non-finite coordinates; first frame "
                "%llu (0-based), vertex %llu (%g)",
                (unsigned long long)nbad, (unsigned long long)ndone, ndone == 1 ? "" : "s",
                dn ? " marked done" : "", nbad == 1 ? "s" : "", (unsigned long long)first_f,
                (unsigned long long)first_v, first_x);
    if (is_res) {
        c->nres++;
        c->res_frames += (long long)T;
        c->res_checked += (long long)ndone;
    } else {
        c->nseq++;
        c->seq_frames += (long long)T;
        c->seq_checked += (long long)ndone;
    }
done:
    CLOSE_ID(H5Sclose, ms);
    CLOSE_ID(H5Sclose, fs);
    CLOSE_ID(H5Pclose, dcpl);
    CLOSE_ID(H5Tclose, ft);
    CLOSE_ID(H5Dclose, d);
    free(buf);
    free(flags);
}

static void check_all_equal(vctx *c, const char *group, const cJSON *spec)
{
    const char *dname = jstr(spec, "dataset");
    const cJSON *when = cJSON_GetObjectItemCaseSensitive(spec, "when");
    vdset *rec = dname ? find_dset(c, dname) : NULL;
    int64_t want = 0, wval = 0, bad = 0, first = -1;
    char full[DTX_H5_PATH_MAX];
    const char *wattr = NULL;
    size_t npts;
    int64_t *v;
    if (!rec || !rec->usable || rec->cls != H5T_INTEGER || !jnum(spec, "value", &want))
        return;
    if (when) {
        vattr *a;
        wattr = jstr(when, "attribute");
        a = wattr ? find_attr(c, wattr) : NULL;
        if (!a || !a->is_int || !jnum(when, "value", &wval) || a->ival != wval)
            return;
    }
    v = read_values(c, group, rec, H5T_NATIVE_INT64, sizeof(int64_t), &npts);
    if (!v)
        return;
    for (size_t i = 0; i < npts; i++)
        if (v[i] != want && bad++ == 0)
            first = (int64_t)i;
    free(v);
    if (bad) {
        join(group, dname, full, sizeof full);
        problem(c, full, "%lld of %zu entries are not %lld%s%s%s; first at [%lld]",
                (long long)bad, npts, (long long)want, wattr ? " although " : "",
                wattr ? wattr : "", wattr ? " = 1" : "", (long long)first);
    }
}

static void check_one(vctx *c, const char *group, const cJSON *spec)
{
    const char *what = jstr(spec, "check");
    char da[DTX_H5_PATH_MAX + 64], db[DTX_H5_PATH_MAX + 64];
    int64_t a, b;
    if (!what)
        return;
    if (strcmp(what, "at_least") == 0) {
        const char *s = jstr(spec, "symbol");
        if (s && lookup(c, s, &a, da, sizeof da) && jnum(spec, "value", &b) && a < b)
            problem(c, group, "%s is %lld; at least %lld needed", da, (long long)a,
                    (long long)b);
    } else if (strcmp(what, "equal") == 0) {
        const char *sa = jstr(spec, "a"), *sb = jstr(spec, "b");
        if (sa && sb && lookup(c, sa, &a, da, sizeof da) && lookup(c, sb, &b, db, sizeof db) &&
            a != b)
            problem(c, group, "%s is %lld, but %s is %lld", da, (long long)a, db, (long long)b);
    } else if (strcmp(what, "range") == 0) {
        check_range(c, group, spec);
    } else if (strcmp(what, "finite") == 0) {
        check_finite(c, group, spec);
    } else if (strcmp(what, "finite_frames") == 0) {
        check_finite_frames(c, group, spec);
    } else if (strcmp(what, "all_equal") == 0) {
        check_all_equal(c, group, spec);
    } else if (strcmp(what, "mesh_readable") == 0) {
        /* Only on an otherwise clean mesh, to avoid reporting twice. */
        if (c->cur_problems == 0) {
            dtx_mesh m;
            dtx_error e;
            if (dtx_h5_read_mesh(c->file, group, &m, &e) != DTX_OK)
                problem(c, group, "%s", strip_prefix(c, e.msg, group));
            dtx_mesh_free(&m);
        }
    } else if (strcmp(what, "mesh_attributes") == 0) {
        dtx_error e; /* only on an otherwise clean mesh, as mesh_readable */
        if (c->cur_problems == 0 && dtx_h5_check_mesh_attrs(c->file, group, &e) != DTX_OK)
            problem(c, group, "%s", strip_prefix(c, e.msg, group));
    } else {
        problem(c, group, "layout description: unknown check \"%s\"", what);
    }
}

/* ================================================================ groups */

static void reset_current(vctx *c, const char *path, const char *kind)
{
    for (int i = 0; i < c->nattrs; i++)
        free(c->attrs[i].sval);
    memset(&c->cur, 0, sizeof c->cur);
    snprintf(c->cur.path, sizeof c->cur.path, "%s", path);
    snprintf(c->cur.kind, sizeof c->cur.kind, "%s", kind);
    c->cur_problems = 0;
    c->ndsets = c->nattrs = c->nrefs = 0;
}

static void keep_current(vctx *c)
{
    if (c->nobjs == c->capobjs) {
        size_t cap = c->capobjs ? 2 * c->capobjs : 16;
        vobj *p = realloc(c->objs, cap * sizeof *p);
        if (!p) {
            c->oom = 1;
            return;
        }
        c->objs = p;
        c->capobjs = cap;
    }
    c->objs[c->nobjs++] = c->cur;
}

static void check_group(vctx *c, const cJSON *kind, const char *path)
{
    const cJSON *item;
    reset_current(c, path, jstr(kind, "name"));
    c->nobjects++;
    cJSON_ArrayForEach(item, cJSON_GetObjectItemCaseSensitive(kind, "datasets"))
        check_dataset(c, path, item);
    cJSON_ArrayForEach(item, cJSON_GetObjectItemCaseSensitive(kind, "attributes"))
        check_attribute(c, path, item);
    cJSON_ArrayForEach(item, cJSON_GetObjectItemCaseSensitive(kind, "references"))
        check_reference(c, path, item);
    cJSON_ArrayForEach(item, cJSON_GetObjectItemCaseSensitive(kind, "checks"))
        check_one(c, path, item);
    if (c->cur_problems == 0)
        out(c, "%s: ok\n", path);
    else
        c->nbad++;
    keep_current(c);
    reset_current(c, "", "");
}

static int list_members(vctx *c, const char *group, dtx_h5_names *l)
{
    if (dtx_h5_list_names(c->file, group, l) < 0) {
        problem(c, group, "cannot list the group's members");
        return -1;
    }
    return 0;
}

static int is_group(vctx *c, const char *path)
{
    H5O_info_t info;
    if (!dtx_h5_path_exists(c->file, path))
        return 0;
    return H5Oget_info_by_name2(c->file, path, &info, H5O_INFO_BASIC, H5P_DEFAULT) >= 0 &&
           info.type == H5O_TYPE_GROUP;
}

/* 1 when the group at path holds at least one of the kind's datasets (it
 * is an object of that kind, complete or not), 0 when it holds none (it is
 * a namespace group such as /results/<target>). */
static int looks_like_object(vctx *c, const cJSON *kind, const char *path)
{
    const cJSON *d;
    char full[DTX_H5_PATH_MAX];
    cJSON_ArrayForEach(d, cJSON_GetObjectItemCaseSensitive(kind, "datasets"))
    {
        if (join(path, d->string, full, sizeof full) == 0 &&
            H5Lexists(c->file, full, H5P_DEFAULT) > 0)
            return 1;
    }
    return 0;
}

/* Checks the members of a kind's group or of a namespace group below it. */
static void walk_kind(vctx *c, const cJSON *kind, const char *gpath, int depth)
{
    const char *kname = jstr(kind, "name");
    size_t tl = strlen(DTX_H5_TMP_PREFIX);
    dtx_h5_names l;
    if (list_members(c, gpath, &l) < 0)
        return;
    for (size_t i = 0; i < l.n; i++) {
        char path[DTX_H5_PATH_MAX];
        if (join(gpath, l.names[i], path, sizeof path))
            continue;
        if (strncmp(l.names[i], DTX_H5_TMP_PREFIX, tl) == 0)
            out(c, "%s: note: temporary group left by an interrupted writer (not checked; "
                   "remove it or resume the run)\n", path);
        else if (!is_group(c, path))
            problem(c, path, "is not a group (expected a %s group)", kname);
        else if (looks_like_object(c, kind, path))
            check_group(c, kind, path);
        else if (depth >= 8)
            problem(c, path, "groups nested too deeply below /%s", kname);
        else {
            dtx_h5_names sub;
            if (list_members(c, path, &sub) < 0)
                continue;
            if (sub.n == 0)
                problem(c, path, "is empty: neither a %s group nor a group of them", kname);
            dtx_h5_names_free(&sub);
            walk_kind(c, kind, path, depth + 1);
        }
    }
    dtx_h5_names_free(&l);
}

static void check_kind(vctx *c, const cJSON *kind)
{
    const char *gpath = jstr(kind, "group"), *kname = jstr(kind, "name");
    if (!gpath || !kname || !dtx_h5_path_exists(c->file, gpath))
        return;
    if (!is_group(c, gpath)) {
        problem(c, gpath, "is not a group");
        return;
    }
    walk_kind(c, kind, gpath, 0);
}

/* Notes top-level members that are not part of the layout. */
static void check_top(vctx *c, const cJSON *kinds)
{
    dtx_h5_names l;
    if (list_members(c, "/", &l) < 0)
        return;
    for (size_t i = 0; i < l.n; i++) {
        const cJSON *k;
        int known = 0;
        cJSON_ArrayForEach(k, kinds)
        {
            const char *g = jstr(k, "group");
            known |= g && g[0] == '/' && strcmp(g + 1, l.names[i]) == 0;
        }
        if (!known)
            out(c, "/%s: note: not part of the dtx layout (not checked)\n", l.names[i]);
    }
    dtx_h5_names_free(&l);
}

/* "; 3 results, 25 of 27 frames checked (finite; 2 not done); 1 sequence,
 * 6 of 6 frames checked (finite)", or "" when neither kind was read. */
static void frames_text(const vctx *c, char *buf, size_t n)
{
    int w = 0;
    buf[0] = '\0';
    if (c->nres > 0)
        w = snprintf(buf, n, "; %d result%s, %lld of %lld frames checked (finite%s", c->nres,
                     c->nres == 1 ? "" : "s", c->res_checked, c->res_frames,
                     c->res_checked < c->res_frames ? "; " : ")");
    if (w > 0 && (size_t)w < n && c->res_checked < c->res_frames)
        w += snprintf(buf + w, n - (size_t)w, "%lld not done)", c->res_frames - c->res_checked);
    if (w >= 0 && (size_t)w < n && c->nseq > 0)
        snprintf(buf + w, n - (size_t)w, "; %d sequence%s, %lld of %lld frames checked (finite)",
                 c->nseq, c->nseq == 1 ? "" : "s", c->seq_checked, c->seq_frames);
}

/* ================================================================= entry */

dtx_status dtx_h5_validate(const char *path, char **report, dtx_error *err)
{
    vctx c;
    cJSON *desc = NULL;
    char *text = NULL;
    const cJSON *item, *kinds;
    dtx_status st = DTX_OK;
    htri_t is;
    hid_t fapl;
    int root_bad = 0;
    char frames[300];

    dtx_h5_init();
    memset(&c, 0, sizeof c);
    c.file = H5I_INVALID_HID;
    *report = NULL;
    snprintf(c.fname, sizeof c.fname, "%s", path);

    /* A FIFO or a device would make H5Fis_hdf5 wait or read for ever. */
    if ((st = dtx_file_check_regular(path, err)) != DTX_OK) {
        out(&c, "%s\n", err ? err->msg : "cannot open");
        goto done;
    }
    is = H5Fis_hdf5(path);
    if (is <= 0) {
        st = dtx_seterr(err, is == 0 ? DTX_EFORMAT : DTX_EIO, "%s: %s", path,
                        is == 0 ? "not an HDF5 file" : "cannot be read as HDF5");
        out(&c, "%s\n", err ? err->msg : "not an HDF5 file");
        goto done;
    }
    /* The guard driver refuses a corrupt global heap, on which HDF5 would
     * loop reading a variable-length string (h5guard.h). */
    fapl = H5Pcreate(H5P_FILE_ACCESS);
    if (fapl >= 0 && dtx_h5_guard_set_fapl(fapl) >= 0)
        c.file = H5Fopen(path, H5F_ACC_RDONLY, fapl);
    else
        c.file = H5I_INVALID_HID;
    CLOSE_ID(H5Pclose, fapl);
    if (c.file < 0) {
        st = dtx_seterr(err, DTX_EIO, "%s: cannot open the HDF5 file", path);
        out(&c, "%s\n", err ? err->msg : "cannot open");
        goto done;
    }
    text = dtx_h5_layout_json();
    desc = text ? cJSON_Parse(text) : NULL;
    kinds = desc ? cJSON_GetObjectItemCaseSensitive(desc, "kinds") : NULL;
    if (!cJSON_IsArray(kinds)) {
        st = dtx_seterr(err, text ? DTX_EIO : DTX_ENOMEM,
                        "the compiled-in layout description cannot be parsed");
        goto done;
    }

    /* --------------------------------------------------------- root */
    reset_current(&c, "/", "root");
    cJSON_ArrayForEach(item, cJSON_GetObjectItemCaseSensitive(
                                 cJSON_GetObjectItemCaseSensitive(desc, "root"), "attributes"))
        check_attribute(&c, "/", item);
    if (c.cur_problems == 0)
        out(&c, "/: ok\n");
    root_bad = c.cur_problems > 0;
    reset_current(&c, "", "");

    /* ------------------------------------------- groups, kind by kind */
    cJSON_ArrayForEach(item, kinds) check_kind(&c, item);
    check_top(&c, kinds);

    frames_text(&c, frames, sizeof frames);
    if (c.nproblems == 0)
        out(&c, "%s: valid dtx layout v%d (%d group%s checked%s)\n", path,
            DTX_H5_FORMAT_VERSION, c.nobjects, c.nobjects == 1 ? "" : "s", frames);
    else
        out(&c, "%s: not a valid dtx layout v%d: %d problem%s (%d group%s checked, %d with "
                "problems%s%s)\n",
            path, DTX_H5_FORMAT_VERSION, c.nproblems, c.nproblems == 1 ? "" : "s", c.nobjects,
            c.nobjects == 1 ? "" : "s", c.nbad, root_bad ? "; root attributes wrong" : "",
            frames);
    if (c.oom) {
        st = dtx_seterr(err, DTX_ENOMEM, "%s: out of memory while validating", path);
    } else if (c.nproblems > 0) {
        if (c.nproblems > 1)
            st = dtx_seterr(err, DTX_EFORMAT, "%.900s (and %d more problem%s)", c.first,
                            c.nproblems - 1, c.nproblems == 2 ? "" : "s");
        else
            st = dtx_seterr(err, DTX_EFORMAT, "%s", c.first);
    }
done:
    reset_current(&c, "", "");
    cJSON_Delete(desc);
    free(text);
    free(c.objs);
    CLOSE_ID(H5Fclose, c.file);
    if (c.oom) {
        free(c.buf);
        c.buf = NULL;
    }
    *report = c.buf;
    return st;
}
