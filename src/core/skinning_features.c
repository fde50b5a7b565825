/*
 * skinning_features.c: per-vertex rotation and scale/shear features of
 * deformed frames, and the k-means clustering on W' = [W, logr, s] that
 * groups the skinning fit's ARAP edges (Yang et al. 2018, section 3.3).
 *
 * The per-vertex deformation gradient is the rest-area-weighted mean of
 * the gradients of the vertex's triangles (Sumner & Popovic's fourth-vertex
 * gradients, dtx_deformation_gradients) rather than the paper's one-ring
 * least squares (equation 6): the one-ring system is singular at a vertex
 * whose one-ring is flat, while the triangle gradients carry the normal
 * direction and are always defined.
 */
#include "dtx_core.h"
#include "mat3.h"
#include "skinning_internal.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#define SQRT2 1.41421356237309504880

dtx_status dtx_skin_features(const dtx_skin_mesh *mesh, int32_t nframes, const double *X,
                             const dtx_skin_params *p, double *feat, dtx_error *err)
{
    double *grad = NULL;
    int32_t nv, nf;
    int nt;
    int64_t stride;

    if (!mesh || nframes < 0 || (nframes > 0 && (!X || !feat)))
        return dtx_seterr(err, DTX_EINVAL, "skinning features: bad arguments");
    nv = mesh->nv;
    nf = mesh->nf;
    for (int64_t i = 0; i < (int64_t)nframes * nv * 3; i++)
        if (!isfinite(X[i]))
            return dtx_seterr(err, DTX_ENONFINITE,
                              "skinning features: frame %lld, vertex %lld has a non-finite "
                              "coordinate",
                              (long long)(i / (3 * (int64_t)nv)), (long long)(i / 3 % nv));
    if (nframes == 0)
        return DTX_OK;
    nt = dtx_skin_threads_(p ? p->threads : 0);
    if (nt > nframes)
        nt = nframes;
    grad = dtx_alloc((size_t)nt * nf, 9 * sizeof(double), 0);
    if (!grad)
        return dtx_seterr(err, DTX_ENOMEM,
                          "skinning features: out of memory (%d triangles x %d threads)", (int)nf,
                          nt);
    stride = (int64_t)DTX_SKIN_FEAT * nframes;

#pragma omp parallel for schedule(dynamic, 1) num_threads(nt)
    for (int32_t f = 0; f < nframes; f++) {
        double *G = grad + (size_t)omp_get_thread_num() * nf * 9;
        dtx_deformation_gradients(mesh->Vinv, mesh->F, nf, X + (size_t)f * nv * 3, G);
        for (int32_t i = 0; i < nv; i++) {
            double D[9] = {0}, U[9], N[9];
            double *o = feat + (size_t)i * stride + (size_t)DTX_SKIN_FEAT * f;
            for (int64_t s = mesh->vf_start[i]; s < mesh->vf_start[i + 1]; s++) {
                const double *g = G + 9 * (size_t)mesh->vf_face[s];
                double w = mesh->vf_w[s];
                for (int k = 0; k < 9; k++)
                    D[k] += w * g[k];
            }
            dtx_polar3(D, U, N);
            dtx_so3_log(U, o);
            o[3] = N[0];
            o[4] = N[4];
            o[5] = N[8];
            o[6] = SQRT2 * N[1];
            o[7] = SQRT2 * N[2];
            o[8] = SQRT2 * N[5];
        }
    }
    free(grad);
    return DTX_OK;
}

dtx_status dtx_skin_cluster(int32_t nv, int32_t m, const double *W, int32_t nframes,
                            const double *feat, const dtx_skin_params *p, int32_t *labels,
                            dtx_error *err)
{
    double *Wp, gr, gs;
    int32_t k, d;
    int64_t fstride;
    dtx_status st;

    if (!W || !p || !labels || nv < 1 || m < 1 || nframes < 0 || (nframes > 0 && !feat))
        return dtx_seterr(err, DTX_EINVAL, "skinning clusters: bad arguments");
    k = p->nclusters > 0 ? p->nclusters : m;
    if (k > nv)
        return dtx_seterr(err, DTX_EINVAL, "skinning clusters: %d clusters for %d vertices", (int)k,
                          (int)nv);
    if ((int64_t)m + (int64_t)DTX_SKIN_FEAT * nframes > INT32_MAX)
        return dtx_seterr(err, DTX_EINVAL, "skinning clusters: too many frames (%d)", (int)nframes);
    fstride = (int64_t)DTX_SKIN_FEAT * nframes;
    d = m + (int32_t)fstride;
    Wp = dtx_alloc((size_t)nv * d, sizeof *Wp, 0);
    if (!Wp)
        return dtx_seterr(err, DTX_ENOMEM,
                          "skinning clusters: out of memory (%d vertices x %d features)", (int)nv,
                          (int)d);
    /* W' = [W, gamma_logr / sqrt(nframes) logr, gamma_s / sqrt(nframes) s] */
    gr = nframes > 0 ? p->gamma_logr / sqrt((double)nframes) : 0.0;
    gs = nframes > 0 ? p->gamma_s / sqrt((double)nframes) : 0.0;
    for (int32_t i = 0; i < nv; i++) {
        double *row = Wp + (size_t)i * d;
        const double *fi = feat ? feat + (size_t)i * fstride : NULL;
        memcpy(row, W + (size_t)i * m, sizeof(double) * (size_t)m);
        for (int64_t j = 0; j < fstride; j++)
            row[m + j] = fi[j] * (j % DTX_SKIN_FEAT < 3 ? gr : gs);
    }
    st = dtx_kmeans(Wp, nv, d, k, p->kmeans_iters, p->kmeans_seed, p->threads, labels, NULL, NULL,
                    err);
    if (st != DTX_OK)
        dtx_error_prefix(err, "skinning clusters");
    free(Wp);
    return st;
}
