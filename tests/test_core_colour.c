/* Colour maths (seed eqs. 9-15) against values computed independently in double precision. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>

#include "core/colour.h"
#include "core/rng.h"

/* {linear, encoded} pairs computed in Python 3 (double) with the seed's eq. 9:
 *   enc = lambda x: 12.92*x if x <= 0.0031308 else 1.055*x**(1/2.4) - 0.055
 * and printed with %.9g. */
static const double srgb_encode_table[][2] = {
    {0, 0},
    {0.001, 0.01292},
    {0.0031308, 0.040449936},
    {0.0031309, 0.0404511778},
    {0.01, 0.0998528227},
    {0.05, 0.247800528},
    {0.1, 0.349190213},
    {0.18, 0.46135613},
    {0.21404114, 0.499999999},
    {0.5, 0.735356983},
    {0.75, 0.880825021},
    {1, 1},
    {2, 1.35325605}, /* HDR values pass through the same curve */
    {8, 2.45422701},
};

/* {encoded, linear} pairs from the inverse, same method:
 *   dec = lambda y: y/12.92 if y <= 0.04045 else ((y+0.055)/1.055)**2.4 */
static const double srgb_decode_table[][2] = {
    {0, 0},
    {0.02, 0.00154798762},
    {0.04045, 0.00313080495},
    {0.04046, 0.00313159455},
    {0.1, 0.0100228256},
    {0.2, 0.0331047666},
    {0.5, 0.21404114},
    {0.735356983, 0.5},
    {0.9, 0.787412289},
    {1, 1},
};

#define N_OF(t) (sizeof(t) / sizeof((t)[0]))

static void test_srgb_encode_matches_reference(void **state)
{
    (void)state;
    for (size_t i = 0; i < N_OF(srgb_encode_table); i++) {
        double x = srgb_encode_table[i][0], want = srgb_encode_table[i][1];
        double got = esr_srgb_from_linear((float)x);
        assert_true(fabs(got - want) <= 2e-6 * fmax(1.0, want));
    }
}

static void test_srgb_decode_matches_reference(void **state)
{
    (void)state;
    for (size_t i = 0; i < N_OF(srgb_decode_table); i++) {
        double y = srgb_decode_table[i][0], want = srgb_decode_table[i][1];
        double got = esr_linear_from_srgb((float)y);
        assert_true(fabs(got - want) <= 2e-6 * fmax(1e-3, want));
    }
}

static void test_srgb_round_trip(void **state)
{
    (void)state;
    for (int i = 0; i <= 4000; i++) {
        float x = (float)i / 1000.0f; /* 0 .. 4, HDR included */
        float back = esr_linear_from_srgb(esr_srgb_from_linear(x));
        assert_true(fabsf(back - x) <= 1e-5f * fmaxf(1.0f, x));
        float y = (float)i / 4000.0f;
        float back_y = esr_srgb_from_linear(esr_linear_from_srgb(y));
        assert_true(fabsf(back_y - y) <= 2e-6f);
    }
}

/* The two branches meet at the knee: IEC's constants leave a jump of ~3e-8 there. */
static void test_srgb_continuous_at_knee(void **state)
{
    (void)state;
    const float knee = 0.0031308f;
    float below = esr_srgb_from_linear(knee), above = esr_srgb_from_linear(nextafterf(knee, 1.0f));
    assert_true(fabsf(above - below) < 1e-6f);
    const float knee_enc = 0.04045f;
    float dbelow = esr_linear_from_srgb(knee_enc), dabove = esr_linear_from_srgb(nextafterf(knee_enc, 1.0f));
    assert_true(fabsf(dabove - dbelow) < 1e-7f);
    /* monotone across the whole range */
    float prev = -1.0f;
    for (int i = 0; i <= 10000; i++) {
        float v = esr_srgb_from_linear((float)i * 1e-4f);
        assert_true(v >= prev);
        prev = v;
    }
}

