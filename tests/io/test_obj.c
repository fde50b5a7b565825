/* test_obj.c: the OBJ reader (good, malformed, truncated and mutated input),
 * the OBJ writer (round trip, atomicity) and dtx_mesh_read's dispatch. */
#include "check.h"
#include "meshfile.h"

#include <dirent.h>
#include <errno.h>
#include <signal.h>
#include <stdint.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

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

/* Parses the first len bytes of s from an exactly sized heap copy (no NUL
 * after it), so that reading past the end shows up under valgrind/ASan. */
static dtx_status parse_n(const char *s, size_t len, dtx_mesh *m, warn_log *wl, dtx_error *err)
{
    dtx_warner w = {collect, wl};
    char *copy = malloc(len ? len : 1);
    dtx_status st;
    if (wl)
        memset(wl, 0, sizeof *wl);
    memcpy(copy, s, len);
    err->msg[0] = '\0';
    st = dtx_obj_parse("t.obj", copy, len, m, wl ? &w : NULL, err);
    free(copy);
    return st;
}

static dtx_status parse(const char *s, dtx_mesh *m, warn_log *wl, dtx_error *err)
{
    return parse_n(s, strlen(s), m, wl, err);
}

/* A parse that must fail with `code` and a message containing `needle`;
 * the output must be left empty. */
static void expect_fail(const char *s, dtx_status code, const char *needle)
{
    dtx_mesh m;
    dtx_error err;
    dtx_status st = parse(s, &m, NULL, &err);
    CHECK_EQ_INT(st, code);
    if (st != code || !strstr(err.msg, needle))
        fprintf(stderr, "  input: %.60s...\n  message: %s\n  expected to contain: %s\n", s, err.msg,
                needle);
    CHECK(strstr(err.msg, needle) != NULL);
    CHECK(m.nv == 0 && m.nf == 0 && m.V == NULL && m.F == NULL);
    dtx_mesh_free(&m);
}

/* What any successfully parsed mesh must satisfy. */
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

static void test_basic(void)
{
    const char *s = "# a tetrahedron\n"
                    "mtllib x.mtl\n"
                    "o tet\n"
                    "v 0 0 0\n"
                    "v 1.5 0 0\n"
                    "v 0 -2.25 0\n"
                    "v 0 0 1e-3\n"
                    "vn 0 0 1\n"
                    "vt 0.5 0.5\n"
                    "g group\n"
                    "s off\n"
                    "usemtl m\n"
                    "f 1 3 2\n"
                    "f 1 2 4\n"
                    "f 1 4 3\n"
                    "f 2 3 4 # a comment after a face\n"
                    "l 1 2\n";
    dtx_mesh m;
    dtx_error err;
    warn_log wl;
    CHECK_OK(parse(s, &m, &wl, &err), &err);
    CHECK_EQ_INT(m.nv, 4);
    CHECK_EQ_INT(m.nf, 4);
    CHECK_EQ_INT(wl.count, 0);
    if (m.nv == 4 && m.nf == 4) {
        CHECK_DBL(m.V[3], ==, 1.5);
        CHECK_DBL(m.V[7], ==, -2.25);
        CHECK_DBL(m.V[11], ==, 1e-3);
        CHECK_EQ_INT(m.F[0], 0);
        CHECK_EQ_INT(m.F[1], 2);
        CHECK_EQ_INT(m.F[2], 1);
        CHECK_EQ_INT(m.F[9], 1);
        CHECK_EQ_INT(m.F[10], 2);
        CHECK_EQ_INT(m.F[11], 3);
        CHECK_OK(dtx_mesh_validate(&m, "tet", &err), &err);
    }
    dtx_mesh_free(&m);
}

static void test_vertex_forms(void)
{
    /* w, colours, w + colours: only x y z are kept */
    const char *s = "v 1 2 3 1.0\nv 4 5 6 0.1 0.2 0.3\nv 7 8 9 1 0.5 0.5 0.5\nf 1 2 3\n";
    dtx_mesh m;
    dtx_error err;
    CHECK_OK(parse(s, &m, NULL, &err), &err);
    CHECK_EQ_INT(m.nv, 3);
    if (m.nv == 3)
        for (int i = 0; i < 9; i++)
            CHECK_DBL(m.V[i], ==, i + 1);
    dtx_mesh_free(&m);
}

