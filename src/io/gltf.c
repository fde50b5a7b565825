/*
 * gltf.c: the .glb writer (layout in gltf.h).
 *
 * Phases: check the arguments; the glTF vertices (one per distinct corner
 * attribute combination) and the primitives (faces grouped by material);
 * rest positions, normals and UVs in float32; pass 1 over the frames for
 * the morph targets' min/max; the JSON document (cJSON) and the byte
 * layout; then header, JSON chunk and BIN chunk (pass 2 over the frames
 * writes the deltas) into an atomic file.
 *
 * Numbers that must be exact in the JSON (accessor min/max, which
 * validators compare with the data, and byte counts that may exceed
 * INT_MAX, which cJSON would print through a saturated int) are written
 * as raw JSON text: floats with %.17g of their exact double value, which
 * reads back as exactly that value whether a reader keeps doubles or
 * rounds to float32.
 */
#include "gltf.h"
#include "byteorder.h"

#include "atomic_file.h"
#include "weld.h"

#include <cjson/cJSON.h>

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* glTF constants (specification, "Accessor" and "Buffer View"). */
enum {
    GL_UNSIGNED_SHORT = 5123,
    GL_UNSIGNED_INT = 5125,
    GL_FLOAT = 5126,
    GL_ARRAY_BUFFER = 34962,
    GL_ELEMENT_ARRAY_BUFFER = 34963,
    GL_TRIANGLES = 4
};
#define GLB_MAGIC 0x46546C67u      /* "glTF" */
#define GLB_CHUNK_JSON 0x4E4F534Au /* "JSON" */
#define GLB_CHUNK_BIN 0x004E4942u  /* "BIN\0" */

static uint64_t align4(uint64_t n) { return (n + 3u) & ~(uint64_t)3u; }

/* A double that fits float32 once rounded (no overflow to infinity). */
static int fits_f32(double x) { return isfinite(x) && fabs(x) <= FLT_MAX; }

/* ------------------------------------------------------------ JSON helpers */

/* Building the document: every helper checks its inputs for NULL and
 * records an allocation failure in *oom, so the builder can run straight
 * through and test once at the end. */
typedef struct {
    int oom;
} jctx;

static cJSON *jadd(jctx *j, cJSON *parent, const char *key, cJSON *item)
{
    if (!item) {
        j->oom = 1;
        return NULL;
    }
    if (!parent) {
        cJSON_Delete(item);
        j->oom = 1;
        return NULL;
    }
    if (key ? !cJSON_AddItemToObject(parent, key, item) : !cJSON_AddItemToArray(parent, item)) {
        cJSON_Delete(item);
        j->oom = 1;
        return NULL;
    }
    return item;
}

static cJSON *jint(jctx *j, cJSON *parent, const char *key, int64_t v)
{
    char buf[32];
    snprintf(buf, sizeof buf, "%lld", (long long)v);
    return jadd(j, parent, key, cJSON_CreateRaw(buf));
}

static cJSON *jflt(jctx *j, cJSON *parent, const char *key, float v)
{
    char buf[40];
    snprintf(buf, sizeof buf, "%.17g", (double)v);
    return jadd(j, parent, key, cJSON_CreateRaw(buf));
}

static cJSON *jstr(jctx *j, cJSON *parent, const char *key, const char *s)
{
    return jadd(j, parent, key, cJSON_CreateString(s));
}

static cJSON *jobj(jctx *j, cJSON *parent, const char *key)
{
    return jadd(j, parent, key, cJSON_CreateObject());
}

static cJSON *jarr(jctx *j, cJSON *parent, const char *key)
{
    return jadd(j, parent, key, cJSON_CreateArray());
}

static void jvec3(jctx *j, cJSON *acc, const char *key, const float *v)
{
    cJSON *a = jarr(j, acc, key);
    for (int c = 0; c < 3; c++)
        jflt(j, a, NULL, v[c]);
}

static void buffer_view(jctx *j, cJSON *views, uint64_t off, uint64_t len, int stride, int target)
{
    cJSON *v = jobj(j, views, NULL);
    jint(j, v, "buffer", 0);
    jint(j, v, "byteOffset", (int64_t)off);
    jint(j, v, "byteLength", (int64_t)len);
    if (stride)
        jint(j, v, "byteStride", stride);
    if (target)
        jint(j, v, "target", target);
}

static cJSON *accessor(jctx *j, cJSON *accs, int view, uint64_t off, int ctype, int64_t count,
                       const char *type)
{
    cJSON *a = jobj(j, accs, NULL);
    jint(j, a, "bufferView", view);
    if (off)
        jint(j, a, "byteOffset", (int64_t)off);
    jint(j, a, "componentType", ctype);
    jint(j, a, "count", count);
    jstr(j, a, "type", type);
    return a;
}

/* ------------------------------------------------------------ geometry */

/* Area-weighted unit normals of positions X (nv x 3) on the faces F,
 * summed over weld classes (wmap: nv -> [0, nw), NULL: none) so that
 * vertices at one position share one normal.  acc: nw x 3 scratch; N: nv x
 * 3 doubles.  A class whose faces have no area gets +z. */
