/* fuzz_off.c: libFuzzer harness for dtx_off_parse (src/io/off.c): any input
 * gives either a valid mesh or a clean error naming the file. */
#include "fuzz_util.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    return fuzz_mesh_parser(dtx_off_parse, "fuzz.off", data, size);
}
