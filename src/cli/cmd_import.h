/*
 * cmd_import.h: `dtx import mesh|sequence|markers`, adding a mesh, a
 * sequence of frames or a marker set to a dtx file.
 */
#ifndef DTX_CMD_IMPORT_H
#define DTX_CMD_IMPORT_H

/* Runs `dtx import KIND ... -o OUT.h5 --name NAME [options]` with main's
 * argc/argv (argv[1] == "import", argv[2] the kind: mesh, sequence or
 * markers; any other kind prints every import command's usage).  OUT.h5 is
 * created when missing.  Prints what it wrote (or "dtx: error: ..." / a
 * usage message) on stderr.  Returns the exit status: 0 on success, 1 on an
 * error (an OUT.h5 the import created is removed), 2 on a usage error
 * (nothing is read or written). */
int dtx_cmd_import(int argc, char **argv);

#endif /* DTX_CMD_IMPORT_H */
