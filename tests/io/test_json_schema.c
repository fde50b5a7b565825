/* test_json_schema.c: the JSON Schema subset validator, keyword by keyword,
 * with the exact messages (JSON pointer, expectation, what was found). */
#include "check.h"
#include "json_schema.h"

#include <cjson/cJSON.h>
#include <string.h>

/* Validates doc against schema (both JSON text); msg gets the message. */
static dtx_status run(const char *schema, const char *doc, char *msg, size_t n)
{
    cJSON *s = cJSON_Parse(schema), *d = cJSON_Parse(doc);
    dtx_status st;
    if (!s || !d) {
        fprintf(stderr, "test bug: cannot parse %s\n", !s ? schema : doc);
        cJSON_Delete(s);
        cJSON_Delete(d);
        snprintf(msg, n, "test bug");
        return DTX_EINVAL;
    }
    st = dtx_json_validate(s, d, msg, n);
    cJSON_Delete(s);
    cJSON_Delete(d);
    return st;
}

static void expect_ok_(const char *schema, const char *doc, const char *file, int line)
{
    char msg[1024];
    dtx_status st = run(schema, doc, msg, sizeof msg);
    if (st == DTX_OK) {
        check_passed_++;
    } else {
        check_failed_++;
        fprintf(stderr, "%s:%d: %s against %s: expected valid, got %s: %s\n", file, line, doc,
                schema, dtx_status_name(st), msg);
    }
}

static void expect_err_(const char *schema, const char *doc, dtx_status want_st,
                        const char *want, const char *file, int line)
{
    char msg[1024];
    dtx_status st = run(schema, doc, msg, sizeof msg);
    if (st == want_st && (!want || strcmp(msg, want) == 0)) {
        check_passed_++;
    } else {
        check_failed_++;
        fprintf(stderr, "%s:%d: %s against %s:\n  expected %s: %s\n  got      %s: %s\n", file,
                line, doc, schema, dtx_status_name(want_st), want ? want : "(any)",
                dtx_status_name(st), msg);
    }
}

#define EXPECT_OK(schema, doc) expect_ok_(schema, doc, __FILE__, __LINE__)
#define EXPECT_ERR(schema, doc, want) expect_err_(schema, doc, DTX_EJOB, want, __FILE__, __LINE__)
#define EXPECT_SCHEMA_ERR(schema, doc, want)                                                      \
    expect_err_(schema, doc, DTX_EINVAL, want, __FILE__, __LINE__)

static void test_type(void)
{
    EXPECT_OK("{\"type\":\"string\"}", "\"x\"");
    EXPECT_ERR("{\"type\":\"string\"}", "5", "at the top level: expected a string, got 5");
    EXPECT_ERR("{\"properties\":{\"a\":{\"type\":\"string\"}}}", "{\"a\":2.5}",
               "at /a: expected a string, got 2.5");
    EXPECT_ERR("{\"type\":\"number\"}", "\"5\"", "at the top level: expected a number, got \"5\"");
    EXPECT_OK("{\"type\":\"number\"}", "-1.25e3");
    EXPECT_OK("{\"type\":\"integer\"}", "3");
    EXPECT_OK("{\"type\":\"integer\"}", "3.0");
    EXPECT_OK("{\"type\":\"integer\"}", "-7");
    EXPECT_ERR("{\"type\":\"integer\"}", "3.5", "at the top level: expected an integer, got 3.5");
    EXPECT_ERR("{\"type\":\"integer\"}", "true", "at the top level: expected an integer, got true");
    EXPECT_OK("{\"type\":\"boolean\"}", "false");
    EXPECT_ERR("{\"type\":\"boolean\"}", "0", "at the top level: expected a boolean, got 0");
    EXPECT_OK("{\"type\":\"null\"}", "null");
    EXPECT_ERR("{\"type\":\"object\"}", "[1]", "at the top level: expected an object, got an array");
    EXPECT_ERR("{\"type\":\"array\"}", "{}", "at the top level: expected an array, got an object");
    EXPECT_ERR("{\"type\":\"object\"}", "[]",
               "at the top level: expected an object, got an empty array");
    /* Type arrays. */
    EXPECT_OK("{\"type\":[\"string\",\"null\"]}", "null");
    EXPECT_OK("{\"type\":[\"string\",\"null\"]}", "\"a\"");
    EXPECT_ERR("{\"type\":[\"string\",\"null\"]}", "5",
               "at the top level: expected a string or null, got 5");
    EXPECT_ERR("{\"type\":[\"string\",\"integer\",\"null\"]}", "0.5",
               "at the top level: expected a string, an integer or null, got 0.5");
    /* Long strings are shortened in messages. */
    EXPECT_ERR("{\"type\":\"number\"}", "\"0123456789012345678901234567890123456789XYZ\"",
               "at the top level: expected a number, got "
               "\"0123456789012345678901234567890123456789...\"");
}

