/*
 * graph.h: union-find over int32 indices and the connected components of a
 * triangle mesh's vertices (internal to the core library).
 *
 * One rule everywhere: the root of a class is its lowest index (a union
 * hangs the higher root under the lower one).  Roots, and the numbering
 * derived from them, therefore depend only on the classes, never on the
 * order of the unions or on how far a path has been halved.  Classes are
 * numbered 0.. in order of their lowest index.  The weld map (weld.c), the
 * mesh checks (mesh.c), the proximity graph and its spanning tree
 * (proximity.c) and the biharmonic weights' components (biharmonic.c) all
 * rely on that numbering, so their results do not change with the order in
 * which edges are visited.
 *
 * Pure functions on caller-owned arrays, no state of their own: thread-safe
 * on distinct arrays.
 */
#ifndef DTX_GRAPH_H
#define DTX_GRAPH_H

#include <stdint.h>

/* parent: n int32 (output, caller-allocated): every index its own class. */
void dtx__uf_init(int32_t *parent, int32_t n);

/* The root (lowest index) of i's class.  Halves the path on the way, so
 * parent is written although the classes do not change. */
int32_t dtx__uf_find(int32_t *parent, int32_t i);

/* Joins the classes of a and b, the higher root under the lower.  Returns 1
 * when two classes were joined, 0 when a and b were already in one. */
int dtx__uf_union(int32_t *parent, int32_t a, int32_t b);

/* Numbers the classes of parent (n int32, in/out: paths are halved) 0.. in
 * order of their lowest index.
 *   label: n int32, in/out.  On entry a negative value leaves an index out
 *          (it gets -1), any other value makes it a member; on return a
 *          member's label is its class number.  An index united with any
 *          other must be a member (the class's root is looked up).
 *   lowest: NULL, or n int32 (output, caller-allocated; only the first
 *          count are set): lowest[c] is the lowest index of class c, so it
 *          is increasing.
 * Returns the number of classes with a member (count). */
int32_t dtx__uf_label(int32_t *parent, int32_t n, int32_t *label, int32_t *lowest);

/* What dtx__tri_components gives a vertex that is in no triangle. */
typedef enum {
    DTX__ISOLATED_UNLABELLED, /* -1, and no component */
    DTX__ISOLATED_OWN         /* a component of its own */
} dtx__isolated;

/* Connected components over shared vertices of the triangles F (nf x 3,
 * row-major int32, every index in [0, nv)).  comp: nv int32 (output,
 * caller-allocated), the component of each vertex, numbered 0.. in order
 * of the component's lowest vertex; a vertex in no triangle gets what
 * isolated says.  Returns the number of components, or -1 when the nv
 * int32 of scratch cannot be allocated (comp is then untouched). */
int32_t dtx__tri_components(const int32_t *F, int32_t nf, int32_t nv, dtx__isolated isolated,
                            int32_t *comp);

#endif /* DTX_GRAPH_H */
