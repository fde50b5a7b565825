/* test_npy.c: the .npy frame reader (src/io/npy.c).  Files are built here
 * byte by byte as numpy writes them: float32 and float64, little- and
 * big-endian, C and Fortran order, header versions 1.0 and 2.0, (T, V, 3)
 * and (V, 3); every value must come back exactly, in (frame, vertex,
 * coordinate) order.  Then every truncation of a good file, trailing bytes,
 * and malformed headers (magic, version, dtype, shape, keys) must be
 * rejected with a message naming the file and the problem, and no array. */
#include "check.h"
#include "npy.h"

#include <stdint.h>
#include <string.h>

/* A .npy image in buf (at most cap bytes): header text `dict` padded as
 * numpy pads it (to a multiple of 64 with spaces and '\n'), then the data
 * bytes.  Returns its length. */
static size_t make_npy(unsigned char *buf, size_t cap, int version, const char *dict,
                       const unsigned char *data, size_t ndata)
{
    size_t pre = version == 1 ? 10 : 12, hl = strlen(dict) + 1, total;
    while ((pre + hl) % 64)
        hl++;
    total = pre + hl + ndata;
    if (total > cap)
        return 0;
    memcpy(buf, "\x93NUMPY", 6);
    buf[6] = (unsigned char)version;
    buf[7] = 0;
    if (version == 1) {
        buf[8] = (unsigned char)(hl & 0xff);
        buf[9] = (unsigned char)(hl >> 8);
    } else {
        for (int k = 0; k < 4; k++)
            buf[8 + k] = (unsigned char)((hl >> (8 * k)) & 0xff);
    }
    memset(buf + pre, ' ', hl);
    memcpy(buf + pre, dict, strlen(dict));
    buf[pre + hl - 1] = '\n';
    memcpy(buf + pre + hl, data, ndata);
    return total;
}

/* The value at (frame t, vertex v, coordinate c) of the test arrays:
 * distinct, exact in float32, some negative. */
static double value(int t, int v, int c) { return (t * 100 + v * 10 + c) * 0.25 - 7.0; }

/* The data of a T x V x 3 array in the given order and item type. */
static size_t make_data(unsigned char *out, int T, int V, int f64, int big, int fortran)
{
    size_t k = 0, sz = f64 ? 8 : 4;
    int dims[3] = {T, V, 3};
    for (int i = 0; i < T * V * 3; i++) {
        int t, v, c;
        unsigned char b[8];
        if (!fortran) {
            t = i / (V * 3);
            v = i / 3 % V;
            c = i % 3;
        } else {
            t = i % dims[0];
            v = i / dims[0] % dims[1];
            c = i / (dims[0] * dims[1]);
        }
        if (f64) {
            double d = value(t, v, c);
            memcpy(b, &d, 8);
        } else {
            float f = (float)value(t, v, c);
            memcpy(b, &f, 4);
        }
        /* The test host is little-endian (checked in main). */
        for (size_t j = 0; j < sz; j++)
            out[k + j] = big ? b[sz - 1 - j] : b[j];
        k += sz;
    }
    return k;
}

static void expect_frames(const unsigned char *buf, size_t len, int T, int V)
{
    int32_t t = -1, v = -1;
    double *X = NULL;
    dtx_error err;
    dtx_status st = dtx_npy_parse_frames("a.npy", buf, len, &t, &v, &X, &err);
    CHECK_EQ_INT(st, DTX_OK);
    if (st != DTX_OK) {
        fprintf(stderr, "  %s\n", err.msg);
        return;
    }
    CHECK_EQ_INT(t, T);
    CHECK_EQ_INT(v, V);
    for (int i = 0; i < T * V * 3; i++)
        if (X[i] != value(i / (V * 3), i / 3 % V, i % 3)) {
            CHECK_DBL(X[i], ==, value(i / (V * 3), i / 3 % V, i % 3));
            break;
        }
    free(X);
}

static void expect_fail(const unsigned char *buf, size_t len, const char *what)
{
    int32_t t = -1, v = -1;
    double *X = (double *)&t; /* must become NULL */
    dtx_error err;
    dtx_status st = dtx_npy_parse_frames("bad.npy", buf, len, &t, &v, &X, &err);
    CHECK_EQ_INT(st, DTX_EPARSE);
    CHECK(X == NULL);
    if (st == DTX_OK)
        fprintf(stderr, "  accepted instead of \"%s\"\n", what);
    if (st != DTX_OK) {
        CHECK(strncmp(err.msg, "bad.npy: ", 9) == 0);
        if (!strstr(err.msg, what)) {
            CHECK(strstr(err.msg, what) != NULL);
            fprintf(stderr, "  message \"%s\" lacks \"%s\"\n", err.msg, what);
        }
    } else {
        free(X);
    }
}

static unsigned char buf[1 << 16], data[1 << 15], m[1 << 16];

