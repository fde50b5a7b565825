/* test_markers_csv.c: the marker CSV reader (bases, header, comments,
 * labels, and every class of bad input). */
#include "check.h"
#include "meshfile.h"

#include <dirent.h>
#include <stdint.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#define SCRATCH DTX_TEST_SCRATCH
#define DATA_DIR "/work/shared/data"

/* Parses len bytes from an exactly sized heap copy (no NUL after it). */
static dtx_status parse_n(const char *s, size_t len, int base, dtx_markers *m, dtx_error *err)
{
    char *copy = malloc(len ? len : 1);
    dtx_status st;
    memcpy(copy, s, len);
    err->msg[0] = '\0';
    st = dtx_markers_parse_csv("m.csv", copy, len, base, m, err);
    free(copy);
    return st;
}

static dtx_status parse(const char *s, int base, dtx_markers *m, dtx_error *err)
{
    return parse_n(s, strlen(s), base, m, err);
}

static void expect_fail(const char *s, int base, dtx_status code, const char *needle)
{
    dtx_markers m;
    dtx_error err;
    dtx_status st = parse(s, base, &m, &err);
    CHECK_EQ_INT(st, code);
    CHECK(strstr(err.msg, needle) != NULL);
    if (st != code || !strstr(err.msg, needle))
        fprintf(stderr, "  input: %s\n  message: %s\n  expected to contain: %s\n", s, err.msg,
                needle);
    CHECK(m.n == 0 && m.src == NULL && m.tgt == NULL && m.labels == NULL);
    dtx_markers_free(&m);
}

static void test_base0_header(void)
{
    const char *s = "source_vertex,target_vertex,label\n"
                    "2653,1316,left front paw left side\n"
                    "0,0,\n"
                    "7,9\n";
    dtx_markers m;
    dtx_error err;
    CHECK_OK(parse(s, 0, &m, &err), &err);
    CHECK_EQ_INT(m.n, 3);
    if (m.n == 3) {
        CHECK_EQ_INT(m.src[0], 2653);
        CHECK_EQ_INT(m.tgt[0], 1316);
        CHECK(strcmp(m.labels[0], "left front paw left side") == 0);
        CHECK_EQ_INT(m.src[1], 0);
        CHECK_EQ_INT(m.tgt[1], 0);
        CHECK(strcmp(m.labels[1], "") == 0);
        CHECK_EQ_INT(m.src[2], 7);
        CHECK_EQ_INT(m.tgt[2], 9);
        CHECK(m.labels[2] && strcmp(m.labels[2], "") == 0);
    }
    dtx_markers_free(&m);
    CHECK(m.n == 0 && m.src == NULL);
}

static void test_base1_and_format(void)
{
    const char *s = "\xEF\xBB\xBF# markers, 1-based\r\n"
                    "\r\n"
                    "  1 , 2 ,  nose tip  \r\n"
                    "# between\r\n"
                    "10,20,\"ear, left \"\"outer\"\"\"\r\n"
                    "3,4,a,b"; /* no final newline; the label keeps its comma */
    dtx_markers m;
    dtx_error err;
    CHECK_OK(parse(s, 1, &m, &err), &err);
    CHECK_EQ_INT(m.n, 3);
    if (m.n == 3) {
        CHECK_EQ_INT(m.src[0], 0);
        CHECK_EQ_INT(m.tgt[0], 1);
        CHECK(strcmp(m.labels[0], "nose tip") == 0);
        CHECK_EQ_INT(m.src[1], 9);
        CHECK_EQ_INT(m.tgt[1], 19);
        CHECK(strcmp(m.labels[1], "ear, left \"outer\"") == 0);
        CHECK_EQ_INT(m.src[2], 2);
        CHECK_EQ_INT(m.tgt[2], 3);
        CHECK(strcmp(m.labels[2], "a,b") == 0);
    }
    dtx_markers_free(&m);
}

