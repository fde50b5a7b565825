/*
 * h5frames.h: vertex frames and faces in HDF5 files that other programs
 * wrote (not dtx files): a dataset of positions in any axis order, a faces
 * dataset elsewhere, every such dataset of a group.  `dtx import` reads
 * them; DFAUST's registrations (one (V, 3, T) float dataset per sequence and
 * one shared (F, 3) int32 `faces` dataset, 0-based) are the documented
 * example.
 *
 * Axis order: a string naming each dimension of the dataset in the file's
 * order, with T (frames), V (vertices) and C (the 3 coordinates): "TVC" is
 * (T, V, 3), DFAUST's is "VCT".  A 2-D dataset is one frame: "VC" or "CV".
 *
 * Frames are read a block at a time through an HDF5 hyperslab on the T axis
 * (memory O(block x V), whatever the sequence's length); HDF5 converts any
 * floating-point type to double.  Integer positions are refused.
 *
 * Dataset and group paths are taken from the root group ("walk" is
 * "/walk").
 *
 * Thread-safety: as HDF5 (dtx opens files from one thread).
 */
#ifndef DTX_H5FRAMES_H
#define DTX_H5FRAMES_H

#include "status.h"

#include <hdf5.h>
#include <stdint.h>

/* Opens an HDF5 file read-only through dtx's guarded serial driver
 * (h5guard.h), whatever its layout.  DTX_EIO naming the file when it is
 * missing, not a regular file or not readable; DTX_EFORMAT when it is not
 * HDF5.  Close *file with H5Fclose. */
dtx_status dtx_h5_foreign_open(const char *path, hid_t *file, dtx_error *err);

/* A positions dataset opened for reading frames.  Fields are read-only. */
typedef struct {
    hid_t dset;
    int ndim;  /* 2 or 3 */
    int ax[3]; /* ax[0], ax[1], ax[2]: the dataset dimension of T, V, C (-1: no T) */
    hsize_t dims[3];
    int32_t nframes, nv;
    char name[512]; /* "FILE:/path", for messages */
} dtx_h5_frames;

/* Checks an axis-order string for a dataset of ndim dimensions: ndim
 * letters, each of T, V and C at most once, V and C present, T present when
 * ndim is 3.  Fills ax (as dtx_h5_frames.ax); DTX_EINVAL with a message
 * otherwise.  Pure. */
dtx_status dtx_h5_axes_parse(const char *axes, int ndim, int ax[3], dtx_error *err);

/* Opens the dataset at path of file (fname names the file in messages):
 * floating-point values (DTX_EFORMAT "expected floating-point positions,
 * found integer" otherwise), 2 or 3 dimensions matching axes (NULL: "TVC",
 * or "VC" for a 2-D dataset), the C dimension 3, at least one frame and one
 * vertex (each at most INT32_MAX), and fully stored (a dataset never fully
 * written is refused rather than read as fill values).  Close with
 * dtx_h5_frames_close. */
dtx_status dtx_h5_frames_open(hid_t file, const char *fname, const char *path, const char *axes,
                              dtx_h5_frames *fr, dtx_error *err);

/* Reads frames [first, first + count) into out: count x nv x 3 doubles,
 * row-major, whatever the axis order (caller allocates).  Values as
 * stored, NaN included. */
dtx_status dtx_h5_frames_read(const dtx_h5_frames *fr, int32_t first, int32_t count, double *out,
                              dtx_error *err);

/* Closes the dataset (accepts a closed or zeroed one). */
void dtx_h5_frames_close(dtx_h5_frames *fr);

/* Reads the faces dataset at path: integers of shape (F, 3), 0-based
 * vertex indices below nv.  *F receives nf x 3 int32 (malloc'ed, caller
 * frees), *nf the count.  DTX_EFORMAT naming the file, the dataset and the
 * problem (missing, not integer, wrong shape, an index out of range). */
dtx_status dtx_h5_read_faces(hid_t file, const char *fname, const char *path, int32_t nv,
                             int32_t *nf, int32_t **F, dtx_error *err);

/* The datasets directly under group whose names match the shell pattern
 * (fnmatch), sorted by strcmp, as full paths ("/group/name").  *paths is a
 * malloc'ed array of *n malloc'ed strings (free each, then the array);
 * NULL with *n == 0 when none match.  DTX_EFORMAT when group is not a
 * group of the file. */
dtx_status dtx_h5_match_datasets(hid_t file, const char *fname, const char *group,
                                 const char *pattern, char ***paths, int *n, dtx_error *err);

#endif /* DTX_H5FRAMES_H */
