/* EXR round trips for every pixel type and write compression, named layers in one part (light
 * groups), half conversion, bad files, and the lamp scene's EXR/PNG relation (which catches
 * swapped channels). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/colour.h"
#include "core/error.h"
#include "io/half.h"
#include "io/image.h"
#include "test_support.h"

/* Distinct values per channel (so a channel swap shows), HDR range, negative values too. The
 * lower half is hashed noise, which does not compress: codecs must then store chunks raw. */
static float pattern(int x, int y, int c)
{
    if (y < 35)
        return (float)(c + 1) * 0.37f + (float)x * 0.25f - (float)y * 0.125f;
    uint32_t h = (uint32_t)x * 73856093u ^ (uint32_t)y * 19349663u ^ (uint32_t)c * 83492791u;
    h ^= h >> 13;
    h *= 0x5bd1e995u;
    h ^= h >> 15;
    return (float)(h % 100000u) / 12500.0f - 4.0f;
}

static void test_half_conversion(void **state)
{
    (void)state;
    assert_int_equal(esr_float_to_half(1.0f), 0x3c00);
    assert_int_equal(esr_float_to_half(-2.0f), 0xc000);
    assert_int_equal(esr_float_to_half(65504.0f), 0x7bff);
    assert_int_equal(esr_float_to_half(65520.0f), 0x7c00);       /* rounds to infinity */
    assert_int_equal(esr_float_to_half(5.9604645e-8f), 0x0001);  /* smallest subnormal */
    assert_int_equal(esr_float_to_half(2.9802322e-8f), 0x0000);  /* half of it: tie to even */
    assert_int_equal(esr_float_to_half(1.0f + 1.0f / 2048.0f), 0x3c00); /* tie to even (down) */
    assert_int_equal(esr_float_to_half(1.0f + 3.0f / 2048.0f), 0x3c02); /* tie to even (up) */
    assert_true(isnan(esr_half_to_float(esr_float_to_half(NAN))));
    /* Every finite half survives half -> float -> half. */
    for (uint32_t h = 0; h < 0x10000u; h++) {
        if ((h & 0x7c00u) == 0x7c00u)
            continue;
        float f = esr_half_to_float((uint16_t)h);
        assert_int_equal(esr_float_to_half(f), h);
    }
    assert_float_equal(esr_half_to_float(0x3555), 0.333251953125f, 0.0);
    assert_float_equal(esr_half_to_float(0x0001), 5.9604645e-8f, 0.0);
}

static void round_trip(int channels, enum esr_exr_pixel pixel, enum esr_exr_compression compression)
{
    char path[1100];
    snprintf(path, sizeof path, "%s/rt_%d_%d_%d.exr", test_tmpdir, channels, (int)pixel, (int)compression);
    /* Taller than one ZIP/PIZ block (16/32 lines) so several chunks and a partial last one occur. */
    int w = 13, h = 70;
    struct esr_image img, back;
    assert_int_equal(esr_image_alloc(&img, w, h, channels), ESR_OK);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int c = 0; c < channels; c++) {
                float v = pattern(x, y, c);
                img.data[((size_t)y * (size_t)w + (size_t)x) * (size_t)channels + (size_t)c] =
                    pixel == ESR_EXR_UINT ? roundf(fabsf(v) * 100.0f) : v;
            }
    assert_int_equal(esr_exr_write_as(path, &img, pixel, compression), ESR_OK);
    assert_int_equal(esr_exr_read(path, &back), ESR_OK);
    assert_int_equal(back.width, w);
    assert_int_equal(back.height, h);
    assert_int_equal(back.channels, 4);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            const float *src = img.data + ((size_t)y * (size_t)w + (size_t)x) * (size_t)channels;
            const float *got = back.data + ((size_t)y * (size_t)w + (size_t)x) * 4;
            float expect[4];
            for (int c = 0; c < 3; c++) /* 1 and 2 channels are Y(,A): Y fills R,G,B */
                expect[c] = channels >= 3 ? src[c] : src[0];
            expect[3] = channels == 4 ? src[3] : channels == 2 ? src[1] : 1.0f;
            for (int c = 0; c < 4; c++) {
                float e = pixel == ESR_EXR_HALF ? esr_half_to_float(esr_float_to_half(expect[c])) : expect[c];
                if (got[c] != e)
                    fail_msg("channels %d pixel %d compression %d at (%d,%d,%d): got %g expected %g", channels,
                             (int)pixel, (int)compression, x, y, c, (double)got[c], (double)e);
            }
        }
    esr_image_free(&img);
    esr_image_free(&back);
}

