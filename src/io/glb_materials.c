/* glb_materials.c: materials of a stored asset for the .glb writer
 * (glb_materials.h). */
#include "glb_materials.h"

#include "h5layout.h"
#include "meshfile_util.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#define IMAGE_MAX ((size_t)256 << 20) /* larger textures are not embedded */

/* ------------------------------------------------------------ .mtl */

void dtx_mtl_free(dtx_mtl *m)
{
    if (!m)
        return;
    for (int32_t i = 0; i < m->n; i++) {
        free(m->m[i].name);
        free(m->m[i].map_kd);
    }
    free(m->m);
    memset(m, 0, sizeof *m);
}

static char *dup_range(const char *b, const char *e)
{
    char *s;
    while (b < e && dtx_is_blank(*b))
        b++;
    while (e > b && dtx_is_blank(e[-1]))
        e--;
    s = malloc((size_t)(e - b) + 1);
    if (s) {
        memcpy(s, b, (size_t)(e - b));
        s[e - b] = 0;
    }
    return s;
}

/* Reads up to max numbers from [p, e) into v; returns how many. */
static int numbers(const char *p, const char *e, double *v, int max)
{
    int n = 0;
    while (n < max) {
        char tok[DTX_MAX_NUMBER_LEN + 1], *end;
        size_t len;
        const char *t = dtx_next_token(&p, e, &len);
        if (!t)
            break;
        if (len > DTX_MAX_NUMBER_LEN)
            return -1;
        memcpy(tok, t, len);
        tok[len] = 0;
        v[n] = strtod(tok, &end);
        if (*end || !isfinite(v[n]))
            return -1;
        n++;
    }
    return n;
}

/* 1 when the token [t, t + n) is a number. */
static int is_number(const char *t, size_t n)
{
    char tok[64], *end;
    if (n == 0 || n >= sizeof tok)
        return 0;
    memcpy(tok, t, n);
    tok[n] = 0;
    (void)strtod(tok, &end);
    return *end == 0;
}

/* The map options whose value is a word (MTL specification). */
static int word_option(const char *t, size_t n)
{
    static const char *const w[] = {"-clamp", "-blendu", "-blendv", "-cc", "-imfchan", "-type"};
    for (size_t i = 0; i < sizeof w / sizeof *w; i++)
        if (strlen(w[i]) == n && memcmp(w[i], t, n) == 0)
            return 1;
    return 0;
}

dtx_status dtx_mtl_parse(const char *name, const char *buf, size_t len, dtx_mtl *out,
                         dtx_error *err)
{
    dtx_lines it;
    const char *b, *e;
    int32_t cap = 0;
    memset(out, 0, sizeof *out);
    dtx_lines_init(&it, buf, len);
    while (dtx_lines_next(&it, &b, &e)) {
        const char *p = b, *k;
        size_t n;
        dtx_mtl_material *cur = out->n ? out->m + out->n - 1 : NULL;
        k = dtx_next_token(&p, e, &n);
        if (!k || *k == '#')
            continue;
        if (n == 6 && memcmp(k, "newmtl", 6) == 0) {
            if (out->n == cap) {
                int32_t nc = cap ? 2 * cap : 8;
                dtx_mtl_material *m = realloc(out->m, (size_t)nc * sizeof *m);
                if (!m)
                    goto oom;
                out->m = m, cap = nc;
            }
            cur = out->m + out->n;
            memset(cur, 0, sizeof *cur);
            cur->alpha = 1.0;
            if (!(cur->name = dup_range(p, e)))
                goto oom;
            out->n++;
        } else if (!cur) {
            continue; /* statements before the first newmtl belong to none */
        } else if (n == 2 && memcmp(k, "Kd", 2) == 0) {
            if (numbers(p, e, cur->kd, 3) != 3) {
                dtx_mtl_free(out);
                return dtx_seterr(err, DTX_EPARSE, "%s:%ld: Kd needs three numbers", name, it.line);
            }
            cur->has_kd = 1;
        } else if ((n == 1 && *k == 'd') || (n == 2 && memcmp(k, "Tr", 2) == 0)) {
            double v;
            if (numbers(p, e, &v, 1) != 1) {
                dtx_mtl_free(out);
                return dtx_seterr(err, DTX_EPARSE, "%s:%ld: %.*s needs a number", name, it.line,
                                  (int)n, k);
            }
            cur->alpha = n == 1 ? v : 1.0 - v;
        } else if (n == 6 && memcmp(k, "map_Kd", 6) == 0) {
            /* Options come before the file name: -name and its values
             * (numbers, or one word for the options that take a word). */
            for (;;) {
                const char *save = p, *t;
                size_t tn;
                t = dtx_next_token(&p, e, &tn);
                if (!t || t[0] != '-' || is_number(t, tn)) {
                    p = save;
                    break;
                }
                if (word_option(t, tn)) {
                    (void)dtx_next_token(&p, e, &tn);
                    continue;
                }
                for (;;) {
                    const char *s2 = p, *u = dtx_next_token(&p, e, &tn);
                    if (!u || !is_number(u, tn)) {
                        p = s2;
                        break;
                    }
                }
            }
            free(cur->map_kd);
            if (!(cur->map_kd = dup_range(p, e)))
                goto oom;
            if (!cur->map_kd[0]) {
                free(cur->map_kd);
                cur->map_kd = NULL;
            }
        }
    }
    return DTX_OK;
oom:
    dtx_mtl_free(out);
    return dtx_seterr(err, DTX_ENOMEM, "%s: out of memory", name);
}