static void test_fan(void)
{
    const char *s = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv -1 0.5 0\n"
                    "f 1 2 3 4\n"    /* quad: 2 triangles */
                    "f 1 2 3\n"      /* triangle */
                    "f 5 1 2 3 4\n"; /* pentagon: 3 triangles */
    const int32_t want[6][3] = {{0, 1, 2}, {0, 2, 3}, {0, 1, 2}, {4, 0, 1}, {4, 1, 2}, {4, 2, 3}};
    dtx_mesh m;
    dtx_error err;
    warn_log wl;
    CHECK_OK(parse(s, &m, &wl, &err), &err);
    CHECK_EQ_INT(m.nf, 6);
    if (m.nf == 6)
        for (int f = 0; f < 6; f++)
            for (int k = 0; k < 3; k++)
                CHECK_EQ_INT(m.F[3 * f + k], want[f][k]);
    /* exactly one warning for the file, counting both polygons and naming
     * the first one's line */
    CHECK_EQ_INT(wl.count, 1);
    CHECK(strstr(wl.last, "2 polygons") != NULL);
    CHECK(strstr(wl.last, "line 6") != NULL);
    dtx_mesh_free(&m);
    /* without a warner the warnings are dropped, not a crash */
    CHECK_OK(parse(s, &m, NULL, &err), &err);
    dtx_mesh_free(&m);
}

static void test_negative_and_slashes(void)
{
    const char *s = "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
                    "f -3 -2 -1\n"
                    "v 0 0 1\n"
                    "f -4 -1 -2\n" /* relative to the 4 vertices so far */
                    "vt 0 0\nvn 0 0 1\n"
                    "f 1/1 2/1 4/1\n"
                    "f 1//1 2//1 4//1\n"
                    "f 1/1/1 3/1/1 4/-1/-1\n"
                    "f -4/1 -3//1 -1/1/1\n";
    const int32_t want[6][3] = {{0, 1, 2}, {0, 3, 2}, {0, 1, 3}, {0, 1, 3}, {0, 2, 3}, {0, 1, 3}};
    dtx_mesh m;
    dtx_error err;
    CHECK_OK(parse(s, &m, NULL, &err), &err);
    CHECK_EQ_INT(m.nv, 4);
    CHECK_EQ_INT(m.nf, 6);
    if (m.nf == 6)
        for (int f = 0; f < 6; f++)
            for (int k = 0; k < 3; k++)
                CHECK_EQ_INT(m.F[3 * f + k], want[f][k]);
    dtx_mesh_free(&m);
}

static void test_crlf_and_whitespace(void)
{
    const char *s = "\xEF\xBB\xBF# BOM and CRLF\r\n"
                    "v 0 0 0\r\n"
                    "  v\t1 0 0  \r\n"
                    "v 0 1 0\r\n"
                    "\r\n"
                    "f 1 2 3\r\n"
                    "f 3 2 1"; /* no final newline */
    dtx_mesh m;
    dtx_error err;
    CHECK_OK(parse(s, &m, NULL, &err), &err);
    CHECK_EQ_INT(m.nv, 3);
    CHECK_EQ_INT(m.nf, 2);
    if (m.nf == 2) {
        CHECK_DBL(m.V[3], ==, 1.0);
        CHECK_EQ_INT(m.F[3], 2);
        CHECK_EQ_INT(m.F[5], 0);
    }
    dtx_mesh_free(&m);
}

static void test_unknown_keyword(void)
{
    const char *s = "v 0 0 0\nv 1 0 0\nv 0 1 0\nbogus 1 2\nf 1 2 3\ncurv 1 2\n";
    dtx_mesh m;
    dtx_error err;
    warn_log wl;
    CHECK_OK(parse(s, &m, &wl, &err), &err);
    CHECK_EQ_INT(m.nf, 1);
    CHECK_EQ_INT(wl.count, 1);
    CHECK(strstr(wl.last, "t.obj:4:") != NULL);
    CHECK(strstr(wl.last, "'bogus'") != NULL);
    CHECK(strstr(wl.last, "2 such lines") != NULL);
    dtx_mesh_free(&m);
}

