/*
 * html_view.c: the self-contained page of `dtx view` (html_view.h).
 *
 * The page is: a Content-Security-Policy naming the one script by its
 * SHA-256, a <style>, the data as JSON and base64 in non-executing
 * <script> elements, and one module script made of three.js (its ES module
 * build, whose final `export{a as B,...}` is turned into
 * `const THREE={B:a,...}` so the viewer's code in the same script can use
 * it) followed by the viewer's code (view_app.js).  three.js, the viewer's
 * code and its style sheet are compiled in (cmake/embed.cmake).
 */
#include "html_view.h"
#include "byteorder.h"

#include "atomic_file.h"

#include <math.h>
#include <stdio.h>
#include <zlib.h>
#include <stdlib.h>
#include <string.h>

extern const unsigned char dtx_view_app_js[];
extern const size_t dtx_view_app_js_len;
extern const unsigned char dtx_view_css[];
extern const size_t dtx_view_css_len;
#ifdef DTX_HAVE_THREE
extern const unsigned char dtx_three_js[];
extern const size_t dtx_three_js_len;
#endif

int dtx_view_available(void)
{
#ifdef DTX_HAVE_THREE
    return 1;
#else
    return 0;
#endif
}

/* ------------------------------------------------------------- base64 */

size_t dtx_base64(const void *data, size_t n, char *out)
{
    static const char tab[] =
        "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    const unsigned char *p = data;
    size_t k = 0, i = 0;
    for (; i + 3 <= n; i += 3) {
        unsigned v = (unsigned)p[i] << 16 | (unsigned)p[i + 1] << 8 | p[i + 2];
        out[k++] = tab[v >> 18];
        out[k++] = tab[(v >> 12) & 63];
        out[k++] = tab[(v >> 6) & 63];
        out[k++] = tab[v & 63];
    }
    if (n - i == 1) {
        unsigned v = (unsigned)p[i] << 16;
        out[k++] = tab[v >> 18];
        out[k++] = tab[(v >> 12) & 63];
        out[k++] = '=';
        out[k++] = '=';
    } else if (n - i == 2) {
        unsigned v = (unsigned)p[i] << 16 | (unsigned)p[i + 1] << 8;
        out[k++] = tab[v >> 18];
        out[k++] = tab[(v >> 12) & 63];
        out[k++] = tab[(v >> 6) & 63];
        out[k++] = '=';
    }
    out[k] = 0;
    return k;
}

/* ------------------------------------------------------------- SHA-256 */

#define ROR(x, r) (((x) >> (r)) | ((x) << (32 - (r))))

