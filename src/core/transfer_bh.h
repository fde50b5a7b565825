/*
 * transfer_bh.h: biharmonic deformation transfer (Yang, Gao, Lai, Rosin &
 * Xia 2018, section 3.6).
 *
 * Key points: m source vertices and the m target vertices that correspond
 * to them (from a marker file, or selected by keypoints.h and mapped through
 * a correspondence).  Each frame of the source animation is fitted by
 * linear blend skinning of the source rest mesh with one affine map T_k
 * per key point (bounded biharmonic weights of the source key points, the
 * clustered ARAP fit of skinning.h: lambda E_arap + E_diff); the same maps
 * then drive the target rest mesh through the target's own bounded
 * biharmonic weights of the target key points:
 *
 *     x_i = sum_k w^B_ik T_k [b_i; 1].
 *
 * The maps act in source coordinates, so the target is first brought onto
 * the source by the similarity (rotation, uniform scale, translation) that
 * best maps its key points onto the source key points (dtx_similarity_fit;
 * with fewer than 3 key points, translation and scale only), skinned there,
 * and mapped back: results are in the target's own coordinates and move
 * with the source (the paper applies T to the target as it stands, which
 * assumes the two meshes are already aligned).
 *
 * The clustering of the source fit uses W and, when training frames are
 * given, the rotation and stretch features of those frames (skinning.h);
 * the plan is fixed once built, so every frame's result depends on that
 * frame alone (not on how a sequence is split over ranks or threads).
 *
 * Residual of a frame: the RMS distance between the fitted source and the
 * source frame, divided by the source's bounding-box diagonal: how well the
 * key points capture that frame.
 */
#ifndef DTX_TRANSFER_BH_H
#define DTX_TRANSFER_BH_H

#include "mesh.h"
#include "skinning.h"
#include "status.h"

#include <stdint.h>

typedef struct {
    dtx_skin_params skin; /* lambda, gammas, fit settings; nclusters 0 = m */
} dtx_bh_params;

void dtx_bh_params_default(dtx_bh_params *p);

typedef struct dtx_bh_plan dtx_bh_plan;

/* What a plan holds, for reports. */
typedef struct {
    int32_t keys;            /* m */
    int32_t clusters;
    double weights_seconds;  /* both meshes' bounded biharmonic weights */
    int weights_given;       /* 1: both were given (dtx_bh_plan_create_weights) */
    double align_scale;      /* the target-to-source similarity's scale */
    double align_rms;        /* RMS distance of the aligned target key points
                                to the source key points, / source diagonal */
} dtx_bh_info;

/* Builds the plan.  src_keys, tgt_keys: m >= 1 vertex indices each (key k
 * of the source corresponds to key k of the target); distinct within each
 * mesh; every connected component of each mesh needs a key point (bounded
 * biharmonic weights).  ntrain >= 0 training frames Xtrain (ntrain x
 * nv_src x 3) for the clustering (NULL when 0).  Errors name the key point
 * or mesh: DTX_EINVAL, DTX_ERANGE, DTX_EMESH, DTX_ENONFINITE, DTX_ENOMEM,
 * DTX_ESOLVE. */
dtx_status dtx_bh_plan_create(const dtx_mesh *src, const dtx_mesh *tgt, const int32_t *src_keys,
                              const int32_t *tgt_keys, int32_t m, const dtx_bh_params *prm,
                              int32_t ntrain, const double *Xtrain, dtx_bh_plan **out,
                              dtx_error *err);
/* The same with the bounded biharmonic weights of either mesh given
 * (src_weights nv_src x m, tgt_weights nv_tgt x m, as dtx_bbw computes
 * them for src_keys and tgt_keys, copied), or NULL to have them computed:
 * for a caller that computed them already, or shared the work out. */
dtx_status dtx_bh_plan_create_weights(const dtx_mesh *src, const dtx_mesh *tgt,
                                      const int32_t *src_keys, const int32_t *tgt_keys, int32_t m,
                                      const dtx_bh_params *prm, int32_t ntrain,
                                      const double *Xtrain, const double *src_weights,
                                      const double *tgt_weights, dtx_bh_plan **out,
                                      dtx_error *err);
void dtx_bh_plan_free(dtx_bh_plan **plan);
void dtx_bh_plan_info(const dtx_bh_plan *plan, dtx_bh_info *info);
int32_t dtx_bh_plan_nv_src(const dtx_bh_plan *plan);
int32_t dtx_bh_plan_nv_tgt(const dtx_bh_plan *plan);

/* Transfers nframes source frames Xs (nframes x nv_src x 3) into Xt
 * (nframes x nv_tgt x 3); residual (nframes, may be NULL) as in the file
 * comment.  OpenMP over frames (the fit's); bitwise independent of the
 * thread count and of how frames are split across calls.  Errors:
 * DTX_ENONFINITE (a non-finite source coordinate; nothing written),
 * DTX_ENOMEM. */
dtx_status dtx_bh_apply(const dtx_bh_plan *plan, int64_t nframes, const double *Xs, double *Xt,
                        double *residual, dtx_error *err);

#endif /* DTX_TRANSFER_BH_H */
