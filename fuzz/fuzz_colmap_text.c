/* COLMAP text models (src/import/colmap_text.c): cameras.txt, images.txt and points3D.txt in one
 * input, split and checked as colmap_fuzz.h says; fuzz/colmap.dict holds the format's words. */
#include "colmap_fuzz.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const char *const names[ESR_COLMAP_FILES] = {"cameras.txt", "images.txt", "points3D.txt"};
    fuzz_colmap_run(data, size, names, esr_colmap_model_parse_text);
    return 0;
}