static void test_base_directive(void)
{
    const char *s1 = "# index_base: 1\nsrc,tgt\n1,1\n5,6\n";
    const char *s0 = "a,b,c\n# index_base = 0\n0,1\n";
    dtx_markers m;
    dtx_error err;

    /* from the file */
    CHECK_OK(parse(s1, -1, &m, &err), &err);
    CHECK_EQ_INT(m.n, 2);
    if (m.n == 2) {
        CHECK_EQ_INT(m.src[0], 0);
        CHECK_EQ_INT(m.tgt[1], 5);
    }
    dtx_markers_free(&m);
    CHECK_OK(parse(s0, -1, &m, &err), &err);
    CHECK_EQ_INT(m.n, 1);
    if (m.n == 1)
        CHECK_EQ_INT(m.tgt[0], 1);
    dtx_markers_free(&m);
    /* agreeing with the argument */
    CHECK_OK(parse(s1, 1, &m, &err), &err);
    dtx_markers_free(&m);
    /* disagreeing, or missing when needed */
    expect_fail(s1, 0, DTX_EINVAL, "m.csv:1: the file says index_base 1");
    expect_fail(s0, 1, DTX_EINVAL, "m.csv:2: the file says index_base 0");
    expect_fail("1,2\n", -1, DTX_EINVAL, "index base unknown");
    expect_fail("# index_base: 1\n# index_base: 0\n1,2\n", -1, DTX_EPARSE,
                "m.csv:2: index_base 0 contradicts index_base 1 at line 1");
    expect_fail("# index_base: 2\n1,2\n", -1, DTX_EPARSE, "m.csv:1: index_base must be 0 or 1");
    expect_fail("# index_base\n1,2\n", 0, DTX_EPARSE, "m.csv:1: index_base must be 0 or 1");
    expect_fail("1,2\n", 2, DTX_EINVAL, "index_base must be 0, 1 or -1");
    /* an ordinary comment mentioning other things is fine */
    CHECK_OK(parse("# index of markers\n1,2\n", 0, &m, &err), &err);
    dtx_markers_free(&m);
}

static void test_bad(void)
{
    char *big;
    expect_fail("# index_base: 1\n1,2\n0,3\n", -1, DTX_ERANGE,
                "m.csv:3: source vertex index 0 in a 1-based file");
    expect_fail("1,2\n3,0,x\n", 1, DTX_ERANGE, "m.csv:2: target vertex index 0 in a 1-based file");
    expect_fail("1,-2\n", 0, DTX_ERANGE, "m.csv:1: target vertex index -2 in a 0-based file");
    expect_fail("1,2\nx,5\n", 0, DTX_EPARSE, "m.csv:2: source vertex 'x' is not an integer");
    expect_fail("1,2\n5,y\n", 0, DTX_EPARSE, "m.csv:2: target vertex 'y' is not an integer");
    expect_fail("h1,h2\n5,1.5\n", 0, DTX_EPARSE, "m.csv:2: target vertex '1.5' is not an integer");
    expect_fail("1,2\nsource,target\n", 0, DTX_EPARSE, "m.csv:2: source vertex 'source'");
    expect_fail("h\nh2\n", 0, DTX_EPARSE, "m.csv:2: source vertex 'h2'");
    expect_fail("1,2\n5\n", 0, DTX_EPARSE, "m.csv:2: missing target vertex");
    expect_fail("1,2\n5,\n", 0, DTX_EPARSE, "m.csv:2: target vertex '' is not an integer");
    expect_fail("1,2\n,5\n", 0, DTX_EPARSE, "m.csv:2: source vertex '' is not an integer");
    expect_fail("1,3000000000\n", 0, DTX_ERANGE,
                "m.csv:1: target vertex index 3000000000 too "
                "large");
    expect_fail("99999999999999999999999,1\n", 0, DTX_ERANGE, "m.csv:1: source vertex index");
    expect_fail("", 0, DTX_EPARSE, "no markers");
    expect_fail("source_vertex,target_vertex,label\n# nothing\n\n", 0, DTX_EPARSE, "no markers");
    {
        const char s[] = "1,2\n3,\0004\n";
        dtx_markers m;
        dtx_error err;
        CHECK_EQ_INT(parse_n(s, sizeof s - 1, 0, &m, &err), DTX_EPARSE);
        CHECK(strstr(err.msg, "not a text file") != NULL);
    }
    big = malloc(DTX_MESHFILE_MAX_LINE + 100);
    strcpy(big, "1,2\n3,4,");
    memset(big + 8, 'L', DTX_MESHFILE_MAX_LINE);
    strcpy(big + 8 + DTX_MESHFILE_MAX_LINE, "\n");
    expect_fail(big, 0, DTX_EPARSE, "m.csv:2: line too long");
    free(big);
}

