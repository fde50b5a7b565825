/* graph.c: union-find and the components of a triangle mesh (graph.h). */
#include "graph.h"

#include "status.h"

#include <assert.h>
#include <stdlib.h>

void dtx__uf_init(int32_t *parent, int32_t n)
{
    for (int32_t i = 0; i < n; i++)
        parent[i] = i;
}

int32_t dtx__uf_find(int32_t *parent, int32_t i)
{
    while (parent[i] != i) {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    return i;
}

int dtx__uf_union(int32_t *parent, int32_t a, int32_t b)
{
    a = dtx__uf_find(parent, a);
    b = dtx__uf_find(parent, b);
    if (a == b)
        return 0;
    if (a < b)
        parent[b] = a;
    else
        parent[a] = b;
    return 1;
}

int32_t dtx__uf_label(int32_t *parent, int32_t n, int32_t *label, int32_t *lowest)
{
    int32_t count = 0;
    /* A class's root is its lowest index, so going up from 0 meets the root
     * first: it opens the next number and the rest of the class copies it. */
    for (int32_t i = 0; i < n; i++) {
        int32_t r;
        if (label[i] < 0) {
            label[i] = -1;
            continue;
        }
        r = dtx__uf_find(parent, i);
        if (r == i) {
            if (lowest)
                lowest[count] = i;
            label[i] = count++;
        } else {
            assert(label[r] >= 0 && "a member united with a non-member");
            label[i] = label[r]; /* r < i: already numbered */
        }
    }
    return count;
}

int32_t dtx__tri_components(const int32_t *F, int32_t nf, int32_t nv, dtx__isolated isolated,
                            int32_t *comp)
{
    int32_t *parent = dtx_alloc((size_t)nv, sizeof *parent, 0), n;
    if (!parent)
        return -1;
    dtx__uf_init(parent, nv);
    for (int32_t v = 0; v < nv; v++)
        comp[v] = isolated == DTX__ISOLATED_OWN ? 0 : -1;
    for (int32_t f = 0; f < nf; f++) {
        const int32_t *t = F + 3 * (size_t)f;
        for (int k = 0; k < 3; k++) {
            dtx__uf_union(parent, t[k], t[(k + 1) % 3]);
            comp[t[k]] = 0; /* in a triangle: a member */
        }
    }
    n = dtx__uf_label(parent, nv, comp, NULL);
    free(parent);
    return n;
}