static void test_objects(void)
{
    const char *s = "{\"type\":\"object\",\"properties\":{\"file\":{\"type\":\"string\"},"
                    "\"mesh\":{\"type\":\"string\"}},\"required\":[\"file\",\"mesh\"],"
                    "\"additionalProperties\":false}";
    const char *outer = "{\"properties\":{\"source\":{\"$ref\":\"#/$defs/src\"}},"
                        "\"$defs\":{\"src\":{\"type\":\"object\",\"required\":[\"file\","
                        "\"mesh\"],\"properties\":{\"file\":{},\"mesh\":{}}}}}";
    EXPECT_OK(s, "{\"file\":\"a\",\"mesh\":\"b\"}");
    EXPECT_ERR(s, "{\"file\":\"a\"}", "at the top level: missing required key \"mesh\"");
    EXPECT_ERR(outer, "{\"source\":{\"file\":\"a\"}}", "at /source: missing required key \"mesh\"");
    EXPECT_OK(outer, "{\"source\":{\"file\":\"a\",\"mesh\":2}}");
    EXPECT_ERR(s, "{\"file\":\"a\",\"mesh\":\"b\",\"msh\":1}",
               "at the top level: unknown key \"msh\" (allowed: file, mesh)");
    /* Document order: a missing key counts as being at the closing brace,
     * so a misspelt key (which explains the missing one) comes first, and
     * so do the members' own errors. */
    EXPECT_ERR(s, "{\"file\":\"a\",\"msh\":\"b\"}",
               "at the top level: unknown key \"msh\" (allowed: file, mesh)");
    EXPECT_ERR(s, "{\"file\":1}", "at /file: expected a string, got 1");
    /* The value's own checks come before its members'. */
    EXPECT_ERR("{\"type\":\"object\",\"maxItems\":0,\"properties\":{\"a\":{\"type\":\"string\"}}}",
               "[]", "at the top level: expected an object, got an empty array");
    EXPECT_ERR("{\"minItems\":3,\"items\":{\"type\":\"string\"}}", "[1]",
               "at the top level: expected an array of at least 3 strings, got 1 item");
    /* Members in document order, not schema order. */
    EXPECT_ERR(s, "{\"mesh\":1,\"file\":2}", "at /mesh: expected a string, got 1");
    EXPECT_ERR(s, "{\"file\":2,\"mesh\":1}", "at /file: expected a string, got 2");
    /* additionalProperties as a schema. */
    EXPECT_OK("{\"additionalProperties\":{\"type\":\"number\"}}", "{\"x\":1,\"y\":2}");
    EXPECT_ERR("{\"properties\":{\"n\":{\"type\":\"string\"}},"
               "\"additionalProperties\":{\"type\":\"number\"}}",
               "{\"n\":\"s\",\"x\":1,\"y\":\"a\"}", "at /y: expected a number, got \"a\"");
    EXPECT_OK("{\"additionalProperties\":true}", "{\"x\":{\"y\":[1,2]}}");
    EXPECT_ERR("{\"additionalProperties\":false}", "{\"x\":1}",
               "at the top level: unknown key \"x\" (no keys are allowed here)");
    /* A key forbidden by a false schema. */
    EXPECT_ERR("{\"properties\":{\"csv\":false}}", "{\"csv\":\"m.csv\"}",
               "at the top level: key \"csv\" is not allowed here");
    EXPECT_ERR("false", "1", "at the top level: no value is allowed here");
    EXPECT_OK("true", "{\"anything\":[1]}");
    /* Repeated keys are errors, wherever they are. */
    EXPECT_ERR(s, "{\"file\":\"a\",\"mesh\":\"b\",\"file\":\"c\"}",
               "at the top level: duplicate key \"file\"");
    EXPECT_ERR("{\"properties\":{\"free\":true}}", "{\"free\":{\"a\":[{\"k\":1,\"k\":2}]}}",
               "at /free/a/0: duplicate key \"k\"");
    EXPECT_ERR("{}", "{\"b\":1,\"a\":1,\"b\":2,\"a\":2}", "at the top level: duplicate key \"b\"");
    /* ... found where the repetition is. */
    EXPECT_ERR(s, "{\"file\":\"a\",\"file\":\"c\",\"x\":1}",
               "at the top level: duplicate key \"file\"");
    EXPECT_ERR(s, "{\"x\":1,\"file\":\"a\",\"file\":\"c\"}",
               "at the top level: unknown key \"x\" (allowed: file, mesh)");
    /* Items named through $ref are still named in messages. */
    EXPECT_ERR("{\"$defs\":{\"t\":{\"type\":\"object\"}},\"minItems\":1,"
               "\"items\":{\"$ref\":\"#/$defs/t\"}}",
               "[]", "at the top level: expected a non-empty array of objects, got an empty array");
    /* Pointer escapes (RFC 6901). */
    EXPECT_ERR("{\"additionalProperties\":{\"type\":\"string\"}}", "{\"a/b~c\":1}",
               "at /a~1b~0c: expected a string, got 1");
}

