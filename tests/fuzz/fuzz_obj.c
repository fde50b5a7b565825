/* fuzz_obj.c: libFuzzer harness for dtx_obj_parse (src/io/obj.c): any input
 * gives either a valid mesh or a clean error naming the file. */
#include "fuzz_util.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    return fuzz_mesh_parser(dtx_obj_parse, "fuzz.obj", data, size);
}
