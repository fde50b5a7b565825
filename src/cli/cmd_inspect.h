/*
 * cmd_inspect.h: `dtx inspect`, a readable summary of what a dtx HDF5 file
 * holds (src/io/h5inspect.h collects it).
 */
#ifndef DTX_CMD_INSPECT_H
#define DTX_CMD_INSPECT_H

/* Runs `dtx inspect` with main's argc/argv (argv[1] == "inspect").  Prints
 * the summary on stdout (text, or one JSON document with --json).  Returns
 * the exit status: 0 on success, 1 on an error (a missing file, not HDF5,
 * not the dtx layout: message on stderr), 2 on a usage error.  Read-only. */
int dtx_cmd_inspect(int argc, char **argv);

#endif /* DTX_CMD_INSPECT_H */
