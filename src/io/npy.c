/*
 * npy.c: the .npy reader for vertex frames (format in npy.h).
 *
 * The header dict is parsed by a small recursive-descent reader that knows
 * the three keys numpy writes; it never reads past the header's bytes.
 * Values are converted with explicit byte order, so files read the same on
 * any host.
 */
#include "npy.h"
#include "byteorder.h"

#include "meshfile_util.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------ the header dict */

typedef struct {
    const char *name;
    const unsigned char *p, *end;
    dtx_error *err;
} dict_reader;

static void skip_ws(dict_reader *r)
{
    while (r->p < r->end && (*r->p == ' ' || *r->p == '\t' || *r->p == '\n' || *r->p == '\r'))
        r->p++;
}

static dtx_status bad(dict_reader *r, const char *what)
{
    return dtx_seterr(r->err, DTX_EPARSE, "%s: malformed .npy header: %s", r->name, what);
}

/* A quoted string ('...' or "..."), copied into out[n] (no escapes: numpy
 * writes none in these three values). */
static dtx_status read_string(dict_reader *r, char *out, size_t n, const char *what)
{
    unsigned char q;
    size_t k = 0;
    skip_ws(r);
    if (r->p >= r->end || (*r->p != '\'' && *r->p != '"'))
        return bad(r, what);
    q = *r->p++;
    while (r->p < r->end && *r->p != q) {
        if (*r->p == '\\' || k + 1 >= n)
            return bad(r, what);
        out[k++] = (char)*r->p++;
    }
    if (r->p >= r->end)
        return bad(r, what);
    r->p++;
    out[k] = '\0';
    return DTX_OK;
}

static int accept_char(dict_reader *r, char c)
{
    skip_ws(r);
    if (r->p < r->end && *r->p == (unsigned char)c) {
        r->p++;
        return 1;
    }
    return 0;
}

static int accept_word(dict_reader *r, const char *w)
{
    size_t n = strlen(w);
    skip_ws(r);
    if ((size_t)(r->end - r->p) >= n && memcmp(r->p, w, n) == 0) {
        r->p += n;
        return 1;
    }
    return 0;
}

/* (d0, d1, ...) with an optional trailing comma; () is a scalar. */
static dtx_status read_shape(dict_reader *r, dtx_npy_header *h)
{
    if (!accept_char(r, '('))
        return bad(r, "'shape' is not a tuple");
    h->ndim = 0;
    for (;;) {
        int64_t v = 0;
        int digits = 0;
        if (accept_char(r, ')'))
            return DTX_OK;
        skip_ws(r);
        while (r->p < r->end && *r->p >= '0' && *r->p <= '9') {
            if (v > (INT64_MAX - 9) / 10)
                return dtx_seterr(r->err, DTX_EPARSE, "%s: .npy shape has a dimension too large",
                                  r->name);
            v = 10 * v + (*r->p++ - '0');
            digits++;
        }
        if (!digits)
            return bad(r, "'shape' holds something other than non-negative integers");
        (void)accept_char(r, 'L'); /* Python 2's long integers */
        if (h->ndim == DTX_NPY_MAX_DIMS)
            return bad(r, "'shape' has more than 32 dimensions");
        h->shape[h->ndim++] = v;
        if (!accept_char(r, ',')) {
            if (accept_char(r, ')'))
                return DTX_OK;
            return bad(r, "'shape' tuple not closed");
        }
    }
}

