/* The fractal noise texture of `esr synth`'s capture scene: it stays in [0, 1] and uses the whole
 * range (a texture with contrast), it is continuous (no seams for a path tracer to show), it does
 * not repeat at any multiple of its period (the point of it: a feature matcher must not find one
 * patch in two places, as it does on a checker), and a textured material blends the two base
 * colours while checker and stripes still pick one of them exactly. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <string.h>

#include "core/rng.h"
#include "synth/noise.h"
#include "synth/prim.h"

#define PERIOD 0.4f

static struct esr_vec3 random_point(struct esr_rng *rng)
{
    return esr_v3(4.0f * esr_rng_float(rng) - 2.0f, 4.0f * esr_rng_float(rng) - 2.0f,
                  4.0f * esr_rng_float(rng) - 2.0f);
}

static void test_range_and_contrast(void **state)
{
    (void)state;
    struct esr_rng rng = esr_rng_init(7, 0);
    int dark = 0, bright = 0;
    const int n = 20000;
    for (int i = 0; i < n; i++) {
        const float v = esr_synth_noise(random_point(&rng), PERIOD);
        assert_true(v >= 0.0f && v <= 1.0f);
        dark += v < 0.15f;
        bright += v > 0.85f;
    }
    /* both ends are reached often: patches of both base colours */
    assert_true(dark > n / 50);
    assert_true(bright > n / 50);
}

static void test_continuous(void **state)
{
    (void)state;
    struct esr_rng rng = esr_rng_init(7, 1);
    /* along each axis an octave's slope is at most 1.5 / cell (smoothstep's), times 5 for the
     * stretch: a step of h on all three axes moves the value by at most
     * 3 * 5 * 1.5 * h * sum_o (amp_o / cell_o) / sum_o amp_o; a seam (a jump) exceeds it */
    const float h = 1e-4f, amp_over_cell = (0.5f + 0.25f * 2 + 0.125f * 4 + 0.0625f * 8) / PERIOD;
    const float bound = 3.0f * 5.0f * 1.5f * h * amp_over_cell / 0.9375f;
    for (int i = 0; i < 5000; i++) {
        const struct esr_vec3 x = random_point(&rng);
        const struct esr_vec3 y = esr_v3(x.x + h, x.y - h, x.z + h);
        assert_true(fabsf(esr_synth_noise(x, PERIOD) - esr_synth_noise(y, PERIOD)) <= bound * 1.01f + 1e-6f);
    }
}

/* Mean |n(x) - n(x + shift)| over random x: 0 for a texture that repeats by shift. */
static float mean_difference(struct esr_vec3 shift)
{
    struct esr_rng rng = esr_rng_init(7, 2);
    double sum = 0.0;
    const int n = 4000;
    for (int i = 0; i < n; i++) {
        const struct esr_vec3 x = random_point(&rng);
        sum += fabsf(esr_synth_noise(x, PERIOD) - esr_synth_noise(esr_v3_add(x, shift), PERIOD));
    }
    return (float)(sum / n);
}

static void test_does_not_repeat(void **state)
{
    (void)state;
    for (int k = 1; k <= 16; k++) {
        const float d = (float)k * PERIOD;
        assert_true(mean_difference(esr_v3(d, 0, 0)) > 0.15f);
        assert_true(mean_difference(esr_v3(0, d, 0)) > 0.15f);
        assert_true(mean_difference(esr_v3(d, d, 0)) > 0.15f);
        assert_true(mean_difference(esr_v3(0.5f * d, 0, 0)) > 0.15f);
    }
    /* the same point gives the same value (the renders of every camera agree) */
    assert_true(mean_difference(esr_v3(0, 0, 0)) == 0.0f);
}

static void test_material_blend(void **state)
{
    (void)state;
    struct esr_synth_prim p;
    memset(&p, 0, sizeof p);
    p.mat.base[0] = 0.8f, p.mat.base[1] = 0.7f, p.mat.base[2] = 0.1f;
    p.base2[0] = 0.1f, p.base2[1] = 0.3f, p.base2[2] = 0.9f;
    p.tex_period = PERIOD;
    struct esr_rng rng = esr_rng_init(7, 3);
    for (int i = 0; i < 1000; i++) {
        const struct esr_vec3 x = random_point(&rng);
        p.texture = ESR_SYNTH_TEX_NOISE;
        const float w = esr_synth_noise(x, PERIOD);
        struct esr_material m = esr_synth_prim_material(&p, x);
        for (int c = 0; c < 3; c++)
            assert_float_equal(m.base[c], (1.0f - w) * p.mat.base[c] + w * p.base2[c], 1e-6f);
        /* a checker square is one base colour or the other, exactly */
        p.texture = ESR_SYNTH_TEX_CHECKER;
        m = esr_synth_prim_material(&p, x);
        const int odd = ((int)floorf(x.x / PERIOD) + (int)floorf(x.y / PERIOD)) & 1;
        for (int c = 0; c < 3; c++)
            assert_true(m.base[c] == (odd ? p.base2[c] : p.mat.base[c]));
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_range_and_contrast),
        cmocka_unit_test(test_continuous),
        cmocka_unit_test(test_does_not_repeat),
        cmocka_unit_test(test_material_blend),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
