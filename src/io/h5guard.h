/*
 * h5guard.h: the HDF5 virtual file driver dtx uses for serial files.
 *
 * It reads and writes like HDF5's sec2 driver (pread/pwrite on one
 * descriptor, flock for HDF5's file locking), and in addition checks every
 * global heap collection HDF5 reads before HDF5 parses it.  HDF5 1.10.8
 * walks a collection's objects in H5HG__cache_heap_deserialize (H5HGcache.c)
 * with `p = begin + need`, where need is the free-space object's stored
 * size or an object's header plus its aligned size: a free-space object of
 * size 0 never advances p (an endless loop inside H5Aread / H5Dread of any
 * variable-length string), and an object whose stored size runs past the
 * collection makes H5HG_read copy outside it.  Such a collection is refused
 * here: the read fails with the HDF5 error "corrupt global heap collection
 * at address A: ..." and the H5Aread / H5Dread that needed it fails instead
 * of hanging.
 *
 * HDF5 passes global heap reads to the driver as raw data (H5FD_MEM_DRAW),
 * so a collection is recognised by its content: a read that starts with the
 * signature "GCOL", version 1, and holds the whole collection its header
 * declares, or whose rest HDF5 reads next (a collection larger than HDF5's
 * first 4 KiB guess is read in two parts; the first waits in the driver).  A collection written by HDF5 always passes (its objects tile
 * it exactly); a raw dataset read that happens to start with those 8 bytes
 * is checked the same way and fails only when its bytes would also hang or
 * overrun HDF5 as a collection.
 *
 * Parallel files (MPI-IO) do not go through this driver.
 */
#ifndef DTX_H5GUARD_H
#define DTX_H5GUARD_H

#include <hdf5.h>
#include <stddef.h>

/* Sets the guard driver on the file access list fapl (registering it with
 * HDF5 on first use).  Returns a negative value when HDF5 refuses.  Not
 * thread-safe on the first call (dtx opens files from one thread). */
herr_t dtx_h5_guard_set_fapl(hid_t fapl);

/* Checks the global heap collection image buf[0..n) as HDF5 1.10.8 would
 * walk it, with lengths of sizeof_size bytes (2, 4, 8 or 16).  Returns 1
 * when buf is a complete collection whose objects tile it so that HDF5's
 * walk ends, 0 when buf is not a complete collection (no "GCOL" version 1
 * header, or the declared size exceeds n: nothing to check), and -1 when it
 * is a corrupt one; then why (of why_n bytes) says what is wrong, relative
 * to the collection's start.  Pure; thread-safe. */
int dtx_h5_guard_check_gheap(const unsigned char *buf, size_t n, unsigned sizeof_size,
                             char *why, size_t why_n);

#endif
