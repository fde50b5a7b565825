/*
 * keypoint_setup.h: the key points of a biharmonic transfer, between the
 * core's selection (keypoints.h) and its users (`dtx run` with method
 * biharmonic, `dtx keypoints`): which frames they are selected on, the
 * selection split over MPI ranks, their mapping onto a target through an
 * sp04 correspondence, their labels, and the table a user reads.
 *
 * Conventions: vertex indices are 0-based; V, X are n x 3 row-major
 * doubles.  Outputs are caller-allocated unless a function says it
 * allocates.  Functions that take a communicator are collective over it
 * and return the same status on every rank; the others are thread-safe
 * and do no MPI.
 */
#ifndef DTX_KEYPOINT_SETUP_H
#define DTX_KEYPOINT_SETUP_H

#include "h5layout.h"
#include "keypoints.h"
#include "markers.h"
#include "mesh.h"
#include "status.h"

#include <mpi.h>

#include <stdint.h>
#include <stdio.h>

/* A key point is labelled after a source marker within this many mean
 * edge lengths of the source mesh. */
#define DTX_KP_NEAR_EDGES 3.0

/* The training frames: n = min(want, total) frames evenly spaced over
 * total >= 1 frames (frames numbered across a job's sequences in job
 * order): frame i of n is round(i (total - 1) / (n - 1)) (0 when n == 1),
 * rounding halves up, written to idx[0 .. n) (idx may be NULL).  Returns
 * n (0 when total < 1 or want < 1). */
int32_t dtx_training_frames(int64_t total, int32_t want, int64_t *idx);

/* Reads the training frames of the nseq sequences seqs (frames numbered
 * across them in order; every sequence with nv vertices) into *X, newly
 * allocated (*ntrain x nv x 3); *ntrain = dtx_training_frames(total, want).
 * Independent (any rank alone may call).  Errors: those of
 * dtx_h5_seq_read, DTX_EINVAL (no frames), DTX_ENOMEM. */
dtx_status dtx_read_training_frames(const dtx_h5_seq *const *seqs, int nseq, int32_t want,
                                    int32_t *ntrain, double **X, dtx_error *err);

/* dtx_keypoints_select on every rank of comm, each evaluating its share of
 * the candidates (part_index = rank, part_count = ranks; the parts' errors
 * combined by an MPI_Allreduce with MPI_MIN), so every rank gets the same
 * result, bitwise the same for any number of ranks and threads.  p's part
 * and reduce fields are ignored.  Collective; on failure every rank
 * returns the status and message of the lowest failing rank. */
dtx_status dtx_keypoints_select_comm(const dtx_mesh *src, int32_t nframes, const double *X,
                                     const dtx_kp_params *p, MPI_Comm comm, dtx_kp_result *res,
                                     dtx_error *err);

/* Maps m source key vertices onto the target: tgt_vertex[k] is the target
 * vertex (of those in a face; lowest index on ties) nearest to
 * deformed_src[keys[k]], the key's position on the source deformed onto
 * the target (an sp04 correspondence's deformed_src, nv_src x 3).
 * dup[k] is the first earlier key mapped to the same target vertex, or -1
 * (the caller keeps the first and drops the others).  O(m nv_t).  Errors:
 * DTX_ERANGE (a key out of [0, nv_src)), DTX_EMESH (target without faces),
 * DTX_ENOMEM. */
dtx_status dtx_keypoints_map(const double *deformed_src, int32_t nv_src, const dtx_mesh *tgt,
                             const int32_t *keys, int32_t m, int32_t *tgt_vertex, int32_t *dup,
                             dtx_error *err);

/* For each of the m key vertices, the source marker of mk nearest to it on
 * the rest source (Euclidean; lowest marker on ties): marker[k] its index
 * in mk (-1 when mk is NULL or empty) and dist[k] the distance (INFINITY
 * then).  Marker source vertices must be in range of src. */
void dtx_keypoints_nearest_markers(const dtx_mesh *src, const dtx_markers *mk, const int32_t *keys,
                                   int32_t m, int32_t *marker, double *dist);

/* The label of key k (0-based; printed 1-based): "key K", plus " near L"
 * when its nearest marker (index marker, at distance dist) has a non-empty
 * label L and lies within near distance.  Written into buf[n]. */
void dtx_keypoint_label(int32_t k, const dtx_markers *mk, int32_t marker, double dist, double near,
                        char *buf, size_t n);

/* The key points as a marker set *out (allocated here; free with
 * dtx_markers_free): key k goes from keys[k] to tgt_vertex[k] (tgt_vertex
 * NULL: target -1, for a set without a target side yet), skipping the keys
 * with dup[k] >= 0 (dup may be NULL); labels as dtx_keypoint_label with mk
 * the source markers for the "near" part (may be NULL).  Errors:
 * DTX_ENOMEM, DTX_EINVAL (every key dropped). */
dtx_status dtx_keypoints_marker_set(const dtx_mesh *src, const int32_t *keys,
                                    const int32_t *tgt_vertex, const int32_t *dup, int32_t m,
                                    const dtx_markers *mk, dtx_markers *out, dtx_error *err);

/* Prints the key points as a table, one row per key: its number (1-based),
 * source vertex, rest position, the nearest source marker's label and
 * distance (with mk), and the target vertex (with tgt_vertex; "dropped"
 * where dup[k] >= 0).  Lines start with prefix. */
void dtx_keypoints_print_table(FILE *f, const char *prefix, const dtx_mesh *src,
                               const int32_t *keys, int32_t m, const dtx_markers *mk,
                               const int32_t *tgt_vertex, const int32_t *dup);

/* The selection's error after each step, as stored in a key-point group:
 * the first key points alone, then res->trace (each addition, then each
 * accepted replacement).  steps: 1 + res->ntrace entries.  Returns the
 * number written. */
int32_t dtx_keypoints_steps(const dtx_kp_result *res, double *steps);

/* Prints the selection: counts, the error after each step and the final
 * errors, in lines starting with prefix. */
void dtx_keypoints_print_steps(FILE *f, const char *prefix, const dtx_kp_result *res, double eps);

#endif /* DTX_KEYPOINT_SETUP_H */
