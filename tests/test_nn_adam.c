/* Adam against a two-step example worked by hand, the sparse variant's skip rule, a long range
 * against the formula in double, and the learning-rate schedules against hand values. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "nn/adam.h"
#include "nn/schedule.h"

/* w = 1, gradients 0.5 then -1, lr 0.1, betas 0.9/0.999:
 * t=1: m = 0.05, v = 0.00025, m^ = 0.5, v^ = 0.25 -> w = 1 - 0.1*0.5/0.5 = 0.9
 * t=2: m = -0.055, v = 0.00124975, m^ = -0.055/0.19, v^ = 0.00124975/0.001999
 *      -> w = 0.9 + 0.1*0.289474/0.790688 = 0.93661035 */
static void test_two_steps_by_hand(void **state)
{
    (void)state;
    struct esr_adam a;
    assert_int_equal(esr_adam_init(&a, 3), ESR_OK);
    struct esr_adam_hp hp = {0.1f, 0.9f, 0.999f, 1e-8f, 0};
    float w[3] = {5.0f, 1.0f, 5.0f}, g[3] = {9.0f, 0.5f, 9.0f};
    esr_adam_step(&hp, 1, &a, w, g, 1, 1); /* only entry 1 is in the range */
    assert_float_equal(w[1], 0.9f, 1e-6);
    assert_float_equal(a.m[1], 0.05f, 1e-7);
    assert_float_equal(a.v[1], 0.00025f, 1e-8);
    g[1] = -1.0f;
    esr_adam_step(&hp, 2, &a, w, g, 1, 1);
    assert_float_equal(w[1], 0.93661035f, 2e-6);
    assert_float_equal(a.m[1], -0.055f, 1e-7);
    assert_float_equal(a.v[1], 0.00124975f, 5e-8);
    assert_true(w[0] == 5.0f && w[2] == 5.0f && a.m[0] == 0.0f && a.v[2] == 0.0f);
    esr_adam_free(&a);
}

static void test_sparse_skips_zero_gradients(void **state)
{
    (void)state;
    struct esr_adam a;
    assert_int_equal(esr_adam_init(&a, 2), ESR_OK);
    struct esr_adam_hp hp = {0.1f, 0.9f, 0.999f, 1e-8f, 1};
    float w[2] = {1.0f, 1.0f}, g[2] = {0.5f, 0.5f};
    esr_adam_step(&hp, 1, &a, w, g, 0, 2);
    g[1] = 0.0f;
    esr_adam_step(&hp, 2, &a, w, g, 0, 2);
    /* Entry 1: frozen at its t=1 state; entry 0 keeps moving. */
    assert_float_equal(w[1], 0.9f, 1e-6);
    assert_float_equal(a.m[1], 0.05f, 1e-7);
    assert_float_equal(a.v[1], 0.00025f, 1e-8);
    assert_true(w[0] < 0.85f);
    /* Dense Adam moves the same entry on momentum alone. */
    hp.sparse = 0;
    esr_adam_step(&hp, 3, &a, w, g, 0, 2);
    assert_true(w[1] < 0.9f - 1e-3f);
    assert_int_equal(esr_adam_resize(&a, 5), ESR_OK);
    assert_true(a.count == 5 && a.m[4] == 0.0f && a.m[1] != 0.0f);
    esr_adam_free(&a);
}

/* A range long enough for whole blocks of 8, a tail and several parallel chunks, three steps,
 * against the formula in double per entry: gradients zero in whole blocks, in single entries and
 * as -0; sparse entries with a zero gradient keep their weight and moments bit for bit. */
