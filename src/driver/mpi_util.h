/*
 * mpi_util.h: one outcome for every rank of a communicator.
 *
 * After each phase of a run the ranks agree on its outcome, so that a
 * failure on one rank ends the work on all of them with the same status and
 * the failing rank's message, and no rank waits forever in a later
 * collective call that the failed rank never makes.
 */
#ifndef DTX_MPI_UTIL_H
#define DTX_MPI_UTIL_H

#include "status.h"

#include <mpi.h>
#include <stdint.h>

/* Flags of dtx_mpi_agree (bitwise or; 0 for neither). */

/* Ranks other than the failing one prefix the message they receive with
 * "rank N: " when the failing rank N is not 0, so that the user can tell
 * which rank it came from (rank 0's failures are the usual ones and keep
 * their message as it is). */
#define DTX_AGREE_NAME_RANK 0x1u

/* A rank whose status is DTX_EMPI (it only heard that another rank failed)
 * yields to every rank with another failure: the message chosen is the
 * lowest such rank's, and a DTX_EMPI rank's only when all failing ranks
 * have DTX_EMPI. */
#define DTX_AGREE_OWN_FIRST 0x2u

/* Agrees on st, this rank's outcome of a phase, across comm.  Returns
 * DTX_OK on every rank when every rank's st is DTX_OK.  Otherwise picks the
 * lowest failing rank (see DTX_AGREE_OWN_FIRST) and gives every rank its
 * err->code and err->msg (the picked rank's err must be filled, as
 * dtx_seterr does); returns that code, or DTX_EMPI should that rank have
 * left err->code at DTX_OK.  err is read on the picked rank only and
 * written on all ranks when some rank failed; it must not be NULL.
 *
 * Collective: every rank of comm must call it, at the same point, with the
 * same flags, also ranks that have no work in the phase or have failed
 * earlier in it (one MPI_Allreduce, then one MPI_Bcast when some rank
 * failed).  Not thread-safe for one communicator; call it from the thread
 * that makes the rank's MPI calls. */
dtx_status dtx_mpi_agree(dtx_status st, unsigned flags, MPI_Comm comm, dtx_error *err);

/* A dealer of items 0..total-1 over the ranks of a communicator, for work
 * whose pieces take unequal, unforeseeable times (the bounded weights'
 * programmes): a counter on rank 0 that every rank advances by one-sided
 * atomic fetch-and-add (MPI_Fetch_and_op), so a rank takes its next items
 * when it is ready, without the others' taking part.  Which rank gets which
 * item depends on timing: use it only for work whose results do not depend
 * on who computes them. */
typedef struct {
    MPI_Win win;
    int open;
} dtx_mpi_dealer;

/* Opens the dealer (collective over comm), its counter at 0.  DTX_EMPI on
 * failure, the dealer then closed on every rank (the failure is agreed). */
dtx_status dtx_mpi_dealer_open(dtx_mpi_dealer *d, MPI_Comm comm, dtx_error *err);

/* Claims up to want of the items left of 0..total-1 (every rank passes the
 * same total): sets *k0 and returns how many (the items *k0, *k0 + 1,
 * ...), or 0 when none are left (or on an MPI failure, which the caller's
 * own agreement then has to notice: the items such a rank claimed stay
 * undone).  ctx is the dtx_mpi_dealer; the signature is
 * dtx_bbw_claim_fn's.  Main thread only. */
int32_t dtx_mpi_dealer_claim(void *ctx, int32_t total, int32_t want, int32_t *k0);

/* Closes the dealer (collective; a closed or never opened one is left
 * alone on every rank alike). */
void dtx_mpi_dealer_close(dtx_mpi_dealer *d);

#endif /* DTX_MPI_UTIL_H */
