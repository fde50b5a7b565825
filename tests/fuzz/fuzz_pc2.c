/* fuzz_pc2.c: libFuzzer harness for dtx_pc2_parse (src/io/pc2.c): any input
 * gives either a header that agrees with the input's size and a sample
 * array of that size, or a clean error naming the file and no array. */
#include "fuzz_util.h"
#include "pc2.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const dtx_status allowed[] = {DTX_EPARSE, DTX_ENOMEM, DTX_OK};
    /* An exactly sized copy, so reading past the end is caught. */
    unsigned char *copy = malloc(size ? size : 1);
    dtx_pc2_header h;
    dtx_error err;
    float *P = NULL;
    dtx_status st;
    if (!copy)
        return 0;
    memcpy(copy, data, size);
    st = dtx_pc2_parse("fuzz.pc2", copy, size, &h, &P, &err);
    if (st == DTX_OK) {
        size_t n = 3 * (size_t)h.num_points * (size_t)h.num_samples;
        FUZZ_ASSERT(P != NULL && h.version == 1 && h.num_points >= 1 && h.num_samples >= 1);
        FUZZ_ASSERT(size == 32 + 4 * n);
        FUZZ_ASSERT(isfinite(h.start_frame) && h.sample_rate > 0.0f);
        /* Every float is read: touch the last one. */
        FUZZ_ASSERT(memcmp(&P[n - 1], copy + size - 4, 4) == 0);
    } else {
        fuzz_check_error(st, &err, "fuzz.pc2", allowed);
        FUZZ_ASSERT(P == NULL);
    }
    free(P);
    free(copy);
    return 0;
}
