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
