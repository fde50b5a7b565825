/*
 * cmd_keypoints.h: `dtx keypoints`, automatic key-point selection on a
 * source animation (Yang et al. 2018, src/core/keypoints.h), alone or under
 * mpirun (the candidates are split over the ranks).
 */
#ifndef DTX_CMD_KEYPOINTS_H
#define DTX_CMD_KEYPOINTS_H

/* Runs `dtx keypoints` with main's argc/argv (argv[1] == "keypoints");
 * initialises and finalises MPI.  Selects key points on the source's
 * frames, prints them (rank 0, stdout) and writes /keypoints/NAME (NAME
 * defaults to SRC-keys) into FILE.h5 or OUT.h5; with --target and
 * --markers also /markers/NAME-T, the key points mapped onto T through the
 * sp04 correspondence; with --csv a marker CSV of them (an empty target
 * column to fill in without --target).  Returns the exit status, the same
 * on every rank: 0 on success, 1 on an error (message on stderr from rank
 * 0; nothing is written), 2 on a usage error (nothing is read). */
int dtx_cmd_keypoints(int argc, char **argv);

#endif /* DTX_CMD_KEYPOINTS_H */
