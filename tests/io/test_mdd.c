/* test_mdd.c: the MDD point cache writer and parser: a round trip bitwise
 * equal to the float32-rounded input, the big-endian header and times as
 * Blender's Mesh Cache reads them, rejected arguments and samples (no file
 * or temporary file left, an existing file untouched), and truncated,
 * padded and miscounted files rejected. */
#include "check.h"
#include "mdd.h"

#include <dirent.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define SCRATCH DTX_TEST_SCRATCH

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

static unsigned char *slurp(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    long n;
    unsigned char *buf;
    *len = 0;
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    n = ftell(f);
    fseek(f, 0, SEEK_SET);
    buf = malloc(n > 0 ? (size_t)n : 1);
    if (buf && fread(buf, 1, (size_t)n, f) != (size_t)n) {
        free(buf);
        buf = NULL;
    }
    fclose(f);
    *len = buf ? (size_t)n : 0;
    return buf;
}

static uint32_t be32(const unsigned char *p)
{
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | (uint32_t)p[3];
}

static uint32_t bits(float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    return u;
}

static void test_round_trip(void)
{
    enum { NP = 5, NS = 4 };
    const char *path = SCRATCH "/rt.mdd";
    const float times[NS] = {0.0f, 1.0f / 30, 2.0f / 30, 0.125f};
    double X[NS][NP * 3];
    float want[NS][NP * 3], *P = NULL, *T = NULL;
    int32_t ns, np;
    dtx_mdd_writer w;
    dtx_error err;
    unsigned char *b;
    size_t len;
    for (int s = 0; s < NS; s++)
        for (int i = 0; i < NP * 3; i++) {
            X[s][i] = (s + 1) * 0.1 + i / 3.0 - 2.0; /* rounding to float matters */
            want[s][i] = (float)X[s][i];
        }
    CHECK_OK(dtx_mdd_begin(&w, path, NP, NS, times, &err), &err);
    for (int s = 0; s < NS; s++)
        CHECK_OK(dtx_mdd_write_sample(&w, X[s], &err), &err);
    CHECK_OK(dtx_mdd_finish(&w, &err), &err);
    CHECK_EQ_INT(file_size(path), 8 + 4 * NS + 12 * NP * NS);
    CHECK_EQ_INT(temp_files(), 0);

    /* Big-endian: frame count, point count, times, then sample 1 point 2 y. */
    b = slurp(path, &len);
    CHECK(b != NULL && len == 8 + 4 * NS + 12 * NP * NS);
    if (b && len == 8 + 4 * NS + 12 * NP * NS) {
        CHECK_EQ_INT(be32(b), NS);
        CHECK_EQ_INT(be32(b + 4), NP);
        CHECK_EQ_INT(be32(b + 8 + 4), bits(times[1]));
        CHECK_EQ_INT(be32(b + 8 + 4 * NS + 12 * (1 * NP + 2) + 4), bits(want[1][3 * 2 + 1]));
        CHECK_OK(dtx_mdd_parse("rt.mdd", b, len, &ns, &np, &T, &P, &err), &err);
        CHECK_EQ_INT(ns, NS);
        CHECK_EQ_INT(np, NP);
        CHECK(T && memcmp(T, times, sizeof times) == 0);
        CHECK(P && memcmp(P, want, sizeof want) == 0);
    }
    free(T);
    free(P);
    free(b);
}

static void expect_write_fail(const char *what, dtx_status code, const char *needle, dtx_status st,
                              const dtx_error *err, const char *path)
{
    CHECK_EQ_INT(st, code);
    if (st != code || !strstr(err->msg, needle))
        fprintf(stderr, "%s: got %s: %s (wanted /%s/)\n", what, dtx_status_name(st), err->msg,
                needle);
    CHECK(strstr(err->msg, needle) != NULL);
    CHECK_EQ_INT(access(path, F_OK), -1);
    CHECK_EQ_INT(temp_files(), 0);
}

