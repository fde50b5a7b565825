/* fuzz_ply.c: libFuzzer harness for dtx_ply_parse (src/io/ply.c): any input
 * gives either a valid mesh or a clean error naming the file; and for an
 * input that parses, dtx_ply_parse_attrs gives attributes that pass
 * dtx_mesh_attrs_validate or a clean error. */
#include "fuzz_util.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const dtx_status allowed[] = {DTX_ENONFINITE, DTX_ENOMEM, DTX_OK};
    dtx_warner w = {fuzz_warn, (void *)"fuzz.ply"};
    dtx_mesh m;
    dtx_mesh_attrs a;
    dtx_error err;
    dtx_status st;
    fuzz_mesh_parser(dtx_ply_parse, "fuzz.ply", data, size);
    if (dtx_ply_parse("fuzz.ply", (const char *)data, size, &m, NULL, &err) != DTX_OK)
        return 0;
    st = dtx_ply_parse_attrs("fuzz.ply", (const char *)data, size, m.nf, &a, &w, &err);
    if (st == DTX_OK)
        FUZZ_ASSERT(dtx_mesh_attrs_validate(&a, m.nv, m.nf, "fuzz.ply", &err) == DTX_OK);
    else
        fuzz_check_error(st, &err, "fuzz.ply", allowed);
    FUZZ_ASSERT(st == DTX_OK || !dtx_mesh_attrs_any(&a));
    dtx_mesh_attrs_free(&a);
    dtx_mesh_free(&m);
    return 0;
}
