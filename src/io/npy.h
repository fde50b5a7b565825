/*
 * npy.h: numpy's .npy arrays of vertex positions, as `dtx import sequence`
 * reads them: shape (T, V, 3), T frames of V vertices, or (V, 3), one frame.
 *
 * Format (numpy's "NEP 1: A simple file format for NumPy arrays" and
 * numpy.lib.format), versions 1.0, 2.0 and 3.0:
 *
 *   offset  size  field
 *        0     6  magic "\x93NUMPY"
 *        6     1  major version (1, 2 or 3)
 *        7     1  minor version (0)
 *        8   2|4  header length H, little-endian (2 bytes in 1.0, 4 after)
 *   10|12     H  header: a Python dict literal ending in '\n', e.g.
 *                {'descr': '<f4', 'fortran_order': False, 'shape': (5, 8, 3), }
 *        -     -  the data: prod(shape) items, C order (last index fastest)
 *                 or, with fortran_order True, Fortran order (first fastest)
 *
 * Only float32 and float64 of either byte order are read ('<f4', '>f4',
 * '<f8', '>f8'; numpy writes '<' on little-endian hosts, '>' after
 * byteswap().newbyteorder()); any other descr (integers, float16, complex,
 * records) is refused naming it.  The file must hold exactly the data the
 * header declares (a truncated file, trailing bytes: refused).
 *
 * Thread-safety: reentrant.
 */
#ifndef DTX_NPY_H
#define DTX_NPY_H

#include "status.h"

#include <stddef.h>
#include <stdint.h>

#define DTX_NPY_MAX_DIMS 32 /* numpy's own limit */

/* A parsed header. */
typedef struct {
    int big_endian;    /* 1 for '>' */
    int itemsize;      /* 4 (float32) or 8 (float64) */
    int fortran_order; /* 1: first index fastest */
    int ndim;          /* 0 .. DTX_NPY_MAX_DIMS */
    int64_t shape[DTX_NPY_MAX_DIMS];
    size_t data_offset; /* where the data starts */
} dtx_npy_header;

/* Parses the header of the len bytes at buf (name is used in messages):
 * magic, version, header length, the dict's 'descr', 'fortran_order' and
 * 'shape'.  DTX_EPARSE naming the problem otherwise (a descr other than
 * float32/float64: "dtype '<i4' ..."). Sizes are not checked here. */
dtx_status dtx_npy_parse_header(const char *name, const unsigned char *buf, size_t len,
                                dtx_npy_header *h, dtx_error *err);

/* Parses a whole .npy of vertex frames: the header as above, then the shape
 * ((T, V, 3) or (V, 3) with T, V >= 1 and at most INT32_MAX; DTX_EPARSE
 * naming the shape otherwise) and the byte count (exactly
 * T * V * 3 * itemsize after the header; checked before allocating).
 * *X receives T x V x 3 doubles (row-major, frame by frame; malloc'ed,
 * caller frees; values as stored, NaN included), *T and *V the counts.
 * On failure *X is NULL. */
dtx_status dtx_npy_parse_frames(const char *name, const unsigned char *buf, size_t len, int32_t *T,
                                int32_t *V, double **X, dtx_error *err);

/* Reads the file at path and parses it as dtx_npy_parse_frames does;
 * DTX_EIO when it cannot be read. */
dtx_status dtx_npy_read_frames(const char *path, int32_t *T, int32_t *V, double **X,
                               dtx_error *err);

#endif /* DTX_NPY_H */
