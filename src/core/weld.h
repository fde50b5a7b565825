/*
 * weld.h: welding vertices that an asset split along UV or normal seams.
 *
 * A DCC export duplicates a vertex wherever its UV or normal differs on the
 * faces around it, so the mesh falls apart along those seams (into pieces
 * where a whole seam loop is cut, or with slits that tear open under a
 * transfer).  The solvers need one vertex per position; the user needs the
 * results in the asset's own vertex order and count.  The weld map connects
 * both: map[i] is the welded vertex of asset vertex i.
 *
 * Pure functions on flat arrays: no allocation beyond what is documented, no
 * I/O.  Thread-safe (no shared state).
 */
#ifndef DTX_WELD_H
#define DTX_WELD_H

#include "status.h"

#include <stdint.h>

/* The weld map of nv vertices V (nv x 3 row-major doubles).
 *
 * Two vertices are twins when their Euclidean distance is <= tol (tol 0:
 * bit-identical coordinates, -0 and +0 equal); twins of twins are twins
 * (the classes are the connected components of "within tol").  Outputs,
 * caller-allocated:
 *   map: nv int32, the welded index of each vertex, in [0, *nw);
 *   rep: nv int32 (only the first *nw are set), rep[w] is the lowest
 *        original index in class w.
 * Order is stable: welded vertices are numbered in the order of their
 * lowest original index, so rep is increasing, rep[w] >= w and
 * map[i] <= i; a mesh with no twins gets the identity.
 * Non-finite coordinates are never twins.  tol must be >= 0 and finite
 * (DTX_EINVAL otherwise); DTX_ENOMEM when the scratch (2 nv int32 and nv
 * int32 more) cannot be allocated. */
dtx_status dtx_weld_map(const double *V, int32_t nv, double tol, int32_t *map, int32_t *rep,
                        int32_t *nw, dtx_error *err);

/* The welded mesh: Vw (nw x 3) = V[rep[w]], Fw (nf x 3) = map[F].  Both
 * caller-allocated; F indices must be in [0, nv). */
void dtx_weld_apply(const double *V, const int32_t *F, int32_t nf, const int32_t *map,
                    const int32_t *rep, int32_t nw, double *Vw, int32_t *Fw);

/* Compacts n frames in place from nv to nw vertices per frame: frame f's
 * vertex w becomes frame f's vertex rep[w] (X: n x nv x 3 on entry, its
 * first n x nw x 3 on return).  Safe in place because rep[w] >= w. */
void dtx_weld_compact_frames(double *X, int64_t n, int32_t nv, const int32_t *rep, int32_t nw);

/* Expands n frames in place from nw to nv vertices per frame: vertex i of
 * frame f becomes welded vertex map[i] of frame f, so twins are identical
 * (X holds n x nw x 3 on entry and must have room for n x nv x 3).  Safe in
 * place (working backwards) because map[i] <= i. */
void dtx_weld_expand_frames(double *X, int64_t n, int32_t nw, const int32_t *map, int32_t nv);

#endif /* DTX_WELD_H */
