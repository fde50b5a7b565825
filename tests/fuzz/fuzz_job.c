/* fuzz_job.c: libFuzzer harness for dtx_job_parse (src/io/job.c, with the
 * schema validator src/io/json_schema.c).  Any input gives either a job
 * that keeps the promises of job.h (absolute resolved paths, unique valid
 * target names, at least one sequence and target) or a clean error naming
 * the job.  A parsed job's canonical parameter text must be JSON. */
#include "fuzz_util.h"
#include "job.h"

#include <cjson/cJSON.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const dtx_status allowed[] = {DTX_EPARSE, DTX_EJOB, DTX_ENOMEM, DTX_OK};
    const char *name = "fuzz.json";
    dtx_job job;
    dtx_error err;
    dtx_status st;
    char *params;
    cJSON *p;

    memset(&err, 0, sizeof err);
    /* check_files 0: nothing on disk is needed; "/nonexistent-dtx-fuzz" is
     * resolved lexically. */
    st = dtx_job_parse((const char *)data, size, name, "/nonexistent-dtx-fuzz/jobs", 0, &job, &err);
    if (st != DTX_OK) {
        fuzz_check_error(st, &err, name, allowed);
        FUZZ_ASSERT(job.text == NULL && job.targets == NULL && job.ntargets == 0);
        return 0;
    }
    FUZZ_ASSERT(job.version == DTX_JOB_VERSION);
    FUZZ_ASSERT(job.source_file && job.source_file[0] == '/');
    FUZZ_ASSERT(job.output_file && job.output_file[0] == '/');
    FUZZ_ASSERT(job.source_mesh && job.nsequences >= 1 && job.sequences);
    FUZZ_ASSERT(job.ntargets >= 1 && job.targets);
    FUZZ_ASSERT(job.block_frames >= 1 && job.block_frames <= 65536);
    FUZZ_ASSERT(job.sp04.n_closest >= 1 && job.sp04.n_closest <= 16);
    for (int32_t i = 0; i < job.ntargets; i++) {
        const dtx_job_target *t = &job.targets[i];
        FUZZ_ASSERT(t->name && t->name[0] && t->file && t->file[0] == '/' && t->mesh);
        /* At most one marker source; none only with method springs (a
         * target with the source's connectivity may omit its markers). */
        FUZZ_ASSERT(!(t->markers.csv && t->markers.file));
        FUZZ_ASSERT(t->markers.csv || t->markers.file || job.method == DTX_METHOD_SPRINGS);
        FUZZ_ASSERT(!t->markers.csv || t->markers.index_base == 0 || t->markers.index_base == 1);
        FUZZ_ASSERT(!t->markers.file || t->markers.path);
        FUZZ_ASSERT(t->npins >= 0 && (t->npins == 0 || t->pins));
        for (int32_t k = 0; k < t->npins; k++)
            FUZZ_ASSERT(t->pins[k].vertex >= 0);
        for (int32_t j = 0; j < i; j++)
            FUZZ_ASSERT(strcmp(t->name, job.targets[j].name) != 0);
    }
    params = dtx_job_params_json(&job);
    FUZZ_ASSERT(params != NULL);
    p = cJSON_Parse(params);
    FUZZ_ASSERT(p != NULL);
    cJSON_Delete(p);
    free(params);
    dtx_job_free(&job);
    return 0;
}
