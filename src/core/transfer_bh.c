/*
 * transfer_bh.c: biharmonic deformation transfer (transfer_bh.h).
 */
#include "transfer_bh.h"

#include "bbw.h"
#include "dtx_core.h"
#include "transfer.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

struct dtx_bh_plan {
    int32_t nv_s, nv_t, m, nclusters;
    dtx_skin_params skin;
    dtx_skin_mesh *sm;
    dtx_skin_fit *fit;
    double *Vt_aligned; /* nv_t x 3: the target rest mesh in source coordinates */
    double *Wt;         /* nv_t x m */
    double R[9], t[3], s; /* target -> source similarity */
    double diag_s;
    dtx_bh_info info;
};

void dtx_bh_params_default(dtx_bh_params *p)
{
    memset(p, 0, sizeof *p);
    dtx_skin_params_default(&p->skin);
}

void dtx_bh_plan_free(dtx_bh_plan **plan)
{
    if (!plan || !*plan)
        return;
    dtx_skin_fit_free(&(*plan)->fit);
    dtx_skin_mesh_free(&(*plan)->sm);
    free((*plan)->Vt_aligned);
    free((*plan)->Wt);
    free(*plan);
    *plan = NULL;
}

void dtx_bh_plan_info(const dtx_bh_plan *plan, dtx_bh_info *info) { *info = plan->info; }
int32_t dtx_bh_plan_nv_src(const dtx_bh_plan *plan) { return plan->nv_s; }
int32_t dtx_bh_plan_nv_tgt(const dtx_bh_plan *plan) { return plan->nv_t; }

static dtx_status check_keys(const dtx_mesh *mesh, const int32_t *keys, int32_t m,
                             const char *what, dtx_error *err)
{
    for (int32_t k = 0; k < m; k++) {
        if (keys[k] < 0 || keys[k] >= mesh->nv)
            return dtx_seterr(err, DTX_ERANGE,
                              "%s key point %d: vertex %d out of range (mesh has %d vertices)",
                              what, (int)k, (int)keys[k], (int)mesh->nv);
        for (int32_t j = 0; j < k; j++)
            if (keys[j] == keys[k])
                return dtx_seterr(err, DTX_EINVAL,
                                  "%s key points %d and %d are the same vertex %d", what, (int)j,
                                  (int)k, (int)keys[k]);
    }
    return DTX_OK;
}

/* The similarity x -> s R x + t taking the target key points onto the
 * source's: Umeyama for m >= 3 (unless degenerate), otherwise translation
 * and scale only. */
static dtx_status align(dtx_bh_plan *p, const dtx_mesh *src, const dtx_mesh *tgt,
                        const int32_t *sk, const int32_t *tk, int32_t m, dtx_error *err)
{
    double *P = dtx_alloc((size_t)m, 3 * sizeof *P, 0), *Q = dtx_alloc((size_t)m, 3 * sizeof *Q, 0);
    double cp[3] = {0, 0, 0}, cq[3] = {0, 0, 0}, rp = 0, rq = 0, e2 = 0;
    dtx_status st = DTX_OK;
    if (!P || !Q) {
        free(P);
        free(Q);
        return dtx_seterr(err, DTX_ENOMEM, "out of memory");
    }
    for (int32_t k = 0; k < m; k++)
        for (int d = 0; d < 3; d++) {
            P[3 * k + d] = tgt->V[3 * (size_t)tk[k] + d];
            Q[3 * k + d] = src->V[3 * (size_t)sk[k] + d];
            cp[d] += P[3 * k + d] / m;
            cq[d] += Q[3 * k + d] / m;
        }
    if (m < 3 || dtx_similarity_fit(P, Q, m, p->R, p->t, &p->s, NULL) != DTX_OK ||
        !(p->s > 0.0) || !isfinite(p->s)) {
        for (int32_t k = 0; k < m; k++)
            for (int d = 0; d < 3; d++) {
                rp += (P[3 * k + d] - cp[d]) * (P[3 * k + d] - cp[d]);
                rq += (Q[3 * k + d] - cq[d]) * (Q[3 * k + d] - cq[d]);
            }
        p->s = rp > 0 && rq > 0 ? sqrt(rq / rp) : dtx_bbox_diagonal(src->V, src->nv) /
                                                      dtx_bbox_diagonal(tgt->V, tgt->nv);
        memset(p->R, 0, sizeof p->R);
        p->R[0] = p->R[4] = p->R[8] = 1.0;
        for (int d = 0; d < 3; d++)
            p->t[d] = cq[d] - p->s * cp[d];
    }
    if (!(p->s > 0.0) || !isfinite(p->s))
        st = dtx_seterr(err, DTX_EMESH, "biharmonic: cannot align the target to the source");
    memcpy(p->Vt_aligned, tgt->V, sizeof *p->Vt_aligned * 3 * (size_t)tgt->nv);
    dtx_similarity_apply(p->R, p->t, p->s, p->Vt_aligned, tgt->nv);
    dtx_similarity_apply(p->R, p->t, p->s, P, m);
    for (int64_t i = 0; i < 3 * (int64_t)m; i++)
        e2 += (P[i] - Q[i]) * (P[i] - Q[i]);
    p->info.align_scale = p->s;
    p->info.align_rms = sqrt(e2 / m) / p->diag_s;
    free(P);
    free(Q);
    return st;
}