/* The gradient agrees with a central difference (in double) away from the knee. */
static void test_srgb_gradient_matches_finite_difference(void **state)
{
    (void)state;
    const float xs[] = {0.0005f, 0.002f, 0.01f, 0.1f, 0.5f, 0.9f, 1.7f, 5.0f};
    for (size_t i = 0; i < N_OF(xs); i++) {
        double x = xs[i], h = 1e-3 * x;
        double up = x + h, dn = x - h;
        double enc_up = up <= 0.0031308 ? 12.92 * up : 1.055 * pow(up, 1 / 2.4) - 0.055;
        double enc_dn = dn <= 0.0031308 ? 12.92 * dn : 1.055 * pow(dn, 1 / 2.4) - 0.055;
        double fd = (enc_up - enc_dn) / (2 * h);
        double got = esr_srgb_from_linear_grad(xs[i]);
        assert_true(fabs(got - fd) <= 1e-4 * fabs(fd));
    }
}

/* The image error scale is the encoding's slope at the radiance floored at 0.01 linear: values
 * from the OETF's derivative written out here (1.055 / 2.4 x^(1/2.4 - 1)); constant below the
 * floor, falling above it (a bright channel's error shows less). */
static void test_image_error_scale(void **state)
{
    (void)state;
    const double floor_slope = 1.055 / 2.4 * pow(0.01, 1 / 2.4 - 1); /* 6.452 */
    const float below[] = {-1.0f, 0.0f, 0.002f, 0.0099f};
    for (size_t i = 0; i < N_OF(below); i++)
        assert_true(fabs(esr_image_error_scale(below[i]) - floor_slope) <= 1e-5 * floor_slope);
    const float xs[] = {0.01f, 0.05f, 0.5f, 1.0f, 8.0f};
    double prev = INFINITY;
    for (size_t i = 0; i < N_OF(xs); i++) {
        const double want = 1.055 / 2.4 * pow(xs[i], 1 / 2.4 - 1), got = esr_image_error_scale(xs[i]);
        if (fabs(got - want) > 1e-5 * want)
            fail_msg("x %g: %g, expected %g", (double)xs[i], got, want);
        assert_true(got < prev);
        prev = got;
    }
    assert_true(fabs(esr_image_error_scale(1.0f) - 1.055 / 2.4) <= 1e-6);
}

/* The decoding's gradient against a central difference of the sRGB EOTF written out in double. */
static void test_srgb_decode_gradient_matches_finite_difference(void **state)
{
    (void)state;
    const float xs[] = {0.01f, 0.03f, 0.05f, 0.2f, 0.5f, 0.9f, 0.999f};
    for (size_t i = 0; i < N_OF(xs); i++) {
        double x = xs[i], h = 1e-4 * x;
        double up = x + h, dn = x - h;
        double lin_up = up <= 0.04045 ? up / 12.92 : pow((up + 0.055) / 1.055, 2.4);
        double lin_dn = dn <= 0.04045 ? dn / 12.92 : pow((dn + 0.055) / 1.055, 2.4);
        double fd = (lin_up - lin_dn) / (2 * h);
        double got = esr_linear_from_srgb_grad(xs[i]);
        if (fabs(got - fd) > 1e-4 * fabs(fd))
            fail_msg("x %g: %g vs central difference %g", x, got, fd);
    }
}

/* {r,g,b} -> {h,s,v} from Python's colorsys.rgb_to_hsv (double, %.9g). colorsys uses a
 * different formulation ((max-x)/C differences) of the same hexcone model, so agreement checks
 * eqs. 10-13 independently; values above 1 are HDR inputs (V unbounded). */