static void sha256_block(uint32_t h[8], const unsigned char *b)
{
    static const uint32_t K[64] = {
        0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1, 0x923f82a4,
        0xab1c5ed5, 0xd807aa98, 0x12835b01, 0x243185be, 0x550c7dc3, 0x72be5d74, 0x80deb1fe,
        0x9bdc06a7, 0xc19bf174, 0xe49b69c1, 0xefbe4786, 0x0fc19dc6, 0x240ca1cc, 0x2de92c6f,
        0x4a7484aa, 0x5cb0a9dc, 0x76f988da, 0x983e5152, 0xa831c66d, 0xb00327c8, 0xbf597fc7,
        0xc6e00bf3, 0xd5a79147, 0x06ca6351, 0x14292967, 0x27b70a85, 0x2e1b2138, 0x4d2c6dfc,
        0x53380d13, 0x650a7354, 0x766a0abb, 0x81c2c92e, 0x92722c85, 0xa2bfe8a1, 0xa81a664b,
        0xc24b8b70, 0xc76c51a3, 0xd192e819, 0xd6990624, 0xf40e3585, 0x106aa070, 0x19a4c116,
        0x1e376c08, 0x2748774c, 0x34b0bcb5, 0x391c0cb3, 0x4ed8aa4a, 0x5b9cca4f, 0x682e6ff3,
        0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208, 0x90befffa, 0xa4506ceb, 0xbef9a3f7,
        0xc67178f2};
    uint32_t w[64], a, bb, c, d, e, f, g, hh;
    for (int i = 0; i < 16; i++)
        w[i] = (uint32_t)b[4 * i] << 24 | (uint32_t)b[4 * i + 1] << 16 |
               (uint32_t)b[4 * i + 2] << 8 | b[4 * i + 3];
    for (int i = 16; i < 64; i++) {
        uint32_t s0 = ROR(w[i - 15], 7) ^ ROR(w[i - 15], 18) ^ (w[i - 15] >> 3);
        uint32_t s1 = ROR(w[i - 2], 17) ^ ROR(w[i - 2], 19) ^ (w[i - 2] >> 10);
        w[i] = w[i - 16] + s0 + w[i - 7] + s1;
    }
    a = h[0], bb = h[1], c = h[2], d = h[3], e = h[4], f = h[5], g = h[6], hh = h[7];
    for (int i = 0; i < 64; i++) {
        uint32_t t1 = hh + (ROR(e, 6) ^ ROR(e, 11) ^ ROR(e, 25)) + ((e & f) ^ (~e & g)) + K[i] +
                      w[i];
        uint32_t t2 = (ROR(a, 2) ^ ROR(a, 13) ^ ROR(a, 22)) + ((a & bb) ^ (a & c) ^ (bb & c));
        hh = g, g = f, f = e, e = d + t1, d = c, c = bb, bb = a, a = t1 + t2;
    }
    h[0] += a, h[1] += bb, h[2] += c, h[3] += d, h[4] += e, h[5] += f, h[6] += g, h[7] += hh;
}

void dtx_sha256(const void *data, size_t n, unsigned char digest[32])
{
    uint32_t h[8] = {0x6a09e667, 0xbb67ae85, 0x3c6ef372, 0xa54ff53a,
                     0x510e527f, 0x9b05688c, 0x1f83d9ab, 0x5be0cd19};
    const unsigned char *p = data;
    unsigned char last[128];
    size_t full = n / 64 * 64, rest = n - full, tail;
    uint64_t bits = (uint64_t)n * 8;
    for (size_t i = 0; i < full; i += 64)
        sha256_block(h, p + i);
    memset(last, 0, sizeof last);
    if (rest)
        memcpy(last, p + full, rest);
    last[rest] = 0x80;
    tail = rest + 1 + 8 <= 64 ? 64 : 128;
    for (int i = 0; i < 8; i++)
        last[tail - 1 - i] = (unsigned char)(bits >> (8 * i));
    sha256_block(h, last);
    if (tail == 128)
        sha256_block(h, last + 64);
    for (int i = 0; i < 8; i++) {
        digest[4 * i] = (unsigned char)(h[i] >> 24);
        digest[4 * i + 1] = (unsigned char)(h[i] >> 16);
        digest[4 * i + 2] = (unsigned char)(h[i] >> 8);
        digest[4 * i + 3] = (unsigned char)h[i];
    }
}

/* ------------------------------------------------------ JSON in HTML */

/* Length of the valid UTF-8 sequence at s (1..4), or 0 when s does not
 * start one. */
static int utf8_len(const unsigned char *s)
{
    int n;
    uint32_t c;
    if (s[0] < 0x80)
        return 1;
    if ((s[0] & 0xe0) == 0xc0)
        n = 2, c = s[0] & 0x1f;
    else if ((s[0] & 0xf0) == 0xe0)
        n = 3, c = s[0] & 0x0f;
    else if ((s[0] & 0xf8) == 0xf0)
        n = 4, c = s[0] & 0x07;
    else
        return 0;
    for (int i = 1; i < n; i++) {
        if ((s[i] & 0xc0) != 0x80)
            return 0;
        c = c << 6 | (s[i] & 0x3f);
    }
    if ((n == 2 && c < 0x80) || (n == 3 && c < 0x800) || (n == 4 && c < 0x10000) ||
        c > 0x10ffff || (c >= 0xd800 && c <= 0xdfff))
        return 0;
    return n;
}

