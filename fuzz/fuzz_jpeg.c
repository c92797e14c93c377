/* JPEG decoding (src/io/jpeg.c over libjpeg-turbo) with EXIF orientation (src/io/exif.c, esr's
 * own parser, the part libjpeg-turbo's upstream fuzzing does not cover). An input that starts
 * with a JPEG's SOI marker (FF D8) is decoded as stored and upright (esr_jpeg_decode); any other
 * input is the payload of an APP1 segment, handed to esr_exif_orientation directly, so the
 * parser is fuzzed without the JPEG around it having to stay valid. */
#include <string.h>

#include "fuzz.h"
#include "io/exif.h"
#include "io/image.h"

static void check_pixels(const struct esr_image *img)
{
    if (img->width < 1 || img->height < 1 || (img->channels != 1 && img->channels != 3) || !img->data)
        abort();
    /* every sample is read, so ASan sees a buffer smaller than its claimed size */
    for (size_t i = 0; i < esr_image_count(img); i++)
        if (!(img->data[i] >= 0.0f && img->data[i] <= 1.0f))
            abort();
}

static int same_image(const struct esr_image *a, const struct esr_image *b)
{
    return a->width == b->width && a->height == b->height && a->channels == b->channels &&
           !memcmp(a->data, b->data, esr_image_count(a) * sizeof *a->data);
}

/* The upright image must be the stored one under one of the 8 orientations (which one is the
 * EXIF parser's answer, checked on its own below): 1-4 keep the dimensions, 5-8 swap them. */
static void decode_jpeg(const uint8_t *data, size_t size)
{
    /* The decoder's work grows with the pixels, not with the input's bytes (a 146-byte
     * arithmetic-coded file whose scan ends early decodes to 2 Mpixel without a warning), so the
     * images here stay at 2^18 pixels: larger claims still reach the limit's refusal. */
    static const struct esr_limits limits = {(size_t)1 << 18, (size_t)256 << 20};
    esr_limits_set(&limits);
    struct esr_image stored, upright;
    int status = esr_jpeg_decode(data, size, "fuzz.jpg", 0, &stored);
    if (status != ESR_OK) {
        if (stored.data)
            abort();
        fuzz_done(status);
        return;
    }
    check_pixels(&stored);
    if (esr_jpeg_decode(data, size, "fuzz.jpg", 1, &upright) != ESR_OK) /* the same bytes decode the same */
        abort();
    check_pixels(&upright);
    int found = 0;
    const int swapped = upright.width != stored.width || upright.height != stored.height;
    const int last = !swapped && stored.width != stored.height ? 4 : 8;
    for (int o = swapped ? 5 : 1; o <= last && !found; o++) {
        struct esr_image turned;
        if (esr_image_orient(&stored, o, &turned) != ESR_OK)
            abort();
        found = same_image(&turned, &upright);
        esr_image_free(&turned);
    }
    if (!found)
        abort();
    esr_image_free(&stored);
    esr_image_free(&upright);
}

/* A 3x2 image whose pixels hold their stored index, turned by the parsed orientation: by the
 * EXIF specification, 5..8 swap width and height, and the stored top-left pixel lands in the
 * corner below (with the dimensions this tells all 8 apart); every pixel appears once. */
static void parse_exif(const uint8_t *data, size_t size)
{
    enum { TL, TR, BR, BL };
    static const int corner[9] = {0, TL, TR, BR, BL, TL, TR, BR, BL};
    int o = esr_exif_orientation(data, size);
    if (o < 1 || o > 8)
        abort();
    struct esr_image in, out;
    if (esr_image_alloc(&in, 3, 2, 1) != ESR_OK)
        abort();
    for (int i = 0; i < 6; i++)
        in.data[i] = (float)i;
    if (esr_image_orient(&in, o, &out) != ESR_OK)
        abort();
    const int w = o >= 5 ? 2 : 3, h = o >= 5 ? 3 : 2;
    if (out.width != w || out.height != h || out.channels != 1)
        abort();
    const int x = corner[o] == TR || corner[o] == BR ? w - 1 : 0, y = corner[o] >= BR ? h - 1 : 0;
    if (out.data[y * w + x] != 0.0f)
        abort();
    int seen = 0;
    for (int i = 0; i < 6; i++)
        seen |= 1 << (int)out.data[i];
    if (seen != 0x3f)
        abort();
    esr_image_free(&in);
    esr_image_free(&out);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fuzz_setup();
    if (size >= 2 && data[0] == 0xff && data[1] == 0xd8)
        decode_jpeg(data, size);
    else
        parse_exif(data, size);
    return 0;
}
