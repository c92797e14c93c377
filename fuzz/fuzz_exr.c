/* EXR decoding through esr's wrapper (src/io/exr.c over OpenEXRCore). */
#include "fuzz.h"
#include "io/image.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fuzz_setup();
    struct esr_image img;
    int status = esr_exr_decode(data, size, "fuzz.exr", &img);
    if (status == ESR_OK) {
        if (img.width <= 0 || img.height <= 0 || img.channels != 4)
            abort();
        /* every sample is read (values may be anything a file stores, NaN included) */
        volatile float sink = 0.0f;
        for (size_t i = 0; i < esr_image_count(&img); i++)
            sink += img.data[i];
        (void)sink;
        esr_image_free(&img);
    }
    fuzz_done(status);
    return 0;
}
