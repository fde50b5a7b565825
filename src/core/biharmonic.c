/*
 * biharmonic.c: the biharmonic system Q = L M^-1 L of a mesh, its connected
 * components, the checks on handle sets, and the CHOLMOD helpers shared by
 * the bounded (bbw.c) and the incremental (bbw_incremental.c) weights.
 */
#include "bbw_internal.h"
#include "graph.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void dtx__biharmonic_free(dtx__biharmonic *sys)
{
    if (!sys)
        return;
    dtx_csr_free(&sys->Q);
    free(sys->comp);
    free(sys->lowest);
    memset(sys, 0, sizeof *sys);
}

static int compare_i32(const void *a, const void *b)
{
    int32_t x = *(const int32_t *)a, y = *(const int32_t *)b;
    return (x > y) - (x < y);
}

/* Q = L diag(1/M) L, both triangles, rows sorted.  Two passes over the
 * rows: the pattern (the 2-ring of each vertex), then the values. */
static dtx_status product(const dtx_csr *L, const double *M, dtx_csr *Q, dtx_error *err)
{
    int32_t n = L->n;
    int32_t *mark = dtx_alloc((size_t)n, sizeof *mark, 0);
    double *acc = dtx_alloc((size_t)n, sizeof *acc, 1);
    int64_t nnz = 0;

    memset(Q, 0, sizeof *Q);
    Q->rowptr = dtx_alloc((size_t)n + 1, sizeof *Q->rowptr, 0);
    if (!mark || !acc || !Q->rowptr)
        goto nomem;
    for (int32_t i = 0; i < n; i++)
        mark[i] = -1;
    for (int32_t i = 0; i < n; i++) {
        Q->rowptr[i] = nnz;
        for (int64_t p = L->rowptr[i]; p < L->rowptr[i + 1]; p++) {
            int32_t j = L->col[p];
            for (int64_t q = L->rowptr[j]; q < L->rowptr[j + 1]; q++)
                if (mark[L->col[q]] != i) {
                    mark[L->col[q]] = i;
                    nnz++;
                }
        }
    }
    Q->rowptr[n] = nnz;
    Q->n = n;
    Q->nnz = nnz;
    Q->col = dtx_alloc((size_t)nnz, sizeof *Q->col, 0);
    Q->val = dtx_alloc((size_t)nnz, sizeof *Q->val, 0);
    if (!Q->col || !Q->val)
        goto nomem;
    for (int32_t i = 0; i < n; i++)
        mark[i] = -1;
    for (int32_t i = 0; i < n; i++) {
        int64_t lo = Q->rowptr[i], hi = lo;
        for (int64_t p = L->rowptr[i]; p < L->rowptr[i + 1]; p++) {
            int32_t j = L->col[p];
            double a = L->val[p] / M[j];
            for (int64_t q = L->rowptr[j]; q < L->rowptr[j + 1]; q++) {
                int32_t k = L->col[q];
                if (mark[k] != i) {
                    mark[k] = i;
                    Q->col[hi++] = k;
                }
                acc[k] += a * L->val[q];
            }
        }
        qsort(Q->col + lo, (size_t)(hi - lo), sizeof *Q->col, compare_i32);
        for (int64_t p = lo; p < hi; p++) {
            Q->val[p] = acc[Q->col[p]];
            acc[Q->col[p]] = 0.0;
        }
    }
    free(mark);
    free(acc);
    return DTX_OK;

nomem:
    free(mark);
    free(acc);
    dtx_csr_free(Q);
    return dtx_seterr(err, DTX_ENOMEM, "out of memory forming the biharmonic matrix of %d "
                      "vertices", (int)n);
}

/* Components over the faces whose three vertices do not all coincide
 * (those contribute nothing to L); a vertex in none of them gets -1. */