char *dtx_json_html_string(const char *s)
{
    const unsigned char *p = (const unsigned char *)(s ? s : "");
    size_t n = strlen((const char *)p), k = 0;
    /* Every byte becomes at most 6 characters ("\u00XX" or U+FFFD's
     * "\ufffd"). */
    char *out = malloc(6 * n + 3);
    if (!out)
        return NULL;
    out[k++] = '"';
    while (*p) {
        int len = utf8_len(p);
        unsigned char c = *p;
        if (len == 0) {
            k += (size_t)sprintf(out + k, "\\ufffd");
            p++;
        } else if (len > 1) {
            memcpy(out + k, p, (size_t)len);
            k += (size_t)len;
            p += len;
        } else {
            if (c == '"' || c == '\\') {
                out[k++] = '\\';
                out[k++] = (char)c;
            } else if (c < 0x20 || c == '<' || c == '>' || c == '&' || c == 0x7f)
                k += (size_t)sprintf(out + k, "\\u%04x", c);
            else
                out[k++] = (char)c;
            p++;
        }
    }
    out[k++] = '"';
    out[k] = 0;
    return out;
}

/* Writes s as a JSON string into f; -1 when out of memory. */
static int put_str(FILE *f, const char *s)
{
    char *j = dtx_json_html_string(s);
    if (!j)
        return -1;
    fputs(j, f);
    free(j);
    return 0;
}

/* A finite double as JSON, NaN and infinities as null. */
static void put_num(FILE *f, double v)
{
    if (isfinite(v))
        fprintf(f, "%.17g", v);
    else
        fputs("null", f);
}

/* ------------------------------------------------------------ blobs */

/* Writes one <script type="application/octet-stream" id="dtx-bN"> element
 * holding the base64 of n bytes; returns N, or -1 when out of memory. */
static int put_blob(FILE *f, int *nblobs, const void *data, size_t n)
{
    const size_t chunk = 3 * 65536;
    char *buf = malloc(4 * (chunk / 3) + 1);
    const unsigned char *p = data;
    if (!buf)
        return -1;
    fprintf(f, "<script type=\"application/octet-stream\" id=\"dtx-b%d\">", *nblobs);
    for (size_t i = 0; i < n; i += chunk) {
        size_t m = n - i < chunk ? n - i : chunk;
        fwrite(buf, 1, dtx_base64(p + i, m, buf), f);
    }
    fputs("</script>\n", f);
    free(buf);
    return (*nblobs)++;
}

/* ------------------------------------------------------------ checks */