static void smooth_normals(const double *X, int32_t nv, const int32_t *F, int32_t nf,
                           const int32_t *wmap, int32_t nw, double *acc, double *N)
{
    memset(acc, 0, 3 * (size_t)nw * sizeof *acc);
    for (int32_t f = 0; f < nf; f++) {
        const int32_t *t = F + 3 * (size_t)f;
        const double *a = X + 3 * (size_t)t[0], *b = X + 3 * (size_t)t[1],
                     *c = X + 3 * (size_t)t[2];
        double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        double e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                       e1[0] * e2[1] - e1[1] * e2[0]};
        for (int k = 0; k < 3; k++) {
            int32_t w = wmap ? wmap[t[k]] : t[k];
            for (int c2 = 0; c2 < 3; c2++)
                acc[3 * (size_t)w + c2] += n[c2];
        }
    }
    for (int32_t w = 0; w < nw; w++) {
        double *n = acc + 3 * (size_t)w;
        double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (!(len > 0.0) || !isfinite(len)) {
            n[0] = 0.0, n[1] = 0.0, n[2] = 1.0;
            len = 1.0;
        }
        for (int c = 0; c < 3; c++)
            n[c] /= len;
    }
    for (int32_t i = 0; i < nv; i++)
        for (int c = 0; c < 3; c++)
            N[3 * (size_t)i + c] = acc[3 * (size_t)(wmap ? wmap[i] : i) + c];
}

/* Per-target bounds of the deltas: T x 6 floats (min xyz, max xyz). */
static void bounds_init(float *b)
{
    for (int c = 0; c < 3; c++) {
        b[c] = FLT_MAX;
        b[3 + c] = -FLT_MAX;
    }
}

/* FNV-1a 64 of the n floats at D (their bytes in memory order). */
static uint64_t hash_floats(const float *D, size_t n)
{
    const unsigned char *p = (const unsigned char *)D;
    uint64_t h = UINT64_C(0xcbf29ce484222325);
    for (size_t i = 0; i < n * sizeof *D; i++)
        h = (h ^ p[i]) * UINT64_C(0x100000001b3);
    return h;
}

/* Fetches frame k into X and rounds X - rest to float32 into D (nv x 3),
 * with its bounds into b[6] and the hash of D into *h. */
static dtx_status frame_deltas(const char *path, const dtx_mesh *rest, int64_t k,
                               dtx_glb_frame_fn frame, void *ctx, double *X, float *D, float *b,
                               uint64_t *h, dtx_error *err)
{
    dtx_status st = frame(ctx, k, X, err);
    if (st != DTX_OK)
        return st;
    bounds_init(b);
    for (size_t i = 0; i < 3 * (size_t)rest->nv; i++) {
        double d = X[i] - rest->V[i];
        float f;
        if (!fits_f32(X[i]) || !fits_f32(d))
            return dtx_seterr(err, DTX_ENONFINITE,
                              "%s: frame %lld, vertex %zu (0-based): coordinate %g (or its "
                              "difference from the rest) is not a finite float32",
                              path, (long long)k, i / 3, X[i]);
        f = (float)d;
        D[i] = f;
        b[i % 3] = f < b[i % 3] ? f : b[i % 3];
        b[3 + i % 3] = f > b[3 + i % 3] ? f : b[3 + i % 3];
    }
    *h = hash_floats(D, 3 * (size_t)rest->nv);
    return DTX_OK;
}

/* ------------------------------------------------------------ glTF vertices */

/* The glTF vertices: one per distinct (vertex, uv index, normal index) of
 * the face corners, the first of dtx vertex i being glTF vertex i (gltf.h).
 * of[g]: the dtx vertex of glTF vertex g; t[g], n[g]: its uv and normal
 * index (-1: none); GF: nf x 3 glTF vertex indices.  Arrays hold nv + 3 nf
 * entries (the most there can be). */
typedef struct {
    int32_t ng;
    int32_t *of, *t, *n, *next, *GF;
} gverts;

static void gverts_free(gverts *g)
{
    free(g->of);
    free(g->t);
    free(g->n);
    free(g->next);
    free(g->GF);
    memset(g, 0, sizeof *g);
}

