/*
 * run_internal.h: private to src/driver/run*.c, the files of `dtx run`
 * (run.c reads as the numbered list of phases; see its top comment for
 * which file holds which phase).  Not part of the driver's interface
 * (driver.h).
 *
 * Naming: a function one run*.c file exports to the others is called
 * run_<what> and declared here, grouped by the file that defines it;
 * helpers only one file uses stay `static` there without the prefix.
 * The pure scheduling functions (no MPI, no HDF5) are in run_schedule.h.
 *
 * Every function taking a run_state is called on every rank of r->comm
 * unless its comment says "rank 0"; those returning a status agreed with
 * run_agree() return the same status on every rank.
 */
#ifndef DTX_RUN_INTERNAL_H
#define DTX_RUN_INTERNAL_H

#include "driver.h"

#include "dtx_core.h"
#include "h5layout.h"
#include "job.h"
#include "keypoint_setup.h"
#include "keypoints.h"
#include "output_lock.h"
#include "progress.h"
#include "run_schedule.h"
#include "transfer.h"
#include "weld_setup.h"

#include <mpi.h>

#include <stdint.h>

/* OpenBLAS's own call, when that is the BLAS we run on: BLAS stays
 * single-threaded because threads come from OpenMP and ranks. */
extern void openblas_set_num_threads(int n) __attribute__((weak));

/* Seconds of a rank's phases (wall clock).  output: the output created or
 * reopened and its frames still to do counted; write: the frame loop's
 * writes; finish: results marked complete, the file closed and renamed;
 * wait: the frame loop waiting for other ranks (block agreements, the
 * agreement after the factorisation); cpu sets them against the CPU time
 * the rank got (on a shared machine, a wall time well above it).  Gathered from every rank into the
 * summary's seconds_per_rank (run_summary.c). */
typedef struct {
    double read, keypoints, correspond, factor, output, transfer, write, finish, wait, total;
    double cpu; /* the process's CPU seconds (user + system, every thread) at the summary */
} phase_times;

/* Residual statistics of the frames transferred by this run. */
typedef struct {
    int64_t frames;
    double sum, sumsq, min, max;
} run_stats;

/* Iterative methods (springs' Newton, multicomponent's Gauss-Newton): the
 * solves of a result's frames done by this run (reduced onto rank 0 at the
 * end). */
typedef struct {
    int64_t frames, iterations; /* frames solved, (fine-level) iterations summed */
    int64_t unconverged;        /* frames that stopped without meeting the test */
    int64_t first_unconverged;  /* the lowest of them, or INT64_MAX */
    int64_t inverted_frames;    /* frames with inverted triangles (where counted) */
    int64_t max_inverted;       /* most inverted triangles in a frame */
    int64_t max_inverted_frame; /* that frame (the lowest on ties), or INT64_MAX */
    int64_t max_iterations;
    double max_grad_norm;        /* largest final gradient norm of a frame, or -1
                                    (methods that report it: reports_grad_norm) */
    int64_t max_grad_norm_frame; /* that frame (the lowest on ties), or INT64_MAX */
} solve_stats;

typedef enum { OUT_FRESH, OUT_RESUME, OUT_DONE } out_mode;

enum { RUN_CORR_COMPUTED = 0, RUN_CORR_CACHED = 1, RUN_CORR_STORE = 3 };

typedef struct {
    const dtx_job_target *tj;
    dtx_mesh mesh;
    dtx_markers mk;
    dtx_corr corr;
    char key[17];
    int reused;    /* where the correspondence came from: RUN_CORR_COMPUTED,
                      RUN_CORR_CACHED (the output's or partial's cache) or
                      RUN_CORR_STORE (the correspondence store) */
    int same_conn; /* methods with a proxy (springs): the source's vertices
                      and faces (no correspondence, no markers needed) */
    int owner;     /* rank that computes it */
    char mesh_path[DTX_H5_PATH_MAX], corr_path[DTX_H5_PATH_MAX];
    /* methods with key points (biharmonic): the key points (source ->
     * target vertex) as a marker set, stored in the output at kp_path */
    dtx_markers keys;
    char kp_path[DTX_H5_PATH_MAX];
    /* and their bounded biharmonic weights (run_weights.c), nv x m on the
     * source and on the target, owned, with their cache keys and whether
     * they came from a cache file */
    double *Ws, *Wt;
    char ws_key[17], wt_key[17];
    int ws_cached, wt_cached;
    dtx_weld_ctx weld; /* the asset's vertices (mesh is welded along seams) */
} target_ctx;