static void test_arrays(void)
{
    const char *pos = "{\"properties\":{\"pins\":{\"items\":{\"properties\":{\"position\":{"
                      "\"type\":\"array\",\"minItems\":3,\"maxItems\":3,"
                      "\"items\":{\"type\":\"number\"}}}}}}}";
    const char *w = "{\"type\":\"array\",\"minItems\":1,\"maxItems\":16,"
                    "\"items\":{\"type\":\"number\",\"minimum\":0}}";
    EXPECT_OK(pos, "{\"pins\":[{\"position\":[1,2,3]}]}");
    EXPECT_ERR(pos, "{\"pins\":[{\"position\":[1,2,3]},{\"position\":[1,2]}]}",
               "at /pins/1/position: expected an array of 3 numbers, got 2 items");
    EXPECT_ERR(pos, "{\"pins\":[{\"position\":[1,2,3,4]}]}",
               "at /pins/0/position: expected an array of 3 numbers, got 4 items");
    EXPECT_ERR(pos, "{\"pins\":[{\"position\":[1,\"2\",3]}]}",
               "at /pins/0/position/1: expected a number, got \"2\"");
    EXPECT_OK(w, "[0]");
    EXPECT_ERR(w, "[]", "at the top level: expected an array of 1 to 16 numbers, got 0 items");
    EXPECT_ERR("{\"minItems\":1,\"items\":{\"type\":\"string\"}}", "[]",
               "at the top level: expected a non-empty array of strings, got an empty array");
    EXPECT_ERR(w, "[1,2,3,4,5,6,7,8,9,10,11,12,13,14,15,16,17]",
               "at the top level: expected an array of 1 to 16 numbers, got 17 items");
    EXPECT_ERR(w, "[1,2,-3]", "at /2: expected a number >= 0, got -3");
    EXPECT_ERR("{\"minItems\":2}", "[1]", "at the top level: expected an array of at least 2 items, "
                                          "got 1 item");
    EXPECT_ERR("{\"maxItems\":1,\"items\":{\"type\":\"string\"}}", "[\"a\",\"b\"]",
               "at the top level: expected an array of at most 1 string, got 2 items");
    /* minItems only applies to arrays. */
    EXPECT_OK("{\"minItems\":2}", "\"x\"");
    EXPECT_OK("{\"items\":{\"type\":\"string\"}}", "[]");
}

