/* PNG files through libspng. Decoding always goes through RGBA8/RGBA16 (spng converts every
 * colour type and bit depth to those) and then keeps the channels the file really has. */
#include <math.h>
#include <spng.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/limits.h"
#include "io/file.h"
#include "io/image.h"

/* Channels kept from an image of this colour type (tRNS adds alpha to grey/RGB/palette). */
static int png_channels(const struct spng_ihdr *ihdr, int has_trns)
{
    switch (ihdr->color_type) {
    case SPNG_COLOR_TYPE_GRAYSCALE:
        return has_trns ? 2 : 1;
    case SPNG_COLOR_TYPE_GRAYSCALE_ALPHA:
        return 2;
    case SPNG_COLOR_TYPE_TRUECOLOR:
    case SPNG_COLOR_TYPE_INDEXED:
        return has_trns ? 4 : 3;
    default:
        return 4;
    }
}

/* RGBA sample index kept as output channel k of an image with `channels` channels. */
static int rgba_source(int channels, int k)
{
    if (channels == 1)
        return 0;
    if (channels == 2)
        return k == 0 ? 0 : 3;
    return k;
}

static int png_decode(spng_ctx *ctx, const char *path, struct esr_image *out)
{
    struct spng_ihdr ihdr;
    int rc = spng_get_ihdr(ctx, &ihdr);
    if (rc)
        return ESR_FAIL("'%s' is not a valid PNG: %s", path, spng_strerror(rc));
    /* refused before the decoder allocates anything for the claimed size */
    if ((uint64_t)ihdr.width * ihdr.height > esr_limits()->image_pixels)
        return ESR_FAIL("'%s': PNG claims %ux%u pixels, more than the %zu esr reads", path, ihdr.width,
                        ihdr.height, esr_limits()->image_pixels);
    struct spng_trns trns;
    int has_trns = spng_get_trns(ctx, &trns) == 0;
    int channels = png_channels(&ihdr, has_trns);
    int wide = ihdr.bit_depth == 16;
    int fmt = wide ? SPNG_FMT_RGBA16 : SPNG_FMT_RGBA8;
    size_t size;
    rc = spng_decoded_image_size(ctx, fmt, &size);
    if (rc)
        return ESR_FAIL("'%s': cannot size the PNG image: %s", path, spng_strerror(rc));
    void *raw = malloc(size);
    if (!raw)
        return ESR_FAIL("out of memory decoding '%s'", path);
    rc = spng_decode_image(ctx, raw, size, fmt, SPNG_DECODE_TRNS);
    if (rc) {
        free(raw);
        return ESR_FAIL("'%s': corrupt or truncated PNG: %s", path, spng_strerror(rc));
    }
    if (esr_image_alloc(out, (int)ihdr.width, (int)ihdr.height, channels) != ESR_OK) {
        free(raw);
        return ESR_ERR;
    }
    size_t n = (size_t)ihdr.width * ihdr.height;
    const uint8_t *p8 = raw;
    const uint16_t *p16 = raw;
    float scale = wide ? 1.0f / 65535.0f : 1.0f / 255.0f;
    for (size_t p = 0; p < n; p++)
        for (int k = 0; k < channels; k++) {
            size_t s = p * 4 + (size_t)rgba_source(channels, k);
            out->data[p * (size_t)channels + (size_t)k] = (wide ? (float)p16[s] : (float)p8[s]) * scale;
        }
    free(raw);
    return ESR_OK;
}

