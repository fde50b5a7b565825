/* obj_write.c: OBJ files with the asset's attributes: mtllib, vt, vn,
 * usemtl and v/t/n faces (meshfile.h). */
#include "atomic_file.h"
#include "meshfile.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#ifndef DTX_VERSION
#define DTX_VERSION "unknown"
#endif

/* Writes one face corner reference: v, v/t, v//n or v/t/n (1-based). */
static void corner(FILE *fp, int32_t v, const int32_t *tf, const int32_t *nf, size_t k)
{
    fprintf(fp, " %ld", (long)v + 1);
    if (tf && nf)
        fprintf(fp, "/%ld/%ld", (long)tf[k] + 1, (long)nf[k] + 1);
    else if (tf)
        fprintf(fp, "/%ld", (long)tf[k] + 1);
    else if (nf)
        fprintf(fp, "//%ld", (long)nf[k] + 1);
}

dtx_status dtx_obj_write_attrs(const char *path, const double *Vd, const float *Vf, int32_t nv,
                               const int32_t *F, int32_t nf, const dtx_mesh_attrs *a,
                               const char *comment, dtx_error *err)
{
    dtx_atomic_file af;
    dtx_status st;
    const int32_t *nfaces;
    int32_t cur = -2;

    /* ---- check everything before the file exists */
    if (nv < 0 || nf < 0 || (nv > 0 && !Vd == !Vf) || (nf > 0 && !F))
        return dtx_seterr(err, DTX_EINVAL, "%s: bad mesh arguments (nv %d, nf %d)", path, (int)nv,
                          (int)nf);
    for (int64_t i = 0; i < 3 * (int64_t)nv; i++)
        if (!isfinite(Vd ? Vd[i] : (double)Vf[i]))
            return dtx_seterr(err, DTX_ENONFINITE,
                              "%s: vertex %lld (0-based) has a non-finite coordinate; not "
                              "written",
                              path, (long long)(i / 3));
    for (int64_t i = 0; i < 3 * (int64_t)nf; i++)
        if (F[i] < 0 || F[i] >= nv)
            return dtx_seterr(err, DTX_ERANGE,
                              "%s: face %lld (0-based) has vertex index %d out of range [0, %d); "
                              "not written",
                              path, (long long)(i / 3), (int)F[i], (int)nv);
    if ((st = dtx_mesh_attrs_validate(a, nv, nf, path, err)) != DTX_OK)
        return st;
    if (a && a->mtllib && strpbrk(a->mtllib, "\r\n"))
        return dtx_seterr(err, DTX_EINVAL, "%s: the mtllib name has a line break; not written",
                          path);
    for (int32_t m = 0; a && m < a->nmat; m++)
        if (strpbrk(a->material_names[m], " \t\r\n") || !a->material_names[m][0])
            return dtx_seterr(err, DTX_EINVAL,
                              "%s: material %d's name \"%s\" is empty or has white space; not "
                              "written",
                              path, (int)m, a->material_names[m]);
    nfaces = a && a->normals ? a->normal_faces : NULL;

    st = dtx_atomic_open(&af, path, err);
    if (st != DTX_OK)
        return st;
    fprintf(af.fp, "# Written by dtx %s\n# %d vertices, %d triangles\n", DTX_VERSION, (int)nv,
            (int)nf);
    if (comment) {
        const char *c = comment;
        while (*c) {
            size_t n = strcspn(c, "\n");
            size_t m = n;
            if (m > 0 && c[m - 1] == '\r')
                m--;
            fprintf(af.fp, "# %.*s\n", (int)m, c);
            c += n;
            if (*c == '\n')
                c++;
        }
    }
    if (a && a->mtllib)
        fprintf(af.fp, "mtllib %s\n", a->mtllib);
    for (int32_t i = 0; i < nv; i++) {
        if (Vd)
            fprintf(af.fp, "v %.17g %.17g %.17g\n", Vd[3 * (size_t)i], Vd[3 * (size_t)i + 1],
                    Vd[3 * (size_t)i + 2]);
        else
            fprintf(af.fp, "v %.9g %.9g %.9g\n", (double)Vf[3 * (size_t)i],
                    (double)Vf[3 * (size_t)i + 1], (double)Vf[3 * (size_t)i + 2]);
    }
    for (int32_t i = 0; a && a->uv && i < a->nuv; i++)
        fprintf(af.fp, "vt %.17g %.17g\n", a->uv[2 * (size_t)i], a->uv[2 * (size_t)i + 1]);
    for (int32_t i = 0; a && a->normals && i < a->nn; i++)
        fprintf(af.fp, "vn %.17g %.17g %.17g\n", a->normals[3 * (size_t)i],
                a->normals[3 * (size_t)i + 1], a->normals[3 * (size_t)i + 2]);
    for (int32_t f = 0; f < nf; f++) {
        if (a && a->material && a->material[f] != cur) {
            cur = a->material[f];
            if (cur >= 0)
                fprintf(af.fp, "usemtl %s\n", a->material_names[cur]);
        }
        fputc('f', af.fp);
        for (int k = 0; k < 3; k++)
            corner(af.fp, F[3 * (size_t)f + k], a && a->uv ? a->uv_faces : NULL, nfaces,
                   3 * (size_t)f + (size_t)k);
        fputc('\n', af.fp);
    }
    return dtx_atomic_commit(&af, err);
}
