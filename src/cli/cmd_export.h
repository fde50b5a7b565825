/*
 * cmd_export.h: `dtx export`, a result or a sequence of a dtx HDF5 file as
 * OBJ frames, a PC2 point cache (src/io/pc2.h) and/or a glTF binary
 * (src/io/gltf.h).
 */
#ifndef DTX_CMD_EXPORT_H
#define DTX_CMD_EXPORT_H

/* Runs `dtx export` with main's argc/argv (argv[1] == "export").  Returns
 * the exit status: 0 on success, 1 on an error (message on stderr; no
 * partial output file is left), 2 on a usage error. */
int dtx_cmd_export(int argc, char **argv);

#endif /* DTX_CMD_EXPORT_H */