static dtx_status gverts_make(const dtx_mesh *m, const dtx_mesh_attrs *a, gverts *g, dtx_error *err)
{
    const int use_uv = a && a->uv, use_n = a && a->normals;
    size_t cap = (size_t)m->nv + 3 * (size_t)m->nf;
    memset(g, 0, sizeof *g);
    g->of = dtx_alloc(cap, sizeof *g->of, 0);
    g->t = dtx_alloc(cap, sizeof *g->t, 0);
    g->n = dtx_alloc(cap, sizeof *g->n, 0);
    g->next = dtx_alloc(cap, sizeof *g->next, 0);
    g->GF = dtx_alloc(3 * (size_t)m->nf, sizeof *g->GF, 0);
    if (!g->of || !g->t || !g->n || !g->next || !g->GF) {
        gverts_free(g);
        return dtx_seterr(err, DTX_ENOMEM, "out of memory for %d vertices", (int)m->nv);
    }
    for (int32_t i = 0; i < m->nv; i++) {
        g->of[i] = i;
        g->t[i] = g->n[i] = -2; /* no corner yet */
        g->next[i] = -1;
    }
    g->ng = m->nv;
    for (size_t c = 0; c < 3 * (size_t)m->nf; c++) {
        int32_t v = m->F[c], t = use_uv ? a->uv_faces[c] : -1, n = use_n ? a->normal_faces[c] : -1;
        int32_t x = v, last = v;
        if (g->t[v] == -2) {
            g->t[v] = t, g->n[v] = n;
        } else {
            while (x >= 0 && !(g->t[x] == t && g->n[x] == n))
                last = x, x = g->next[x];
            if (x < 0) {
                x = g->ng++;
                g->of[x] = v, g->t[x] = t, g->n[x] = n, g->next[x] = -1;
                g->next[last] = x;
            }
        }
        g->GF[c] = x;
    }
    for (int32_t i = 0; i < m->nv; i++)
        if (g->t[i] == -2) /* a vertex no face uses */
            g->t[i] = g->n[i] = -1;
    return DTX_OK;
}

/* ------------------------------------------------------------ the writer */

/* A primitive: the faces of one material (-1: none), in face order. */
typedef struct {
    int32_t material, nf;
    uint64_t off; /* byte offset of its indices in the indices view */
} prim_t;

/* Sizes and offsets of the BIN chunk, in bytes. */
typedef struct {
    uint64_t pos, nrm, uv, idx, idx_len, morph, morph_len, times, sp_idx, sp_val, total;
    uint64_t *img; /* image k's offset */
    int ushort;    /* indices as UNSIGNED_SHORT */
    int has_uv, nimg;
} layout;

static void make_layout(int32_t ng, int32_t nf, int has_uv, const dtx_glb_material *mat,
                        int32_t nmat, int64_t T, layout *L)
{
    uint64_t vbytes = 12u * (uint64_t)ng, at;
    L->has_uv = has_uv;
    L->ushort = ng <= 65535; /* 65535 itself is the primitive-restart value */
    L->pos = 0;
    L->nrm = vbytes;
    L->uv = 2 * vbytes;
    L->idx = L->uv + (has_uv ? 8u * (uint64_t)ng : 0u);
    L->idx_len = 3u * (uint64_t)nf * (L->ushort ? 2u : 4u);
    at = align4(L->idx + L->idx_len);
    L->nimg = 0;
    for (int32_t m = 0; m < nmat; m++)
        if (has_uv && mat && mat[m].image && mat[m].image_len > 0) {
            if (L->img)
                L->img[L->nimg] = at;
            L->nimg++;
            at = align4(at + mat[m].image_len);
        }
    L->morph = at;
    L->morph_len = 2u * vbytes * (uint64_t)T;
    L->times = L->morph + L->morph_len;
    L->sp_idx = L->times + 4u * (uint64_t)T;
    L->sp_val = L->sp_idx + 4u * (uint64_t)T;
    L->total = L->sp_val + 4u * (uint64_t)T;
}