static void test_good(void)
{
    static const struct {
        const char *descr;
        int f64, big;
    } types[] = {{"<f4", 0, 0}, {">f4", 0, 1}, {"<f8", 1, 0}, {">f8", 1, 1}};
    char dict[256];
    for (int ti = 0; ti < 4; ti++)
        for (int fortran = 0; fortran < 2; fortran++)
            for (int version = 1; version <= 2; version++) {
                size_t nd = make_data(data, 4, 5, types[ti].f64, types[ti].big, fortran), len;
                snprintf(dict, sizeof dict,
                         "{'descr': '%s', 'fortran_order': %s, 'shape': (4, 5, 3), }",
                         types[ti].descr, fortran ? "True" : "False");
                len = make_npy(buf, sizeof buf, version, dict, data, nd);
                expect_frames(buf, len, 4, 5);
            }
    /* (V, 3): one frame; Fortran order too. */
    {
        size_t nd = make_data(data, 1, 7, 0, 0, 1), len;
        len = make_npy(buf, sizeof buf, 1,
                       "{'descr': '<f4', 'fortran_order': True, 'shape': (7, 3), }", data, nd);
        expect_frames(buf, len, 1, 7);
    }
    /* Keys in another order, double quotes, Python 2 longs, no trailing
     * comma, version 3.0. */
    {
        size_t nd = make_data(data, 2, 3, 1, 0, 0), len;
        len = make_npy(buf, sizeof buf, 3,
                       "{\"shape\": (2L, 3L, 3L), \"fortran_order\": False, \"descr\": \"<f8\"}",
                       data, nd);
        expect_frames(buf, len, 2, 3);
    }
}

static void test_bad(void)
{
    const char *good_dict = "{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3, 3), }";
    size_t nd = make_data(data, 2, 3, 0, 0, 0),
           len = make_npy(buf, sizeof buf, 1, good_dict, data, nd);
    /* Every truncation: the magic, the header, then the data. */
    for (size_t cut = 0; cut < len; cut++) {
        const char *what = cut < 6 ? "not a .npy file" : "truncated";
        memcpy(m, buf, cut);
        expect_fail(m, cut, what);
    }
    memcpy(m, buf, len);
    memset(m + len, 0, 4);
    expect_fail(m, len + 4, "trailing bytes");
    memcpy(m, buf, len);
    m[1] = 'n';
    expect_fail(m, len, "not a .npy file");
    memcpy(m, buf, len);
    m[6] = 4;
    expect_fail(m, len, "version 4.0");
    memcpy(m, buf, len);
    m[len - nd - 1] = ' '; /* the header's closing newline */
    expect_fail(m, len, "newline");

#define BAD_DICT(dict, what)                                  \
    do {                                                      \
        size_t l_ = make_npy(m, sizeof m, 1, dict, data, nd); \
        expect_fail(m, l_, what);                             \
    } while (0)
    BAD_DICT("{'descr': '<i4', 'fortran_order': False, 'shape': (2, 3, 3), }", "dtype '<i4'");
    BAD_DICT("{'descr': '<f2', 'fortran_order': False, 'shape': (2, 3, 3), }", "dtype '<f2'");
    BAD_DICT("{'descr': '<c8', 'fortran_order': False, 'shape': (2, 3, 3), }", "dtype '<c8'");
    BAD_DICT("{'descr': '|u1', 'fortran_order': False, 'shape': (2, 3, 3), }", "dtype '|u1'");
    BAD_DICT("{'descr': [('x', '<f4')], 'fortran_order': False, 'shape': (2, 3, 3), }", "record");
    BAD_DICT("{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3, 4), }",
             "shape (2, 3, 4): expected (frames, vertices, 3)");
    BAD_DICT("{'descr': '<f4', 'fortran_order': False, 'shape': (18,), }", "shape (18,)");
    BAD_DICT("{'descr': '<f4', 'fortran_order': False, 'shape': (), }", "shape ()");
    BAD_DICT("{'descr': '<f4', 'fortran_order': False, 'shape': (1, 2, 3, 3), }",
             "shape (1, 2, 3, 3)");
    BAD_DICT("{'descr': '<f4', 'fortran_order': False, 'shape': (0, 3, 3), }", "0 frames");
    BAD_DICT("{'descr': '<f4', 'fortran_order': False, 'shape': (3000000000, 3, 3), }",
             "3000000000 frames");
    BAD_DICT("{'descr': '<f4', 'fortran_order': False, 'shape': (99999999999999999999, 3, 3), }",
             "too large");
    BAD_DICT("{'descr': '<f4', 'fortran_order': False, 'shape': (2, -3, 3), }",
             "non-negative integers");
    BAD_DICT("{'descr': '<f4', 'fortran_order': Maybe, 'shape': (2, 3, 3), }", "fortran_order");
    BAD_DICT("{'descr': '<f4', 'shape': (2, 3, 3), }", "must all be given");
    BAD_DICT("{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3, 3), 'x': 1}",
             "unknown key 'x'");
    BAD_DICT("{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3, 3)", "no ',' or '}'");
    BAD_DICT("['descr', '<f4']", "not a dict");
    /* A huge shape whose data is absent: refused from the size, before any
     * allocation. */
    BAD_DICT("{'descr': '<f8', 'fortran_order': False, 'shape': (2000000000, 2000000000, 3), }",
             "truncated");
    BAD_DICT("{'descr': '<f8', 'fortran_order': False, 'shape': (3, 3, 3), }",
             "72 data bytes, but 3 frames x 3 vertices x 3 float64 need 216 (truncated)");
#undef BAD_DICT
}

int main(void)
{
    const uint16_t one = 1;
    if (*(const unsigned char *)&one != 1) {
        fprintf(stderr, "test_npy builds its arrays for a little-endian host\n");
        return 1;
    }
    test_good();
    test_bad();
    return check_report();
}