static dtx_status check_page(const char *path, const dtx_view_page *pg, dtx_error *err)
{
    if (pg->npanes < 1 || pg->npanes > 16)
        return dtx_seterr(err, DTX_EINVAL, "%s: %d panes (1..16 allowed)", path, pg->npanes);
    if (pg->pick && pg->npanes != 2)
        return dtx_seterr(err, DTX_EINVAL, "%s: picking needs 2 panes, not %d", path,
                          pg->npanes);
    for (int i = 0; i < pg->npanes; i++) {
        const dtx_view_pane *p = &pg->panes[i];
        const dtx_mesh *m = p->mesh;
        size_t nc;
        if (!m || m->nv < 1 || m->nf < 1)
            return dtx_seterr(err, DTX_EINVAL, "%s: pane %d (%s) has no mesh", path, i,
                              p->title ? p->title : "?");
        if (p->nframes < 0 || (p->nframes > 0 && (!p->frames || !p->frame)))
            return dtx_seterr(err, DTX_EINVAL, "%s: pane %d (%s): frames missing", path, i,
                              p->title ? p->title : "?");
        nc = (size_t)m->nv * 3;
        for (size_t k = 0; k < nc; k++)
            if (!isfinite(m->V[k]))
                return dtx_seterr(err, DTX_ENONFINITE,
                                  "%s: pane %d (%s): rest vertex %zu is not finite", path, i,
                                  p->title ? p->title : "?", k / 3);
        for (int64_t t = 0; t < p->nframes; t++)
            for (size_t k = 0; k < nc; k++)
                if (!isfinite(p->frames[(size_t)t * nc + k]))
                    return dtx_seterr(err, DTX_ENONFINITE,
                                      "%s: pane %d (%s): frame %lld, vertex %zu is not finite",
                                      path, i, p->title ? p->title : "?",
                                      (long long)p->frame[t], k / 3);
        if (pg->markers && p->marker_side)
            for (int32_t j = 0; j < pg->markers->n; j++) {
                int32_t v = p->marker_side == 1 ? pg->markers->src[j] : pg->markers->tgt[j];
                if (v < 0 || v >= m->nv)
                    return dtx_seterr(err, DTX_ERANGE,
                                      "%s: marker %d: vertex %d is out of range of %s "
                                      "(%d vertices)",
                                      pg->markers_name ? pg->markers_name : "markers", j, v,
                                      p->title ? p->title : "?", m->nv);
            }
    }
    /* Key points are drawn on the source mesh when picking, else on every
     * sequence. */
    for (int i = 0; i < pg->npanes; i++) {
        const dtx_view_pane *p = &pg->panes[i];
        if (pg->pick ? i != 0 : !(p->kind && strcmp(p->kind, "sequence") == 0))
            continue;
        for (int32_t j = 0; j < pg->nkeypoints; j++)
            if (pg->keypoints[j] < 0 || pg->keypoints[j] >= p->mesh->nv)
                return dtx_seterr(err, DTX_ERANGE,
                                  "%s: key point %d: vertex %d is out of range of %s "
                                  "(%d vertices)",
                                  pg->keypoints_name ? pg->keypoints_name : "key points", j,
                                  pg->keypoints[j], p->title ? p->title : "?", p->mesh->nv);
    }
    return DTX_OK;
}

/* ------------------------------------------------------------ panes */

/* Writes the pane's blobs and then its JSON object into json (a memory
 * stream written after the blobs). */
