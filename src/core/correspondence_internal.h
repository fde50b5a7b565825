/*
 * correspondence_internal.h: what the two correspondence algorithms share
 * (correspondence.c, Sumner & Popovic; correspondence_mc.c, Zhou et al.).
 * Not part of the public API.
 */
#ifndef DTX_CORRESPONDENCE_INTERNAL_H
#define DTX_CORRESPONDENCE_INTERNAL_H

#include "dtx_core.h"

/* A tetrahedron over four unknowns (vertex v, or nv + f for the fourth
 * vertex of triangle f) whose transformation is T = [x1-x0, x2-x0, x3-x0]
 * inv, inv the inverse of the same matrix at rest (row-major). */
typedef struct {
    int32_t var[4];
    double inv[9];
} dtx__tet;

/* Makes E_R's tetrahedron pairs for dtx__deform_mesh: *tets (2 per pair,
 * owned by the maker's caller, alive until dtx__deform_mesh returns) and
 * *ntetpairs.  Called on a thread of its own while dtx__deform_mesh sets
 * up E_S and E_I, so it must not touch what those read (parallel regions
 * inside it get one thread there). */
typedef dtx_status (*dtx__tet_maker)(void *ctx, const dtx__tet **tets, int64_t *ntetpairs,
                                     dtx_error *err);

/* The argument checks both correspondences start with: n_closest in
 * [0, 16] (DTX_EINVAL) and dtx_markers_validate against the two meshes. */
dtx_status dtx__corr_check(const dtx_mesh *src, const dtx_mesh *tgt,
                           const dtx_markers *markers, const dtx_corr_params *prm,
                           dtx_error *err);

/* RMS distance of the n points X (n x 3) to the surface in bvh, over the
 * points with comp[v] >= 0 (all of them for comp NULL; 0 when none);
 * per-point distances in parallel, summed in order, so the same for any
 * thread count.  -1 when out of memory. */
double dtx__fit_rms(const dtx_bvh *bvh, const double *X, int32_t n, const int32_t *comp);

/* dtx__fit_rms with each point's search started from hint[v] (n, a
 * primitive of bvh near X[v], or -1): the same figure, bit for bit, found
 * sooner. */
double dtx__fit_rms_from(const dtx_bvh *bvh, const double *X, int32_t n, const int32_t *comp,
                         const int32_t *hint);

/* Puts the source S0 (nv_s x 3, caller-allocated) and the target Tn (nv_t x
 * 3) into one frame: the source aligned on the markers by a similarity
 * transform when align != 0 and there are at least 3 markers, then both
 * mapped so that the target's bounding box is centred at the origin with a
 * unit diagonal (center and diag returned, to map back). */
dtx_status dtx__corr_normalise(const dtx_mesh *src, const dtx_mesh *tgt,
                               const dtx_markers *markers, int align, double *S0, double *Tn,
                               double center[3], double *diag, dtx_error *err);

/* The closest valid point to p (a source vertex with unit normal n) on the
 * primitives of tbvh (triangles: anywhere on them, or points), nearer than
 * max_dist: with normal_rule, only on primitives whose normal (tnormals, 3
 * per primitive) makes n . normal > cosmax (the paper's rule with cosmax =
 * cos 90 degrees = 0: normals within 90 degrees); the nearest of those,
 * however near a rejected one is.  hint: a primitive to start from (-1 for
 * none; the answer does not depend on it).  Returns the primitive (-1 if
 * none; ties to the lower index) and its point in cp.  Thread-safe. */
int32_t dtx__closest_valid(const dtx_bvh *tbvh, const double *tnormals, const double p[3],
                           const double n[3], double cosmax, double max_dist, int normal_rule,
                           int32_t hint, double cp[3]);

/* Deforms the mesh (F, nv, nf) with rest positions S0 toward the surface in
 * tbvh (triangles, with face normals tnormals): minimises w_S E_S + w_I E_I
 * + w_C E_C over the vertices and one fourth vertex per triangle, the nfix
 * vertices fixv held at fixpos (nfix x 3), plus for each of the ntetpairs
 * pairs (tets[2k], tets[2k+1]) that make_tets(tets_ctx, ...) makes the
 * terms w_S |Ta - Tb|^2 + w_I |Ta - I|^2 + w_I |Tb - I|^2 (Zhou et al.'s
 * E_R; make_tets NULL for none; its failure is returned as it is).  Phases
 * as in the file comment of correspondence.c.  X (nv x 3, in: the start, normally
 * S0; out: the result); valid_out (nv, may be NULL): 1 for the vertices
 * that had a valid closest point in the last phase; closest_out (nv, may be
 * NULL): each vertex's last closest valid primitive of tbvh (-1: none in
 * any phase), a search hint for dtx__fit_rms_from; *solves counts the
 * solves and *factorizations the numeric factorisations (a phase whose
 * matrix equals the factored one reuses its factor; one that differs from
 * it by at most 200 diagonal entries, vertices that gained or lost their
 * closest point at the same weight, is solved from it by a low-rank
 * correction, see correspondence.c). */
dtx_status dtx__deform_mesh(const int32_t *F, int32_t nv, int32_t nf, const double *S0,
                            const int32_t *fixv, const double *fixpos, int32_t nfix,
                            dtx__tet_maker make_tets, void *tets_ctx, const dtx_bvh *tbvh,
                            const double *tnormals, const dtx_corr_params *prm, double *X,
                            unsigned char *valid_out, int32_t *closest_out, int *solves,
                            int *factorizations, dtx_error *err);

#endif /* DTX_CORRESPONDENCE_INTERNAL_H */
