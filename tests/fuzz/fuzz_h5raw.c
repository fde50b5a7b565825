/*
 * fuzz_h5raw.c: libFuzzer harness that hands the input bytes, as a file,
 * to dtx_h5_validate and the layout readers (fz_check_file).  Mostly
 * HDF5's own parser is exercised here; dtx must fail cleanly on whatever
 * HDF5 manages to open.  Crashes inside libhdf5 itself are HDF5 bugs (see
 * tests/fuzz/README.md); fuzz_h5validate is the harness for dtx's checks.
 * Seed: tests/fuzz/corpus/h5raw/ (a small valid dtx file).
 */
#include "fuzz_h5common.h"

int LLVMFuzzerInitialize(int *argc, char ***argv);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    dtx_h5_init();
    fz_make_dir();
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz_write_file(fz_path, data, size);
    fz_check_file(fz_path, 0);
    return 0;
}
