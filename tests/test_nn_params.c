/* Flat parameter store (alignment, growth keeps values and offsets), NaN guard, activation names
 * and their per-element derivatives against central differences. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>

#include "core/error.h"
#include "nn/activation.h"
#include "nn/guard.h"
#include "nn/params.h"

static void test_take_aligns_and_grows(void **state)
{
    (void)state;
    struct esr_nn_params p;
    size_t a, b, c;
    assert_int_equal(esr_nn_params_init(&p, 4), ESR_OK);
    assert_int_equal(esr_nn_params_take(&p, 3, &a), ESR_OK);
    p.w[a + 2] = 42.0f;
    p.g[a + 1] = 7.0f;
    assert_int_equal(esr_nn_params_take(&p, 1000, &b), ESR_OK); /* forces growth */
    assert_int_equal(esr_nn_params_take(&p, 5, &c), ESR_OK);
    assert_int_equal(a, 0);
    assert_int_equal(b % ESR_NN_PARAM_ALIGN, 0);
    assert_int_equal(c % ESR_NN_PARAM_ALIGN, 0);
    assert_true(b >= 3 && c >= b + 1000 && p.count == c + 5 && p.capacity >= p.count);
    assert_int_equal((uintptr_t)p.w % 64, 0);
    assert_true(p.w[a + 2] == 42.0f && p.g[a + 1] == 7.0f && p.w[b + 999] == 0.0f);
    esr_nn_params_zero_grad(&p, a, 3);
    assert_true(p.g[a + 1] == 0.0f);
    esr_nn_params_free(&p);
}

static void test_guard_finds_nan_and_inf(void **state)
{
    (void)state;
    size_t n = 100003;
    float *x = calloc(n, sizeof(float));
    x[5] = 1e38f;
    x[6] = -0.0f;
    assert_int_equal(esr_nn_all_finite(x, n), 1);
    assert_int_equal(esr_nn_first_nonfinite(x, n), n);
    x[n - 1] = NAN;
    assert_int_equal(esr_nn_all_finite(x, n), 0);
    assert_int_equal(esr_nn_first_nonfinite(x, n), n - 1);
    x[4097] = -INFINITY;
    assert_int_equal(esr_nn_first_nonfinite(x, n), 4097);
    assert_int_equal(esr_nn_all_finite(x, 4097), 1);
    assert_int_equal(esr_nn_all_finite(x, 0), 1);
    free(x);
}

static void test_activation_derivatives(void **state)
{
    (void)state;
    const float zs[] = {-30.0f, -3.0f, -0.4f, 0.3f, 2.5f, 19.0f, 25.0f};
    for (int a = ESR_NN_ACT_NONE; a < ESR_NN_ACT_COUNT; a++)
        for (size_t i = 0; i < sizeof(zs) / sizeof(zs[0]); i++) {
            float z = zs[i], h = 1e-3f * fmaxf(1.0f, fabsf(z));
            if (a == ESR_NN_ACT_TRUNC_EXP && fabsf(z) > 15.0f)
                continue; /* truncated on purpose, checked below */
            double fd = ((double)esr_nn_act_fwd((enum esr_nn_act)a, z + h) -
                         esr_nn_act_fwd((enum esr_nn_act)a, z - h)) / (2.0 * h);
            float y = esr_nn_act_fwd((enum esr_nn_act)a, z);
            float an = esr_nn_act_bwd((enum esr_nn_act)a, y, 1.0f);
            assert_true(fabs(an - fd) <= 2e-3 * (1.0 + fabs(fd)) + 1e-12);
        }
    /* Softplus: stable far out and exactly linear past the threshold. */
    assert_float_equal(esr_nn_softplus_fwd(-100.0f), expf(-100.0f), 1e-45);
    assert_true(esr_nn_softplus_fwd(21.0f) == 21.0f);
    assert_float_equal(esr_nn_softplus_fwd(0.0f), logf(2.0f), 1e-7);
    assert_float_equal(esr_nn_trunc_exp_bwd(expf(20.0f), 1.0f), expf(15.0f), 1.0f);
    enum esr_nn_act act;
    assert_int_equal(esr_nn_act_from_name("softplus", &act), ESR_OK);
    assert_int_equal(act, ESR_NN_ACT_SOFTPLUS);
    assert_string_equal(esr_nn_act_name(ESR_NN_ACT_SIGMOID), "sigmoid");
    assert_null(esr_nn_act_name(ESR_NN_ACT_COUNT));
    assert_int_equal(esr_nn_act_from_name("gelu", &act), ESR_ERR);
    esr_error_clear();
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_take_aligns_and_grows),
        cmocka_unit_test(test_guard_finds_nan_and_inf),
        cmocka_unit_test(test_activation_derivatives),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
