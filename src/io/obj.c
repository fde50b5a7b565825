/* obj.c: Wavefront OBJ meshes, read (v and f lines) and written (through
 * obj_write.c's writer, without attributes). */
#include "meshfile.h"
#include "meshfile_util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static int is_kw(const char *k, size_t n, const char *lit)
{
    return strlen(lit) == n && memcmp(k, lit, n) == 0;
}

/* Keywords that carry nothing a triangle mesh needs: skipped silently. */
static int is_ignored_keyword(const char *k, size_t n)
{
    static const char *const kw[] = {"vn", "vt", "vp", "o", "g", "s", "usemtl", "mtllib", "l"};
    for (size_t i = 0; i < sizeof kw / sizeof kw[0]; i++)
        if (is_kw(k, n, kw[i]))
            return 1;
    return 0;
}

/* Parses one face reference `i`, `i/t`, `i//n` or `i/t/n` and returns the
 * vertex part in *vi.  Returns 0, -1 when malformed, -2 when the vertex
 * index is an integer beyond the int64 range.  t and n must be integers when
 * present (their values are not used). */
static int parse_ref(const char *t, size_t n, int64_t *vi)
{
    const char *e = t + n, *s1 = memchr(t, '/', n), *vend = s1 ? s1 : e;
    int64_t unused;
    int r = dtx_parse_int64(t, (size_t)(vend - t), vi);
    if (r == -1)
        return -1;
    if (s1) {
        const char *tb = s1 + 1, *s2 = memchr(tb, '/', (size_t)(e - tb));
        const char *tend = s2 ? s2 : e;
        if (tend > tb) {
            if (dtx_parse_int64(tb, (size_t)(tend - tb), &unused) == -1)
                return -1;
        } else if (!s2) {
            return -1; /* "i/" */
        }
        if (s2) {
            const char *nb = s2 + 1;
            if (nb == e || memchr(nb, '/', (size_t)(e - nb)) ||
                dtx_parse_int64(nb, (size_t)(e - nb), &unused) == -1)
                return -1;
        }
    }
    return r;
}

/* ------------------------------------------------------------------ counting
 * The first pass counts `v` lines and the triangles the `f` lines will give,
 * so the second pass fills arrays of exactly the right size (no growth, no
 * per-line allocation).  Its counts are upper bounds: the second pass stops
 * at comments and errors on anything malformed. */
static dtx_status obj_count(const char *name, const char *buf, size_t len, int64_t *nv,
                            int64_t *ntri, dtx_error *err)
{
    dtx_lines it;
    const char *b, *e;
    *nv = 0;
    *ntri = 0;
    dtx_lines_init(&it, buf, len);
    while (dtx_lines_next(&it, &b, &e)) {
        const char *p = b, *k;
        size_t n;
        k = dtx_next_token(&p, e, &n);
        if (!k || n != 1)
            continue;
        if (k[0] == 'v') {
            /* Only vertex lines have a length limit (DTX_MESHFILE_MAX_LINE):
             * comments and skipped lines may be of any length. */
            if ((size_t)(e - b) > DTX_MESHFILE_MAX_LINE)
                return dtx_seterr(err, DTX_EPARSE,
                                  "%s:%ld: vertex line too long (%zu bytes; the limit is %zu)",
                                  name, it.line, (size_t)(e - b), DTX_MESHFILE_MAX_LINE);
            (*nv)++;
        } else if (k[0] == 'f') {
            int64_t c = 0;
            while (dtx_next_token(&p, e, &n))
                c++;
            if (c >= 3)
                *ntri += c - 2;
        }
    }
    return DTX_OK;
}

/* ------------------------------------------------------------------ parsing */

