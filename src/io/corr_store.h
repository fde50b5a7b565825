/*
 * corr_store.h: a correspondence store, a directory of correspondences that
 * any number of jobs share (job key "correspondence_store", or
 * `dtx run --store DIR`).
 *
 * The store holds one file per correspondence, DIR/KEY.h5, KEY being the
 * hex hash the driver computes of everything that determines it (source
 * mesh, target mesh, markers and the correspondence parameters, which name
 * the method).  Each file is a dtx HDF5 file (schemas/hdf5-layout-v1.md)
 * holding the one group /correspondences/KEY with one more attribute,
 * content_hash (a hash of its arrays, checked on reading, so a damaged file
 * is refused rather than used); `dtx validate` accepts it.
 *
 * Files are written aside ("DIR/.KEY.h5.tmp-HOST-PID") and renamed into
 * place, so the final name never holds a half-written file; two jobs that
 * compute the same key at once write identical files and either rename
 * wins.  Nothing here removes or rewrites a file it did not create.
 *
 * Serial HDF5 only (call from one rank, one thread at a time).
 */
#ifndef DTX_CORR_STORE_H
#define DTX_CORR_STORE_H

#include "h5layout.h"
#include "status.h"

#include <stddef.h>
#include <stdint.h>

/* out = "DIR/KEY.h5".  DTX_EINVAL when it does not fit in n bytes or key
 * is not 1-64 hex digits. */
dtx_status dtx_corr_store_path(const char *dir, const char *key, char *out, size_t n,
                               dtx_error *err);

/* Looks for the correspondence of key in the store dir.  *found = 0 (and
 * DTX_OK) when DIR/KEY.h5 does not exist.  A file that exists is read in
 * full and checked (dtx_h5_read_corr with src_nv, src_nf, tgt_nf; its key
 * attribute must equal key and its arrays their content_hash;
 * need_deformed != 0: sp04's, it must hold a deformed source; == 0:
 * multicomponent's, it must hold none): anything wrong gives an error
 * naming the file and the problem, and *c is left empty.  On success *c
 * is owned by the caller (dtx_h5_corr_free). */
dtx_status dtx_corr_store_read(const char *dir, const char *key, int32_t src_nv, int32_t src_nf,
                               int32_t tgt_nf, int need_deformed, dtx_h5_corr *c, int *found,
                               dtx_error *err);

/* Writes the correspondence (pairs: npairs x 2; deformed_src: nv_s x 3
 * doubles, or NULL for multicomponent's) as DIR/KEY.h5 with the
 * provenance meta (meta->key must equal key): into a temporary file in dir,
 * synced, then renamed over DIR/KEY.h5.  dir must exist.  On failure the
 * temporary file is removed and DIR/KEY.h5 is as before. */
dtx_status dtx_corr_store_write(const char *dir, const char *key, const int32_t *pairs,
                                int64_t npairs, const double *deformed_src, int32_t nv_s,
                                const dtx_h5_corr_meta *meta, dtx_error *err);

#endif /* DTX_CORR_STORE_H */
