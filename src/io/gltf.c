/*
 * gltf.c: the .glb writer (layout in gltf.h).
 *
 * Phases: check the arguments; rest positions and normals in float32;
 * pass 1 over the frames for the morph targets' min/max; the JSON document
 * (cJSON) and the byte layout; then header, JSON chunk and BIN chunk
 * (pass 2 over the frames writes the deltas) into an atomic file.
 *
 * Numbers that must be exact in the JSON (accessor min/max, which
 * validators compare with the data, and byte counts that may exceed
 * INT_MAX, which cJSON would print through a saturated int) are written
 * as raw JSON text: floats with %.17g of their exact double value, which
 * reads back as exactly that value whether a reader keeps doubles or
 * rounds to float32.
 */
#include "gltf.h"

#include "atomic_file.h"

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

/* ------------------------------------------------------------ byte order */

static void put_u32(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)(v & 0xffu);
    p[1] = (unsigned char)((v >> 8) & 0xffu);
    p[2] = (unsigned char)((v >> 16) & 0xffu);
    p[3] = (unsigned char)((v >> 24) & 0xffu);
}

static void put_f32(unsigned char *p, float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    put_u32(p, u);
}

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

/* Area-weighted vertex normals (the cross product of two edges sums twice
 * the area times the unit normal), normalised; a vertex whose faces have
 * no area gets +z.  N: nv x 3 floats, unit length to float32 rounding. */
static void vertex_normals(const dtx_mesh *m, double *acc, float *N)
{
    memset(acc, 0, 3 * (size_t)m->nv * sizeof *acc);
    for (int32_t f = 0; f < m->nf; f++) {
        const int32_t *t = m->F + 3 * (size_t)f;
        const double *a = m->V + 3 * (size_t)t[0], *b = m->V + 3 * (size_t)t[1],
                     *c = m->V + 3 * (size_t)t[2];
        double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        double e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                       e1[0] * e2[1] - e1[1] * e2[0]};
        for (int k = 0; k < 3; k++)
            for (int c2 = 0; c2 < 3; c2++)
                acc[3 * (size_t)t[k] + c2] += n[c2];
    }
    for (int32_t i = 0; i < m->nv; i++) {
        double *n = acc + 3 * (size_t)i;
        double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (!(len > 0.0) || !isfinite(len)) {
            n[0] = 0.0, n[1] = 0.0, n[2] = 1.0;
            len = 1.0;
        }
        for (int c = 0; c < 3; c++)
            N[3 * (size_t)i + c] = (float)(n[c] / len);
    }
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

/* ------------------------------------------------------------ the writer */

/* Sizes and offsets of the BIN chunk, in bytes. */
typedef struct {
    uint64_t pos, nrm, idx, idx_len, morph, morph_len, times, sp_idx, sp_val, total;
    int ushort; /* indices as UNSIGNED_SHORT */
} layout;

static void make_layout(const dtx_mesh *m, int64_t T, layout *L)
{
    uint64_t vbytes = 12u * (uint64_t)m->nv;
    L->ushort = m->nv <= 65535; /* 65535 itself is the primitive-restart value */
    L->pos = 0;
    L->nrm = vbytes;
    L->idx = 2 * vbytes;
    L->idx_len = 3u * (uint64_t)m->nf * (L->ushort ? 2u : 4u);
    L->morph = align4(L->idx + L->idx_len);
    L->morph_len = vbytes * (uint64_t)T;
    L->times = L->morph + L->morph_len;
    L->sp_idx = L->times + 4u * (uint64_t)T;
    L->sp_val = L->sp_idx + 4u * (uint64_t)T;
    L->total = L->sp_val + 4u * (uint64_t)T;
}