/* ------------------------------------------------------------ paths */

static void note(dtx_glb_materials *m, const char *fmt, ...)
{
    size_t used = strlen(m->note);
    va_list ap;
    if (used + 3 >= sizeof m->note)
        return;
    if (used) {
        strcpy(m->note + used, "; ");
        used += 2;
    }
    va_start(ap, fmt);
    vsnprintf(m->note + used, sizeof m->note - used, fmt, ap);
    va_end(ap);
}

static int is_file(const char *path)
{
    struct stat sb;
    return stat(path, &sb) == 0 && S_ISREG(sb.st_mode);
}

/* The folder of path (none: the current one) joined with rel, into out
 * ("" when it does not fit). */
static void beside(const char *path, const char *rel, char *out, size_t n)
{
    const char *slash = strrchr(path, '/');
    int w;
    if (rel[0] == '/' || !slash)
        w = snprintf(out, n, "%s", rel);
    else
        w = snprintf(out, n, "%.*s/%s", (int)(slash - path), path, rel);
    if (w < 0 || (size_t)w >= n)
        out[0] = 0;
}

/* rel as stored in the file `holder`: beside it, else as written. */
static int find_rel(const char *holder, const char *rel, char *out, size_t n)
{
    beside(holder, rel, out, n);
    if (is_file(out))
        return 1;
    snprintf(out, n, "%s", rel);
    return is_file(out);
}

static int ends_with_ci(const char *s, const char *suffix)
{
    size_t a = strlen(s), b = strlen(suffix);
    return a >= b && strcasecmp(s + a - b, suffix) == 0;
}

/* Follows the source chain from group in f (file) to the OBJ; 1 when found
 * (path in obj). */
static int find_obj(hid_t f, const char *file, const char *group, char *obj, size_t n)
{
    char holder[4096], grp[DTX_H5_PATH_MAX], h5[4096];
    hid_t cur = f;
    int found = 0;
    snprintf(holder, sizeof holder, "%s", file);
    snprintf(grp, sizeof grp, "%s", group);
    for (int hop = 0; hop < 8 && !found; hop++) {
        char *src = NULL, *sep;
        dtx_error e2;
        hid_t next = H5I_INVALID_HID;
        if (dtx_h5_read_attr_str(cur, grp, "source", &src, &e2) != DTX_OK || !src) {
            free(src);
            break;
        }
        sep = strstr(src, ":/");
        if (ends_with_ci(src, ".obj")) {
            found = find_rel(holder, src, obj, n);
        } else if (sep) {
            *sep = 0;
            if (find_rel(holder, src, h5, sizeof h5) &&
                dtx_h5_open(h5, MPI_COMM_NULL, 0, &next, &e2) == DTX_OK) {
                snprintf(grp, sizeof grp, "/%s", sep + 2);
                snprintf(holder, sizeof holder, "%s", h5);
            }
        }
        free(src);
        if (cur != f)
            dtx_h5_close(&cur, NULL);
        cur = next;
        if (cur < 0)
            break;
    }
    if (cur >= 0 && cur != f)
        dtx_h5_close(&cur, NULL);
    return found;
}

/* Reads an image file; NULL (with a note) when missing, too big or not
 * PNG/JPEG. */