static int put_pane(FILE *f, FILE *json, int *nblobs, const dtx_view_pane *p)
{
    const dtx_mesh *m = p->mesh;
    size_t nc = (size_t)m->nv * 3, nfc = (size_t)m->nf * 3;
    size_t big = (nc > nfc ? nc : nfc) * 4;
    unsigned char *b;
    int bf, br, bq = -1;
    double lo[3] = {0, 0, 0}, step[3] = {0, 0, 0};
    if (p->nframes > 0 && (size_t)p->nframes * nc * 2 > big)
        big = (size_t)p->nframes * nc * 2;
    if (!(b = malloc(big)))
        return -1;
    /* Little-endian: the page reads these with typed arrays, which use the
     * machine's order, and every browser's is little. */
    for (size_t k = 0; k < nfc; k++)
        dtx_put_le32(b + 4 * k, (uint32_t)m->F[k]);
    bf = put_blob(f, nblobs, b, nfc * 4);
    for (size_t k = 0; k < nc; k++)
        dtx_put_lef32(b + 4 * k, (float)m->V[k]);
    br = put_blob(f, nblobs, b, nc * 4);
    if (p->nframes > 0) {
        /* Quantise over the bounding box of the frames, per axis. */
        double hi[3];
        size_t total = (size_t)p->nframes * nc;
        for (int a = 0; a < 3; a++)
            lo[a] = hi[a] = p->frames[a];
        for (size_t k = 0; k < total; k++) {
            int a = (int)(k % 3);
            double x = p->frames[k];
            lo[a] = x < lo[a] ? x : lo[a];
            hi[a] = x > hi[a] ? x : hi[a];
        }
        for (int a = 0; a < 3; a++)
            step[a] = (hi[a] - lo[a]) / 65535.0;
        {
            /* 16-bit steps; each frame minus the one before (modulo 2^16);
             * low bytes, then high bytes; gzip.  Smooth motion leaves small
             * differences whose high bytes are mostly 0 or 255. */
            uint16_t *q = malloc(total * sizeof *q);
            unsigned char *z = NULL;
            uLongf zn = compressBound((uLong)(total * 2)) + 64;
            z_stream zs;
            if (q && (z = malloc(zn))) {
                for (size_t k = 0; k < total; k++) {
                    int a = (int)(k % 3);
                    double v = step[a] > 0 ? floor((p->frames[k] - lo[a]) / step[a] + 0.5) : 0;
                    q[k] = (uint16_t)(v < 0 ? 0 : v > 65535 ? 65535 : v);
                }
                for (size_t k = total; k-- > nc;)
                    q[k] = (uint16_t)(q[k] - q[k - nc]);
                for (size_t k = 0; k < total; k++) {
                    b[k] = (unsigned char)q[k];
                    b[total + k] = (unsigned char)(q[k] >> 8);
                }
                memset(&zs, 0, sizeof zs);
                /* windowBits 15 + 16: a gzip stream (DecompressionStream('gzip')). */
                if (deflateInit2(&zs, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) == Z_OK) {
                    zs.next_in = b;
                    zs.avail_in = (uInt)(total * 2);
                    zs.next_out = z;
                    zs.avail_out = (uInt)zn;
                    if (deflate(&zs, Z_FINISH) == Z_STREAM_END)
                        bq = put_blob(f, nblobs, z, zs.total_out);
                    deflateEnd(&zs);
                }
            }
            free(q);
            free(z);
        }
    }
    free(b);
    if (bf < 0 || br < 0 || (p->nframes > 0 && bq < 0))
        return -1;

    fputs("{\"title\":", json);
    if (put_str(json, p->title) || fputs(",\"kind\":", json) < 0 || put_str(json, p->kind) ||
        fputs(",\"info\":", json) < 0 || put_str(json, p->info) ||
        fputs(",\"group\":", json) < 0 || put_str(json, p->group))
        return -1;
    fprintf(json, ",\"nv\":%d,\"nf\":%d,\"faces\":\"dtx-b%d\",\"rest\":\"dtx-b%d\"", m->nv,
            m->nf, bf, br);
    fprintf(json, ",\"markerSide\":%d,\"nframes\":%lld", p->marker_side,
            (long long)p->nframes);
    if (p->nframes > 0) {
        fprintf(json, ",\"frames\":\"dtx-b%d\",\"lo\":[", bq);
        for (int a = 0; a < 3; a++) {
            put_num(json, lo[a]);
            fputs(a < 2 ? "," : "],\"step\":[", json);
        }
        for (int a = 0; a < 3; a++) {
            put_num(json, step[a]);
            fputs(a < 2 ? "," : "],\"frame\":[", json);
        }
        for (int64_t t = 0; t < p->nframes; t++)
            fprintf(json, "%s%lld", t ? "," : "", (long long)p->frame[t]);
        fputs("]", json);
        if (p->residual) {
            fputs(",\"residual\":[", json);
            for (int64_t t = 0; t < p->nframes; t++) {
                if (t)
                    fputc(',', json);
                put_num(json, p->residual[t]);
            }
            fputs("]", json);
        }
    }
    fputs("}", json);
    return 0;
}

/* ------------------------------------------------------------ script */

/* The one script: three.js with its export list made an object, then the
 * viewer.  malloc'ed into *out (*n bytes). */
