/*
 * json_schema.c: the JSON Schema subset validator (see json_schema.h).
 *
 * Two passes.  The schema is first walked on its own so that an unsupported
 * keyword or a malformed keyword value is reported whatever the document
 * looks like; then the document is checked against it.  Errors are built as
 * (JSON pointer, sentence) pairs so that oneOf / anyOf can compare and
 * combine the errors of their branches before anything is formatted.
 */
#include "json_schema.h"

#include <math.h>
#include <regex.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Deepest nesting of schema applications (document levels plus $ref
 * hops) before giving up; also stops a $ref cycle. */
#define MAX_DEPTH 256
/* Deepest nesting of the schema itself. */
#define MAX_SCHEMA_DEPTH 64
/* The work allowed: this many schema applications per value of the
 * document, plus a floor (dtx's job schema needs fewer than 10 per value). */
#define STEPS_PER_VALUE 256L
#define STEPS_MIN 100000L

typedef struct {
    dtx_status code;
    char where[512]; /* JSON pointer of the offending value ("" = root) */
    char text[768];  /* what was expected and what was found */
} verr;

typedef struct {
    const cJSON *root; /* the schema "$ref": "#..." resolves against */
    char ptr[512];     /* JSON pointer of the value being checked */
    size_t ptrlen;
    int depth;
    /* The $ref hops being followed, as (target schema, document value)
     * pairs: meeting a pair again means the references loop without going
     * deeper into the document. */
    const cJSON *ref_s[MAX_DEPTH], *ref_d[MAX_DEPTH];
    int nrefs;
    /* Schema applications left: oneOf / anyOf whose branches refer back to
     * them can take time exponential in the document's depth, so the work
     * is bounded by a multiple of the document's size. */
    long steps_left;
} vctx;

/* ------------------------------------------------------------------ */
/* Small helpers                                                       */
/* ------------------------------------------------------------------ */

void dtx_json_pointer_append(char *buf, size_t bufsize, const char *key)
{
    size_t n;
    if (!buf || bufsize == 0)
        return;
    n = strlen(buf);
    if (n + 1 < bufsize)
        buf[n++] = '/';
    for (; *key && n + 1 < bufsize; key++) {
        if (*key == '~' || *key == '/') {
            if (n + 2 >= bufsize)
                break;
            buf[n++] = '~';
            buf[n++] = *key == '~' ? '0' : '1';
        } else {
            buf[n++] = *key;
        }
    }
    buf[n] = '\0';
}

static void push_key(vctx *c, const char *key)
{
    dtx_json_pointer_append(c->ptr, sizeof c->ptr, key);
    c->ptrlen = strlen(c->ptr);
}

static void push_index(vctx *c, int i)
{
    char num[32];
    snprintf(num, sizeof num, "%d", i);
    push_key(c, num);
}

static void pop_to(vctx *c, size_t len)
{
    c->ptrlen = len;
    c->ptr[len] = '\0';
}