static void test_enum_const(void)
{
    const char *dtype = "{\"properties\":{\"output\":{\"properties\":{\"dtype\":"
                        "{\"enum\":[\"float32\",\"float64\"]}}}}}";
    EXPECT_OK(dtype, "{\"output\":{\"dtype\":\"float64\"}}");
    EXPECT_ERR(dtype, "{\"output\":{\"dtype\":\"float16\"}}",
               "at /output/dtype: expected one of float32, float64, got \"float16\"");
    EXPECT_ERR(dtype, "{\"output\":{\"dtype\":32}}",
               "at /output/dtype: expected one of float32, float64, got 32");
    EXPECT_OK("{\"enum\":[0,1]}", "1.0");
    EXPECT_ERR("{\"enum\":[0,1]}", "2", "at the top level: expected one of 0, 1, got 2");
    EXPECT_OK("{\"enum\":[[1,2],{\"a\":null}]}", "{\"a\":null}");
    EXPECT_ERR("{\"enum\":[[1,2],{\"a\":null}]}", "[2,1]",
               "at the top level: expected one of an array, an object, got an array");
    EXPECT_OK("{\"const\":1}", "1");
    EXPECT_ERR("{\"const\":1}", "2", "at the top level: expected 1, got 2");
    EXPECT_ERR("{\"const\":\"sp04\"}", "\"sp05\"", "at the top level: expected sp04, got \"sp05\"");
    EXPECT_ERR("{\"const\":1}", "\"1\"", "at the top level: expected 1, got \"1\"");
}

static void test_ranges(void)
{
    EXPECT_OK("{\"minimum\":0}", "0");
    EXPECT_ERR("{\"minimum\":0}", "-0.5", "at the top level: expected a number >= 0, got -0.5");
    EXPECT_OK("{\"exclusiveMinimum\":0}", "1e-300");
    EXPECT_ERR("{\"exclusiveMinimum\":0}", "0", "at the top level: expected a number > 0, got 0");
    EXPECT_OK("{\"maximum\":180}", "180");
    EXPECT_ERR("{\"maximum\":180}", "180.5", "at the top level: expected a number <= 180, got 180.5");
    EXPECT_ERR("{\"exclusiveMaximum\":1}", "1", "at the top level: expected a number < 1, got 1");
    EXPECT_OK("{\"exclusiveMinimum\":0,\"maximum\":180}", "180");
    EXPECT_ERR("{\"exclusiveMinimum\":0,\"maximum\":180}", "0",
               "at the top level: expected a number in (0, 180], got 0");
    EXPECT_ERR("{\"type\":\"integer\",\"minimum\":1,\"maximum\":65536}", "65537",
               "at the top level: expected an integer in [1, 65536], got 65537");
    EXPECT_ERR("{\"type\":\"integer\",\"minimum\":1,\"maximum\":65536}", "0",
               "at the top level: expected an integer in [1, 65536], got 0");
    /* With both kinds on one side the stricter bound decides. */
    EXPECT_ERR("{\"minimum\":0,\"exclusiveMinimum\":0}", "0",
               "at the top level: expected a number > 0, got 0");
    EXPECT_OK("{\"minimum\":5}", "\"not a number\"");
    /* Numbers beyond double range are rejected, not turned into inf. */
    EXPECT_ERR("{\"properties\":{\"a\":{\"type\":\"number\"}}}", "{\"a\":1e999}",
               "at /a: number out of range (not finite)");
    EXPECT_ERR("{}", "[1,-1e999]", "at /1: number out of range (not finite)");
}

