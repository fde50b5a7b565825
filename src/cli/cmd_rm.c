/*
 * cmd_rm.c: `dtx rm FILE.h5 PATH...`.  Checks the paths, then removes the
 * objects together, or none when one of them cannot go (src/io/h5remove.h).
 */
#include "cmd_rm.h"

#include "cli_util.h"
#include "h5remove.h"
#include "options.h"

#include <stdio.h>
#include <string.h>

int dtx_cmd_rm(int argc, char **argv)
{
    dtx_error err;
    const char *const *paths = (const char *const *)argv + 3;
    int n = argc - 3;
    if (argc < 4)
        return dtx_cli_usage(dtx_cli_find_name("rm"),
                             "rm needs a file and at least one object path");
    for (int i = 0; i < n; i++)
        if (paths[i][0] != '/' || strstr(paths[i], "//") || paths[i][strlen(paths[i]) - 1] == '/') {
            fprintf(stderr, "dtx: rm: '%s' is not an object path such as /meshes/cat or "
                            "/results/lion/cat-poses\n",
                    paths[i]);
            dtx_cli_print_usage(stderr, dtx_cli_find_name("rm"));
            return 2;
        }
    if (dtx_h5_remove_objects(argv[2], paths, n, &err) != DTX_OK)
        return dtx_cli_fail(&err);
    for (int i = 0; i < n; i++)
        printf("removed %s\n", paths[i]);
    return 0;
}
