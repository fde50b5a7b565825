/* weld.c: the weld map of seam-split vertices (weld.h). */
#include "weld.h"

#include "graph.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Sort context: qsort has none, so vertices are sorted by an index array
 * compared through a file-static pointer... which would not be reentrant.
 * Instead the keys are copied next to the index: (x, i) pairs. */
typedef struct {
    double x;
    int32_t i;
} xkey;

static int cmp_xkey(const void *a, const void *b)
{
    const xkey *p = a, *q = b;
    if (p->x < q->x)
        return -1;
    if (p->x > q->x)
        return 1;
    return (p->i > q->i) - (p->i < q->i);
}

static int twins(const double *p, const double *q, double tol)
{
    if (tol == 0)
        return p[0] == q[0] && p[1] == q[1] && p[2] == q[2];
    {
        double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
        return dx * dx + dy * dy + dz * dz <= tol * tol; /* NaN: false */
    }
}

dtx_status dtx_weld_map(const double *V, int32_t nv, double tol, int32_t *map, int32_t *rep,
                        int32_t *nw, dtx_error *err)
{
    xkey *keys = NULL;
    int32_t *parent = NULL, n = 0, m = 0;
    *nw = 0;
    if (nv < 0 || (nv > 0 && (!V || !map || !rep)))
        return dtx_seterr(err, DTX_EINVAL, "weld: bad arguments (nv %d)", (int)nv);
    if (!(tol >= 0) || !isfinite(tol))
        return dtx_seterr(err, DTX_EINVAL, "weld: the tolerance %g must be finite and >= 0",
                          tol);
    keys = malloc((size_t)(nv > 0 ? nv : 1) * sizeof *keys);
    parent = malloc((size_t)(nv > 0 ? nv : 1) * sizeof *parent);
    if (!keys || !parent) {
        free(keys);
        free(parent);
        return dtx_seterr(err, DTX_ENOMEM, "weld: cannot allocate scratch for %d vertices",
                          (int)nv);
    }
    /* Sweep along x: only vertices within tol in x can be twins.  Vertices
     * with a non-finite coordinate take no part. */
    dtx__uf_init(parent, nv);
    for (int32_t i = 0; i < nv; i++) {
        map[i] = 0; /* every vertex is in a class, if only its own */
        if (isfinite(V[3 * (size_t)i]) && isfinite(V[3 * (size_t)i + 1]) &&
            isfinite(V[3 * (size_t)i + 2])) {
            keys[n].x = V[3 * (size_t)i];
            keys[n].i = i;
            n++;
        }
    }
    qsort(keys, (size_t)n, sizeof *keys, cmp_xkey);
    for (int32_t a = 0; a < n; a++)
        for (int32_t b = a + 1; b < n && keys[b].x - keys[a].x <= tol; b++)
            if (twins(V + 3 * (size_t)keys[a].i, V + 3 * (size_t)keys[b].i, tol))
                dtx__uf_union(parent, keys[a].i, keys[b].i);
    /* Number the classes in order of their lowest index; rep[w] is that
     * index. */
    m = dtx__uf_label(parent, nv, map, rep);
    free(keys);
    free(parent);
    *nw = m;
    return DTX_OK;
}

void dtx_weld_apply(const double *V, const int32_t *F, int32_t nf, const int32_t *map,
                    const int32_t *rep, int32_t nw, double *Vw, int32_t *Fw)
{
    for (int32_t w = 0; w < nw; w++)
        memcpy(Vw + 3 * (size_t)w, V + 3 * (size_t)rep[w], 3 * sizeof *Vw);
    for (size_t k = 0; k < 3 * (size_t)nf; k++)
        Fw[k] = map[F[k]];
}

void dtx_weld_compact_frames(double *X, int64_t n, int32_t nv, const int32_t *rep, int32_t nw)
{
    for (int64_t f = 0; f < n; f++)
        for (int32_t w = 0; w < nw; w++)
            memmove(X + 3 * ((size_t)f * (size_t)nw + (size_t)w),
                    X + 3 * ((size_t)f * (size_t)nv + (size_t)rep[w]), 3 * sizeof *X);
}

void dtx_weld_expand_frames(double *X, int64_t n, int32_t nw, const int32_t *map, int32_t nv)
{
    for (int64_t f = n - 1; f >= 0; f--)
        for (int32_t i = nv - 1; i >= 0; i--)
            memmove(X + 3 * ((size_t)f * (size_t)nv + (size_t)i),
                    X + 3 * ((size_t)f * (size_t)nw + (size_t)map[i]), 3 * sizeof *X);
}