static void test_round_trips(void **state)
{
    (void)state;
    for (int comp = ESR_EXR_NONE; comp <= ESR_EXR_PIZ; comp++) {
        for (int pixel = ESR_EXR_HALF; pixel <= ESR_EXR_UINT; pixel++)
            round_trip(4, (enum esr_exr_pixel)pixel, (enum esr_exr_compression)comp);
        for (int c = 1; c <= 3; c++)
            round_trip(c, ESR_EXR_HALF, (enum esr_exr_compression)comp);
    }
    round_trip(3, ESR_EXR_FLOAT, ESR_EXR_ZIP);
}

/* Three named RGB layers in one file (esr_exr_write_layers) read back layer by layer, each its own
 * pixels (the header sorts the channels by name: light_1 before off); an absent layer and bad
 * layer names are refused naming the file. */
static void test_layers(void **state)
{
    (void)state;
    char path[4200];
    snprintf(path, sizeof path, "%s/layers.exr", test_tmpdir);
    struct esr_image img[3];
    static const char *const names[3] = {"off", "light_1", "light_1_value"};
    for (int l = 0; l < 3; l++) {
        assert_int_equal(esr_image_alloc(&img[l], 37, 41, 3), ESR_OK);
        for (int y = 0; y < 41; y++)
            for (int x = 0; x < 37; x++)
                for (int c = 0; c < 3; c++)
                    img[l].data[((size_t)y * 37 + x) * 3 + c] = pattern(x, y, c) + 10.0f * (float)l;
    }
    assert_int_equal(esr_exr_write_layers(path, img, names, 3, ESR_EXR_FLOAT, ESR_EXR_ZIP), ESR_OK);
    for (int l = 0; l < 3; l++) {
        struct esr_image back;
        if (esr_exr_read_layer(path, names[l], &back) != ESR_OK)
            fail_msg("%s", esr_error_message());
        assert_int_equal(back.width, 37);
        assert_int_equal(back.height, 41);
        for (size_t p = 0; p < 37 * 41; p++)
            for (int c = 0; c < 3; c++)
                assert_true(back.data[p * 4 + c] == img[l].data[p * 3 + c]);
        esr_image_free(&back);
    }
    struct esr_image none;
    esr_error_clear();
    assert_int_equal(esr_exr_read_layer(path, "light_2", &none), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "has no layer 'light_2'"));
    assert_non_null(strstr(esr_error_message(), path));
    static const char *const bad[3] = {"off", "light 1", "x"};
    esr_error_clear();
    assert_int_equal(esr_exr_write_layers(path, img, bad, 3, ESR_EXR_HALF, ESR_EXR_ZIP), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "layer name 'light 1'"));
    esr_error_clear();
    img[2].width = 36;
    assert_int_equal(esr_exr_write_layers(path, img, names, 3, ESR_EXR_HALF, ESR_EXR_ZIP), ESR_ERR);
    img[2].width = 37;
    esr_error_clear();
    for (int l = 0; l < 3; l++)
        esr_image_free(&img[l]);
}

static void expect_read_error(const char *path)
{
    struct esr_image img;
    esr_error_clear();
    assert_int_equal(esr_exr_read(path, &img), ESR_ERR);
    assert_null(img.data);
    if (!strstr(esr_error_message(), path))
        fail_msg("message '%s' does not name '%s'", esr_error_message(), path);
    esr_error_clear();
}

static void write_bytes(const char *path, const unsigned char *data, size_t n)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, n, f), n);
    assert_int_equal(fclose(f), 0);
}