static void test_write_errors(void)
{
    const char *path = SCRATCH "/bad.mdd";
    const float t2[2] = {0.0f, 0.5f}, same[2] = {0.5f, 0.5f}, nan2[2] = {0.0f, NAN};
    double X[6] = {0, 1, 2, 3, 4, 5};
    dtx_mdd_writer w;
    dtx_error err;
    dtx_status st;

    st = dtx_mdd_begin(&w, path, 0, 2, t2, &err);
    expect_write_fail("no points", DTX_EINVAL, "at least one point", st, &err, path);
    st = dtx_mdd_begin(&w, path, 2, 2, same, &err);
    expect_write_fail("equal times", DTX_EINVAL, "sample 1 (0-based)", st, &err, path);
    st = dtx_mdd_begin(&w, path, 2, 2, nan2, &err);
    expect_write_fail("NaN time", DTX_EINVAL, "not finite", st, &err, path);

    CHECK_OK(dtx_mdd_begin(&w, path, 2, 2, t2, &err), &err);
    X[4] = 1e300; /* beyond float32 */
    st = dtx_mdd_write_sample(&w, X, &err);
    X[4] = 4;
    expect_write_fail("beyond float32", DTX_ENONFINITE, "point 1", st, &err, path);
    dtx_mdd_abort(&w);

    CHECK_OK(dtx_mdd_begin(&w, path, 2, 2, t2, &err), &err);
    CHECK_OK(dtx_mdd_write_sample(&w, X, &err), &err);
    st = dtx_mdd_finish(&w, &err);
    expect_write_fail("too few", DTX_EINVAL, "1 of the 2 samples", st, &err, path);

    /* An existing file is untouched by an aborted write. */
    {
        FILE *f = fopen(path, "wb");
        fputs("old", f);
        fclose(f);
        CHECK_OK(dtx_mdd_begin(&w, path, 2, 2, t2, &err), &err);
        CHECK_OK(dtx_mdd_write_sample(&w, X, &err), &err);
        dtx_mdd_abort(&w);
        CHECK_EQ_INT(file_size(path), 3);
        CHECK_EQ_INT(temp_files(), 0);
        remove(path);
    }
}

static void expect_parse_fail(const unsigned char *buf, size_t len, const char *needle)
{
    unsigned char *copy = malloc(len ? len : 1);
    float *P = (float *)1, *T = (float *)1;
    int32_t ns, np;
    dtx_error err;
    dtx_status st;
    memcpy(copy, buf, len);
    st = dtx_mdd_parse("t.mdd", copy, len, &ns, &np, &T, &P, &err);
    free(copy);
    CHECK_EQ_INT(st, DTX_EPARSE);
    CHECK(P == NULL && T == NULL);
    if (!strstr(err.msg, needle))
        fprintf(stderr, "parse: message \"%s\" lacks \"%s\"\n", err.msg, needle);
    CHECK(strstr(err.msg, needle) != NULL);
}

static void test_parse_errors(void)
{
    const char *path = SCRATCH "/p.mdd";
    const float t2[2] = {0.0f, 0.5f};
    double X[6] = {0.5, 1, 2, 3, 4, 5};
    dtx_mdd_writer w;
    dtx_error err;
    unsigned char *good, *m;
    size_t len;
    CHECK_OK(dtx_mdd_begin(&w, path, 2, 2, t2, &err), &err);
    CHECK_OK(dtx_mdd_write_sample(&w, X, &err), &err);
    CHECK_OK(dtx_mdd_write_sample(&w, X, &err), &err);
    CHECK_OK(dtx_mdd_finish(&w, &err), &err);
    good = slurp(path, &len);
    CHECK(good != NULL && len == 8 + 8 + 48);
    if (!good)
        return;
    m = malloc(len + 4);
    for (size_t cut = 0; cut < len; cut++)
        expect_parse_fail(good, cut, cut < 8 ? "shorter than the 8-byte" : "truncated");
    memcpy(m, good, len);
    memset(m + len, 0, 4);
    expect_parse_fail(m, len + 4, "trailing bytes");
    memcpy(m, good, len);
    m[0] = 0xff, m[1] = 0xff, m[2] = 0xff, m[3] = 0xff; /* -1 samples */
    expect_parse_fail(m, len, "-1 samples");
    memcpy(m, good, len);
    m[4] = 0x7f, m[5] = 0xff, m[6] = 0xff, m[7] = 0xff; /* more points than the file holds */
    expect_parse_fail(m, len, "truncated");
    free(m);
    free(good);
}

int main(void)
{
    test_round_trip();
    test_write_errors();
    test_parse_errors();
    return check_report();
}
