/* test_gltf.c: the .glb writer.  Files are parsed back (header, chunks,
 * JSON with cJSON, binary data) and checked against the glTF 2.0 rules the
 * writer promises: chunk padding (spaces, zeros) and 4-byte alignment,
 * lengths, buffer views inside the buffer with the right strides and
 * targets, accessors inside their views and aligned, POSITION and morph
 * accessor min/max equal to the data, unit normals, indices equal to the
 * faces (UNSIGNED_SHORT up to 65535 vertices, UNSIGNED_INT above), deltas
 * equal to the float-rounded frame - rest, morph normals that turn the
 * rest normals into the frame's own, strictly increasing times and
 * one-hot weights.  With the asset's attributes: TEXCOORD_0 = (u, 1 - v),
 * the asset's normals made unit, one primitive per material with that
 * material's faces in order, materials with their names, base colour and
 * embedded PNG; per-corner UVs split vertices into copies that extras
 * name, each corner keeping its position, UV and morph delta.  Bad arguments, bad frames, failing
 * callbacks, a file over 4 GiB and unwritable paths fail cleanly with no file left. */
#include "check.h"
#include "gltf.h"

#include <cjson/cJSON.h>

#include <dirent.h>
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define SCRATCH DTX_TEST_SCRATCH

/* ------------------------------------------------------------ frames */

typedef struct {
    const dtx_mesh *m;
    int64_t calls;
    int64_t nan_frame;    /* frame that gets a NaN (-1: none) */
    int64_t fail_frame;   /* frame whose callback fails (-1: none) */
    int64_t change_after; /* after this many calls, frames change (-1: never) */
} frames;

/* Frame k: the rest scaled by 1 + 0.1 k about the origin, moved by
 * (0.25 k, -0.125 k, 0.0625 k), vertex i nudged by 1e-3 * (i mod 7). */
static void frame_k(const dtx_mesh *m, int64_t k, double *X)
{
    for (int32_t i = 0; i < m->nv; i++)
        for (int c = 0; c < 3; c++) {
            static const double move[3] = {0.25, -0.125, 0.0625};
            X[3 * i + c] = m->V[3 * i + c] * (1.0 + 0.1 * (double)k) + move[c] * (double)k +
                           1e-3 * (double)(i % 7);
        }
}

static dtx_status frame_cb(void *ctx, int64_t k, double *X, dtx_error *err)
{
    frames *f = ctx;
    f->calls++;
    if (k == f->fail_frame)
        return dtx_seterr(err, DTX_EIO, "test: frame %lld cannot be read", (long long)k);
    frame_k(f->m, k, X);
    if (k == f->nan_frame)
        X[3 * (f->m->nv - 1) + 2] = NAN;
    if (f->change_after >= 0 && f->calls > f->change_after)
        X[0] += 1.0;
    return DTX_OK;
}

/* ------------------------------------------------------------ meshes */

static void octahedron(dtx_mesh *m)
{
    static const double V[] = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
    static const int32_t F[] = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4,
                                2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
    dtx_error err;
    CHECK_OK(dtx_mesh_alloc(m, 6, 8, &err), &err);
    memcpy(m->V, V, sizeof V);
    memcpy(m->F, F, sizeof F);
}

/* An nx x ny grid of vertices in the z = 0 plane, two triangles a cell. */
static void grid(dtx_mesh *m, int32_t nx, int32_t ny)
{
    dtx_error err;
    int32_t t = 0;
    CHECK_OK(dtx_mesh_alloc(m, nx * ny, 2 * (nx - 1) * (ny - 1), &err), &err);
    for (int32_t j = 0; j < ny; j++)
        for (int32_t i = 0; i < nx; i++) {
            double *v = m->V + 3 * (size_t)(j * nx + i);
            v[0] = i * 0.01, v[1] = j * 0.01, v[2] = 0.0;
        }
    for (int32_t j = 0; j + 1 < ny; j++)
        for (int32_t i = 0; i + 1 < nx; i++) {
            int32_t a = j * nx + i, b = a + 1, c = a + nx, d = c + 1;
            int32_t *f = m->F + 3 * (size_t)t;
            f[0] = a, f[1] = b, f[2] = d, f[3] = a, f[4] = d, f[5] = c;
            t += 2;
        }
}

/* Area-weighted unit normals of positions X on m's faces (N: nv x 3). */
static void normals_of(const dtx_mesh *m, const double *X, double *N)
{
    memset(N, 0, 3 * (size_t)m->nv * sizeof *N);
    for (int32_t f = 0; f < m->nf; f++) {
        const int32_t *t = m->F + 3 * f;
        const double *a = X + 3 * t[0], *b = X + 3 * t[1], *c = X + 3 * t[2];
        double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        double e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                       e1[0] * e2[1] - e1[1] * e2[0]};
        for (int k = 0; k < 3; k++)
            for (int q = 0; q < 3; q++)
                N[3 * t[k] + q] += n[q];
    }
    for (int32_t i = 0; i < m->nv; i++) {
        double *n = N + 3 * i, l = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        for (int q = 0; q < 3; q++)
            n[q] /= l;
    }
}

/* ------------------------------------------------------------ reading */

static long file_size(const char *path)
{
    struct stat sb;
    return stat(path, &sb) == 0 ? (long)sb.st_size : -1;
}

