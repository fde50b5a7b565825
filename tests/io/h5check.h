/*
 * h5check.h: HDF5 helpers shared by the io test programs (after check.h).
 */
#ifndef DTX_TEST_H5CHECK_H
#define DTX_TEST_H5CHECK_H

#include "check.h"
#include "h5layout.h"

/* A new HDF5 file at path (serial), or H5I_INVALID_HID after a failed check. */
static inline hid_t h5check_new_file(const char *path)
{
    hid_t f = H5I_INVALID_HID;
    dtx_error e;
    CHECK_OK(dtx_h5_create(path, MPI_COMM_NULL, &f, &e), &e);
    return f;
}

#endif /* DTX_TEST_H5CHECK_H */
