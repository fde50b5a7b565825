/* fuzz_json_schema.c: libFuzzer harness for dtx_json_validate
 * (src/io/json_schema.c) with a fuzzed schema and document: the input is
 * SCHEMA NUL DOCUMENT (without a NUL byte, the text is both).  Whatever the
 * two are, the validator returns DTX_OK, DTX_EJOB (document) or DTX_EINVAL
 * (schema) with a message, and never loops, recurses without bound or
 * reads out of bounds. */
#include "fuzz_util.h"
#include "json_schema.h"

#include <cjson/cJSON.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *text = (const char *)data, *nul = memchr(text, '\0', size);
    size_t slen = nul ? (size_t)(nul - text) : size;
    cJSON *schema = cJSON_ParseWithLength(text, slen), *doc;
    char msg[1024];
    dtx_status st;
    if (!schema)
        return 0;
    doc = nul ? cJSON_ParseWithLength(nul + 1, size - slen - 1) : schema;
    if (doc) {
        memset(msg, 'x', sizeof msg);
        st = dtx_json_validate(schema, doc, msg, sizeof msg);
        FUZZ_ASSERT(st == DTX_OK || st == DTX_EJOB || st == DTX_EINVAL || st == DTX_ENOMEM);
        FUZZ_ASSERT(memchr(msg, '\0', sizeof msg) != NULL);
        FUZZ_ASSERT(st == DTX_OK || msg[0] != '\0');
        /* A tiny buffer is truncated, never overrun (ASan would see it). */
        {
            char *small = malloc(5);
            FUZZ_ASSERT(small != NULL);
            (void)dtx_json_validate(schema, doc, small, 5);
            FUZZ_ASSERT(memchr(small, '\0', 5) != NULL);
            free(small);
        }
    }
    if (doc != schema)
        cJSON_Delete(doc);
    cJSON_Delete(schema);
    return 0;
}