static const double hsv_table[][2][3] = {
    {{0, 0, 0}, {0, 0, 0}},
    {{0.5, 0.5, 0.5}, {0, 0, 0.5}},
    {{1, 1, 1}, {0, 0, 1}},
    {{3, 3, 3}, {0, 0, 3}},
    {{1, 0, 0}, {0, 1, 1}},
    {{0, 1, 0}, {0.333333333, 1, 1}},
    {{0, 0, 1}, {0.666666667, 1, 1}},
    {{1, 1, 0}, {0.166666667, 1, 1}},
    {{0, 1, 1}, {0.5, 1, 1}},
    {{1, 0, 1}, {0.833333333, 1, 1}},
    {{0.8, 0.3, 0.1}, {0.0476190476, 0.875, 0.8}},
    {{0.2, 0.7, 0.4}, {0.4, 0.714285714, 0.7}},
    {{0.3, 0.2, 0.9}, {0.69047619, 0.777777778, 0.9}},
    {{0.9, 0.1, 0.5}, {0.916666667, 0.888888889, 0.9}},
    {{1, 0, 0.001}, {0.999833333, 1, 1}}, /* hue wraps: H' < 0 becomes H near 1 */
    {{0.25, 0.5, 0.75}, {0.583333333, 0.666666667, 0.75}},
    {{4.5, 2, 0.5}, {0.0625, 0.888888889, 4.5}},
    {{12, 1, 6}, {0.924242424, 0.916666667, 12}},
    {{0.1, 2.5, 2.4}, {0.493055556, 0.96, 2.5}},
    {{7, 7, 1}, {0.166666667, 0.857142857, 7}},
    {{0, 0, 0.02}, {0.666666667, 1, 0.02}},
    {{0.0001, 0.0002, 0}, {0.25, 1, 0.0002}},
};

/* {h,s,v} -> {r,g,b} from colorsys.hsv_to_rgb (same method). */
static const double rgb_table[][2][3] = {
    {{0, 1, 1}, {1, 0, 0}},
    {{0.166666667, 1, 1}, {1, 1, 0}},
    {{0.5, 0.5, 2}, {1, 2, 2}},
    {{0.999, 1, 1}, {1, 0, 0.006}},
    {{0.3, 0, 5}, {5, 5, 5}},
    {{0.75, 0.8, 3.5}, {2.1, 0.7, 3.5}},
    {{0.05, 0.9, 10}, {10, 3.7, 1}},
    {{0.6, 0.25, 0.4}, {0.3, 0.34, 0.4}},
    {{0.95, 1, 0.7}, {0.7, 0, 0.21}},
    {{0.4166, 0.6, 1.2}, {0.48, 1.2, 0.839712}},
};

static void assert_close3(const float got[3], const double want[3], double tol)
{
    for (int c = 0; c < 3; c++)
        assert_true(fabs(got[c] - want[c]) <= tol * fmax(1.0, fabs(want[c])));
}

static void test_rgb_to_hsv_matches_colorsys(void **state)
{
    (void)state;
    for (size_t i = 0; i < N_OF(hsv_table); i++) {
        float rgb[3] = {(float)hsv_table[i][0][0], (float)hsv_table[i][0][1], (float)hsv_table[i][0][2]};
        float hsv[3];
        esr_rgb_to_hsv(rgb, hsv);
        assert_close3(hsv, hsv_table[i][1], 2e-6);
    }
}

static void test_hsv_to_rgb_matches_colorsys(void **state)
{
    (void)state;
    for (size_t i = 0; i < N_OF(rgb_table); i++) {
        float hsv[3] = {(float)rgb_table[i][0][0], (float)rgb_table[i][0][1], (float)rgb_table[i][0][2]};
        float rgb[3];
        esr_hsv_to_rgb(hsv, rgb);
        assert_close3(rgb, rgb_table[i][1], 2e-5); /* H is stored to 9 digits; x6 in eq. 14 */
    }
}

/* H is taken modulo 1 (floored), so H, H+1, H-1 give one colour; H = 1 is red like H = 0. */
static void test_hsv_hue_wraps(void **state)
{
    (void)state;
    const float base[3] = {0.3f, 0.7f, 2.0f};
    float want[3];
    esr_hsv_to_rgb(base, want);
    const float shifts[] = {-2.0f, -1.0f, 1.0f, 3.0f};
    for (size_t i = 0; i < N_OF(shifts); i++) {
        float hsv[3] = {base[0] + shifts[i], base[1], base[2]}, rgb[3];
        esr_hsv_to_rgb(hsv, rgb);
        for (int c = 0; c < 3; c++)
            assert_true(fabsf(rgb[c] - want[c]) < 1e-5f);
    }
    const float one[3] = {1.0f, 1.0f, 1.0f};
    const float almost[3] = {-1e-9f, 1.0f, 1.0f};
    float rgb[3];
    esr_hsv_to_rgb(one, rgb);
    assert_true(rgb[0] == 1.0f && rgb[1] == 0.0f && fabsf(rgb[2]) < 1e-6f);
    esr_hsv_to_rgb(almost, rgb);
    assert_true(rgb[0] == 1.0f && fabsf(rgb[1]) < 1e-6f && fabsf(rgb[2]) < 1e-6f);
}