static int temp_files(void)
{
    DIR *d = opendir(SCRATCH);
    struct dirent *e;
    int n = 0;
    if (!d)
        return -1;
    while ((e = readdir(d)) != NULL)
        n += strstr(e->d_name, ".tmp-") != NULL;
    closedir(d);
    return n;
}

static uint32_t le32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static float lef32(const unsigned char *p)
{
    uint32_t u = le32(p);
    float f;
    memcpy(&f, &u, 4);
    return f;
}

typedef struct {
    unsigned char *bytes;
    size_t len;
    cJSON *json;
    const unsigned char *bin;
    uint32_t bin_len;
} glb;

static void glb_free(glb *g)
{
    free(g->bytes);
    cJSON_Delete(g->json);
    memset(g, 0, sizeof *g);
}

/* Reads and checks the container; 0 on success. */
static int glb_load(const char *path, glb *g)
{
    FILE *f = fopen(path, "rb");
    uint32_t jlen;
    size_t end;
    memset(g, 0, sizeof *g);
    CHECK(f != NULL);
    if (!f)
        return -1;
    g->len = (size_t)file_size(path);
    g->bytes = malloc(g->len);
    CHECK(fread(g->bytes, 1, g->len, f) == g->len);
    fclose(f);
    CHECK(g->len >= 28);
    if (g->len < 28)
        return -1;
    /* header */
    CHECK_EQ_INT(le32(g->bytes), 0x46546C67u);
    CHECK_EQ_INT(le32(g->bytes + 4), 2);
    CHECK_EQ_INT(le32(g->bytes + 8), g->len);
    /* JSON chunk: 4-byte multiple, padded with spaces */
    jlen = le32(g->bytes + 12);
    CHECK_EQ_INT(le32(g->bytes + 16), 0x4E4F534Au);
    CHECK_EQ_INT(jlen % 4, 0);
    CHECK(20 + (size_t)jlen + 8 <= g->len);
    if (20 + (size_t)jlen + 8 > g->len)
        return -1;
    g->json = cJSON_ParseWithLength((const char *)g->bytes + 20, jlen);
    CHECK(g->json != NULL);
    end = jlen;
    while (end > 0 && g->bytes[20 + end - 1] == ' ')
        end--;
    CHECK(end > 0 && g->bytes[20 + end - 1] == '}');
    CHECK_INT(jlen - end, <, 4);
    /* BIN chunk: 4-byte multiple, ends the file */
    g->bin_len = le32(g->bytes + 20 + jlen);
    CHECK_EQ_INT(le32(g->bytes + 24 + jlen), 0x004E4942u);
    CHECK_EQ_INT(g->bin_len % 4, 0);
    CHECK_EQ_INT(28 + (size_t)jlen + g->bin_len, g->len);
    g->bin = g->bytes + 28 + jlen;
    return g->json && 28 + (size_t)jlen + g->bin_len == g->len ? 0 : -1;
}

static const cJSON *at(const cJSON *o, const char *key)
{
    return cJSON_GetObjectItemCaseSensitive(o, key);
}

static double num(const cJSON *o, const char *key, double dflt)
{
    const cJSON *v = at(o, key);
    return cJSON_IsNumber(v) ? v->valuedouble : dflt;
}

static const cJSON *nth(const cJSON *arr, int64_t i) { return cJSON_GetArrayItem(arr, (int)i); }

/* The bytes of accessor a's element i, component c (any stride). */
static const unsigned char *elem(const glb *g, const cJSON *a, int64_t i, int c, int csize)
{
    const cJSON *v = nth(at(g->json, "bufferViews"), (int64_t)num(a, "bufferView", -1));
    double stride = num(v, "byteStride", 0);
    const char *type = cJSON_GetStringValue(at(a, "type"));
    int ncomp = type && strcmp(type, "VEC3") == 0 ? 3 : type && strcmp(type, "VEC2") == 0 ? 2 : 1;
    size_t off = (size_t)num(v, "byteOffset", 0) + (size_t)num(a, "byteOffset", 0);
    size_t st = stride > 0 ? (size_t)stride : (size_t)(ncomp * csize);
    return g->bin + off + (size_t)i * st + (size_t)c * (size_t)csize;
}

/* Element i of a SCALAR float accessor without a buffer view: zero unless
 * one of its sparse entries sets it (strictly increasing indices, so the
 * first match is the only one). */
static float sparse_f32(const glb *g, const cJSON *a, int64_t i)
{
    const cJSON *sp = at(a, "sparse"), *views = at(g->json, "bufferViews");
    const cJSON *iv = nth(views, (int64_t)num(at(sp, "indices"), "bufferView", -1)),
                *vv = nth(views, (int64_t)num(at(sp, "values"), "bufferView", -1));
    int64_t n = (int64_t)num(sp, "count", 0);
    const unsigned char *ip = g->bin + (size_t)num(iv, "byteOffset", 0),
                        *vp = g->bin + (size_t)num(vv, "byteOffset", 0);
    if (!sp || !iv || !vv)
        return NAN;
    for (int64_t e = 0; e < n; e++) {
        uint32_t idx = (uint32_t)ip[4 * e] | (uint32_t)ip[4 * e + 1] << 8 |
                       (uint32_t)ip[4 * e + 2] << 16 | (uint32_t)ip[4 * e + 3] << 24;
        if (e > 0) {
            const unsigned char *q = ip + 4 * (e - 1);
            uint32_t prev =
                (uint32_t)q[0] | (uint32_t)q[1] << 8 | (uint32_t)q[2] << 16 | (uint32_t)q[3] << 24;
            if (!(idx > prev))
                return NAN;
        }
        if (idx == (uint64_t)i)
            return lef32(vp + 4 * e);
    }
    return 0.0f;
}

