/*
 * cmd_validate.c: `dtx validate FILE.h5`, the schema check of a dtx file
 * (src/io/h5validate.c): its report on stdout.
 */
#include "cmd_validate.h"

#include "cli_util.h"
#include "options.h"

#include "dtx_core.h"
#include "h5layout.h"

#include <stdio.h>
#include <stdlib.h>

int dtx_cmd_validate(int argc, char **argv)
{
    char *report = NULL;
    dtx_error err;
    dtx_status st;
    if (argc != 3)
        return dtx_cli_usage_rank0(dtx_cli_find_name("validate"), "validate needs one file");
    st = dtx_h5_validate(argv[2], &report, &err);
    if (report)
        fputs(report, stdout);
    free(report);
    return st == DTX_OK ? 0 : dtx_cli_fail(&err);
}
