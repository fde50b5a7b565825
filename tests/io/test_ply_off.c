/* test_ply_off.c: the PLY (ascii, binary both byte orders) and OFF readers on
 * good, malformed, truncated and mutated input. */
#include "check.h"
#include "meshfile.h"

#include <dirent.h>
#include <stdint.h>
#include <string.h>
#include <sys/stat.h>

#define SCRATCH DTX_TEST_SCRATCH
#define DATA_DIR "/work/shared/data"

typedef struct {
    int count;
    char last[1024];
} warn_log;

static void collect(void *ctx, const char *msg)
{
    warn_log *l = ctx;
    l->count++;
    snprintf(l->last, sizeof l->last, "%s", msg);
}

typedef dtx_status (*parse_fn)(const char *, const char *, size_t, dtx_mesh *, const dtx_warner *,
                               dtx_error *);

/* Parses len bytes from an exactly sized heap copy (no NUL after it), so
 * that reading past the end shows up under valgrind/ASan. */
static dtx_status run(parse_fn fn, const char *name, const char *s, size_t len, dtx_mesh *m,
                      warn_log *wl, dtx_error *err)
{
    dtx_warner w = {collect, wl};
    char *copy = malloc(len ? len : 1);
    dtx_status st;
    if (wl)
        memset(wl, 0, sizeof *wl);
    memcpy(copy, s, len);
    err->msg[0] = '\0';
    st = fn(name, copy, len, m, wl ? &w : NULL, err);
    free(copy);
    return st;
}

static dtx_status ply(const char *s, dtx_mesh *m, warn_log *wl, dtx_error *err)
{
    return run(dtx_ply_parse, "t.ply", s, strlen(s), m, wl, err);
}

static dtx_status off(const char *s, dtx_mesh *m, warn_log *wl, dtx_error *err)
{
    return run(dtx_off_parse, "t.off", s, strlen(s), m, wl, err);
}

static void expect_fail_n(parse_fn fn, const char *name, const char *s, size_t len, dtx_status code,
                          const char *needle)
{
    dtx_mesh m;
    dtx_error err;
    dtx_status st = run(fn, name, s, len, &m, NULL, &err);
    CHECK_EQ_INT(st, code);
    CHECK(strstr(err.msg, needle) != NULL);
    if (st != code || !strstr(err.msg, needle))
        fprintf(stderr, "  message: %s\n  expected to contain: %s\n", err.msg, needle);
    CHECK(m.nv == 0 && m.nf == 0 && m.V == NULL && m.F == NULL);
    dtx_mesh_free(&m);
}

static void ply_fail(const char *s, dtx_status code, const char *needle)
{
    expect_fail_n(dtx_ply_parse, "t.ply", s, strlen(s), code, needle);
}

static void off_fail(const char *s, dtx_status code, const char *needle)
{
    expect_fail_n(dtx_off_parse, "t.off", s, strlen(s), code, needle);
}

static int mesh_sane(const dtx_mesh *m)
{
    if (m->nv < 1 || m->nf < 1 || !m->V || !m->F)
        return 0;
    for (int64_t i = 0; i < 3 * (int64_t)m->nv; i++)
        if (!isfinite(m->V[i]))
            return 0;
    for (int64_t i = 0; i < 3 * (int64_t)m->nf; i++)
        if (m->F[i] < 0 || m->F[i] >= m->nv)
            return 0;
    return 1;
}

/* Every prefix parses or fails cleanly; returns the number of prefixes that
 * misbehaved. */
static int truncations(parse_fn fn, const char *s, size_t len, int *nok)
{
    int bad = 0;
    *nok = 0;
    for (size_t cut = 0; cut <= len; cut++) {
        dtx_mesh m;
        dtx_error err;
        warn_log wl;
        if (run(fn, "cut", s, cut, &m, &wl, &err) == DTX_OK) {
            (*nok)++;
            bad += !mesh_sane(&m);
        } else {
            bad += err.msg[0] == '\0' || m.V != NULL || m.F != NULL;
        }
        dtx_mesh_free(&m);
    }
    return bad;
}

/* Random byte changes (from `alphabet`, or any byte when it is NULL). */
static int mutations(parse_fn fn, const char *s, size_t len, const char *alphabet, int iters)
{
    char *b = malloc(len);
    uint32_t x = 2024;
    int bad = 0;
    for (int iter = 0; iter < iters; iter++) {
        dtx_mesh m;
        dtx_error err;
        memcpy(b, s, len);
        for (int k = 0; k < 1 + iter % 3; k++) {
            size_t at;
            x = x * 1664525u + 1013904223u;
            at = (x >> 8) % len;
            x = x * 1664525u + 1013904223u;
            b[at] = alphabet ? alphabet[(x >> 8) % strlen(alphabet)] : (char)(x >> 24);
        }
        if (run(fn, "mut", b, len, &m, NULL, &err) == DTX_OK)
            bad += !mesh_sane(&m);
        else
            bad += err.msg[0] == '\0';
        dtx_mesh_free(&m);
    }
    free(b);
    return bad;
}

/* ================================================================== PLY */

static const char *ply_ascii = "ply\n"
                               "format ascii 1.0\n"
                               "comment a tetrahedron with extras\n"
                               "obj_info made by hand\n"
                               "element vertex 4\n"
                               "property float z\n" /* any order */
                               "property uchar red\n"
                               "property float x\n"
                               "property list uchar float extra\n"
                               "property double y\n"
                               "element face 4\n"
                               "property uchar flags\n"
                               "property list uchar int vertex_indices\n"
                               "element edge 2\n"
                               "property int vertex1\n"
                               "property int vertex2\n"
                               "end_header\n"
                               "0 255 0 0 0\n"
                               "0 1 1.5 2 7 8 0\n"
                               "0 2 0 1 9 -2.25\n"
                               "1e-3 3 0 0 0\n"
                               "0 3 0 2 1\n"
                               "0 3 0 1 3\n"
                               "0 3 0 3 2\n"
                               "0 3 1 2 3\n"
                               "0 1\n"
                               "1 2\n";

static void check_tet(const dtx_mesh *m)
{
    CHECK_EQ_INT(m->nv, 4);
    CHECK_EQ_INT(m->nf, 4);
    if (m->nv != 4 || m->nf != 4)
        return;
    CHECK_DBL(m->V[3], ==, 1.5);
    CHECK_DBL(m->V[7], ==, -2.25);
    CHECK_NEAR(m->V[11], 1e-3, 1e-10); /* 1e-3 as float or as double */
    CHECK_DBL(m->V[0] + m->V[1] + m->V[2], ==, 0);
    CHECK_EQ_INT(m->F[1], 2);
    CHECK_EQ_INT(m->F[2], 1);
    CHECK_EQ_INT(m->F[9], 1);
    CHECK_EQ_INT(m->F[11], 3);
}

static void test_ply_ascii(void)
{
    dtx_mesh m;
    dtx_error err;
    warn_log wl;
    CHECK_OK(ply(ply_ascii, &m, &wl, &err), &err);
    check_tet(&m);
    CHECK_EQ_INT(wl.count, 0);
    dtx_mesh_free(&m);
}

