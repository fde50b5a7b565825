/*
 * plan_util.h: building blocks the transfer plans of the core library share
 * (internal to the core library): the checks of their pins and
 * correspondence pairs, the centroid they translate by, the wall clock they
 * time their factorisations with, and their per-thread workspaces.
 */
#ifndef DTX_PLAN_UTIL_H
#define DTX_PLAN_UTIL_H

#include "dtx_core.h"

#include <stddef.h>
#include <stdint.h>

/* Checks the pinned vertices of a plan: translation "pins" needs at least
 * one, and every pins[i] must lie in [0, nv).  pins: npins.  Returns DTX_OK,
 * or DTX_EINVAL / DTX_ERANGE with a message naming the first offender. */
dtx_status dtx__check_pins(dtx_anchor anchor, const int32_t *pins, int32_t npins, int32_t nv,
                           dtx_error *err);

/* Checks correspondence pairs (source triangle, target triangle):
 * pairs: npairs x 2, source in [0, nf_src), target in [0, nf_tgt).
 * Returns DTX_OK or DTX_ERANGE naming the first pair out of range. */
dtx_status dtx__check_pairs(const int32_t *pairs, int64_t npairs, int32_t nf_src, int32_t nf_tgt,
                            dtx_error *err);

/* c (3) = the mean of the n rows of X (n x 3, row-major), summed in row
 * order so that every caller gets the same bits for the same rows. */
void dtx__centroid(const double *X, int32_t n, double *c);

/* Wall-clock seconds (omp_get_wtime), 0 without OpenMP. */
double dtx__now_seconds(void);

/* Per-thread workspaces of a plan, allocated once and reused by every
 * apply: one workspace of `size` bytes per OpenMP thread, workspace t for
 * thread t.  A plan embeds one dtx__workers, zeroed when the plan is. */
typedef struct {
    void *set; /* n workspaces of size bytes each */
    int n;
    size_t size;
} dtx__workers;

/* Makes ws one zeroed workspace of `size` bytes per OpenMP thread (one
 * without OpenMP), each filled by init(plan, workspace), unless ws already
 * has that many (then nothing is done).  init returns 0 when out of memory;
 * fini(plan, workspace) frees what init allocated and must accept a
 * workspace init filled only partly or not at all.  When out of memory
 * every workspace is freed and the message is "out of memory for <what>".
 * Not thread-safe: call it before the parallel region. */
dtx_status dtx__workers_ensure(dtx__workers *ws, size_t size, void *plan,
                               int (*init)(void *plan, void *workspace),
                               void (*fini)(void *plan, void *workspace), const char *what,
                               dtx_error *err);

/* Frees every workspace (fini(plan, workspace) on each) and the set,
 * leaving ws empty. */
void dtx__workers_free(dtx__workers *ws, void *plan, void (*fini)(void *plan, void *workspace));

/* Workspace t of ws (t < ws->n). */
static inline void *dtx__worker(const dtx__workers *ws, int t)
{
    return (char *)ws->set + (size_t)t * ws->size;
}

#endif /* DTX_PLAN_UTIL_H */
