/* Image allocation, extension dispatch and the two compositing formulas. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "core/error.h"
#include "io/image.h"

static void test_composite(void **state)
{
    (void)state;
    struct esr_image rgba, out;
    assert_int_equal(esr_image_alloc(&rgba, 2, 1, 4), ESR_OK);
    const float px[8] = {1.0f, 0.5f, 0.0f, 0.25f, 0.2f, 0.4f, 0.6f, 1.0f};
    memcpy(rgba.data, px, sizeof px);
    const float bg[3] = {1.0f, 0.0f, 0.5f};
    /* straight alpha: c = rgb * a + bg * (1 - a) */
    assert_int_equal(esr_image_composite(&rgba, bg, &out), ESR_OK);
    assert_int_equal(out.channels, 3);
    const float straight[6] = {1.0f * 0.25f + 0.75f, 0.5f * 0.25f, 0.0f + 0.5f * 0.75f, 0.2f, 0.4f, 0.6f};
    for (int i = 0; i < 6; i++)
        assert_float_equal(out.data[i], straight[i], 1e-6);
    esr_image_free(&out);
    /* premultiplied: c = rgb + bg * (1 - a) */
    assert_int_equal(esr_image_composite_premultiplied(&rgba, bg, &out), ESR_OK);
    const float premul[6] = {1.0f + 0.75f, 0.5f, 0.5f * 0.75f, 0.2f, 0.4f, 0.6f};
    for (int i = 0; i < 6; i++)
        assert_float_equal(out.data[i], premul[i], 1e-6);
    esr_image_free(&out);
    esr_image_free(&rgba);
    /* grey stands for all three channels; grey + alpha composites like RGBA */
    struct esr_image grey;
    assert_int_equal(esr_image_alloc(&grey, 2, 1, 2), ESR_OK);
    const float ga[4] = {0.8f, 0.5f, 0.3f, 1.0f};
    memcpy(grey.data, ga, sizeof ga);
    assert_int_equal(esr_image_composite(&grey, bg, &out), ESR_OK);
    const float expanded[6] = {0.4f + 0.5f, 0.4f, 0.4f + 0.25f, 0.3f, 0.3f, 0.3f};
    for (int i = 0; i < 6; i++)
        assert_float_equal(out.data[i], expanded[i], 1e-6);
    esr_image_free(&out);
    esr_image_free(&grey);
}

static void test_alloc_and_dispatch(void **state)
{
    (void)state;
    struct esr_image img;
    esr_error_clear();
    assert_int_equal(esr_image_alloc(&img, 0, 4, 3), ESR_ERR);
    assert_null(img.data);
    assert_int_equal(esr_image_alloc(&img, 4, 4, 5), ESR_ERR);
    esr_error_clear();
    assert_int_equal(esr_image_read("/tmp/picture.jpg", &img), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "picture.jpg"));
    esr_error_clear();
    assert_int_equal(esr_image_read("/nonexistent/x.EXR", &img), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "/nonexistent/x.EXR"));
    esr_error_clear();
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_composite),
        cmocka_unit_test(test_alloc_and_dispatch),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