static void test_strings(void)
{
    const char *name = "{\"properties\":{\"name\":{\"type\":\"string\","
                       "\"pattern\":\"^[A-Za-z0-9_.-]+$\"}}}";
    EXPECT_OK(name, "{\"name\":\"lion_2.v-1\"}");
    EXPECT_ERR(name, "{\"name\":\"big lion\"}",
               "at /name: expected a string matching ^[A-Za-z0-9_.-]+$, got \"big lion\"");
    EXPECT_ERR(name, "{\"name\":\"\"}",
               "at /name: expected a string matching ^[A-Za-z0-9_.-]+$, got \"\"");
    /* Patterns are not anchored unless they say so (as in ECMA 262). */
    EXPECT_OK("{\"pattern\":\"b+\"}", "\"abbc\"");
    EXPECT_ERR("{\"pattern\":\"^b\"}", "\"abc\"",
               "at the top level: expected a string matching ^b, got \"abc\"");
    EXPECT_OK("{\"minLength\":1}", "\"x\"");
    EXPECT_ERR("{\"minLength\":1}", "\"\"", "at the top level: expected a non-empty string, got \"\"");
    EXPECT_ERR("{\"maxLength\":2}", "\"abc\"",
               "at the top level: expected a string of at most 2 bytes, got \"abc\"");
    /* Control characters are escaped in messages. */
    EXPECT_ERR("{\"type\":\"number\"}", "\"a\\nb\"",
               "at the top level: expected a number, got \"a\\u000ab\"");
}

static void test_combinators(void)
{
    const char *markers =
        "{\"type\":\"object\",\"properties\":{\"csv\":{\"type\":\"string\"},"
        "\"index_base\":{\"enum\":[0,1]},\"file\":{\"type\":\"string\"},"
        "\"path\":{\"type\":\"string\"}},\"additionalProperties\":false,\"oneOf\":["
        "{\"title\":\"CSV markers\",\"required\":[\"csv\",\"index_base\"],"
        "\"properties\":{\"file\":false,\"path\":false}},"
        "{\"title\":\"HDF5 markers\",\"required\":[\"file\",\"path\"],"
        "\"properties\":{\"csv\":false,\"index_base\":false}}]}";
    const char *untitled = "{\"oneOf\":[{\"type\":\"string\"},{\"type\":\"array\"}]}";
    const char *both = "{\"oneOf\":[{\"type\":\"number\"},{\"type\":\"integer\"}]}";
    const char *any = "{\"anyOf\":[{\"type\":\"number\"},{\"type\":\"integer\"}]}";

    EXPECT_OK(markers, "{\"csv\":\"m.csv\",\"index_base\":1}");
    EXPECT_OK(markers, "{\"file\":\"m.h5\",\"path\":\"/markers/x\"}");
    EXPECT_ERR(markers, "{\"csv\":\"m.csv\",\"idx_base\":0}",
               "at the top level: unknown key \"idx_base\" (allowed: csv, index_base, file, path)");
    /* The branch that fits best is reported, named by its title. */
    EXPECT_ERR(markers, "{\"csv\":\"m.csv\"}",
               "at the top level: missing required key \"index_base\" (for CSV markers)");
    EXPECT_ERR(markers, "{\"path\":\"/m\"}",
               "at the top level: missing required key \"file\" (for HDF5 markers)");
    EXPECT_ERR(markers, "{\"csv\":\"m.csv\",\"index_base\":0,\"file\":\"m.h5\"}",
               "at the top level: key \"file\" is not allowed here (for CSV markers)");
    /* Member errors are found before the oneOf. */
    EXPECT_ERR(markers, "{\"csv\":\"m.csv\",\"index_base\":2}",
               "at /index_base: expected one of 0, 1, got 2");
    /* No branch fits better than another: all are listed. */
    EXPECT_ERR(markers, "{}",
               "at the top level: matches none of the allowed forms: CSV markers (missing "
               "required key \"csv\"); HDF5 markers (missing required key \"file\")");
    EXPECT_ERR(markers, "{\"csv\":\"a\",\"index_base\":0,\"file\":\"b\",\"path\":\"c\"}",
               "at the top level: matches none of the allowed forms: CSV markers (key \"file\" "
               "is not allowed here); HDF5 markers (key \"csv\" is not allowed here)");
    EXPECT_OK(untitled, "\"s\"");
    EXPECT_OK(untitled, "[]");
    EXPECT_ERR(untitled, "3",
               "at the top level: matches none of the allowed forms: form 1 (expected a string, "
               "got 3); form 2 (expected an array, got 3)");
    /* oneOf: exactly one; anyOf: at least one. */
    EXPECT_OK(both, "1.5");
    EXPECT_ERR(both, "2", "at the top level: matches more than one of the allowed forms (forms 1 "
                          "and 2)");
    EXPECT_OK(any, "2");
    EXPECT_OK(any, "1.5");
    EXPECT_ERR(any, "\"2\"",
               "at the top level: matches none of the allowed forms: form 1 (expected a number, "
               "got \"2\"); form 2 (expected an integer, got \"2\")");
    /* A deeper error marks the better branch. */
    EXPECT_ERR("{\"anyOf\":[{\"type\":\"string\"},{\"items\":{\"type\":\"string\"}}]}", "[\"a\",1]",
               "at /1: expected a string, got 1");
}

