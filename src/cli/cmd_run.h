/*
 * cmd_run.h: `dtx run`, running a transfer job (src/driver/driver.h).
 */
#ifndef DTX_CMD_RUN_H
#define DTX_CMD_RUN_H

/* Runs `dtx run JOB.json [--quiet] [--resume] [--break-lock] [--summary
 * PATH]` with main's argc/argv (argv[1] == "run"), alone or under mpirun:
 * initializes and finalizes MPI.  Returns the exit status: 0 when the job
 * succeeded, 1 on an error (message on stderr from rank 0), 2 on a usage
 * error.  After an HDF5 file that could not be closed it leaves with
 * _exit() instead of returning. */
int dtx_cmd_run(int argc, char **argv);

#endif /* DTX_CMD_RUN_H */
