/* markers_csv.c: marker sets (source/target vertex pairs) from CSV files. */
#include "meshfile.h"
#include "meshfile_util.h"

#include <stdlib.h>
#include <string.h>

/* [*b, *e) without leading and trailing blanks. */
static void trim(const char **b, const char **e)
{
    while (*b < *e && dtx_is_blank(**b))
        (*b)++;
    while (*e > *b && dtx_is_blank((*e)[-1]))
        (*e)--;
}

/* Looks at a comment line [b, e) (b at the '#') for `# index_base: N`.
 * Returns -1 when it is an ordinary comment, 0 or 1 for the base it sets,
 * -2 when it names index_base with a bad value. */
static int base_directive(const char *b, const char *e)
{
    static const char kw[] = "index_base";
    const size_t kn = sizeof kw - 1;
    b++;
    trim(&b, &e);
    if ((size_t)(e - b) < kn || memcmp(b, kw, kn) != 0)
        return -1;
    b += kn;
    trim(&b, &e);
    if (b == e || (*b != ':' && *b != '='))
        return -2;
    b++;
    trim(&b, &e);
    if (e - b == 1 && (*b == '0' || *b == '1'))
        return *b - '0';
    return -2;
}

/* A new string holding the label [b, e): trimmed, and when wrapped in
 * double quotes unwrapped, with "" inside turned into ". */
static char *make_label(const char *b, const char *e)
{
    char *s;
    size_t k = 0;
    int quoted;
    trim(&b, &e);
    quoted = e - b >= 2 && b[0] == '"' && e[-1] == '"';
    if (quoted) {
        b++;
        e--;
    }
    s = malloc((size_t)(e - b) + 1);
    if (!s)
        return NULL;
    for (const char *p = b; p < e; p++) {
        s[k++] = *p;
        if (quoted && p[0] == '"' && p + 1 < e && p[1] == '"')
            p++;
    }
    s[k] = '\0';
    return s;
}

/* Parses one index field [b, e) of line `line`, converting it to 0-based. */
static dtx_status index_field(const char *name, long line, const char *what, const char *b,
                              const char *e, int base, int32_t *out, dtx_error *err)
{
    int64_t v;
    char show[48];
    int r;
    trim(&b, &e);
    if (e - b >= 2 && b[0] == '"' && e[-1] == '"') { /* "12", as spreadsheets write it */
        b++;
        e--;
        trim(&b, &e);
    }
    r = dtx_parse_int64(b, (size_t)(e - b), &v);
    if (r == -1 && b == e)
        return dtx_seterr(err, DTX_EPARSE,
                          "%s:%ld: %s '' is not an integer (the field is empty: every marker "
                          "needs a source and a target vertex; fill it in)",
                          name, line, what);
    if (r == -1)
        return dtx_seterr(err, DTX_EPARSE, "%s:%ld: %s '%s' is not an integer", name, line, what,
                          dtx_show_token(b, (size_t)(e - b), show, sizeof show));
    if (r == 0 && v < base)
        return dtx_seterr(err, DTX_ERANGE, "%s:%ld: %s index %lld in a %d-based file", name, line,
                          what, (long long)v, base);
    if (r != 0 || v - base > INT32_MAX)
        return dtx_seterr(err, DTX_ERANGE, "%s:%ld: %s index %s too large", name, line, what,
                          dtx_show_token(b, (size_t)(e - b), show, sizeof show));
    *out = (int32_t)(v - base);
    return DTX_OK;
}

