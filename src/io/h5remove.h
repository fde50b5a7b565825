/*
 * h5remove.h: removing objects (meshes, sequences, marker sets, key points,
 * correspondences, results) from a dtx HDF5 file, for `dtx rm`.
 *
 * An object is removed only when nothing left in the file refers to it (a
 * sequence's rest mesh, a result's target, the source or target mesh of a
 * marker set, key-point set or correspondence): every path to remove is
 * checked first, and a refused removal changes nothing.  HDF5 does not give
 * the freed space back to the file system; later objects written into the
 * same file reuse it, and `h5repack` writes a compact copy.
 *
 * Thread-safety: as the rest of the HDF5 layer (one thread at a time).
 */
#ifndef DTX_H5REMOVE_H
#define DTX_H5REMOVE_H

#include "status.h"

/* Removes the objects paths[0..n-1] (each "/KIND/NAME", or
 * "/results/TARGET/SEQUENCE", or "/results/TARGET" for all of a target's
 * results) from the dtx file at path, opened for writing.  A namespace group
 * left empty (/results/TARGET) goes too.  Errors (nothing removed):
 * DTX_EINVAL a path that is not an object of the layout, is missing or is named twice;
 * DTX_EFORMAT an object another one refers to
 * (the message names the first referrer and how to remove both); those of
 * dtx_h5_open; DTX_EIO when HDF5 fails to unlink. */
dtx_status dtx_h5_remove_objects(const char *path, const char *const *paths, int n, dtx_error *err);

#endif /* DTX_H5REMOVE_H */
