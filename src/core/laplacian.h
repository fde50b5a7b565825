/*
 * laplacian.h: the cotangent Laplacian and the lumped (Voronoi-mixed) mass
 * matrix of a triangle mesh, the discrete operators of the biharmonic
 * weights (bbw.h) and of cotangent-weighted ARAP energies.
 *
 * Sign convention: L is the stiffness matrix of piecewise-linear functions,
 * positive semi-definite: u' L u = sum over edges (i, j) of w_ij (u_i -
 * u_j)^2 with the cotangent weight w_ij = (cot a_ij + cot b_ij) / 2 (a_ij,
 * b_ij the angles opposite the edge), L_ij = -w_ij, L_ii = sum_j w_ij.  (libigl's
 * cotmatrix is -L.)  Obtuse angles give negative cotangents and are kept:
 * they are what makes L exact on linear functions (L x = 0 at the interior
 * vertices of a flat mesh).
 *
 * Thin triangles: a triangle whose doubled area |e1 x e2| is below
 * DTX_MESH_THIN_RATIO times its longest edge squared (needles and zero-area
 * triangles) uses DTX_MESH_THIN_RATIO * longest^2 in place of |e1 x e2|, in
 * its cotangents and its area alike.  That scales its three cotangents by
 * one positive factor, so its contribution stays finite and positive
 * semi-definite (no NaN, no Inf, no indefinite L); a triangle whose three
 * vertices coincide contributes nothing.  Such triangles are counted.
 */
#ifndef DTX_LAPLACIAN_H
#define DTX_LAPLACIAN_H

#include "status.h"

#include <stdint.h>

/* A square sparse matrix in compressed sparse rows: row i holds
 * col[rowptr[i] .. rowptr[i+1]-1] (strictly ascending) with values val[..].
 * Every array is owned by the struct (free with dtx_csr_free). */
typedef struct {
    int32_t n;       /* rows = columns */
    int64_t nnz;     /* rowptr[n] */
    int64_t *rowptr; /* n + 1 */
    int32_t *col;    /* nnz */
    double *val;     /* nnz */
} dtx_csr;

/* Frees the arrays of A and zeroes it.  Accepts NULL and a zeroed struct. */
void dtx_csr_free(dtx_csr *A);

/* The cotangent Laplacian L (nv x nv, the convention above) of the mesh with
 * vertex positions V (nv x 3 row-major) and faces F (nf x 3, 0-based, every
 * index in [0, nv): the caller validates, e.g. with dtx_mesh_validate).
 *
 * *L is overwritten (not freed first) and allocated here; free it with
 * dtx_csr_free.  Every row holds its diagonal (0 for a vertex in no face)
 * and the vertices it shares an edge with, so the pattern is the edge graph;
 * an edge's weight may be exactly 0 (two right angles).  L is exactly
 * symmetric (L_ij and L_ji are the same sum in the same order) and each row
 * sums to 0 up to rounding (|sum| <~ 1e-15 L_ii).
 *
 * nthin (may be NULL): the number of thin triangles treated as above.
 * Returns DTX_ENOMEM, DTX_EINVAL (nv < 1, nf < 0, NULL arrays) or DTX_OK.
 * O(nf) time and memory; thread-safe. */
dtx_status dtx_cotan_laplacian(const double *V, int32_t nv, const int32_t *F, int32_t nf,
                               dtx_csr *L, int32_t *nthin, dtx_error *err);

/* The lumped mass matrix M (diagonal, nv doubles, caller-allocated) with
 * Meyer et al.'s mixed Voronoi areas (2003): a triangle with no obtuse
 * angle gives each corner its Voronoi area (|e_ij|^2 cot k + |e_ik|^2 cot
 * j) / 8; an obtuse one gives A/2 to the obtuse corner and A/4 to the two
 * others; a thin triangle (above) gives A'/3 to each corner with its
 * regularised area A' = DTX_MESH_THIN_RATIO * longest^2 / 2.  Each
 * triangle's three shares add up to its area, so sum(M) is the surface area
 * (thin triangles counted with A').
 *
 * A vertex that would get no mass (in no face, or only in triangles whose
 * three vertices coincide) gets the smallest positive mass of the mesh (1
 * if there is none), so M > 0 always; their number is returned in nzero
 * (may be NULL).  Same arguments and errors as dtx_cotan_laplacian;
 * thread-safe. */
dtx_status dtx_mass_voronoi(const double *V, int32_t nv, const int32_t *F, int32_t nf,
                            double *M, int32_t *nzero, dtx_error *err);

#endif /* DTX_LAPLACIAN_H */
