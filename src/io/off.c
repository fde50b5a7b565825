/* off.c: Object File Format (ASCII OFF) meshes, read. */
#include "meshfile.h"
#include "meshfile_util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The next line holding something other than blanks and a comment, with
 * the comment cut off.  Returns 0 at the end of the buffer. */
static int content_line(dtx_lines *it, const char **b, const char **e)
{
    while (dtx_lines_next(it, b, e)) {
        const char *hash = memchr(*b, '#', (size_t)(*e - *b)), *p;
        size_t n;
        if (hash)
            *e = hash;
        p = *b;
        if (dtx_next_token(&p, *e, &n))
            return 1;
    }
    return 0;
}

/* 1 (with a message) when the record line [b, e) of it, comment cut off,
 * is longer than DTX_MESHFILE_MAX_LINE: the header, counts and vertex
 * lines hold a few numbers each (face lines and comments have no limit). */
static int too_long(const char *name, const dtx_lines *it, const char *b, const char *e,
                    dtx_error *err)
{
    if ((size_t)(e - b) <= DTX_MESHFILE_MAX_LINE)
        return 0;
    dtx_seterr(err, DTX_EPARSE, "%s:%ld: line too long (%zu bytes; the limit is %zu)", name,
               it->line, (size_t)(e - b), DTX_MESHFILE_MAX_LINE);
    return 1;
}

/* Recognises the header keyword: [ST][C][N]OFF.  Returns 1 for a supported
 * one, 0 for something else, -1 for an unsupported variant (4OFF, nOFF). */
static int off_keyword(const char *t, size_t n)
{
    size_t i = 0;
    if (n < 3 || memcmp(t + n - 3, "OFF", 3) != 0)
        return 0;
    n -= 3;
    if (i + 2 <= n && t[i] == 'S' && t[i + 1] == 'T')
        i += 2;
    if (i < n && t[i] == 'C')
        i++;
    if (i < n && t[i] == 'N')
        i++;
    if (i < n && (t[i] == '4' || t[i] == 'n'))
        return -1;
    return i == n ? 1 : 0;
}

