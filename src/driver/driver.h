/*
 * driver.h: the MPI/OpenMP batch run of a dtx job.  The driver only
 * orchestrates phases (load, validate, correspond, factor, frame loop,
 * write, verify); the numerics live in src/core and the files in src/io.
 */
#ifndef DTX_DRIVER_H
#define DTX_DRIVER_H

#include "dtx_core.h"
#include "status.h"

#include <mpi.h>

#include <stdint.h>

/* Frame-group size the driver aligns rank ranges and blocks to: the core's
 * solve group, so no group is split between ranks. */
#define DTX_FRAME_ALIGN DTX_SP04_SOLVE_GROUP

/* Frames [first, first + count) owned by `rank` of `nranks` for a sequence
 * of nframes frames, dealt in whole groups of `group` frames.  Every frame
 * is owned by exactly one rank; ranks may own none. */
void dtx_partition_frames(int64_t nframes, int group, int nranks, int rank, int64_t *first,
                          int64_t *count);

/* Options of a run (command-line flags). */
typedef struct {
    int quiet;          /* no progress or summary on stderr */
    const char *summary_path; /* run summary JSON, or NULL for OUTPUT.summary.json */
    int resume;         /* continue OUTPUT.partial of an interrupted run of the same job */
    int break_lock;     /* remove OUTPUT.lock first: the user checked that the run
                           it names is gone (output_lock.h) */
    const char *store_dir; /* correspondence store directory (overrides the job's
                              correspondence_store), or NULL */
    int correspond_only;   /* compute and store the correspondences, transfer nothing
                              (needs a store; the output is not touched) */
} dtx_run_opts;

/* Runs the job file at job_path on every rank of comm (MPI must be
 * initialised; all ranks call).  Rank 0 reads and checks the job and the
 * inputs, computes (or finds in the output's cache) each target's
 * correspondence and broadcasts it; every rank factors the transfer system
 * and transfers its own frames (dtx_partition_frames) in blocks, writing
 * them into the output with collective parallel HDF5.  The output is
 * written to a temporary file renamed over the job's output only at the
 * end.  Every rank returns the same status; err holds the message of the
 * first rank that failed.  Only rank 0 prints. */
dtx_status dtx_run_job(const char *job_path, MPI_Comm comm, const dtx_run_opts *opts,
                       dtx_error *err);

#endif /* DTX_DRIVER_H */
