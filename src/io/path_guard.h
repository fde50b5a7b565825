/*
 * path_guard.h: the rule that dtx never writes to, renames over or deletes
 * a path that the job or the command names as an input.
 *
 * A command collects its inputs in a guard (dtx_path_guard_add), then asks
 * the guard about every path it is about to create, truncate, rename over
 * or remove (dtx_path_guard_check), before it creates anything.  Two paths
 * are the same file when
 *   - both exist and stat() gives the same device and inode (this catches
 *     hard links, symbolic links to the input and other spellings of it);
 *   - or their canonical names are equal: realpath() of the path, or, for
 *     a path that does not exist yet, realpath() of its directory followed
 *     by its last component (so "./a/../in.h5" and "in.h5" match).
 * A symbolic link at the checked path is followed, since opening it for
 * writing would write through it.
 *
 * Usage (a CLI command writing OUT from inputs IN1, IN2):
 *   dtx_path_guard g;
 *   dtx_path_guard_init(&g);
 *   st = dtx_path_guard_add(&g, in1, "the mesh file", err);
 *   if (st == DTX_OK) st = dtx_path_guard_add(&g, in2, "the job file", err);
 *   if (st == DTX_OK) st = dtx_path_guard_check(&g, out, "the output", err);
 *   dtx_path_guard_free(&g);
 *   if (st != DTX_OK) return fail(err);    // nothing was touched
 * For one input and one output dtx_path_guard_check_pair does the same in
 * one call.
 *
 * Not thread-safe for one guard; distinct guards are independent.  The
 * check is made once, before writing: a file renamed into place by another
 * process afterwards is not seen (nothing portable closes that race).
 */
#ifndef DTX_PATH_GUARD_H
#define DTX_PATH_GUARD_H

#include "status.h"

#include <sys/types.h>

typedef struct {
    char *path;  /* as given (owned copy) */
    char *canon; /* canonical name (owned), or NULL when it cannot be formed */
    char *role; /* what the input is, for messages ("/source/file"; owned copy) */
    dev_t dev;
    ino_t ino;
    int exists; /* stat() succeeded: dev and ino are set */
} dtx_path_guard_entry;

typedef struct {
    dtx_path_guard_entry *in;
    int n, cap;
} dtx_path_guard;

/* An empty guard. */
void dtx_path_guard_init(dtx_path_guard *g);

/* Records path as an input.  role (copied; e.g. a JSON pointer or "the
 * mesh file") names it in messages.  A NULL path is
 * ignored.  DTX_ENOMEM only. */
dtx_status dtx_path_guard_add(dtx_path_guard *g, const char *path, const char *role,
                              dtx_error *err);

/* 1 when path names the same file as input number i of the guard (see the
 * header comment for "same"), else 0. */
int dtx_path_guard_same(const dtx_path_guard *g, int i, const char *path);

/* DTX_OK when path is none of the guard's inputs.  Otherwise DTX_EINVAL
 * with "PATH (USE) is the input ROLE (INPUT): dtx does not write over, rename
 * over or delete its inputs", where use says what dtx was about to do with
 * the path ("the output", "the output's temporary file OUT.partial"). */
dtx_status dtx_path_guard_check(const dtx_path_guard *g, const char *path, const char *use,
                                dtx_error *err);

/* dtx_path_guard_check for a single input: a guard holding only `input`
 * (role `role`), asked about `path` (use `use`). */
dtx_status dtx_path_guard_check_pair(const char *input, const char *role, const char *path,
                                     const char *use, dtx_error *err);

/* DTX_OK when path is missing or an existing regular file (which dtx may
 * replace by a rename).  DTX_EINVAL, naming path, use and what is there,
 * when path is a directory, a device, a FIFO or a socket: renaming a file
 * over those fails only at the end (a directory) or replaces a special
 * file.  Symbolic links are followed (they are checked as what they point
 * to).  Call it on every path a command will create, before reading any
 * input. */
dtx_status dtx_output_path_check(const char *path, const char *use, dtx_error *err);

/* Frees the guard's copies; g is empty again.  Accepts an empty guard. */
void dtx_path_guard_free(dtx_path_guard *g);

#endif /* DTX_PATH_GUARD_H */