static void test_bad_inputs(void)
{
    const char *tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    char buf[512];

    expect_fail("", DTX_EPARSE, "empty file");
    expect_fail("# only a comment\n\n", DTX_EPARSE, "no vertices");
    expect_fail("v 0 0 0\nv 1 0 0\nv 0 1 0\n", DTX_EPARSE, "no faces");
    expect_fail("f 1 2 3\n", DTX_EPARSE, "no vertices");

    snprintf(buf, sizeof buf, "%sf 1 2\n", tri);
    expect_fail(buf, DTX_EPARSE, "t.obj:4: face with 2 vertices");
    snprintf(buf, sizeof buf, "%sf\n", tri);
    expect_fail(buf, DTX_EPARSE, "t.obj:4: face with 0 vertices");
    snprintf(buf, sizeof buf, "%sf 1 2 0\n", tri);
    expect_fail(buf, DTX_ERANGE, "t.obj:4: face index 0");
    snprintf(buf, sizeof buf, "%sf 1 2 4\n", tri);
    expect_fail(buf, DTX_ERANGE, "t.obj:4: face index 4 out of range");
    snprintf(buf, sizeof buf, "%sf 1 2 99999999999999999999999\n", tri);
    expect_fail(buf, DTX_ERANGE, "t.obj:4: face index");
    snprintf(buf, sizeof buf, "%sf -1 -2 -4\n", tri);
    expect_fail(buf, DTX_ERANGE, "t.obj:4: relative face index -4 refers before the first");
    expect_fail("v 0 0 0\nf -1 -2 -3\nv 1 0 0\nv 0 1 0\n", DTX_ERANGE, "t.obj:2: relative");
    snprintf(buf, sizeof buf, "%sf 1 2 x\n", tri);
    expect_fail(buf, DTX_EPARSE, "t.obj:4: malformed face line");
    snprintf(buf, sizeof buf, "%sf 1 2 3.0\n", tri);
    expect_fail(buf, DTX_EPARSE, "t.obj:4: malformed face line");
    snprintf(buf, sizeof buf, "%sf 1/ 2 3\n", tri);
    expect_fail(buf, DTX_EPARSE, "t.obj:4: malformed face line");
    snprintf(buf, sizeof buf, "%sf 1/1/ 2 3\n", tri);
    expect_fail(buf, DTX_EPARSE, "t.obj:4: malformed face line");
    snprintf(buf, sizeof buf, "%sf 1/1/1/1 2 3\n", tri);
    expect_fail(buf, DTX_EPARSE, "t.obj:4: malformed face line");
    snprintf(buf, sizeof buf, "%sf 1/a 2 3\n", tri);
    expect_fail(buf, DTX_EPARSE, "t.obj:4: malformed face line");

    expect_fail("v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n", DTX_EPARSE,
                "t.obj:2: malformed vertex line: expected 3 numbers");
    expect_fail("v\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", DTX_EPARSE,
                "t.obj:1: malformed vertex line: expected 3 numbers");
    expect_fail("v 0 0 0\nv 1 0 0 0 0\nv 0 1 0\nf 1 2 3\n", DTX_EPARSE,
                "t.obj:2: malformed vertex line");
    expect_fail("v 0 0 0\nv 1 0 0 0 0 0 0 0\nv 0 1 0\nf 1 2 3\n", DTX_EPARSE,
                "t.obj:2: malformed vertex line");
    expect_fail("v 0 0 0\nv 1 0 x\nv 0 1 0\nf 1 2 3\n", DTX_EPARSE,
                "t.obj:2: malformed vertex line: 'x' is not a number");
    expect_fail("v 0 0 0\nv 1 0 0.5.5\nv 0 1 0\nf 1 2 3\n", DTX_EPARSE, "t.obj:2: malformed");
    expect_fail("v 0 0 0\nv 1 0 3abc\nv 0 1 0\nf 1 2 3\n", DTX_EPARSE, "t.obj:2: malformed");
    expect_fail("v 0 0 0\nv 1 0 0,5\nv 0 1 0\nf 1 2 3\n", DTX_EPARSE, "t.obj:2: malformed");
    expect_fail("v 0 0 0\nv 1 0 0\n# x\nv 0 nan 0\nf 1 2 3\n", DTX_ENONFINITE,
                "t.obj:4: vertex 3 has a non-finite coordinate");
    expect_fail("v 0 0 0\nv 1 0 0\nv 0 1 -inf\nf 1 2 3\n", DTX_ENONFINITE,
                "t.obj:3: vertex 3 has a non-finite");
    expect_fail("v 0 0 0\nv 1e999 0 0\nv 0 1 0\nf 1 2 3\n", DTX_ENONFINITE,
                "t.obj:2: vertex 2 has a non-finite");
    /* a number too long for any real coordinate */
    {
        char *s = malloc(400);
        strcpy(s, "v 0 0 0\nv 1 0 0\nv 0 1 0.");
        memset(s + strlen(s), '1', 200);
        strcpy(s + 24 + 200, "\nf 1 2 3\n");
        expect_fail(s, DTX_EPARSE, "t.obj:3: malformed vertex line");
        free(s);
    }
}