/* The same tetrahedron in binary, with a list in the vertex element, a
 * 16-bit and a 64-bit property to skip, and a trailing element. */
typedef struct {
    unsigned char b[2048];
    size_t n;
    int be;
} bin;

static void put(bin *o, const void *v, int size)
{
    const unsigned char *p = v;
    for (int k = 0; k < size; k++) /* the host is little-endian or big-endian */
        o->b[o->n + (size_t)k] = p[k];
    {
        uint16_t one = 1;
        int host_be = *(unsigned char *)&one == 0;
        if (host_be != o->be)
            for (int k = 0; k < size / 2; k++) {
                unsigned char t = o->b[o->n + (size_t)k];
                o->b[o->n + (size_t)k] = o->b[o->n + (size_t)(size - 1 - k)];
                o->b[o->n + (size_t)(size - 1 - k)] = t;
            }
    }
    o->n += (size_t)size;
}
static void put_f32(bin *o, float v) { put(o, &v, 4); }
static void put_f64(bin *o, double v) { put(o, &v, 8); }
static void put_u8(bin *o, uint8_t v) { put(o, &v, 1); }
static void put_i16(bin *o, int16_t v) { put(o, &v, 2); }
static void put_i32(bin *o, int32_t v) { put(o, &v, 4); }
static void put_u32(bin *o, uint32_t v) { put(o, &v, 4); }