static dtx_status make_script(const char *path, char **out, size_t *n, dtx_error *err)
{
#ifdef DTX_HAVE_THREE
    const char *t = (const char *)dtx_three_js, *ex = NULL, *end;
    size_t tl = dtx_three_js_len, k = 0;
    char *s;
    for (const char *p = t; (p = strstr(p, "export{")) != NULL; p++)
        ex = p;
    if (!ex || !(end = strchr(ex, '}')))
        return dtx_seterr(err, DTX_EINVAL,
                          "%s: the three.js compiled into dtx has no export list "
                          "(an ES module build such as three.module.min.js is needed)",
                          path);
    s = malloc(tl + (size_t)(end - ex) + dtx_view_app_js_len + 64);
    if (!s)
        return dtx_seterr(err, DTX_ENOMEM, "%s: out of memory", path);
    memcpy(s, t, (size_t)(ex - t));
    k = (size_t)(ex - t);
    k += (size_t)sprintf(s + k, "const THREE={");
    /* "a as B,c,..." -> "B:a,c:c,..." */
    for (const char *p = ex + 7; p < end;) {
        const char *c = memchr(p, ',', (size_t)(end - p)), *as;
        const char *ie = c ? c : end;
        size_t len = (size_t)(ie - p);
        as = NULL;
        for (const char *q = p; q + 4 <= ie; q++)
            if (memcmp(q, " as ", 4) == 0) {
                as = q;
                break;
            }
        if (as) {
            memcpy(s + k, as + 4, (size_t)(ie - as - 4));
            k += (size_t)(ie - as - 4);
            s[k++] = ':';
            memcpy(s + k, p, (size_t)(as - p));
            k += (size_t)(as - p);
        } else {
            memcpy(s + k, p, len);
            k += len;
            s[k++] = ':';
            memcpy(s + k, p, len);
            k += len;
        }
        s[k++] = c ? ',' : '}';
        p = ie + 1;
    }
    memcpy(s + k, end + 1, tl - (size_t)(end + 1 - t));
    k += tl - (size_t)(end + 1 - t);
    s[k++] = '\n';
    memcpy(s + k, dtx_view_app_js, dtx_view_app_js_len);
    k += dtx_view_app_js_len;
    *out = s;
    *n = k;
    return DTX_OK;
#else
    (void)out;
    (void)n;
    /* The status is returned as a constant so that the compiler sees that
     * the caller never goes on to write a NULL script (-Wnonnull). */
    dtx_seterr(err, DTX_EINVAL,
               "%s: this dtx was built without three.js, which `dtx view` needs: run "
               "scripts/setup.sh (it installs three into build-tools/), then rebuild",
               path);
    return DTX_EINVAL;
#endif
}

/* ------------------------------------------------------------ page */

/* 1 when needle occurs in the n bytes at s (case-insensitively for
 * letters, as the HTML parser reads an end tag). */
static int contains(const char *s, size_t n, const char *needle)
{
    size_t m = strlen(needle);
    for (size_t i = 0; i + m <= n; i++) {
        size_t j = 0;
        while (j < m && (s[i + j] | 0x20) == (needle[j] | 0x20))
            j++;
        if (j == m)
            return 1;
    }
    return 0;
}

