/*
 * run_schedule.h: how `dtx run` deals the frames of a result to the ranks
 * and which of them a resumed run still has to do.  Pure functions on flat
 * arrays: no MPI, no HDF5, no allocation; thread-safe.
 * (tests/driver/test_run_schedule.c.)
 *
 * Frames are handled in groups of `align` frames (the solve group): group
 * g holds frames [g * align, min((g + 1) * align, nframes)).
 */
#ifndef DTX_RUN_SCHEDULE_H
#define DTX_RUN_SCHEDULE_H

#include <stdint.h>

/* The groups with a frame not done, from done (nframes flags, 1 = done):
 * todo[0 .. *ntodo), increasing; todo holds ceil(nframes / align) entries
 * (caller-allocated).  *skipped counts the frames of the groups that are
 * done in whole. */
void run_groups_todo(const uint8_t *done, int64_t nframes, int align, int64_t *todo, int64_t *ntodo,
                     int64_t *skipped);

/* The groups todo[a .. b) of one rank cut into segments: runs of
 * consecutive groups (todo[k] == todo[k - 1] + 1) of at most gpb groups.
 * Returns the number of segments; with seg != NULL (b - a + 1 entries)
 * stores segment k's first index into todo in seg[k] (seg[nseg] = b). */
int64_t run_segments(const int64_t *todo, int64_t a, int64_t b, int64_t gpb, int64_t *seg);

/* The range [*a, *b) of the ntodo groups that rank q of nranks deals with
 * (dtx_partition_frames with groups of one), the ranks rotated by rot >= 0
 * so that the remainders of many short sequences do not all land on the
 * first ranks.  Over q = 0 .. nranks - 1 the ranges tile [0, ntodo). */
void run_rank_range(int64_t ntodo, int nranks, int q, int rot, int64_t *a, int64_t *b);

#endif /* DTX_RUN_SCHEDULE_H */
