/* test_pc2.c: the PC2 point cache writer and reader: a round trip that is
 * bitwise equal to the float32-rounded input, the header bytes, and
 * rejected arguments, samples and files (truncated, trailing bytes, bad
 * signature, version, counts), with no file or temporary file left after a
 * failed write and an existing file untouched. */
#include "check.h"
#include "pc2.h"

#include <dirent.h>
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define SCRATCH DTX_TEST_SCRATCH

/* A deterministic pseudo-random double in [-s, s). */
static double rnd(uint64_t *state, double s)
{
    *state = *state * 6364136223846793005ull + 1442695040888963407ull;
    return s * ((double)(*state >> 11) / 9007199254740992.0 * 2.0 - 1.0);
}

static long file_size(const char *path)
{
    struct stat sb;
    return stat(path, &sb) == 0 ? (long)sb.st_size : -1;
}

/* Number of temporary files (".NAME.tmp-...") left in the scratch dir. */
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

static uint32_t le32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

/* ------------------------------------------------------------------ */

static void test_round_trip(void)
{
    enum { NP = 7, NS = 5 };
    const char *path = SCRATCH "/rt.pc2";
    double X[NS][NP * 3];
    float want[NS][NP * 3], *P = NULL;
    uint64_t state = 42;
    dtx_pc2_writer w;
    dtx_pc2_header h;
    dtx_error err;
    unsigned char *bytes;
    size_t len;
    float f;

    for (int s = 0; s < NS; s++)
        for (int i = 0; i < NP * 3; i++) {
            /* Values whose float rounding matters, plus exact ones. */
            X[s][i] = (i % 5 == 0) ? (double)(s * 100 + i) : rnd(&state, 1e3);
            want[s][i] = (float)X[s][i];
        }
    CHECK_OK(dtx_pc2_begin(&w, path, NP, NS, 1.0f, 2.0f, &err), &err);
    for (int s = 0; s < NS - 1; s++)
        CHECK_OK(dtx_pc2_write_sample(&w, X[s], &err), &err);
    CHECK_OK(dtx_pc2_write_sample_f32(&w, want[NS - 1], &err), &err); /* float32 entry */
    CHECK_OK(dtx_pc2_finish(&w, &err), &err);
    CHECK_EQ_INT(file_size(path), 32 + 12 * NP * NS);
    CHECK_EQ_INT(temp_files(), 0);

    /* Header bytes, as the format describes them (little-endian). */
    bytes = slurp(path, &len);
    CHECK(bytes != NULL && len == 32 + 12 * NP * NS);
    if (bytes && len >= 32) {
        CHECK(memcmp(bytes, "POINTCACHE2\0", 12) == 0);
        CHECK_EQ_INT(le32(bytes + 12), 1);
        CHECK_EQ_INT(le32(bytes + 16), NP);
        CHECK_EQ_INT(le32(bytes + 28), NS);
        f = 1.0f;
        CHECK_EQ_INT(le32(bytes + 20), le32((const unsigned char *)&f)); /* host is LE */
        /* Sample 2, point 3, y: byte 32 + 12 * (2 * NP + 3) + 4. */
        memcpy(&f, bytes + 32 + 12 * (2 * NP + 3) + 4, 4);
        CHECK_DBL(f, ==, want[2][3 * 3 + 1]);
    }
    free(bytes);

    /* Read back: header fields and every float bitwise equal. */
    CHECK_OK(dtx_pc2_read(path, &h, &P, &err), &err);
    CHECK_EQ_INT(h.version, 1);
    CHECK_EQ_INT(h.num_points, NP);
    CHECK_EQ_INT(h.num_samples, NS);
    CHECK_DBL(h.start_frame, ==, 1.0);
    CHECK_DBL(h.sample_rate, ==, 2.0);
    CHECK(P != NULL && memcmp(P, want, sizeof want) == 0);
    if (P && memcmp(P, want, sizeof want) != 0)
        for (int i = 0; i < NS * NP * 3; i++)
            if (memcmp(&P[i], &want[i / (NP * 3)][i % (NP * 3)], 4) != 0) {
                fprintf(stderr, "first difference at float %d: %.9g vs %.9g\n", i, (double)P[i],
                        (double)want[i / (NP * 3)][i % (NP * 3)]);
                break;
            }
    free(P);
}

