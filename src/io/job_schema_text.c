/*
 * job_schema_text.c: schemas/job.schema.json built into the binary.  The
 * build embeds the file's bytes (cmake/embed.cmake, dtx_job_schema_json in
 * the build's generated/ folder), so the schema has one copy, the file.
 */
#include "job.h"

#include <stdlib.h>
#include <string.h>

extern const unsigned char dtx_job_schema_json[];
extern const size_t dtx_job_schema_json_len;

char *dtx_job_schema_text(void)
{
    char *text = malloc(dtx_job_schema_json_len + 1);
    if (!text)
        return NULL;
    memcpy(text, dtx_job_schema_json, dtx_job_schema_json_len + 1);
    return text;
}
