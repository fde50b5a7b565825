/*
 * keypoint_setup.c: key points of a biharmonic transfer between the core's
 * selection and its users (keypoint_setup.h).
 */
#include "keypoint_setup.h"

#include "mpi_util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------ */
/* Training frames                                                     */
/* ------------------------------------------------------------------ */

int32_t dtx_training_frames(int64_t total, int32_t want, int64_t *idx)
{
    int32_t n;
    if (total < 1 || want < 1)
        return 0;
    n = (int64_t)want < total ? want : (int32_t)total;
    for (int32_t i = 0; idx && i < n; i++)
        /* round(i (total - 1) / (n - 1)), halves up, in exact integers. */
        idx[i] = n == 1 ? 0 : ((int64_t)2 * i * (total - 1) + (n - 1)) / ((int64_t)2 * (n - 1));
    return n;
}

dtx_status dtx_read_training_frames(const dtx_h5_seq *const *seqs, int nseq, int32_t want,
                                    int32_t *ntrain, double **X, dtx_error *err)
{
    int64_t total = 0, *idx = NULL;
    int32_t n, nv = nseq > 0 ? seqs[0]->nv : 0;
    dtx_status st = DTX_OK;
    *ntrain = 0;
    *X = NULL;
    for (int s = 0; s < nseq; s++)
        total += seqs[s]->nframes;
    n = dtx_training_frames(total, want, NULL);
    if (n < 1 || nv < 1)
        return dtx_seterr(err, DTX_EINVAL, "no source frames to train on (%lld frames)",
                          (long long)total);
    idx = dtx_alloc((size_t)n, sizeof *idx, 0);
    *X = dtx_alloc((size_t)n * (size_t)nv, 3 * sizeof **X, 0);
    if (!idx || !*X) {
        st = dtx_seterr(err, DTX_ENOMEM, "out of memory for %d training frames", (int)n);
        goto done;
    }
    dtx_training_frames(total, want, idx);
    /* Walk the sequences once: idx is increasing. */
    {
        int s = 0;
        int64_t first = 0; /* number of sequence s's frame 0 */
        for (int32_t i = 0; i < n && st == DTX_OK; i++) {
            while (s < nseq && idx[i] >= first + seqs[s]->nframes)
                first += seqs[s++]->nframes;
            if (s == nseq || seqs[s]->nv != nv) {
                st = dtx_seterr(err, DTX_EINVAL, "training frame %lld: %s", (long long)idx[i],
                                s == nseq ? "past the last sequence" : "vertex counts differ");
                break;
            }
            st = dtx_h5_seq_read(seqs[s], idx[i] - first, 1, *X + (size_t)i * 3 * (size_t)nv, err);
        }
    }
done:
    free(idx);
    if (st != DTX_OK) {
        free(*X);
        *X = NULL;
    } else {
        *ntrain = n;
    }
    return st;
}

/* ------------------------------------------------------------------ */
/* Selection across ranks                                              */
/* ------------------------------------------------------------------ */

static dtx_status reduce_min(void *ctx, double *errs, int32_t n, int local_ok, dtx_error *err)
{
    MPI_Comm comm = *(MPI_Comm *)ctx;
    int ok = local_ok != 0;
    /* Whether every rank got here without failing first: a rank that
     * failed on its own calls with local_ok 0 and n 0. */
    MPI_Allreduce(MPI_IN_PLACE, &ok, 1, MPI_INT, MPI_LAND, comm);
    if (!ok)
        return dtx_seterr(err, DTX_EMPI, "key points: another rank failed");
    if (n > 0 && MPI_Allreduce(MPI_IN_PLACE, errs, (int)n, MPI_DOUBLE, MPI_MIN, comm) !=
                     MPI_SUCCESS)
        return dtx_seterr(err, DTX_EMPI, "key points: combining the ranks' errors failed");
    return DTX_OK;
}

dtx_status dtx_keypoints_select_comm(const dtx_mesh *src, int32_t nframes, const double *X,
                                     const dtx_kp_params *p, MPI_Comm comm, dtx_kp_result *res,
                                     dtx_error *err)
{
    dtx_kp_params q = *p;
    MPI_Comm c = comm;
    dtx_mpi_dealer dealer;
    dtx_status st;
    MPI_Comm_rank(comm, &q.part_index);
    MPI_Comm_size(comm, &q.part_count);
    q.reduce = q.part_count > 1 ? reduce_min : NULL;
    q.reduce_ctx = &c;
    q.claim = NULL;
    memset(&dealer, 0, sizeof dealer);
    /* The final set's bounded weights are dealt out as the ranks ask for
     * them: the programmes take unequal times. */
    if (q.part_count > 1) {
        if ((st = dtx_mpi_dealer_open(&dealer, comm, err)) != DTX_OK) {
            memset(res, 0, sizeof *res);
            return st;
        }
        q.claim = dtx_mpi_dealer_claim;
        q.claim_ctx = &dealer;
    }
    st = dtx_keypoints_select(src, nframes, X, &q, res, err);
    dtx_mpi_dealer_close(&dealer);
    /* A rank whose own failure is the real one wins over ranks that only
     * heard of it from reduce_min ("another rank failed", DTX_EMPI). */
    if ((st = dtx_mpi_agree(st, DTX_AGREE_OWN_FIRST, comm, err)) != DTX_OK)
        dtx_kp_result_free(res);
    return st;
}

