/* JPEG files through libjpeg(-turbo). libjpeg reports fatal errors by calling error_exit, which
 * by default exits the process; here it longjmps back with the message, so a corrupt file is an
 * error naming it. Warnings that mean the pixels are wrong (data ends early, corrupt entropy
 * data) are errors too, and stop the decoding at once: a grey-filled photo would silently train
 * a wrong scene, and a few hundred bytes claiming a large image would otherwise be decoded in
 * full only to be refused. */
#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <jerror.h>
#include <jpeglib.h>

#include "core/error.h"
#include "core/limits.h"
#include "io/exif.h"
#include "io/file.h"
#include "io/image.h"

struct jpeg_failure {
    struct jpeg_error_mgr mgr;
    jmp_buf back;
    char message[JMSG_LENGTH_MAX];
    int bad_data; /* a warning that the decoded pixels are not the photo's */
};

static void on_error(j_common_ptr info)
{
    struct jpeg_failure *f = (struct jpeg_failure *)info->err;
    f->mgr.format_message(info, f->message);
    longjmp(f->back, 1);
}

static void on_message(j_common_ptr info, int level)
{
    struct jpeg_failure *f = (struct jpeg_failure *)info->err;
    /* trace messages, and junk between markers (the pixels are intact) */
    if (level >= 0 || f->mgr.msg_code == JWRN_EXTRANEOUS_DATA)
        return;
    f->bad_data = 1;
    f->mgr.format_message(info, f->message);
    longjmp(f->back, 1);
}

/* The decoder's work once the header is read: grey stays 1 channel, everything else RGB. A
 * header claiming more than esr_limits()->image_pixels is refused before anything is allocated. */
static int decode(struct jpeg_decompress_struct *d, const char *path, struct esr_image *out)
{
    d->out_color_space = d->num_components == 1 ? JCS_GRAYSCALE : JCS_RGB;
    if (d->jpeg_color_space == JCS_CMYK || d->jpeg_color_space == JCS_YCCK)
        return ESR_FAIL("'%s' is a CMYK JPEG; esr reads grey and colour (RGB/YCbCr) JPEGs", path);
    if ((uint64_t)d->image_width * d->image_height > esr_limits()->image_pixels)
        return ESR_FAIL("'%s': JPEG claims %ux%u pixels, more than the %zu esr reads", path, d->image_width,
                        d->image_height, esr_limits()->image_pixels);
    jpeg_start_decompress(d);
    const int w = (int)d->output_width, h = (int)d->output_height, c = d->output_components;
    ESR_TRY(esr_image_alloc(out, w, h, c));
    /* from the decoder's own pool, so a longjmp out of jpeg_read_scanlines leaks nothing */
    JSAMPARRAY rows = d->mem->alloc_sarray((j_common_ptr)d, JPOOL_IMAGE, (JDIMENSION)(w * c), 1);
    while ((int)d->output_scanline < h) {
        float *dst = out->data + (size_t)d->output_scanline * (size_t)w * (size_t)c;
        jpeg_read_scanlines(d, rows, 1);
        for (int i = 0; i < w * c; i++)
            dst[i] = (float)rows[0][i] * (1.0f / 255.0f);
    }
    jpeg_finish_decompress(d);
    return ESR_OK;
}

/* The orientation from the first EXIF APP1 segment the decoder saved (1 when none). */
static int saved_orientation(const struct jpeg_decompress_struct *d)
{
    for (jpeg_saved_marker_ptr m = d->marker_list; m; m = m->next)
        if (m->marker == JPEG_APP0 + 1) {
            int o = esr_exif_orientation(m->data, m->data_length);
            if (o != 1)
                return o;
        }
    return 1;
}

/* Decodes the stored pixels; *orientation receives the EXIF orientation. */
static int decode_stored(const void *bytes, size_t size, const char *name, struct esr_image *out, int *orientation)
{
    memset(out, 0, sizeof *out); /* a longjmp before the pixels are allocated frees NULL */
    struct jpeg_decompress_struct d;
    struct jpeg_failure fail;
    memset(&fail, 0, sizeof fail);
    d.err = jpeg_std_error(&fail.mgr);
    fail.mgr.error_exit = on_error;
    fail.mgr.emit_message = on_message;
    int status = ESR_OK;
    /* volatile: out is written between setjmp and a possible longjmp */
    struct esr_image *volatile target = out;
    if (setjmp(fail.back)) {
        esr_image_free(target);
        status = fail.bad_data ? ESR_FAIL("'%s' is a corrupt or truncated JPEG: %s", name, fail.message)
                               : ESR_FAIL("'%s' is not a valid JPEG: %s", name, fail.message);
    } else {
        jpeg_create_decompress(&d);
        jpeg_mem_src(&d, bytes, (unsigned long)size);
        jpeg_save_markers(&d, JPEG_APP0 + 1, 0xffff);
        jpeg_read_header(&d, TRUE);
        *orientation = saved_orientation(&d);
        status = decode(&d, name, target);
    }
    jpeg_destroy_decompress(&d);
    return status;
}