typedef struct {
    const char *path; /* HDF5 path in the source file */
    const char *name; /* result name: the path's last component */
    dtx_h5_seq seq;
    int open;
} seq_ctx;

typedef struct {
    dtx_h5_result res;
    int open;
    int finished; /* already complete in the resumed partial */
    run_stats st;
    solve_stats sv;
} result_ctx;

typedef struct {
    MPI_Comm comm;
    int rank, nranks, nthreads;
    int align; /* frames per group: rank ranges, blocks and result chunks are
                  whole groups (sp04's solve group; 1 for springs, whose
                  frames are independent and expensive, so that few frames
                  still spread over the ranks) */
    const dtx_run_opts *opts;
    dtx_job job;
    const dtx_transfer_method *method; /* the job's method (transfer.h) */
    dtx_transfer_params prm;           /* and its parameters */
    dtx_mesh src;
    dtx_weld_ctx src_weld; /* the source asset's vertices (src is welded) */
    hid_t src_file, out;
    char partial[4200];
    char partial_new[4300]; /* OUTPUT.partial.new: the partial before its rename */
    char run_key[17];
    dtx_output_lock lock; /* rank 0: OUTPUT.lock, held from take_output to the end */
    out_mode mode;
    int nt, ns;
    target_ctx *tg;
    seq_ctx *sq;
    char **seq_paths; /* the job's sequences, wildcards expanded: ns paths */
    result_ctx *rs;   /* nt x ns, result of target t and sequence s at t * ns + s */
    phase_times tm;
    run_stats stats;
    /* methods with key points (biharmonic): the training frames (every
     * rank) and, with keypoints "auto", the key points selected on them */
    int32_t ntrain;
    double *Xtrain;
    dtx_kp_result kp;
    char kp_key[17]; /* cache key of the selection (keypoints "auto") */
    int kp_cached;   /* the key points and their weights came from a cache */
    int64_t frames_todo, frames_skipped, frames_done; /* global, known on rank 0 */
    dtx_progress prog;
} run_state;

#define RESULT(r, t, s) (&(r)->rs[(size_t)(t) * (size_t)(r)->ns + (size_t)(s)])

/* run_common.c: small helpers. */

/* Collective agreement on a phase's outcome (mpi_util.h, naming the
 * failing rank when it is not rank 0). */