/* A write that must fail: status `code`, a message containing `needle`,
 * no file at path and no temporary file. */
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
    const char *path = SCRATCH "/bad.pc2";
    double X[6] = {0, 1, 2, 3, 4, 5};
    dtx_pc2_writer w;
    dtx_error err;
    dtx_status st;

    st = dtx_pc2_begin(&w, path, 0, 1, 0.0f, 1.0f, &err);
    expect_write_fail("no points", DTX_EINVAL, "at least one point", st, &err, path);
    st = dtx_pc2_begin(&w, path, 2, 0, 0.0f, 1.0f, &err);
    expect_write_fail("no samples", DTX_EINVAL, "at least one point", st, &err, path);
    st = dtx_pc2_begin(&w, path, 2, 1, 0.0f, 0.0f, &err);
    expect_write_fail("rate 0", DTX_EINVAL, "sample rate", st, &err, path);
    st = dtx_pc2_begin(&w, path, 2, 1, NAN, 1.0f, &err);
    expect_write_fail("NaN start", DTX_EINVAL, "start frame", st, &err, path);
    st = dtx_pc2_begin(&w, SCRATCH "/no-such-dir/x.pc2", 2, 1, 0.0f, 1.0f, &err);
    CHECK_EQ_INT(st, DTX_EIO);
    CHECK(strstr(err.msg, "no-such-dir") != NULL);

    /* A NaN, an infinity and a double beyond float32 in a sample. */
    {
        const double bad[3] = {NAN, INFINITY, 1e300};
        for (int b = 0; b < 3; b++) {
            CHECK_OK(dtx_pc2_begin(&w, path, 2, 2, 0.0f, 1.0f, &err), &err);
            CHECK_OK(dtx_pc2_write_sample(&w, X, &err), &err);
            X[4] = bad[b];
            st = dtx_pc2_write_sample(&w, X, &err);
            X[4] = 4;
            expect_write_fail("non-finite", DTX_ENONFINITE, "point 1", st, &err, path);
            dtx_pc2_abort(&w); /* allowed after a failure */
        }
    }

    /* Too few samples at finish, too many while writing. */
    CHECK_OK(dtx_pc2_begin(&w, path, 2, 3, 0.0f, 1.0f, &err), &err);
    CHECK_OK(dtx_pc2_write_sample(&w, X, &err), &err);
    st = dtx_pc2_finish(&w, &err);
    expect_write_fail("too few", DTX_EINVAL, "1 of the 3 samples", st, &err, path);
    CHECK_OK(dtx_pc2_begin(&w, path, 2, 1, 0.0f, 1.0f, &err), &err);
    CHECK_OK(dtx_pc2_write_sample(&w, X, &err), &err);
    st = dtx_pc2_write_sample(&w, X, &err);
    expect_write_fail("too many", DTX_EINVAL, "more than the 1 samples", st, &err, path);

    /* An existing file is untouched by an aborted write. */
    {
        FILE *f = fopen(path, "wb");
        fputs("old contents", f);
        fclose(f);
        CHECK_OK(dtx_pc2_begin(&w, path, 2, 2, 0.0f, 1.0f, &err), &err);
        CHECK_OK(dtx_pc2_write_sample(&w, X, &err), &err);
        dtx_pc2_abort(&w);
        CHECK_EQ_INT(file_size(path), 12);
        CHECK_EQ_INT(temp_files(), 0);
        remove(path);
    }
}

/* Parses len bytes from an exactly sized heap copy; must fail with
 * DTX_EPARSE and a message containing needle. */
static void expect_parse_fail(const unsigned char *buf, size_t len, const char *needle)
{
    unsigned char *copy = malloc(len ? len : 1);
    dtx_pc2_header h;
    float *P = (float *)1;
    dtx_error err;
    dtx_status st;
    memcpy(copy, buf, len);
    st = dtx_pc2_parse("t.pc2", copy, len, &h, &P, &err);
    free(copy);
    CHECK_EQ_INT(st, DTX_EPARSE);
    CHECK(P == NULL);
    if (!strstr(err.msg, needle))
        fprintf(stderr, "parse: message \"%s\" lacks \"%s\"\n", err.msg, needle);
    CHECK(strstr(err.msg, needle) != NULL);
}

static void put32(unsigned char *p, uint32_t v)
{
    memcpy(p, &v, 4); /* the test host is little-endian, as the format */
}

static void test_parse_errors(void)
{
    const char *path = SCRATCH "/p.pc2";
    double X[6] = {0.5, 1, 2, 3, 4, 5};
    dtx_pc2_writer w;
    dtx_error err;
    unsigned char *good, *m;
    size_t len;
    float f;

    CHECK_OK(dtx_pc2_begin(&w, path, 2, 2, 0.0f, 1.0f, &err), &err);
    CHECK_OK(dtx_pc2_write_sample(&w, X, &err), &err);
    CHECK_OK(dtx_pc2_write_sample(&w, X, &err), &err);
    CHECK_OK(dtx_pc2_finish(&w, &err), &err);
    good = slurp(path, &len);
    CHECK(good != NULL && len == 32 + 48);
    if (!good)
        return;
    m = malloc(len + 4);

    for (size_t cut = 0; cut < len; cut += (cut < 40 ? 1 : 7))
        expect_parse_fail(good, cut, cut < 32 ? "shorter than the 32-byte" : "truncated");
    memcpy(m, good, len);
    memset(m + len, 0, 4);
    expect_parse_fail(m, len + 4, "trailing bytes");

    memcpy(m, good, len);
    m[0] = 'p';
    expect_parse_fail(m, len, "signature");
    memcpy(m, good, len);
    m[11] = ' '; /* the NUL is part of the signature */
    expect_parse_fail(m, len, "signature");
    memcpy(m, good, len);
    put32(m + 12, 2);
    expect_parse_fail(m, len, "version 2");
    memcpy(m, good, len);
    put32(m + 16, 0xffffffffu); /* -1 points */
    expect_parse_fail(m, len, "-1 points");
    memcpy(m, good, len);
    put32(m + 28, 0);
    expect_parse_fail(m, len, "0 samples");
    /* Counts the file cannot hold are rejected before any allocation. */
    memcpy(m, good, len);
    put32(m + 16, 0x7fffffffu);
    put32(m + 28, 0x7fffffffu);
    expect_parse_fail(m, len, "truncated");
    memcpy(m, good, len);
    f = -1.0f;
    memcpy(m + 24, &f, 4);
    expect_parse_fail(m, len, "sample rate");
    memcpy(m, good, len);
    f = INFINITY;
    memcpy(m + 20, &f, 4);
    expect_parse_fail(m, len, "start frame");

    CHECK_EQ_INT(dtx_pc2_read(SCRATCH "/missing.pc2", &(dtx_pc2_header){0}, &(float *){NULL}, &err),
                 DTX_EIO);
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