dtx_status dtx_bh_plan_create(const dtx_mesh *src, const dtx_mesh *tgt, const int32_t *src_keys,
                              const int32_t *tgt_keys, int32_t m, const dtx_bh_params *prm,
                              int32_t ntrain, const double *Xtrain, dtx_bh_plan **out,
                              dtx_error *err)
{
    return dtx_bh_plan_create_weights(src, tgt, src_keys, tgt_keys, m, prm, ntrain, Xtrain, NULL,
                                      NULL, out, err);
}

dtx_status dtx_bh_plan_create_weights(const dtx_mesh *src, const dtx_mesh *tgt,
                                      const int32_t *src_keys, const int32_t *tgt_keys, int32_t m,
                                      const dtx_bh_params *prm, int32_t ntrain,
                                      const double *Xtrain, const double *src_weights,
                                      const double *tgt_weights, dtx_bh_plan **out,
                                      dtx_error *err)
{
    dtx_bh_plan *p;
    dtx_status st;
    double *Wcomputed = NULL, *feat = NULL, t0;
    const double *Ws = src_weights; /* the source's weights, given or computed */
    int32_t *labels = NULL;
    dtx_bh_params def;

    *out = NULL;
    if (!prm) {
        dtx_bh_params_default(&def);
        prm = &def;
    }
    if (!src || !tgt || !src_keys || !tgt_keys || m < 1 || ntrain < 0 || (ntrain > 0 && !Xtrain))
        return dtx_seterr(err, DTX_EINVAL, "biharmonic: missing meshes or key points");
    if ((st = dtx_mesh_validate(src, "biharmonic: source mesh", err)) != DTX_OK ||
        (st = dtx_mesh_validate(tgt, "biharmonic: target mesh", err)) != DTX_OK ||
        (st = check_keys(src, src_keys, m, "source", err)) != DTX_OK ||
        (st = check_keys(tgt, tgt_keys, m, "target", err)) != DTX_OK)
        return st;
    p = dtx_alloc(1, sizeof *p, 1);
    if (!p)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory");
    p->nv_s = src->nv;
    p->nv_t = tgt->nv;
    p->m = m;
    p->skin = prm->skin;
    p->nclusters = prm->skin.nclusters > 0 ? prm->skin.nclusters : m;
    if (p->nclusters > src->nv)
        p->nclusters = src->nv;
    p->diag_s = dtx_bbox_diagonal(src->V, src->nv);
    p->Vt_aligned = dtx_alloc((size_t)tgt->nv, 3 * sizeof *p->Vt_aligned, 0);
    p->Wt = dtx_alloc((size_t)tgt->nv, (size_t)m * sizeof *p->Wt, 0);
    if (!src_weights)
        Ws = Wcomputed = dtx_alloc((size_t)src->nv, (size_t)m * sizeof *Wcomputed, 0);
    labels = dtx_alloc((size_t)src->nv, sizeof *labels, 0);
    feat = dtx_alloc((size_t)src->nv, (size_t)DTX_SKIN_FEAT * (size_t)(ntrain ? ntrain : 1) *
                                          sizeof *feat, 0);
    if (!p->Vt_aligned || !p->Wt || !Ws || !labels || !feat) {
        st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
        goto fail;
    }
    t0 = omp_get_wtime();
    if (!src_weights && (st = dtx_bbw(src, src_keys, m, NULL, Wcomputed, NULL, err)) != DTX_OK) {
        dtx_error_prefix(err, "biharmonic: source weights");
        goto fail;
    }
    if (tgt_weights)
        memcpy(p->Wt, tgt_weights, (size_t)tgt->nv * (size_t)m * sizeof *p->Wt);
    else if ((st = dtx_bbw(tgt, tgt_keys, m, NULL, p->Wt, NULL, err)) != DTX_OK) {
        dtx_error_prefix(err, "biharmonic: target weights");
        goto fail;
    }
    p->info.weights_seconds = omp_get_wtime() - t0;
    p->info.weights_given = src_weights && tgt_weights;
    if ((st = align(p, src, tgt, src_keys, tgt_keys, m, err)) != DTX_OK)
        goto fail;
    {
        dtx_skin_params sp = p->skin;
        sp.nclusters = p->nclusters;
        if ((st = dtx_skin_mesh_create(src->V, src->nv, src->F, src->nf, DTX_SKIN_COTAN, &p->sm,
                                       err)) != DTX_OK ||
            (ntrain > 0 && (st = dtx_skin_features(p->sm, ntrain, Xtrain, &sp, feat, err)) !=
                               DTX_OK) ||
            (st = dtx_skin_cluster(src->nv, m, Ws, ntrain, feat, &sp, labels, err)) != DTX_OK ||
            (st = dtx_skin_fit_create(p->sm, m, Ws, labels, p->nclusters, &sp, &p->fit, err)) !=
                DTX_OK) {
            dtx_error_prefix(err, "biharmonic: source fit");
            goto fail;
        }
    }
    p->info.keys = m;
    p->info.clusters = p->nclusters;
    free(Wcomputed);
    free(labels);
    free(feat);
    *out = p;
    return DTX_OK;
fail:
    free(Wcomputed);
    free(labels);
    free(feat);
    dtx_bh_plan_free(&p);
    return st;
}

