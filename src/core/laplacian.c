/*
 * laplacian.c: the cotangent Laplacian and the Voronoi-mixed mass matrix
 * (conventions in laplacian.h).
 */
#include "laplacian.h"

#include "mesh.h"
#include "vec3.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void dtx_csr_free(dtx_csr *A)
{
    if (!A)
        return;
    free(A->rowptr);
    free(A->col);
    free(A->val);
    memset(A, 0, sizeof *A);
}

static dtx_status check_args(const double *V, int32_t nv, const int32_t *F, int32_t nf,
                             const void *out, const char *what, dtx_error *err)
{
    if (nv < 1 || nf < 0 || !V || (nf > 0 && !F) || !out)
        return dtx_seterr(err, DTX_EINVAL,
                          "%s: invalid arguments (%d vertices, %d faces%s%s%s)", what, (int)nv,
                          (int)nf, V ? "" : ", no positions", (nf > 0 && !F) ? ", no faces" : "",
                          out ? "" : ", no output");
    return DTX_OK;
}

/* ------------------------------------------------------------------ */
/* One triangle                                                        */
/* ------------------------------------------------------------------ */

/* The triangle's geometry: dot[k] = e_ka . e_kb at corner k (a, b its two
 * neighbours), len2[k] = squared length of the edge opposite corner k, and
 * the doubled area to divide by (|e1 x e2|, or the regularised value for a
 * thin triangle).  Returns 0 when the three vertices coincide (nothing to
 * contribute), 2 for a thin triangle, 1 otherwise. */
static int triangle(const double *V, const int32_t *t, double dot[3], double len2[3],
                    double *area2)
{
    const double *p[3] = {V + 3 * (size_t)t[0], V + 3 * (size_t)t[1], V + 3 * (size_t)t[2]};
    double e[3][3], n[3], longest2, cr;
    /* e[k] is the edge opposite corner k, from corner k+1 to corner k+2. */
    for (int k = 0; k < 3; k++)
        sub3(p[(k + 2) % 3], p[(k + 1) % 3], e[k]);
    for (int k = 0; k < 3; k++) {
        len2[k] = dot3(e[k], e[k]);
        /* The edges leaving corner k towards k+1 and k+2 are e[k+2] and
         * -e[k+1]. */
        dot[k] = -dot3(e[(k + 2) % 3], e[(k + 1) % 3]);
    }
    longest2 = fmax(len2[0], fmax(len2[1], len2[2]));
    if (!(longest2 > 0.0))
        return 0;
    cross3(e[2], e[1], n);
    cr = sqrt(dot3(n, n));
    if (cr <= DTX_MESH_THIN_RATIO * longest2) {
        *area2 = DTX_MESH_THIN_RATIO * longest2;
        return 2;
    }
    *area2 = cr;
    return 1;
}

/* ------------------------------------------------------------------ */
/* Cotangent Laplacian                                                 */
/* ------------------------------------------------------------------ */

typedef struct {
    int32_t col;
    int32_t seq; /* position of the entry in its row before sorting: the face order */
    double w;
} entry;

static int compare_entry(const void *a, const void *b)
{
    const entry *x = a, *y = b;
    if (x->col != y->col)
        return x->col < y->col ? -1 : 1;
    return (x->seq > y->seq) - (x->seq < y->seq);
}