static dtx_status components(const dtx_mesh *mesh, dtx__biharmonic *sys, dtx_error *err)
{
    int32_t nv = mesh->nv, *parent = dtx_alloc((size_t)nv, sizeof *parent, 0);
    int32_t ncomp;

    sys->comp = dtx_alloc((size_t)nv, sizeof *sys->comp, 0);
    if (!parent || !sys->comp)
        goto nomem;
    dtx__uf_init(parent, nv);
    for (int32_t i = 0; i < nv; i++)
        sys->comp[i] = -1; /* in no face counted (yet) */
    for (int32_t f = 0; f < mesh->nf; f++) {
        const int32_t *t = mesh->F + 3 * (size_t)f;
        const double *a = mesh->V + 3 * (size_t)t[0], *b = mesh->V + 3 * (size_t)t[1],
                     *c = mesh->V + 3 * (size_t)t[2];
        if (memcmp(a, b, 3 * sizeof *a) == 0 && memcmp(a, c, 3 * sizeof *a) == 0)
            continue;
        for (int k = 0; k < 3; k++) {
            dtx__uf_union(parent, t[k], t[(k + 1) % 3]);
            sys->comp[t[k]] = 0; /* in a face counted: numbered below */
        }
    }
    ncomp = dtx__uf_label(parent, nv, sys->comp, NULL);
    sys->ncomp = ncomp;
    sys->lowest = dtx_alloc((size_t)ncomp, sizeof *sys->lowest, 0);
    if (!sys->lowest)
        goto nomem;
    for (int32_t c = 0; c < ncomp; c++)
        sys->lowest[c] = -1;
    for (int32_t i = 0; i < nv; i++)
        if (sys->comp[i] >= 0 && sys->lowest[sys->comp[i]] < 0)
            sys->lowest[sys->comp[i]] = i;
    free(parent);
    return DTX_OK;

nomem:
    free(parent);
    return dtx_seterr(err, DTX_ENOMEM, "out of memory labelling the components of %d vertices",
                      (int)nv);
}

dtx_status dtx__biharmonic_build(const dtx_mesh *mesh, dtx__biharmonic *sys, dtx_error *err)
{
    dtx_csr L = {0};
    double *M = NULL;
    dtx_status st;

    memset(sys, 0, sizeof *sys);
    if (!mesh)
        return dtx_seterr(err, DTX_EINVAL, "biharmonic weights: no mesh");
    st = dtx_mesh_validate(mesh, "biharmonic weights: mesh", err);
    if (st != DTX_OK)
        return st;
    sys->nv = mesh->nv;
    st = components(mesh, sys, err);
    if (st != DTX_OK)
        goto fail;
    for (int32_t i = 0; i < mesh->nv; i++)
        if (sys->comp[i] < 0) {
            int32_t count = 0;
            for (int32_t j = i; j < mesh->nv; j++)
                count += sys->comp[j] < 0;
            st = dtx_seterr(err, DTX_EMESH,
                            "biharmonic weights: vertex %d is in no triangle of non-zero size "
                            "(%d such vertices); the weights are defined on the surface only, "
                            "remove unreferenced vertices first",
                            (int)i, (int)count);
            goto fail;
        }
    M = dtx_alloc((size_t)mesh->nv, sizeof *M, 0);
    if (!M) {
        st = dtx_seterr(err, DTX_ENOMEM, "out of memory for the mass matrix of %d vertices",
                        (int)mesh->nv);
        goto fail;
    }
    st = dtx_cotan_laplacian(mesh->V, mesh->nv, mesh->F, mesh->nf, &L, &sys->nthin, err);
    if (st == DTX_OK)
        st = dtx_mass_voronoi(mesh->V, mesh->nv, mesh->F, mesh->nf, M, NULL, err);
    if (st == DTX_OK)
        st = product(&L, M, &sys->Q, err);
    if (st != DTX_OK)
        goto fail;
    dtx_csr_free(&L);
    free(M);
    return DTX_OK;

fail:
    dtx_csr_free(&L);
    free(M);
    dtx__biharmonic_free(sys);
    return st;
}

