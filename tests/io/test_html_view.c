/* test_html_view.c: the page writer of `dtx view`: base64 and SHA-256
 * against published test vectors, text from files made safe inside a
 * <script> element, the page's Content-Security-Policy naming the SHA-256 of
 * the one script it has, and bad pages refused with nothing written. */
#include "check.h"
#include "html_view.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define SCRATCH DTX_TEST_SCRATCH

static void test_base64(void)
{
    /* RFC 4648, section 10. */
    static const char *in[] = {"", "f", "fo", "foo", "foob", "fooba", "foobar"};
    static const char *out[] = {"", "Zg==", "Zm8=", "Zm9v", "Zm9vYg==", "Zm9vYmE=", "Zm9vYmFy"};
    char buf[16];
    for (int i = 0; i < 7; i++) {
        size_t n = dtx_base64(in[i], strlen(in[i]), buf);
        CHECK_EQ_INT((int)n, (int)strlen(out[i]));
        CHECK(strcmp(buf, out[i]) == 0);
    }
}

static void hex(const unsigned char *d, char *out)
{
    for (int i = 0; i < 32; i++)
        sprintf(out + 2 * i, "%02x", d[i]);
}

static void test_sha256(void)
{
    /* FIPS 180-2 examples, and lengths around the padding boundary. */
    unsigned char d[32];
    char h[65];
    char *million = malloc(1000000);
    dtx_sha256("abc", 3, d);
    hex(d, h);
    CHECK(strcmp(h, "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad") == 0);
    dtx_sha256("", 0, d);
    hex(d, h);
    CHECK(strcmp(h, "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855") == 0);
    dtx_sha256("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq", 56, d);
    hex(d, h);
    CHECK(strcmp(h, "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1") == 0);
    memset(million, 'a', 1000000);
    dtx_sha256(million, 1000000, d);
    hex(d, h);
    CHECK(strcmp(h, "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0") == 0);
    free(million);
}

static void test_json(void)
{
    struct {
        const char *in, *out;
    } c[] = {
        {"cat", "\"cat\""},
        {"</script><script>alert(1)</script>",
         "\"\\u003c/script\\u003e\\u003cscript\\u003ealert(1)\\u003c/script\\u003e\""},
        {"a\"b\\c&d", "\"a\\\"b\\\\c\\u0026d\""},
        {"line\nbreak\t", "\"line\\u000abreak\\u0009\""},
        {"\xc3\xa9t\xc3\xa9", "\"\xc3\xa9t\xc3\xa9\""},   /* UTF-8 kept */
        {"bad\xff\xc3", "\"bad\\ufffd\\ufffd\""},          /* invalid bytes replaced */
        {"\xed\xa0\x80", "\"\\ufffd\\ufffd\\ufffd\""},     /* a surrogate is not UTF-8 */
    };
    for (size_t i = 0; i < sizeof c / sizeof c[0]; i++) {
        char *j = dtx_json_html_string(c[i].in);
        CHECK(j && strcmp(j, c[i].out) == 0);
        if (j && strcmp(j, c[i].out) != 0)
            fprintf(stderr, "  %s -> %s, want %s\n", c[i].in, j, c[i].out);
        free(j);
    }
}