dtx_status dtx_cotan_laplacian(const double *V, int32_t nv, const int32_t *F, int32_t nf,
                               dtx_csr *L, int32_t *nthin, dtx_error *err)
{
    dtx_status st = check_args(V, nv, F, nf, L, "cotangent Laplacian", err);
    int64_t *start = NULL, *fill = NULL;
    entry *ent = NULL;
    int32_t thin = 0;
    int64_t total, nnz = 0;

    if (st != DTX_OK)
        return st;
    memset(L, 0, sizeof *L);
    start = dtx_alloc((size_t)nv + 1, sizeof *start, 1);
    fill = dtx_alloc((size_t)nv, sizeof *fill, 0);
    ent = dtx_alloc((size_t)nf, 6 * sizeof *ent, 0);
    if (!start || !fill || !ent)
        goto nomem;

    /* Every face puts two entries in each of its three rows, in face order
     * (so that L_ij and L_ji are summed over the same faces in the same
     * order, which makes L exactly symmetric). */
    for (int32_t f = 0; f < nf; f++)
        for (int k = 0; k < 3; k++)
            start[F[3 * (size_t)f + k] + 1] += 2;
    for (int32_t i = 0; i < nv; i++)
        start[i + 1] += start[i];
    memcpy(fill, start, (size_t)nv * sizeof *fill);
    for (int32_t f = 0; f < nf; f++) {
        const int32_t *t = F + 3 * (size_t)f;
        double dot[3], len2[3], area2 = 0.0;
        int kind = triangle(V, t, dot, len2, &area2);
        thin += kind == 2;
        for (int k = 0; k < 3; k++) {
            /* Corner k's angle is opposite the edge (k+1, k+2). */
            int32_t a = t[(k + 1) % 3], b = t[(k + 2) % 3];
            double w = kind ? 0.5 * dot[k] / area2 : 0.0;
            ent[fill[a]].col = b;
            ent[fill[a]].seq = (int32_t)(fill[a] - start[a]);
            ent[fill[a]++].w = w;
            ent[fill[b]].col = a;
            ent[fill[b]].seq = (int32_t)(fill[b] - start[b]);
            ent[fill[b]++].w = w;
        }
    }

    /* Sort each row by column (ties in face order), merge duplicates. */
    for (int32_t i = 0; i < nv; i++) {
        int64_t lo = start[i], hi = start[i + 1], out = lo;
        qsort(ent + lo, (size_t)(hi - lo), sizeof *ent, compare_entry);
        for (int64_t p = lo; p < hi; p++) {
            if (out > lo && ent[out - 1].col == ent[p].col) {
                ent[out - 1].w += ent[p].w;
            } else {
                ent[out++] = ent[p];
            }
        }
        fill[i] = out - lo; /* distinct neighbours of i */
        nnz += fill[i] + 1;
    }

    total = nnz;
    L->n = nv;
    L->nnz = total;
    L->rowptr = dtx_alloc((size_t)nv + 1, sizeof *L->rowptr, 0);
    L->col = dtx_alloc((size_t)total, sizeof *L->col, 0);
    L->val = dtx_alloc((size_t)total, sizeof *L->val, 0);
    if (!L->rowptr || !L->col || !L->val)
        goto nomem;
    nnz = 0;
    for (int32_t i = 0; i < nv; i++) {
        const entry *r = ent + start[i];
        int64_t diag;
        double sum = 0.0;
        int placed = 0;
        L->rowptr[i] = nnz;
        for (int64_t p = 0; p < fill[i]; p++) {
            if (!placed && r[p].col > i) {
                diag = nnz++;
                placed = 1;
                L->col[diag] = i;
            }
            L->col[nnz] = r[p].col;
            L->val[nnz++] = -r[p].w;
            sum += r[p].w;
        }
        if (!placed) {
            L->col[nnz] = i;
            diag = nnz++;
        }
        L->val[diag] = sum;
    }
    L->rowptr[nv] = nnz;
    free(start);
    free(fill);
    free(ent);
    if (nthin)
        *nthin = thin;
    return DTX_OK;

nomem:
    dtx_csr_free(L);
    free(start);
    free(fill);
    free(ent);
    return dtx_seterr(err, DTX_ENOMEM, "out of memory building the cotangent Laplacian of %d "
                      "vertices and %d faces", (int)nv, (int)nf);
}

/* ------------------------------------------------------------------ */
/* Voronoi-mixed mass matrix                                           */
/* ------------------------------------------------------------------ */

dtx_status dtx_mass_voronoi(const double *V, int32_t nv, const int32_t *F, int32_t nf,
                            double *M, int32_t *nzero, dtx_error *err)
{
    dtx_status st = check_args(V, nv, F, nf, M, "mass matrix", err);
    double smallest = INFINITY;
    int32_t zero = 0;

    if (st != DTX_OK)
        return st;
    memset(M, 0, (size_t)nv * sizeof *M);
    for (int32_t f = 0; f < nf; f++) {
        const int32_t *t = F + 3 * (size_t)f;
        double dot[3], len2[3], area2 = 0.0, A;
        int kind = triangle(V, t, dot, len2, &area2);
        if (kind == 0)
            continue;
        A = 0.5 * area2;
        if (kind == 2) {
            for (int k = 0; k < 3; k++)
                M[t[k]] += A / 3.0;
        } else if (dot[0] < 0.0 || dot[1] < 0.0 || dot[2] < 0.0) {
            for (int k = 0; k < 3; k++)
                M[t[k]] += dot[k] < 0.0 ? 0.5 * A : 0.25 * A;
        } else {
            /* Corner k's Voronoi area: the two edges at k (opposite corners
             * k+1 and k+2), each with the cotangent of its opposite angle. */
            for (int k = 0; k < 3; k++) {
                int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
                M[t[k]] += (len2[k1] * dot[k1] + len2[k2] * dot[k2]) / area2 / 8.0;
            }
        }
    }
    for (int32_t i = 0; i < nv; i++)
        if (M[i] > 0.0 && M[i] < smallest)
            smallest = M[i];
    if (!(smallest < INFINITY))
        smallest = 1.0;
    for (int32_t i = 0; i < nv; i++)
        if (!(M[i] > 0.0)) {
            M[i] = smallest;
            zero++;
        }
    if (nzero)
        *nzero = zero;
    return DTX_OK;
}
