/* PNG decoding through esr's wrapper (src/io/png.c over libspng). */
#include "fuzz.h"
#include "io/image.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fuzz_setup();
    struct esr_image img;
    int status = esr_png_decode(data, size, "fuzz.png", &img);
    if (status == ESR_OK) {
        if (img.width <= 0 || img.height <= 0 || img.channels < 1 || img.channels > 4)
            abort();
        /* every sample is read, so ASan sees a buffer smaller than its claimed size */
        for (size_t i = 0; i < esr_image_count(&img); i++)
            if (!(img.data[i] >= 0.0f && img.data[i] <= 1.0f))
                abort();
        esr_image_free(&img);
    }
    fuzz_done(status);
    return 0;
}
