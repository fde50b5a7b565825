/*
 * cmd_render.h: `dtx render`, pictures of meshes, sequences and results
 * (PNG; src/io/render.h draws them).
 */
#ifndef DTX_CMD_RENDER_H
#define DTX_CMD_RENDER_H

#include "status.h"

/* Runs `dtx render` with main's argc/argv (argv[1] == "render").  Returns
 * the exit status: 0 on success, 1 on an error (message on stderr, no
 * output file left), 2 on a usage error. */
int dtx_cmd_render(int argc, char **argv);

/* As dtx_cmd_render, for a caller that reports the outcome itself (`dtx
 * report`): an error's message goes into *err instead of stderr (warnings
 * still go to stderr).  Returns 0, 1 (error, *err set) or 2 (bad arguments,
 * *err set). */
int dtx_render_sheet(int argc, char **argv, dtx_error *err);

#endif /* DTX_CMD_RENDER_H */
