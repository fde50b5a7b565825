/*
 * test_run_schedule.c: how `dtx run` deals frame groups to the ranks and
 * which groups a resumed run still does (run_schedule.h).  Pure functions
 * only: no MPI_Init, no HDF5, so it runs without mpirun.
 *  - Rank ranges: for many (ntodo, nranks, rotation) the ranges of the
 *    ranks tile [0, ntodo), sizes differ by at most one, rotation 0 is
 *    dtx_partition_frames, a rotation moves the larger shares; hand-checked
 *    cases.
 *  - Segments: runs of consecutive groups cut at gaps of a non-contiguous
 *    todo list and at gpb groups; sub-ranges, empty ranges, the count
 *    without seg.
 *  - Groups to do: done groups skipped (a short last group too), a group
 *    with one frame not done kept, only flag 1 means done.
 *  - The whole schedule (groups to do, ranges, segments) covers every frame
 *    not done exactly once, in blocks that start on a group boundary; with
 *    nothing done and no rotation a rank's frames are dtx_partition_frames's.
 */
#include "check.h"
#include "driver.h"
#include "run_schedule.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* Hand-checked ranges: 5 groups over 3 ranks are 2, 2, 1; rotation 1 gives
 * rank 1 the first share and rank 0 the last. */
static void test_rank_range_cases(void)
{
    int64_t a, b;
    static const int64_t want_rot0[3][2] = {{0, 2}, {2, 4}, {4, 5}};
    static const int64_t want_rot1[3][2] = {{4, 5}, {0, 2}, {2, 4}};
    static const int64_t want_rot5[3][2] = {{2, 4}, {4, 5}, {0, 2}}; /* 5 % 3 = 2 */
    for (int q = 0; q < 3; q++) {
        run_rank_range(5, 3, q, 0, &a, &b);
        CHECK_EQ_INT(a, want_rot0[q][0]);
        CHECK_EQ_INT(b, want_rot0[q][1]);
        run_rank_range(5, 3, q, 1, &a, &b);
        CHECK_EQ_INT(a, want_rot1[q][0]);
        CHECK_EQ_INT(b, want_rot1[q][1]);
        run_rank_range(5, 3, q, 5, &a, &b);
        CHECK_EQ_INT(a, want_rot5[q][0]);
        CHECK_EQ_INT(b, want_rot5[q][1]);
    }
    /* Fewer groups than ranks: one each for the first (rotated) ranks. */
    run_rank_range(1, 4, 2, 2, &a, &b);
    CHECK_EQ_INT(a, 0);
    CHECK_EQ_INT(b, 1);
    run_rank_range(1, 4, 0, 2, &a, &b);
    CHECK_EQ_INT(b - a, 0);
}

/* Every group index in [0, ntodo) is dealt to exactly one rank. */
static void test_rank_range_tiles(void)
{
    static const int64_t ntodos[] = {0, 1, 2, 3, 5, 7, 8, 16, 17, 100, 1001};
    static const int nrankss[] = {1, 2, 3, 4, 7, 16};
    static const int rots[] = {0, 1, 2, 3, 5, 13, 64};
    for (size_t i = 0; i < sizeof ntodos / sizeof *ntodos; i++)
        for (size_t j = 0; j < sizeof nrankss / sizeof *nrankss; j++)
            for (size_t k = 0; k < sizeof rots / sizeof *rots; k++) {
                int64_t ntodo = ntodos[i], minn = INT64_MAX, maxn = 0;
                int nranks = nrankss[j], rot = rots[k], twice = 0, missed = 0;
                int *owner = malloc((size_t)(ntodo + 1) * sizeof *owner);
                CHECK(owner != NULL);
                if (!owner)
                    return;
                for (int64_t g = 0; g < ntodo; g++)
                    owner[g] = -1;
                for (int q = 0; q < nranks; q++) {
                    int64_t a, b;
                    run_rank_range(ntodo, nranks, q, rot, &a, &b);
                    CHECK(0 <= a && a <= b && b <= ntodo);
                    minn = b - a < minn ? b - a : minn;
                    maxn = b - a > maxn ? b - a : maxn;
                    for (int64_t g = a; g < b && g < ntodo && g >= 0; g++) {
                        twice += owner[g] != -1;
                        owner[g] = q;
                    }
                    if (rot % nranks == 0) {
                        int64_t first, count;
                        dtx_partition_frames(ntodo, 1, nranks, q, &first, &count);
                        CHECK_EQ_INT(a, first);
                        CHECK_EQ_INT(b, first + count);
                    }
                }
                for (int64_t g = 0; g < ntodo; g++)
                    missed += owner[g] == -1;
                CHECK_EQ_INT(twice, 0);
                CHECK_EQ_INT(missed, 0);
                CHECK_INT(maxn - minn, <=, 1);
                free(owner);
            }
}

