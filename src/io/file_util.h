/*
 * file_util.h: opening input files so that a FIFO, a device or a directory
 * given where a file is expected is refused at once instead of hanging the
 * run (a FIFO without a writer blocks open and read forever) or filling the
 * memory (/dev/zero never ends).  Every reader of a user's input file goes
 * through here: the mesh readers, marker CSVs, PC2 caches, job files and the
 * HDF5 files before H5Fopen.
 *
 * Also the small path helpers the layers above share (a relative path
 * between two files, whether two paths are one file, a path's last
 * component).
 *
 * Messages name the path and the kind of file:
 *   "x.obj: not a regular file (a FIFO)"
 * All functions are reentrant.
 */
#ifndef DTX_FILE_UTIL_H
#define DTX_FILE_UTIL_H

#include "status.h"

#include <stddef.h>
#include <sys/stat.h>

/* What the mode's file type is, for messages: "a FIFO", "a character
 * device", "a directory", ...  Never NULL. */
const char *dtx_file_kind(mode_t mode);

/* Opens path read-only and returns its descriptor in *fd (close it with
 * close) and its fstat in *sb (may be NULL).  The open uses O_NONBLOCK, so
 * that opening a FIFO never waits for a writer; the file type is then
 * checked with fstat on the open descriptor (no race with a rename between
 * a stat and the open), and O_NONBLOCK is cleared again.  Anything but a
 * regular file is DTX_EIO with "path: not a regular file (a FIFO)" and *fd
 * is -1; so is a file that cannot be opened ("path: cannot open: reason"). */
dtx_status dtx_file_open_regular(const char *path, int *fd, struct stat *sb, dtx_error *err);

/* As dtx_file_open_regular, then closes the file: for inputs that another
 * library opens by name (H5Fopen blocks forever on a FIFO). */
dtx_status dtx_file_check_regular(const char *path, dtx_error *err);

/* Reads the whole regular file at path into a new buffer *buf (malloc'd,
 * freed by the caller with free) of *len bytes plus one NUL byte at
 * (*buf)[*len].  A file of more than max_bytes bytes (by fstat, before
 * anything is allocated) is DTX_EIO with "path: file too large (N bytes;
 * the limit is M)"; pass SIZE_MAX for no limit beyond the memory.  On
 * failure *buf is NULL and *len is 0. */
dtx_status dtx_file_read_regular(const char *path, size_t max_bytes, char **buf, size_t *len,
                                 dtx_error *err);

/* The path of the existing file `target` relative to the directory of the
 * file `from` (which need not exist yet; its directory must), written into
 * out (n bytes): "in.h5", "../data/in.h5".  Both are resolved with
 * realpath first.  When they share no directory but the root, or anything
 * cannot be resolved or does not fit, out gets target as given.  Used for
 * references between files that move together (a result and its source). */
void dtx_path_relative(const char *target, const char *from, char *out, size_t n);

/* Whether the paths a and b name the same file by stat(): 1 when both
 * exist and have the same device and inode (hard links, symbolic links and
 * other spellings of one file are the same), 0 when both exist and differ,
 * -1 when either cannot be stat()ed (it does not exist, for one).  Callers
 * choose what a missing file means for them. */
int dtx_file_same_inode(const char *a, const char *b);

/* The last component of path: what follows its last '/', or path itself
 * when it has none ("dir/in.h5" gives "in.h5", "/meshes/lion" gives "lion",
 * "dir/" gives "").  Points into path; nothing is allocated. */
const char *dtx_path_base_name(const char *path);

/* Moves the file at `from` to `to`, replacing a file there atomically: at
 * every moment `to` names either the file it named before or the new one.
 * When `to` exists, the two names are exchanged (renameat2 with
 * RENAME_EXCHANGE) and the replaced file, then at `from`, is unlinked: a
 * rename() over an existing file makes ext4 (auto_da_alloc) write out the
 * new file's dirty pages and wait for them (0.5 s for a 1.2 GB output on
 * the 2-core VM of README's Speed section).  Without exchange (other systems, older kernels,
 * file systems without it) it is a plain rename().  *old_left is 1 when
 * the replaced file could not be unlinked and is left at `from`.  DTX_EIO
 * with both paths and the reason when nothing was moved. */
dtx_status dtx_file_replace(const char *from, const char *to, int *old_left, dtx_error *err);

#endif /* DTX_FILE_UTIL_H */