static dtx_status fail(vctx *c, verr *e, dtx_status code, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;

static dtx_status fail(vctx *c, verr *e, dtx_status code, const char *fmt, ...)
{
    va_list ap;
    e->code = code;
    snprintf(e->where, sizeof e->where, "%s", c->ptr);
    va_start(ap, fmt);
    vsnprintf(e->text, sizeof e->text, fmt, ap);
    va_end(ap);
    return code;
}

/* Shortest of %.15g / %.17g that reads back as the same double. */
static void fmt_num(double x, char *buf, size_t n)
{
    snprintf(buf, n, "%.15g", x);
    if (strtod(buf, NULL) != x)
        snprintf(buf, n, "%.17g", x);
}

/* A string as a JSON literal, shortened to about 40 characters (and to
 * what fits in n bytes), with "..." when shortened.  Each character takes
 * up to 6 bytes ("\u001f"), so one is written only when it, a following
 * "...", the closing quote and the NUL all still fit. */
static void fmt_str(const char *s, char *buf, size_t n)
{
    size_t k = 0, shown = 0;
    if (n < 12) {
        if (n)
            buf[0] = '\0';
        return;
    }
    buf[k++] = '"';
    for (; *s; s++) {
        unsigned char ch = (unsigned char)*s;
        if (shown >= 40 || k + 6 + 3 + 2 > n) {
            memcpy(buf + k, "...", 3);
            k += 3;
            break;
        }
        if (ch == '"' || ch == '\\') {
            buf[k++] = '\\';
            buf[k++] = (char)ch;
        } else if (ch < 0x20 || ch == 0x7f) {
            k += (size_t)snprintf(buf + k, n - k, "\\u%04x", ch);
        } else {
            buf[k++] = (char)ch;
        }
        shown++;
    }
    buf[k++] = '"';
    buf[k] = '\0';
}

/* What a value is, for "got ..." in messages. */
static void describe(const cJSON *v, char *buf, size_t n)
{
    if (cJSON_IsString(v))
        fmt_str(v->valuestring, buf, n);
    else if (cJSON_IsNumber(v))
        fmt_num(v->valuedouble, buf, n);
    else if (cJSON_IsTrue(v))
        snprintf(buf, n, "true");
    else if (cJSON_IsFalse(v))
        snprintf(buf, n, "false");
    else if (cJSON_IsNull(v))
        snprintf(buf, n, "null");
    else if (cJSON_IsArray(v))
        snprintf(buf, n, cJSON_GetArraySize(v) ? "an array" : "an empty array");
    else if (cJSON_IsObject(v))
        snprintf(buf, n, "an object");
    else
        snprintf(buf, n, "an invalid value");
}

static int is_integral(double x)
{
    return isfinite(x) && floor(x) == x;
}

/* Exact JSON equality (numbers by value, objects regardless of order). */
static int json_equal(const cJSON *a, const cJSON *b)
{
    const cJSON *x, *y;
    if (cJSON_IsNumber(a) && cJSON_IsNumber(b))
        return a->valuedouble == b->valuedouble;
    if (cJSON_IsString(a) && cJSON_IsString(b))
        return strcmp(a->valuestring, b->valuestring) == 0;
    if (cJSON_IsBool(a) || cJSON_IsNull(a))
        return (a->type & 0xff) == (b->type & 0xff);
    if (cJSON_IsArray(a) && cJSON_IsArray(b)) {
        for (x = a->child, y = b->child; x && y; x = x->next, y = y->next)
            if (!json_equal(x, y))
                return 0;
        return !x && !y;
    }
    if (cJSON_IsObject(a) && cJSON_IsObject(b)) {
        if (cJSON_GetArraySize(a) != cJSON_GetArraySize(b))
            return 0;
        for (x = a->child; x; x = x->next) {
            y = cJSON_GetObjectItemCaseSensitive(b, x->string);
            if (!y || !json_equal(x, y))
                return 0;
        }
        return 1;
    }
    return 0;
}

/* ------------------------------------------------------------------ */
/* Types                                                               */
/* ------------------------------------------------------------------ */

static const char *const type_names[] = {"null", "boolean", "object", "array",
                                         "number", "integer", "string"};
static const char *const type_nouns[] = {"null", "a boolean", "an object", "an array",
                                         "a number", "an integer", "a string"};
static const char *const type_plurals[] = {"nulls", "booleans", "objects", "arrays",
                                           "numbers", "integers", "strings"};
#define NTYPES ((int)(sizeof type_names / sizeof type_names[0]))

static int type_index(const char *name)
{
    int i;
    for (i = 0; i < NTYPES; i++)
        if (strcmp(name, type_names[i]) == 0)
            return i;
    return -1;
}

static int type_matches(int t, const cJSON *d)
{
    switch (t) {
    case 0: return cJSON_IsNull(d);
    case 1: return cJSON_IsBool(d);
    case 2: return cJSON_IsObject(d);
    case 3: return cJSON_IsArray(d);
    case 4: return cJSON_IsNumber(d);
    case 5: return cJSON_IsNumber(d) && is_integral(d->valuedouble);
    case 6: return cJSON_IsString(d);
    default: return 0;
    }
}

static const cJSON *resolve_ref(const cJSON *root, const char *ref);

/* The single type name of a schema ("type": "number"), following $ref, or
 * -1; used to word messages. */
static int single_type(const cJSON *root, const cJSON *s)
{
    int hops;
    for (hops = 0; hops < 8 && cJSON_IsObject(s); hops++) {
        const cJSON *t = cJSON_GetObjectItemCaseSensitive(s, "type");
        const cJSON *ref = cJSON_GetObjectItemCaseSensitive(s, "$ref");
        if (cJSON_IsString(t))
            return type_index(t->valuestring);
        if (!cJSON_IsString(ref))
            break;
        s = resolve_ref(root, ref->valuestring);
    }
    return -1;
}

/* ------------------------------------------------------------------ */
/* The schema pass                                                     */
/* ------------------------------------------------------------------ */

/* Resolves "#" or "#/a/b" against root (RFC 6901 escapes); NULL if not
 * found. */
static const cJSON *resolve_ref(const cJSON *root, const char *ref)
{
    const cJSON *node = root;
    char tok[256];
    if (ref[0] != '#')
        return NULL;
    ref++;
    while (*ref) {
        size_t k = 0;
        if (*ref != '/')
            return NULL;
        ref++;
        while (*ref && *ref != '/') {
            char ch = *ref++;
            if (ch == '~') {
                if (*ref == '0')
                    ch = '~';
                else if (*ref == '1')
                    ch = '/';
                else
                    return NULL;
                ref++;
            }
            if (k + 1 >= sizeof tok)
                return NULL;
            tok[k++] = ch;
        }
        tok[k] = '\0';
        if (cJSON_IsObject(node)) {
            node = cJSON_GetObjectItemCaseSensitive(node, tok);
        } else if (cJSON_IsArray(node)) {
            char *end;
            long i = strtol(tok, &end, 10);
            if (k == 0 || *end || i < 0 || i > 1000000)
                return NULL;
            node = cJSON_GetArrayItem(node, (int)i);
        } else {
            return NULL;
        }
        if (!node)
            return NULL;
    }
    return node;
}

static const char *const ignored_keywords[] = {"$schema", "$id", "$comment", "$defs", "title",
                                               "description", "default", "examples"};

static dtx_status schema_err(char *buf, size_t n, const char *spath, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;

static dtx_status schema_err(char *buf, size_t n, const char *spath, const char *fmt, ...)
{
    char text[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    if (buf && n)
        snprintf(buf, n, "schema error at #%s: %s", spath, text);
    return DTX_EINVAL;
}

static int is_schema(const cJSON *s)
{
    return cJSON_IsObject(s) || cJSON_IsBool(s);
}

static dtx_status check_schema(const cJSON *root, const cJSON *s, char *spath, size_t spsize,
                               int depth, char *msg, size_t msgsize);

/* Checks a child schema found under key (and index >= 0 when in an
 * array) of the schema at spath. */
static dtx_status check_child(const cJSON *root, const cJSON *s, char *spath, size_t spsize,
                              const char *key, int index, int depth, char *msg, size_t msgsize)
{
    size_t len = strlen(spath);
    dtx_status st;
    dtx_json_pointer_append(spath, spsize, key);
    if (index >= 0) {
        char num[32];
        snprintf(num, sizeof num, "%d", index);
        dtx_json_pointer_append(spath, spsize, num);
    }
    st = check_schema(root, s, spath, spsize, depth + 1, msg, msgsize);
    spath[len] = '\0';
    return st;
}

/* Checks every member of the object kw, the keyword kw->string ("$defs",
 * "properties") of the schema at spath, as a schema of its own. */
static dtx_status check_member_schemas(const cJSON *root, const cJSON *kw, char *spath,
                                       size_t spsize, int depth, char *msg, size_t msgsize)
{
    for (const cJSON *m = kw->child; m; m = m->next) {
        size_t len = strlen(spath);
        dtx_status st;
        dtx_json_pointer_append(spath, spsize, kw->string);
        st = check_child(root, m, spath, spsize, m->string, -1, depth, msg, msgsize);
        spath[len] = '\0';
        if (st)
            return st;
    }
    return DTX_OK;
}

/* Patterns dtx accepts: POSIX extended regular expressions of at most
 * PATTERN_MAX bytes in which no quantifier (*, +, ?, {m,n}) follows another
 * directly.  POSIX leaves "a+*" undefined, and glibc's matcher takes
 * exponential time and memory on runs of them ("a??????...", "a+++++..."),
 * so a schema could stall a job's validation; the patterns dtx's own schema
 * uses need neither. */
#define PATTERN_MAX 1024
static int pattern_ok(const char *p)
{
    int prev_quant = 0, in_bracket = 0;
    if (strlen(p) > PATTERN_MAX)
        return 0;
    for (; *p; p++) {
        if (in_bracket) {
            if (*p == ']')
                in_bracket = 0;
            continue;
        }
        if (*p == '\\' && p[1]) {
            p++;
            prev_quant = 0;
        } else if (*p == '[') {
            in_bracket = 1;
            if (p[1] == '^')
                p++;
            if (p[1] == ']') /* "[]...]": a literal ] first */
                p++;
            prev_quant = 0;
        } else if (*p == '*' || *p == '+' || *p == '?' || *p == '{') {
            if (prev_quant)
                return 0;
            if (*p == '{')
                while (p[1] && *p != '}')
                    p++;
            prev_quant = 1;
        } else {
            prev_quant = 0;
        }
    }
    return 1;
}

static dtx_status check_schema(const cJSON *root, const cJSON *s, char *spath, size_t spsize,
                               int depth, char *msg, size_t msgsize)
{
    const cJSON *kw;
    dtx_status st;
    if (depth > MAX_SCHEMA_DEPTH)
        return schema_err(msg, msgsize, spath, "schema nested too deeply");
    if (cJSON_IsBool(s))
        return DTX_OK;
    if (!cJSON_IsObject(s))
        return schema_err(msg, msgsize, spath, "a schema must be an object or a boolean");
    for (kw = s->child; kw; kw = kw->next) {
        const char *k = kw->string;
        size_t i;
        int ignored = 0;
        for (i = 0; i < sizeof ignored_keywords / sizeof ignored_keywords[0]; i++)
            if (strcmp(k, ignored_keywords[i]) == 0)
                ignored = 1;
        if (strcmp(k, "$defs") == 0) {
            if (!cJSON_IsObject(kw))
                return schema_err(msg, msgsize, spath, "$defs must be an object");
            if ((st = check_member_schemas(root, kw, spath, spsize, depth, msg, msgsize)) != DTX_OK)
                return st;
        } else if (ignored) {
            continue;
        } else if (strcmp(k, "type") == 0) {
            const cJSON *t;
            if (cJSON_IsString(kw)) {
                if (type_index(kw->valuestring) < 0)
                    return schema_err(msg, msgsize, spath, "unknown type \"%s\"",
                                      kw->valuestring);
            } else if (cJSON_IsArray(kw) && kw->child) {
                for (t = kw->child; t; t = t->next)
                    if (!cJSON_IsString(t) || type_index(t->valuestring) < 0)
                        return schema_err(msg, msgsize, spath,
                                          "\"type\" must list known type names");
            } else {
                return schema_err(msg, msgsize, spath,
                                  "\"type\" must be a type name or an array of them");
            }
        } else if (strcmp(k, "enum") == 0) {
            if (!cJSON_IsArray(kw) || !kw->child)
                return schema_err(msg, msgsize, spath, "\"enum\" must be a non-empty array");
        } else if (strcmp(k, "const") == 0) {
            continue;
        } else if (strcmp(k, "properties") == 0) {
            if (!cJSON_IsObject(kw))
                return schema_err(msg, msgsize, spath, "\"properties\" must be an object");
            if ((st = check_member_schemas(root, kw, spath, spsize, depth, msg, msgsize)) != DTX_OK)
                return st;
        } else if (strcmp(k, "required") == 0) {
            const cJSON *r;
            if (!cJSON_IsArray(kw))
                return schema_err(msg, msgsize, spath, "\"required\" must be an array");
            for (r = kw->child; r; r = r->next)
                if (!cJSON_IsString(r))
                    return schema_err(msg, msgsize, spath,
                                      "\"required\" must list key names (strings)");
        } else if (strcmp(k, "additionalProperties") == 0 || strcmp(k, "items") == 0) {
            st = check_child(root, kw, spath, spsize, k, -1, depth, msg, msgsize);
            if (st)
                return st;
        } else if (strcmp(k, "minItems") == 0 || strcmp(k, "maxItems") == 0 ||
                   strcmp(k, "minLength") == 0 || strcmp(k, "maxLength") == 0) {
            if (!cJSON_IsNumber(kw) || !is_integral(kw->valuedouble) || kw->valuedouble < 0 ||
                kw->valuedouble > 2147483647.0)
                return schema_err(msg, msgsize, spath, "\"%s\" must be a non-negative integer",
                                  k);
        } else if (strcmp(k, "minimum") == 0 || strcmp(k, "maximum") == 0 ||
                   strcmp(k, "exclusiveMinimum") == 0 || strcmp(k, "exclusiveMaximum") == 0) {
            if (!cJSON_IsNumber(kw) || !isfinite(kw->valuedouble))
                return schema_err(msg, msgsize, spath, "\"%s\" must be a number", k);
        } else if (strcmp(k, "pattern") == 0) {
            regex_t re;
            if (!cJSON_IsString(kw))
                return schema_err(msg, msgsize, spath, "\"pattern\" must be a string");
            if (!pattern_ok(kw->valuestring))
                return schema_err(msg, msgsize, spath,
                                  "pattern too long or with a quantifier right after another "
                                  "(\"a+*\"), which POSIX leaves undefined");
            if (regcomp(&re, kw->valuestring, REG_EXTENDED | REG_NOSUB) != 0)
                return schema_err(msg, msgsize, spath, "invalid pattern \"%s\"",
                                  kw->valuestring);
            regfree(&re);
        } else if (strcmp(k, "oneOf") == 0 || strcmp(k, "anyOf") == 0) {
            const cJSON *b;
            int i_b = 0;
            if (!cJSON_IsArray(kw) || !kw->child)
                return schema_err(msg, msgsize, spath, "\"%s\" must be a non-empty array", k);
            for (b = kw->child; b; b = b->next, i_b++) {
                st = check_child(root, b, spath, spsize, k, i_b, depth, msg, msgsize);
                if (st)
                    return st;
            }
        } else if (strcmp(k, "$ref") == 0) {
            const cJSON *target;
            if (!cJSON_IsString(kw))
                return schema_err(msg, msgsize, spath, "\"$ref\" must be a string");
            target = resolve_ref(root, kw->valuestring);
            if (!target || !is_schema(target))
                return schema_err(msg, msgsize, spath, "cannot resolve \"$ref\": \"%s\"",
                                  kw->valuestring);
        } else {
            return schema_err(msg, msgsize, spath, "unsupported keyword \"%s\"", k);
        }
    }
    return DTX_OK;
}

/* ------------------------------------------------------------------ */
/* The document pass                                                   */
/* ------------------------------------------------------------------ */

static dtx_status validate(vctx *c, const cJSON *s, const cJSON *d, verr *e);

typedef struct {
    const char *key;
    int index;
} keyrec;

static int keyrec_cmp(const void *a, const void *b)
{
    const keyrec *x = a, *y = b;
    int r = strcmp(x->key, y->key);
    if (r)
        return r;
    return (x->index > y->index) - (x->index < y->index);
}

/* The index of the first member of object d whose key an earlier member
 * already has, -1 when there is none, -2 when out of memory.  cJSON keeps
 * both copies of a repeated key and a lookup sees only the first, so a
 * repetition would otherwise be silently ignored. */
static int first_duplicate(const cJSON *d)
{
    int n = cJSON_GetArraySize(d), i, first = -1;
    const cJSON *m;
    keyrec *recs;
    if (n < 2)
        return -1;
    recs = dtx_alloc((size_t)n, sizeof *recs, 0);
    if (!recs)
        return -2;
    for (m = d->child, i = 0; m && i < n; m = m->next, i++) {
        recs[i].key = m->string ? m->string : "";
        recs[i].index = i;
    }
    qsort(recs, (size_t)n, sizeof *recs, keyrec_cmp);
    for (i = 1; i < n; i++)
        if (strcmp(recs[i].key, recs[i - 1].key) == 0 && (first < 0 || recs[i].index < first))
            first = recs[i].index;
    free(recs);
    return first;
}

static dtx_status duplicate_error(vctx *c, const cJSON *m, verr *e)
{
    char ks[128];
    fmt_str(m->string ? m->string : "", ks, sizeof ks);
    return fail(c, e, DTX_EJOB, "duplicate key %s", ks);
}

/* One level deeper into the document (c->depth + 1), within the limits on
 * the depth and on the steps a validation may take. */
static dtx_status descend(vctx *c, verr *e)
{
    if (c->depth >= MAX_DEPTH)
        return fail(c, e, DTX_EJOB, "nested too deeply (more than %d levels)", MAX_DEPTH);
    if (--c->steps_left < 0)
        return fail(c, e, DTX_EINVAL,
                    "schema error: validating this document takes too many steps (oneOf / "
                    "anyOf branches that refer back to themselves?)");
    c->depth++;
    return DTX_OK;
}

/* The checks every value gets, schema or not: finite numbers, no repeated
 * keys, recursively. */
static dtx_status walk_generic(vctx *c, const cJSON *d, verr *e)
{
    const cJSON *m;
    dtx_status st;
    int i = 0;
    int dup = -1;
    if (cJSON_IsNumber(d) && !isfinite(d->valuedouble))
        return fail(c, e, DTX_EJOB, "number out of range (not finite)");
    if (!cJSON_IsObject(d) && !cJSON_IsArray(d))
        return DTX_OK;
    if (cJSON_IsObject(d) && (dup = first_duplicate(d)) == -2)
        return fail(c, e, DTX_ENOMEM, "out of memory");
    if ((st = descend(c, e)) != DTX_OK)
        return st;
    for (m = d->child; m; m = m->next, i++) {
        size_t len = c->ptrlen;
        if (i == dup) {
            c->depth--;
            return duplicate_error(c, m, e);
        }
        if (cJSON_IsObject(d))
            push_key(c, m->string ? m->string : "");
        else
            push_index(c, i);
        st = walk_generic(c, m, e);
        pop_to(c, len);
        if (st) {
            c->depth--;
            return st;
        }
    }
    c->depth--;
    return DTX_OK;
}

/* "a string", "a string or null", ... */
static void expected_types(const cJSON *t, char *buf, size_t n)
{
    const cJSON *x;
    size_t k = 0;
    buf[0] = '\0';
    if (cJSON_IsString(t)) {
        snprintf(buf, n, "%s", type_nouns[type_index(t->valuestring)]);
        return;
    }
    for (x = t->child; x; x = x->next) {
        const char *sep = x == t->child ? "" : x->next ? ", " : " or ";
        if (k < n)
            k += (size_t)snprintf(buf + k, n - k, "%s%s", sep,
                                  type_nouns[type_index(x->valuestring)]);
    }
}

static dtx_status check_type(vctx *c, const cJSON *t, const cJSON *d, verr *e)
{
    const cJSON *x;
    char want[128], got[128];
    if (cJSON_IsString(t)) {
        if (type_matches(type_index(t->valuestring), d))
            return DTX_OK;
    } else {
        for (x = t->child; x; x = x->next)
            if (type_matches(type_index(x->valuestring), d))
                return DTX_OK;
    }
    expected_types(t, want, sizeof want);
    describe(d, got, sizeof got);
    return fail(c, e, DTX_EJOB, "expected %s, got %s", want, got);
}

/* An allowed value as listed in messages: strings bare (one of float32,
 * float64), anything else as JSON. */
static void enum_value(const cJSON *x, char *buf, size_t n)
{
    if (cJSON_IsString(x))
        snprintf(buf, n, "%s", x->valuestring);
    else
        describe(x, buf, n);
}

static dtx_status check_enum(vctx *c, const cJSON *en, const cJSON *d, verr *e)
{
    const cJSON *x;
    char list[512], got[128];
    size_t k = 0;
    for (x = en->child; x; x = x->next)
        if (json_equal(x, d))
            return DTX_OK;
    list[0] = '\0';
    for (x = en->child; x && k < sizeof list; x = x->next) {
        char one[128];
        enum_value(x, one, sizeof one);
        k += (size_t)snprintf(list + k, sizeof list - k, "%s%s", x == en->child ? "" : ", ",
                              one);
    }
    describe(d, got, sizeof got);
    if (en->child && !en->child->next)
        return fail(c, e, DTX_EJOB, "expected %s, got %s", list, got);
    return fail(c, e, DTX_EJOB, "expected one of %s, got %s", list, got);
}

static dtx_status check_range(vctx *c, const cJSON *s, const cJSON *d, verr *e)
{
    const cJSON *mn = cJSON_GetObjectItemCaseSensitive(s, "minimum");
    const cJSON *mx = cJSON_GetObjectItemCaseSensitive(s, "maximum");
    const cJSON *xmn = cJSON_GetObjectItemCaseSensitive(s, "exclusiveMinimum");
    const cJSON *xmx = cJSON_GetObjectItemCaseSensitive(s, "exclusiveMaximum");
    const cJSON *lo = NULL, *hi = NULL;
    int lo_excl = 0, hi_excl = 0, ok = 1;
    double x = d->valuedouble;
    char los[64], his[64], got[64];
    const char *noun = single_type(c->root, s) == 5 ? "an integer" : "a number";

    /* The binding bound on each side (both keywords may be present). */
    if (mn)
        lo = mn;
    if (xmn && (!lo || xmn->valuedouble >= lo->valuedouble)) {
        lo = xmn;
        lo_excl = 1;
    }
    if (mx)
        hi = mx;
    if (xmx && (!hi || xmx->valuedouble <= hi->valuedouble)) {
        hi = xmx;
        hi_excl = 1;
    }
    if (lo && (lo_excl ? !(x > lo->valuedouble) : !(x >= lo->valuedouble)))
        ok = 0;
    if (hi && (hi_excl ? !(x < hi->valuedouble) : !(x <= hi->valuedouble)))
        ok = 0;
    if (ok)
        return DTX_OK;
    if (lo)
        fmt_num(lo->valuedouble, los, sizeof los);
    if (hi)
        fmt_num(hi->valuedouble, his, sizeof his);
    fmt_num(x, got, sizeof got);
    if (lo && hi)
        return fail(c, e, DTX_EJOB, "expected %s in %c%s, %s%c, got %s", noun,
                    lo_excl ? '(' : '[', los, his, hi_excl ? ')' : ']', got);
    if (lo)
        return fail(c, e, DTX_EJOB, "expected %s %s %s, got %s", noun, lo_excl ? ">" : ">=",
                    los, got);
    return fail(c, e, DTX_EJOB, "expected %s %s %s, got %s", noun, hi_excl ? "<" : "<=", his,
                got);
}

/* "3 numbers", "1 to 16 numbers", "at least 1 string", ... for minItems /
 * maxItems (-1 when absent) and the items schema. */
static void count_phrase(const vctx *c, long lo, long hi, const cJSON *items,
                         const char *unit_one, const char *unit_many, char *buf, size_t n)
{
    int t = items ? single_type(c->root, items) : -1;
    const char *many = t >= 0 ? type_plurals[t] : unit_many;
    const char *one = t >= 0 ? type_names[t] : unit_one;
    if (lo >= 0 && hi >= 0 && lo == hi)
        snprintf(buf, n, "%ld %s", lo, lo == 1 ? one : many);
    else if (lo >= 0 && hi >= 0)
        snprintf(buf, n, "%ld to %ld %s", lo, hi, many);
    else if (lo >= 0)
        snprintf(buf, n, "at least %ld %s", lo, lo == 1 ? one : many);
    else
        snprintf(buf, n, "at most %ld %s", hi, hi == 1 ? one : many);
}

static long get_count(const cJSON *s, const char *key)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(s, key);
    return cJSON_IsNumber(v) ? (long)v->valuedouble : -1;
}

static dtx_status check_array_size(vctx *c, const cJSON *s, const cJSON *d, verr *e)
{
    long lo = get_count(s, "minItems"), hi = get_count(s, "maxItems");
    long n = cJSON_GetArraySize(d);
    char what[128];
    if ((lo < 0 || n >= lo) && (hi < 0 || n <= hi))
        return DTX_OK;
    if (lo == 1 && hi < 0) {
        int t = single_type(c->root, cJSON_GetObjectItemCaseSensitive(s, "items"));
        return fail(c, e, DTX_EJOB, "expected a non-empty array of %s, got an empty array",
                    t >= 0 ? type_plurals[t] : "items");
    }
    count_phrase(c, lo, hi, cJSON_GetObjectItemCaseSensitive(s, "items"), "item", "items", what,
                 sizeof what);
    return fail(c, e, DTX_EJOB, "expected an array of %s, got %ld item%s", what, n,
                n == 1 ? "" : "s");
}

static dtx_status check_string(vctx *c, const cJSON *s, const cJSON *d, verr *e)
{
    long lo = get_count(s, "minLength"), hi = get_count(s, "maxLength");
    long n = (long)strlen(d->valuestring);
    const cJSON *pat = cJSON_GetObjectItemCaseSensitive(s, "pattern");
    char got[128];
    describe(d, got, sizeof got);
    if ((lo >= 0 && n < lo) || (hi >= 0 && n > hi)) {
        char what[128];
        if (lo == 1 && hi < 0)
            return fail(c, e, DTX_EJOB, "expected a non-empty string, got %s", got);
        count_phrase(c, lo, hi, NULL, "byte", "bytes", what, sizeof what);
        return fail(c, e, DTX_EJOB, "expected a string of %s, got %s", what, got);
    }
    if (cJSON_IsString(pat)) {
        regex_t re;
        int r;
        if (!pattern_ok(pat->valuestring) ||
            regcomp(&re, pat->valuestring, REG_EXTENDED | REG_NOSUB) != 0)
            return fail(c, e, DTX_EINVAL, "schema error: invalid pattern \"%.200s\"",
                        pat->valuestring);
        r = regexec(&re, d->valuestring, 0, NULL, 0);
        regfree(&re);
        if (r != 0)
            return fail(c, e, DTX_EJOB, "expected a string matching %s, got %s",
                        pat->valuestring, got);
    }
    return DTX_OK;
}

static dtx_status unknown_key(vctx *c, const cJSON *props, const cJSON *m, verr *e)
{
    const cJSON *p;
    char allowed[512], ks[128];
    size_t k = 0;
    allowed[0] = '\0';
    for (p = props ? props->child : NULL; p && k < sizeof allowed; p = p->next)
        k += (size_t)snprintf(allowed + k, sizeof allowed - k, "%s%s",
                              p == props->child ? "" : ", ", p->string);
    fmt_str(m->string, ks, sizeof ks);
    if (!props || !props->child)
        return fail(c, e, DTX_EJOB, "unknown key %s (no keys are allowed here)", ks);
    return fail(c, e, DTX_EJOB, "unknown key %s (allowed: %s)", ks, allowed);
}

/* The members of object d in document order (repeated keys, unknown and
 * forbidden keys, and each member's own schema), then the required keys
 * that are missing (they would be at the end of the object). */
static dtx_status check_members(vctx *c, const cJSON *s, const cJSON *d, verr *e)
{
    const cJSON *props = cJSON_GetObjectItemCaseSensitive(s, "properties");
    const cJSON *addl = cJSON_GetObjectItemCaseSensitive(s, "additionalProperties");
    const cJSON *req = cJSON_GetObjectItemCaseSensitive(s, "required");
    const cJSON *m;
    int dup = first_duplicate(d), i = 0;
    if (dup == -2)
        return fail(c, e, DTX_ENOMEM, "out of memory");
    for (m = d->child; m; m = m->next, i++) {
        const cJSON *sub = props ? cJSON_GetObjectItemCaseSensitive(props, m->string) : NULL;
        size_t len = c->ptrlen;
        dtx_status st;
        if (i == dup)
            return duplicate_error(c, m, e);
        if (!sub && cJSON_IsFalse(addl))
            return unknown_key(c, props, m, e);
        if (!sub)
            sub = addl;
        if (cJSON_IsFalse(sub)) {
            /* A key this schema forbids by name. */
            char ks[128];
            fmt_str(m->string, ks, sizeof ks);
            return fail(c, e, DTX_EJOB, "key %s is not allowed here", ks);
        }
        push_key(c, m->string);
        st = sub ? validate(c, sub, m, e) : walk_generic(c, m, e);
        pop_to(c, len);
        if (st)
            return st;
    }
    if (cJSON_IsArray(req)) {
        const cJSON *r;
        for (r = req->child; r; r = r->next)
            if (!cJSON_GetObjectItemCaseSensitive(d, r->valuestring)) {
                char ks[128];
                fmt_str(r->valuestring, ks, sizeof ks);
                return fail(c, e, DTX_EJOB, "missing required key %s", ks);
            }
    }
    return DTX_OK;
}

static dtx_status check_items(vctx *c, const cJSON *s, const cJSON *d, verr *e)
{
    const cJSON *items = cJSON_GetObjectItemCaseSensitive(s, "items");
    const cJSON *m;
    int i = 0;
    for (m = d->child; m; m = m->next, i++) {
        size_t len = c->ptrlen;
        dtx_status st;
        push_index(c, i);
        st = items ? validate(c, items, m, e) : walk_generic(c, m, e);
        pop_to(c, len);
        if (st)
            return st;
    }
    return DTX_OK;
}

/* How well d fits a branch that it failed: the number of the branch's
 * required keys d has, then how deep in d the branch's error lies. */
static long branch_score(const cJSON *b, const cJSON *d, const verr *be)
{
    const cJSON *req = cJSON_IsObject(b) ? cJSON_GetObjectItemCaseSensitive(b, "required")
                                         : NULL;
    const cJSON *r;
    long present = 0;
    if (cJSON_IsObject(d) && cJSON_IsArray(req))
        for (r = req->child; r; r = r->next)
            if (cJSON_GetObjectItemCaseSensitive(d, r->valuestring))
                present++;
    return present * 10000 + (long)strlen(be->where);
}

static const char *branch_title(const cJSON *b)
{
    const cJSON *t = cJSON_IsObject(b) ? cJSON_GetObjectItemCaseSensitive(b, "title") : NULL;
    return cJSON_IsString(t) ? t->valuestring : NULL;
}

static dtx_status check_combinator(vctx *c, const cJSON *list, int one, const cJSON *d,
                                   verr *e)
{
    const cJSON *b, *best = NULL;
    verr *errs;
    int nb = cJSON_GetArraySize(list), i, nmatch = 0, tie = 0;
    long best_score = -1;
    int best_i = -1, first_match = -1, second_match = -1;
    dtx_status st = DTX_OK;

    errs = dtx_alloc((size_t)nb, sizeof *errs, 1);
    if (!errs)
        return fail(c, e, DTX_ENOMEM, "out of memory");
    for (b = list->child, i = 0; b; b = b->next, i++) {
        size_t len = c->ptrlen;
        dtx_status bs = validate(c, b, d, &errs[i]);
        pop_to(c, len);
        if (bs == DTX_OK) {
            nmatch++;
            if (first_match < 0)
                first_match = i;
            else if (second_match < 0)
                second_match = i;
        } else if (bs != DTX_EJOB) {
            *e = errs[i];
            st = bs;
            goto done;
        }
    }
    if (one ? nmatch == 1 : nmatch >= 1)
        goto done;

    if (nmatch > 1) {
        const char *t1 = branch_title(cJSON_GetArrayItem(list, first_match));
        const char *t2 = branch_title(cJSON_GetArrayItem(list, second_match));
        if (t1 && t2)
            st = fail(c, e, DTX_EJOB, "matches more than one of the allowed forms (%s; %s)",
                      t1, t2);
        else
            st = fail(c, e, DTX_EJOB,
                      "matches more than one of the allowed forms (forms %d and %d)",
                      first_match + 1, second_match + 1);
        goto done;
    }

    /* No branch matches: report the one that fits best, if one does. */
    for (b = list->child, i = 0; b; b = b->next, i++) {
        long sc = branch_score(b, d, &errs[i]);
        if (sc > best_score) {
            best_score = sc;
            best = b;
            best_i = i;
            tie = 0;
        } else if (sc == best_score) {
            tie = 1;
        }
    }
    if (!tie && best) {
        const char *title = branch_title(best);
        *e = errs[best_i];
        if (title) {
            size_t k = strlen(e->text);
            snprintf(e->text + k, sizeof e->text - k, " (for %s)", title);
        }
        st = DTX_EJOB;
    } else {
        char text[sizeof e->text];
        size_t k = 0;
        k += (size_t)snprintf(text, sizeof text, "matches none of the allowed forms: ");
        for (b = list->child, i = 0; b && k < sizeof text; b = b->next, i++) {
            const char *title = branch_title(b);
            char label[64];
            if (!title) {
                snprintf(label, sizeof label, "form %d", i + 1);
                title = label;
            }
            if (strcmp(errs[i].where, c->ptr) == 0)
                k += (size_t)snprintf(text + k, sizeof text - k, "%s%s (%s)", i ? "; " : "",
                                      title, errs[i].text);
            else
                k += (size_t)snprintf(text + k, sizeof text - k, "%s%s (at %s: %s)",
                                      i ? "; " : "", title, errs[i].where, errs[i].text);
        }
        st = fail(c, e, DTX_EJOB, "%s", text);
    }
done:
    free(errs);
    return st;
}

static dtx_status validate(vctx *c, const cJSON *s, const cJSON *d, verr *e)
{
    const cJSON *kw;
    dtx_status st = DTX_OK;

    if (cJSON_IsTrue(s))
        return walk_generic(c, d, e);
    if (cJSON_IsFalse(s))
        return fail(c, e, DTX_EJOB, "no value is allowed here");
    if ((st = descend(c, e)) != DTX_OK)
        return st;

    /* $ref applies the referenced schema in place. */
    kw = cJSON_GetObjectItemCaseSensitive(s, "$ref");
    if (cJSON_IsString(kw)) {
        const cJSON *target = resolve_ref(c->root, kw->valuestring);
        int i;
        if (!target) {
            st = fail(c, e, DTX_EINVAL, "schema error: cannot resolve \"$ref\": \"%s\"",
                      kw->valuestring);
            goto done;
        }
        for (i = 0; i < c->nrefs; i++)
            if (c->ref_s[i] == target && c->ref_d[i] == d) {
                st = fail(c, e, DTX_EINVAL,
                          "schema error: \"$ref\": \"%s\" refers back to itself without "
                          "going deeper into the document",
                          kw->valuestring);
                goto done;
            }
        /* nrefs < depth <= MAX_DEPTH: every hop is one validate() level. */
        c->ref_s[c->nrefs] = target;
        c->ref_d[c->nrefs] = d;
        c->nrefs++;
        st = validate(c, target, d, e);
        c->nrefs--;
        if (st != DTX_OK)
            goto done;
    }

    /* ---- the value's own checks ---- */
    if (cJSON_IsNumber(d) && !isfinite(d->valuedouble)) {
        st = fail(c, e, DTX_EJOB, "number out of range (not finite)");
        goto done;
    }
    if ((kw = cJSON_GetObjectItemCaseSensitive(s, "type")) != NULL &&
        (st = check_type(c, kw, d, e)) != DTX_OK)
        goto done;
    if ((kw = cJSON_GetObjectItemCaseSensitive(s, "enum")) != NULL &&
        (st = check_enum(c, kw, d, e)) != DTX_OK)
        goto done;
    if ((kw = cJSON_GetObjectItemCaseSensitive(s, "const")) != NULL && !json_equal(kw, d)) {
        char want[128], got[128];
        enum_value(kw, want, sizeof want);
        describe(d, got, sizeof got);
        st = fail(c, e, DTX_EJOB, "expected %s, got %s", want, got);
        goto done;
    }
    if (cJSON_IsNumber(d) && (st = check_range(c, s, d, e)) != DTX_OK)
        goto done;
    if (cJSON_IsString(d) && (st = check_string(c, s, d, e)) != DTX_OK)
        goto done;
    if (cJSON_IsArray(d) && (st = check_array_size(c, s, d, e)) != DTX_OK)
        goto done;

    /* ---- members, in document order, then missing keys ---- */
    if (cJSON_IsArray(d) && (st = check_items(c, s, d, e)) != DTX_OK)
        goto done;
    if (cJSON_IsObject(d) && (st = check_members(c, s, d, e)) != DTX_OK)
        goto done;

    /* ---- combinators ---- */
    if ((kw = cJSON_GetObjectItemCaseSensitive(s, "oneOf")) != NULL &&
        (st = check_combinator(c, kw, 1, d, e)) != DTX_OK)
        goto done;
    if ((kw = cJSON_GetObjectItemCaseSensitive(s, "anyOf")) != NULL &&
        (st = check_combinator(c, kw, 0, d, e)) != DTX_OK)
        goto done;
done:
    c->depth--;
    return st;
}

/* The number of values in v (itself included); cJSON limits the nesting
 * of what it parses (CJSON_NESTING_LIMIT), the depth cap covers documents
 * built in memory. */
static long count_values(const cJSON *v, int depth)
{
    const cJSON *m;
    long n = 1;
    if (depth > 4 * MAX_DEPTH)
        return n;
    for (m = v->child; m && (cJSON_IsArray(v) || cJSON_IsObject(v)); m = m->next)
        n += count_values(m, depth + 1);
    return n;
}

dtx_status dtx_json_validate(const cJSON *schema, const cJSON *doc, char *msg, size_t msgsize)
{
    vctx c;
    verr e;
    char spath[512] = "";
    dtx_status st;

    if (msg && msgsize)
        msg[0] = '\0';
    if (!schema || !doc) {
        if (msg && msgsize)
            snprintf(msg, msgsize, "no schema or no document");
        return DTX_EINVAL;
    }
    st = check_schema(schema, schema, spath, sizeof spath, 0, msg, msgsize);
    if (st)
        return st;

    memset(&c, 0, sizeof c);
    c.root = schema;
    c.steps_left = STEPS_PER_VALUE * count_values(doc, 0) + STEPS_MIN;
    memset(&e, 0, sizeof e);
    st = validate(&c, schema, doc, &e);
    if (st && msg && msgsize) {
        if (st == DTX_EJOB)
            snprintf(msg, msgsize, "at %s: %s", e.where[0] ? e.where : "the top level", e.text);
        else
            snprintf(msg, msgsize, "%s", e.text);
    }
    return st;
}

/* ------------------------------------------------------------------ */
/* Checks on the JSON text                                              */
/* ------------------------------------------------------------------ */

/* The offset just past the string whose opening quote is at text[i], or
 * len when it is not closed; *nul is set when it holds \u0000. */
static size_t skip_string(const char *text, size_t len, size_t i, int *nul)
{
    *nul = 0;
    for (i++; i < len; i++) {
        if (text[i] == '"')
            return i + 1;
        if (text[i] == '\\') {
            if (i + 5 < len && text[i + 1] == 'u' && memcmp(text + i + 2, "0000", 4) == 0)
                *nul = 1;
            i++; /* the escaped character (a \uXXXX's digits are plain) */
        }
    }
    return len;
}

size_t dtx_json_find_too_deep(const char *text, size_t len, int max_depth)
{
    long depth = 0;
    int nul;
    for (size_t i = 0; i < len;) {
        char c = text[i];
        if (c == '"') {
            i = skip_string(text, len, i, &nul);
            continue;
        }
        if (c == '[' || c == '{') {
            if (++depth > max_depth)
                return i;
        } else if ((c == ']' || c == '}') && depth > 0) {
            depth--;
        }
        i++;
    }
    return (size_t)-1;
}

/* Copies the member name between the quotes at text[b] and text[e - 1]
 * into out (outsz bytes) for a JSON pointer: the simple escapes undone,
 * \uXXXX kept as written, truncated if needed. */
static void copy_key(const char *text, size_t b, size_t e, char *out, size_t outsz)
{
    size_t k = 0;
    for (size_t i = b + 1; i + 1 < e && k + 1 < outsz; i++) {
        char c = text[i];
        if (c == '\\' && i + 2 < e) {
            char x = text[++i];
            c = x == 'n' ? '\n' : x == 't' ? '\t' : x == 'r' ? '\r' : x == 'b' ? '\b'
                : x == 'f' ? '\f' : x == 'u' ? '\\' : x;
            if (x == 'u')
                i--; /* keep "\u" and the digits as they are */
        }
        out[k++] = c;
    }
    out[k] = '\0';
}

size_t dtx_json_find_nul_escape(const char *text, size_t len, char *ptr, size_t ptrsize)
{
    /* A stack of the open containers: whether each is an array, its
     * current element index and the length of ptr at its start.  Levels
     * beyond the stack are counted but not named (dtx_job_parse refuses
     * them earlier anyway). */
    enum { STACK = DTX_JSON_MAX_DEPTH + 1 };
    struct {
        int array;
        long index;
        size_t base;
    } st[STACK];
    long depth = 0;
    int want_key = 0, nul;
    char buf[512] = "", key[256];

    for (size_t i = 0; i < len;) {
        char c = text[i];
        if (c == '"') {
            size_t e = skip_string(text, len, i, &nul);
            if (want_key && depth > 0 && depth <= STACK) {
                buf[st[depth - 1].base] = '\0';
                copy_key(text, i, e, key, sizeof key);
                dtx_json_pointer_append(buf, sizeof buf, key);
            }
            if (nul) {
                if (ptr && ptrsize > 0)
                    snprintf(ptr, ptrsize, "%s", buf);
                return i;
            }
            want_key = 0;
            i = e;
            continue;
        }
        if (c == '{' || c == '[') {
            if (depth < STACK) {
                st[depth].array = c == '[';
                st[depth].index = 0;
                st[depth].base = strlen(buf);
                if (c == '[')
                    snprintf(buf + strlen(buf), sizeof buf - strlen(buf), "/0");
            }
            depth++;
            want_key = c == '{';
        } else if (c == '}' || c == ']') {
            if (depth > 0 && --depth < STACK)
                buf[st[depth].base] = '\0';
            want_key = 0;
        } else if (c == ',' && depth > 0 && depth <= STACK) {
            size_t b = st[depth - 1].base;
            buf[b] = '\0';
            if (st[depth - 1].array)
                snprintf(buf + b, sizeof buf - b, "/%ld", ++st[depth - 1].index);
            else
                want_key = 1;
        }
        i++;
    }
    return (size_t)-1;
}

void dtx_json_line_col(const char *text, size_t len, size_t pos, size_t *line, size_t *col)
{
    *line = 1;
    *col = 1;
    if (pos > len)
        pos = len;
    for (size_t i = 0; i < pos; i++) {
        if (text[i] == '\n' || (text[i] == '\r' && (i + 1 >= len || text[i + 1] != '\n'))) {
            (*line)++;
            *col = 1;
        } else if (text[i] != '\r') {
            (*col)++;
        }
    }
}