static void test_segments(void)
{
    /* Gaps after 2 and 6 and 13; gpb 3 also cuts the run 9..13. */
    static const int64_t todo[10] = {0, 1, 2, 5, 6, 9, 10, 11, 12, 13};
    static const int64_t want[5] = {0, 3, 5, 8, 10};
    static const int64_t want_sub[4] = {1, 3, 5, 7};
    int64_t seg[11];
    CHECK_EQ_INT(run_segments(todo, 0, 10, 3, seg), 4);
    for (int k = 0; k < 5; k++)
        CHECK_EQ_INT(seg[k], want[k]);
    CHECK_EQ_INT(run_segments(todo, 0, 10, 3, NULL), 4);
    /* A rank's sub-range starts a segment at its own first group. */
    CHECK_EQ_INT(run_segments(todo, 1, 7, 3, seg), 3);
    for (int k = 0; k < 4; k++)
        CHECK_EQ_INT(seg[k], want_sub[k]);
    /* gpb 1: one segment per group; a large gpb: cut at gaps only. */
    CHECK_EQ_INT(run_segments(todo, 0, 10, 1, seg), 10);
    for (int k = 0; k <= 10; k++)
        CHECK_EQ_INT(seg[k], k);
    CHECK_EQ_INT(run_segments(todo, 0, 10, 1000, NULL), 3);
    /* An empty range: no segment, seg[0] = b. */
    seg[0] = -1;
    CHECK_EQ_INT(run_segments(todo, 4, 4, 3, seg), 0);
    CHECK_EQ_INT(seg[0], 4);
}

static void test_groups_todo(void)
{
    uint8_t done[10];
    int64_t todo[10], ntodo = -1, skipped = -1;
    /* 10 frames in groups of 4: [0, 4), [4, 8), [8, 10). */
    memset(done, 0, sizeof done);
    run_groups_todo(done, 10, 4, todo, &ntodo, &skipped);
    CHECK_EQ_INT(ntodo, 3);
    CHECK_EQ_INT(skipped, 0);
    for (int k = 0; k < 3; k++)
        CHECK_EQ_INT(todo[k], k);
    memset(done, 1, 4);
    run_groups_todo(done, 10, 4, todo, &ntodo, &skipped);
    CHECK_EQ_INT(ntodo, 2);
    CHECK_EQ_INT(todo[0], 1);
    CHECK_EQ_INT(todo[1], 2);
    CHECK_EQ_INT(skipped, 4);
    /* The short last group done as well: 4 + 2 frames skipped. */
    done[8] = done[9] = 1;
    run_groups_todo(done, 10, 4, todo, &ntodo, &skipped);
    CHECK_EQ_INT(ntodo, 1);
    CHECK_EQ_INT(todo[0], 1);
    CHECK_EQ_INT(skipped, 6);
    /* One frame not done keeps its whole group; a flag other than 1 is
     * not done. */
    done[2] = 0;
    done[9] = 2;
    run_groups_todo(done, 10, 4, todo, &ntodo, &skipped);
    CHECK_EQ_INT(ntodo, 3);
    CHECK_EQ_INT(skipped, 0);
    memset(done, 1, sizeof done);
    run_groups_todo(done, 10, 4, todo, &ntodo, &skipped);
    CHECK_EQ_INT(ntodo, 0);
    CHECK_EQ_INT(skipped, 10);
    /* Groups of one frame: exactly the frames not done. */
    done[3] = done[7] = 0;
    run_groups_todo(done, 10, 1, todo, &ntodo, &skipped);
    CHECK_EQ_INT(ntodo, 2);
    CHECK_EQ_INT(todo[0], 3);
    CHECK_EQ_INT(todo[1], 7);
    CHECK_EQ_INT(skipped, 8);
    run_groups_todo(done, 0, 4, todo, &ntodo, &skipped);
    CHECK_EQ_INT(ntodo, 0);
    CHECK_EQ_INT(skipped, 0);
}

/* The schedule of one result as run_frames.c builds it: every frame not
 * done is in exactly one block of one rank, blocks start on a group
 * boundary and are at most gpb groups; done groups are in none. */
