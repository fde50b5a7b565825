/* fuzz_npy.c: libFuzzer harness for dtx_npy_parse_frames (src/io/npy.c):
 * any input gives either frames whose count agrees with the input's size
 * (header plus T x V x 3 items of 4 or 8 bytes), or a clean error naming
 * the file and no array. */
#include "fuzz_util.h"
#include "npy.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const dtx_status allowed[] = {DTX_EPARSE, DTX_ENOMEM, DTX_OK};
    /* An exactly sized copy, so reading past the end is caught. */
    unsigned char *copy = malloc(size ? size : 1);
    dtx_npy_header h;
    dtx_error err;
    double *X = NULL;
    int32_t T = -1, V = -1;
    dtx_status st;
    if (!copy)
        return 0;
    memcpy(copy, data, size);
    st = dtx_npy_parse_frames("fuzz.npy", copy, size, &T, &V, &X, &err);
    if (st == DTX_OK) {
        size_t n = 3 * (size_t)T * (size_t)V;
        FUZZ_ASSERT(X != NULL && T >= 1 && V >= 1);
        FUZZ_ASSERT(dtx_npy_parse_header("fuzz.npy", copy, size, &h, &err) == DTX_OK);
        FUZZ_ASSERT(size == h.data_offset + n * (size_t)h.itemsize);
        /* Every value is read: touch the last one. */
        FUZZ_ASSERT(X[n - 1] == X[n - 1] || isnan(X[n - 1]));
    } else {
        fuzz_check_error(st, &err, "fuzz.npy", allowed);
        FUZZ_ASSERT(X == NULL);
    }
    free(X);
    free(copy);
    return 0;
}
