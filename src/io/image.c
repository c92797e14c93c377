#include "io/image.h"

#include <ctype.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"

int esr_image_alloc(struct esr_image *img, int width, int height, int channels)
{
    img->width = img->height = img->channels = 0;
    img->data = NULL;
    if (width <= 0 || height <= 0 || channels < 1 || channels > 4)
        return ESR_FAIL("invalid image size %dx%d with %d channels", width, height, channels);
    size_t n = (size_t)width * (size_t)height * (size_t)channels;
    float *data = calloc(n, sizeof *data);
    if (!data)
        return ESR_FAIL("out of memory allocating a %dx%dx%d image", width, height, channels);
    img->width = width;
    img->height = height;
    img->channels = channels;
    img->data = data;
    return ESR_OK;
}

void esr_image_free(struct esr_image *img)
{
    if (!img)
        return;
    free(img->data);
    img->data = NULL;
    img->width = img->height = img->channels = 0;
}

static int has_extension(const char *path, const char *ext)
{
    size_t n = strlen(path), m = strlen(ext);
    if (n < m)
        return 0;
    for (size_t i = 0; i < m; i++)
        if (tolower((unsigned char)path[n - m + i]) != ext[i])
            return 0;
    return 1;
}

int esr_image_is_exr(const char *path)
{
    return has_extension(path, ".exr");
}

int esr_image_read(const char *path, struct esr_image *out)
{
    if (has_extension(path, ".png"))
        return esr_png_read(path, out);
    if (has_extension(path, ".exr"))
        return esr_exr_read(path, out);
    if (has_extension(path, ".jpg") || has_extension(path, ".jpeg"))
        return esr_jpeg_read(path, out);
    return ESR_FAIL("'%s': unknown image extension (expected .png, .exr, .jpg or .jpeg)", path);
}

/* Both compositing rules share one loop: c = rgb * rgb_scale + bg * (1 - a), where rgb_scale is
 * a for straight alpha and 1 for premultiplied alpha; a grey channel stands for all three. */
static int composite(const struct esr_image *in, const float bg[3], int premultiplied, struct esr_image *out)
{
    ESR_TRY(esr_image_alloc(out, in->width, in->height, 3));
    size_t n = (size_t)in->width * (size_t)in->height;
    const int c = in->channels, grey = c < 3;
    for (size_t p = 0; p < n; p++) {
        const float *s = in->data + p * (size_t)c;
        float a = c == 4 || c == 2 ? s[c - 1] : 1.0f;
        float scale = premultiplied ? 1.0f : a;
        for (int k = 0; k < 3; k++)
            out->data[p * 3 + (size_t)k] = s[grey ? 0 : k] * scale + bg[k] * (1.0f - a);
    }
    return ESR_OK;
}

int esr_image_composite(const struct esr_image *rgba, const float bg[3], struct esr_image *rgb)
{
    return composite(rgba, bg, 0, rgb);
}

int esr_image_composite_premultiplied(const struct esr_image *rgba, const float bg[3], struct esr_image *rgb)
{
    return composite(rgba, bg, 1, rgb);
}
