/*
 * cmd_run.c: `dtx run JOB.json`, a transfer job run by the driver
 * (src/driver/driver.h), alone or under mpirun.
 */
#include "cmd_run.h"

#include "cli_util.h"
#include "options.h"

#include "driver.h"
#include "dtx_core.h"

#include <string.h>

int dtx_cmd_run(int argc, char **argv)
{
    dtx_run_opts o;
    dtx_error err;
    dtx_status st;
    char *pos[2];
    int rank = 0;
    memset(&o, 0, sizeof o);
    if (dtx_cli_positionals(argc, argv, 2, pos, 2) != 1)
        return dtx_cli_usage_rank0(dtx_cli_find_name("run"), "run needs one job file");
    for (int i = 2; i < argc; i++)
        if (strcmp(argv[i], "--quiet") == 0)
            o.quiet = 1;
        else if (strcmp(argv[i], "--resume") == 0)
            o.resume = 1;
        else if (strcmp(argv[i], "--break-lock") == 0)
            o.break_lock = 1;
        else if (strcmp(argv[i], "--correspond-only") == 0)
            o.correspond_only = 1;
    o.summary_path = dtx_cli_opt_value(argc, argv, "--summary");
    o.store_dir = dtx_cli_opt_value(argc, argv, "--store");
    if (o.store_dir && !o.store_dir[0])
        return dtx_cli_usage_rank0(dtx_cli_find_name("run"), "--store needs a directory");
    dtx_cli_mpi_init(&argc, &argv);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    st = dtx_run_job(pos[0], MPI_COMM_WORLD, &o, &err);
    if (st != DTX_OK && rank == 0)
        dtx_cli_fail(&err);
    return dtx_cli_mpi_finish(st);
}
