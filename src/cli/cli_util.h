/*
 * cli_util.h: what several `dtx` commands print the same way (a usage error,
 * "dtx: error: ...", "dtx: warning: ...") and the simple option lookup of
 * the import commands and run.  Everything goes to stderr; nothing here
 * keeps state, so it is as thread-safe as stdio.
 */
#ifndef DTX_CLI_UTIL_H
#define DTX_CLI_UTIL_H

#include "dtx_core.h"
#include "options.h"

/* 1 on an MPI rank other than 0 (OMPI_COMM_WORLD_RANK set and not "0"):
 * under mpirun every rank would print the same usage error, so only rank 0
 * does. */
int dtx_cli_quiet_rank(void);

/* Prints "dtx: MSG" (nothing when msg is NULL), then the usage of command c,
 * or the overview of every command when c is NULL, on stderr.  Returns 2,
 * the exit status of a usage error. */
int dtx_cli_usage(const dtx_cli_cmd *c, const char *msg);

/* dtx_cli_usage() on rank 0 only (see dtx_cli_quiet_rank); returns 2. */
int dtx_cli_usage_rank0(const dtx_cli_cmd *c, const char *msg);

/* Prints "dtx: error: " and err->msg on stderr.  Returns 1, the exit status
 * of an error. */
int dtx_cli_fail(const dtx_error *err);

/* A dtx_warner callback (ctx unused): prints "dtx: warning: MSG" on stderr. */
void dtx_cli_print_warning(void *ctx, const char *msg);

/* MPI_Init_thread (MPI_THREAD_FUNNELED) for a command run under MPI.  A
 * process started without a launcher (no mpirun: none of the variables
 * OMPI_COMM_WORLD_SIZE, PMIX_RANK, PMI_RANK is set) is an MPI singleton,
 * for which OpenMPI would fork a helper daemon (orted) first; dtx never
 * spawns or connects to other jobs, so it asks for an isolated singleton
 * instead (OMPI_MCA_ess_singleton_isolated=1, unless the user set it):
 * 0.1 s less at every start (0.8 s under the sanitizers) and one process
 * fewer.  Its session directory goes below a fresh
 * $TMPDIR/dtx-mpi-HOST-PID-XXXXXX (unless OMPI_MCA_orte_tmpdir_base is set),
 * removed at exit, so that concurrent singletons never share one; those
 * that killed singletons of this host left are removed first. */
void dtx_cli_mpi_init(int *argc, char ***argv);

/* Ends a command run under MPI (MPI_Finalize) and returns its exit status:
 * 0 when st is DTX_OK, else 1.  After a failed write (disk full) HDF5 can
 * still hold a file it could not close, and its exit handler would crash
 * closing it again after MPI_Finalize: then this leaves at once with
 * _exit() (stdio flushed), without running exit handlers. */
int dtx_cli_mpi_finish(dtx_status st);

/* The value following the first argv[i] equal to name, or NULL. */
const char *dtx_cli_opt_value(int argc, char **argv, const char *name);

/* A valued option that a command's parser stores in a `const char *` field
 * of its argument struct: the option's name and the field's offset. */
typedef struct {
    const char *name;
    size_t off;
} dtx_cli_slot;

/* When argv[*i] names one of the nslots slots, stores the value after it in
 * that field of args and moves *i onto the value.  Returns 1 when stored, 0
 * when argv[*i] names no slot, and -1 with "CMD: NAME needs a value" (also
 * for an empty value when reject_empty) or "CMD: NAME given twice" in buf
 * (n bytes). */
int dtx_cli_take_slot(const char *cmd, const dtx_cli_slot *slots, size_t nslots, int reject_empty,
                      void *args, int argc, char **argv, int *i, char *buf, size_t n);

/* The positional arguments of argv[from..]: neither an option ("--x"), nor
 * the value of an option that takes one (by the command's option table,
 * options.h; for a command line no table names, by a list of the import and
 * run options that take a value).  Stores
 * at most cap of them in out and returns how many there are (which may be
 * more than cap). */
int dtx_cli_positionals(int argc, char **argv, int from, char **out, int cap);

#endif /* DTX_CLI_UTIL_H */
