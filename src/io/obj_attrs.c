/* obj_attrs.c: the attributes of an OBJ file (vt, vn, per-corner v/t/n
 * references, usemtl, mtllib), read in a pass of their own after
 * dtx_obj_parse has read the mesh: faces are fan-triangulated exactly as
 * there, so attribute face i belongs to mesh face i. */
#include "meshfile.h"
#include "meshfile_util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static int kw(const char *k, size_t n, const char *lit)
{
    return strlen(lit) == n && memcmp(k, lit, n) == 0;
}

/* Resolves a 1-based or negative OBJ index against count items so far. */
static int resolve(int64_t v, int64_t sofar, int64_t total, int32_t *out)
{
    if (v > 0 && v <= total) {
        *out = (int32_t)(v - 1);
        return 0;
    }
    if (v < 0 && v >= -sofar) {
        *out = (int32_t)(sofar + v);
        return 0;
    }
    return -1;
}

dtx_status dtx_obj_parse_attrs(const char *name, const char *buf, size_t len, int32_t nf,
                               dtx_mesh_attrs *a, dtx_error *err)
{
    dtx_lines it;
    const char *b, *e;
    int64_t nvt = 0, nvn = 0, cvt = 0, cvn = 0, tri = 0;
    int has_t = 1, has_n = 1, any_f = 0;
    int32_t cur_mat = -1, cap_mat = 0;
    dtx_status st = DTX_OK;
    memset(a, 0, sizeof *a);
    /* ---- counts */
    dtx_lines_init(&it, buf, len);
    while (dtx_lines_next(&it, &b, &e)) {
        const char *p = b, *k;
        size_t n;
        if (!(k = dtx_next_token(&p, e, &n)))
            continue;
        nvt += kw(k, n, "vt");
        nvn += kw(k, n, "vn");
    }
    if (nvt > INT32_MAX || nvn > INT32_MAX)
        return dtx_seterr(err, DTX_ERANGE, "%s: too many vt or vn lines", name);
    a->nuv = (int32_t)nvt;
    a->nn = (int32_t)nvn;
    a->uv = nvt ? malloc((size_t)nvt * 2 * sizeof *a->uv) : NULL;
    a->normals = nvn ? malloc((size_t)nvn * 3 * sizeof *a->normals) : NULL;
    a->uv_faces = nvt ? malloc((size_t)(nf ? nf : 1) * 3 * sizeof *a->uv_faces) : NULL;
    a->normal_faces = nvn ? malloc((size_t)(nf ? nf : 1) * 3 * sizeof *a->normal_faces) : NULL;
    a->material = malloc((size_t)(nf ? nf : 1) * sizeof *a->material);
    if ((nvt && (!a->uv || !a->uv_faces)) || (nvn && (!a->normals || !a->normal_faces)) ||
        !a->material) {
        st = dtx_seterr(err, DTX_ENOMEM, "%s: out of memory for the attributes", name);
        goto fail;
    }
    /* ---- values and references */
    dtx_lines_init(&it, buf, len);
    while (dtx_lines_next(&it, &b, &e)) {
        const char *p = b, *k, *t;
        size_t n;
        if (!(k = dtx_next_token(&p, e, &n)) || k[0] == '#')
            continue;
        if (kw(k, n, "vt") || kw(k, n, "vn")) {
            int isn = k[1] == 'n', want = isn ? 3 : 2, cnt = 0;
            double x[3] = {0, 0, 0};
            while ((t = dtx_next_token(&p, e, &n)) && t[0] != '#' && cnt < want) {
                if (dtx_parse_double(t, n, &x[cnt]) != 0 || !isfinite(x[cnt])) {
                    st = dtx_seterr(err, DTX_EPARSE, "%s:%ld: malformed %s line", name, it.line,
                                    isn ? "vn" : "vt");
                    goto fail;
                }
                cnt++;
            }
            if (cnt < (isn ? 3 : 1)) {
                st = dtx_seterr(err, DTX_EPARSE, "%s:%ld: %s line with %d numbers", name,
                                it.line, isn ? "vn" : "vt", cnt);
                goto fail;
            }
            if (isn)
                memcpy(a->normals + 3 * cvn++, x, 3 * sizeof *x);
            else
                memcpy(a->uv + 2 * cvt++, x, 2 * sizeof *x);
        } else if (kw(k, n, "mtllib") || kw(k, n, "usemtl")) {
            const char *s = p;
            size_t m;
            while (s < e && (*s == ' ' || *s == '\t'))
                s++;
            m = (size_t)(e - s);
            while (m > 0 && (s[m - 1] == ' ' || s[m - 1] == '\t' || s[m - 1] == '\r'))
                m--;
            if (k[0] == 'm') {
                free(a->mtllib);
                if (!(a->mtllib = malloc(m + 1)))
                    goto nomem;
                memcpy(a->mtllib, s, m);
                a->mtllib[m] = 0;
            } else {
                int32_t i;
                for (i = 0; i < a->nmat; i++)
                    if (strlen(a->material_names[i]) == m && memcmp(a->material_names[i], s, m) == 0)
                        break;
                if (i == a->nmat) {
                    if (a->nmat == cap_mat) {
                        char **q = realloc(a->material_names,
                                           (size_t)(cap_mat ? 2 * cap_mat : 8) * sizeof *q);
                        if (!q)
                            goto nomem;
                        a->material_names = q;
                        cap_mat = cap_mat ? 2 * cap_mat : 8;
                    }
                    if (!(a->material_names[i] = malloc(m + 1)))
                        goto nomem;
                    memcpy(a->material_names[i], s, m);
                    a->material_names[i][m] = 0;
                    a->nmat++;
                }
                cur_mat = i;
            }
        } else if (kw(k, n, "f")) {
            int32_t ft[3] = {0, 0, 0}, fn[3] = {0, 0, 0};
            int64_t cnt = 0;
            any_f = 1;
            while ((t = dtx_next_token(&p, e, &n)) && t[0] != '#') {
                const char *s1 = memchr(t, '/', n), *s2 = NULL, *end = t + n;
                int64_t tv = 0, nv = 0;
                int32_t ti = -1, ni = -1;
                if (s1)
                    s2 = memchr(s1 + 1, '/', (size_t)(end - s1 - 1));
                if (s1 && (s2 ? s2 : end) > s1 + 1 &&
                    dtx_parse_int64(s1 + 1, (size_t)((s2 ? s2 : end) - s1 - 1), &tv) == 0 &&
                    resolve(tv, cvt, nvt, &ti) != 0) {
                    st = dtx_seterr(err, DTX_ERANGE, "%s:%ld: texture coordinate index %lld out "
                                    "of range (%lld vt lines)", name, it.line, (long long)tv,
                                    (long long)nvt);
                    goto fail;
                }
                if (s2 && s2 + 1 < end && dtx_parse_int64(s2 + 1, (size_t)(end - s2 - 1), &nv) == 0 &&
                    resolve(nv, cvn, nvn, &ni) != 0) {
                    st = dtx_seterr(err, DTX_ERANGE, "%s:%ld: normal index %lld out of range "
                                    "(%lld vn lines)", name, it.line, (long long)nv, (long long)nvn);
                    goto fail;
                }
                has_t &= ti >= 0;
                has_n &= ni >= 0;
                if (cnt == 0) {
                    ft[0] = ti;
                    fn[0] = ni;
                } else if (cnt >= 2 && tri < nf) {
                    if (a->uv_faces) {
                        a->uv_faces[3 * tri] = ft[0];
                        a->uv_faces[3 * tri + 1] = ft[1];
                        a->uv_faces[3 * tri + 2] = ti;
                    }
                    if (a->normal_faces) {
                        a->normal_faces[3 * tri] = fn[0];
                        a->normal_faces[3 * tri + 1] = fn[1];
                        a->normal_faces[3 * tri + 2] = ni;
                    }
                    a->material[tri] = cur_mat;
                    tri++;
                }
                ft[1] = ti;
                fn[1] = ni;
                cnt++;
            }
        }
    }
    if (tri != nf) {
        st = dtx_seterr(err, DTX_EPARSE, "%s: %lld attribute faces for %d mesh faces", name,
                        (long long)tri, (int)nf);
        goto fail;
    }
    /* Corners without a vt (or vn) reference: the attribute is not
     * per corner throughout, so it is not kept. */
    if (!has_t || !any_f) {
        free(a->uv);
        free(a->uv_faces);
        a->uv = NULL;
        a->uv_faces = NULL;
        a->nuv = 0;
    }
    if (!has_n || !any_f) {
        free(a->normals);
        free(a->normal_faces);
        a->normals = NULL;
        a->normal_faces = NULL;
        a->nn = 0;
    }
    if (a->nmat == 0) {
        free(a->material);
        a->material = NULL;
    }
    return dtx_mesh_attrs_validate(a, INT32_MAX, nf, name, err) == DTX_OK ? DTX_OK
                                                                          : (dtx_mesh_attrs_free(a), DTX_EPARSE);
nomem:
    st = dtx_seterr(err, DTX_ENOMEM, "%s: out of memory for the attributes", name);
fail:
    dtx_mesh_attrs_free(a);
    return st;
}

dtx_status dtx_obj_read_attrs(const char *path, int32_t nf, dtx_mesh_attrs *a, dtx_error *err)
{
    char *buf = NULL;
    size_t len = 0;
    dtx_status st = dtx_file_read_all(path, &buf, &len, err);
    memset(a, 0, sizeof *a);
    if (st == DTX_OK)
        st = dtx_obj_parse_attrs(path, buf, len, nf, a, err);
    free(buf);
    return st;
}