/* "image/png", "image/jpeg" or NULL, from the first bytes. */
static const char *image_mime(const unsigned char *p, size_t n)
{
    static const unsigned char png[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    if (n >= 8 && memcmp(p, png, 8) == 0)
        return "image/png";
    if (n >= 3 && p[0] == 0xff && p[1] == 0xd8 && p[2] == 0xff)
        return "image/jpeg";
    return NULL;
}

/* Everything make_json needs. */
typedef struct {
    const dtx_mesh *m;
    const gverts *g;
    int64_t T;
    const layout *L;
    const prim_t *prims;
    int nprims;
    const dtx_glb_material *mat; /* nmat (names only when no colours) */
    const char *const *mat_names;
    int32_t nmat;
    const float *pmin, *pmax, *B, *times;
} doc_in;

/* The JSON document.  B: T x 6 delta bounds; times: T floats. */
static cJSON *make_json(const doc_in *d, const dtx_glb_opts *o, jctx *j)
{
    const dtx_mesh *m = d->m;
    const layout *L = d->L;
    const int64_t T = d->T, ng = d->g->ng;
    const char *name = o->name ? o->name : "dtx";
    cJSON *root = cJSON_CreateObject(), *asset, *x, *prims, *names, *weights, *accs, *views, *anim,
          *smp, *ch, *mextras;
    char buf[64];
    /* Accessor and view numbers: positions, normals, [uvs], the primitives'
     * indices, then two morph accessors a frame, times, weights. */
    const int64_t a_uv = 2, a_idx = L->has_uv ? 3 : 2, a_morph = a_idx + d->nprims,
                  a_times = a_morph + 2 * T, a_w = a_times + 1;
    const int v_idx = L->has_uv ? 3 : 2, v_img = v_idx + 1, v_morph = v_img + L->nimg,
              v_times = v_morph + 1;
    if (!root) {
        j->oom = 1;
        return NULL;
    }
    asset = jobj(j, root, "asset");
    jstr(j, asset, "version", "2.0");
    jstr(j, asset, "generator", "dtx " DTX_VERSION);
    if (o->source) {
        x = jobj(j, asset, "extras");
        jstr(j, x, "source", o->source);
    }
    jint(j, root, "scene", 0);
    x = jobj(j, jarr(j, root, "scenes"), NULL);
    jint(j, jarr(j, x, "nodes"), NULL, 0);
    x = jobj(j, jarr(j, root, "nodes"), NULL);
    jint(j, x, "mesh", 0);
    jstr(j, x, "name", name);

    /* ---- mesh: one primitive a material, sharing one morph target a frame */
    x = jobj(j, jarr(j, root, "meshes"), NULL);
    jstr(j, x, "name", name);
    prims = jarr(j, x, "primitives");
    weights = jarr(j, x, "weights");
    mextras = jobj(j, x, "extras");
    names = jarr(j, mextras, "targetNames");
    for (int p = 0; p < d->nprims && !j->oom; p++) {
        cJSON *prim = jobj(j, prims, NULL), *attr = jobj(j, prim, "attributes"), *targets;
        jint(j, attr, "POSITION", 0);
        jint(j, attr, "NORMAL", 1);
        if (L->has_uv)
            jint(j, attr, "TEXCOORD_0", a_uv);
        jint(j, prim, "indices", a_idx + p);
        if (d->prims[p].material >= 0)
            jint(j, prim, "material", d->prims[p].material);
        jint(j, prim, "mode", GL_TRIANGLES);
        targets = jarr(j, prim, "targets");
        for (int64_t k = 0; k < T && !j->oom; k++) {
            cJSON *t = jobj(j, targets, NULL);
            jint(j, t, "POSITION", a_morph + 2 * k);
            jint(j, t, "NORMAL", a_morph + 2 * k + 1);
        }
    }
    for (int64_t k = 0; k < T && !j->oom; k++) {
        jint(j, weights, NULL, 0);
        snprintf(buf, sizeof buf, "frame-%05lld", (long long)(o->label_first + k * o->label_step));
        jstr(j, names, NULL, buf);
    }
    if (ng > m->nv) {
        cJSON *cp = jobj(j, mextras, "dtx_vertex_copies"), *of;
        jint(j, cp, "vertices", m->nv);
        of = jarr(j, cp, "copy_of");
        for (int64_t g = m->nv; g < ng && !j->oom; g++)
            jint(j, of, NULL, d->g->of[g]);
    }

    /* ---- materials, textures, images */
    if (d->nmat > 0) {
        cJSON *mats = jarr(j, root, "materials"), *texs = NULL, *imgs = NULL;
        int img = 0;
        for (int32_t k = 0; k < d->nmat && !j->oom; k++) {
            const dtx_glb_material *mk = d->mat ? d->mat + k : NULL;
            cJSON *mo = jobj(j, mats, NULL), *pbr;
            if (mk && mk->name)
                jstr(j, mo, "name", mk->name);
            else if (d->mat_names && d->mat_names[k])
                jstr(j, mo, "name", d->mat_names[k]);
            else {
                snprintf(buf, sizeof buf, "material-%d", (int)k);
                jstr(j, mo, "name", buf);
            }
            pbr = jobj(j, mo, "pbrMetallicRoughness");
            if (mk && L->has_uv && mk->image && mk->image_len > 0) {
                cJSON *io;
                if (!texs) {
                    texs = jarr(j, root, "textures");
                    imgs = jarr(j, root, "images");
                }
                jint(j, jobj(j, pbr, "baseColorTexture"), "index", img);
                jint(j, jobj(j, texs, NULL), "source", img);
                io = jobj(j, imgs, NULL);
                if (mk->image_name)
                    jstr(j, io, "name", mk->image_name);
                jint(j, io, "bufferView", v_img + img);
                jstr(j, io, "mimeType", image_mime(mk->image, mk->image_len));
                img++;
            } else if (mk && mk->has_color) {
                cJSON *c = jarr(j, pbr, "baseColorFactor");
                for (int q = 0; q < 4; q++)
                    jflt(j, c, NULL, mk->base_color[q]);
            }
            /* OBJ materials are dielectric (glTF's default is metal). */
            jint(j, pbr, "metallicFactor", 0);
        }
    }

    /* ---- animation: the weights, one-hot per key (a sparse accessor) */
    anim = jobj(j, jarr(j, root, "animations"), NULL);
    jstr(j, anim, "name", "frames");
    smp = jobj(j, jarr(j, anim, "samplers"), NULL);
    jint(j, smp, "input", a_times);
    jint(j, smp, "output", a_w);
    jstr(j, smp, "interpolation", o->step ? "STEP" : "LINEAR");
    ch = jobj(j, jarr(j, anim, "channels"), NULL);
    jint(j, ch, "sampler", 0);
    x = jobj(j, ch, "target");
    jint(j, x, "node", 0);
    jstr(j, x, "path", "weights");

    /* ---- buffer, views, accessors */
    jint(j, jobj(j, jarr(j, root, "buffers"), NULL), "byteLength", (int64_t)L->total);
    views = jarr(j, root, "bufferViews");
    buffer_view(j, views, L->pos, 12u * (uint64_t)ng, 12, GL_ARRAY_BUFFER);
    buffer_view(j, views, L->nrm, 12u * (uint64_t)ng, 12, GL_ARRAY_BUFFER);
    if (L->has_uv)
        buffer_view(j, views, L->uv, 8u * (uint64_t)ng, 8, GL_ARRAY_BUFFER);
    buffer_view(j, views, L->idx, L->idx_len, 0, GL_ELEMENT_ARRAY_BUFFER);
    for (int32_t k = 0, img = 0; k < d->nmat && d->mat; k++)
        if (L->has_uv && d->mat[k].image && d->mat[k].image_len > 0)
            buffer_view(j, views, L->img[img++], d->mat[k].image_len, 0, 0);
    buffer_view(j, views, L->morph, L->morph_len, 12, GL_ARRAY_BUFFER);
    buffer_view(j, views, L->times, 4u * (uint64_t)T, 0, 0);
    buffer_view(j, views, L->sp_idx, 4u * (uint64_t)T, 0, 0);
    buffer_view(j, views, L->sp_val, 4u * (uint64_t)T, 0, 0);

    accs = jarr(j, root, "accessors");
    x = accessor(j, accs, 0, 0, GL_FLOAT, ng, "VEC3");
    jvec3(j, x, "min", d->pmin);
    jvec3(j, x, "max", d->pmax);
    accessor(j, accs, 1, 0, GL_FLOAT, ng, "VEC3");
    if (L->has_uv)
        accessor(j, accs, 2, 0, GL_FLOAT, ng, "VEC2");
    for (int p = 0; p < d->nprims; p++)
        accessor(j, accs, v_idx, d->prims[p].off, L->ushort ? GL_UNSIGNED_SHORT : GL_UNSIGNED_INT,
                 3 * (int64_t)d->prims[p].nf, "SCALAR");
    for (int64_t k = 0; k < T && !j->oom; k++) {
        x = accessor(j, accs, v_morph, 24u * (uint64_t)ng * (uint64_t)k, GL_FLOAT, ng, "VEC3");
        jvec3(j, x, "min", d->B + 6 * k);
        jvec3(j, x, "max", d->B + 6 * k + 3);
        accessor(j, accs, v_morph, 24u * (uint64_t)ng * (uint64_t)k + 12u * (uint64_t)ng, GL_FLOAT,
                 ng, "VEC3");
    }
    x = accessor(j, accs, v_times, 0, GL_FLOAT, T, "SCALAR");
    jflt(j, jarr(j, x, "min"), NULL, d->times[0]);
    jflt(j, jarr(j, x, "max"), NULL, d->times[T - 1]);
    /* The T x T one-hot weights: no buffer view (all zeros) and T sparse
     * entries, the 1 of key k at index k * T + k. */
    x = jobj(j, accs, NULL);
    jint(j, x, "componentType", GL_FLOAT);
    jint(j, x, "count", T * T);
    jstr(j, x, "type", "SCALAR");
    x = jobj(j, x, "sparse");
    jint(j, x, "count", T);
    smp = jobj(j, x, "indices");
    jint(j, smp, "bufferView", v_times + 1);
    jint(j, smp, "componentType", GL_UNSIGNED_INT);
    jint(j, jobj(j, x, "values"), "bufferView", v_times + 2);
    return root;
}

/* Writes n floats (in bytes[], at least 4 n) through af. */
static void write_f32s(FILE *fp, unsigned char *bytes, const float *v, size_t n)
{
    for (size_t i = 0; i < n; i++)
        dtx_put_lef32(bytes + 4 * i, v[i]);
    fwrite(bytes, 4, n, fp);
}

dtx_status dtx_glb_write(const char *path, const dtx_mesh *rest, int64_t nframes,
                         dtx_glb_frame_fn frame, void *ctx, const dtx_glb_opts *opts,
                         dtx_error *err)
{
    const int64_t T = nframes;
    const size_t n3 = 3 * (size_t)(rest ? rest->nv : 0);
    const dtx_mesh_attrs *at = opts ? opts->attrs : NULL;
    dtx_status st = DTX_OK;
    dtx_atomic_file af;
    jctx j = {0};
    layout L;
    gverts g;
    doc_in din;
    prim_t *prims = NULL;
    int nprims = 0;
    int32_t nmat = 0, nw = 0;
    size_t g3;
    cJSON *doc = NULL;
    char *json = NULL;
    double *X = NULL, *acc = NULL, *Nr = NULL, *Nk = NULL;
    int32_t *wmap = NULL, *wrep = NULL;
    float *P = NULL, *N = NULL, *UV = NULL, *D = NULL, *B = NULL, *times = NULL, *GD = NULL;
    unsigned char *bytes = NULL, head[28];
    float pmin[3], pmax[3], b2[6];
    uint64_t *H = NULL, h2;
    size_t json_len, json_pad, nbytes;
    uint64_t file_len;

    memset(&af, 0, sizeof af);
    memset(&g, 0, sizeof g);
    memset(&L, 0, sizeof L);

    /* ================================================ arguments */
    if (!rest || !frame || !opts)
        return dtx_seterr(err, DTX_EINVAL, "%s: missing mesh, frame source or options", path);
    if (rest->nv < 1 || rest->nf < 1 || !rest->V || !rest->F)
        return dtx_seterr(err, DTX_EINVAL, "%s: the rest mesh is empty (%d vertices, %d faces)",
                          path, (int)rest->nv, (int)rest->nf);
    if (T < 1 || T > DTX_GLB_MAX_FRAMES)
        return dtx_seterr(err, DTX_EINVAL, "%s: %lld frames; a .glb holds 1 to %d", path,
                          (long long)T, DTX_GLB_MAX_FRAMES);
    if (!(opts->seconds_per_frame > 0.0) || !isfinite(opts->seconds_per_frame))
        return dtx_seterr(err, DTX_EINVAL, "%s: seconds per frame %g must be finite and > 0", path,
                          opts->seconds_per_frame);
    for (size_t i = 0; i < 3 * (size_t)rest->nf; i++)
        if (rest->F[i] < 0 || rest->F[i] >= rest->nv)
            return dtx_seterr(err, DTX_ERANGE,
                              "%s: face %zu (0-based) has vertex index %d out of range [0, %d)",
                              path, i / 3, (int)rest->F[i], (int)rest->nv);
    for (size_t i = 0; i < n3; i++)
        if (!fits_f32(rest->V[i]))
            return dtx_seterr(err, DTX_ENONFINITE,
                              "%s: rest vertex %zu (0-based): coordinate %g is not a finite "
                              "float32",
                              path, i / 3, rest->V[i]);
    if (at) {
        st = dtx_mesh_attrs_validate(at, rest->nv, rest->nf, path, err);
        if (st != DTX_OK)
            return st;
        nmat = at->material ? at->nmat : 0;
        for (int32_t i = 0; at->uv && i < at->nuv; i++)
            if (!fits_f32(at->uv[2 * (size_t)i]) || !fits_f32(1.0 - at->uv[2 * (size_t)i + 1]))
                return dtx_seterr(err, DTX_ENONFINITE,
                                  "%s: uv %d (0-based) is not a finite float32", path, (int)i);
    }
    if (opts->materials && opts->nmaterials != nmat)
        return dtx_seterr(err, DTX_EINVAL, "%s: %d materials given for a mesh with %d", path,
                          (int)opts->nmaterials, (int)nmat);
    for (int32_t k = 0; opts->materials && k < nmat; k++) {
        const dtx_glb_material *mk = opts->materials + k;
        if (mk->image && !image_mime(mk->image, mk->image_len))
            return dtx_seterr(err, DTX_EINVAL,
                              "%s: material %d (%s): the image is neither PNG "
                              "nor JPEG",
                              path, (int)k, mk->name ? mk->name : "unnamed");
        for (int q = 0; mk->has_color && q < 4; q++)
            if (!(mk->base_color[q] >= 0.0f && mk->base_color[q] <= 1.0f))
                return dtx_seterr(err, DTX_EINVAL,
                                  "%s: material %d (%s): base colour component %d is %g, not "
                                  "in [0, 1]",
                                  path, (int)k, mk->name ? mk->name : "unnamed", q,
                                  (double)mk->base_color[q]);
    }

    /* ================================================ glTF vertices, primitives */
    st = gverts_make(rest, at, &g, err);
    if (st != DTX_OK) {
        dtx_error_prefix(err, "%s", path);
        return st;
    }
    g3 = 3 * (size_t)g.ng;
    prims = dtx_alloc((size_t)nmat + 1, sizeof *prims, 1);
    L.img = dtx_alloc((size_t)nmat + 1, sizeof *L.img, 1);
    if (!prims || !L.img) {
        st = dtx_seterr(err, DTX_ENOMEM, "%s: out of memory", path);
        goto fail;
    }
    for (int32_t k = 0; k <= nmat; k++) {
        int32_t id = k < nmat ? k : -1, cnt = 0;
        for (int32_t f = 0; f < rest->nf; f++)
            cnt += (nmat ? at->material[f] : -1) == id;
        if (cnt > 0)
            prims[nprims].material = id, prims[nprims++].nf = cnt;
    }
    make_layout(g.ng, rest->nf, at && at->uv, opts->materials, nmat, T, &L);
    for (int p = 0, sum = 0; p < nprims; p++) {
        prims[p].off = 3u * (uint64_t)sum * (L.ushort ? 2u : 4u);
        sum += prims[p].nf;
    }
    if (L.total + 28u > UINT32_MAX) /* before reading any frame; the JSON adds more below */
    {
        st = dtx_seterr(err, DTX_ERANGE,
                        "%s: the .glb would exceed 4 GiB (%d vertices x %lld frames); the "
                        "format stops there (export fewer frames)",
                        path, (int)g.ng, (long long)T);
        goto fail;
    }

    /* ================================================ buffers */
    nbytes = (size_t)4 * (g3 > (size_t)T ? g3 : (size_t)T);
    X = dtx_alloc(n3, sizeof *X, 0);
    acc = dtx_alloc(n3, sizeof *acc, 0);
    Nr = dtx_alloc(n3, sizeof *Nr, 0);
    Nk = dtx_alloc(n3, sizeof *Nk, 0);
    wmap = dtx_alloc((size_t)rest->nv, sizeof *wmap, 0);
    wrep = dtx_alloc((size_t)rest->nv, sizeof *wrep, 0);
    P = dtx_alloc(g3, sizeof *P, 0);
    N = dtx_alloc(g3, sizeof *N, 0);
    UV = dtx_alloc(2 * (size_t)g.ng, sizeof *UV, 0);
    GD = dtx_alloc(g3, sizeof *GD, 0);
    D = dtx_alloc(n3, sizeof *D, 0);
    B = dtx_alloc((size_t)T, 6 * sizeof *B, 0);
    H = dtx_alloc((size_t)T, sizeof *H, 0);
    times = dtx_alloc((size_t)T, sizeof *times, 0);
    bytes = dtx_alloc(nbytes, 1, 0);
    if (!X || !acc || !Nr || !Nk || !wmap || !wrep || !P || !N || !UV || !GD || !D || !B || !H ||
        !times || !bytes) {
        st = dtx_seterr(err, DTX_ENOMEM, "%s: out of memory (%d vertices, %lld frames)", path,
                        (int)rest->nv, (long long)T);
        goto fail;
    }

    /* ================================================ rest mesh, times */
    bounds_init(b2);
    for (size_t i = 0; i < n3; i++) {
        float p = (float)rest->V[i];
        b2[i % 3] = p < b2[i % 3] ? p : b2[i % 3];
        b2[3 + i % 3] = p > b2[3 + i % 3] ? p : b2[3 + i % 3];
    }
    memcpy(pmin, b2, sizeof pmin);
    memcpy(pmax, b2 + 3, sizeof pmax);
    st = dtx_weld_map(rest->V, rest->nv, 0.0, wmap, wrep, &nw, err);
    if (st != DTX_OK) {
        dtx_error_prefix(err, "%s", path);
        goto fail;
    }
    smooth_normals(rest->V, rest->nv, rest->F, rest->nf, wmap, nw, acc, Nr);
    for (int32_t q = 0; q < g.ng; q++) {
        const double *v = rest->V + 3 * (size_t)g.of[q], *n = Nr + 3 * (size_t)g.of[q];
        double len = 0.0;
        if (g.n[q] >= 0) { /* the asset's normal, when it has a direction */
            const double *an = at->normals + 3 * (size_t)g.n[q];
            len = sqrt(an[0] * an[0] + an[1] * an[1] + an[2] * an[2]);
            if (len > 0.0 && isfinite(len))
                n = an;
            else
                len = 0.0;
        }
        for (int c = 0; c < 3; c++) {
            P[3 * (size_t)q + c] = (float)v[c];
            N[3 * (size_t)q + c] = (float)(len > 0.0 ? n[c] / len : n[c]);
        }
        UV[2 * (size_t)q] = g.t[q] >= 0 ? (float)at->uv[2 * (size_t)g.t[q]] : 0.0f;
        UV[2 * (size_t)q + 1] = g.t[q] >= 0 ? (float)(1.0 - at->uv[2 * (size_t)g.t[q] + 1]) : 0.0f;
    }
    for (int64_t k = 0; k < T; k++) {
        double t = (double)k * opts->seconds_per_frame;
        if (!fits_f32(t) || (k > 0 && !((float)t > times[k - 1]))) {
            st = dtx_seterr(err, DTX_EINVAL,
                            "%s: frame times are not strictly increasing in float32 at frame "
                            "%lld (%g s per frame)",
                            path, (long long)k, opts->seconds_per_frame);
            goto fail;
        }
        times[k] = (float)t;
    }

    /* ================================================ pass 1: bounds */
    for (int64_t k = 0; k < T; k++) {
        st = frame_deltas(path, rest, k, frame, ctx, X, D, B + 6 * k, H + k, err);
        if (st != DTX_OK)
            goto fail;
    }

    /* ================================================ JSON, sizes */
    din.m = rest, din.g = &g, din.T = T, din.L = &L, din.prims = prims, din.nprims = nprims;
    din.mat = opts->materials;
    din.mat_names = at ? (const char *const *)at->material_names : NULL;
    din.nmat = nmat;
    din.pmin = pmin, din.pmax = pmax, din.B = B, din.times = times;
    doc = make_json(&din, opts, &j);
    json = (doc && !j.oom) ? cJSON_PrintUnformatted(doc) : NULL;
    if (!json) {
        st = dtx_seterr(err, DTX_ENOMEM, "%s: out of memory building the glTF JSON", path);
        goto fail;
    }
    json_len = strlen(json);
    json_pad = (size_t)align4(json_len);
    file_len = 12u + 8u + json_pad + 8u + L.total;
    if (file_len > UINT32_MAX) {
        st = dtx_seterr(err, DTX_ERANGE,
                        "%s: the .glb would be %.2f GiB; the format stops at 4 GiB (export "
                        "fewer frames)",
                        path, (double)file_len / 1073741824.0);
        goto fail;
    }

    /* ================================================ write */
    st = dtx_atomic_open(&af, path, err);
    if (st != DTX_OK)
        goto fail;
    dtx_put_le32(head, GLB_MAGIC);
    dtx_put_le32(head + 4, 2);
    dtx_put_le32(head + 8, (uint32_t)file_len);
    dtx_put_le32(head + 12, (uint32_t)json_pad);
    dtx_put_le32(head + 16, GLB_CHUNK_JSON);
    fwrite(head, 1, 20, af.fp);
    fwrite(json, 1, json_len, af.fp);
    fwrite("   ", 1, json_pad - json_len, af.fp);
    dtx_put_le32(head, (uint32_t)L.total);
    dtx_put_le32(head + 4, GLB_CHUNK_BIN);
    fwrite(head, 1, 8, af.fp);

    /* positions, normals, UVs */
    write_f32s(af.fp, bytes, P, g3);
    write_f32s(af.fp, bytes, N, g3);
    if (L.has_uv)
        write_f32s(af.fp, bytes, UV, 2 * (size_t)g.ng);
    /* indices, primitive by primitive, then zeros up to the next multiple of 4 */
    for (int p = 0; p < nprims; p++)
        for (int32_t f = 0; f < rest->nf; f++) {
            if ((nmat ? at->material[f] : -1) != prims[p].material)
                continue;
            for (int c = 0; c < 3; c++) {
                uint32_t v = (uint32_t)g.GF[3 * (size_t)f + c];
                if (L.ushort) {
                    dtx_put_le16(bytes, v);
                    fwrite(bytes, 1, 2, af.fp);
                } else {
                    dtx_put_le32(bytes, v);
                    fwrite(bytes, 1, 4, af.fp);
                }
            }
        }
    fwrite("\0\0\0", 1, (size_t)(align4(L.idx + L.idx_len) - L.idx - L.idx_len), af.fp);
    /* images, each padded to 4 */
    for (int32_t k = 0; k < nmat && opts->materials; k++) {
        const dtx_glb_material *mk = opts->materials + k;
        if (!L.has_uv || !mk->image || mk->image_len == 0)
            continue;
        fwrite(mk->image, 1, mk->image_len, af.fp);
        fwrite("\0\0\0", 1, (size_t)(align4(mk->image_len) - mk->image_len), af.fp);
    }

    /* ---- pass 2: the morph deltas, checked against pass 1 */
    for (int64_t k = 0; k < T; k++) {
        st = frame_deltas(path, rest, k, frame, ctx, X, D, b2, &h2, err);
        if (st != DTX_OK)
            goto fail;
        if (h2 != H[k] || memcmp(b2, B + 6 * k, sizeof b2) != 0) {
            st =
                dtx_seterr(err, DTX_EINVAL, "%s: frame %lld changed between the two reading passes",
                           path, (long long)k);
            goto fail;
        }
        for (int32_t q = 0; q < g.ng; q++)
            memcpy(GD + 3 * (size_t)q, D + 3 * (size_t)g.of[q], 3 * sizeof *GD);
        write_f32s(af.fp, bytes, GD, g3);
        smooth_normals(X, rest->nv, rest->F, rest->nf, wmap, nw, acc, Nk);
        for (int32_t q = 0; q < g.ng; q++)
            for (int c = 0; c < 3; c++) {
                size_t i = 3 * (size_t)g.of[q] + (size_t)c;
                GD[3 * (size_t)q + c] = (float)(Nk[i] - Nr[i]);
            }
        write_f32s(af.fp, bytes, GD, g3);
    }

    /* ---- times, then the sparse weights: indices k * T + k, values 1 */
    write_f32s(af.fp, bytes, times, (size_t)T);
    for (int64_t k = 0; k < T; k++)
        dtx_put_le32(bytes + 4 * k, (uint32_t)(k * T + k));
    fwrite(bytes, 4, (size_t)T, af.fp);
    for (int64_t k = 0; k < T; k++)
        dtx_put_lef32(bytes + 4 * k, 1.0f);
    fwrite(bytes, 4, (size_t)T, af.fp);
    st = dtx_atomic_commit(&af, err); /* checks every write above */

fail:
    if (st != DTX_OK)
        dtx_atomic_abort(&af);
    cJSON_free(json);
    cJSON_Delete(doc);
    free(bytes);
    free(times);
    free(H);
    free(B);
    free(D);
    free(GD);
    free(UV);
    free(N);
    free(P);
    free(wrep);
    free(wmap);
    free(Nk);
    free(Nr);
    free(acc);
    free(X);
    free(L.img);
    free(prims);
    gverts_free(&g);
    return st;
}
