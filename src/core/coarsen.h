/*
 * coarsen.h: one level of coarsening of a spring network, for the multigrid
 * start of the springs method (springs.c).  Internal to the core.
 *
 * Vertex clustering on the graph of the edge springs:
 *   - seeds: the vertices are visited in index order; a vertex that is not
 *     within two edge hops of an earlier seed becomes a seed (a maximal set
 *     of seeds at least three hops apart, so every vertex is within two hops
 *     of one);
 *   - clusters: a breadth-first search from all seeds at once (seeds in
 *     order, first come first served) gives every vertex to its nearest seed
 *     in hops, ties to the seed that reached it first;
 *   - the coarse vertices are the clusters, each represented by its seed.
 * Coarse springs:
 *   - edge springs between clusters joined by an edge spring;
 *   - bending springs between clusters two coarse edge hops apart (that
 *     share an edge neighbour and are not joined themselves), the coarse
 *     counterpart of the fine bending springs, which mostly fall inside one
 *     cluster or between neighbours;
 *   - internal springs between the clusters of the two ends of an internal
 *     spring (when different).
 * Pairs found twice are kept once, with the lower kind (dtx_spring_kind).
 * On triangle meshes a level has about 1/6 to 1/10 of the vertices of the one
 * below.  Deterministic; serial.
 */
#ifndef DTX_COARSEN_H
#define DTX_COARSEN_H

#include "springs.h"

#include <stdint.h>

typedef struct {
    int32_t n;              /* coarse vertices (clusters) */
    int32_t *rep;           /* n: the fine vertex that represents each (its seed), increasing */
    int32_t *cluster;       /* nfine: the cluster of each fine vertex, -1 for a vertex
                               without edge springs (in no cluster) */
    dtx_spring_set springs; /* the coarse springs, over coarse vertex indices */
} dtx_coarse_level;

/* Coarsens the network of nfine vertices and springs (fine->ends, kind, as
 * from dtx_springs_build or a previous call).  Fills *out (free with
 * dtx_coarse_level_free); returns DTX_ENOMEM (out empty) on failure. */
dtx_status dtx_coarsen(int32_t nfine, const dtx_spring_set *fine, dtx_coarse_level *out,
                       dtx_error *err);
void dtx_coarse_level_free(dtx_coarse_level *c);

/* Sorts the n pairs (ends: n x 2 with i < j, kind: n) by (i, j, kind) and
 * keeps the first of each pair; returns the new count and fills count[]
 * (shared by dtx_springs_build and dtx_coarsen). */
int32_t dtx__springs_sort_unique(int32_t *ends, unsigned char *kind, int32_t n,
                                 int32_t count[DTX_SPRING_KINDS]);

/* Symmetric adjacency (CSR: *adjp n + 1 offsets, *adj the neighbours, each
 * list sorted; both allocated, free with free()) of the springs of kind
 * `want` among n vertices.  Returns 0 on allocation failure (nothing
 * allocated). */
int dtx__spring_adjacency(int32_t n, const int32_t *ends, const unsigned char *kind, int32_t ns,
                          int want, int32_t **adjp, int32_t **adj);

#endif /* DTX_COARSEN_H */