/* The JSON document.  B: T x 6 delta bounds; times: T floats. */
static cJSON *make_json(const dtx_mesh *m, int64_t T, const layout *L, const float *pmin,
                        const float *pmax, const float *B, const float *times,
                        const dtx_glb_opts *o, jctx *j)
{
    const char *name = o->name ? o->name : "dtx";
    cJSON *root = cJSON_CreateObject(), *asset, *x, *prim, *targets, *names, *weights, *accs,
          *views, *anim, *smp, *ch;
    char buf[64];
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

    /* ---- mesh: one primitive with one morph target per frame */
    x = jobj(j, jarr(j, root, "meshes"), NULL);
    jstr(j, x, "name", name);
    prim = jobj(j, jarr(j, x, "primitives"), NULL);
    weights = jarr(j, x, "weights");
    names = jarr(j, jobj(j, x, "extras"), "targetNames");
    {
        cJSON *attr = jobj(j, prim, "attributes");
        jint(j, attr, "POSITION", 0);
        jint(j, attr, "NORMAL", 1);
    }
    jint(j, prim, "indices", 2);
    jint(j, prim, "mode", GL_TRIANGLES);
    targets = jarr(j, prim, "targets");
    for (int64_t k = 0; k < T && !j->oom; k++) {
        jint(j, jobj(j, targets, NULL), "POSITION", 3 + k);
        jint(j, weights, NULL, 0);
        snprintf(buf, sizeof buf, "frame-%05lld", (long long)(o->label_first + k * o->label_step));
        jstr(j, names, NULL, buf);
    }

    /* ---- animation: the weights, one-hot per key (a sparse accessor) */
    anim = jobj(j, jarr(j, root, "animations"), NULL);
    jstr(j, anim, "name", "frames");
    smp = jobj(j, jarr(j, anim, "samplers"), NULL);
    jint(j, smp, "input", 3 + T);
    jint(j, smp, "output", 4 + T);
    jstr(j, smp, "interpolation", o->step ? "STEP" : "LINEAR");
    ch = jobj(j, jarr(j, anim, "channels"), NULL);
    jint(j, ch, "sampler", 0);
    x = jobj(j, ch, "target");
    jint(j, x, "node", 0);
    jstr(j, x, "path", "weights");

    /* ---- buffer, views, accessors */
    jint(j, jobj(j, jarr(j, root, "buffers"), NULL), "byteLength", (int64_t)L->total);
    views = jarr(j, root, "bufferViews");
    buffer_view(j, views, L->pos, 12u * (uint64_t)m->nv, 12, GL_ARRAY_BUFFER);
    buffer_view(j, views, L->nrm, 12u * (uint64_t)m->nv, 12, GL_ARRAY_BUFFER);
    buffer_view(j, views, L->idx, L->idx_len, 0, GL_ELEMENT_ARRAY_BUFFER);
    buffer_view(j, views, L->morph, L->morph_len, 12, GL_ARRAY_BUFFER);
    buffer_view(j, views, L->times, 4u * (uint64_t)T, 0, 0);
    buffer_view(j, views, L->sp_idx, 4u * (uint64_t)T, 0, 0);
    buffer_view(j, views, L->sp_val, 4u * (uint64_t)T, 0, 0);

    accs = jarr(j, root, "accessors");
    x = accessor(j, accs, 0, 0, GL_FLOAT, m->nv, "VEC3");
    jvec3(j, x, "min", pmin);
    jvec3(j, x, "max", pmax);
    accessor(j, accs, 1, 0, GL_FLOAT, m->nv, "VEC3");
    accessor(j, accs, 2, 0, L->ushort ? GL_UNSIGNED_SHORT : GL_UNSIGNED_INT, 3 * (int64_t)m->nf,
             "SCALAR");
    for (int64_t k = 0; k < T && !j->oom; k++) {
        x = accessor(j, accs, 3, 12u * (uint64_t)m->nv * (uint64_t)k, GL_FLOAT, m->nv, "VEC3");
        jvec3(j, x, "min", B + 6 * k);
        jvec3(j, x, "max", B + 6 * k + 3);
    }
    x = accessor(j, accs, 4, 0, GL_FLOAT, T, "SCALAR");
    jflt(j, jarr(j, x, "min"), NULL, times[0]);
    jflt(j, jarr(j, x, "max"), NULL, times[T - 1]);
    /* The T x T one-hot weights: no buffer view (all zeros) and T sparse
     * entries, the 1 of key k at index k * T + k. */
    x = jobj(j, accs, NULL);
    jint(j, x, "componentType", GL_FLOAT);
    jint(j, x, "count", T * T);
    jstr(j, x, "type", "SCALAR");
    x = jobj(j, x, "sparse");
    jint(j, x, "count", T);
    smp = jobj(j, x, "indices");
    jint(j, smp, "bufferView", 5);
    jint(j, smp, "componentType", GL_UNSIGNED_INT);
    jint(j, jobj(j, x, "values"), "bufferView", 6);
    return root;
}