static dtx_status read_dict(dict_reader *r, dtx_npy_header *h)
{
    int have_descr = 0, have_order = 0, have_shape = 0;
    dtx_status st;
    if (!accept_char(r, '{'))
        return bad(r, "the header is not a dict");
    for (;;) {
        char key[32];
        if (accept_char(r, '}'))
            break;
        if ((st = read_string(r, key, sizeof key, "a key is not a short quoted string")) != DTX_OK)
            return st;
        if (!accept_char(r, ':'))
            return bad(r, "no ':' after a key");
        if (strcmp(key, "descr") == 0) {
            char d[64];
            skip_ws(r);
            if (r->p < r->end && *r->p == '[')
                return dtx_seterr(r->err, DTX_EPARSE,
                                  "%s: a record (structured) dtype; only float32 or float64 "
                                  "positions can be read",
                                  r->name);
            if ((st = read_string(r, d, sizeof d, "'descr' is not a quoted string")) != DTX_OK)
                return st;
            if (strlen(d) == 3 && (d[0] == '<' || d[0] == '>') && d[1] == 'f' &&
                (d[2] == '4' || d[2] == '8')) {
                h->big_endian = d[0] == '>';
                h->itemsize = d[2] - '0';
            } else {
                return dtx_seterr(r->err, DTX_EPARSE,
                                  "%s: dtype '%s': only float32 or float64 positions can be read "
                                  "('<f4', '>f4', '<f8', '>f8'; convert with "
                                  "a.astype(numpy.float32))",
                                  r->name, d);
            }
            have_descr = 1;
        } else if (strcmp(key, "fortran_order") == 0) {
            if (accept_word(r, "True"))
                h->fortran_order = 1;
            else if (accept_word(r, "False"))
                h->fortran_order = 0;
            else
                return bad(r, "'fortran_order' is neither True nor False");
            have_order = 1;
        } else if (strcmp(key, "shape") == 0) {
            if ((st = read_shape(r, h)) != DTX_OK)
                return st;
            have_shape = 1;
        } else {
            return dtx_seterr(r->err, DTX_EPARSE, "%s: malformed .npy header: unknown key '%s'",
                              r->name, key);
        }
        if (!accept_char(r, ',')) {
            if (accept_char(r, '}'))
                break;
            return bad(r, "no ',' or '}' after a value");
        }
    }
    if (!have_descr || !have_order || !have_shape)
        return bad(r, "'descr', 'fortran_order' and 'shape' must all be given");
    return DTX_OK;
}

dtx_status dtx_npy_parse_header(const char *name, const unsigned char *buf, size_t len,
                                dtx_npy_header *h, dtx_error *err)
{
    static const unsigned char magic[6] = {0x93, 'N', 'U', 'M', 'P', 'Y'};
    size_t hlen, start;
    dict_reader r;
    dtx_status st;
    memset(h, 0, sizeof *h);
    if (len < sizeof magic || memcmp(buf, magic, sizeof magic) != 0)
        return dtx_seterr(err, DTX_EPARSE, "%s: not a .npy file (no \"\\x93NUMPY\" magic)", name);
    if (len < 10)
        return dtx_seterr(err, DTX_EPARSE, "%s: %zu bytes, shorter than a .npy header (truncated?)",
                          name, len);
    if (buf[6] < 1 || buf[6] > 3)
        return dtx_seterr(err, DTX_EPARSE, "%s: .npy format version %d.%d (1.0, 2.0, 3.0 known)",
                          name, (int)buf[6], (int)buf[7]);
    if (buf[6] == 1) {
        hlen = (size_t)buf[8] | (size_t)buf[9] << 8;
        start = 10;
    } else {
        if (len < 12)
            return dtx_seterr(err, DTX_EPARSE,
                              "%s: %zu bytes, shorter than a .npy header "
                              "(truncated?)",
                              name, len);
        hlen = dtx_get_le32(buf + 8);
        start = 12;
    }
    if (hlen > len - start)
        return dtx_seterr(err, DTX_EPARSE,
                          "%s: the .npy header says %zu bytes but only %zu follow (truncated?)",
                          name, hlen, len - start);
    if (hlen == 0 || buf[start + hlen - 1] != '\n')
        return dtx_seterr(err, DTX_EPARSE,
                          "%s: malformed .npy header: it does not end in a "
                          "newline",
                          name);
    r.name = name;
    r.p = buf + start;
    r.end = buf + start + hlen;
    r.err = err;
    if ((st = read_dict(&r, h)) != DTX_OK)
        return st;
    h->data_offset = start + hlen;
    return DTX_OK;
}

/* ------------------------------------------------------------ the frames */

