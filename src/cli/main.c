/*
 * main.c: the `dtx` command.  Checks the command line against the option
 * table (options.h), answers help and version, and hands the rest to the
 * command's cmd_*.c.  Exit status 0 on success, 1 on any error (with
 * "dtx: error: ..." on stderr), 2 on a usage error.
 */
#include "cli_util.h"
#include "cmd_diff.h"
#include "cmd_export.h"
#include "cmd_generate.h"
#include "cmd_import.h"
#include "cmd_inspect.h"
#include "cmd_keypoints.h"
#include "cmd_render.h"
#include "cmd_report.h"
#include "cmd_rm.h"
#include "cmd_run.h"
#include "cmd_validate.h"
#include "cmd_view.h"
#include "dtx_core.h"
#include "h5layout.h"
#include "options.h"

#include <signal.h>
#include <stdio.h>
#include <string.h>

/* The command being run (for its usage text), set by main(). */
static const dtx_cli_cmd *current_cmd;

/* dtx help [COMMAND...], dtx --help */
static int cmd_help(int argc, char **argv)
{
    const dtx_cli_cmd *c;
    if (argc <= 2 || argv[1][0] == '-') {
        dtx_cli_print_overview(stdout);
        return 0;
    }
    /* "help import mesh" finds "import mesh"; "help import" the first import. */
    if (!(c = dtx_cli_find(argc - 1, argv + 1)) && !(c = dtx_cli_find_name(argv[2]))) {
        fprintf(stderr, "dtx: help: unknown command '%s'\n", argv[2]);
        dtx_cli_print_overview(stderr);
        return 2;
    }
    dtx_cli_print_help(stdout, c);
    return 0;
}

/* Checks the options of argv against its command's table: 0 to go on, or the
 * exit status (0 after --help, 2 after a usage error) with *done set. */
static int check_options(int argc, char **argv, int *done)
{
    char msg[512];
    int r;
    *done = 0;
    if (!(current_cmd = dtx_cli_find(argc, argv)))
        return 0;
    r = dtx_cli_check(current_cmd, argc, argv, msg, sizeof msg);
    if (r == 0)
        return 0;
    *done = 1;
    if (r == 1) {
        if (!dtx_cli_quiet_rank())
            dtx_cli_print_help(stdout, current_cmd);
        return 0;
    }
    if (!dtx_cli_quiet_rank()) {
        fprintf(stderr, "%s\n", msg);
        dtx_cli_print_usage(stderr, current_cmd);
    }
    return 2;
}

int main(int argc, char **argv)
{
    int done, rc;
    if (argc < 2)
        return dtx_cli_usage_rank0(NULL, NULL); /* the overview */
    if (strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0 ||
        (strcmp(argv[1], "help") == 0 && argc > 2 && argv[2][0] != '-'))
        return cmd_help(argc, argv);
    rc = check_options(argc, argv, &done);
    if (done)
        return rc;
    if (strcmp(argv[1], "version") == 0 || strcmp(argv[1], "--version") == 0) {
        printf("dtx %s\n", DTX_VERSION);
        return 0;
    }
    if (strcmp(argv[1], "help") == 0)
        return cmd_help(argc, argv);
    /* A file-size limit (ulimit -f) must make a write fail with EFBIG and
     * a message, not kill the process half-way. */
    signal(SIGXFSZ, SIG_IGN);
    dtx_h5_init();
    if (strcmp(argv[1], "import") == 0)
        return dtx_cmd_import(argc, argv);
    if (strcmp(argv[1], "run") == 0)
        return dtx_cmd_run(argc, argv);
    if (strcmp(argv[1], "keypoints") == 0)
        return dtx_cmd_keypoints(argc, argv);
    if (strcmp(argv[1], "export") == 0)
        return dtx_cmd_export(argc, argv);
    if (strcmp(argv[1], "inspect") == 0)
        return dtx_cmd_inspect(argc, argv);
    if (strcmp(argv[1], "validate") == 0)
        return dtx_cmd_validate(argc, argv);
    if (strcmp(argv[1], "diff") == 0)
        return dtx_cmd_diff(argc, argv);
    if (strcmp(argv[1], "render") == 0)
        return dtx_cmd_render(argc, argv);
    if (strcmp(argv[1], "report") == 0)
        return dtx_cmd_report(argc, argv);
    if (strcmp(argv[1], "generate") == 0)
        return dtx_cmd_generate(argc, argv);
    if (strcmp(argv[1], "rm") == 0)
        return dtx_cmd_rm(argc, argv);
    if (strcmp(argv[1], "view") == 0)
        return dtx_cmd_view(argc, argv);
    fprintf(stderr, "dtx: unknown command '%s'\n\n", argv[1]);
    dtx_cli_print_overview(stderr);
    return 2;
}