dtx_status dtx_bh_apply(const dtx_bh_plan *p, int64_t nframes, const double *Xs, double *Xt,
                        double *residual, dtx_error *err)
{
    dtx_skin_params sp = p->skin;
    dtx_skin_out o;
    double *T = NULL, *diff = NULL;
    dtx_status st;
    if (nframes <= 0)
        return DTX_OK;
    if (nframes > INT32_MAX)
        return dtx_seterr(err, DTX_EINVAL, "biharmonic: too many frames in one call");
    T = dtx_alloc((size_t)nframes, (size_t)p->m * 12 * sizeof *T, 0);
    diff = dtx_alloc((size_t)nframes, sizeof *diff, 0);
    if (!T || !diff) {
        free(T);
        free(diff);
        return dtx_seterr(err, DTX_ENOMEM, "out of memory");
    }
    sp.nclusters = p->nclusters;
    memset(&o, 0, sizeof o);
    o.T = T;
    o.diff = diff;
    st = dtx_skin_fit_frames(p->fit, (int32_t)nframes, Xs, &sp, &o, err);
    if (st == DTX_OK) {
        dtx_skin_apply(p->nv_t, p->m, p->Vt_aligned, p->Wt, (int32_t)nframes, T, sp.threads, Xt);
        /* Back to the target's coordinates: b = R^T (x - t) / s. */
#pragma omp parallel for schedule(static)
        for (int64_t i = 0; i < nframes * (int64_t)p->nv_t; i++) {
            double *x = Xt + 3 * (size_t)i, d[3];
            for (int k = 0; k < 3; k++)
                d[k] = x[k] - p->t[k];
            for (int k = 0; k < 3; k++)
                x[k] = (p->R[k] * d[0] + p->R[3 + k] * d[1] + p->R[6 + k] * d[2]) / p->s;
        }
        if (residual)
            for (int64_t f = 0; f < nframes; f++)
                residual[f] = sqrt(diff[f] / p->nv_s) / p->diag_s;
    }
    free(T);
    free(diff);
    return st;
}

/* ------------------------------------------------------------------ */
/* The method table (transfer.h)                                       */
/* ------------------------------------------------------------------ */

/* The table's plan: the biharmonic plan, the residuals of the last apply,
 * and with DTX_ANCHOR_FIXED the target's rest centroid every frame is
 * moved to. */
typedef struct {
    dtx_bh_plan *plan;
    void *res; /* res_cap doubles */
    int64_t res_cap;
    int recentre;
    double centre[3];
} bh_method_plan;

/* Moves each of the n frames X (n x nv x 3) so that its vertex centroid is
 * c (per frame, in vertex order: the same bits however frames are split). */