static void test_truncation(void)
{
    const char *s = "# index_base: 1\r\nsrc,tgt,label\r\n12,7,nose\r\n3,\"4\",x\r\n5,6\r\n";
    size_t len = strlen(s);
    int bad = 0, nok = 0;
    for (size_t cut = 0; cut <= len; cut++) {
        dtx_markers m;
        dtx_error err;
        if (parse_n(s, cut, -1, &m, &err) == DTX_OK) {
            nok++;
            for (int32_t i = 0; i < m.n; i++)
                bad += m.src[i] < 0 || m.tgt[i] < 0 || !m.labels[i];
        } else {
            bad += err.msg[0] == '\0' || m.src != NULL;
        }
        dtx_markers_free(&m);
    }
    CHECK_EQ_INT(bad, 0);
    CHECK(nok > 0);
    {
        dtx_markers m;
        dtx_error err;
        CHECK_OK(parse_n(s, len, -1, &m, &err), &err);
        CHECK_EQ_INT(m.n, 3);
        if (m.n == 3) {
            CHECK_EQ_INT(m.src[1], 2); /* quoted "4" is allowed */
            CHECK_EQ_INT(m.tgt[1], 3);
            CHECK(strcmp(m.labels[2], "") == 0);
        }
        dtx_markers_free(&m);
    }
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

static void test_files(void)
{
    const char *path = SCRATCH "/m.csv";
    const char *dir = cat_lion_dir();
    char real[1024];
    FILE *f = fopen(path, "wb");
    dtx_markers m;
    dtx_error err;
    if (f) {
        fputs("# index_base: 0\n0,1,a\n2,3,b\n", f);
        fclose(f);
    }
    CHECK_OK(dtx_markers_read_csv(path, -1, &m, &err), &err);
    CHECK_EQ_INT(m.n, 2);
    dtx_markers_free(&m);
    CHECK_EQ_INT(dtx_markers_read_csv(SCRATCH "/absent.csv", 0, &m, &err), DTX_EIO);
    CHECK(strstr(err.msg, "absent.csv") != NULL);

    if (!dir) {
        printf("note: no sumner-cat-lion data folder, real-data checks skipped\n");
        return;
    }
    snprintf(real, sizeof real, "%s/markers.csv", dir);
    CHECK_OK(dtx_markers_read_csv(real, 0, &m, &err), &err);
    CHECK_EQ_INT(m.n, 55);
    if (m.n == 55) {
        CHECK_EQ_INT(m.src[0], 2653);
        CHECK_EQ_INT(m.tgt[0], 1316);
        CHECK(strcmp(m.labels[0], "left front paw left side") == 0);
    }
    CHECK_OK(dtx_markers_validate(&m, 7207, 5000, real, &err), &err);
    dtx_markers_free(&m);
    /* the data's README says 0-based and the file does not: -1 must refuse */
    CHECK_EQ_INT(dtx_markers_read_csv(real, -1, &m, &err), DTX_EINVAL);
}

/* Every seed file under tests/io/corpus/csv/: good_* must read, bad_* must
 * fail with a message naming the file.  Files without an index_base line
 * are read as 0-based. */
static void test_corpus(void)
{
    char dir[1024], path[2048];
    DIR *d;
    struct dirent *de;
    int seen = 0;
    snprintf(dir, sizeof dir, "%s/tests/io/corpus/csv", DTX_SRC);
    d = opendir(dir);
    CHECK(d != NULL);
    if (!d)
        return;
    while ((de = readdir(d))) {
        dtx_markers m;
        dtx_error err;
        dtx_status st;
        int good = strncmp(de->d_name, "good_", 5) == 0;
        if (!good && strncmp(de->d_name, "bad_", 4) != 0)
            continue;
        snprintf(path, sizeof path, "%s/%s", dir, de->d_name);
        st = dtx_markers_read_csv(path, -1, &m, &err);
        if (st == DTX_EINVAL && strstr(err.msg, "index base unknown"))
            st = dtx_markers_read_csv(path, 0, &m, &err);
        seen++;
        if (good) {
            CHECK_OK(st, &err);
            CHECK(st != DTX_OK || m.n >= 1);
        } else {
            CHECK(st != DTX_OK && strstr(err.msg, de->d_name) != NULL);
            if (st == DTX_OK)
                fprintf(stderr, "  %s was accepted\n", path);
        }
        dtx_markers_free(&m);
    }
    closedir(d);
    CHECK(seen >= 4);
}

/* The bad-input rows the tests above do not cover.  Binary garbage fails
 * cleanly.  Out-of-range and repeated vertices are, as documented, left to
 * dtx_markers_validate (the reader knows no mesh): the reader accepts them
 * and the check rejects them naming the file. */
static void test_bad_input_rows(void)
{
    dtx_markers m;
    dtx_error err;
    char g[2048];
    uint32_t x = 5;
    for (size_t i = 0; i < sizeof g; i++) {
        x = x * 1664525u + 1013904223u;
        g[i] = (char)((x >> 24) | 1); /* no NUL: the parser reads it all */
    }
    for (int base = -1; base <= 1; base++) {
        CHECK(parse_n(g, sizeof g, base, &m, &err) != DTX_OK);
        CHECK(strncmp(err.msg, "m.csv", 5) == 0);
        CHECK(m.src == NULL);
        dtx_markers_free(&m);
    }
    g[100] = '\0';
    CHECK_EQ_INT(parse_n(g, sizeof g, 0, &m, &err), DTX_EPARSE);
    CHECK(strstr(err.msg, "m.csv: not a text file") != NULL);

    /* the wrong base: index 0 in a 1-based file (above) and a -1 */
    expect_fail("# index_base: 0\n-1,2\n", -1, DTX_ERANGE,
                "m.csv:2: source vertex index -1 in a 0-based file");
    expect_fail("# index_base: 1\n1,2\n", 0, DTX_EINVAL, "the file says index_base 1");

    /* out of range and repeated: read, then rejected by the check */
    CHECK_OK(parse("# index_base: 1\n1,1\n9,2\n", -1, &m, &err), &err);
    CHECK_EQ_INT(m.n, 2);
    CHECK_EQ_INT(dtx_markers_validate(&m, 5, 5, "m.csv", &err), DTX_ERANGE);
    CHECK(strncmp(err.msg, "m.csv: ", 7) == 0 && strstr(err.msg, "out of range") != NULL);
    dtx_markers_free(&m);
    CHECK_OK(parse("1,1,a\n2,3,b\n1,4,c\n", 0, &m, &err), &err);
    CHECK_EQ_INT(m.n, 3);
    CHECK_EQ_INT(dtx_markers_validate(&m, 5, 5, "m.csv", &err), DTX_EINVAL);
    CHECK(strncmp(err.msg, "m.csv: ", 7) == 0 && strstr(err.msg, "two markers") != NULL);
    dtx_markers_free(&m);
}

/* Lone CR, LF and CRLF line ends (the index_base line included), long
 * comment lines, and a FIFO refused before reading. */
static void test_line_ends_and_special_files(void)
{
    const char *texts[3] = {"# index_base: 1\rsrc,tgt\r12,7,nose\r3,4\r",
                            "# index_base: 1\nsrc,tgt\n12,7,nose\n3,4\n",
                            "# index_base: 1\r\nsrc,tgt\r\n12,7,nose\r3,4"};
    dtx_markers m;
    dtx_error err;
    char fifo[512];
    for (int i = 0; i < 3; i++) {
        CHECK_OK(parse(texts[i], -1, &m, &err), &err);
        CHECK_EQ_INT(m.n, 2);
        if (m.n == 2) {
            CHECK_EQ_INT(m.src[0], 11);
            CHECK_EQ_INT(m.tgt[1], 3);
            CHECK(strcmp(m.labels[0], "nose") == 0);
        }
        dtx_markers_free(&m);
    }
    expect_fail("# index_base: 0\r1,2\r3,x\r", -1, DTX_EPARSE,
                "m.csv:3: target vertex 'x' is not an integer");
    {
        char *big = malloc(DTX_MESHFILE_MAX_LINE + 100);
        strcpy(big, "1,2\n# ");
        memset(big + 6, 'c', DTX_MESHFILE_MAX_LINE);
        strcpy(big + 6 + DTX_MESHFILE_MAX_LINE, "\n3,4\n");
        CHECK_OK(parse(big, 0, &m, &err), &err);
        CHECK_EQ_INT(m.n, 2);
        dtx_markers_free(&m);
        free(big);
    }
    snprintf(fifo, sizeof fifo, "%s/fifo.csv", SCRATCH);
    unlink(fifo);
    CHECK(mkfifo(fifo, 0600) == 0);
    {
        pid_t pid;
        int ws = 0;
        fflush(NULL);
        pid = fork();
        if (pid == 0) {
            char want[600];
            dtx_status st;
            alarm(20); /* a regression (a blocking open) fails instead of hanging */
            st = dtx_markers_read_csv(fifo, 0, &m, &err);
            snprintf(want, sizeof want, "%s: not a regular file (a FIFO)", fifo);
            _exit(st == DTX_EIO && strstr(err.msg, want) == err.msg ? 0 : 1);
        }
        CHECK(pid > 0 && waitpid(pid, &ws, 0) == pid);
        CHECK(WIFEXITED(ws) && WEXITSTATUS(ws) == 0);
    }
    unlink(fifo);
}

int main(void)
{
    test_base0_header();
    test_base1_and_format();
    test_base_directive();
    test_bad();
    test_truncation();
    test_bad_input_rows();
    test_files();
    test_corpus();
    test_line_ends_and_special_files();
    return check_report();
}
