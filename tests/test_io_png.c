/* PNG round trips at 8 and 16 bits for 1-4 channels, clamping, and clear errors on bad files. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "io/image.h"
#include "test_support.h"

/* Values with an exact code value plus some off-grid ones, so rounding is exercised. */
static void fill_pattern(struct esr_image *img)
{
    for (size_t i = 0; i < esr_image_count(img); i++)
        img->data[i] = (float)((i * 37u) % 101u) / 100.0f;
}

static void round_trip(int channels, int bits)
{
    char path[1100];
    snprintf(path, sizeof path, "%s/rt_%d_%d.png", test_tmpdir, channels, bits);
    struct esr_image img, back;
    assert_int_equal(esr_image_alloc(&img, 7, 5, channels), ESR_OK);
    fill_pattern(&img);
    assert_int_equal(esr_png_write(path, &img, bits), ESR_OK);
    assert_int_equal(esr_png_read(path, &back), ESR_OK);
    assert_int_equal(back.width, 7);
    assert_int_equal(back.height, 5);
    assert_int_equal(back.channels, channels);
    float maxv = bits == 16 ? 65535.0f : 255.0f;
    for (size_t i = 0; i < esr_image_count(&img); i++) {
        float expect = roundf(img.data[i] * maxv) / maxv;
        assert_float_equal(back.data[i], expect, 1e-6);
    }
    esr_image_free(&img);
    esr_image_free(&back);
}

static void test_round_trips(void **state)
{
    (void)state;
    for (int c = 1; c <= 4; c++) {
        round_trip(c, 8);
        round_trip(c, 16);
    }
}

static void test_clamps_out_of_range(void **state)
{
    (void)state;
    char path[1100];
    snprintf(path, sizeof path, "%s/clamp.png", test_tmpdir);
    struct esr_image img, back;
    assert_int_equal(esr_image_alloc(&img, 4, 1, 1), ESR_OK);
    img.data[0] = -0.5f;
    img.data[1] = 2.0f;
    img.data[2] = NAN;
    img.data[3] = 0.5f;
    assert_int_equal(esr_png_write(path, &img, 8), ESR_OK);
    assert_int_equal(esr_png_read(path, &back), ESR_OK);
    assert_float_equal(back.data[0], 0.0f, 0.0);
    assert_float_equal(back.data[1], 1.0f, 0.0);
    assert_float_equal(back.data[2], 0.0f, 0.0);
    assert_float_equal(back.data[3], 128.0f / 255.0f, 1e-6);
    esr_image_free(&img);
    esr_image_free(&back);
}

static void expect_read_error(const char *path, const char *fragment)
{
    struct esr_image img;
    esr_error_clear();
    assert_int_equal(esr_png_read(path, &img), ESR_ERR);
    assert_null(img.data);
    assert_non_null(strstr(esr_error_message(), path));
    if (fragment && !strstr(esr_error_message(), fragment))
        fail_msg("message '%s' lacks '%s'", esr_error_message(), fragment);
    esr_error_clear();
}

static void test_bad_files(void **state)
{
    (void)state;
    char path[1100], bad[1100];
    snprintf(path, sizeof path, "%s/missing.png", test_tmpdir);
    expect_read_error(path, "cannot open");

    snprintf(path, sizeof path, "%s/garbage.png", test_tmpdir);
    assert_int_equal(test_write_file(path, "this is not a png file at all"), 0);
    expect_read_error(path, NULL);

    /* A valid PNG cut in half. */
    snprintf(path, sizeof path, "%s/whole.png", test_tmpdir);
    struct esr_image img;
    assert_int_equal(esr_image_alloc(&img, 32, 32, 4), ESR_OK);
    fill_pattern(&img);
    assert_int_equal(esr_png_write(path, &img, 8), ESR_OK);
    esr_image_free(&img);
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    char buf[8192];
    size_t n = fread(buf, 1, sizeof buf, f);
    fclose(f);
    snprintf(bad, sizeof bad, "%s/truncated.png", test_tmpdir);
    f = fopen(bad, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(buf, 1, n / 2, f), n / 2);
    fclose(f);
    expect_read_error(bad, NULL);

    /* Flipped bytes inside the image data (CRC mismatch). */
    buf[n / 2] ^= 0x5a;
    snprintf(bad, sizeof bad, "%s/corrupt.png", test_tmpdir);
    f = fopen(bad, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(buf, 1, n, f), n);
    fclose(f);
    expect_read_error(bad, NULL);
}

static void test_write_errors(void **state)
{
    (void)state;
    struct esr_image img;
    assert_int_equal(esr_image_alloc(&img, 2, 2, 3), ESR_OK);
    esr_error_clear();
    assert_int_equal(esr_png_write("/nonexistent-dir/x.png", &img, 8), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "/nonexistent-dir/x.png"));
    esr_error_clear();
    char path[1100];
    snprintf(path, sizeof path, "%s/bits.png", test_tmpdir);
    assert_int_equal(esr_png_write(path, &img, 12), ESR_ERR);
    esr_error_clear();
    esr_image_free(&img);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_round_trips),
        cmocka_unit_test(test_clamps_out_of_range),
        cmocka_unit_test(test_bad_files),
        cmocka_unit_test(test_write_errors),
    };
    return cmocka_run_group_tests(tests, test_setup_tmpdir, test_teardown_tmpdir);
}