/* ------------------------------------------------------------------ */
/* Mapping onto a target                                               */
/* ------------------------------------------------------------------ */

static double dist2(const double *a, const double *b)
{
    double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
    return dx * dx + dy * dy + dz * dz;
}

dtx_status dtx_keypoints_map(const double *deformed_src, int32_t nv_src, const dtx_mesh *tgt,
                             const int32_t *keys, int32_t m, int32_t *tgt_vertex, int32_t *dup,
                             dtx_error *err)
{
    unsigned char *used;
    if (tgt->nf < 1)
        return dtx_seterr(err, DTX_EMESH, "the target mesh has no faces");
    for (int32_t k = 0; k < m; k++)
        if (keys[k] < 0 || keys[k] >= nv_src)
            return dtx_seterr(err, DTX_ERANGE, "key point %d: vertex %d is out of range [0, %d)",
                              (int)k + 1, (int)keys[k], (int)nv_src);
    used = dtx_alloc((size_t)tgt->nv, 1, 1);
    if (!used)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory");
    for (int64_t i = 0; i < 3 * (int64_t)tgt->nf; i++)
        used[tgt->F[i]] = 1;
    for (int32_t k = 0; k < m; k++) {
        const double *p = deformed_src + 3 * (size_t)keys[k];
        double best = INFINITY;
        int32_t bv = -1;
        for (int32_t v = 0; v < tgt->nv; v++) {
            double d;
            if (!used[v])
                continue;
            d = dist2(p, tgt->V + 3 * (size_t)v);
            if (d < best) {
                best = d;
                bv = v;
            }
        }
        tgt_vertex[k] = bv;
        dup[k] = -1;
        for (int32_t j = 0; j < k && dup[k] < 0; j++)
            if (tgt_vertex[j] == bv)
                dup[k] = j;
    }
    free(used);
    return DTX_OK;
}

/* ------------------------------------------------------------------ */
/* Labels                                                              */
/* ------------------------------------------------------------------ */

void dtx_keypoints_nearest_markers(const dtx_mesh *src, const dtx_markers *mk, const int32_t *keys,
                                   int32_t m, int32_t *marker, double *dist)
{
    for (int32_t k = 0; k < m; k++) {
        const double *p = src->V + 3 * (size_t)keys[k];
        double best = INFINITY;
        int32_t bi = -1;
        for (int32_t i = 0; mk && i < mk->n; i++) {
            double d = dist2(p, src->V + 3 * (size_t)mk->src[i]);
            if (d < best) {
                best = d;
                bi = i;
            }
        }
        marker[k] = bi;
        dist[k] = bi >= 0 ? sqrt(best) : INFINITY;
    }
}

void dtx_keypoint_label(int32_t k, const dtx_markers *mk, int32_t marker, double dist, double near,
                        char *buf, size_t n)
{
    const char *l = mk && mk->labels && marker >= 0 && marker < mk->n ? mk->labels[marker] : NULL;
    if (l && l[0] && dist <= near)
        snprintf(buf, n, "key %d near %s", (int)k + 1, l);
    else
        snprintf(buf, n, "key %d", (int)k + 1);
}

dtx_status dtx_keypoints_marker_set(const dtx_mesh *src, const int32_t *keys,
                                    const int32_t *tgt_vertex, const int32_t *dup, int32_t m,
                                    const dtx_markers *mk, dtx_markers *out, dtx_error *err)
{
    int32_t *marker = dtx_alloc((size_t)m, sizeof *marker, 0), kept = 0, j = 0;
    double *dist = dtx_alloc((size_t)m, sizeof *dist, 0);
    double near = DTX_KP_NEAR_EDGES * dtx_mesh_mean_edge(src);
    dtx_status st = DTX_OK;
    memset(out, 0, sizeof *out);
    if (!marker || !dist) {
        st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
        goto done;
    }
    for (int32_t k = 0; k < m; k++)
        kept += !dup || dup[k] < 0;
    if (kept == 0) {
        st = dtx_seterr(err, DTX_EINVAL, "no key points");
        goto done;
    }
    dtx_keypoints_nearest_markers(src, mk, keys, m, marker, dist);
    if ((st = dtx_markers_alloc(out, kept, err)) != DTX_OK)
        goto done;
    for (int32_t k = 0; k < m; k++) {
        char label[512];
        if (dup && dup[k] >= 0)
            continue;
        dtx_keypoint_label(k, mk, marker[k], dist[k], near, label, sizeof label);
        out->src[j] = keys[k];
        out->tgt[j] = tgt_vertex ? tgt_vertex[k] : -1;
        out->labels[j] = malloc(strlen(label) + 1);
        if (!out->labels[j]) {
            st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
            dtx_markers_free(out);
            goto done;
        }
        strcpy(out->labels[j], label);
        j++;
    }
done:
    free(marker);
    free(dist);
    return st;
}