static void test_binary_and_long_lines(void)
{
    dtx_mesh m;
    dtx_error err;
    /* NUL bytes */
    {
        const char s[] = "v 0 0 0\nv 1 0 0\nv 0 1\0 0\nf 1 2 3\n";
        CHECK_EQ_INT(parse_n(s, sizeof s - 1, &m, NULL, &err), DTX_EPARSE);
        CHECK(strstr(err.msg, "not a text file") != NULL);
        CHECK(m.V == NULL);
    }
    /* random binary garbage without NULs: must fail cleanly */
    {
        char g[4096];
        uint32_t x = 12345;
        for (size_t i = 0; i < sizeof g; i++) {
            x = x * 1664525u + 1013904223u;
            g[i] = (char)((x >> 24) | 1);
        }
        CHECK(parse_n(g, sizeof g, &m, NULL, &err) != DTX_OK);
        CHECK(err.msg[0] != '\0');
        dtx_mesh_free(&m);
    }
    /* Comment lines of any length are skipped (a long comment is valid
     * OBJ); a vertex line longer than the limit is an error naming its
     * line, and neither needs quadratic or unbounded work. */
    {
        size_t n = DTX_MESHFILE_MAX_LINE + 100;
        char *s = malloc(n + 64);
        size_t k = (size_t)sprintf(s, "v 0 0 0\nv 1 0 0\n#");
        memset(s + k, 'a', n);
        k += n;
        k += (size_t)sprintf(s + k, "\nv 0 1 0\nf 1 2 3\n");
        CHECK_OK(parse_n(s, k, &m, NULL, &err), &err);
        CHECK_EQ_INT(m.nf, 1);
        dtx_mesh_free(&m);
        k = (size_t)sprintf(s, "v 0 0 0\nv 1 0 0\nv 0 1 0");
        memset(s + k, ' ', n);
        k += n;
        k += (size_t)sprintf(s + k, "\nf 1 2 3\n");
        CHECK_EQ_INT(parse_n(s, k, &m, NULL, &err), DTX_EPARSE);
        CHECK(strstr(err.msg, "t.obj:3: vertex line too long") != NULL);
        free(s);
    }
}

/* Lone CR (classic Mac OS), LF and CRLF line ends, also mixed, give the
 * same mesh, and messages count lines the same way. */
static void test_cr_line_ends(void)
{
    const char *lf = "# c\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    const char *cr = "# c\rv 0 0 0\rv 1 0 0\rv 0 1 0\rf 1 2 3\r";
    const char *mixed = "# c\r\nv 0 0 0\rv 1 0 0\nv 0 1 0\r\rf 1 2 3";
    const char *texts[3] = {lf, cr, mixed};
    dtx_mesh m;
    dtx_error err;
    for (int i = 0; i < 3; i++) {
        CHECK_OK(parse(texts[i], &m, NULL, &err), &err);
        CHECK_EQ_INT(m.nv, 3);
        CHECK_EQ_INT(m.nf, 1);
        if (m.nv == 3)
            CHECK_DBL(m.V[3], ==, 1.0);
        dtx_mesh_free(&m);
    }
    expect_fail("v 0 0 0\rv 1 0 0\rv x 1 0\rf 1 2 3\r", DTX_EPARSE,
                "t.obj:3: malformed vertex line: 'x' is not a number");
    expect_fail("v 0 0 0\r\rv 1 0 0\r\nv 0 1 0\rf 1 2 4\r", DTX_ERANGE, "t.obj:5: ");
}