static void test_refs(void)
{
    const char *s = "{\"$defs\":{\"pos\":{\"type\":\"number\"},\"a~b/c\":{\"const\":2}},"
                    "\"properties\":{\"x\":{\"$ref\":\"#/$defs/pos\"},"
                    "\"y\":{\"$ref\":\"#/$defs/a~0b~1c\"},\"z\":{\"items\":{\"$ref\":\"#\"}}}}";
    EXPECT_OK(s, "{\"x\":1,\"y\":2}");
    EXPECT_ERR(s, "{\"x\":\"1\"}", "at /x: expected a number, got \"1\"");
    EXPECT_ERR(s, "{\"y\":3}", "at /y: expected 2, got 3");
    /* Recursive schemas work; the document pointer keeps growing. */
    EXPECT_OK(s, "{\"z\":[{\"z\":[{\"x\":5}]}]}");
    EXPECT_ERR(s, "{\"z\":[{\"z\":[{\"x\":true}]}]}", "at /z/0/z/0/x: expected a number, got true");
    /* A $ref cycle that never descends is a schema error, not a crash. */
    EXPECT_SCHEMA_ERR("{\"$ref\":\"#\"}", "1",
                      "schema error: \"$ref\": \"#\" refers back to itself without going "
                      "deeper into the document");
}

static void test_schema_errors(void)
{
    EXPECT_SCHEMA_ERR("{\"if\":{}}", "1", "schema error at #: unsupported keyword \"if\"");
    EXPECT_SCHEMA_ERR("{\"properties\":{\"a\":{\"prefixItems\":[]}}}", "1",
                      "schema error at #/properties/a: unsupported keyword \"prefixItems\"");
    EXPECT_SCHEMA_ERR("{\"$ref\":\"#/$defs/nope\"}", "1",
                      "schema error at #: cannot resolve \"$ref\": \"#/$defs/nope\"");
    EXPECT_SCHEMA_ERR("{\"pattern\":\"(\"}", "\"x\"", "schema error at #: invalid pattern \"(\"");
    /* A quantifier right after another (undefined in POSIX; glibc's matcher
     * took exponential time on the fuzzer's "a??????..." and "a+++++...") and
     * overlong patterns are refused at once; bracket expressions and escapes
     * may hold those characters. */
    EXPECT_SCHEMA_ERR("{\"pattern\":\"^a???????????????????????????????????+$\"}", "\"a\"",
                      "schema error at #: pattern too long or with a quantifier right after another (\"a+*\"), which POSIX leaves undefined");
    EXPECT_SCHEMA_ERR("{\"pattern\":\"^a+****************************$\"}", "\"a\"",
                      "schema error at #: pattern too long or with a quantifier right after another (\"a+*\"), which POSIX leaves undefined");
    EXPECT_SCHEMA_ERR("{\"pattern\":\"x{2}+\"}", "\"xx\"",
                      "schema error at #: pattern too long or with a quantifier right after another (\"a+*\"), which POSIX leaves undefined");
    EXPECT_OK("{\"pattern\":\"^[+*?]+\\\\+a{1,2}$\"}", "\"*?+a\"");
    EXPECT_SCHEMA_ERR("{\"type\":\"float\"}", "1", "schema error at #: unknown type \"float\"");
    EXPECT_SCHEMA_ERR("{\"minItems\":-1}", "[]",
                      "schema error at #: \"minItems\" must be a non-negative integer");
    EXPECT_SCHEMA_ERR("{\"oneOf\":[{}, 3]}", "1",
                      "schema error at #/oneOf/1: a schema must be an object or a boolean");
    EXPECT_SCHEMA_ERR("{\"$defs\":{\"x\":{\"minimum\":\"0\"}}}", "1",
                      "schema error at #/$defs/x: \"minimum\" must be a number");
    /* Annotations are accepted and ignored. */
    EXPECT_OK("{\"$schema\":\"x\",\"$id\":\"y\",\"title\":\"t\",\"description\":\"d\","
              "\"default\":3,\"$comment\":\"c\",\"examples\":[1]}",
              "\"anything\"");
    /* A small buffer truncates, never overflows. */
    {
        char msg[8];
        memset(msg, 'X', sizeof msg);
        CHECK_EQ_INT(run("{\"type\":\"string\"}", "5", msg, sizeof msg), DTX_EJOB);
        CHECK(memchr(msg, '\0', sizeof msg) != NULL);
        CHECK(strcmp(msg, "at the ") == 0);
    }
}

