/* The learned background's lookup (fields/background.h) against values worked out by hand from
 * its definition: u = atan2(y, x) / 2 pi + 1/2, v = acos(z) / pi, texel centres at (i + 1/2) / W,
 * bilinear, wrapping in u, clamped in v, one layer per lighting mode, sigmoid; and its backward
 * against central differences. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "fields/background.h"

#define W ESR_BACKGROUND_W
#define H ESR_BACKGROUND_H

static size_t at(int mode, int row, int col, int c) { return (((size_t)mode * H + row) * W + col) * 3 + c; }

static float sigmoid(float x) { return 1.0f / (1.0f + expf(-x)); }

static float *zeros(void)
{
    float *l = calloc(ESR_BACKGROUND_PARAMS, sizeof(float));
    assert_non_null(l);
    return l;
}

/* A direction straight at a texel centre reads that texel alone; modes read their own layer. */
static void test_texel_centres(void **state)
{
    (void)state;
    float *l = zeros();
    /* texel (row 8, col 40): u = 40.5 / 64, v = 8.5 / 32 */
    const double u = 40.5 / W, v = 8.5 / H, phi = (u - 0.5) * 2 * M_PI, theta = v * M_PI;
    const float d[3] = {(float)(sin(theta) * cos(phi)), (float)(sin(theta) * sin(phi)), (float)cos(theta)};
    l[at(0, 8, 40, 0)] = 2.0f, l[at(0, 8, 40, 1)] = -1.0f, l[at(0, 8, 40, 2)] = 0.5f;
    l[at(1, 8, 40, 0)] = -3.0f;
    const uint8_t off = 0, on = 1;
    float out[3];
    esr_background_fwd(l, d, &off, 1, out);
    assert_float_equal(out[0], sigmoid(2.0f), 1e-4);
    assert_float_equal(out[1], sigmoid(-1.0f), 1e-4);
    assert_float_equal(out[2], sigmoid(0.5f), 1e-4);
    esr_background_fwd(l, d, &on, 1, out);
    assert_float_equal(out[0], sigmoid(-3.0f), 1e-4);
    assert_float_equal(out[1], 0.5f, 1e-4);
    free(l);
}

/* Halfway between two texels in u across the seam (u = 0 = 1, behind: -X): the mean of column
 * W-1 and column 0. Straight up: row 0 clamped, halfway between the columns at u = 1/2. */
static void test_seam_and_pole(void **state)
{
    (void)state;
    float *l = zeros();
    for (int row = 0; row < H; row++) {
        l[at(0, row, W - 1, 0)] = 1.0f;
        l[at(0, row, 0, 0)] = 3.0f;
    }
    const uint8_t off = 0;
    float out[3];
    /* -X with a tiny -Y: atan2 -> -pi, u -> 0: between the centres of columns W-1 (u = 1 - 0.5/W)
     * and 0 (u = 0.5/W); v = 1/2 sits between rows H/2 - 1 and H/2 (both set the same) */
    const float d_seam[3] = {-1.0f, -1e-7f, 0.0f};
    esr_background_fwd(l, d_seam, &off, 1, out);
    assert_float_equal(out[0], sigmoid(2.0f), 1e-3);
    free(l);
    l = zeros();
    /* straight up: v = 0, clamped to row 0; u = atan2(0, 0) = 0 -> 1/2: between columns 31, 32 */
    l[at(0, 0, W / 2 - 1, 1)] = 1.0f, l[at(0, 0, W / 2, 1)] = 2.0f;
    const float d_up[3] = {0.0f, 0.0f, 5.0f}; /* length does not matter */
    esr_background_fwd(l, d_up, &off, 1, out);
    assert_float_equal(out[1], sigmoid(1.5f), 1e-4);
    free(l);
}

static void test_backward_matches_central_differences(void **state)
{
    (void)state;
    enum { N = 5 };
    float *l = zeros(), *g = zeros();
    for (size_t i = 0; i < ESR_BACKGROUND_PARAMS; i++)
        l[i] = (float)sin(0.37 * (double)i);
    const float d[N * 3] = {0.3f, -0.8f, 0.2f, -0.5f, 0.1f, -0.7f, 0.0f, 0.2f, 1.0f,
                            -1.0f, 0.01f, 0.3f, 0.6f, 0.6f, -0.1f};
    const uint8_t on[N] = {0, 1, 0, 1, 1};
    const float d_out[N * 3] = {0.5f, -1.0f, 0.25f, 1.0f, 0.3f, -0.2f, 0.7f, 0.1f, -0.4f,
                                -0.6f, 0.9f, 0.2f, 0.3f, -0.3f, 0.8f};
    esr_background_bwd(l, d, on, N, d_out, g);
    float out[N * 3];
    int checked = 0;
    for (size_t i = 0; i < ESR_BACKGROUND_PARAMS; i++) {
        const float keep = l[i], eps = 1e-2f;
        double f[2];
        for (int s = 0; s < 2; s++) {
            l[i] = keep + (s ? -eps : eps);
            esr_background_fwd(l, d, on, N, out);
            f[s] = 0.0;
            for (int k = 0; k < N * 3; k++)
                f[s] += (double)d_out[k] * out[k];
        }
        l[i] = keep;
        const double fd = (f[0] - f[1]) / (2.0 * eps);
        if (fabs(fd - g[i]) > 1e-3 * fmax(1.0, fabs(fd)))
            fail_msg("logit %zu: analytic %.6g, central difference %.6g", i, (double)g[i], fd);
        checked += g[i] != 0.0f;
    }
    assert_int_equal(checked, N * 4 * 3); /* four texels per ray and channel, none shared */
    free(l);
    free(g);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_texel_centres),
        cmocka_unit_test(test_seam_and_pole),
        cmocka_unit_test(test_backward_matches_central_differences),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