static void recentre(double *X, int64_t n, int32_t nv, const double c[3])
{
    for (int64_t f = 0; f < n; f++) {
        double *Y = X + (size_t)f * 3 * (size_t)nv, m[3] = {0, 0, 0};
        for (int32_t i = 0; i < nv; i++)
            for (int k = 0; k < 3; k++)
                m[k] += Y[3 * (size_t)i + k];
        for (int k = 0; k < 3; k++)
            m[k] = c[k] - m[k] / nv;
        for (int32_t i = 0; i < nv; i++)
            for (int k = 0; k < 3; k++)
                Y[3 * (size_t)i + k] += m[k];
    }
}

static void bh_method_free(void **plan)
{
    bh_method_plan *p = *plan;
    if (!p)
        return;
    dtx_bh_plan_free(&p->plan);
    free(p->res);
    free(p);
    *plan = NULL;
}

static dtx_status bh_method_create(const dtx_transfer_inputs *in, const dtx_transfer_params *prm,
                                   void **plan, dtx_error *err)
{
    bh_method_plan *p = dtx_alloc(1, sizeof *p, 1);
    dtx_status st;
    *plan = NULL;
    if (!p)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory");
    st = dtx_bh_plan_create_weights(in->src, in->tgt, in->src_keys, in->tgt_keys, in->nkeys,
                                    &prm->u.bh, in->ntrain, in->Xtrain, in->src_weights,
                                    in->tgt_weights, &p->plan, err);
    *plan = p;
    if (st != DTX_OK) {
        bh_method_free(plan);
        return st;
    }
    p->recentre = in->anchor == DTX_ANCHOR_FIXED;
    for (int k = 0; k < 3; k++) {
        p->centre[k] = 0;
        for (int32_t i = 0; i < in->tgt->nv; i++)
            p->centre[k] += in->tgt->V[3 * (size_t)i + k];
        p->centre[k] /= in->tgt->nv;
    }
    return DTX_OK;
}

static dtx_status bh_method_apply(void *plan, int64_t nframes, const double *Xs, double *Xt,
                                  dtx_frame_info *info, dtx_error *err)
{
    bh_method_plan *p = plan;
    dtx_status st = dtx_transfer_scratch(&p->res, &p->res_cap, nframes, sizeof(double), err);
    const double *res = p->res;
    if (st == DTX_OK)
        st = dtx_bh_apply(p->plan, nframes, Xs, Xt, p->res, err);
    if (st == DTX_OK && p->recentre)
        recentre(Xt, nframes, dtx_bh_plan_nv_tgt(p->plan), p->centre);
    for (int64_t i = 0; st == DTX_OK && i < nframes; i++) {
        info[i].residual = res[i];
        info[i].iterations = info[i].converged = info[i].inverted = -1;
        info[i].grad_norm = NAN;
    }
    return st;
}

static void bh_method_describe(const void *plan, char *buf, size_t size)
{
    const bh_method_plan *p = plan;
    dtx_bh_info info;
    dtx_bh_plan_info(p->plan, &info);
    if (info.weights_given)
        snprintf(buf, size,
                 "%d key points, %d rotation clusters; key points %.2f%% of the source diagonal "
                 "apart after aligning the target",
                 (int)info.keys, (int)info.clusters, 100 * info.align_rms);
    else
        snprintf(buf, size,
                 "%d key points, %d rotation clusters, biharmonic weights %.2f s; key points "
                 "%.2f%% of the source diagonal apart after aligning the target",
                 (int)info.keys, (int)info.clusters, info.weights_seconds, 100 * info.align_rms);
}

/* The transfer's settings in the job file's "biharmonic" object
 * (transfer.h); the key-point selection's are the run's (io/job.c). */
static const dtx_setting bh_settings[] = {
    {"gamma_logr", DTX_SETTING_DOUBLE, offsetof(dtx_bh_params, skin.gamma_logr), NULL},
    {"gamma_s", DTX_SETTING_DOUBLE, offsetof(dtx_bh_params, skin.gamma_s), NULL},
    {"lambda", DTX_SETTING_DOUBLE, offsetof(dtx_bh_params, skin.lambda), NULL},
};

const dtx_transfer_method dtx_method_biharmonic = {
    .name = "biharmonic",
    .kind = DTX_TRANSFER_BIHARMONIC,
    .iterative = 0,
    .solve_group = DTX_SP04_SOLVE_GROUP,
    .correspondence = DTX_TRANSFER_CORR_SP04,
    .uses_keypoints = 1,
    .multi_component_target = 1,
    .settings = bh_settings,
    .nsettings = (int)(sizeof bh_settings / sizeof *bh_settings),
    .plan_create = bh_method_create,
    .apply = bh_method_apply,
    .plan_free = bh_method_free,
    .describe = bh_method_describe,
};
