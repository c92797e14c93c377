/* In-memory images and PNG / EXR / JPEG files.
 * Pixels are float, interleaved, rows top-first (PNG/EXR order), pixel (0,0) top-left.
 * PNG values are the stored code values scaled to [0,1] (no colour conversion);
 * EXR values are linear as stored. */
#ifndef ESR_IO_IMAGE_H
#define ESR_IO_IMAGE_H

#include <stddef.h>

struct esr_image {
    int width, height;
    int channels; /* 1 = grey, 2 = grey+alpha, 3 = RGB, 4 = RGBA */
    float *data;  /* width * height * channels floats, owned */
};

int esr_image_alloc(struct esr_image *img, int width, int height, int channels);
void esr_image_free(struct esr_image *img);
static inline size_t esr_image_count(const struct esr_image *img)
{
    return (size_t)img->width * (size_t)img->height * (size_t)img->channels;
}

/* PNG, 8- or 16-bit, any colour type (palette and grey are expanded; output keeps alpha if the
 * file has it: grey -> 1, grey+alpha -> 2, RGB -> 3, RGBA/palette with tRNS -> 4 channels). */
int esr_png_read(const char *path, struct esr_image *out);
/* The same from size bytes in memory; name stands for the file in messages. Both refuse a
 * header that claims more than esr_limits()->image_pixels pixels before allocating. */
int esr_png_decode(const void *bytes, size_t size, const char *name, struct esr_image *out);
/* bits = 8 or 16; channels 1, 2, 3 or 4; values are clamped to [0,1] and rounded. Written atomically. */
int esr_png_write(const char *path, const struct esr_image *img, int bits);

/* Scanline or tiled EXR (part 0, level 0 of a tiled part), half/float/uint channels, any
 * compression the core library decodes. Returns the data window as 4 channels R,G,B,A (A = 1
 * when absent, missing colour channels 0; a luminance-only Y channel fills R,G,B; other channels
 * are ignored). Values are as stored: premultiplied by alpha when the file has alpha (OpenEXR
 * convention). Fails naming the file when it is missing, truncated or corrupt. */
int esr_exr_read(const char *path, struct esr_image *out);
/* esr_exr_read of one layer of a multi-layer file (esr_exr_write_layers): its channels
 * "<layer>.R" and so on (NULL: the bare R, G, B, A, Y); a file without the layer is refused. */
int esr_exr_read_layer(const char *path, const char *layer, struct esr_image *out);
/* The same from size bytes in memory (name stands for the file in messages); both refuse a data
 * window of more than esr_limits()->image_pixels pixels before allocating. */
int esr_exr_decode(const void *bytes, size_t size, const char *name, struct esr_image *out);

enum esr_exr_pixel { ESR_EXR_HALF, ESR_EXR_FLOAT, ESR_EXR_UINT };
enum esr_exr_compression { ESR_EXR_NONE, ESR_EXR_RLE, ESR_EXR_ZIPS, ESR_EXR_ZIP, ESR_EXR_PIZ };
/* Writes a scanline EXR with channels R,G,B(,A) (1 channel: Y; 2 channels: Y,A) of the given
 * pixel type (UINT rounds and clamps to [0, 2^32)) and compression. Written atomically. */
int esr_exr_write_as(const char *path, const struct esr_image *img, enum esr_exr_pixel pixel,
                     enum esr_exr_compression compression);
/* One part holding n layers of one size and channel count (light groups, `esr lightmix`):
 * layer l's channels named "<names[l]>.R" and so on, as compositors read layers; names of 1 to
 * 64 letters, digits or _, at most 64 layers. Written atomically. */
int esr_exr_write_layers(const char *path, const struct esr_image *layers,
                         const char *const *names, int n, enum esr_exr_pixel pixel,
                         enum esr_exr_compression compression);
/* Shorthand: half = 1 for 16-bit floats, else 32-bit float; ZIP compression. */
int esr_exr_write(const char *path, const struct esr_image *img, int half);

/* JPEG (libjpeg-turbo), 8-bit grey (1 channel) or colour (3 channels, RGB), values the code
 * values / 255. esr_jpeg_read turns the pixels upright by the EXIF orientation tag (a portrait
 * photo stored sideways comes out portrait); esr_jpeg_read_stored keeps them as stored, which is
 * what COLMAP's cameras describe (COLMAP ignores the tag). Fails naming the file when it is not a
 * JPEG, is truncated or corrupt, or is CMYK. */
int esr_jpeg_read(const char *path, struct esr_image *out);
int esr_jpeg_read_stored(const char *path, struct esr_image *out);
/* The same from size bytes in memory (name stands for the file in messages): upright 1 as
 * esr_jpeg_read, 0 as esr_jpeg_read_stored. Both refuse a header that claims more than
 * esr_limits()->image_pixels pixels before allocating. */
int esr_jpeg_decode(const void *bytes, size_t size, const char *name, int upright, struct esr_image *out);

/* img's first three channels (a fourth, alpha, is dropped; one channel is written as grey RGB),
 * clipped to [0, 1], as a JPEG of quality 1..100 (libjpeg's 4:2:0 defaults); app1, when not
 * NULL, is written as the APP1 segment (an EXIF payload "Exif\0\0" + TIFF). */
int esr_jpeg_write(const char *path, const struct esr_image *img, int quality, const unsigned char *app1,
                   size_t app1_size);

/* Dispatch on the extension (.png / .exr / .jpg / .jpeg, case-insensitive). */
int esr_image_read(const char *path, struct esr_image *out);
/* 1 when path ends in .exr (any case): linear values, premultiplied alpha; PNG and JPEG hold
 * sRGB-encoded values with straight alpha. */
int esr_image_is_exr(const char *path);

/* Straight-alpha RGBA (as in the dataset PNGs) -> RGB on background bg: c = rgb*a + bg*(1-a).
 * Accepts 3-channel input unchanged, and grey (+ alpha) with the grey in all three channels.
 * Output is a new 3-channel image. */
int esr_image_composite(const struct esr_image *rgba, const float bg[3], struct esr_image *rgb);
/* Premultiplied RGBA (EXR) -> RGB on background bg: c = rgb + bg*(1-a). */
int esr_image_composite_premultiplied(const struct esr_image *rgba, const float bg[3], struct esr_image *rgb);

#endif
