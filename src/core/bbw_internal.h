/*
 * bbw_internal.h: what bbw.c, bbw_incremental.c and biharmonic.c share (not
 * part of the public API).
 *
 * The biharmonic system of a mesh is Q = L M^-1 L (nv x nv, symmetric
 * positive semi-definite, the pattern of the 2-ring), L the cotangent
 * Laplacian and M the Voronoi-mixed mass matrix (laplacian.h).  Its null
 * space is the functions constant on each connected component, so Q
 * restricted to the vertices that are not handles is positive definite as
 * soon as every component holds a handle, which dtx__check_handles
 * enforces.  Weights with Dirichlet handles are solved on that restriction
 * with a simplicial L D L' factorisation (CHOLMOD), whose solves are
 * read-only on the factor and so may run concurrently.
 */
#ifndef DTX_BBW_INTERNAL_H
#define DTX_BBW_INTERNAL_H

#include "cholmod_util.h"
#include "laplacian.h"
#include "mesh.h"
#include "status.h"

#include <cholmod.h>
#include <stdint.h>

typedef struct {
    int32_t nv;
    dtx_csr Q;       /* L M^-1 L, both triangles stored */
    int32_t ncomp;   /* connected components over the faces whose vertices do not coincide */
    int32_t *comp;   /* nv: component of each vertex (numbered by lowest vertex), -1 if none */
    int32_t *lowest; /* ncomp: lowest vertex of each component */
    int32_t nthin;   /* thin triangles (laplacian.h) */
} dtx__biharmonic;

/* Builds Q and the components of mesh (validated here with
 * dtx_mesh_validate).  A vertex in no face (or only in faces whose vertices
 * coincide) is DTX_EMESH: the weights are defined on the surface only. */
dtx_status dtx__biharmonic_build(const dtx_mesh *mesh, dtx__biharmonic *sys, dtx_error *err);
void dtx__biharmonic_free(dtx__biharmonic *sys);

/* Checks a handle set: m >= 1, every handle in [0, nv), no vertex twice,
 * and every component holding at least one handle. */
dtx_status dtx__check_handles(const dtx__biharmonic *sys, const int32_t *handles, int32_t m,
                              dtx_error *err);

/* (Q x)_i. */
static inline double dtx__row_dot(const dtx_csr *Q, int32_t i, const double *x)
{
    double s = 0.0;
    for (int64_t p = Q->rowptr[i]; p < Q->rowptr[i + 1]; p++)
        s += Q->val[p] * x[Q->col[p]];
    return s;
}

/* cholmod_start with the weights' settings (cholmod_util.h): simplicial
 * L D L' and AMD only; CHOLMOD's default also tries METIS when AMD's fill
 * is high, which costs more than it saves at these sizes. */
static inline void dtx__bbw_chol_start(cholmod_common *cc)
{
    dtx__chol_start(cc, DTX__CHOL_SIMPLICIAL, DTX__CHOL_ORDER_AMD);
}

/* The block Q(I, I) of the nfree vertices I = {v : idx[v] >= 0}, numbered
 * idx[v] in increasing vertex order (fvert[k] is the vertex of index k), as
 * a CHOLMOD matrix holding the lower triangle (stype -1, sorted, packed).
 * NULL on allocation failure. */
cholmod_sparse *dtx__block(const dtx_csr *Q, const int32_t *idx, const int32_t *fvert,
                           int32_t nfree, cholmod_common *cc);

/* Analyses and factors A (a free block, on a dtx__bbw_chol_start common)
 * into *L.  On failure *L is NULL and err is set (dtx__chol_error):
 * DTX_ENOMEM, or DTX_ESOLVE when A is not positive definite; the message
 * starts "WHAT: the N x N biharmonic system", what naming the caller. */
dtx_status dtx__bbw_factor(cholmod_sparse *A, const char *what, cholmod_factor **L,
                           cholmod_common *cc, dtx_error *err);

#endif /* DTX_BBW_INTERNAL_H */