/* Structure of views and accessors, and min/max against the data. */
static void check_views_accessors(const glb *g)
{
    const cJSON *views = at(g->json, "bufferViews"), *accs = at(g->json, "accessors"), *v, *a;
    double blen = num(nth(at(g->json, "buffers"), 0), "byteLength", -1);
    CHECK_EQ_INT(cJSON_GetArraySize(at(g->json, "buffers")), 1);
    CHECK_INT(blen, <=, g->bin_len);
    CHECK_INT(g->bin_len - blen, <, 4);
    cJSON_ArrayForEach(v, views)
    {
        double off = num(v, "byteOffset", 0), len = num(v, "byteLength", -1);
        double stride = num(v, "byteStride", 0), target = num(v, "target", 0);
        CHECK_EQ_INT(num(v, "buffer", -1), 0);
        CHECK_EQ_INT((int64_t)off % 4, 0);
        CHECK_INT(len, >, 0);
        CHECK_DBL(off + len, <=, blen);
        /* Vertex attribute views have a stride of one VEC3 (a VEC2 for
         * UVs); index, image and animation views have none (the validator
         * forbids it for indices). */
        if (target == 34962)
            CHECK(stride == 12 || stride == 8);
        else
            CHECK_EQ_INT(stride, 0);
    }
    cJSON_ArrayForEach(a, accs)
    {
        const cJSON *view = nth(views, (int64_t)num(a, "bufferView", -1));
        int ctype = (int)num(a, "componentType", 0);
        int csize = ctype == 5123 ? 2 : 4;
        const char *type = cJSON_GetStringValue(at(a, "type"));
        int ncomp = type && strcmp(type, "VEC3") == 0   ? 3
                    : type && strcmp(type, "VEC2") == 0 ? 2
                                                        : 1;
        double count = num(a, "count", -1), aoff = num(a, "byteOffset", 0);
        double stride = num(view, "byteStride", 0);
        double esize = (double)(ncomp * csize), st = stride > 0 ? stride : esize;
        const cJSON *mn = at(a, "min"), *mx = at(a, "max");
        if (!view && at(a, "sparse")) {
            /* Zeros with sparse entries: their views hold count indices
             * (UNSIGNED_INT) and count values of the accessor's type. */
            const cJSON *sp = at(a, "sparse");
            double n = num(sp, "count", -1);
            const cJSON *iv = nth(views, (int64_t)num(at(sp, "indices"), "bufferView", -1)),
                        *vv = nth(views, (int64_t)num(at(sp, "values"), "bufferView", -1));
            CHECK(iv != NULL && vv != NULL);
            CHECK_INT(n, >=, 1);
            CHECK_INT(n, <=, count);
            CHECK_EQ_INT(num(at(sp, "indices"), "componentType", 0), 5125);
            CHECK_DBL(4.0 * n, <=, num(iv, "byteLength", -1));
            CHECK_DBL(esize * n, <=, num(vv, "byteLength", -1));
            CHECK(!cJSON_IsArray(mn) && !cJSON_IsArray(mx));
            continue;
        }
        CHECK(view != NULL);
        if (!view)
            continue;
        CHECK(ctype == 5126 || ctype == 5125 || ctype == 5123);
        CHECK_INT(count, >=, 1);
        CHECK_EQ_INT((int64_t)(num(view, "byteOffset", 0) + aoff) % csize, 0);
        CHECK_DBL(aoff + st * (count - 1) + esize, <=, num(view, "byteLength", -1));
        CHECK_EQ_INT(cJSON_IsArray(mn), cJSON_IsArray(mx));
        if (cJSON_IsArray(mn) && ctype == 5126) {
            float lo[3] = {FLT_MAX, FLT_MAX, FLT_MAX}, hi[3] = {-FLT_MAX, -FLT_MAX, -FLT_MAX};
            CHECK_EQ_INT(cJSON_GetArraySize(mn), ncomp);
            for (int64_t i = 0; i < (int64_t)count; i++)
                for (int c = 0; c < ncomp; c++) {
                    float x = lef32(elem(g, a, i, c, 4));
                    lo[c] = x < lo[c] ? x : lo[c];
                    hi[c] = x > hi[c] ? x : hi[c];
                }
            for (int c = 0; c < ncomp; c++) {
                /* Exactly the float values, read back as doubles. */
                CHECK_DBL(nth(mn, c)->valuedouble, ==, (double)lo[c]);
                CHECK_DBL(nth(mx, c)->valuedouble, ==, (double)hi[c]);
            }
        }
    }
}