static unsigned char *read_image(dtx_glb_materials *m, const char *path, size_t *len)
{
    static const unsigned char png[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    char *buf = NULL;
    struct stat sb;
    dtx_error e2;
    if (stat(path, &sb) != 0 || !S_ISREG(sb.st_mode)) {
        note(m, "texture %s not found", path);
        return NULL;
    }
    if ((size_t)sb.st_size > IMAGE_MAX) {
        note(m, "texture %s is over 256 MiB: not embedded", path);
        return NULL;
    }
    if (dtx_file_read_all(path, &buf, len, &e2) != DTX_OK) {
        note(m, "%s", e2.msg);
        return NULL;
    }
    if (!((*len >= 8 && memcmp(buf, png, 8) == 0) ||
          (*len >= 3 && (unsigned char)buf[0] == 0xff && (unsigned char)buf[1] == 0xd8 &&
           (unsigned char)buf[2] == 0xff))) {
        note(m, "texture %s is neither PNG nor JPEG: not embedded", path);
        free(buf);
        return NULL;
    }
    return (unsigned char *)buf;
}

static float clamp01(double x) { return x < 0.0 ? 0.0f : x > 1.0 ? 1.0f : (float)x; }

dtx_status dtx_glb_materials_load(hid_t f, const char *file, const char *group,
                                  const dtx_mesh_attrs *a, dtx_glb_materials *out, dtx_error *err)
{
    char obj[4096], mtl_path[4096], lib[4096];
    dtx_mtl lib_m;
    char *buf = NULL;
    size_t len;
    dtx_error e2;
    memset(out, 0, sizeof *out);
    memset(&lib_m, 0, sizeof lib_m);
    if (!a || !a->material || a->nmat < 1)
        return DTX_OK;
    out->mat = dtx_alloc((size_t)a->nmat, sizeof *out->mat, 1);
    if (!out->mat)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory for %d materials", (int)a->nmat);
    out->n = a->nmat;
    for (int32_t k = 0; k < a->nmat; k++)
        if (a->material_names && a->material_names[k] &&
            !(out->mat[k].name = strdup(a->material_names[k]))) {
            dtx_glb_materials_free(out);
            return dtx_seterr(err, DTX_ENOMEM, "out of memory for %d materials", (int)a->nmat);
        }
    if (!a->mtllib || !a->mtllib[0]) {
        note(out, "%s names no material library (mtllib): materials without colours", group);
        return DTX_OK;
    }
    /* The first file of the mtllib line (names may not hold blanks). */
    snprintf(lib, sizeof lib, "%s", a->mtllib);
    if (find_obj(f, file, group, obj, sizeof obj)) {
        out->obj_path = strdup(obj);
        beside(obj, lib, mtl_path, sizeof mtl_path);
    } else {
        beside(file, lib, mtl_path, sizeof mtl_path);
    }
    if (!is_file(mtl_path)) {
        char *sp = strpbrk(lib, " \t");
        if (sp) {
            *sp = 0;
            beside(out->obj_path ? obj : file, lib, mtl_path, sizeof mtl_path);
        }
    }
    if (!is_file(mtl_path) && out->obj_path) { /* not beside the OBJ: beside the dtx file */
        beside(file, lib, mtl_path, sizeof mtl_path);
    }
    if (!is_file(mtl_path)) {
        if (out->obj_path)
            note(out,
                 "material library %s not found beside %s or %s (materials without "
                 "colours)",
                 lib, out->obj_path, file);
        else
            note(out,
                 "the asset's OBJ was not found (source attributes from %s:%s) and %s is "
                 "not beside %s (materials without colours)",
                 file, group, lib, file);
        return DTX_OK;
    }
    out->mtl_path = strdup(mtl_path);
    if (dtx_file_read_all(mtl_path, &buf, &len, &e2) != DTX_OK) {
        note(out, "%s", e2.msg);
        return DTX_OK;
    }
    if (dtx_mtl_parse(mtl_path, buf, len, &lib_m, &e2) != DTX_OK) {
        free(buf);
        if (e2.code == DTX_ENOMEM)
            return dtx_seterr(err, DTX_ENOMEM, "%s", e2.msg);
        note(out, "%s (materials without colours)", e2.msg);
        return DTX_OK;
    }
    free(buf);
    for (int32_t k = 0; k < a->nmat; k++) {
        const dtx_mtl_material *mm = NULL;
        dtx_glb_material *g = out->mat + k;
        for (int32_t i = 0; g->name && i < lib_m.n; i++)
            if (strcmp(lib_m.m[i].name, g->name) == 0)
                mm = lib_m.m + i;
        if (!mm) {
            note(out, "material %s is not in %s", g->name ? g->name : "(unnamed)", mtl_path);
            continue;
        }
        if (mm->has_kd) {
            g->has_color = 1;
            for (int c = 0; c < 3; c++)
                g->base_color[c] = clamp01(mm->kd[c]);
            g->base_color[3] = clamp01(mm->alpha);
        }
        if (mm->map_kd) {
            char ip[4096];
            size_t ilen = 0;
            beside(mtl_path, mm->map_kd, ip, sizeof ip);
            g->image = read_image(out, ip, &ilen);
            g->image_len = ilen;
            if (g->image) {
                const char *base = strrchr(mm->map_kd, '/');
                g->image_name = strdup(base ? base + 1 : mm->map_kd);
                out->nimages++;
            }
        }
    }
    dtx_mtl_free(&lib_m);
    return DTX_OK;
}

void dtx_glb_materials_free(dtx_glb_materials *m)
{
    if (!m)
        return;
    for (int32_t k = 0; k < m->n; k++) {
        free((void *)m->mat[k].image);
        free((void *)m->mat[k].image_name);
        free((void *)m->mat[k].name);
    }
    free(m->mat);
    free(m->obj_path);
    free(m->mtl_path);
    memset(m, 0, sizeof *m);
}