dtx_status dtx__check_handles(const dtx__biharmonic *sys, const int32_t *handles, int32_t m,
                              dtx_error *err)
{
    int32_t *seen = NULL, *covered = NULL;
    dtx_status st = DTX_OK;

    if (m < 1 || !handles)
        return dtx_seterr(err, DTX_EINVAL,
                          "biharmonic weights: %s (at least one handle is needed)",
                          m < 1 ? "no handles" : "the handle array is NULL");
    if (m > sys->nv)
        return dtx_seterr(err, DTX_ERANGE, "biharmonic weights: %d handles on a mesh of %d "
                          "vertices", (int)m, (int)sys->nv);
    for (int32_t k = 0; k < m; k++)
        if (handles[k] < 0 || handles[k] >= sys->nv)
            return dtx_seterr(err, DTX_ERANGE,
                              "biharmonic weights: handle %d is vertex %d, out of range [0, %d)",
                              (int)k, (int)handles[k], (int)sys->nv);
    seen = dtx_alloc((size_t)sys->nv, sizeof *seen, 0);
    covered = dtx_alloc((size_t)sys->ncomp, sizeof *covered, 1);
    if (!seen || !covered) {
        st = dtx_seterr(err, DTX_ENOMEM, "out of memory checking %d handles", (int)m);
        goto done;
    }
    for (int32_t i = 0; i < sys->nv; i++)
        seen[i] = -1;
    for (int32_t k = 0; k < m; k++) {
        if (seen[handles[k]] >= 0) {
            st = dtx_seterr(err, DTX_EINVAL,
                            "biharmonic weights: handles %d and %d are the same vertex %d",
                            (int)seen[handles[k]], (int)k, (int)handles[k]);
            goto done;
        }
        seen[handles[k]] = k;
        covered[sys->comp[handles[k]]] = 1;
    }
    for (int32_t c = 0; c < sys->ncomp; c++)
        if (!covered[c]) {
            st = dtx_seterr(err, DTX_EMESH,
                            "biharmonic weights: the mesh has %d connected components and "
                            "component %d (the one of vertex %d) has no handle, so its weights "
                            "are undefined",
                            (int)sys->ncomp, (int)c, (int)sys->lowest[c]);
            goto done;
        }
done:
    free(seen);
    free(covered);
    return st;
}

cholmod_sparse *dtx__block(const dtx_csr *Q, const int32_t *idx, const int32_t *fvert,
                           int32_t nfree, cholmod_common *cc)
{
    int64_t nnz = 0;
    cholmod_sparse *A;
    int32_t *Ap, *Ai;
    double *Ax;

    for (int32_t k = 0; k < nfree; k++) {
        int32_t v = fvert[k];
        for (int64_t p = Q->rowptr[v]; p < Q->rowptr[v + 1]; p++)
            nnz += idx[Q->col[p]] >= k;
    }
    A = cholmod_allocate_sparse((size_t)nfree, (size_t)nfree, (size_t)nnz, 1, 1, -1,
                                CHOLMOD_REAL, cc);
    if (!A)
        return NULL;
    Ap = A->p;
    Ai = A->i;
    Ax = A->x;
    nnz = 0;
    /* Column k of the lower triangle is row fvert[k] of Q from column k on
     * (Q is symmetric); idx grows with the vertex, so rows come sorted. */
    for (int32_t k = 0; k < nfree; k++) {
        int32_t v = fvert[k];
        Ap[k] = (int32_t)nnz;
        for (int64_t p = Q->rowptr[v]; p < Q->rowptr[v + 1]; p++) {
            int32_t r = idx[Q->col[p]];
            if (r >= k) {
                Ai[nnz] = r;
                Ax[nnz++] = Q->val[p];
            }
        }
    }
    Ap[nfree] = (int32_t)nnz;
    return A;
}

dtx_status dtx__bbw_factor(cholmod_sparse *A, const char *what, cholmod_factor **L,
                           cholmod_common *cc, dtx_error *err)
{
    char system[160];
    snprintf(system, sizeof system, "%s: the %d x %d biharmonic system", what, (int)A->nrow,
             (int)A->nrow);
    return dtx__chol_analyze_factorize(A, DTX__CHOL_TEAMS, system,
                                       "; the mesh may have degenerate triangles", L, cc, err);
}