dtx_status dtx_markers_parse_csv(const char *name, const char *buf, size_t len, int index_base,
                                 dtx_markers *out, dtx_error *err)
{
    dtx_lines it;
    const char *b, *e;
    int file_base = -1, base, seen_first = 0;
    long base_line = 0;
    int64_t ndata = 0;
    int32_t m = 0;
    dtx_status st;

    memset(out, 0, sizeof *out);
    if (index_base < -1 || index_base > 1)
        return dtx_seterr(err, DTX_EINVAL,
                          "%s: index_base must be 0, 1 or -1 (from the file), "
                          "not %d",
                          name, index_base);
    if (dtx_has_nul(buf, len))
        return dtx_seterr(err, DTX_EPARSE, "%s: not a text file (contains NUL bytes)", name);

    /* ---- pass 1: the index_base directive and the number of data lines */
    dtx_lines_init(&it, buf, len);
    while (dtx_lines_next(&it, &b, &e)) {
        int d;
        trim(&b, &e);
        if (b == e)
            continue;
        if (*b != '#') {
            /* A data line holds two indices and a label: a megabyte of it
             * is not a marker (comment lines may be of any length). */
            if ((size_t)(e - b) > DTX_MESHFILE_MAX_LINE)
                return dtx_seterr(err, DTX_EPARSE,
                                  "%s:%ld: line too long (%zu bytes; the limit is %zu)", name,
                                  it.line, (size_t)(e - b), DTX_MESHFILE_MAX_LINE);
            ndata++;
            continue;
        }
        d = base_directive(b, e);
        if (d == -2)
            return dtx_seterr(err, DTX_EPARSE, "%s:%ld: index_base must be 0 or 1", name, it.line);
        if (d >= 0 && file_base >= 0 && d != file_base)
            return dtx_seterr(err, DTX_EPARSE,
                              "%s:%ld: index_base %d contradicts index_base %d at line %ld", name,
                              it.line, d, file_base, base_line);
        if (d >= 0 && file_base < 0) {
            file_base = d;
            base_line = it.line;
        }
    }
    if (index_base >= 0 && file_base >= 0 && index_base != file_base)
        return dtx_seterr(err, DTX_EINVAL,
                          "%s:%ld: the file says index_base %d but %d-based indices were asked "
                          "for",
                          name, base_line, file_base, index_base);
    if (index_base < 0 && file_base < 0)
        return dtx_seterr(err, DTX_EINVAL,
                          "%s: index base unknown: the file has no '# index_base: 0|1' line and "
                          "none was given",
                          name);
    base = index_base >= 0 ? index_base : file_base;
    if (ndata > INT32_MAX)
        return dtx_seterr(err, DTX_ERANGE, "%s: too many lines", name);
    st = dtx_markers_alloc(out, (int32_t)ndata, err);
    if (st != DTX_OK)
        return st;

    /* ---- pass 2: the markers */
    dtx_lines_init(&it, buf, len);
    while (dtx_lines_next(&it, &b, &e)) {
        const char *c1, *c2, *f2e;
        trim(&b, &e);
        if (b == e || *b == '#')
            continue;
        c1 = memchr(b, ',', (size_t)(e - b));
        if (!seen_first) {
            /* The first data line may be a header: its first field is not
             * an integer. */
            const char *fb = b, *fe = c1 ? c1 : e;
            int64_t v;
            seen_first = 1;
            trim(&fb, &fe);
            if (dtx_parse_int64(fb, (size_t)(fe - fb), &v) == -1)
                continue;
        }
        st = index_field(name, it.line, "source vertex", b, c1 ? c1 : e, base, &out->src[m], err);
        if (st != DTX_OK)
            goto fail;
        if (!c1) {
            st = dtx_seterr(err, DTX_EPARSE,
                            "%s:%ld: missing target vertex (expected "
                            "source_vertex,target_vertex[,label])",
                            name, it.line);
            goto fail;
        }
        c2 = memchr(c1 + 1, ',', (size_t)(e - c1 - 1));
        f2e = c2 ? c2 : e;
        st = index_field(name, it.line, "target vertex", c1 + 1, f2e, base, &out->tgt[m], err);
        if (st != DTX_OK)
            goto fail;
        out->labels[m] = c2 ? make_label(c2 + 1, e) : make_label(e, e);
        if (!out->labels[m]) {
            st = dtx_seterr(err, DTX_ENOMEM, "%s: out of memory", name);
            goto fail;
        }
        m++;
    }
    if (m == 0) {
        st = dtx_seterr(err, DTX_EPARSE, "%s: no markers", name);
        goto fail;
    }
    out->n = m;
    return DTX_OK;

fail:
    dtx_markers_free(out);
    return st;
}

dtx_status dtx_markers_read_csv(const char *path, int index_base, dtx_markers *out, dtx_error *err)
{
    char *buf;
    size_t len;
    dtx_status st;
    memset(out, 0, sizeof *out);
    st = dtx_file_read_all(path, &buf, &len, err);
    if (st != DTX_OK)
        return st;
    st = dtx_markers_parse_csv(path, buf, len, index_base, out, err);
    free(buf);
    return st;
}
