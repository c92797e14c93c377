/* Image headers that claim more pixels than esr reads (esr_limits()->image_pixels, 2^28 by
 * default) are refused with a message before any pixel is allocated: a PNG and an EXR claiming
 * 100000 x 100000 pixels and a JPEG claiming 60000 x 60000 in a few hundred bytes, and the limit
 * itself. */
#define _GNU_SOURCE /* memmem */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include <jpeglib.h> /* after stdio.h, which it needs */

#include "core/error.h"
#include "core/limits.h"
#include "io/file.h"
#include "io/image.h"
#include "test_support.h"

static void put_be32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)(v >> 24), p[1] = (uint8_t)(v >> 16), p[2] = (uint8_t)(v >> 8), p[3] = (uint8_t)v;
}

/* A PNG signature and a valid IHDR (RGBA8) of w x h pixels, and nothing else. */
static size_t png_header(uint8_t *out, uint32_t w, uint32_t h)
{
    static const uint8_t signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    memcpy(out, signature, 8);
    put_be32(out + 8, 13);
    memcpy(out + 12, "IHDR", 4);
    put_be32(out + 16, w);
    put_be32(out + 20, h);
    const uint8_t rest[5] = {8, 6, 0, 0, 0}; /* depth 8, RGBA, deflate, no filter, no interlace */
    memcpy(out + 24, rest, 5);
    put_be32(out + 29, (uint32_t)crc32(0, out + 12, 17));
    return 33;
}

static void expect_refused(int status, const char *what)
{
    assert_int_equal(status, ESR_ERR);
    if (!strstr(esr_error_message(), what))
        fail_msg("message '%s' should say '%s'", esr_error_message(), what);
    esr_error_clear();
}

static void test_png_claims_too_much(void **state)
{
    (void)state;
    uint8_t png[64];
    size_t n = png_header(png, 100000, 100000);
    struct esr_image img;
    expect_refused(esr_png_decode(png, n, "huge.png", &img), "'huge.png': PNG claims 100000x100000 pixels");
    assert_null(img.data);
}

/* esr's own 4x4 EXR with its data window rewritten to claim 100000 x 100000 pixels. */
static void test_exr_claims_too_much(void **state)
{
    (void)state;
    char path[1100];
    snprintf(path, sizeof path, "%s/small.exr", test_tmpdir);
    struct esr_image img;
    assert_int_equal(esr_image_alloc(&img, 4, 4, 4), ESR_OK);
    assert_int_equal(esr_exr_write_as(path, &img, ESR_EXR_FLOAT, ESR_EXR_NONE), ESR_OK);
    esr_image_free(&img);
    unsigned char *exr;
    size_t n;
    assert_int_equal(esr_file_read_all(path, &exr, &n), ESR_OK);
    static const char key[] = "dataWindow\0box2i"; /* then the size (16) and xmin ymin xmax ymax */
    unsigned char *at = memmem(exr, n, key, sizeof key);
    assert_non_null(at);
    const int32_t xmax = 99999, ymax = 99999;
    memcpy(at + sizeof key + 4 + 8, &xmax, 4);
    memcpy(at + sizeof key + 4 + 12, &ymax, 4);
    expect_refused(esr_exr_decode(exr, n, "huge.exr", &img), "'huge.exr': EXR claims 100000x100000 pixels");
    assert_null(img.data);
    free(exr);
}

/* An 8x8 grey JPEG (libjpeg into memory) whose frame header (SOF0) then claims w x h pixels. */
static unsigned char *jpeg_claiming(unsigned w, unsigned h, unsigned long *n)
{
    struct jpeg_compress_struct c;
    struct jpeg_error_mgr err;
    c.err = jpeg_std_error(&err);
    jpeg_create_compress(&c);
    unsigned char *out = NULL;
    jpeg_mem_dest(&c, &out, n);
    c.image_width = c.image_height = 8;
    c.input_components = 1;
    c.in_color_space = JCS_GRAYSCALE;
    jpeg_set_defaults(&c);
    jpeg_start_compress(&c, TRUE);
    JSAMPLE row[8] = {0, 32, 64, 96, 128, 160, 192, 224};
    JSAMPROW rows[1] = {row};
    while (c.next_scanline < 8)
        jpeg_write_scanlines(&c, rows, 1);
    jpeg_finish_compress(&c);
    jpeg_destroy_compress(&c);
    unsigned char *sof = memmem(out, *n, "\xff\xc0", 2); /* then length, precision, height, width */
    assert_non_null(sof);
    sof[5] = (unsigned char)(h >> 8), sof[6] = (unsigned char)h, sof[7] = (unsigned char)(w >> 8), sof[8] = (unsigned char)w;
    return out;
}

static void test_jpeg_claims_too_much(void **state)
{
    (void)state;
    unsigned long n;
    unsigned char *jpeg = jpeg_claiming(60000, 60000, &n); /* libjpeg's own maximum is 65500 */
    struct esr_image img;
    expect_refused(esr_jpeg_decode(jpeg, n, "huge.jpg", 1, &img), "'huge.jpg': JPEG claims 60000x60000 pixels");
    assert_null(img.data);
    free(jpeg);
    /* within the limit but its data ends after the first 8x8 block: refused as truncated */
    jpeg = jpeg_claiming(4096, 4096, &n);
    expect_refused(esr_jpeg_decode(jpeg, n, "short.jpg", 0, &img), "'short.jpg' is a corrupt or truncated JPEG");
    assert_null(img.data);
    free(jpeg);
}

/* The limit is a setting: 16 pixels admit a 4x4 image and refuse a 5x4 one. */
static void test_limit_is_a_setting(void **state)
{
    (void)state;
    const struct esr_limits saved = *esr_limits(), tight = {16, 0};
    esr_limits_set(&tight);
    uint8_t png[64];
    size_t n = png_header(png, 5, 4);
    struct esr_image img;
    expect_refused(esr_png_decode(png, n, "five.png", &img), "more than the 16 esr reads");
    n = png_header(png, 4, 4);
    /* no image data follows: refused, but by the decoder, not by the limit */
    assert_int_equal(esr_png_decode(png, n, "four.png", &img), ESR_ERR);
    assert_null(strstr(esr_error_message(), "esr reads"));
    esr_error_clear();
    unsigned long jn;
    unsigned char *jpeg = jpeg_claiming(5, 4, &jn);
    expect_refused(esr_jpeg_decode(jpeg, jn, "five.jpg", 1, &img), "more than the 16 esr reads");
    free(jpeg);
    esr_limits_set(&saved);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_png_claims_too_much),
        cmocka_unit_test(test_exr_claims_too_much),
        cmocka_unit_test(test_jpeg_claims_too_much),
        cmocka_unit_test(test_limit_is_a_setting),
    };
    return cmocka_run_group_tests(tests, test_setup_tmpdir, test_teardown_tmpdir);
}