/* A tetrahedron pane with two frames. */
static double V[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
static int32_t F[] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
static double frames[24];
static int64_t frame_no[2] = {0, 5};
static double residual[2] = {0.5, NAN};

static char *slurp(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    char *b;
    long len;
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    len = ftell(f);
    fseek(f, 0, SEEK_SET);
    b = malloc((size_t)len + 1);
    *n = fread(b, 1, (size_t)len, f);
    b[*n] = 0;
    fclose(f);
    return b;
}

static void test_page(void)
{
    dtx_mesh m = {4, 4, V, F};
    dtx_view_pane p = {"</script>\"<b>", "result", "method sp04", "g", &m, 2, frame_no,
                       frames, residual, 2};
    int32_t src[1] = {1}, tgt[1] = {3};
    char *labels[1] = {"</script><script>alert(1)</script>"};
    dtx_markers mk = {1, src, tgt, labels};
    dtx_view_page pg;
    dtx_error err;
    char path[512], *page, *csp, *mod, *end, want[64];
    unsigned char d[32];
    size_t n;
    for (int i = 0; i < 24; i++)
        frames[i] = V[i % 12] + (i >= 12 ? 0.25 : 0);
    memset(&pg, 0, sizeof pg);
    pg.file = "t<&>.h5";
    pg.panes = &p;
    pg.npanes = 1;
    pg.file_frames = 6;
    pg.stride = 5;
    pg.max_frames = 2;
    pg.markers = &mk;
    pg.markers_name = "/markers/<m>";
    snprintf(path, sizeof path, "%s/page.html", SCRATCH);
    unlink(path);
    if (!dtx_view_available()) {
        CHECK_EQ_INT(dtx_view_write(path, &pg, &err), DTX_EINVAL);
        CHECK(strstr(err.msg, "without three.js") != NULL);
        CHECK(access(path, F_OK) != 0);
        return;
    }
    CHECK_OK(dtx_view_write(path, &pg, &err), &err);
    page = slurp(path, &n);
    CHECK(page != NULL);
    if (!page)
        return;
    /* The CSP names the SHA-256 of the module script, the only executable
     * one, and allows no network. */
    csp = strstr(page, "script-src 'sha256-");
    mod = strstr(page, "<script type=\"module\">");
    CHECK(csp && mod && strstr(page, "default-src 'none'") && strstr(page, "connect-src 'none'"));
    if (csp) { /* script-src has the hash alone: no 'unsafe-inline' */
        const char *semi = strchr(csp, ';');
        const char *u = strstr(csp, "unsafe");
        CHECK(semi && (!u || u > semi));
    }
    if (csp && mod) {
        mod += strlen("<script type=\"module\">");
        end = strstr(mod, "</script>");
        CHECK(end != NULL);
        dtx_sha256(mod, (size_t)(end - mod), d);
        dtx_base64(d, 32, want);
        CHECK(strncmp(csp + strlen("script-src 'sha256-"), want, strlen(want)) == 0);
    }
    /* The only "</script" are the page's own: each script element closes
     * once, so no text from the data ended one early. */
    {
        int opens = 0, closes = 0;
        for (char *q = page; (q = strstr(q, "<script")) != NULL; q++)
            opens++;
        for (char *q = page; (q = strstr(q, "</script")) != NULL; q++)
            closes++;
        CHECK_EQ_INT(opens, closes);
        CHECK_EQ_INT(opens, 1 + 1 + 3); /* data, module, faces/rest/frames */
    }
    CHECK(strstr(page, "\\u003c/script\\u003e\\u003cscript\\u003ealert(1)") != NULL);
    CHECK(strstr(page, "\"residual\":[0.5,null]") != NULL);
    CHECK(strstr(page, "\"frame\":[0,5]") != NULL);
    free(page);

    /* Bad pages: refused, nothing written. */
    unlink(path);
    tgt[0] = 4; /* out of range of 4 vertices */
    CHECK_EQ_INT(dtx_view_write(path, &pg, &err), DTX_ERANGE);
    CHECK(strstr(err.msg, "marker 0: vertex 4 is out of range") != NULL);
    tgt[0] = 3;
    frames[13] = NAN;
    CHECK_EQ_INT(dtx_view_write(path, &pg, &err), DTX_ENONFINITE);
    CHECK(strstr(err.msg, "frame 5, vertex 0 is not finite") != NULL);
    frames[13] = 0;
    {
        int32_t kv[1] = {9};
        pg.keypoints = kv;
        pg.nkeypoints = 1;
        pg.keypoints_name = "/keypoints/k";
        p.kind = "sequence"; /* key points are drawn on sequences */
        CHECK_EQ_INT(dtx_view_write(path, &pg, &err), DTX_ERANGE);
        CHECK(strstr(err.msg, "/keypoints/k: key point 0: vertex 9 is out of range") != NULL);
        p.kind = "result"; /* not drawn on results: not checked against them */
        CHECK_OK(dtx_view_write(path, &pg, &err), &err);
        unlink(path);
        pg.keypoints = NULL;
        pg.nkeypoints = 0;
    }
    pg.pick = 1;
    CHECK_EQ_INT(dtx_view_write(path, &pg, &err), DTX_EINVAL);
    CHECK(strstr(err.msg, "picking needs 2 panes") != NULL);
    CHECK(access(path, F_OK) != 0);
}

int main(void)
{
    test_base64();
    test_sha256();
    test_json();
    test_page();
    return check_report();
}