dtx_status dtx_off_parse(const char *name, const char *buf, size_t len, dtx_mesh *out,
                         const dtx_warner *w, dtx_error *err)
{
    dtx_lines it;
    const char *b, *e, *p, *t, *data;
    size_t n, fcap;
    int64_t nv = 0, nf = 0, nt = 0, npoly = 0, cnt[3];
    int ncnt = 0, kw;
    long poly_line = 0;
    double *V = NULL;
    int32_t *F = NULL;
    char show[48];
    dtx_status st;

    memset(out, 0, sizeof *out);
    if (dtx_has_nul(buf, len))
        return dtx_seterr(err, DTX_EPARSE, "%s: not a text file (contains NUL bytes)", name);
    dtx_lines_init(&it, buf, len);

    /* ---- header keyword, then the counts (possibly on the same line) */
    if (!content_line(&it, &b, &e))
        return dtx_seterr(err, DTX_EPARSE, "%s: empty file", name);
    if (too_long(name, &it, b, e, err))
        return DTX_EPARSE;
    p = b;
    t = dtx_next_token(&p, e, &n);
    kw = off_keyword(t, n);
    if (kw <= 0)
        return dtx_seterr(err, DTX_EPARSE, "%s:%ld: %s '%s'", name, it.line,
                          kw < 0 ? "unsupported OFF variant"
                                 : "not an OFF file: expected OFF, found",
                          dtx_show_token(t, n, show, sizeof show));
    t = dtx_next_token(&p, e, &n);
    if (t && n == 6 && memcmp(t, "BINARY", 6) == 0)
        return dtx_seterr(err, DTX_EPARSE, "%s:%ld: binary OFF is not supported", name, it.line);
    if (!t) {
        if (!content_line(&it, &b, &e))
            return dtx_seterr(err, DTX_EPARSE, "%s: no counts line after the OFF header", name);
        if (too_long(name, &it, b, e, err))
            return DTX_EPARSE;
        p = b;
        t = dtx_next_token(&p, e, &n);
    }
    for (; t; t = dtx_next_token(&p, e, &n)) {
        int r;
        if (ncnt == 3)
            return dtx_seterr(err, DTX_EPARSE,
                              "%s:%ld: malformed counts line: expected 'vertices faces [edges]'",
                              name, it.line);
        r = dtx_parse_int64(t, n, &cnt[ncnt]);
        if (r == -1)
            return dtx_seterr(err, DTX_EPARSE,
                              "%s:%ld: malformed counts line: '%s' is not an "
                              "integer",
                              name, it.line, dtx_show_token(t, n, show, sizeof show));
        if (r == -2 || cnt[ncnt] < 0)
            return dtx_seterr(err, DTX_ERANGE, "%s:%ld: count '%s' out of range", name, it.line,
                              dtx_show_token(t, n, show, sizeof show));
        ncnt++;
    }
    if (ncnt < 2)
        return dtx_seterr(err, DTX_EPARSE,
                          "%s:%ld: malformed counts line: expected 'vertices faces [edges]'", name,
                          it.line);
    nv = cnt[0];
    nf = cnt[1];
    if (nv == 0)
        return dtx_seterr(err, DTX_EPARSE, "%s:%ld: no vertices", name, it.line);
    if (nf == 0)
        return dtx_seterr(err, DTX_EPARSE, "%s:%ld: no faces", name, it.line);
    /* Each vertex and each face takes a line of at least one character plus
     * a line end: check the counts against the bytes left before allocating
     * anything from them (a loose bound, so that short malformed lines get
     * their own, more precise, message below). */
    data = it.cur;
    if (nv > INT32_MAX || nf > INT32_MAX ||
        ((uint64_t)nv + (uint64_t)nf) * 2 > (uint64_t)(it.end - data) + 1)
        return dtx_seterr(err, DTX_ERANGE,
                          "%s:%ld: the counts (%lld vertices, %lld faces) cannot fit in the "
                          "%zu bytes that follow (file truncated or counts wrong)",
                          name, it.line, (long long)nv, (long long)nf, (size_t)(it.end - data));
    V = dtx_alloc((size_t)nv, 3 * sizeof *V, 0);
    fcap = (size_t)nf;
    F = dtx_alloc(fcap, 3 * sizeof *F, 0);
    if (!V || !F) {
        st = dtx_seterr(err, DTX_ENOMEM, "%s: cannot allocate %lld vertices and %lld faces", name,
                        (long long)nv, (long long)nf);
        goto fail;
    }

    /* ---- vertices: x y z, then anything (colours, normals) ignored */
    for (int64_t i = 0; i < nv; i++) {
        if (!content_line(&it, &b, &e)) {
            st = dtx_seterr(err, DTX_EPARSE,
                            "%s: file ends after %lld of %lld vertices (truncated?)", name,
                            (long long)i, (long long)nv);
            goto fail;
        }
        if (too_long(name, &it, b, e, err)) {
            st = DTX_EPARSE;
            goto fail;
        }
        p = b;
        for (int k = 0; k < 3; k++) {
            t = dtx_next_token(&p, e, &n);
            if (!t) {
                st = dtx_seterr(err, DTX_EPARSE,
                                "%s:%ld: malformed vertex line: expected 3 numbers, found %d", name,
                                it.line, k);
                goto fail;
            }
            if (dtx_parse_double(t, n, &V[3 * i + k]) != 0) {
                st = dtx_seterr(err, DTX_EPARSE,
                                "%s:%ld: malformed vertex line: '%s' is not a number", name,
                                it.line, dtx_show_token(t, n, show, sizeof show));
                goto fail;
            }
        }
        if (!isfinite(V[3 * i]) || !isfinite(V[3 * i + 1]) || !isfinite(V[3 * i + 2])) {
            st = dtx_seterr(err, DTX_ENONFINITE,
                            "%s:%ld: vertex %lld (0-based) has a non-finite coordinate", name,
                            it.line, (long long)i);
            goto fail;
        }
    }

    /* ---- faces: n i1 .. in, then anything (a colour) ignored */
    for (int64_t f = 0; f < nf; f++) {
        int64_t k, first = 0, prev = 0;
        int r;
        if (!content_line(&it, &b, &e)) {
            st = dtx_seterr(err, DTX_EPARSE, "%s: file ends after %lld of %lld faces (truncated?)",
                            name, (long long)f, (long long)nf);
            goto fail;
        }
        p = b;
        t = dtx_next_token(&p, e, &n);
        r = dtx_parse_int64(t, n, &k);
        if (r == -1) {
            st = dtx_seterr(err, DTX_EPARSE,
                            "%s:%ld: malformed face line: '%s' is not a vertex count", name,
                            it.line, dtx_show_token(t, n, show, sizeof show));
            goto fail;
        }
        if (r == 0 && k >= 0 && k < 3) {
            st = dtx_seterr(err, DTX_EPARSE, "%s:%ld: face with %lld vertices (at least 3 needed)",
                            name, it.line, (long long)k);
            goto fail;
        }
        /* A face line cannot hold more indices than it has bytes. */
        if (r != 0 || k < 0 || k > (e - b)) {
            st = dtx_seterr(err, DTX_ERANGE, "%s:%ld: bad face vertex count '%s'", name, it.line,
                            dtx_show_token(t, n, show, sizeof show));
            goto fail;
        }
        for (int64_t j = 0; j < k; j++) {
            int64_t vi;
            t = dtx_next_token(&p, e, &n);
            if (!t) {
                st = dtx_seterr(err, DTX_EPARSE,
                                "%s:%ld: malformed face line: %lld vertex indices announced, %lld "
                                "found",
                                name, it.line, (long long)k, (long long)j);
                goto fail;
            }
            r = dtx_parse_int64(t, n, &vi);
            if (r == -1) {
                st = dtx_seterr(err, DTX_EPARSE,
                                "%s:%ld: malformed face line: '%s' is not a vertex index", name,
                                it.line, dtx_show_token(t, n, show, sizeof show));
                goto fail;
            }
            if (r != 0 || vi < 0 || vi >= nv) {
                st = dtx_seterr(err, DTX_ERANGE,
                                "%s:%ld: face vertex index %s out of range [0, %lld)", name,
                                it.line, dtx_show_token(t, n, show, sizeof show), (long long)nv);
                goto fail;
            }
            if (j == 0) {
                first = vi;
            } else if (j >= 2) {
                if (nt == INT32_MAX) {
                    st = dtx_seterr(err, DTX_ERANGE, "%s: more than %d triangles", name,
                                    (int)INT32_MAX);
                    goto fail;
                }
                if (dtx_tri_push(&F, &fcap, &nt, (int32_t)first, (int32_t)prev, (int32_t)vi) != 0) {
                    st = dtx_seterr(err, DTX_ENOMEM, "%s: out of memory", name);
                    goto fail;
                }
            }
            prev = vi;
        }
        if (k > 3 && npoly++ == 0)
            poly_line = it.line;
    }
    if (content_line(&it, &b, &e))
        dtx_warnf(w, "%s:%ld: data after the last face ignored", name, it.line);
    dtx_warn_fanned(w, name, npoly, poly_line);
    dtx_mesh_take(out, nv, nt, V, F);
    return DTX_OK;

fail:
    free(V);
    free(F);
    return st;
}

dtx_status dtx_off_read(const char *path, dtx_mesh *out, const dtx_warner *w, dtx_error *err)
{
    return dtx_mesh_read_with(path, dtx_off_parse, out, w, err);
}
