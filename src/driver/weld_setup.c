/* weld_setup.c: a run's meshes welded along their seams (weld_setup.h). */
#include "weld_setup.h"

#include "h5layout.h"
#include "h5mesh_attrs.h"
#include "weld.h"

#include <stdlib.h>
#include <string.h>

dtx_status dtx_weld_setup(dtx_mesh *m, double tol, const char *what, dtx_weld_ctx *w,
                          dtx_error *err)
{
    dtx_mesh welded;
    dtx_status st;
    memset(w, 0, sizeof *w);
    w->nv = w->nw = m->nv;
    if (tol < 0 || m->nv == 0)
        return DTX_OK;
    w->map = malloc((size_t)m->nv * sizeof *w->map);
    w->rep = malloc((size_t)m->nv * sizeof *w->rep);
    if (!w->map || !w->rep) {
        dtx_weld_ctx_free(w);
        return dtx_seterr(err, DTX_ENOMEM, "%s: out of memory for the weld map", what);
    }
    st = dtx_weld_map(m->V, m->nv, tol, w->map, w->rep, &w->nw, err);
    if (st == DTX_OK && w->nw == m->nv) { /* no twins: the identity */
        dtx_weld_ctx_free(w);
        w->nv = w->nw = m->nv;
        return DTX_OK;
    }
    if (st == DTX_OK)
        st = dtx_mesh_alloc(&welded, w->nw, m->nf, err);
    if (st != DTX_OK) {
        dtx_weld_ctx_free(w);
        return st;
    }
    dtx_weld_apply(m->V, m->F, m->nf, w->map, w->rep, w->nw, welded.V, welded.F);
    st = dtx_mesh_validate(&welded, what, err);
    if (st != DTX_OK) {
        dtx_error_prefix(err, "after welding %d vertices at the same position%s", (int)(m->nv - w->nw),
                         tol > 0 ? " (within weld_tolerance)" : "");
        dtx_mesh_free(&welded);
        dtx_weld_ctx_free(w);
        return st;
    }
    w->asset = *m;
    *m = welded;
    return DTX_OK;
}

const dtx_mesh *dtx_weld_asset(const dtx_weld_ctx *w, const dtx_mesh *welded)
{
    return w->map ? &w->asset : welded;
}

int32_t dtx_weld_index(const dtx_weld_ctx *w, int32_t i)
{
    return w->map && i >= 0 && i < w->nv ? w->map[i] : i;
}

void dtx_weld_markers(dtx_markers *mk, const dtx_weld_ctx *src, const dtx_weld_ctx *tgt)
{
    for (int32_t i = 0; i < mk->n; i++) {
        if (src)
            mk->src[i] = dtx_weld_index(src, mk->src[i]);
        if (tgt)
            mk->tgt[i] = dtx_weld_index(tgt, mk->tgt[i]);
    }
}

void dtx_weld_source_frames(const dtx_weld_ctx *w, double *X, int64_t n)
{
    if (w->map)
        dtx_weld_compact_frames(X, n, w->nv, w->rep, w->nw);
}

void dtx_weld_result_frames(const dtx_weld_ctx *w, double *X, int64_t n)
{
    if (w->map)
        dtx_weld_expand_frames(X, n, w->nw, w->map, w->nv);
}

void dtx_weld_ctx_free(dtx_weld_ctx *w)
{
    if (!w)
        return;
    free(w->map);
    free(w->rep);
    dtx_mesh_free(&w->asset);
    w->map = w->rep = NULL;
    dtx_obj_frames_end(&w->obj);
    w->obj_ready = 0;
}

dtx_status dtx_weld_write_obj(dtx_weld_ctx *w, const dtx_mesh *welded, const char *file,
                              const char *mesh, const char *path, const double *X,
                              const char *comment, dtx_error *err)
{
    const dtx_mesh *m = dtx_weld_asset(w, welded);
    dtx_status st = DTX_OK;
    if (!w->obj_ready) {
        dtx_mesh_attrs a;
        hid_t f = H5I_INVALID_HID;
        st = dtx_h5_open(file, MPI_COMM_NULL, 0, &f, err);
        if (st == DTX_OK)
            st = dtx_h5_read_mesh_attrs(f, mesh, m->nv, m->nf, &a, err);
        if (f >= 0)
            dtx_h5_close(&f, NULL);
        if (st == DTX_OK)
            st = dtx_obj_frames_begin(&w->obj, m, &a, err);
        if (st != DTX_OK)
            return st;
        w->obj_ready = 1;
    }
    return dtx_obj_frames_write(&w->obj, path, X, NULL, comment, err);
}

dtx_status dtx_weld_write_asset(hid_t out, const char *group, const dtx_weld_ctx *w,
                                const dtx_mesh *welded, const char *file, const char *mesh,
                                const char *source, dtx_error *err)
{
    const dtx_mesh *m = dtx_weld_asset(w, welded);
    dtx_mesh_attrs a;
    hid_t f = H5I_INVALID_HID;
    dtx_status st = dtx_h5_open(file, MPI_COMM_NULL, 0, &f, err);
    if (st == DTX_OK)
        st = dtx_h5_read_mesh_attrs(f, mesh, m->nv, m->nf, &a, err);
    if (f >= 0)
        dtx_h5_close(&f, NULL);
    if (st != DTX_OK)
        return st;
    st = dtx_h5_write_mesh_with(out, group, m, &a, source, err);
    dtx_mesh_attrs_free(&a);
    return st;
}
