/* JPEG files through libjpeg(-turbo). libjpeg reports fatal errors by calling error_exit, which
 * by default exits the process; here it longjmps back with the message, so a corrupt file is an
 * error naming it. Warnings that mean the pixels are wrong (data ends early, corrupt entropy
 * data) are errors too: a grey-filled photo would silently train a wrong scene. */
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <jerror.h>
#include <jpeglib.h>

#include "core/error.h"
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
    if (level >= 0 || f->bad_data)
        return; /* trace messages, and only the first warning is kept */
    int harmless = f->mgr.msg_code == JWRN_EXTRANEOUS_DATA; /* junk between markers, pixels intact */
    if (!harmless) {
        f->bad_data = 1;
        f->mgr.format_message(info, f->message);
    }
}

/* Pixel data larger than this is refused before decoding (a corrupt header can claim 65535^2). */
#define JPEG_MAX_PIXELS (256L << 20)

/* The decoder's work once the header is read: grey stays 1 channel, everything else RGB. */
static int decode(struct jpeg_decompress_struct *d, const char *path, struct esr_image *out)
{
    d->out_color_space = d->num_components == 1 ? JCS_GRAYSCALE : JCS_RGB;
    if (d->jpeg_color_space == JCS_CMYK || d->jpeg_color_space == JCS_YCCK)
        return ESR_FAIL("'%s' is a CMYK JPEG; esr reads grey and colour (RGB/YCbCr) JPEGs", path);
    if ((long)d->image_width * (long)d->image_height > JPEG_MAX_PIXELS)
        return ESR_FAIL("'%s': %ux%u pixels is more than esr decodes", path, d->image_width, d->image_height);
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

/* Decodes path; *orientation receives the EXIF orientation. */
static int jpeg_decode_file(const char *path, struct esr_image *out, int *orientation)
{
    out->data = NULL;
    out->width = out->height = out->channels = 0;
    unsigned char *bytes;
    size_t size;
    ESR_TRY(esr_file_read_all(path, &bytes, &size));
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
        status = ESR_FAIL("'%s' is not a valid JPEG: %s", path, fail.message);
    } else {
        jpeg_create_decompress(&d);
        jpeg_mem_src(&d, bytes, (unsigned long)size);
        jpeg_save_markers(&d, JPEG_APP0 + 1, 0xffff);
        jpeg_read_header(&d, TRUE);
        *orientation = saved_orientation(&d);
        status = decode(&d, path, target);
        if (status == ESR_OK && fail.bad_data) {
            esr_image_free(target);
            status = ESR_FAIL("'%s' is a corrupt or truncated JPEG: %s", path, fail.message);
        }
    }
    jpeg_destroy_decompress(&d);
    free(bytes);
    return status;
}

int esr_jpeg_read_stored(const char *path, struct esr_image *out)
{
    int orientation;
    return jpeg_decode_file(path, out, &orientation);
}

int esr_jpeg_read(const char *path, struct esr_image *out)
{
    memset(out, 0, sizeof *out);
    int orientation = 1;
    struct esr_image stored;
    ESR_TRY(jpeg_decode_file(path, &stored, &orientation));
    if (orientation == 1) {
        *out = stored;
        return ESR_OK;
    }
    int status = esr_image_orient(&stored, orientation, out);
    esr_image_free(&stored);
    return status;
}