/* Reads path with dtx_mesh_read in a child process, under a 20 s alarm
 * and (outside AddressSanitizer, which reserves terabytes) a 1 GiB
 * address-space limit, so that a reader that blocks on a FIFO or reads a
 * device forever fails the test instead of hanging it or filling the
 * memory.  The read must fail with "PATH: not a regular file (KIND)". */
static void expect_not_regular(const char *path, const char *kind)
{
    pid_t pid;
    int ws = 0;
    fflush(NULL);
    pid = fork();
    if (pid == 0) {
        dtx_mesh m;
        dtx_error err;
        char want[512];
        dtx_status st;
#if !defined(__SANITIZE_ADDRESS__)
        struct rlimit rl = {(rlim_t)1 << 30, (rlim_t)1 << 30};
        setrlimit(RLIMIT_AS, &rl);
#endif
        alarm(20);
        st = dtx_mesh_read(path, &m, NULL, &err);
        snprintf(want, sizeof want, "%s: not a regular file (%s)", path, kind);
        if (st == DTX_EIO && strstr(err.msg, want) == err.msg && m.V == NULL)
            _exit(0);
        fprintf(stderr, "  %s: status %d, message: %s\n", path, (int)st, err.msg);
        _exit(1);
    }
    CHECK(pid > 0);
    if (pid > 0)
        CHECK(waitpid(pid, &ws, 0) == pid);
    CHECK(WIFEXITED(ws) && WEXITSTATUS(ws) == 0);
    if (!WIFEXITED(ws))
        fprintf(stderr, "  %s: the reader was killed by signal %d (a hang?)\n", path,
                WIFSIGNALED(ws) ? WTERMSIG(ws) : 0);
}

/* A FIFO, a device or a directory where a mesh file is expected: refused
 * before reading, for every format. */
static void test_special_files(void)
{
    const char *exts[] = {"obj", "ply", "off"};
    char p[256];
    for (int i = 0; i < 3; i++) {
        snprintf(p, sizeof p, SCRATCH "/fifo.%s", exts[i]);
        unlink(p);
        CHECK(mkfifo(p, 0600) == 0);
        expect_not_regular(p, "a FIFO");
        unlink(p);
        snprintf(p, sizeof p, SCRATCH "/zero.%s", exts[i]);
        unlink(p);
        CHECK(symlink(i == 1 ? "/dev/urandom" : "/dev/zero", p) == 0);
        expect_not_regular(p, "a character device");
        unlink(p);
        snprintf(p, sizeof p, SCRATCH "/dir.%s", exts[i]);
        rmdir(p);
        CHECK(mkdir(p, 0700) == 0);
        expect_not_regular(p, "a directory");
        rmdir(p);
    }
}

static void test_truncation(void)
{
    const char *s = "# cube-ish\r\nv 0 0 0\r\nv 1 0 0 1\r\nv 1 1 0\r\nv 0 1 -1.5e-2\r\n"
                    "vt 0 0\r\nf 1/1 2/1 3/1 4/1\r\nf -4//1 -3//1 -1//1\r\nf 2 3 4\r\n";
    size_t len = strlen(s);
    int ok = 0, failed = 0, bad = 0;
    for (size_t cut = 0; cut <= len; cut++) {
        dtx_mesh m;
        dtx_error err;
        warn_log wl;
        dtx_status st = parse_n(s, cut, &m, &wl, &err);
        if (st == DTX_OK) {
            ok++;
            if (!mesh_sane(&m))
                bad++;
        } else {
            failed++;
            if (err.msg[0] == '\0' || m.V || m.F)
                bad++;
        }
        dtx_mesh_free(&m);
    }
    CHECK_EQ_INT(bad, 0);
    CHECK(ok > 0);
    CHECK(failed > 0);
    /* the whole file is good */
    {
        dtx_mesh m;
        dtx_error err;
        CHECK_OK(parse_n(s, len, &m, NULL, &err), &err);
        CHECK_EQ_INT(m.nf, 4);
        dtx_mesh_free(&m);
    }
}