/* RGB -> HSV -> RGB is the identity for random colours, HDR included; H, S stay in [0,1]. */
static void test_hsv_round_trip(void **state)
{
    (void)state;
    struct esr_rng rng = esr_rng_init(7, 0);
    for (int i = 0; i < 20000; i++) {
        float scale = 1.0f + 20.0f * esr_rng_float(&rng) * (i & 1);
        float rgb[3] = {scale * esr_rng_float(&rng), scale * esr_rng_float(&rng), scale * esr_rng_float(&rng)};
        if (i % 7 == 0)
            rgb[1] = rgb[0]; /* ties between channels */
        float hsv[3], back[3];
        esr_rgb_to_hsv(rgb, hsv);
        assert_true(hsv[0] >= 0.0f && hsv[0] < 1.0f);
        assert_true(hsv[1] >= 0.0f && hsv[1] <= 1.0f);
        esr_hsv_to_rgb(hsv, back);
        for (int c = 0; c < 3; c++)
            assert_true(fabsf(back[c] - rgb[c]) <= 2e-6f * fmaxf(1.0f, hsv[2]));
    }
}

/* The edit rule keeps V = max(R,G,B) and takes the target's H and S exactly. */
static void test_recolour_keeps_value(void **state)
{
    (void)state;
    const float lamp[3] = {6.0f, 4.5f, 2.0f}; /* warm HDR emission, V = 6 */
    float out[3], hsv[3];
    esr_recolour_keep_value(lamp, 2.0f / 3.0f, 1.0f, out); /* pure blue */
    assert_true(fabsf(out[0]) < 1e-6f && fabsf(out[1]) < 1e-5f && fabsf(out[2] - 6.0f) < 1e-6f);
    esr_recolour_keep_value(lamp, 0.5f, 0.5f, out); /* cyan at half saturation: (3, 6, 6) */
    assert_true(fabsf(out[0] - 3.0f) < 1e-5f && fabsf(out[1] - 6.0f) < 1e-5f && fabsf(out[2] - 6.0f) < 1e-5f);
    struct esr_rng rng = esr_rng_init(11, 0);
    for (int i = 0; i < 1000; i++) {
        float rgb[3] = {5 * esr_rng_float(&rng), 5 * esr_rng_float(&rng), 5 * esr_rng_float(&rng)};
        float th = esr_rng_float(&rng), ts = esr_rng_float(&rng);
        esr_recolour_keep_value(rgb, th, ts, out);
        esr_rgb_to_hsv(out, hsv);
        float v = fmaxf(rgb[0], fmaxf(rgb[1], rgb[2]));
        assert_true(fabsf(hsv[2] - v) <= 1e-6f * fmaxf(1.0f, v));
        assert_true(fabsf(hsv[1] - ts) < 1e-4f);
        if (ts > 1e-2f && v > 1e-2f) { /* hue is undefined for grey and black */
            float dh = fabsf(hsv[0] - th);
            assert_true(fminf(dh, 1.0f - dh) < 1e-4f);
        }
    }
    const float black[3] = {0, 0, 0};
    esr_recolour_keep_value(black, 0.3f, 1.0f, out); /* V = 0 stays black */
    assert_true(out[0] == 0.0f && out[1] == 0.0f && out[2] == 0.0f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_srgb_encode_matches_reference),
        cmocka_unit_test(test_srgb_decode_matches_reference),
        cmocka_unit_test(test_srgb_round_trip),
        cmocka_unit_test(test_srgb_continuous_at_knee),
        cmocka_unit_test(test_srgb_gradient_matches_finite_difference),
        cmocka_unit_test(test_srgb_decode_gradient_matches_finite_difference),
        cmocka_unit_test(test_image_error_scale),
        cmocka_unit_test(test_rgb_to_hsv_matches_colorsys),
        cmocka_unit_test(test_hsv_to_rgb_matches_colorsys),
        cmocka_unit_test(test_hsv_hue_wraps),
        cmocka_unit_test(test_hsv_round_trip),
        cmocka_unit_test(test_recolour_keeps_value),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
