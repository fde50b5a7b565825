/*
 * h5util.h: small HDF5 helpers shared by the layout (h5layout.c) and its
 * validator (h5validate.c); internal to the I/O layer.
 */
#ifndef DTX_H5UTIL_H
#define DTX_H5UTIL_H

#include <hdf5.h>
#include <stdint.h>

/* Closes an HDF5 identifier with fn (H5Dclose, H5Gclose ...) when it is
 * open, and marks it closed. */
#define CLOSE_ID(fn, id)        \
    do {                        \
        if ((id) > 0)           \
            (void)fn(id);       \
        (id) = H5I_INVALID_HID; \
    } while (0)

/* Whether a dataset whose contents need `need` bytes cannot have been
 * fully written when `stored` bytes are allocated for it: fewer bytes than
 * it needs, or with nfilt > 0 filters (gzip) fewer than it could compress
 * to (gzip cannot compress better than about 1032:1; 1100 leaves room, and
 * 64 bytes for a nearly empty dataset). */
static inline int dtx_h5_short_of_storage(uint64_t need, uint64_t stored, int nfilt)
{
    return nfilt > 0 ? need / 1100u > stored + 64 : need > stored;
}

#endif /* DTX_H5UTIL_H */
