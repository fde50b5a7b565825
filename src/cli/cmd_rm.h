/*
 * cmd_rm.h: `dtx rm FILE.h5 PATH...`, removing objects from a dtx file
 * (src/io/h5remove.h).
 */
#ifndef DTX_CMD_RM_H
#define DTX_CMD_RM_H

/* Runs `dtx rm` with main's argc/argv (argv[1] == "rm").  Returns the exit
 * status: 0 when every object was removed, 1 on an error (nothing removed;
 * message on stderr), 2 on a usage error. */
int dtx_cmd_rm(int argc, char **argv);

#endif /* DTX_CMD_RM_H */