static void test_pointer_append(void)
{
    char buf[16] = "/a";
    dtx_json_pointer_append(buf, sizeof buf, "b/c");
    CHECK(strcmp(buf, "/a/b~1c") == 0);
    dtx_json_pointer_append(buf, sizeof buf, "~");
    CHECK(strcmp(buf, "/a/b~1c/~0") == 0);
    dtx_json_pointer_append(buf, sizeof buf, "0123456789");
    CHECK_EQ_INT(strlen(buf), 15);
}

/* Inputs found by the fuzzer (tests/fuzz/fuzz_job.c): keys and strings of
 * control characters, each shown as a 6-byte \u escape, once overran the
 * 128-byte buffer that quotes them in messages. */
static int starts_with(const char *s, const char *prefix)
{
    return strncmp(s, prefix, strlen(prefix)) == 0;
}

static void test_fuzz_regressions(void)
{
    char doc[256], msg[1024], want[1024];
    /* Every length around the old overflow, as an unknown key and as a
     * string value. */
    for (int len = 0; len <= 60; len++) {
        char key[64];
        dtx_status st;
        memset(key, '\r', (size_t)len);
        key[len] = '\0';
        snprintf(doc, sizeof doc, "{\"%s\": 1}", key);
        st = run("{\"properties\": {\"a\": true}, \"additionalProperties\": false}", doc, msg,
                 sizeof msg);
        CHECK_EQ_INT(st, DTX_EJOB);
        CHECK(starts_with(msg, "at the top level: unknown key \""));
        CHECK(strstr(msg, "(allowed: a)") != NULL);
        CHECK(strlen(msg) < 200);
        snprintf(doc, sizeof doc, "\"%s\"", key);
        st = run("{\"type\": \"integer\"}", doc, msg, sizeof msg);
        CHECK_EQ_INT(st, DTX_EJOB);
        CHECK(starts_with(msg, "at the top level: expected an integer, got \""));
        CHECK(strlen(msg) < 200);
    }
    /* The shortened form: escapes up to the room left, then "...". */
    memset(doc, 0, sizeof doc);
    strcpy(doc, "{\"");
    memset(doc + 2, '\r', 30);
    strcpy(doc + 32, "\": 1}");
    strcpy(want, "at the top level: unknown key \"");
    for (int i = 0; i < 20; i++)
        strcat(want, "\\u000d");
    strcat(want, "...\" (allowed: a)");
    EXPECT_ERR("{\"properties\": {\"a\": true}, \"additionalProperties\": false}", doc, want);

    /* A $ref loop through anyOf once took 2^256 steps (a hang); now the
     * loop is found at once. */
    EXPECT_SCHEMA_ERR("{\"$defs\":{\"a\":{\"anyOf\":[{\"$ref\":\"#/$defs/a\"},"
                      "{\"$ref\":\"#/$defs/a\"}]}},\"$ref\":\"#/$defs/a\"}",
                      "1",
                      "schema error: \"$ref\": \"#/$defs/a\" refers back to itself without "
                      "going deeper into the document");
    /* Branches that recurse into the document (legal, but exponential in
     * its depth) stop at the step budget instead of running for ages. */
    {
        /* anyOf tries every branch, so each level doubles the work. */
        const char *sch = "{\"$defs\":{\"a\":{\"anyOf\":[{\"items\":{\"$ref\":\"#/$defs/a\"}},"
                          "{\"items\":{\"$ref\":\"#/$defs/a\"}}]}},\"$ref\":\"#/$defs/a\"}";
        char deep[200];
        int k = 0;
        for (int i = 0; i < 60; i++)
            deep[k++] = '[';
        for (int i = 0; i < 60; i++)
            deep[k++] = ']';
        deep[k] = '\0';
        EXPECT_SCHEMA_ERR(sch, deep,
                          "schema error: validating this document takes too many steps (oneOf "
                          "/ anyOf branches that refer back to themselves?)");
        /* The same schema on a shallow document is fine. */
        EXPECT_OK(sch, "[[[[[[]]]]],[]]");
    }
}

