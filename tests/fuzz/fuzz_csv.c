/* fuzz_csv.c: libFuzzer harness for dtx_markers_parse_csv
 * (src/io/markers_csv.c).  The first input byte picks index_base (-1, 0 or
 * 1), the rest is the file.  Any input gives either markers with 0-based
 * indices >= 0 and a label each, or a clean error naming the file. */
#include "fuzz_util.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const dtx_status allowed[] = {DTX_EPARSE, DTX_ERANGE, DTX_EINVAL, DTX_ENOMEM, DTX_OK};
    const char *name = "fuzz.csv";
    dtx_markers mk;
    dtx_error err;
    dtx_status st;
    int base;
    if (size == 0)
        return 0;
    base = data[0] % 3 - 1;
    memset(&mk, 0x5a, sizeof mk);
    memset(&err, 0, sizeof err);
    st = dtx_markers_parse_csv(name, (const char *)data + 1, size - 1, base, &mk, &err);
    if (st != DTX_OK) {
        fuzz_check_error(st, &err, name, allowed);
        FUZZ_ASSERT(mk.n == 0 && mk.src == NULL && mk.tgt == NULL && mk.labels == NULL);
        return 0;
    }
    FUZZ_ASSERT(mk.n > 0 && mk.src && mk.tgt && mk.labels);
    for (int32_t i = 0; i < mk.n; i++) {
        FUZZ_ASSERT(mk.src[i] >= 0 && mk.tgt[i] >= 0);
        FUZZ_ASSERT(mk.labels[i] != NULL);
        (void)strlen(mk.labels[i]);
    }
    (void)dtx_markers_validate(&mk, 64, 64, name, &err);
    dtx_markers_free(&mk);
    return 0;
}
