/*
 * cmd_validate.h: `dtx validate`, checking a dtx file against its schema.
 */
#ifndef DTX_CMD_VALIDATE_H
#define DTX_CMD_VALIDATE_H

/* Runs `dtx validate FILE.h5` with main's argc/argv (argv[1] ==
 * "validate"): prints the report of dtx_h5_validate (src/io/h5layout.h) on
 * stdout.  Returns the exit status: 0 when the file is valid, 1 when it is
 * not or cannot be read (message on stderr), 2 on a usage error. */
int dtx_cmd_validate(int argc, char **argv);

#endif /* DTX_CMD_VALIDATE_H */