static void test_long_range_against_formula(void **state)
{
    (void)state;
    enum { N = 40003, OFF = 5 };
    struct esr_adam a;
    assert_int_equal(esr_adam_init(&a, N + OFF), ESR_OK);
    float *w = malloc((N + OFF) * sizeof(float)), *g = malloc((N + OFF) * sizeof(float));
    double *rw = malloc(N * sizeof(double)), *rm = calloc(N, sizeof(double)),
           *rv = calloc(N, sizeof(double));
    assert_true(w && g && rw && rm && rv);
    for (int sparse = 0; sparse < 2; sparse++) {
        const struct esr_adam_hp hp = {0.05f, 0.9f, 0.99f, 1e-8f, sparse};
        for (int i = 0; i < N + OFF; i++)
            w[i] = 0.001f * (float)(i % 1000) - 0.3f;
        memset(a.m, 0, (N + OFF) * sizeof(float));
        memset(a.v, 0, (N + OFF) * sizeof(float));
        for (int i = 0; i < N; i++)
            rw[i] = w[OFF + i], rm[i] = rv[i] = 0.0;
        uint32_t s = 7;
        for (int t = 1; t <= 3; t++) {
            for (int i = 0; i < N + OFF; i++) {
                s = s * 1664525u + 1013904223u;
                const int block = (i - OFF) / 8, r = (int)(s >> 24);
                float gi = ((float)(s >> 8 & 0xffff) / 32768.0f - 1.0f);
                if (block % 3 == 0 || r < 40) /* whole zero blocks, and scattered zeros */
                    gi = r & 1 ? 0.0f : -0.0f;
                g[i] = gi;
            }
            const float keep_w = w[OFF + 24 * 8], keep_m = a.m[OFF + 24 * 8];
            esr_adam_step(&hp, t, &a, w, g, OFF, N);
            const double bc1 = 1.0 - pow(0.9, t), bc2 = 1.0 - pow(0.99, t);
            for (int i = 0; i < N; i++) {
                const double gi = g[OFF + i];
                if (sparse && gi == 0.0)
                    continue;
                rm[i] = 0.9 * rm[i] + 0.1 * gi;
                rv[i] = 0.99 * rv[i] + 0.01 * gi * gi;
                rw[i] -= 0.05 / bc1 * rm[i] / (sqrt(rv[i] / bc2) + 1e-8);
            }
            if (sparse) /* block 24 is all zeros: untouched */
                assert_true(w[OFF + 24 * 8] == keep_w && a.m[OFF + 24 * 8] == keep_m);
        }
        for (int i = 0; i < N; i++) {
            assert_true(fabs(w[OFF + i] - rw[i]) < 2e-6 * (1.0 + fabs(rw[i])));
            assert_true(fabs(a.m[OFF + i] - rm[i]) < 1e-6 && fabs(a.v[OFF + i] - rv[i]) < 1e-6);
        }
        for (int i = 0; i < OFF; i++) /* outside the range */
            assert_true(a.m[i] == 0.0f && w[i] == 0.001f * (float)i - 0.3f);
    }
    free(w);
    free(g);
    free(rw);
    free(rm);
    free(rv);
    esr_adam_free(&a);
}

static void test_schedules_by_hand(void **state)
{
    (void)state;
    assert_float_equal(esr_lr_exp_factor(0, 1000, 0.1f), 1.0f, 0);
    assert_float_equal(esr_lr_exp_factor(250, 1000, 0.1f), 0.56234133f, 1e-6);
    assert_float_equal(esr_lr_exp_factor(1000, 1000, 0.1f), 0.1f, 1e-7);
    assert_float_equal(esr_lr_warmup_factor(0, 100), 0.0f, 0);
    assert_float_equal(esr_lr_warmup_factor(25, 100), 0.25f, 0);
    assert_float_equal(esr_lr_warmup_factor(100, 100), 1.0f, 0);
    assert_float_equal(esr_lr_warmup_factor(5, 0), 1.0f, 0);
    /* warm-up 100 then cosine over 100..1100 to alpha 0.05: half way -> (0+1)/2*0.95+0.05 */
    assert_float_equal(esr_lr_cosine_factor(50, 1100, 100, 0.05f), 0.5f, 0);
    assert_float_equal(esr_lr_cosine_factor(100, 1100, 100, 0.05f), 1.0f, 1e-7);
    assert_float_equal(esr_lr_cosine_factor(600, 1100, 100, 0.05f), 0.525f, 1e-6);
    assert_float_equal(esr_lr_cosine_factor(350, 1100, 100, 0.1f), 0.86819805f, 1e-6);
    assert_float_equal(esr_lr_cosine_factor(5000, 1100, 100, 0.05f), 0.05f, 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_two_steps_by_hand),
        cmocka_unit_test(test_sparse_skips_zero_gradients),
        cmocka_unit_test(test_long_range_against_formula),
        cmocka_unit_test(test_schedules_by_hand),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
