/* markers.c: allocation and validation of marker sets. */
#include "markers.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

dtx_status dtx_markers_alloc(dtx_markers *m, int32_t n, dtx_error *err)
{
    memset(m, 0, sizeof *m);
    if (n < 0)
        return dtx_seterr(err, DTX_EINVAL, "negative marker count %d", (int)n);
    m->src = dtx_alloc((size_t)n, sizeof *m->src, 1);
    m->tgt = dtx_alloc((size_t)n, sizeof *m->tgt, 1);
    m->labels = dtx_alloc((size_t)n, sizeof *m->labels, 1);
    if (!m->src || !m->tgt || !m->labels) {
        dtx_markers_free(m);
        return dtx_seterr(err, DTX_ENOMEM, "cannot allocate %d markers", (int)n);
    }
    m->n = n;
    return DTX_OK;
}

void dtx_markers_free(dtx_markers *m)
{
    if (!m)
        return;
    if (m->labels)
        for (int32_t i = 0; i < m->n; i++)
            free(m->labels[i]);
    free(m->labels);
    free(m->src);
    free(m->tgt);
    memset(m, 0, sizeof *m);
}

static int cmp_i64(const void *a, const void *b)
{
    int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
    return (x > y) - (x < y);
}

/* Finds a vertex used by two markers in idx[0..n) (every idx[i] >= 0):
 * returns 1 with the vertex and the two marker numbers (first < second;
 * the lowest such vertex), 0 when every vertex is used once, -1 when out of
 * memory.  O(n log n). */
static int find_repeat(const int32_t *idx, int32_t n, int32_t *vertex, int32_t *first,
                       int32_t *second)
{
    /* Keys vertex * 2^32 + marker sort by vertex, then by marker. */
    int64_t *s = dtx_alloc((size_t)n, sizeof *s, 0);
    int found = 0;
    if (!s)
        return -1;
    for (int32_t i = 0; i < n; i++)
        s[i] = (int64_t)idx[i] * ((int64_t)1 << 32) + i;
    qsort(s, (size_t)n, sizeof *s, cmp_i64);
    for (int32_t i = 1; i < n && !found; i++)
        if (s[i] >> 32 == s[i - 1] >> 32) {
            *vertex = (int32_t)(s[i] >> 32);
            *first = (int32_t)(s[i - 1] & 0xffffffff);
            *second = (int32_t)(s[i] & 0xffffffff);
            found = 1;
        }
    free(s);
    return found;
}

/* " (\"label\")" for marker i when it has a label, else "". */
static const char *label_of(const dtx_markers *m, int32_t i, char *buf, size_t n)
{
    if (!m->labels || !m->labels[i] || !m->labels[i][0])
        return "";
    snprintf(buf, n, " (\"%.100s\")", m->labels[i]);
    return buf;
}

static dtx_status check_repeats(const dtx_markers *m, const int32_t *idx, const char *side,
                                const char *what, dtx_error *err)
{
    int32_t v = 0, a = 0, b = 0;
    char la[120], lb[120];
    int r = find_repeat(idx, m->n, &v, &a, &b);
    if (r < 0)
        return dtx_seterr(err, DTX_ENOMEM, "%s: out of memory", what);
    if (r > 0)
        return dtx_seterr(err, DTX_EINVAL,
                          "%s: %s vertex %d is used by two markers, %d%s and %d%s (0-based "
                          "marker numbers): a vertex may have one marker",
                          what, side, (int)v, (int)a, label_of(m, a, la, sizeof la), (int)b,
                          label_of(m, b, lb, sizeof lb));
    return DTX_OK;
}

dtx_status dtx_markers_validate(const dtx_markers *m, int32_t src_nv, int32_t tgt_nv,
                                const char *what, dtx_error *err)
{
    dtx_status st;
    char lb[120];
    if (m->n < 1)
        return dtx_seterr(err, DTX_EINVAL, "%s: no markers", what);
    for (int32_t i = 0; i < m->n; i++) {
        if (m->src[i] < 0 || m->src[i] >= src_nv)
            return dtx_seterr(err, DTX_ERANGE,
                              "%s: marker %d%s: source vertex %d out of range [0, %d) "
                              "(0-based; is the index base right?)",
                              what, (int)i, label_of(m, i, lb, sizeof lb), (int)m->src[i],
                              (int)src_nv);
        if (m->tgt[i] < 0 || m->tgt[i] >= tgt_nv)
            return dtx_seterr(err, DTX_ERANGE,
                              "%s: marker %d%s: target vertex %d out of range [0, %d) "
                              "(0-based; is the index base right?)",
                              what, (int)i, label_of(m, i, lb, sizeof lb), (int)m->tgt[i],
                              (int)tgt_nv);
    }
    if ((st = check_repeats(m, m->src, "source", what, err)) != DTX_OK)
        return st;
    return check_repeats(m, m->tgt, "target", what, err);
}

/* 1 for every vertex of m that is in a face (caller frees), NULL when out
 * of memory. */
static unsigned char *used_vertices(const dtx_mesh *m)
{
    unsigned char *used = dtx_alloc((size_t)m->nv, 1, 1);
    if (used)
        for (int64_t i = 0; i < 3 * (int64_t)m->nf; i++)
            used[m->F[i]] = 1;
    return used;
}

dtx_status dtx_markers_check_referenced(const dtx_markers *m, const dtx_mesh *src, const char *what,
                                        dtx_error *err)
{
    unsigned char *used = used_vertices(src);
    dtx_status st = DTX_OK;
    char lb[120];
    if (!used)
        return dtx_seterr(err, DTX_ENOMEM, "%s: out of memory", what);
    for (int32_t i = 0; i < m->n; i++)
        if (!used[m->src[i]]) {
            st = dtx_seterr(err, DTX_EINVAL,
                            "%s: marker %d%s: source vertex %d is in no triangle of the source "
                            "mesh, so the marker constrains nothing (is the index base right? "
                            "is it the right mesh?)",
                            what, (int)i, label_of(m, i, lb, sizeof lb), (int)m->src[i]);
            break;
        }
    free(used);
    return st;
}
