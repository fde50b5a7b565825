/* meshfile_util.c: whole-file reading and bounded text scanning for the
 * mesh and marker readers. */
#include "meshfile_util.h"

#include "file_util.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

dtx_status dtx_file_read_all(const char *path, char **buf, size_t *len, dtx_error *err)
{
    /* Only regular files: a FIFO would block and /dev/zero would grow the
     * buffer until the memory runs out (file_util.h). */
    return dtx_file_read_regular(path, SIZE_MAX, buf, len, err);
}

void dtx_warnf(const dtx_warner *w, const char *fmt, ...)
{
    char msg[1024];
    va_list ap;
    if (!w || !w->fn)
        return;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    w->fn(w->ctx, msg);
}

void dtx_warn_fanned(const dtx_warner *w, const char *name, int64_t npoly, long first_line)
{
    if (npoly > 0)
        dtx_warnf(w,
                  "%s: %lld polygons with more than 3 vertices were fan-triangulated (the first "
                  "at line %ld)",
                  name, (long long)npoly, first_line);
}

void dtx_mesh_take(dtx_mesh *out, int64_t nv, int64_t nf, double *V, int32_t *F)
{
    out->nv = (int32_t)nv;
    out->nf = (int32_t)nf;
    out->V = V;
    out->F = F;
}

int dtx_has_nul(const char *buf, size_t len) { return len > 0 && memchr(buf, '\0', len) != NULL; }

void dtx_lines_init(dtx_lines *it, const char *buf, size_t len)
{
    it->cur = buf;
    it->end = buf + len;
    it->line = 0;
    if (len >= 3 && memcmp(buf, "\xEF\xBB\xBF", 3) == 0)
        it->cur += 3;
}

int dtx_lines_next(dtx_lines *it, const char **b, const char **e)
{
    const char *p = it->cur;
    if (p >= it->end)
        return 0;
    *b = p;
    /* A line ends at "\n", "\r\n" or a lone "\r" (classic Mac OS), so the
     * three conventions all give the same lines. */
    while (p < it->end && *p != '\n' && *p != '\r')
        p++;
    *e = p;
    if (p < it->end && *p == '\r')
        p++;
    if (p < it->end && *p == '\n')
        p++;
    it->cur = p;
    it->line++;
    return 1;
}

const char *dtx_next_token(const char **p, const char *e, size_t *n)
{
    const char *s = *p, *t;
    while (s < e && dtx_is_blank(*s))
        s++;
    if (s >= e) {
        *p = e;
        *n = 0;
        return NULL;
    }
    t = s;
    while (t < e && !dtx_is_blank(*t))
        t++;
    *p = t;
    *n = (size_t)(t - s);
    return s;
}

int dtx_parse_double(const char *s, size_t n, double *out)
{
    char tmp[DTX_MAX_NUMBER_LEN + 1];
    char *endp;
    if (n == 0 || n > DTX_MAX_NUMBER_LEN)
        return -1;
    /* strtod skips leading white space itself; a token never has any, but
     * reject it anyway so "whole number" means exactly these characters. */
    if (dtx_is_blank(s[0]) || s[0] == '\n')
        return -1;
    memcpy(tmp, s, n);
    tmp[n] = '\0';
    errno = 0;
    *out = strtod(tmp, &endp);
    if (endp != tmp + n)
        return -1;
    /* ERANGE: overflow gives +-HUGE_VAL (inf, rejected by the callers as
     * non-finite); underflow gives a tiny or zero value, which is fine. */
    return 0;
}

int dtx_parse_int64(const char *s, size_t n, int64_t *out)
{
    size_t i = 0;
    int neg = 0, over = 0;
    uint64_t v = 0, lim;
    if (n == 0 || n > DTX_MAX_NUMBER_LEN)
        return -1;
    if (s[0] == '+' || s[0] == '-') {
        neg = s[0] == '-';
        i = 1;
    }
    if (i == n)
        return -1;
    lim = neg ? (uint64_t)INT64_MAX + 1 : (uint64_t)INT64_MAX;
    for (; i < n; i++) {
        unsigned d = (unsigned char)s[i] - '0';
        if (d > 9)
            return -1;
        if (!over && v > (lim - d) / 10)
            over = 1;
        if (!over)
            v = v * 10 + d;
    }
    if (over) {
        *out = neg ? INT64_MIN : INT64_MAX;
        return -2;
    }
    if (neg)
        *out = v == (uint64_t)INT64_MAX + 1 ? INT64_MIN : -(int64_t)v;
    else
        *out = (int64_t)v;
    return 0;
}

const char *dtx_show_token(const char *s, size_t n, char *out, size_t outsz)
{
    size_t k = 0, max = outsz - 1;
    int cut = 0;
    if (n > max) {
        max = outsz - 4;
        cut = 1;
    }
    for (; k < n && k < max; k++) {
        unsigned char c = (unsigned char)s[k];
        out[k] = (c >= 0x20 && c < 0x7f) ? (char)c : '?';
    }
    if (cut) {
        memcpy(out + k, "...", 3);
        k += 3;
    }
    out[k] = '\0';
    return out;
}

/* ------------------------------------------------------------------ dispatch */

/* 1 if path ends with ext (".obj"), ignoring ASCII case. */
static int has_ext(const char *path, const char *ext)
{
    size_t n = strlen(path), m = strlen(ext);
    if (n < m)
        return 0;
    for (size_t i = 0; i < m; i++) {
        char c = path[n - m + i];
        if (c >= 'A' && c <= 'Z')
            c = (char)(c - 'A' + 'a');
        if (c != ext[i])
            return 0;
    }
    return 1;
}

int dtx_tri_push(int32_t **F, size_t *cap, int64_t *nt, int32_t a, int32_t b, int32_t c)
{
    if ((size_t)*nt == *cap) {
        size_t nc = *cap ? *cap * 2 : 8;
        int32_t *nf;
        if (nc > SIZE_MAX / (3 * sizeof **F))
            return -1;
        nf = realloc(*F, nc * 3 * sizeof **F);
        if (!nf)
            return -1;
        *F = nf;
        *cap = nc;
    }
    (*F)[3 * *nt] = a;
    (*F)[3 * *nt + 1] = b;
    (*F)[3 * *nt + 2] = c;
    (*nt)++;
    return 0;
}

dtx_status dtx_mesh_read_with(const char *path, dtx_mesh_parse_fn parse, dtx_mesh *out,
                              const dtx_warner *w, dtx_error *err)
{
    char *buf;
    size_t len;
    dtx_status st;
    memset(out, 0, sizeof *out);
    st = dtx_file_read_all(path, &buf, &len, err);
    if (st != DTX_OK)
        return st;
    st = parse(path, buf, len, out, w, err);
    free(buf);
    return st;
}

dtx_status dtx_mesh_read(const char *path, dtx_mesh *out, const dtx_warner *w, dtx_error *err)
{
    memset(out, 0, sizeof *out);
    if (has_ext(path, ".obj"))
        return dtx_obj_read(path, out, w, err);
    if (has_ext(path, ".ply"))
        return dtx_ply_read(path, out, w, err);
    if (has_ext(path, ".off"))
        return dtx_off_read(path, out, w, err);
    return dtx_seterr(err, DTX_EINVAL,
                      "%s: unknown mesh file type (expected the extension .obj, .ply or .off)",
                      path);
}