/* ------------------------------------------------------------------ */
/* Reports                                                             */
/* ------------------------------------------------------------------ */

void dtx_keypoints_print_table(FILE *f, const char *prefix, const dtx_mesh *src,
                               const int32_t *keys, int32_t m, const dtx_markers *mk,
                               const int32_t *tgt_vertex, const int32_t *dup)
{
    int32_t *marker = dtx_alloc((size_t)(m > 0 ? m : 1), sizeof *marker, 0);
    double *dist = dtx_alloc((size_t)(m > 0 ? m : 1), sizeof *dist, 0);
    if (!marker || !dist) {
        free(marker);
        free(dist);
        fprintf(f, "%s(out of memory for the table)\n", prefix);
        return;
    }
    dtx_keypoints_nearest_markers(src, mk, keys, m, marker, dist);
    fprintf(f, "%s%4s %8s  %-38s", prefix, "key", "vertex", "position (x y z)");
    if (mk)
        fprintf(f, "  %-30s %10s", "nearest marker", "distance");
    if (tgt_vertex)
        fprintf(f, "  %13s", "target vertex");
    fputc('\n', f);
    for (int32_t k = 0; k < m; k++) {
        const double *p = src->V + 3 * (size_t)keys[k];
        char pos[64];
        snprintf(pos, sizeof pos, "%.6g %.6g %.6g", p[0], p[1], p[2]);
        fprintf(f, "%s%4d %8d  %-38s", prefix, (int)k + 1, (int)keys[k], pos);
        if (mk) {
            const char *l = marker[k] >= 0 && mk->labels ? mk->labels[marker[k]] : NULL;
            char name[64];
            if (marker[k] < 0)
                snprintf(name, sizeof name, "-");
            else if (l && l[0])
                snprintf(name, sizeof name, "%.30s", l);
            else
                snprintf(name, sizeof name, "marker %d", (int)marker[k]);
            fprintf(f, "  %-30s %10.4g", name, marker[k] >= 0 ? dist[k] : 0.0);
        }
        if (tgt_vertex) {
            if (dup && dup[k] >= 0)
                fprintf(f, "  %13s", "dropped");
            else
                fprintf(f, "  %13d", (int)tgt_vertex[k]);
        }
        fputc('\n', f);
    }
    free(marker);
    free(dist);
}

int32_t dtx_keypoints_steps(const dtx_kp_result *res, double *steps)
{
    steps[0] = res->error_first;
    for (int32_t i = 0; i < res->ntrace; i++)
        steps[1 + i] = res->trace[i];
    return 1 + res->ntrace;
}

void dtx_keypoints_print_steps(FILE *f, const char *prefix, const dtx_kp_result *res, double eps)
{
    int32_t adds = res->ntrace - res->replacements, first = res->count - adds;
    fprintf(f, "%s%d key point%s from %d candidates (%lld evaluations here)", prefix,
            (int)res->count, res->count == 1 ? "" : "s", (int)res->ncand,
            (long long)res->evaluations);
    fprintf(f,
            "; error (mean vertex distance, in units of the source radius %.4g) after each "
            "step:\n",
            res->radius);
    fprintf(f, "%s  first %d: %.4g", prefix, (int)first, res->error_first);
    for (int32_t i = 0; i < adds; i++) {
        if (i % 6 == 5)
            fprintf(f, "\n%s ", prefix);
        fprintf(f, ", +key %d: %.4g", (int)(first + i + 1), res->trace[i]);
    }
    fputc('\n', f);
    if (res->replacements > 0) {
        fprintf(f, "%s  %d replacement%s:", prefix, (int)res->replacements,
                res->replacements == 1 ? "" : "s");
        for (int32_t i = adds; i < res->ntrace; i++)
            fprintf(f, " %.4g", res->trace[i]);
        fputc('\n', f);
    }
    fprintf(f, "%s  final error %.4g (eps %.4g%s); with bounded weights %.4g\n", prefix, res->error,
            eps, res->error <= eps ? ", reached" : ", not reached", res->error_exact);
}