int esr_jpeg_decode(const void *bytes, size_t size, const char *name, int upright, struct esr_image *out)
{
    memset(out, 0, sizeof *out);
    int orientation = 1;
    struct esr_image stored;
    ESR_TRY(decode_stored(bytes, size, name, &stored, &orientation));
    if (!upright || orientation == 1) {
        *out = stored;
        return ESR_OK;
    }
    int status = esr_image_orient(&stored, orientation, out);
    esr_image_free(&stored);
    return status;
}

static int read_file(const char *path, int upright, struct esr_image *out)
{
    memset(out, 0, sizeof *out);
    unsigned char *bytes;
    size_t size;
    ESR_TRY(esr_file_read_all(path, &bytes, &size));
    int status = esr_jpeg_decode(bytes, size, path, upright, out);
    free(bytes);
    return status;
}

int esr_jpeg_read_stored(const char *path, struct esr_image *out)
{
    return read_file(path, 0, out);
}

int esr_jpeg_read(const char *path, struct esr_image *out)
{
    return read_file(path, 1, out);
}

/* The compressor's work on an open file: rows of 8-bit RGB from the first three channels. */
static void encode(struct jpeg_compress_struct *c, const struct esr_image *img, int quality,
                   const unsigned char *app1, size_t app1_size, unsigned char *row)
{
    c->image_width = (JDIMENSION)img->width;
    c->image_height = (JDIMENSION)img->height;
    c->input_components = 3;
    c->in_color_space = JCS_RGB;
    jpeg_set_defaults(c);
    jpeg_set_quality(c, quality, TRUE);
    jpeg_start_compress(c, TRUE);
    if (app1)
        jpeg_write_marker(c, JPEG_APP0 + 1, app1, (unsigned)app1_size);
    while (c->next_scanline < c->image_height) {
        const float *src = img->data + (size_t)c->next_scanline * (size_t)img->width * (size_t)img->channels;
        for (int x = 0; x < img->width; x++)
            for (int k = 0; k < 3; k++) {
                const float v = src[(size_t)x * (size_t)img->channels + (size_t)(img->channels >= 3 ? k : 0)];
                row[3 * x + k] = (JSAMPLE)lroundf(fminf(fmaxf(v, 0.0f), 1.0f) * 255.0f);
            }
        jpeg_write_scanlines(c, &row, 1);
    }
    jpeg_finish_compress(c);
}

int esr_jpeg_write(const char *path, const struct esr_image *img, int quality, const unsigned char *app1,
                   size_t app1_size)
{
    if (quality < 1 || quality > 100)
        return ESR_FAIL("%s: JPEG quality %d is out of range 1..100", path, quality);
    if (app1 && app1_size > 65533)
        return ESR_FAIL("%s: EXIF segment of %zu bytes is over JPEG's 65533", path, app1_size);
    FILE *f = fopen(path, "wb");
    if (!f)
        return ESR_FAIL("cannot create '%s': %s", path, strerror(errno));
    unsigned char *row = malloc((size_t)img->width * 3);
    if (!row) {
        fclose(f);
        return ESR_FAIL("%s: out of memory", path);
    }
    struct jpeg_compress_struct c;
    struct jpeg_failure fail;
    memset(&fail, 0, sizeof fail);
    c.err = jpeg_std_error(&fail.mgr);
    fail.mgr.error_exit = on_error;
    int rc = ESR_OK;
    jpeg_create_compress(&c);
    if (setjmp(fail.back) == 0) {
        jpeg_stdio_dest(&c, f);
        encode(&c, img, quality, app1, app1_size, row);
    } else {
        rc = ESR_FAIL("%s: %s", path, fail.message);
    }
    jpeg_destroy_compress(&c);
    free(row);
    if (fclose(f) != 0 && rc == ESR_OK)
        rc = ESR_FAIL("cannot write '%s': %s", path, strerror(errno));
    return rc;
}
