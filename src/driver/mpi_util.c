/*
 * mpi_util.c: one outcome for every rank of a communicator (see
 * mpi_util.h).
 */
#include "mpi_util.h"

#include <limits.h>
#include <string.h>

dtx_status dtx_mpi_agree(dtx_status st, unsigned flags, MPI_Comm comm, dtx_error *err)
{
    int rank, nranks, mine, first;
    struct {
        int code;
        char msg[sizeof err->msg];
    } buf;
    MPI_Comm_rank(comm, &rank);
    MPI_Comm_size(comm, &nranks);
    /* The minimum over the ranks picks the failure: rank numbers for real
     * failures, and with DTX_AGREE_OWN_FIRST rank numbers shifted past every
     * real failure for ranks that only heard of one. */
    if (st == DTX_OK)
        mine = INT_MAX;
    else if ((flags & DTX_AGREE_OWN_FIRST) && st == DTX_EMPI)
        mine = nranks + rank;
    else
        mine = rank;
    MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, comm);
    if (first == INT_MAX)
        return DTX_OK;
    if (first >= nranks)
        first -= nranks;

    /* The code and the message travel together, in one broadcast. */
    memset(&buf, 0, sizeof buf);
    if (rank == first) {
        buf.code = (int)err->code;
        memcpy(buf.msg, err->msg, sizeof buf.msg);
    }
    MPI_Bcast(&buf, (int)sizeof buf, MPI_BYTE, first, comm);
    err->code = (dtx_status)buf.code;
    memcpy(err->msg, buf.msg, sizeof err->msg);
    err->msg[sizeof err->msg - 1] = '\0';
    if ((flags & DTX_AGREE_NAME_RANK) && rank != first && first != 0)
        dtx_error_prefix(err, "rank %d", first);
    return err->code != DTX_OK ? err->code : DTX_EMPI;
}

/* ------------------------------------------------------------------ */
/* Dealer                                                              */
/* ------------------------------------------------------------------ */

dtx_status dtx_mpi_dealer_open(dtx_mpi_dealer *d, MPI_Comm comm, dtx_error *err)
{
    int64_t *base = NULL;
    int rank, ok;
    MPI_Comm_rank(comm, &rank);
    memset(d, 0, sizeof *d);
    d->win = MPI_WIN_NULL;
    ok = MPI_Win_allocate(rank == 0 ? (MPI_Aint)sizeof *base : 0, (int)sizeof *base,
                          MPI_INFO_NULL, comm, &base, &d->win) == MPI_SUCCESS;
    /* The counter starts at 0 before any rank can reach it. */
    if (ok && rank == 0) {
        ok = MPI_Win_lock(MPI_LOCK_EXCLUSIVE, 0, 0, d->win) == MPI_SUCCESS;
        if (ok) {
            *base = 0;
            ok = MPI_Win_unlock(0, d->win) == MPI_SUCCESS;
        }
    }
    MPI_Allreduce(MPI_IN_PLACE, &ok, 1, MPI_INT, MPI_LAND, comm);
    if (ok)
        ok = MPI_Win_lock_all(0, d->win) == MPI_SUCCESS;
    MPI_Allreduce(MPI_IN_PLACE, &ok, 1, MPI_INT, MPI_LAND, comm);
    if (!ok) {
        if (d->win != MPI_WIN_NULL)
            MPI_Win_free(&d->win);
        return dtx_seterr(err, DTX_EMPI, "could not set up the sharing of work over the ranks "
                          "(MPI one-sided communication)");
    }
    d->open = 1;
    return DTX_OK;
}

int32_t dtx_mpi_dealer_claim(void *ctx, int32_t total, int32_t want, int32_t *k0)
{
    dtx_mpi_dealer *d = ctx;
    int64_t inc = want, old = 0;
    if (!d->open || want < 1 ||
        MPI_Fetch_and_op(&inc, &old, MPI_INT64_T, 0, 0, MPI_SUM, d->win) != MPI_SUCCESS ||
        MPI_Win_flush(0, d->win) != MPI_SUCCESS || old >= total)
        return 0;
    *k0 = (int32_t)old;
    return total - old < want ? (int32_t)(total - old) : want;
}

void dtx_mpi_dealer_close(dtx_mpi_dealer *d)
{
    if (!d->open)
        return;
    MPI_Win_unlock_all(d->win);
    MPI_Win_free(&d->win);
    d->open = 0;
}
