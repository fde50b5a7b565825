/* markers.c: allocation and validation of marker sets. */
#include "markers.h"

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

static int cmp_i32(const void *a, const void *b)
{
    int32_t x = *(const int32_t *)a, y = *(const int32_t *)b;
    return (x > y) - (x < y);
}

/* Finds a repeated value in idx[0..n); returns its position in the sorted
 * copy's value or -1.  Uses a sorted copy so it is O(n log n). */
static int32_t find_repeat(const int32_t *idx, int32_t n, int32_t *value)
{
    int32_t *s = dtx_alloc((size_t)n, sizeof *s, 0);
    int32_t found = -1;
    if (!s)
        return -2;
    memcpy(s, idx, (size_t)n * sizeof *s);
    qsort(s, (size_t)n, sizeof *s, cmp_i32);
    for (int32_t i = 1; i < n; i++)
        if (s[i] == s[i - 1]) {
            *value = s[i];
            found = i;
            break;
        }
    free(s);
    return found;
}

dtx_status dtx_markers_validate(const dtx_markers *m, int32_t src_nv, int32_t tgt_nv,
                                const char *what, dtx_error *err)
{
    int32_t v = 0, r;
    if (m->n < 1)
        return dtx_seterr(err, DTX_EINVAL, "%s: no markers", what);
    for (int32_t i = 0; i < m->n; i++) {
        if (m->src[i] < 0 || m->src[i] >= src_nv)
            return dtx_seterr(err, DTX_ERANGE,
                              "%s: marker %d: source vertex %d out of range [0, %d) "
                              "(0-based; is the index base right?)",
                              what, (int)i, (int)m->src[i], (int)src_nv);
        if (m->tgt[i] < 0 || m->tgt[i] >= tgt_nv)
            return dtx_seterr(err, DTX_ERANGE,
                              "%s: marker %d: target vertex %d out of range [0, %d) "
                              "(0-based; is the index base right?)",
                              what, (int)i, (int)m->tgt[i], (int)tgt_nv);
    }
    r = find_repeat(m->src, m->n, &v);
    if (r == -2)
        return dtx_seterr(err, DTX_ENOMEM, "%s: out of memory", what);
    if (r >= 0)
        return dtx_seterr(err, DTX_EINVAL, "%s: source vertex %d is used by two markers", what,
                          (int)v);
    r = find_repeat(m->tgt, m->n, &v);
    if (r == -2)
        return dtx_seterr(err, DTX_ENOMEM, "%s: out of memory", what);
    if (r >= 0)
        return dtx_seterr(err, DTX_EINVAL, "%s: target vertex %d is used by two markers", what,
                          (int)v);
    return DTX_OK;
}