/* Everything about one written file of mesh m with T frames. */
static void check_file(const char *path, const dtx_mesh *m, int64_t T, double spf, int step,
                       int64_t label_first, int64_t label_step)
{
    glb g;
    const cJSON *prim, *accs, *targets, *anim, *smp, *mesh;
    double *X;
    if (glb_load(path, &g) != 0) {
        glb_free(&g);
        return;
    }
    check_views_accessors(&g);
    accs = at(g.json, "accessors");
    CHECK_EQ_INT(cJSON_GetArraySize(accs), 3 + 2 * T + 2);
    CHECK_EQ_INT(cJSON_GetArraySize(at(g.json, "bufferViews")), 7);
    CHECK(strcmp(cJSON_GetStringValue(at(at(g.json, "asset"), "version")), "2.0") == 0);
    CHECK_EQ_INT(num(g.json, "scene", -1), 0);
    mesh = nth(at(g.json, "meshes"), 0);
    prim = nth(at(mesh, "primitives"), 0);
    CHECK_EQ_INT(num(prim, "mode", -1), 4);
    CHECK_EQ_INT(num(at(prim, "attributes"), "POSITION", -1), 0);
    CHECK_EQ_INT(num(at(prim, "attributes"), "NORMAL", -1), 1);
    CHECK_EQ_INT(num(prim, "indices", -1), 2);
    targets = at(prim, "targets");
    CHECK_EQ_INT(cJSON_GetArraySize(targets), T);
    CHECK_EQ_INT(cJSON_GetArraySize(at(mesh, "weights")), T);
    CHECK_EQ_INT(cJSON_GetArraySize(at(at(mesh, "extras"), "targetNames")), T);
    {
        char want[32];
        const cJSON *names = at(at(mesh, "extras"), "targetNames");
        snprintf(want, sizeof want, "frame-%05lld",
                 (long long)(label_first + (T - 1) * label_step));
        CHECK(strcmp(cJSON_GetStringValue(nth(names, T - 1)), want) == 0);
    }

    /* rest positions, unit normals, indices */
    {
        const cJSON *pa = nth(accs, 0), *na = nth(accs, 1), *ia = nth(accs, 2);
        int ushort = m->nv <= 65535;
        int bad_pos = 0, bad_idx = 0;
        double worst = 0.0;
        CHECK_EQ_INT(num(pa, "count", -1), m->nv);
        CHECK_EQ_INT(num(ia, "count", -1), 3 * (int64_t)m->nf);
        CHECK_EQ_INT(num(ia, "componentType", -1), ushort ? 5123 : 5125);
        for (int32_t i = 0; i < m->nv; i++) {
            double len2 = 0.0;
            for (int c = 0; c < 3; c++) {
                float n = lef32(elem(&g, na, i, c, 4));
                bad_pos += lef32(elem(&g, pa, i, c, 4)) != (float)m->V[3 * i + c];
                len2 += (double)n * n;
            }
            worst = fabs(sqrt(len2) - 1.0) > worst ? fabs(sqrt(len2) - 1.0) : worst;
        }
        for (int64_t i = 0; i < 3 * (int64_t)m->nf; i++) {
            const unsigned char *p = elem(&g, ia, i, 0, ushort ? 2 : 4);
            uint32_t v = ushort ? (uint32_t)(p[0] | p[1] << 8) : le32(p);
            bad_idx += v != (uint32_t)m->F[i];
        }
        CHECK_EQ_INT(bad_pos, 0);
        CHECK_EQ_INT(bad_idx, 0);
        CHECK_DBL(worst, <, 1e-6);
    }

    /* morph deltas = float(frame - rest); rest normal + normal delta = the
     * frame's own area-weighted normal (these meshes have no two vertices
     * at one position) */
    X = malloc(3 * (size_t)m->nv * sizeof *X);
    {
        double *Nr = malloc(3 * (size_t)m->nv * sizeof *Nr),
               *Nk = malloc(3 * (size_t)m->nv * sizeof *Nk);
        const cJSON *na = nth(accs, 1);
        normals_of(m, m->V, Nr);
        for (int64_t k = 0; k < T; k++) {
            const cJSON *da = nth(accs, (int64_t)num(nth(targets, k), "POSITION", -1)),
                        *dn = nth(accs, (int64_t)num(nth(targets, k), "NORMAL", -1));
            int bad = 0;
            double worst = 0.0, worst_base = 0.0;
            CHECK_EQ_INT(num(nth(targets, k), "POSITION", -1), 3 + 2 * k);
            CHECK_EQ_INT(num(nth(targets, k), "NORMAL", -1), 3 + 2 * k + 1);
            frame_k(m, k, X);
            normals_of(m, X, Nk);
            for (int32_t i = 0; i < m->nv; i++)
                for (int c = 0; c < 3; c++) {
                    double base = lef32(elem(&g, na, i, c, 4));
                    double shown = base + lef32(elem(&g, dn, i, c, 4));
                    bad += lef32(elem(&g, da, i, c, 4)) != (float)(X[3 * i + c] - m->V[3 * i + c]);
                    worst = fmax(worst, fabs(shown - Nk[3 * i + c]));
                    worst_base = fmax(worst_base, fabs(base - Nr[3 * i + c]));
                }
            CHECK_EQ_INT(bad, 0);
            CHECK_DBL(worst, <, 1e-6);
            CHECK_DBL(worst_base, <, 1e-6);
        }
        free(Nr);
        free(Nk);
    }
    free(X);

    /* animation: times and one-hot weights */
    anim = nth(at(g.json, "animations"), 0);
    smp = nth(at(anim, "samplers"), 0);
    CHECK(strcmp(cJSON_GetStringValue(at(smp, "interpolation")), step ? "STEP" : "LINEAR") == 0);
    CHECK_EQ_INT(num(at(nth(at(anim, "channels"), 0), "target"), "node", -1), 0);
    CHECK(strcmp(cJSON_GetStringValue(at(at(nth(at(anim, "channels"), 0), "target"), "path")),
                 "weights") == 0);
    {
        const cJSON *ta = nth(accs, (int64_t)num(smp, "input", -1)),
                    *wa = nth(accs, (int64_t)num(smp, "output", -1));
        int bad_t = 0, bad_w = 0;
        CHECK_EQ_INT(num(smp, "input", -1), 3 + 2 * T);
        CHECK_EQ_INT(num(ta, "count", -1), T);
        CHECK_EQ_INT(num(wa, "count", -1), T * T);
        CHECK(cJSON_IsArray(at(ta, "min")) && cJSON_IsArray(at(ta, "max")));
        for (int64_t k = 0; k < T; k++) {
            float t = lef32(elem(&g, ta, k, 0, 4));
            bad_t += t != (float)((double)k * spf);
            bad_t += k > 0 && !(t > lef32(elem(&g, ta, k - 1, 0, 4)));
            for (int64_t j = 0; j < T; j++)
                bad_w += sparse_f32(&g, wa, k * T + j) != (j == k ? 1.0f : 0.0f);
        }
        CHECK_EQ_INT(bad_t, 0);
        CHECK_EQ_INT(bad_w, 0);
    }
    glb_free(&g);
}