dtx_status run_agree(MPI_Comm comm, dtx_status st, dtx_error *err);
/* Wall-clock seconds (MPI_Wtime). */
double run_wtime(void);
/* DTX_EIO when DTX_FAULT=PHASE@RANK names this phase and rank, else DTX_OK. */
dtx_status run_injected_fault(const run_state *r, const char *phase, dtx_error *err);
/* A message from rank 0 on stderr (not with --quiet); a no-op elsewhere. */
void run_say(run_state *r, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* mkdir -p of the directory part of path (dir_only != 0) or of path. */
dtx_status run_make_dirs(const char *path, int dir_only, dtx_error *err);
/* 1 when the job's method builds on a correspondence (r->method's
 * correspondence): for its pairs, its proxies, or to map key points
 * selected on the source (keypoints "auto"); 0 when it needs none (key
 * points from markers).  A target with the source's vertices and faces
 * needs none either way (target_ctx.same_conn). */
int run_uses_correspondence(const run_state *r);
/* The provenance of target tc's correspondence as its HDF5 group records it
 * (meta: key, source and target mesh and markers as text, params); the
 * strings live in d. */
typedef struct {
    char source[4200], target[4200], markers[4200];
} run_corr_desc;
void run_corr_meta(const run_state *r, const target_ctx *tc, const char *params,
                   run_corr_desc *d, dtx_h5_corr_meta *meta);

/* run_inputs.c: phases 1 and 2. */

/* Rank 0 loads and checks the job file; every rank parses its text. */
dtx_status run_load_job(MPI_Comm comm, const char *path, dtx_job *job, dtx_error *err);
/* Every rank reads the source, the targets, the sequences; sets r->run_key. */
dtx_status run_read_inputs(run_state *r, dtx_error *err);

/* run_output.c: the output's lifecycle (phases 1, 3, 5 and 7). */

/* Checks the paths the run writes and takes OUTPUT.lock (rank 0). */
dtx_status run_take_output(run_state *r, dtx_error *err);
/* Rank 0, after a failure: keeps, or removes, OUTPUT.partial, and says so. */
void run_partial_fate(run_state *r, const char *job_path, dtx_error *err);
/* Rank 0 decides (fresh output, resume of OUTPUT.partial, or nothing to
 * do) and broadcasts it into r->mode. */
void run_choose_mode(run_state *r);
/* Creates every object of the output up front, or reopens the partial
 * and reads which frames are done; a partial that cannot be continued is
 * started over. */
dtx_status run_open_output(run_state *r, dtx_error *err);
/* Closes every open result handle (not collective). */
void run_close_results(run_state *r);
/* Marks the results complete, closes and renames OUTPUT.partial to OUTPUT. */
dtx_status run_finish_output(run_state *r, dtx_error *err);

/* run_corr.c: key points and correspondences (phases 3b and 4). */

dtx_status run_select_keypoints(run_state *r, dtx_error *err);
dtx_status run_correspondences(run_state *r, dtx_error *err);
dtx_status run_target_keys(run_state *r, dtx_error *err);

/* run_store.c: the correspondence store (src/io/corr_store.h). */

/* The store directory: --store, else the job's correspondence_store, else NULL. */
const char *run_store_dir(const run_state *r);
/* Rank 0 (a no-op elsewhere and without a store): each target with
 * reused[t] == 0 whose correspondence is in the store gets it in tc->corr
 * and reused[t] = RUN_CORR_STORE; a store file that cannot be used is
 * named in a warning and left to be recomputed. */
void run_store_lookup(run_state *r, int *reused);
/* Rank 0 writes every correspondence not taken from the store into it
 * (creating the directory); after run_correspondences. */
dtx_status run_store_save(run_state *r, dtx_error *err);

/* run_weights.c: method biharmonic's bounded biharmonic weights of each
 * target's key points on the source (tc->Ws) and on the target (tc->Wt),
 * once per run before the output is created: found by key in the partial
 * or the old output (as correspondences are), taken from the key-point
 * selection or an earlier target, or computed with the handles shared out
 * over the ranks.  Collective. */
dtx_status run_bh_weights(run_state *r, dtx_error *err);
/* The cache key of weights of handles (m) on a mesh. */
void run_weights_key(const dtx_mesh *mesh, const int32_t *handles, int32_t m, char out[17]);
/* The weights with this key in OUTPUT.partial or OUTPUT (rank 0 reads,
 * every rank receives): when a group there has the key, nv rows, *m
 * handles (any number when *m <= 0; set) equal to handles (when not
 * NULL), *found = 1 and *found_handles (*m) and *W (nv x *m) are
 * allocated; else *found = 0.  A group that does not read back cleanly
 * counts as missing.  Collective. */
dtx_status run_weights_fetch(run_state *r, const char *key, int32_t nv, int32_t *m,
                             const int32_t *handles, int32_t **found_handles, double **W,
                             int *found, dtx_error *err);
/* Rank 0, creating the partial: writes each target's weights as
 * /weights/TARGET-source and /weights/TARGET-target. */
dtx_status run_weights_write(run_state *r, hid_t f, dtx_error *err);
void run_bh_weights_free(run_state *r);

/* run_frames.c: the frame loop (phase 6). */

/* Frames still to do over all results (rank 0's count is the one used). */
dtx_status run_count_todo(run_state *r, dtx_error *err);
dtx_status run_transfer_all(run_state *r, dtx_error *err);

/* run_summary.c: statistics, solves and the summary (phase 8). */

void run_stats_init(run_stats *s);
void run_stats_add(run_stats *s, double v);
void run_solves_init(solve_stats *s);
/* Frame f's solve: into s, and as its frame_stats row (grad_norm: NaN
 * where the method does not report it). */
void run_solves_add(solve_stats *s, int64_t f, int32_t iterations, int converged, int32_t inverted,
                    double grad_norm, int32_t row[DTX_H5_FRAME_STATS]);
/* Adds this rank's statistics of every result to r->stats. */
void run_add_result_stats(run_state *r);
/* Per-result statistics and solves of all ranks onto rank 0, saying how
 * the solves went. */
void run_gather_results(run_state *r);
/* The summary JSON and the last lines (rank 0 writes and prints). */
void run_summarise(run_state *r);

#endif /* DTX_RUN_INTERNAL_H */