dtx_status dtx_obj_parse(const char *name, const char *buf, size_t len, dtx_mesh *out,
                         const dtx_warner *w, dtx_error *err)
{
    double *V = NULL;
    int32_t *F = NULL;
    int64_t nv, ntri, cur_v = 0, cur_t = 0, npoly = 0, nunknown = 0;
    long poly_line = 0, unknown_line = 0;
    char unknown_kw[40] = "", show[48];
    dtx_lines it;
    const char *b, *e;
    dtx_status st;

    memset(out, 0, sizeof *out);
    if (dtx_has_nul(buf, len))
        return dtx_seterr(err, DTX_EPARSE, "%s: not a text file (contains NUL bytes)", name);
    st = obj_count(name, buf, len, &nv, &ntri, err);
    if (st != DTX_OK)
        return st;
    if (nv == 0)
        return dtx_seterr(err, DTX_EPARSE, "%s: %s", name,
                          len == 0 ? "empty file" : "no vertices (no 'v' lines)");
    if (nv > INT32_MAX)
        return dtx_seterr(err, DTX_ERANGE, "%s: %lld vertices (at most %d are supported)", name,
                          (long long)nv, (int)INT32_MAX);
    if (ntri > INT32_MAX)
        return dtx_seterr(err, DTX_ERANGE, "%s: %lld triangles (at most %d are supported)", name,
                          (long long)ntri, (int)INT32_MAX);
    V = dtx_alloc((size_t)nv, 3 * sizeof *V, 0);
    F = dtx_alloc((size_t)ntri, 3 * sizeof *F, 0);
    if (!V || !F) {
        st = dtx_seterr(err, DTX_ENOMEM, "%s: cannot allocate %lld vertices and %lld triangles",
                        name, (long long)nv, (long long)ntri);
        goto fail;
    }

    dtx_lines_init(&it, buf, len);
    while (dtx_lines_next(&it, &b, &e)) {
        const char *p = b, *k, *t;
        size_t n;
        k = dtx_next_token(&p, e, &n);
        if (!k || k[0] == '#')
            continue;

        if (is_kw(k, n, "v")) {
            /* ---- v x y z [w] [r g b] */
            double x[7];
            int cnt = 0;
            while ((t = dtx_next_token(&p, e, &n)) && t[0] != '#') {
                if (cnt == 7) {
                    cnt++;
                    break;
                }
                if (dtx_parse_double(t, n, &x[cnt]) != 0) {
                    st = dtx_seterr(err, DTX_EPARSE,
                                    "%s:%ld: malformed vertex line: '%s' is not a number", name,
                                    it.line, dtx_show_token(t, n, show, sizeof show));
                    goto fail;
                }
                cnt++;
            }
            if (cnt < 3) {
                st = dtx_seterr(err, DTX_EPARSE,
                                "%s:%ld: malformed vertex line: expected 3 numbers, found %d", name,
                                it.line, cnt);
                goto fail;
            }
            if (cnt == 5 || cnt > 7) {
                st = dtx_seterr(err, DTX_EPARSE,
                                "%s:%ld: malformed vertex line: expected x y z [w] [r g b], "
                                "found %s numbers",
                                name, it.line, cnt == 5 ? "5" : "more than 7");
                goto fail;
            }
            if (!isfinite(x[0]) || !isfinite(x[1]) || !isfinite(x[2])) {
                st = dtx_seterr(err, DTX_ENONFINITE,
                                "%s:%ld: vertex %lld has a non-finite coordinate", name, it.line,
                                (long long)cur_v + 1);
                goto fail;
            }
            memcpy(V + 3 * cur_v, x, 3 * sizeof *V);
            cur_v++;

        } else if (is_kw(k, n, "f")) {
            /* ---- f r1 r2 r3 ...: fan (r1 r2 r3), (r1 r3 r4), ... */
            int32_t first = 0, prev = 0;
            int64_t cnt = 0;
            while ((t = dtx_next_token(&p, e, &n)) && t[0] != '#') {
                int64_t vi = 0;
                int32_t idx;
                int r = parse_ref(t, n, &vi);
                if (r == -1) {
                    st = dtx_seterr(err, DTX_EPARSE,
                                    "%s:%ld: malformed face line: bad vertex reference '%s'", name,
                                    it.line, dtx_show_token(t, n, show, sizeof show));
                    goto fail;
                }
                if (r == 0 && vi == 0) {
                    st = dtx_seterr(err, DTX_ERANGE,
                                    "%s:%ld: face index 0 (OBJ indices start at 1)", name, it.line);
                    goto fail;
                }
                if (vi > 0) {
                    if (r != 0 || vi > nv) {
                        st = dtx_seterr(err, DTX_ERANGE,
                                        "%s:%ld: face index %s out of range (the file has %lld "
                                        "vertices)",
                                        name, it.line, dtx_show_token(t, n, show, sizeof show),
                                        (long long)nv);
                        goto fail;
                    }
                    idx = (int32_t)(vi - 1);
                } else {
                    /* vi < -cur_v, not -vi > cur_v: -INT64_MIN overflows. */
                    if (r != 0 || vi < -cur_v) {
                        st = dtx_seterr(err, DTX_ERANGE,
                                        "%s:%ld: relative face index %s refers before the first "
                                        "vertex (%lld vertices defined so far)",
                                        name, it.line, dtx_show_token(t, n, show, sizeof show),
                                        (long long)cur_v);
                        goto fail;
                    }
                    idx = (int32_t)(cur_v + vi);
                }
                if (cnt == 0) {
                    first = idx;
                } else if (cnt >= 2) {
                    if (cur_t >= ntri) { /* cannot happen: the first pass counted more */
                        st = dtx_seterr(err, DTX_EPARSE, "%s:%ld: internal triangle count error",
                                        name, it.line);
                        goto fail;
                    }
                    F[3 * cur_t] = first;
                    F[3 * cur_t + 1] = prev;
                    F[3 * cur_t + 2] = idx;
                    cur_t++;
                }
                prev = idx;
                cnt++;
            }
            if (cnt < 3) {
                st = dtx_seterr(err, DTX_EPARSE,
                                "%s:%ld: face with %lld vertices (at least 3 needed)", name,
                                it.line, (long long)cnt);
                goto fail;
            }
            if (cnt > 3 && npoly++ == 0)
                poly_line = it.line;

        } else if (!is_ignored_keyword(k, n)) {
            if (nunknown++ == 0) {
                unknown_line = it.line;
                dtx_show_token(k, n, unknown_kw, sizeof unknown_kw);
            }
        }
    }
    if (cur_t == 0) {
        st = dtx_seterr(err, DTX_EPARSE, "%s: no faces (no 'f' lines)", name);
        goto fail;
    }
    dtx_warn_fanned(w, name, npoly, poly_line);
    if (nunknown > 0)
        dtx_warnf(w, "%s:%ld: unknown keyword '%s' ignored (%lld such lines in the file)", name,
                  unknown_line, unknown_kw, (long long)nunknown);
    dtx_mesh_take(out, nv, cur_t, V, F);
    return DTX_OK;

fail:
    free(V);
    free(F);
    return st;
}

dtx_status dtx_obj_read(const char *path, dtx_mesh *out, const dtx_warner *w, dtx_error *err)
{
    return dtx_mesh_read_with(path, dtx_obj_parse, out, w, err);
}

/* ------------------------------------------------------------------ writing */

dtx_status dtx_obj_write(const char *path, const double *V, int32_t nv, const int32_t *F,
                         int32_t nf, const char *comment, dtx_error *err)
{
    return dtx_obj_write_attrs(path, V, NULL, nv, F, nf, NULL, comment, err);
}

dtx_status dtx_obj_write_f32(const char *path, const float *V, int32_t nv, const int32_t *F,
                             int32_t nf, const char *comment, dtx_error *err)
{
    return dtx_obj_write_attrs(path, NULL, V, nv, F, nf, NULL, comment, err);
}