/* ------------------------------------------------------------ tests */

static dtx_glb_opts opts(double spf, int step)
{
    dtx_glb_opts o;
    memset(&o, 0, sizeof o);
    o.seconds_per_frame = spf;
    o.step = step;
    o.name = "test";
    o.label_first = 1;
    o.label_step = 1;
    o.source = "test.h5:/results/t/s";
    return o;
}

static void test_small(void)
{
    dtx_mesh m;
    frames f = {0};
    dtx_error err;
    dtx_glb_opts o = opts(1.0 / 24.0, 0);
    octahedron(&m);
    f.m = &m, f.nan_frame = f.fail_frame = f.change_after = -1;
    CHECK_OK(dtx_glb_write(SCRATCH "/small.glb", &m, 5, frame_cb, &f, &o, &err), &err);
    CHECK_EQ_INT(f.calls, 10); /* two passes */
    check_file(SCRATCH "/small.glb", &m, 5, 1.0 / 24.0, 0, 1, 1);
    /* STEP, one frame, other labels */
    o = opts(0.5, 1);
    o.label_first = 3, o.label_step = 4;
    CHECK_OK(dtx_glb_write(SCRATCH "/one.glb", &m, 1, frame_cb, &f, &o, &err), &err);
    check_file(SCRATCH "/one.glb", &m, 1, 0.5, 1, 3, 4);
    o.name = NULL, o.source = NULL;
    CHECK_OK(dtx_glb_write(SCRATCH "/three.glb", &m, 3, frame_cb, &f, &o, &err), &err);
    check_file(SCRATCH "/three.glb", &m, 3, 0.5, 1, 3, 4);
    CHECK_EQ_INT(temp_files(), 0);
    dtx_mesh_free(&m);
}

/* 65535 vertices keep 16-bit indices (65535 itself, the restart value,
 * is never an index); 65536 and more take 32-bit ones. */
static void test_index_types(void)
{
    static const int32_t dims[2][2] = {{255, 257}, {256, 257}};
    for (int d = 0; d < 2; d++) {
        dtx_mesh m;
        frames f = {0};
        dtx_error err;
        dtx_glb_opts o = opts(0.1, 0);
        grid(&m, dims[d][0], dims[d][1]);
        f.m = &m, f.nan_frame = f.fail_frame = f.change_after = -1;
        CHECK_EQ_INT(m.nv, d == 0 ? 65535 : 65792);
        CHECK_OK(dtx_glb_write(SCRATCH "/grid.glb", &m, 2, frame_cb, &f, &o, &err), &err);
        check_file(SCRATCH "/grid.glb", &m, 2, 0.1, 0, 1, 1);
        dtx_mesh_free(&m);
    }
}

/* The asset's attributes.  Case 1, one UV and normal per vertex (uv_faces
 * and normal_faces equal the faces, as a split OBJ has): a 6 x 5 grid, UVs
 * (i/5, j/4), normals (0, 0.5, 2) unnormalised, faces alternating between
 * materials 1 and 0 by cell row, a PNG on material 0 and a base colour on
 * material 1.  Case 2, per-corner UVs: the octahedron with UVs indexed
 * per corner, so vertices are split into copies. */
static void expect_fail(const char *what, dtx_status got, dtx_status want, const dtx_error *err,
                        const char *needle, const char *path);

static const unsigned char tiny_png[] = {
    0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n', 0, 0, 0, 13, 'I', 'H', 'D', 'R', 0, 0, 0,
    1,    0,   0,   0,   1,    8,    0,    0,    0, 0, 0, 0,  0,   0,   0,   0,   0, 0};