static double item(const unsigned char *p, const dtx_npy_header *h)
{
    if (h->itemsize == 4)
        return (double)(h->big_endian ? dtx_get_bef32(p) : dtx_get_lef32(p));
    {
        uint64_t hi = h->big_endian ? dtx_get_be32(p) : dtx_get_le32(p + 4),
                 lo = h->big_endian ? dtx_get_be32(p + 4) : dtx_get_le32(p), u = hi << 32 | lo;
        double d;
        memcpy(&d, &u, sizeof d);
        return d;
    }
}

dtx_status dtx_npy_parse_frames(const char *name, const unsigned char *buf, size_t len, int32_t *T,
                                int32_t *V, double **X, dtx_error *err)
{
    dtx_npy_header h;
    dtx_status st;
    int64_t t, v;
    uint64_t n, want;
    double *out;
    *X = NULL;
    *T = *V = 0;
    if ((st = dtx_npy_parse_header(name, buf, len, &h, err)) != DTX_OK)
        return st;
    /* ---- the shape: (T, V, 3) or (V, 3) */
    if ((h.ndim != 2 && h.ndim != 3) || h.shape[h.ndim - 1] != 3) {
        char s[256] = "(";
        for (int i = 0; i < h.ndim && strlen(s) < 200; i++)
            snprintf(s + strlen(s), sizeof s - strlen(s), "%s%lld", i ? ", " : "",
                     (long long)h.shape[i]);
        snprintf(s + strlen(s), sizeof s - strlen(s), "%s)", h.ndim == 1 ? "," : "");
        return dtx_seterr(err, DTX_EPARSE,
                          "%s: shape %s: expected (frames, vertices, 3) or (vertices, 3)", name, s);
    }
    t = h.ndim == 3 ? h.shape[0] : 1;
    v = h.shape[h.ndim - 2];
    if (t < 1 || v < 1 || t > INT32_MAX || v > INT32_MAX)
        return dtx_seterr(err, DTX_EPARSE,
                          "%s: %lld frames of %lld vertices (each must be 1 .. 2147483647)", name,
                          (long long)t, (long long)v);
    /* ---- the size, before allocating: t, v < 2^31 so n < 2^64 / 8 */
    n = (uint64_t)t * (uint64_t)v * 3u;
    want = n * (uint64_t)h.itemsize;
    if ((uint64_t)(len - h.data_offset) != want)
        return dtx_seterr(err, DTX_EPARSE,
                          "%s: %zu data bytes, but %lld frames x %lld vertices x 3 float%d need "
                          "%llu (%s)",
                          name, len - h.data_offset, (long long)t, (long long)v, 8 * h.itemsize,
                          (unsigned long long)want,
                          (uint64_t)(len - h.data_offset) < want ? "truncated" : "trailing bytes");
    if (n > SIZE_MAX / sizeof *out || !(out = dtx_alloc((size_t)n, sizeof *out, 0)))
        return dtx_seterr(err, DTX_ENOMEM, "%s: out of memory for %llu values", name,
                          (unsigned long long)n);
    {
        const unsigned char *d = buf + h.data_offset;
        const size_t sz = (size_t)h.itemsize;
        if (!h.fortran_order) {
            for (size_t i = 0; i < (size_t)n; i++)
                out[i] = item(d + sz * i, &h);
        } else {
            /* Fortran order: element (f, i, c) is stored at f + T*(i + V*c)
             * (for (V, 3): i + V*c). */
            for (size_t f = 0; f < (size_t)t; f++)
                for (size_t i = 0; i < (size_t)v; i++)
                    for (size_t c = 0; c < 3; c++)
                        out[(f * (size_t)v + i) * 3 + c] =
                            item(d + sz * (f + (size_t)t * (i + (size_t)v * c)), &h);
        }
    }
    *X = out;
    *T = (int32_t)t;
    *V = (int32_t)v;
    return DTX_OK;
}

dtx_status dtx_npy_read_frames(const char *path, int32_t *T, int32_t *V, double **X, dtx_error *err)
{
    char *buf = NULL;
    size_t len = 0;
    dtx_status st;
    *X = NULL;
    *T = *V = 0;
    if ((st = dtx_file_read_all(path, &buf, &len, err)) != DTX_OK)
        return st;
    st = dtx_npy_parse_frames(path, (const unsigned char *)buf, len, T, V, X, err);
    free(buf);
    return st;
}
