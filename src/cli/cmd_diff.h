/*
 * cmd_diff.h: `dtx diff`, compares the positions of one result in two files.
 */
#ifndef DTX_CMD_DIFF_H
#define DTX_CMD_DIFF_H

/* Runs `dtx diff A.h5 B.h5 /results/... [--tol REL]` with main's argc/argv
 * (argv[1] == "diff").  Returns the exit status: 0 when every frame done in
 * either file is done in both and all their coordinates are finite and
 * agree within REL times the largest coordinate magnitude; 1 when they
 * differ or on an error (message on stderr); 2 on a usage error (a bad
 * --tol included). */
int dtx_cmd_diff(int argc, char **argv);

#endif /* DTX_CMD_DIFF_H */
