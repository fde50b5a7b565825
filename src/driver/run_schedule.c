/*
 * run_schedule.c: which frame groups of a result are still to do and how
 * they are dealt to the ranks: pure functions on flat arrays, no MPI and
 * no HDF5 (tests/driver/test_run_schedule.c runs them without mpirun).
 */
#include "run_schedule.h"

#include "driver.h"

/* The groups (of align frames) with a frame not done. */
void run_groups_todo(const uint8_t *done, int64_t nframes, int align, int64_t *todo, int64_t *ntodo,
                     int64_t *skipped)
{
    int64_t ng = (nframes + align - 1) / align;
    *ntodo = *skipped = 0;
    for (int64_t g = 0; g < ng; g++) {
        int64_t f0 = g * align, f1 = f0 + align, all = 1;
        f1 = f1 < nframes ? f1 : nframes;
        for (int64_t f = f0; f < f1; f++)
            all &= done[f] == 1;
        if (all)
            *skipped += f1 - f0;
        else
            todo[(*ntodo)++] = g;
    }
}

/* The groups todo[a .. b) of one rank cut into segments: runs of
 * consecutive groups of at most gpb groups.  Returns the number of
 * segments; with seg != NULL stores segment k's first index into todo in
 * seg[k] (seg[nseg] = b). */
int64_t run_segments(const int64_t *todo, int64_t a, int64_t b, int64_t gpb, int64_t *seg)
{
    int64_t n = 0, len = 0;
    for (int64_t k = a; k < b; k++) {
        if (k == a || todo[k] != todo[k - 1] + 1 || len == gpb) {
            if (seg)
                seg[n] = k;
            n++;
            len = 0;
        }
        len++;
    }
    if (seg)
        seg[n] = b;
    return n;
}

/* The range [a, b) of todo that rank q deals with.  The ranks are rotated
 * by `rot` so that the remainders of many short sequences do not all land
 * on the first ranks. */
void run_rank_range(int64_t ntodo, int nranks, int q, int rot, int64_t *a, int64_t *b)
{
    int64_t first, count;
    dtx_partition_frames(ntodo, 1, nranks, (q - rot % nranks + nranks) % nranks, &first, &count);
    *a = first;
    *b = first + count;
}