static void test_bad_files(void **state)
{
    (void)state;
    char path[1100], bad[1100];
    snprintf(path, sizeof path, "%s/missing.exr", test_tmpdir);
    expect_read_error(path);
    snprintf(path, sizeof path, "%s/garbage.exr", test_tmpdir);
    assert_int_equal(test_write_file(path, "not an exr"), 0);
    expect_read_error(path);

    snprintf(path, sizeof path, "%s/whole.exr", test_tmpdir);
    struct esr_image img;
    assert_int_equal(esr_image_alloc(&img, 40, 40, 4), ESR_OK);
    for (size_t i = 0; i < esr_image_count(&img); i++)
        img.data[i] = (float)(i % 17) * 0.3f;
    assert_int_equal(esr_exr_write_as(path, &img, ESR_EXR_HALF, ESR_EXR_ZIP), ESR_OK);
    esr_image_free(&img);
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    static unsigned char buf[1 << 16];
    size_t n = fread(buf, 1, sizeof buf, f);
    fclose(f);
    assert_true(n > 400 && n < sizeof buf);

    snprintf(bad, sizeof bad, "%s/truncated.exr", test_tmpdir);
    write_bytes(bad, buf, n - 200);
    expect_read_error(bad);
    snprintf(bad, sizeof bad, "%s/header_only.exr", test_tmpdir);
    write_bytes(bad, buf, 60);
    expect_read_error(bad);
    /* Garbage over the compressed data of the chunks. */
    for (size_t i = n - 300; i < n; i++)
        buf[i] ^= 0xa5;
    snprintf(bad, sizeof bad, "%s/corrupt.exr", test_tmpdir);
    write_bytes(bad, buf, n);
    expect_read_error(bad);
}

/* FORMAT.md: PNG = srgb_oetf(clip(rgb_exr / A, 0, 1)) quantised to 8 bits, for A > 0. */
static void test_lamp_exr_matches_png(void **state)
{
    (void)state;
    const char *scene = test_shared_scene("lamp");
    if (!scene)
        skip();
    const char *names[2] = {"c003_on", "c010_off"};
    for (int i = 0; i < 2; i++) {
        char exr_path[1200], png_path[1200];
        snprintf(exr_path, sizeof exr_path, "%s/test_nv/exr/%s.exr", scene, names[i]);
        snprintf(png_path, sizeof png_path, "%s/test_nv/%s.png", scene, names[i]);
        struct esr_image exr, png;
        assert_int_equal(esr_exr_read(exr_path, &exr), ESR_OK);
        assert_int_equal(esr_png_read(png_path, &png), ESR_OK);
        assert_int_equal(exr.width, 160);
        assert_int_equal(exr.height, 160);
        assert_int_equal(png.channels, 4);
        size_t n = 160 * 160, checked = 0;
        double max_err = 0.0;
        for (size_t p = 0; p < n; p++) {
            float a = exr.data[p * 4 + 3];
            if (a <= 0.5f)
                continue;
            for (int c = 0; c < 3; c++) {
                float lin = exr.data[p * 4 + (size_t)c] / a;
                lin = lin < 0.0f ? 0.0f : lin > 1.0f ? 1.0f : lin;
                double err = fabs((double)esr_srgb_from_linear(lin) - (double)png.data[p * 4 + (size_t)c]);
                max_err = err > max_err ? err : max_err;
            }
            checked++;
        }
        assert_true(checked > 1000);
        /* Half precision + 8-bit rounding: a couple of code values at most. */
        if (max_err > 2.5 / 255.0)
            fail_msg("%s: max |srgb(exr) - png| = %g", names[i], max_err);
        esr_image_free(&exr);
        esr_image_free(&png);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_half_conversion),
        cmocka_unit_test(test_round_trips),
        cmocka_unit_test(test_layers),
        cmocka_unit_test(test_bad_files),
        cmocka_unit_test(test_lamp_exr_matches_png),
    };
    return cmocka_run_group_tests(tests, test_setup_tmpdir, test_teardown_tmpdir);
}