dtx_status dtx_glb_write(const char *path, const dtx_mesh *rest, int64_t nframes,
                         dtx_glb_frame_fn frame, void *ctx, const dtx_glb_opts *opts,
                         dtx_error *err)
{
    const int64_t T = nframes;
    const size_t n3 = 3 * (size_t)(rest ? rest->nv : 0);
    dtx_status st = DTX_OK;
    dtx_atomic_file af;
    jctx j = {0};
    layout L;
    cJSON *doc = NULL;
    char *json = NULL;
    double *X = NULL, *acc = NULL;
    float *P = NULL, *N = NULL, *D = NULL, *B = NULL, *times = NULL;
    unsigned char *bytes = NULL, head[28];
    float pmin[3], pmax[3], b2[6];
    uint64_t *H = NULL, h2;
    size_t json_len, json_pad, nbytes;
    uint64_t file_len;

    memset(&af, 0, sizeof af);

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
    make_layout(rest, T, &L);
    if (L.total + 28u > UINT32_MAX) /* before reading any frame; the JSON adds more below */
        return dtx_seterr(err, DTX_ERANGE,
                          "%s: the .glb would exceed 4 GiB (%d vertices x %lld frames); the "
                          "format stops there (export fewer frames)",
                          path, (int)rest->nv, (long long)T);

    /* ================================================ buffers */
    nbytes = (size_t)4 * (n3 > (size_t)T ? n3 : (size_t)T);
    X = dtx_alloc(n3, sizeof *X, 0);
    acc = dtx_alloc(n3, sizeof *acc, 0);
    P = dtx_alloc(n3, sizeof *P, 0);
    N = dtx_alloc(n3, sizeof *N, 0);
    D = dtx_alloc(n3, sizeof *D, 0);
    B = dtx_alloc((size_t)T, 6 * sizeof *B, 0);
    H = dtx_alloc((size_t)T, sizeof *H, 0);
    times = dtx_alloc((size_t)T, sizeof *times, 0);
    bytes = dtx_alloc(nbytes, 1, 0);
    if (!X || !acc || !P || !N || !D || !B || !H || !times || !bytes) {
        st = dtx_seterr(err, DTX_ENOMEM, "%s: out of memory (%d vertices, %lld frames)", path,
                        (int)rest->nv, (long long)T);
        goto fail;
    }

    /* ================================================ rest mesh, times */
    bounds_init(b2);
    for (size_t i = 0; i < n3; i++) {
        P[i] = (float)rest->V[i];
        b2[i % 3] = P[i] < b2[i % 3] ? P[i] : b2[i % 3];
        b2[3 + i % 3] = P[i] > b2[3 + i % 3] ? P[i] : b2[3 + i % 3];
    }
    memcpy(pmin, b2, sizeof pmin);
    memcpy(pmax, b2 + 3, sizeof pmax);
    vertex_normals(rest, acc, N);
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
    doc = make_json(rest, T, &L, pmin, pmax, B, times, opts, &j);
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
    put_u32(head, GLB_MAGIC);
    put_u32(head + 4, 2);
    put_u32(head + 8, (uint32_t)file_len);
    put_u32(head + 12, (uint32_t)json_pad);
    put_u32(head + 16, GLB_CHUNK_JSON);
    fwrite(head, 1, 20, af.fp);
    fwrite(json, 1, json_len, af.fp);
    fwrite("   ", 1, json_pad - json_len, af.fp);
    put_u32(head, (uint32_t)L.total);
    put_u32(head + 4, GLB_CHUNK_BIN);
    fwrite(head, 1, 8, af.fp);

    /* positions, normals */
    for (size_t i = 0; i < n3; i++)
        put_f32(bytes + 4 * i, P[i]);
    fwrite(bytes, 4, n3, af.fp);
    for (size_t i = 0; i < n3; i++)
        put_f32(bytes + 4 * i, N[i]);
    fwrite(bytes, 4, n3, af.fp);
    /* indices, then zeros up to the next multiple of 4 */
    for (size_t i = 0; i < 3 * (size_t)rest->nf; i++) {
        uint32_t v = (uint32_t)rest->F[i];
        if (L.ushort) {
            unsigned char b[2] = {(unsigned char)(v & 0xffu), (unsigned char)(v >> 8)};
            fwrite(b, 1, 2, af.fp);
        } else {
            put_u32(bytes, v);
            fwrite(bytes, 1, 4, af.fp);
        }
    }
    fwrite("\0\0\0", 1, (size_t)(L.morph - L.idx - L.idx_len), af.fp);

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
        for (size_t i = 0; i < n3; i++)
            put_f32(bytes + 4 * i, D[i]);
        fwrite(bytes, 4, n3, af.fp);
    }

    /* ---- times, then the sparse weights: indices k * T + k, values 1 */
    for (int64_t k = 0; k < T; k++)
        put_f32(bytes + 4 * k, times[k]);
    fwrite(bytes, 4, (size_t)T, af.fp);
    for (int64_t k = 0; k < T; k++)
        put_u32(bytes + 4 * k, (uint32_t)(k * T + k));
    fwrite(bytes, 4, (size_t)T, af.fp);
    for (int64_t k = 0; k < T; k++)
        put_f32(bytes + 4 * k, 1.0f);
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
    free(N);
    free(P);
    free(acc);
    free(X);
    return st;
}