static size_t make_binary_ply(bin *o, int be, int quad)
{
    const float P[4][3] = {{0, 0, 0}, {1.5f, 0, 0}, {0, -2.25f, 0}, {0, 0, 1e-3f}};
    const int32_t T[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
    int n = snprintf((char *)o->b, sizeof o->b,
                     "ply\r\nformat %s 1.0\r\n"
                     "element vertex 4\r\n"
                     "property float32 x\r\nproperty short s\r\nproperty float y\r\n"
                     "property list uchar double extra\r\nproperty float z\r\n"
                     "property double d\r\n"
                     "element face %d\r\n"
                     "property list uchar int vertex_index\r\nproperty uint tag\r\n"
                     "element material 1\r\nproperty int m\r\n"
                     "end_header\r\n",
                     be ? "binary_big_endian" : "binary_little_endian", quad ? 2 : 4);
    o->n = (size_t)n;
    o->be = be;
    for (int i = 0; i < 4; i++) {
        put_f32(o, P[i][0]);
        put_i16(o, (int16_t)-i);
        put_f32(o, P[i][1]);
        put_u8(o, (uint8_t)(i % 3));
        for (int k = 0; k < i % 3; k++)
            put_f64(o, 1e300);
        put_f32(o, P[i][2]);
        put_f64(o, -1.0);
    }
    if (quad) {
        /* a quad 0 1 2 3 and a pentagon-free triangle */
        put_u8(o, 4);
        for (int k = 0; k < 4; k++)
            put_i32(o, k);
        put_u32(o, 0xdeadbeefu);
        put_u8(o, 3);
        put_i32(o, 3);
        put_i32(o, 2);
        put_i32(o, 1);
        put_u32(o, 1);
    } else {
        for (int f = 0; f < 4; f++) {
            put_u8(o, 3);
            for (int k = 0; k < 3; k++)
                put_i32(o, T[f][k]);
            put_u32(o, (uint32_t)f);
        }
    }
    put_i32(o, 42);
    return o->n;
}

static void test_ply_binary(void)
{
    for (int be = 0; be <= 1; be++) {
        bin o;
        dtx_mesh m;
        dtx_error err;
        warn_log wl;
        size_t len = make_binary_ply(&o, be, 0);
        CHECK_OK(run(dtx_ply_parse, "b.ply", (char *)o.b, len, &m, &wl, &err), &err);
        check_tet(&m);
        CHECK_EQ_INT(wl.count, 0);
        dtx_mesh_free(&m);

        /* trailing bytes are ignored with a warning */
        o.b[len] = 0x55;
        CHECK_OK(run(dtx_ply_parse, "b.ply", (char *)o.b, len + 1, &m, &wl, &err), &err);
        CHECK_EQ_INT(wl.count, 1);
        CHECK(strstr(wl.last, "1 bytes") != NULL);
        dtx_mesh_free(&m);

        /* a quad is fan-triangulated, with one warning */
        len = make_binary_ply(&o, be, 1);
        CHECK_OK(run(dtx_ply_parse, "q.ply", (char *)o.b, len, &m, &wl, &err), &err);
        CHECK_EQ_INT(m.nf, 3);
        if (m.nf == 3) {
            const int32_t want[9] = {0, 1, 2, 0, 2, 3, 3, 2, 1};
            for (int k = 0; k < 9; k++)
                CHECK_EQ_INT(m.F[k], want[k]);
        }
        CHECK_EQ_INT(wl.count, 1);
        CHECK(strstr(wl.last, "1 polygons") != NULL);
        dtx_mesh_free(&m);

        /* every truncation fails cleanly (the material element at the end
         * makes every proper prefix short of data) */
        {
            int nok, bad;
            len = make_binary_ply(&o, be, 0);
            bad = truncations(dtx_ply_parse, (char *)o.b, len, &nok);
            CHECK_EQ_INT(bad, 0);
            CHECK_EQ_INT(nok, 1);
            CHECK_EQ_INT(mutations(dtx_ply_parse, (char *)o.b, len, NULL, 3000), 0);
        }
    }
}

static void test_ply_double_and_types(void)
{
    /* double coordinates, uint list count, uint indices, big-endian */
    bin o;
    dtx_mesh m;
    dtx_error err;
    o.be = 1;
    o.n = (size_t)sprintf((char *)o.b, "ply\nformat binary_big_endian 1.0\n"
                                       "element vertex 3\nproperty double x\n"
                                       "property double y\nproperty double z\n"
                                       "element face 1\nproperty list uint uint vertex_indices\n"
                                       "end_header\n");
    for (int i = 0; i < 9; i++)
        put_f64(&o, i == 4 ? 0.1 : i / 3.0);
    put_u32(&o, 3);
    put_u32(&o, 2);
    put_u32(&o, 1);
    put_u32(&o, 0);
    CHECK_OK(run(dtx_ply_parse, "d.ply", (char *)o.b, o.n, &m, NULL, &err), &err);
    CHECK_EQ_INT(m.nv, 3);
    if (m.nv == 3) {
        CHECK_DBL(m.V[4], ==, 0.1);
        CHECK_DBL(m.V[8], ==, 8 / 3.0);
        CHECK_EQ_INT(m.F[0], 2);
    }
    dtx_mesh_free(&m);
    /* an index out of range is found with its byte offset */
    o.n -= 4;
    put_u32(&o, 3);
    expect_fail_n(dtx_ply_parse, "d.ply", (char *)o.b, o.n, DTX_ERANGE,
                  "vertex index 3 out of range [0, 3)");
    /* a NaN coordinate */
    o.n = (size_t)(strstr((char *)o.b, "end_header\n") - (char *)o.b) + 11;
    for (int i = 0; i < 9; i++)
        put_f64(&o, i == 5 ? NAN : 1.0);
    put_u32(&o, 3);
    put_u32(&o, 0);
    put_u32(&o, 1);
    put_u32(&o, 2);
    expect_fail_n(dtx_ply_parse, "d.ply", (char *)o.b, o.n, DTX_ENONFINITE,
                  "vertex 1 (0-based) has a non-finite coordinate");
}

static void test_ply_fan_ascii(void)
{
    const char *s = "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\n"
                    "property float y\nproperty float z\nelement face 2\n"
                    "property list uchar int vertex_index\nend_header\n"
                    "0 0 0\n1 0 0\n1 1 0\n0 1 0\n-1 0.5 0\n"
                    "4 0 1 2 3\n5 4 0 1 2 3\n";
    dtx_mesh m;
    dtx_error err;
    warn_log wl;
    CHECK_OK(ply(s, &m, &wl, &err), &err);
    CHECK_EQ_INT(m.nf, 5);
    if (m.nf == 5) {
        CHECK_EQ_INT(m.F[9], 4);
        CHECK_EQ_INT(m.F[14], 3);
    }
    CHECK_EQ_INT(wl.count, 1);
    CHECK(strstr(wl.last, "2 polygons") != NULL);
    dtx_mesh_free(&m);
}

static void test_ply_bad(void)
{
    const char *hdr = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                      "property float y\nproperty float z\nelement face 1\n"
                      "property list uchar int vertex_indices\nend_header\n";
    char buf[1024];

    ply_fail("", DTX_EPARSE, "not a PLY file");
    ply_fail("PLY\nformat ascii 1.0\nend_header\n", DTX_EPARSE, "not a PLY file");
    ply_fail("ply\nelement vertex 3\nend_header\n", DTX_EPARSE, "no format line");
    ply_fail("ply\nformat binary_middle_endian 1.0\nend_header\n", DTX_EPARSE,
             "t.ply:2: unknown PLY format");
    ply_fail("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n", DTX_EPARSE,
             "no end_header");
    ply_fail("ply\nformat ascii 1.0\nproperty float x\nend_header\n", DTX_EPARSE,
             "t.ply:3: property before any element");
    ply_fail("ply\nformat ascii 1.0\nelement vertex 3\nproperty float128 x\nend_header\n",
             DTX_EPARSE, "t.ply:4: unknown property type 'float128'");
    ply_fail("ply\nformat ascii 1.0\nelement vertex -3\nend_header\n", DTX_ERANGE,
             "t.ply:3: bad element count");
    ply_fail("ply\nformat ascii 1.0\nfoo bar\nend_header\n", DTX_EPARSE,
             "t.ply:3: unknown header keyword 'foo'");
    ply_fail("ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\n"
             "end_header\n3 0 1 2\n",
             DTX_EPARSE, "no 'vertex' element");
    ply_fail("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
             "property float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n",
             DTX_EPARSE, "no 'face' element");
    ply_fail("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
             "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
             "0 0\n1 0\n0 1\n3 0 1 2\n",
             DTX_EPARSE, "no scalar property 'z'");
    ply_fail("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
             "property float z\nelement face 1\nproperty list uchar float vertex_indices\n"
             "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
             DTX_EPARSE, "t.ply:8: face vertex indices must have an integer type");
    ply_fail("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float x\n"
             "end_header\n",
             DTX_EPARSE, "t.ply:5: duplicate property 'x'");
    ply_fail("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
             "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
             "element vertex 3\nproperty float x\nend_header\n",
             DTX_EPARSE, "two 'vertex' elements");
    ply_fail("ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\n"
             "property float z\nelement face 0\nproperty list uchar int vertex_indices\n"
             "end_header\n",
             DTX_EPARSE, "no vertices");

    /* counts the data cannot hold: an error before any allocation */
    ply_fail("ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\n"
             "property float x\nproperty float y\nproperty float z\nelement face 1\n"
             "property list uchar int vertex_indices\nend_header\n0123456789",
             DTX_ERANGE, "1000000000000 vertices");
    ply_fail("ply\nformat binary_little_endian 1.0\nelement vertex 100000000\n"
             "property float x\nproperty float y\nproperty float z\nelement face 1\n"
             "property list uchar int vertex_indices\nend_header\n0123456789",
             DTX_ERANGE, "only 10 bytes follow the header");
    ply_fail("ply\nformat ascii 1.0\nelement vertex 1000\n"
             "property float x\nproperty float y\nproperty float z\nelement face 1\n"
             "property list uchar int vertex_indices\nend_header\n0 0 0\n",
             DTX_ERANGE, "only 6 bytes follow the header");
    ply_fail("ply\nformat ascii 1.0\nelement vertex 3\n"
             "property float x\nproperty float y\nproperty float z\nelement face 1\n"
             "property list uchar int vertex_indices\nelement junk 99999999999999999\n"
             "property int a\nend_header\n0 0 0\n",
             DTX_ERANGE, "follow the header");
    ply_fail("ply\nformat ascii 1.0\nelement vertex 3\n"
             "property float x\nproperty float y\nproperty float z\nelement face 1\n"
             "property list uchar int vertex_indices\nelement empty 99999999999999999\n"
             "end_header\n0 0 0\n",
             DTX_EPARSE, "element 'empty' has no properties");

    /* data errors in ascii name the line */
    snprintf(buf, sizeof buf, "%s0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", hdr);
    ply_fail(buf, DTX_ERANGE, "t.ply:13: face 0 (0-based): vertex index 3 out of range");
    snprintf(buf, sizeof buf, "%s0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n", hdr);
    ply_fail(buf, DTX_ERANGE, "t.ply:13: face 0 (0-based): vertex index -1 out of range");
    snprintf(buf, sizeof buf, "%s0 0 0\n1 0 0\n0 1 0\n2 0 1\n", hdr);
    ply_fail(buf, DTX_EPARSE, "t.ply:13: face 0 (0-based) has 2 vertices");
    snprintf(buf, sizeof buf, "%s0 0 0\n1 0 0\n0 1 0\n300 0 1 2\n", hdr);
    ply_fail(buf, DTX_ERANGE, "t.ply:13: element 'face' item 0 (0-based): out-of-range value");
    snprintf(buf, sizeof buf, "%s0 0 0\n1 0 x\n0 1 0\n3 0 1 2\n", hdr);
    ply_fail(buf, DTX_EPARSE, "t.ply:11: element 'vertex' item 1 (0-based): malformed value");
    snprintf(buf, sizeof buf, "%s0 0 0\n1 0 nan\n0 1 0\n3 0 1 2\n", hdr);
    ply_fail(buf, DTX_ENONFINITE, "t.ply:11: vertex 1 (0-based) has a non-finite coordinate");
    snprintf(buf, sizeof buf, "%s0 0 0\n1 0 0\n0 1 0\n3 0 1\n", hdr);
    ply_fail(buf, DTX_EPARSE, "unexpected end of data in element 'face'");
    {
        size_t n = (size_t)snprintf(buf, sizeof buf, "%s0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", hdr);
        buf[n - 3] = '\0';
        expect_fail_n(dtx_ply_parse, "t.ply", buf, n, DTX_EPARSE, "not a text file");
    }
    /* a NUL byte in the header */
    {
        const char s[] = "ply\nformat ascii 1.0\ncomment \0\nend_header\n";
        expect_fail_n(dtx_ply_parse, "t.ply", s, sizeof s - 1, DTX_EPARSE, "t.ply:3: NUL byte");
    }
}

static void test_ply_truncation(void)
{
    int nok, bad = truncations(dtx_ply_parse, ply_ascii, strlen(ply_ascii), &nok);
    CHECK_EQ_INT(bad, 0);
    /* the last element (edges) is needed: only the cuts in the final
     * newline(s) may succeed */
    CHECK(nok >= 1 && nok <= 2);
    CHECK_EQ_INT(
        mutations(dtx_ply_parse, ply_ascii, strlen(ply_ascii), "0123456789 -+.e\nxyz", 3000), 0);
}

/* ================================================================== OFF */

static void test_off_good(void)
{
    const char *s = "# leading comment\n"
                    "OFF\n"
                    "\n"
                    "4 4 6  # counts\n"
                    "0 0 0\n"
                    "1.5 0 0\n"
                    "0 -2.25 0 # a comment\n"
                    "0 0 1e-3\n"
                    "3 0 2 1\n"
                    "3 0 1 3 255 0 0\n" /* a face colour is ignored */
                    "3 0 3 2\n"
                    "3 1 2 3\n";
    dtx_mesh m;
    dtx_error err;
    warn_log wl;
    CHECK_OK(off(s, &m, &wl, &err), &err);
    CHECK_EQ_INT(m.nv, 4);
    CHECK_EQ_INT(m.nf, 4);
    if (m.nf == 4) {
        CHECK_DBL(m.V[3], ==, 1.5);
        CHECK_DBL(m.V[7], ==, -2.25);
        CHECK_DBL(m.V[11], ==, 1e-3);
        CHECK_EQ_INT(m.F[1], 2);
        CHECK_EQ_INT(m.F[11], 3);
    }
    CHECK_EQ_INT(wl.count, 0);
    dtx_mesh_free(&m);

    /* counts on the header line, COFF colours, CRLF, no final newline */
    CHECK_OK(off("COFF 3 1 0\r\n0 0 0 1 0 0 1\r\n1 0 0 0 1 0 1\r\n0 1 0 0 0 1 1\r\n3 0 1 2", &m,
                 NULL, &err),
             &err);
    CHECK_EQ_INT(m.nf, 1);
    CHECK_EQ_INT(m.nv, 3);
    dtx_mesh_free(&m);
    CHECK_OK(off("NOFF\n3 1\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n", &m, NULL, &err),
             &err);
    CHECK_EQ_INT(m.nf, 1);
    dtx_mesh_free(&m);

    /* fan triangulation, one warning */
    CHECK_OK(off("OFF\n5 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n-1 0.5 0\n4 0 1 2 3\n5 4 0 1 2 3\n", &m,
                 &wl, &err),
             &err);
    CHECK_EQ_INT(m.nf, 5);
    if (m.nf == 5) {
        const int32_t want[15] = {0, 1, 2, 0, 2, 3, 4, 0, 1, 4, 1, 2, 4, 2, 3};
        for (int k = 0; k < 15; k++)
            CHECK_EQ_INT(m.F[k], want[k]);
    }
    CHECK_EQ_INT(wl.count, 1);
    CHECK(strstr(wl.last, "2 polygons") != NULL && strstr(wl.last, "line 8") != NULL);
    dtx_mesh_free(&m);

    /* trailing data: a warning */
    CHECK_OK(off("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 2\n", &m, &wl, &err), &err);
    CHECK_EQ_INT(wl.count, 1);
    CHECK(strstr(wl.last, "t.off:7:") != NULL);
    dtx_mesh_free(&m);
}

static void test_off_bad(void)
{
    off_fail("", DTX_EPARSE, "empty file");
    off_fail("# nothing\n", DTX_EPARSE, "empty file");
    off_fail("ply\n3 1 0\n", DTX_EPARSE, "t.off:1: not an OFF file");
    off_fail("4OFF\n3 1 0\n", DTX_EPARSE, "t.off:1: unsupported OFF variant");
    off_fail("OFF BINARY\n", DTX_EPARSE, "binary OFF is not supported");
    off_fail("OFF\n", DTX_EPARSE, "no counts line");
    off_fail("OFF\n3\n", DTX_EPARSE, "t.off:2: malformed counts line");
    off_fail("OFF\n3 x 0\n", DTX_EPARSE, "t.off:2: malformed counts line: 'x'");
    off_fail("OFF\n3 1 0 7\n", DTX_EPARSE, "t.off:2: malformed counts line");
    off_fail("OFF\n-3 1 0\n", DTX_ERANGE, "t.off:2: count '-3' out of range");
    off_fail("OFF\n0 1 0\n", DTX_EPARSE, "no vertices");
    off_fail("OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n", DTX_EPARSE, "no faces");
    off_fail("OFF\n1000000000000 1 0\n0 0 0\n", DTX_ERANGE, "cannot fit");
    off_fail("OFF\n1000 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", DTX_ERANGE, "cannot fit");
    off_fail("OFF\n3 1 0\n0 0 0\n1 0\n0 1 0\n3 0 1 2\n", DTX_EPARSE,
             "t.off:4: malformed vertex line: expected 3 numbers, found 2");
    off_fail("OFF\n3 1 0\n0 0 0\n1 0 y\n0 1 0\n3 0 1 2\n", DTX_EPARSE,
             "t.off:4: malformed vertex line: 'y' is not a number");
    off_fail("OFF\n3 1 0\n0 0 0\n1 0 0\n0 inf 0\n3 0 1 2\n", DTX_ENONFINITE,
             "t.off:5: vertex 2 (0-based) has a non-finite coordinate");
    off_fail("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", DTX_ERANGE,
             "t.off:6: face vertex index 3 out of range [0, 3)");
    off_fail("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n", DTX_ERANGE,
             "t.off:6: face vertex index -1 out of range");
    off_fail("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n", DTX_EPARSE,
             "t.off:6: face with 2 vertices");
    off_fail("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n", DTX_EPARSE,
             "t.off:6: malformed face line: 4 vertex indices announced, 3 found");
    off_fail("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 z\n", DTX_EPARSE,
             "t.off:6: malformed face line: 'z'");
    off_fail("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\nq 0 1 2\n", DTX_EPARSE,
             "t.off:6: malformed face line: 'q'");
    off_fail("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n99999999999 0 1 2\n", DTX_ERANGE,
             "t.off:6: bad face vertex count");
    off_fail("OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n\n\n\n\n\n\n", DTX_EPARSE,
             "file ends after 1 of 2 faces");
    off_fail("OFF\n3 1 0\n0 0 0\n1 0 0\n\n\n\n\n\n\n\n\n\n\n\n", DTX_EPARSE,
             "file ends after 2 of 3 vertices");
    {
        const char s[] = "OFF\n3 1 0\n0 0 0\n1 0\0 0\n0 1 0\n3 0 1 2\n";
        expect_fail_n(dtx_off_parse, "t.off", s, sizeof s - 1, DTX_EPARSE, "not a text file");
    }
    /* A comment line of any length is skipped; a vertex line longer than
     * the limit is an error naming its line. */
    {
        size_t n = DTX_MESHFILE_MAX_LINE + 10;
        char *s = malloc(n + 100);
        dtx_mesh m;
        dtx_error err;
        size_t k = (size_t)sprintf(s, "OFF\n3 1 0\n#");
        memset(s + k, 'c', n);
        k += n;
        k += (size_t)sprintf(s + k, "\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
        CHECK_OK(run(dtx_off_parse, "t.off", s, k, &m, NULL, &err), &err);
        CHECK_EQ_INT(m.nf, 1);
        dtx_mesh_free(&m);
        k = (size_t)sprintf(s, "OFF\n3 1 0\n0 0 0");
        memset(s + k, ' ', n);
        k += n;
        k += (size_t)sprintf(s + k, "\n1 0 0\n0 1 0\n3 0 1 2\n");
        expect_fail_n(dtx_off_parse, "t.off", s, k, DTX_EPARSE, "t.off:3: line too long");
        free(s);
    }
}

/* s with every "\n" replaced by rep (a new string). */
static char *relined(const char *s, const char *rep)
{
    size_t n = 0, r = strlen(rep), k = 0;
    char *o;
    for (const char *p = s; *p; p++)
        n += *p == '\n' ? r : 1;
    o = malloc(n + 1);
    for (const char *p = s; *p; p++) {
        if (*p == '\n') {
            memcpy(o + k, rep, r);
            k += r;
        } else {
            o[k++] = *p;
        }
    }
    o[k] = '\0';
    return o;
}

/* Lone CR (classic Mac OS) and CRLF line ends read like LF in OFF files,
 * PLY headers and ascii PLY bodies; a binary body after a lone-CR header
 * may start with the byte 0x0A. */
static void test_cr_line_ends(void)
{
    const char *off_lf = "OFF\n# c\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    const char *eols[2] = {"\r", "\r\n"};
    dtx_mesh m;
    dtx_error err;
    for (int i = 0; i < 2; i++) {
        char *p = relined(ply_ascii, eols[i]), *o = relined(off_lf, eols[i]);
        CHECK_OK(ply(p, &m, NULL, &err), &err);
        check_tet(&m);
        dtx_mesh_free(&m);
        CHECK_OK(off(o, &m, NULL, &err), &err);
        CHECK_EQ_INT(m.nv, 3);
        CHECK_EQ_INT(m.nf, 1);
        dtx_mesh_free(&m);
        free(p);
        free(o);
    }
    off_fail("OFF\r3 1 0\r0 0 0\r1 x 0\r0 1 0\r3 0 1 2\r", DTX_EPARSE,
             "t.off:4: malformed vertex line: 'x' is not a number");
    {
        /* ascii PLY line numbers count lone CRs: the face is on line 13 */
        char *p = relined("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                          "property float y\nproperty float z\nelement face 1\n"
                          "property list uchar int vertex_indices\nend_header\n"
                          "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
                          "\r");
        ply_fail(p, DTX_ERANGE, "t.ply:13: face 0 (0-based): vertex index 3 out of range");
        free(p);
    }
    for (int i = 0; i < 2; i++) {
        /* x of vertex 0 is the float with bits 0x3F80000A: its first byte,
         * little-endian, is 0x0A, right after end_header's line end */
        unsigned char b[512];
        const uint32_t xbits = 0x3F80000Au;
        const float P[3][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
        float x0;
        char *h = relined("ply\nformat binary_little_endian 1.0\nelement vertex 3\n"
                          "property float x\nproperty float y\nproperty float z\n"
                          "element face 1\nproperty list uchar int vertex_indices\n"
                          "end_header\n",
                          eols[i]);
        size_t n = strlen(h);
        memcpy(b, h, n);
        free(h);
        memcpy(&x0, &xbits, 4);
        for (int v = 0; v < 3; v++)
            for (int c = 0; c < 3; c++) {
                float f = v == 0 && c == 0 ? x0 : P[v][c];
                uint32_t u;
                memcpy(&u, &f, 4);
                for (int k = 0; k < 4; k++)
                    b[n++] = (unsigned char)(u >> (8 * k));
            }
        b[n++] = 3;
        for (int v = 0; v < 3; v++)
            for (int k = 0; k < 4; k++)
                b[n++] = (unsigned char)(k == 0 ? v : 0);
        CHECK_OK(run(dtx_ply_parse, "b.ply", (char *)b, n, &m, NULL, &err), &err);
        CHECK_EQ_INT(m.nf, 1);
        if (m.nf == 1) {
            CHECK_DBL(m.V[0], ==, (double)x0);
            CHECK_DBL(m.V[3], ==, 1.0);
            CHECK_EQ_INT(m.F[2], 2);
        }
        dtx_mesh_free(&m);
    }
}

/* Only PLY version 1.0 exists; another version is refused, and header
 * comments may be of any length while other header lines may not. */
static void test_ply_version_and_long_lines(void)
{
    const char *h = "ply\nformat ascii %s\nelement vertex 3\nproperty float x\n"
                    "property float y\nproperty float z\nelement face 1\n"
                    "property list uchar int vertex_indices\nend_header\n"
                    "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    char s[512];
    dtx_mesh m;
    dtx_error err;
    snprintf(s, sizeof s, h, "1.0");
    CHECK_OK(ply(s, &m, NULL, &err), &err);
    dtx_mesh_free(&m);
    snprintf(s, sizeof s, h, "2.0");
    ply_fail(s, DTX_EPARSE, "t.ply:2: PLY version '2.0' is not supported (only 1.0)");
    snprintf(s, sizeof s, h, "1.01");
    ply_fail(s, DTX_EPARSE, "t.ply:2: PLY version '1.01' is not supported");
    snprintf(s, sizeof s, h, "");
    ply_fail(s, DTX_EPARSE, "t.ply:2: PLY version (none given) is not supported");
    snprintf(s, sizeof s, h, "1.0 extra");
    ply_fail(s, DTX_EPARSE, "t.ply:2: unexpected text after");
    {
        size_t n = DTX_MESHFILE_MAX_LINE + 10;
        char *b = malloc(n + 600);
        size_t k;
        snprintf(s, sizeof s, h, "1.0");
        k = (size_t)sprintf(b, "ply\ncomment ");
        memset(b + k, 'c', n);
        k += n;
        k += (size_t)sprintf(b + k, "\n%s", s + 4);
        CHECK_OK(run(dtx_ply_parse, "t.ply", b, k, &m, NULL, &err), &err);
        CHECK_EQ_INT(m.nf, 1);
        dtx_mesh_free(&m);
        k = (size_t)sprintf(b, "ply\nobj_info ");
        memset(b + k, ' ', n);
        k += n;
        k += (size_t)sprintf(b + k, "\n%s", s + 4);
        CHECK_OK(run(dtx_ply_parse, "t.ply", b, k, &m, NULL, &err), &err);
        dtx_mesh_free(&m);
        k = (size_t)sprintf(b, "ply\nformat ascii 1.0");
        memset(b + k, ' ', n);
        k += n;
        k += (size_t)sprintf(b + k, "\n%s", strchr(s + 4, '\n') + 1);
        expect_fail_n(dtx_ply_parse, "t.ply", b, k, DTX_EPARSE, "t.ply:2: header line too long");
        free(b);
    }
}

static void test_off_truncation(void)
{
    const char *s = "OFF\r\n# c\r\n4 2 0\r\n0 0 0\r\n1 0 0 0.5 0.5 0.5\r\n1 1 0\r\n"
                    "0 1 -1.5e-2\r\n4 0 1 2 3\r\n3 3 2 1 # x\r\n";
    int nok, bad = truncations(dtx_off_parse, s, strlen(s), &nok);
    CHECK_EQ_INT(bad, 0);
    CHECK(nok >= 1);
    CHECK_EQ_INT(mutations(dtx_off_parse, s, strlen(s), "0123456789 -+.e\n#OF", 3000), 0);
}

/* ================================================================== files */

static void write_file(const char *path, const char *s, size_t n)
{
    FILE *f = fopen(path, "wb");
    if (f) {
        fwrite(s, 1, n, f);
        fclose(f);
    }
}

static void test_files(void)
{
    dtx_mesh m;
    dtx_error err;
    bin o;
    size_t n = make_binary_ply(&o, 0, 0);
    write_file(SCRATCH "/tet.ply", (char *)o.b, n);
    {
        const char *t = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
        write_file(SCRATCH "/tet.Off", t, strlen(t));
    }
    CHECK_OK(dtx_mesh_read(SCRATCH "/tet.ply", &m, NULL, &err), &err);
    check_tet(&m);
    dtx_mesh_free(&m);
    CHECK_OK(dtx_mesh_read(SCRATCH "/tet.Off", &m, NULL, &err), &err);
    CHECK_EQ_INT(m.nf, 1);
    dtx_mesh_free(&m);
    CHECK_EQ_INT(dtx_ply_read(SCRATCH "/none.ply", &m, NULL, &err), DTX_EIO);
    CHECK(strstr(err.msg, "none.ply") != NULL);
    CHECK_EQ_INT(dtx_off_read(SCRATCH "/none.off", &m, NULL, &err), DTX_EIO);
}

static void test_real_data(void)
{
    const char *cactus = DATA_DIR "/cactus/cactus0.ply";
    struct stat sb;
    dtx_mesh m;
    dtx_error err;
    warn_log wl;
    dtx_warner w = {collect, &wl};
    if (stat(cactus, &sb) != 0) {
        printf("note: %s absent, real-data checks skipped\n", cactus);
        return;
    }
    memset(&wl, 0, sizeof wl);
    CHECK_OK(dtx_ply_read(cactus, &m, &w, &err), &err);
    CHECK_EQ_INT(m.nv, 5261);
    CHECK_EQ_INT(m.nf, 10518);
    CHECK_EQ_INT(wl.count, 0);
    if (m.nv == 5261) {
        /* the first vertex line is "0.513434 0.457519 0.583028" (floats) */
        CHECK_DBL(m.V[0], ==, 0.513434);
        CHECK_DBL(m.V[2], ==, 0.583028);
    }
    CHECK_OK(dtx_mesh_validate(&m, cactus, &err), &err);
    dtx_mesh_free(&m);
}

/* Every seed file under tests/io/corpus/<sub>/: good_* must read (and be
 * sane), bad_* must fail with a message naming the file. */
static void test_corpus(const char *sub)
{
    char dir[1024], path[2048];
    DIR *d;
    struct dirent *de;
    int seen = 0;
    snprintf(dir, sizeof dir, "%s/tests/io/corpus/%s", DTX_SRC, sub);
    d = opendir(dir);
    CHECK(d != NULL);
    if (!d)
        return;
    while ((de = readdir(d))) {
        dtx_mesh m;
        dtx_error err;
        dtx_status st;
        int good = strncmp(de->d_name, "good_", 5) == 0;
        if (!good && strncmp(de->d_name, "bad_", 4) != 0)
            continue;
        snprintf(path, sizeof path, "%s/%s", dir, de->d_name);
        st = dtx_mesh_read(path, &m, NULL, &err);
        seen++;
        if (good) {
            CHECK_OK(st, &err);
            CHECK(st != DTX_OK || mesh_sane(&m));
        } else {
            CHECK(st != DTX_OK && strstr(err.msg, de->d_name) != NULL);
            if (st == DTX_OK)
                fprintf(stderr, "  %s was accepted\n", path);
        }
        dtx_mesh_free(&m);
    }
    closedir(d);
    CHECK(seen >= 4);
}

/* ============================================================ bad-input rows
 * The rows of the bad-input table not covered above: binary garbage,
 * non-finite and out-of-range values in binary PLY (whose messages give
 * byte offsets), and list counts larger than the data. */

/* Writes into b a little-endian binary PLY: 3 float vertices (xyz) and 1
 * face with the list count `count` of type count_type ("uchar" or "uint")
 * followed by the nidx indices idx.  Returns its length. */
static size_t bin_ply(unsigned char *b, const char *count_type, const float *xyz, uint32_t count,
                      const int32_t *idx, int nidx)
{
    size_t n = (size_t)sprintf((char *)b,
                               "ply\nformat binary_little_endian 1.0\nelement vertex 3\n"
                               "property float x\nproperty float y\nproperty float z\n"
                               "element face 1\nproperty list %s int vertex_indices\n"
                               "end_header\n",
                               count_type);
    for (int i = 0; i < 9; i++) {
        uint32_t u;
        memcpy(&u, &xyz[i], 4);
        for (int k = 0; k < 4; k++)
            b[n++] = (unsigned char)(u >> (8 * k));
    }
    if (strcmp(count_type, "uchar") == 0) {
        b[n++] = (unsigned char)count;
    } else {
        for (int k = 0; k < 4; k++)
            b[n++] = (unsigned char)(count >> (8 * k));
    }
    for (int i = 0; i < nidx; i++)
        for (int k = 0; k < 4; k++)
            b[n++] = (unsigned char)((uint32_t)idx[i] >> (8 * k));
    return n;
}

static void test_bad_input_rows(void)
{
    unsigned char b[1024];
    float xyz[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    int32_t tri[3] = {0, 1, 2};
    size_t n, hdr;
    dtx_mesh m;
    dtx_error err;

    /* the good file, to be sure the variants differ only where meant */
    n = bin_ply(b, "uchar", xyz, 3, tri, 3);
    CHECK_OK(run(dtx_ply_parse, "b.ply", (char *)b, n, &m, NULL, &err), &err);
    CHECK_EQ_INT(m.nf, 1);
    dtx_mesh_free(&m);
    hdr = n - 9 * 4 - 1 - 3 * 4;

    /* NaN and infinity in binary data: the vertex and its byte offset */
    xyz[4] = NAN;
    n = bin_ply(b, "uchar", xyz, 3, tri, 3);
    expect_fail_n(dtx_ply_parse, "b.ply", (char *)b, n, DTX_ENONFINITE, "b.ply (byte offset");
    expect_fail_n(dtx_ply_parse, "b.ply", (char *)b, n, DTX_ENONFINITE,
                  "vertex 1 (0-based) has a non-finite coordinate");
    xyz[4] = -INFINITY;
    n = bin_ply(b, "uchar", xyz, 3, tri, 3);
    expect_fail_n(dtx_ply_parse, "b.ply", (char *)b, n, DTX_ENONFINITE,
                  "vertex 1 (0-based) has a non-finite coordinate");
    xyz[4] = 0;

    /* out of range and negative indices, at the offset of the index */
    {
        int32_t bad[3] = {0, 3, 2};
        char want[128];
        n = bin_ply(b, "uchar", xyz, 3, bad, 3);
        snprintf(want, sizeof want,
                 "b.ply (byte offset %zu): face 0 (0-based): vertex index 3 out of range [0, 3)",
                 hdr + 9 * 4 + 1 + 4);
        expect_fail_n(dtx_ply_parse, "b.ply", (char *)b, n, DTX_ERANGE, want);
        bad[1] = -1;
        n = bin_ply(b, "uchar", xyz, 3, bad, 3);
        expect_fail_n(dtx_ply_parse, "b.ply", (char *)b, n, DTX_ERANGE,
                      "face 0 (0-based): vertex index -1 out of range [0, 3)");
        bad[1] = INT32_MIN;
        n = bin_ply(b, "uchar", xyz, 3, bad, 3);
        expect_fail_n(dtx_ply_parse, "b.ply", (char *)b, n, DTX_ERANGE,
                      "vertex index -2147483648 out of range");
    }

    /* a list count far beyond the data (4294967295 indices announced, 3
     * present): the end of the data, not a huge allocation */
    n = bin_ply(b, "uint", xyz, UINT32_MAX, tri, 3);
    expect_fail_n(dtx_ply_parse, "b.ply", (char *)b, n, DTX_EPARSE,
                  "unexpected end of data in element 'face' item 0");
    n = bin_ply(b, "uchar", xyz, 255, tri, 3);
    expect_fail_n(dtx_ply_parse, "b.ply", (char *)b, n, DTX_EPARSE,
                  "unexpected end of data in element 'face' item 0");

    /* binary garbage, whole files and after a valid header: clean errors
     * naming the file */
    {
        char g[4096];
        uint32_t x = 99;
        for (size_t i = 0; i < sizeof g; i++) {
            x = x * 1664525u + 1013904223u;
            g[i] = (char)(x >> 24);
        }
        expect_fail_n(dtx_ply_parse, "g.ply", g, sizeof g, DTX_EPARSE, "g.ply: not a PLY file");
        expect_fail_n(dtx_off_parse, "g.off", g, sizeof g, DTX_EPARSE, "g.off: not a text file");
        for (size_t i = 0; i < sizeof g; i++)
            g[i] = g[i] ? g[i] : 'z'; /* no NUL: the text parsers go further */
        CHECK(run(dtx_off_parse, "g.off", g, sizeof g, &m, NULL, &err) != DTX_OK);
        CHECK(strncmp(err.msg, "g.off:", 6) == 0);
        dtx_mesh_free(&m);
        bin_ply(b, "uchar", xyz, 3, tri, 3); /* the header hdr was measured on */
        memcpy(g, b, hdr);
        CHECK(run(dtx_ply_parse, "g.ply", g, sizeof g, &m, NULL, &err) != DTX_OK || mesh_sane(&m));
        dtx_mesh_free(&m);
        memcpy(g, "ply\nformat ascii 1.0\n", 21);
        CHECK(run(dtx_ply_parse, "g.ply", g, sizeof g, &m, NULL, &err) != DTX_OK);
        CHECK(strncmp(err.msg, "g.ply", 5) == 0);
        dtx_mesh_free(&m);
    }
}


/* ------------------------------------------------------------ attributes */

static dtx_status ply_attrs(const char *s, size_t len, int32_t nf, dtx_mesh_attrs *a,
                            warn_log *wl, dtx_error *err)
{
    dtx_warner w = {collect, wl};
    char *copy = malloc(len ? len : 1);
    dtx_status st;
    memset(wl, 0, sizeof *wl);
    memcpy(copy, s, len);
    err->msg[0] = '\0';
    st = dtx_ply_parse_attrs("a.ply", copy, len, nf, a, &w, err);
    free(copy);
    return st;
}

/* A quad (two triangles) with uchar RGBA colours, float normals and s, t;
 * the tetrahedron in binary with float colours, double normals and
 * texture_u, texture_v; each read back into dtx_mesh_attrs. */
static void test_ply_attrs(void)
{
    static const char asc[] = "ply\nformat ascii 1.0\n"
                              "element vertex 4\n"
                              "property float x\nproperty float y\nproperty float z\n"
                              "property float nx\nproperty float ny\nproperty float nz\n"
                              "property uchar red\nproperty uchar green\nproperty uchar blue\n"
                              "property uchar alpha\nproperty float s\nproperty float t\n"
                              "element face 1\nproperty list uchar int vertex_indices\n"
                              "end_header\n"
                              "0 0 0 0 0 1 255 0 0 255 0 0\n"
                              "1 0 0 0 0 1 0 255 0 255 1 0\n"
                              "1 1 0 0 0 1 0 0 255 128 1 1\n"
                              "0 1 0 0 0 1 51 51 51 0 0 1\n"
                              "4 0 1 2 3\n";
    dtx_mesh_attrs a;
    dtx_error err;
    warn_log wl;
    CHECK_OK(ply_attrs(asc, strlen(asc), 2, &a, &wl, &err), &err);
    CHECK_EQ_INT(a.ncolor, 4);
    CHECK_EQ_INT(a.nn, 4);
    CHECK_EQ_INT(a.nuv, 4);
    CHECK_EQ_INT(wl.count, 0); /* the quad's warning is the mesh reader's */
    if (a.colors && a.normals && a.uv && a.uv_faces && a.normal_faces) {
        const int32_t F[6] = {0, 1, 2, 0, 2, 3};
        CHECK_NEAR(a.colors[0], 1.0, 0);
        CHECK_NEAR(a.colors[4 * 2 + 3], 128.0 / 255.0, 1e-15);
        CHECK_NEAR(a.colors[4 * 3 + 1], 0.2, 1e-15);
        CHECK_NEAR(a.normals[3 * 2 + 2], 1.0, 0);
        CHECK_NEAR(a.uv[2 * 2], 1.0, 0);
        CHECK_NEAR(a.uv[2 * 3 + 1], 1.0, 0);
        CHECK(memcmp(a.uv_faces, F, sizeof F) == 0);
        CHECK(memcmp(a.normal_faces, F, sizeof F) == 0);
        CHECK_OK(dtx_mesh_attrs_validate(&a, 4, 2, "a.ply", &err), &err);
    }
    dtx_mesh_attrs_free(&a);
    /* A face count other than the mesh's is refused. */
    CHECK_EQ_INT(ply_attrs(asc, strlen(asc), 3, &a, &wl, &err), DTX_EINVAL);

    /* Only some of the channels: nothing of that attribute is kept. */
    {
        static const char part[] = "ply\nformat ascii 1.0\nelement vertex 3\n"
                                   "property float x\nproperty float y\nproperty float z\n"
                                   "property float nx\nproperty float u\n"
                                   "property uchar red\nproperty uchar green\n"
                                   "element face 1\nproperty list uchar int vertex_indices\n"
                                   "end_header\n0 0 0 1 0 1 2\n1 0 0 1 0 1 2\n0 1 0 1 0 1 2\n"
                                   "3 0 1 2\n";
        CHECK_OK(ply_attrs(part, strlen(part), 1, &a, &wl, &err), &err);
        CHECK(!dtx_mesh_attrs_any(&a));
        dtx_mesh_attrs_free(&a);
    }
    /* A non-finite normal is an error naming the vertex; a float colour
     * outside [0, 1] drops the colours with a warning. */
    {
        static const char nan_n[] = "ply\nformat ascii 1.0\nelement vertex 3\n"
                                    "property float x\nproperty float y\nproperty float z\n"
                                    "property float nx\nproperty float ny\nproperty float nz\n"
                                    "element face 1\nproperty list uchar int vertex_indices\n"
                                    "end_header\n0 0 0 0 0 1\n1 0 0 0 nan 1\n0 1 0 0 0 1\n"
                                    "3 0 1 2\n";
        static const char big[] = "ply\nformat ascii 1.0\nelement vertex 3\n"
                                  "property float x\nproperty float y\nproperty float z\n"
                                  "property float red\nproperty float green\n"
                                  "property float blue\n"
                                  "element face 1\nproperty list uchar int vertex_indices\n"
                                  "end_header\n0 0 0 0 0 1\n1 0 0 0 1.5 1\n0 1 0 0 0 1\n"
                                  "3 0 1 2\n";
        CHECK_EQ_INT(ply_attrs(nan_n, strlen(nan_n), 1, &a, &wl, &err), DTX_ENONFINITE);
        CHECK(strstr(err.msg, "a.ply") && strstr(err.msg, "vertex 1 (0-based)") &&
              strstr(err.msg, "normal"));
        CHECK(!dtx_mesh_attrs_any(&a));
        CHECK_OK(ply_attrs(big, strlen(big), 1, &a, &wl, &err), &err);
        CHECK(a.colors == NULL);
        CHECK_EQ_INT(wl.count, 1);
        CHECK(strstr(wl.last, "vertex 1 (0-based)") && strstr(wl.last, "1.5"));
        dtx_mesh_attrs_free(&a);
    }

    /* Binary, both byte orders: float RGB, double normals, texture_u/v. */
    for (int be = 0; be <= 1; be++) {
        const float P[4][3] = {{0, 0, 0}, {1.5f, 0, 0}, {0, -2.25f, 0}, {0, 0, 1e-3f}};
        const int32_t T[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
        bin o;
        int nok, n = snprintf((char *)o.b, sizeof o.b,
                              "ply\nformat %s 1.0\nelement vertex 4\n"
                              "property float x\nproperty float y\nproperty float z\n"
                              "property float red\nproperty float green\nproperty float blue\n"
                              "property double nx\nproperty double ny\nproperty double nz\n"
                              "property float texture_u\nproperty float texture_v\n"
                              "element face 4\nproperty list uchar int vertex_indices\n"
                              "end_header\n",
                              be ? "binary_big_endian" : "binary_little_endian");
        o.n = (size_t)n;
        o.be = be;
        for (int i = 0; i < 4; i++) {
            for (int k = 0; k < 3; k++)
                put_f32(&o, P[i][k]);
            for (int k = 0; k < 3; k++)
                put_f32(&o, 0.25f * (float)(i + k) / 2.0f);
            for (int k = 0; k < 3; k++)
                put_f64(&o, k == i % 3 ? -1.0 : 0.0);
            put_f32(&o, 0.125f * (float)i);
            put_f32(&o, 1.0f - 0.125f * (float)i);
        }
        for (int f = 0; f < 4; f++) {
            put_u8(&o, 3);
            for (int k = 0; k < 3; k++)
                put_i32(&o, T[f][k]);
        }
        CHECK_OK(ply_attrs((char *)o.b, o.n, 4, &a, &wl, &err), &err);
        CHECK_EQ_INT(a.ncolor, 3);
        CHECK_EQ_INT(a.nn, 4);
        CHECK_EQ_INT(a.nuv, 4);
        if (a.colors && a.normals && a.uv) {
            CHECK_NEAR(a.colors[3 * 3 + 2], 0.25 * 5 / 2.0, 0);
            CHECK_NEAR(a.normals[3 * 2 + 2], -1.0, 0);
            CHECK_NEAR(a.normals[3 * 2 + 1], 0.0, 0);
            CHECK_NEAR(a.uv[2 * 3], 0.375, 0);
            CHECK_NEAR(a.uv[2 * 3 + 1], 0.625, 0);
            CHECK(memcmp(a.uv_faces, T, sizeof T) == 0);
        }
        dtx_mesh_attrs_free(&a);
        /* Every truncation fails cleanly, leaving nothing allocated. */
        nok = 0;
        for (size_t cut = 0; cut < o.n; cut++) {
            dtx_status st = ply_attrs((char *)o.b, cut, 4, &a, &wl, &err);
            nok += st == DTX_OK;
            CHECK(st == DTX_OK || (err.msg[0] && !dtx_mesh_attrs_any(&a)));
            dtx_mesh_attrs_free(&a);
        }
        CHECK_EQ_INT(nok, 0);
    }
}

int main(void)
{
    test_ply_ascii();
    test_ply_binary();
    test_ply_double_and_types();
    test_ply_fan_ascii();
    test_ply_bad();
    test_ply_truncation();
    test_ply_attrs();
    test_off_good();
    test_off_bad();
    test_off_truncation();
    test_cr_line_ends();
    test_ply_version_and_long_lines();
    test_bad_input_rows();
    test_files();
    test_real_data();
    test_corpus("ply");
    test_corpus("off");
    return check_report();
}