/* The checks on the JSON text: depth (strings skipped), \u0000 with the
 * JSON pointer of its place, and line/column with every line end. */
static void test_text_checks(void)
{
    char ptr[128];
    const char *t;
    size_t line, col;
    t = "[[[]]]";
    CHECK(dtx_json_find_too_deep(t, strlen(t), 3) == (size_t)-1);
    CHECK(dtx_json_find_too_deep(t, strlen(t), 2) == 2);
    t = "{\"a\":\"[[[[\\\"[[\"}";
    CHECK(dtx_json_find_too_deep(t, strlen(t), 1) == (size_t)-1);
    t = "{\"a\":[1,{\"b\":\"x\"},{\"c\":[\"y\",\"z\\u0000\"]}],\"d\":\"\\u0000\"}";
    CHECK(dtx_json_find_nul_escape(t, strlen(t), ptr, sizeof ptr) != (size_t)-1);
    CHECK(strcmp(ptr, "/a/2/c/1") == 0);
    t = "{\"a\":[1,{\"b\":\"x\"}],\"d~/\":{\"e\":\"\\u0000\"}}";
    CHECK(dtx_json_find_nul_escape(t, strlen(t), ptr, sizeof ptr) != (size_t)-1);
    CHECK(strcmp(ptr, "/d~0~1/e") == 0);
    t = "{\"a\":{},\"k\\u0000\":1}";
    CHECK(dtx_json_find_nul_escape(t, strlen(t), ptr, sizeof ptr) != (size_t)-1);
    CHECK(strcmp(ptr, "/k\\u0000") == 0);
    t = "\"\\u0000\"";
    CHECK(dtx_json_find_nul_escape(t, strlen(t), ptr, sizeof ptr) == 0);
    CHECK(strcmp(ptr, "") == 0);
    t = "{\"a\":\"\\\\u0000\",\"b\":\"\\u00001\"}"; /* an escaped backslash, then a NUL */
    CHECK(dtx_json_find_nul_escape(t, strlen(t), ptr, sizeof ptr) != (size_t)-1);
    CHECK(strcmp(ptr, "/b") == 0);
    t = "{\"a\":\"\\u0001\"}";
    CHECK(dtx_json_find_nul_escape(t, strlen(t), ptr, sizeof ptr) == (size_t)-1);
    t = "a\nb\r\nc\rd";
    dtx_json_line_col(t, strlen(t), 7, &line, &col);
    CHECK(line == 4 && col == 1);
    dtx_json_line_col(t, strlen(t), 4, &line, &col);
    CHECK(line == 2 && col == 2);
}

int main(void)
{
    test_type();
    test_objects();
    test_arrays();
    test_enum_const();
    test_ranges();
    test_strings();
    test_combinators();
    test_refs();
    test_schema_errors();
    test_pointer_append();
    test_fuzz_regressions();
    test_text_checks();
    return check_report();
}