static void test_attrs(void)
{
    dtx_mesh m;
    dtx_mesh_attrs a;
    dtx_glb_material mat[2];
    frames f = {0};
    dtx_error err;
    dtx_glb_opts o = opts(0.1, 0);
    glb g;
    char *names[2] = {"stone", "moss"};
    int32_t count[2] = {0, 0};
    grid(&m, 6, 5);
    f.m = &m, f.nan_frame = f.fail_frame = f.change_after = -1;
    memset(&a, 0, sizeof a);
    a.nuv = a.nn = m.nv;
    a.uv = malloc(2 * (size_t)m.nv * sizeof *a.uv);
    a.normals = malloc(3 * (size_t)m.nv * sizeof *a.normals);
    a.uv_faces = a.normal_faces = m.F;
    a.nmat = 2;
    a.material = malloc((size_t)m.nf * sizeof *a.material);
    a.material_names = names;
    for (int32_t i = 0; i < m.nv; i++) {
        a.uv[2 * i] = (i % 6) / 5.0, a.uv[2 * i + 1] = (i / 6) / 4.0;
        a.normals[3 * i] = 0.0, a.normals[3 * i + 1] = 0.5, a.normals[3 * i + 2] = 2.0;
    }
    for (int32_t t = 0; t < m.nf; t++) {
        a.material[t] = (t / 10) % 2 == 0; /* 10 triangles a cell row */
        count[a.material[t]]++;
    }
    memset(mat, 0, sizeof mat);
    mat[0].image = tiny_png, mat[0].image_len = sizeof tiny_png, mat[0].image_name = "t.png";
    mat[1].has_color = 1;
    mat[1].base_color[0] = 0.25f, mat[1].base_color[1] = 0.5f, mat[1].base_color[2] = 0.75f,
    mat[1].base_color[3] = 1.0f;
    o.attrs = &a, o.materials = mat, o.nmaterials = 2;
    CHECK_OK(dtx_glb_write(SCRATCH "/attrs.glb", &m, 3, frame_cb, &f, &o, &err), &err);
    if (glb_load(SCRATCH "/attrs.glb", &g) == 0) {
        const cJSON *accs = at(g.json, "accessors"), *mesh = nth(at(g.json, "meshes"), 0);
        const cJSON *prims = at(mesh, "primitives"), *mats = at(g.json, "materials");
        const cJSON *p0 = nth(prims, 0), *uva, *na, *img;
        int bad_uv = 0, bad_n = 0;
        check_views_accessors(&g);
        CHECK_EQ_INT(cJSON_GetArraySize(prims), 2);
        CHECK(at(mesh, "extras") && !at(at(mesh, "extras"), "dtx_vertex_copies"));
        uva = nth(accs, (int64_t)num(at(p0, "attributes"), "TEXCOORD_0", -1));
        na = nth(accs, (int64_t)num(at(p0, "attributes"), "NORMAL", -1));
        CHECK_EQ_INT(num(uva, "count", -1), m.nv);
        CHECK(strcmp(cJSON_GetStringValue(at(uva, "type")), "VEC2") == 0);
        for (int32_t i = 0; i < m.nv; i++) {
            /* UVs as stored with v flipped; normals the asset's, unit */
            bad_uv += lef32(elem(&g, uva, i, 0, 4)) != (float)a.uv[2 * i];
            bad_uv += lef32(elem(&g, uva, i, 1, 4)) != (float)(1.0 - a.uv[2 * i + 1]);
            bad_n += fabs(lef32(elem(&g, na, i, 1, 4)) - 0.5 / sqrt(4.25)) > 1e-7;
            bad_n += fabs(lef32(elem(&g, na, i, 2, 4)) - 2.0 / sqrt(4.25)) > 1e-7;
        }
        CHECK_EQ_INT(bad_uv, 0);
        CHECK_EQ_INT(bad_n, 0);
        /* one primitive per material, material 0 first, with its faces in order */
        for (int p = 0; p < 2; p++) {
            const cJSON *pr = nth(prims, p), *ia = nth(accs, (int64_t)num(pr, "indices", -1));
            int bad = 0;
            int32_t q = 0;
            CHECK_EQ_INT(num(pr, "material", -1), p);
            CHECK_EQ_INT(num(ia, "count", -1), 3 * (int64_t)count[p]);
            CHECK_EQ_INT(cJSON_GetArraySize(at(pr, "targets")), 3);
            for (int32_t t = 0; t < m.nf; t++) {
                if (a.material[t] != p)
                    continue;
                for (int c = 0; c < 3; c++) {
                    const unsigned char *b = elem(&g, ia, 3 * q + c, 0, 2);
                    bad += (int32_t)(b[0] | b[1] << 8) != m.F[3 * t + c];
                }
                q++;
            }
            CHECK_EQ_INT(bad, 0);
        }
        CHECK(strcmp(cJSON_GetStringValue(at(nth(mats, 0), "name")), "stone") == 0);
        CHECK(strcmp(cJSON_GetStringValue(at(nth(mats, 1), "name")), "moss") == 0);
        CHECK_EQ_INT(
            num(at(at(nth(mats, 0), "pbrMetallicRoughness"), "baseColorTexture"), "index", -1), 0);
        CHECK_DBL(num(at(nth(mats, 1), "pbrMetallicRoughness"), "metallicFactor", -1), ==, 0.0);
        CHECK_DBL(
            nth(at(at(nth(mats, 1), "pbrMetallicRoughness"), "baseColorFactor"), 2)->valuedouble,
            ==, 0.75);
        img = nth(at(g.json, "images"), 0);
        CHECK(strcmp(cJSON_GetStringValue(at(img, "mimeType")), "image/png") == 0);
        {
            const cJSON *iv = nth(at(g.json, "bufferViews"), (int64_t)num(img, "bufferView", -1));
            CHECK_EQ_INT(num(iv, "byteLength", -1), sizeof tiny_png);
            CHECK(iv &&
                  memcmp(g.bin + (size_t)num(iv, "byteOffset", 0), tiny_png, sizeof tiny_png) == 0);
        }
    }
    glb_free(&g);

    /* errors: material count, an image that is not PNG or JPEG, a uv index
     * out of range; no file left */
    {
        const char *path = SCRATCH "/attrs-bad.glb";
        static const unsigned char gif[] = {'G', 'I', 'F', '8', '9', 'a'};
        dtx_status st;
        o.nmaterials = 1;
        st = dtx_glb_write(path, &m, 2, frame_cb, &f, &o, &err);
        expect_fail("material count", st, DTX_EINVAL, &err, "1 materials given", path);
        o.nmaterials = 2;
        mat[0].image = gif, mat[0].image_len = sizeof gif;
        st = dtx_glb_write(path, &m, 2, frame_cb, &f, &o, &err);
        expect_fail("gif", st, DTX_EINVAL, &err, "neither PNG nor JPEG", path);
        mat[0].image = NULL;
        a.nuv = 3; /* uv_faces now point past the UVs */
        st = dtx_glb_write(path, &m, 2, frame_cb, &f, &o, &err);
        CHECK(st != DTX_OK);
        CHECK_EQ_INT(access(path, F_OK), -1);
        a.nuv = m.nv;
    }
    free(a.uv);
    free(a.normals);
    free(a.material);
    dtx_mesh_free(&m);

    /* Case 2: per-corner UVs on the octahedron: corner c of face t gets
     * UV index (t % 2) * 6 + F[c] (two UV sets), so every vertex used by
     * faces of both parities is split once. */
    {
        int32_t uvf[24];
        double uv[24];
        int distinct = 0, bad_pos = 0, bad_uv = 0, bad_d = 0;
        octahedron(&m);
        f.m = &m;
        memset(&a, 0, sizeof a);
        for (int i = 0; i < 12; i++)
            uv[2 * i] = 0.05 * i, uv[2 * i + 1] = 0.5 + 0.03 * i;
        for (int c = 0; c < 24; c++)
            uvf[c] = (c / 3) % 2 * 6 + m.F[c];
        for (int v = 0; v < 6; v++) { /* distinct (v, uv) pairs */
            int seen[2] = {0, 0};
            for (int c = 0; c < 24; c++)
                if (m.F[c] == v)
                    seen[(c / 3) % 2] = 1;
            distinct += seen[0] + seen[1];
        }
        a.nuv = 12, a.uv = uv, a.uv_faces = uvf;
        o = opts(0.1, 0);
        o.attrs = &a;
        CHECK_OK(dtx_glb_write(SCRATCH "/corner.glb", &m, 2, frame_cb, &f, &o, &err), &err);
        if (glb_load(SCRATCH "/corner.glb", &g) == 0) {
            const cJSON *accs = at(g.json, "accessors"), *mesh = nth(at(g.json, "meshes"), 0);
            const cJSON *pr = nth(at(mesh, "primitives"), 0);
            const cJSON *pa = nth(accs, 0), *uva = nth(accs, 2),
                        *ia = nth(accs, (int64_t)num(pr, "indices", -1)),
                        *da = nth(accs, (int64_t)num(nth(at(pr, "targets"), 1), "POSITION", -1));
            const cJSON *cp = at(at(mesh, "extras"), "dtx_vertex_copies"), *of = at(cp, "copy_of");
            int ng = (int)num(pa, "count", -1);
            double X[18];
            CHECK_EQ_INT(ng, distinct);
            CHECK_EQ_INT(num(cp, "vertices", -1), 6);
            CHECK_EQ_INT(cJSON_GetArraySize(of), ng - 6);
            frame_k(&m, 1, X);
            for (int q = 0; q < ng; q++) { /* glTF vertex q is dtx vertex src */
                int src = q < 6 ? q : (int)nth(of, q - 6)->valuedouble;
                for (int c = 0; c < 3; c++) {
                    bad_pos += lef32(elem(&g, pa, q, c, 4)) != (float)m.V[3 * src + c];
                    bad_d +=
                        lef32(elem(&g, da, q, c, 4)) != (float)(X[3 * src + c] - m.V[3 * src + c]);
                }
            }
            for (int c = 0; c < 24; c++) { /* each corner: its position and its UV */
                const unsigned char *b = elem(&g, ia, c, 0, 2);
                int q = b[0] | b[1] << 8;
                int src = q < 6 ? q : (int)nth(of, q - 6)->valuedouble;
                bad_uv += src != m.F[c];
                bad_uv += lef32(elem(&g, uva, q, 0, 4)) != (float)uv[2 * uvf[c]];
                bad_uv += lef32(elem(&g, uva, q, 1, 4)) != (float)(1.0 - uv[2 * uvf[c] + 1]);
            }
            CHECK_EQ_INT(bad_pos, 0);
            CHECK_EQ_INT(bad_uv, 0);
            CHECK_EQ_INT(bad_d, 0);
        }
        glb_free(&g);
        dtx_mesh_free(&m);
    }
    CHECK_EQ_INT(temp_files(), 0);
}