int esr_png_decode(const void *bytes, size_t size, const char *name, struct esr_image *out)
{
    out->data = NULL;
    out->width = out->height = out->channels = 0;
    spng_ctx *ctx = spng_ctx_new(0);
    if (!ctx)
        return ESR_FAIL("out of memory opening '%s'", name);
    /* The PNG maximum per side: what a header may claim is capped by png_decode's pixel count
     * (esr_limits), which says so in its message, before anything is allocated. */
    spng_set_image_limits(ctx, 0x7fffffffu, 0x7fffffffu);
    spng_set_chunk_limits(ctx, 64u << 20, 64u << 20);
    int rc = spng_set_png_buffer(ctx, bytes, size);
    int status = rc ? ESR_FAIL("'%s': cannot read PNG: %s", name, spng_strerror(rc)) : png_decode(ctx, name, out);
    spng_ctx_free(ctx);
    return status;
}

int esr_png_read(const char *path, struct esr_image *out)
{
    out->data = NULL;
    out->width = out->height = out->channels = 0;
    unsigned char *bytes;
    size_t size;
    ESR_TRY(esr_file_read_all(path, &bytes, &size));
    int status = esr_png_decode(bytes, size, path, out);
    free(bytes);
    return status;
}

static const uint8_t png_color_types[5] = {0, SPNG_COLOR_TYPE_GRAYSCALE, SPNG_COLOR_TYPE_GRAYSCALE_ALPHA,
                                           SPNG_COLOR_TYPE_TRUECOLOR, SPNG_COLOR_TYPE_TRUECOLOR_ALPHA};

/* Float [0,1] samples -> packed 8- or 16-bit host-endian samples (what SPNG_FMT_PNG expects). */
static void *png_quantise(const struct esr_image *img, int bits, size_t *size)
{
    size_t n = esr_image_count(img);
    float maxv = bits == 16 ? 65535.0f : 255.0f;
    *size = n * (size_t)(bits / 8);
    void *raw = malloc(*size);
    if (!raw)
        return NULL;
    for (size_t i = 0; i < n; i++) {
        float v = img->data[i];
        v = v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f; /* NaN -> 0 */
        float q = roundf(v * maxv);
        if (bits == 16)
            ((uint16_t *)raw)[i] = (uint16_t)q;
        else
            ((uint8_t *)raw)[i] = (uint8_t)q;
    }
    return raw;
}

int esr_png_write(const char *path, const struct esr_image *img, int bits)
{
    if (bits != 8 && bits != 16)
        return ESR_FAIL("PNG bit depth must be 8 or 16, got %d (writing '%s')", bits, path);
    if (!img->data || img->width <= 0 || img->height <= 0 || img->channels < 1 || img->channels > 4)
        return ESR_FAIL("cannot write '%s': invalid image (%dx%d, %d channels)", path, img->width, img->height,
                        img->channels);
    size_t raw_size;
    void *raw = png_quantise(img, bits, &raw_size);
    if (!raw)
        return ESR_FAIL("out of memory encoding '%s'", path);
    spng_ctx *ctx = spng_ctx_new(SPNG_CTX_ENCODER);
    if (!ctx) {
        free(raw);
        return ESR_FAIL("out of memory encoding '%s'", path);
    }
    struct spng_ihdr ihdr;
    memset(&ihdr, 0, sizeof ihdr);
    ihdr.width = (uint32_t)img->width;
    ihdr.height = (uint32_t)img->height;
    ihdr.bit_depth = (uint8_t)bits;
    ihdr.color_type = png_color_types[img->channels];
    int rc = spng_set_option(ctx, SPNG_ENCODE_TO_BUFFER, 1);
    if (!rc)
        rc = spng_set_ihdr(ctx, &ihdr);
    if (!rc)
        rc = spng_encode_image(ctx, raw, raw_size, SPNG_FMT_PNG, SPNG_ENCODE_FINALIZE);
    free(raw);
    size_t png_size = 0;
    void *png = rc ? NULL : spng_get_png_buffer(ctx, &png_size, &rc);
    spng_ctx_free(ctx);
    if (rc || !png) {
        free(png);
        return ESR_FAIL("cannot encode '%s': %s", path, spng_strerror(rc));
    }
    int status = esr_file_write_atomic(path, png, png_size);
    free(png);
    return status;
}
