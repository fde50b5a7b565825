/*
 * cmd_generate.h: the `dtx generate` subcommand (multi-component test
 * targets from one mesh: pebbles, garment, eyes; see src/gen/generate.h).
 */
#ifndef DTX_CMD_GENERATE_H
#define DTX_CMD_GENERATE_H

/* Runs `dtx generate KIND IN OUT [options]` with argv[1] == "generate".
 * Prints what it made (or "dtx: error: ..." / a usage message) on stderr.
 * Returns the exit status: 0 on success, 1 on an error (no output file is
 * left behind), 2 on a usage error (nothing is read or written). */
int dtx_cmd_generate(int argc, char **argv);

#endif /* DTX_CMD_GENERATE_H */