static void check_schedule(const uint8_t *done, int64_t nframes, int align, int nranks, int rot,
                           int64_t gpb)
{
    int64_t ng = (nframes + align - 1) / align, ntodo, skipped, covered = 0, notdone = 0;
    int64_t *todo = malloc((size_t)(ng + 1) * sizeof *todo);
    int64_t *seg = malloc((size_t)(ng + 2) * sizeof *seg);
    int *hits = calloc((size_t)nframes + 1, sizeof *hits);
    int bad = 0;
    CHECK(todo && seg && hits);
    if (!todo || !seg || !hits)
        goto done;
    run_groups_todo(done, nframes, align, todo, &ntodo, &skipped);
    for (int q = 0; q < nranks; q++) {
        int64_t a, b, nseg;
        run_rank_range(ntodo, nranks, q, rot, &a, &b);
        nseg = run_segments(todo, a, b, gpb, seg);
        for (int64_t k = 0; k < nseg; k++) {
            int64_t f0 = todo[seg[k]] * align, f1 = (todo[seg[k + 1] - 1] + 1) * align;
            f1 = f1 < nframes ? f1 : nframes;
            bad += f0 % align != 0;
            bad += seg[k + 1] - seg[k] > gpb;
            /* A segment is consecutive groups, so [f0, f1) are its frames. */
            bad += todo[seg[k + 1] - 1] - todo[seg[k]] != seg[k + 1] - 1 - seg[k];
            for (int64_t f = f0; f < f1; f++)
                hits[f]++;
        }
    }
    for (int64_t g = 0; g < ng; g++) {
        int64_t f0 = g * align, f1 = f0 + align < nframes ? f0 + align : nframes, all = 1;
        for (int64_t f = f0; f < f1; f++)
            all &= done[f] == 1;
        for (int64_t f = f0; f < f1; f++) {
            bad += hits[f] != (all ? 0 : 1);
            covered += hits[f];
            notdone += !all;
        }
    }
    CHECK_EQ_INT(bad, 0);
    CHECK_EQ_INT(covered, notdone);
    CHECK_EQ_INT(covered + skipped, nframes);
done:
    free(todo);
    free(seg);
    free(hits);
}

static void test_schedule(void)
{
    static const int64_t nframess[] = {1, 7, 8, 9, 63, 64, 65, 200};
    static const int aligns[] = {1, 3, DTX_FRAME_ALIGN};
    static const int nrankss[] = {1, 2, 3, 5};
    uint8_t done[200];
    for (size_t i = 0; i < sizeof nframess / sizeof *nframess; i++)
        for (size_t j = 0; j < sizeof aligns / sizeof *aligns; j++)
            for (size_t k = 0; k < sizeof nrankss / sizeof *nrankss; k++)
                for (int pattern = 0; pattern < 4; pattern++) {
                    int64_t nframes = nframess[i];
                    for (int64_t f = 0; f < nframes; f++)
                        done[f] = pattern == 0   ? 0
                                  : pattern == 1 ? (f % 5) < 2       /* scattered */
                                  : pattern == 2 ? f < nframes / 2   /* a killed run */
                                                 : (f / 8) % 3 == 1; /* whole groups */
                    for (int rot = 0; rot < 4; rot++)
                        check_schedule(done, nframes, aligns[j], nrankss[k], rot, 2);
                    check_schedule(done, nframes, aligns[j], nrankss[k], 1, 1000);
                }
    /* Nothing done, no rotation: rank q's frames are those
     * dtx_partition_frames gives it in groups of DTX_FRAME_ALIGN. */
    memset(done, 0, sizeof done);
    for (int nranks = 1; nranks <= 5; nranks++) {
        int64_t todo[200 / DTX_FRAME_ALIGN + 1], ntodo, skipped;
        run_groups_todo(done, 200, DTX_FRAME_ALIGN, todo, &ntodo, &skipped);
        for (int q = 0; q < nranks; q++) {
            int64_t a, b, first, count;
            run_rank_range(ntodo, nranks, q, 0, &a, &b);
            dtx_partition_frames(200, DTX_FRAME_ALIGN, nranks, q, &first, &count);
            if (count == 0) {
                CHECK_EQ_INT(b - a, 0);
                continue;
            }
            CHECK_EQ_INT(todo[a] * DTX_FRAME_ALIGN, first);
            CHECK_EQ_INT(b < ntodo ? todo[b] * DTX_FRAME_ALIGN : 200, first + count);
        }
    }
}

int main(void)
{
    test_rank_range_cases();
    test_rank_range_tiles();
    test_segments();
    test_groups_todo();
    test_schedule();
    return check_report();
}
