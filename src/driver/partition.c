/*
 * partition.c: which frames each rank owns.  Frames are dealt out in whole
 * solve groups (aligned to the group size), as evenly as possible, the
 * remainder going to the lowest ranks, so that every frame is computed with
 * the same arithmetic whatever the number of ranks.
 */
#include "driver.h"

void dtx_partition_frames(int64_t nframes, int group, int nranks, int rank, int64_t *first,
                          int64_t *count)
{
    int64_t ngroups = (nframes + group - 1) / group;
    int64_t base = ngroups / nranks, rem = ngroups % nranks;
    int64_t g0 = rank * base + (rank < rem ? rank : rem);
    int64_t ng = base + (rank < rem ? 1 : 0);
    int64_t f0 = g0 * group, f1 = (g0 + ng) * group;
    if (f0 > nframes)
        f0 = nframes;
    if (f1 > nframes)
        f1 = nframes;
    *first = f0;
    *count = f1 - f0;
}
