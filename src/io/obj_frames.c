/* obj_frames.c: OBJ frames of an asset with its attributes (obj_frames.h). */
#include "obj_frames.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

dtx_status dtx_obj_frames_begin(dtx_obj_frames *w, const dtx_mesh *mesh, dtx_mesh_attrs *a,
                                dtx_error *err)
{
    dtx_status st;
    memset(w, 0, sizeof *w);
    w->mesh = mesh;
    if (a) {
        w->owned = *a;
        memset(a, 0, sizeof *a);
    }
    /* OBJ names are single words: a glTF/FBX material "Skin Mat" becomes
     * "Skin_Mat" (an empty name "material_N") in the OBJ frames. */
    for (int32_t m = 0; m < w->owned.nmat; m++) {
        char *s = w->owned.material_names[m];
        if (s && !s[0]) {
            char *r = malloc(32);
            if (!r) {
                dtx_obj_frames_end(w);
                return dtx_seterr(err, DTX_ENOMEM, "out of memory");
            }
            snprintf(r, 32, "material_%d", (int)m);
            free(s);
            w->owned.material_names[m] = r;
        }
        for (s = w->owned.material_names[m]; s && *s; s++)
            if (*s == ' ' || *s == '\t' || *s == '\r' || *s == '\n')
                *s = '_';
    }
    w->a = w->owned;
    if (w->owned.normals) {
        st = dtx_frame_normals_plan(mesh->V, mesh->nv, mesh->F, mesh->nf, w->owned.normals,
                                    w->owned.nn, w->owned.normal_faces, &w->plan, err);
        if (st == DTX_OK && !(w->a.normals = malloc(((size_t)w->plan.nout + 1) * 3 *
                                                    sizeof *w->a.normals)))
            st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
        if (st != DTX_OK) {
            dtx_obj_frames_end(w);
            return st;
        }
        w->a.nn = w->plan.nout;
        w->a.normal_faces = w->plan.out_faces;
    }
    return DTX_OK;
}

dtx_status dtx_obj_frames_write(dtx_obj_frames *w, const char *path, const double *X,
                                const float *Xf, const char *comment, dtx_error *err)
{
    const dtx_mesh *m = w->mesh;
    if (!dtx_mesh_attrs_any(&w->a))
        return X ? dtx_obj_write(path, X, m->nv, m->F, m->nf, comment, err)
                 : dtx_obj_write_f32(path, Xf, m->nv, m->F, m->nf, comment, err);
    if (w->a.normals)
        dtx_frame_normals_apply(&w->plan, X, X ? NULL : Xf, m->F, w->a.normals);
    return dtx_obj_write_attrs(path, X, X ? NULL : Xf, m->nv, m->F, m->nf, &w->a, comment, err);
}

void dtx_obj_frames_end(dtx_obj_frames *w)
{
    if (!w)
        return;
    if (w->a.normals != w->owned.normals)
        free(w->a.normals);
    dtx_frame_normals_free(&w->plan);
    dtx_mesh_attrs_free(&w->owned);
    memset(w, 0, sizeof *w);
}