/* A write that must fail: status, message, no file, no temporary file. */
static void expect_fail(const char *what, dtx_status got, dtx_status want, const dtx_error *err,
                        const char *needle, const char *path)
{
    CHECK_EQ_INT(got, want);
    if (got != want || !strstr(err->msg, needle))
        fprintf(stderr, "%s: got %s: %s (wanted /%s/)\n", what, dtx_status_name(got), err->msg,
                needle);
    CHECK(strstr(err->msg, needle) != NULL);
    CHECK_EQ_INT(access(path, F_OK), -1);
    CHECK_EQ_INT(temp_files(), 0);
}

static void test_errors(void)
{
    const char *path = SCRATCH "/bad.glb";
    dtx_mesh m, empty;
    frames f = {0};
    dtx_error err;
    dtx_status st;
    dtx_glb_opts o = opts(0.1, 0);
    octahedron(&m);
    memset(&empty, 0, sizeof empty);
    f.m = &m, f.nan_frame = f.fail_frame = f.change_after = -1;

    st = dtx_glb_write(path, &m, 0, frame_cb, &f, &o, &err);
    expect_fail("0 frames", st, DTX_EINVAL, &err, "0 frames", path);
    st = dtx_glb_write(path, &m, DTX_GLB_MAX_FRAMES + 1, frame_cb, &f, &o, &err);
    expect_fail("too many frames", st, DTX_EINVAL, &err, "a .glb holds 1 to", path);
    st = dtx_glb_write(path, &empty, 1, frame_cb, &f, &o, &err);
    expect_fail("empty mesh", st, DTX_EINVAL, &err, "empty", path);
    o.seconds_per_frame = 0.0;
    st = dtx_glb_write(path, &m, 2, frame_cb, &f, &o, &err);
    expect_fail("spf 0", st, DTX_EINVAL, &err, "seconds per frame", path);
    o.seconds_per_frame = 1e-45; /* k * spf collapses in float32 */
    st = dtx_glb_write(path, &m, 3, frame_cb, &f, &o, &err);
    expect_fail("times", st, DTX_EINVAL, &err, "not strictly increasing", path);
    o.seconds_per_frame = 0.1;

    m.F[4] = 6;
    st = dtx_glb_write(path, &m, 2, frame_cb, &f, &o, &err);
    expect_fail("index", st, DTX_ERANGE, &err, "out of range", path);
    m.F[4] = 4;
    m.V[7] = 1e39; /* beyond float32 */
    st = dtx_glb_write(path, &m, 2, frame_cb, &f, &o, &err);
    expect_fail("rest float range", st, DTX_ENONFINITE, &err, "rest vertex 2", path);
    m.V[7] = 1.0;

    f.nan_frame = 2;
    st = dtx_glb_write(path, &m, 4, frame_cb, &f, &o, &err);
    expect_fail("NaN frame", st, DTX_ENONFINITE, &err, "frame 2, vertex 5", path);
    f.nan_frame = -1;
    f.fail_frame = 1;
    st = dtx_glb_write(path, &m, 4, frame_cb, &f, &o, &err);
    expect_fail("callback error", st, DTX_EIO, &err, "frame 1 cannot be read", path);
    f.fail_frame = -1;
    f.calls = 0;
    f.change_after = 4; /* pass 2 differs from pass 1 */
    st = dtx_glb_write(path, &m, 4, frame_cb, &f, &o, &err);
    expect_fail("frames changed", st, DTX_EINVAL, &err, "changed between", path);
    f.change_after = -1;

    /* Over 4 GiB (100,489 vertices x 4096 frames): refused before any frame
     * is read. */
    {
        dtx_mesh big;
        frames fb = {0};
        grid(&big, 317, 317);
        fb.m = &big, fb.nan_frame = fb.fail_frame = fb.change_after = -1;
        st = dtx_glb_write(path, &big, DTX_GLB_MAX_FRAMES, frame_cb, &fb, &o, &err);
        expect_fail("4 GiB", st, DTX_ERANGE, &err, "exceed 4 GiB", path);
        CHECK_EQ_INT(fb.calls, 0);
        dtx_mesh_free(&big);
    }

    st = dtx_glb_write(SCRATCH "/no-such-dir/x.glb", &m, 2, frame_cb, &f, &o, &err);
    CHECK_EQ_INT(st, DTX_EIO);
    CHECK(strstr(err.msg, "no-such-dir") != NULL);

    /* A failed write leaves an existing file untouched. */
    {
        FILE *fp = fopen(path, "wb");
        fputs("old", fp);
        fclose(fp);
        f.nan_frame = 1;
        st = dtx_glb_write(path, &m, 3, frame_cb, &f, &o, &err);
        CHECK_EQ_INT(st, DTX_ENONFINITE);
        CHECK_EQ_INT(file_size(path), 3);
        CHECK_EQ_INT(temp_files(), 0);
        remove(path);
        f.nan_frame = -1;
    }
    dtx_mesh_free(&m);
}

int main(void)
{
    test_small();
    test_index_types();
    test_errors();
    test_attrs();
    return check_report();
}