/* Byte mutations of a small file: never a crash, and a success is sane. */
static void test_mutations(void)
{
    const char *s = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nf -1 -2 -3\n";
    const char alphabet[] = "0123456789 -+./\n\r#vfe\tx";
    size_t len = strlen(s);
    char *b = malloc(len);
    uint32_t x = 7;
    int bad = 0;
    for (int iter = 0; iter < 5000; iter++) {
        dtx_mesh m;
        dtx_error err;
        memcpy(b, s, len);
        for (int k = 0; k < 1 + iter % 4; k++) {
            x = x * 1664525u + 1013904223u;
            size_t at = (x >> 8) % len;
            x = x * 1664525u + 1013904223u;
            b[at] = alphabet[(x >> 8) % (sizeof alphabet - 1)];
        }
        if (parse_n(b, len, &m, NULL, &err) == DTX_OK) {
            if (!mesh_sane(&m))
                bad++;
        } else if (err.msg[0] == '\0') {
            bad++;
        }
        dtx_mesh_free(&m);
    }
    CHECK_EQ_INT(bad, 0);
    free(b);
}

/* Inputs found by the fuzzer (tests/fuzz/fuzz_obj.c), each once a crash or
 * undefined behaviour under the sanitizers; now clean errors. */
static void test_fuzz_regressions(void)
{
    /* INT64_MIN as a relative index: "-vi > cur_v" negated INT64_MIN. */
    expect_fail("v 0 1 1\nv 0 0 0\nf -9223372036854775808 /1/3-ar\n", DTX_ERANGE,
                "t.obj:3: relative face index -9223372036854775808 refers before the first "
                "vertex (2 vertices defined so far)");
    expect_fail("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -9223372036854775808\n", DTX_ERANGE,
                "t.obj:4: relative face index -9223372036854775808");
    /* One below INT64_MIN does not parse as an int64 at all. */
    expect_fail("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -9223372036854775809\n", DTX_ERANGE,
                "t.obj:4: relative face index -9223372036854775809");
}

/* ------------------------------------------------------------------ writer */

static int file_exists(const char *p)
{
    struct stat sb;
    return stat(p, &sb) == 0;
}

/* Number of entries in dir whose name starts with prefix. */
static int count_prefixed(const char *dir, const char *prefix)
{
    DIR *d = opendir(dir);
    struct dirent *de;
    int n = 0;
    if (!d)
        return -1;
    while ((de = readdir(d)))
        if (strncmp(de->d_name, prefix, strlen(prefix)) == 0)
            n++;
    closedir(d);
    return n;
}

static char *slurp(const char *path)
{
    FILE *f = fopen(path, "rb");
    char *b;
    long n;
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    n = ftell(f);
    fseek(f, 0, SEEK_SET);
    b = malloc((size_t)n + 1);
    if (fread(b, 1, (size_t)n, f) != (size_t)n)
        n = 0;
    b[n] = '\0';
    fclose(f);
    return b;
}

static void test_write_roundtrip(void)
{
    enum { NV = 500, NF = 400 };
    const char *path = SCRATCH "/rt.obj";
    double *V = malloc(NV * 3 * sizeof *V);
    float *Vf = malloc(NV * 3 * sizeof *Vf);
    int32_t *F = malloc(NF * 3 * sizeof *F);
    uint64_t x = 99;
    dtx_mesh m;
    dtx_error err;
    int exact = 1, near = 1;

    for (int i = 0; i < 3 * NV; i++) {
        double u, e;
        x = x * 6364136223846793005ull + 1442695040888963407ull;
        u = (double)(x >> 11) / 9007199254740992.0; /* [0, 1) with 53 bits */
        x = x * 6364136223846793005ull + 1442695040888963407ull;
        e = (double)((int)((x >> 33) % 41) - 20); /* exponents -20..20 */
        V[i] = (i % 2 ? -1 : 1) * u * pow(10.0, e);
        Vf[i] = (float)V[i];
    }
    V[0] = 0.1;
    V[1] = 1.0 / 3.0;
    V[2] = -0.0;
    V[3] = 5e-300;
    V[4] = 1.7976931348623157e308;
    for (int f = 0; f < NF; f++)
        for (int k = 0; k < 3; k++)
            F[3 * f + k] = (f * 7 + k * 13) % NV;

    CHECK_OK(dtx_obj_write(path, V, NV, F, NF, "cat -> lion, frame 3\nsecond line", &err), &err);
    CHECK_EQ_INT(count_prefixed(SCRATCH, ".rt.obj"), 0); /* no temporary left */
    {
        char *txt = slurp(path);
        CHECK(txt && strncmp(txt, "# Written by dtx", 16) == 0);
        CHECK(txt && strstr(txt, "\n# cat -> lion, frame 3\n# second line\n") != NULL);
        free(txt);
    }
    CHECK_OK(dtx_obj_read(path, &m, NULL, &err), &err);
    CHECK_EQ_INT(m.nv, NV);
    CHECK_EQ_INT(m.nf, NF);
    if (m.nv == NV && m.nf == NF) {
        for (int i = 0; i < 3 * NV; i++) {
            if (m.V[i] != V[i])
                exact = 0;
            if (fabs(m.V[i] - V[i]) > 1e-12 * fabs(V[i]))
                near = 0;
        }
        CHECK(near);
        CHECK(exact); /* %.17g round-trips binary64 exactly */
        CHECK(memcmp(m.F, F, NF * 3 * sizeof *F) == 0);
    }
    dtx_mesh_free(&m);

    /* float32 frames round-trip exactly once rounded back to float */
    CHECK_OK(dtx_obj_write_f32(path, Vf, NV, F, NF, NULL, &err), &err);
    CHECK_OK(dtx_mesh_read(path, &m, NULL, &err), &err);
    exact = m.nv == NV;
    for (int i = 0; exact && i < 3 * NV; i++)
        if ((float)m.V[i] != Vf[i] || fabs(m.V[i] - Vf[i]) > 1e-7 * fabs(Vf[i]))
            exact = 0;
    CHECK(exact);
    dtx_mesh_free(&m);
    free(V);
    free(Vf);
    free(F);
}

