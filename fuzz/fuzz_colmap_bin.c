/* COLMAP binary models (src/import/colmap_binary.c): cameras.bin, images.bin and points3D.bin in
 * one input, split and checked as colmap_fuzz.h says. */
#include "colmap_fuzz.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const char *const names[ESR_COLMAP_FILES] = {"cameras.bin", "images.bin", "points3D.bin"};
    fuzz_colmap_run(data, size, names, esr_colmap_model_parse_binary);
    return 0;
}