dtx_status dtx_view_write(const char *path, const dtx_view_page *pg, dtx_error *err)
{
    dtx_atomic_file af;
    dtx_status st;
    char *script = NULL, *json = NULL, hash[48];
    size_t script_n = 0, json_n = 0;
    unsigned char digest[32];
    FILE *jf = NULL, *f;
    int nblobs = 0, bad = 0;

    if ((st = check_page(path, pg, err)) != DTX_OK)
        return st;
    if ((st = make_script(path, &script, &script_n, err)) != DTX_OK)
        return st;
    if (contains(script, script_n, "</script") || contains(script, script_n, "<!--")) {
        free(script);
        return dtx_seterr(err, DTX_EINVAL, "%s: the page's script contains '</script' or '<!--'",
                          path);
    }
    dtx_sha256(script, script_n, digest);
    dtx_base64(digest, 32, hash);
    if ((st = dtx_atomic_open(&af, path, err)) != DTX_OK) {
        free(script);
        return st;
    }
    f = af.fp;
    if (!(jf = open_memstream(&json, &json_n))) {
        bad = 1;
        goto done;
    }
    fputs("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n", f);
    fprintf(f,
            "<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; "
            "script-src 'sha256-%s'; style-src 'unsafe-inline'; img-src data: blob:; "
            "connect-src 'none'; base-uri 'none'; form-action 'none'\">\n",
            hash);
    fputs("<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
          "<title>dtx view</title>\n<style>\n",
          f);
    fwrite(dtx_view_css, 1, dtx_view_css_len, f);
    fputs("</style>\n</head>\n<body>\n<div id=\"dtx-app\"></div>\n", f);

    /* The data: blobs first, then the JSON that names them. */
    fprintf(jf, "{\"mode\":\"%s\",\"file\":", pg->pick ? "pick" : "player");
    bad |= put_str(jf, pg->file);
    fprintf(jf, ",\"fileFrames\":%lld,\"stride\":%lld,\"maxFrames\":%lld,\"panes\":[",
            (long long)pg->file_frames, (long long)pg->stride, (long long)pg->max_frames);
    for (int i = 0; i < pg->npanes && !bad; i++) {
        if (i)
            fputc(',', jf);
        bad |= put_pane(f, jf, &nblobs, &pg->panes[i]);
    }
    fputs("]", jf);
    if (pg->markers && !bad) {
        const dtx_markers *mk = pg->markers;
        fputs(",\"markers\":{\"name\":", jf);
        bad |= put_str(jf, pg->markers_name);
        fputs(",\"src\":[", jf);
        for (int32_t j = 0; j < mk->n; j++)
            fprintf(jf, "%s%d", j ? "," : "", mk->src[j]);
        fputs("],\"tgt\":[", jf);
        for (int32_t j = 0; j < mk->n; j++)
            fprintf(jf, "%s%d", j ? "," : "", mk->tgt[j]);
        fputs("],\"label\":[", jf);
        for (int32_t j = 0; j < mk->n && !bad; j++) {
            if (j)
                fputc(',', jf);
            bad |= put_str(jf, mk->labels ? mk->labels[j] : "");
        }
        fputs("]}", jf);
    }
    if (pg->nkeypoints > 0 && !bad) {
        fputs(",\"keypoints\":{\"name\":", jf);
        bad |= put_str(jf, pg->keypoints_name);
        fputs(",\"vertex\":[", jf);
        for (int32_t j = 0; j < pg->nkeypoints; j++)
            fprintf(jf, "%s%d", j ? "," : "", pg->keypoints[j]);
        fputs("],\"label\":[", jf);
        for (int32_t j = 0; j < pg->nkeypoints && !bad; j++) {
            if (j)
                fputc(',', jf);
            bad |= put_str(jf, pg->keypoint_labels ? pg->keypoint_labels[j] : "");
        }
        fputs("]}", jf);
    }
    if (pg->report && !bad) {
        fputs(",\"report\":", jf);
        bad |= put_str(jf, pg->report);
    }
    fputs("}", jf);
    if (fclose(jf) != 0)
        bad = 1;
    jf = NULL;
    if (bad)
        goto done;
    fputs("<script type=\"application/json\" id=\"dtx-data\">", f);
    fwrite(json, 1, json_n, f);
    fputs("</script>\n<script type=\"module\">", f);
    fwrite(script, 1, script_n, f);
    fputs("</script>\n</body>\n</html>\n", f);

done:
    if (jf)
        fclose(jf);
    free(json);
    free(script);
    if (bad) {
        dtx_atomic_abort(&af);
        return dtx_seterr(err, DTX_ENOMEM, "%s: out of memory writing the page", path);
    }
    return dtx_atomic_commit(&af, err);
}