static void test_write_failures(void)
{
    const double V[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const int32_t F[3] = {0, 1, 2};
    const int32_t Fbad[3] = {0, 1, 3};
    const double Vnan[9] = {0, 0, 0, 1, 0, 0, 0, NAN, 0};
    const char *path = SCRATCH "/keep.obj";
    dtx_error err;
    char *before, *after;

    /* a directory that does not exist */
    CHECK_EQ_INT(dtx_obj_write(SCRATCH "/no/such/dir/x.obj", V, 3, F, 1, NULL, &err), DTX_EIO);
    CHECK(strstr(err.msg, "no/such/dir/x.obj") != NULL);
    CHECK(!file_exists(SCRATCH "/no/such/dir/x.obj"));

    /* bad data is refused before anything is written, and an existing file
     * at the path stays as it was */
    CHECK_OK(dtx_obj_write(path, V, 3, F, 1, "original", &err), &err);
    before = slurp(path);
    CHECK_EQ_INT(dtx_obj_write(path, V, 3, Fbad, 1, NULL, &err), DTX_ERANGE);
    CHECK(strstr(err.msg, "face 0") != NULL);
    CHECK_EQ_INT(dtx_obj_write(path, Vnan, 3, F, 1, NULL, &err), DTX_ENONFINITE);
    CHECK(strstr(err.msg, "vertex 2") != NULL);
    CHECK_EQ_INT(dtx_obj_write(SCRATCH "/never.obj", Vnan, 3, F, 1, NULL, &err), DTX_ENONFINITE);
    CHECK(!file_exists(SCRATCH "/never.obj"));
    after = slurp(path);
    CHECK(before && after && strcmp(before, after) == 0);
    free(before);
    free(after);

    /* a directory that is not writable (meaningless as root, who may write
     * anywhere) */
    if (geteuid() != 0) {
        const char *ro = SCRATCH "/readonly";
        mkdir(ro, 0755);
        chmod(ro, 0555);
        CHECK_EQ_INT(dtx_obj_write(SCRATCH "/readonly/x.obj", V, 3, F, 1, NULL, &err), DTX_EIO);
        CHECK(!file_exists(SCRATCH "/readonly/x.obj"));
        CHECK_EQ_INT(count_prefixed(ro, "."), 2); /* only . and .. */
        chmod(ro, 0755);
    } else {
        printf("note: running as root, the read-only directory case is skipped\n");
    }

    /* a write that fails half-way (the file size limit is hit): no partial
     * file and no temporary file are left */
    {
        struct rlimit old, lim;
        enum { NV = 20000 };
        double *big = calloc(NV * 3, sizeof *big);
        dtx_status st;
        for (int i = 0; i < NV * 3; i++)
            big[i] = 1.0 / (i + 3);
        signal(SIGXFSZ, SIG_IGN);
        getrlimit(RLIMIT_FSIZE, &old);
        lim = old;
        lim.rlim_cur = 50000;
        if (setrlimit(RLIMIT_FSIZE, &lim) == 0) {
            st = dtx_obj_write(SCRATCH "/big.obj", big, NV, F, 1, NULL, &err);
            setrlimit(RLIMIT_FSIZE, &old);
            CHECK_EQ_INT(st, DTX_EIO);
            CHECK(!file_exists(SCRATCH "/big.obj"));
            CHECK_EQ_INT(count_prefixed(SCRATCH, ".big.obj"), 0);
        } else {
            printf("note: cannot lower RLIMIT_FSIZE, the mid-write failure case is skipped\n");
        }
        free(big);
    }
}

static void test_dispatch(void)
{
    const double V[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const int32_t F[3] = {0, 1, 2};
    dtx_mesh m;
    dtx_error err;
    CHECK_OK(dtx_obj_write(SCRATCH "/UPPER.OBJ", V, 3, F, 1, NULL, &err), &err);
    CHECK_OK(dtx_mesh_read(SCRATCH "/UPPER.OBJ", &m, NULL, &err), &err);
    CHECK_EQ_INT(m.nf, 1);
    dtx_mesh_free(&m);
    CHECK_EQ_INT(dtx_mesh_read(SCRATCH "/x.stl", &m, NULL, &err), DTX_EINVAL);
    CHECK(strstr(err.msg, "x.stl") != NULL);
    CHECK_EQ_INT(dtx_mesh_read(SCRATCH "/missing.obj", &m, NULL, &err), DTX_EIO);
    CHECK(strstr(err.msg, "missing.obj") != NULL);
    CHECK_EQ_INT(dtx_obj_read(SCRATCH, &m, NULL, &err), DTX_EIO); /* a directory */
}

/* The cat/lion folder: the shared full copy when present, else the bundled
 * one the data.unpack fixture puts in the build tree (SCRATCH is
 * <build>/testdata/<test>); NULL when neither exists. */
static const char *cat_lion_dir(void)
{
    static const char *const dirs[] = {DATA_DIR "/sumner-cat-lion",
                                       SCRATCH "/../../data/sumner-cat-lion"};
    struct stat sb;
    for (size_t i = 0; i < sizeof dirs / sizeof dirs[0]; i++)
        if (stat(dirs[i], &sb) == 0)
            return dirs[i];
    return NULL;
}

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

static void test_real_data(void)
{
    const char *dir = cat_lion_dir();
    char cat[1024], lion[1024];
    dtx_mesh m;
    dtx_error err;
    warn_log wl;
    dtx_warner w = {collect, &wl};
    double t0, best = 1e30;
    if (!dir) {
        printf("note: no sumner-cat-lion data folder, real-data checks skipped\n");
        return;
    }
    snprintf(cat, sizeof cat, "%s/source/cat-reference.obj", dir);
    snprintf(lion, sizeof lion, "%s/target/lion-reference.obj", dir);
    for (int rep = 0; rep < 3; rep++) {
        memset(&wl, 0, sizeof wl);
        t0 = now_ms();
        CHECK_OK(dtx_obj_read(cat, &m, &w, &err), &err);
        if (now_ms() - t0 < best)
            best = now_ms() - t0;
        CHECK_EQ_INT(m.nv, 7207);
        CHECK_EQ_INT(m.nf, 14410);
        CHECK_EQ_INT(wl.count, 0);
        if (rep == 0)
            CHECK_OK(dtx_mesh_validate(&m, cat, &err), &err);
        dtx_mesh_free(&m);
    }
    printf("cat-reference.obj read in %.2f ms (best of 3)\n", best);
    CHECK_OK(dtx_mesh_read(lion, &m, NULL, &err), &err);
    CHECK_EQ_INT(m.nv, 5000);
    CHECK_EQ_INT(m.nf, 9996);
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

int main(void)
{
    test_basic();
    test_vertex_forms();
    test_fan();
    test_negative_and_slashes();
    test_crlf_and_whitespace();
    test_unknown_keyword();
    test_bad_inputs();
    test_binary_and_long_lines();
    test_cr_line_ends();
    test_special_files();
    test_truncation();
    test_mutations();
    test_fuzz_regressions();
    test_write_roundtrip();
    test_write_failures();
    test_dispatch();
    test_real_data();
    test_corpus("obj");
    return check_report();
}
