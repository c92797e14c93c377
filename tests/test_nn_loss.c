/* Losses: values by hand, gradients against central differences, accumulation into d_pred,
 * thread-count independence of the value. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <omp.h>
#include <stdlib.h>

#include "nn/loss.h"

static const float pred[4] = {0.5f, -1.0f, 2.0f, 0.25f};
static const float target[4] = {0.0f, 1.0f, 2.0f, 0.0f};

static void test_values_by_hand(void **state)
{
    (void)state;
    /* diffs 0.5, -2, 0, 0.25 */
    assert_float_equal(esr_loss_mse(pred, target, 4, 1.0f, NULL), (0.25 + 4 + 0 + 0.0625) / 4, 1e-7);
    assert_float_equal(esr_loss_l1(pred, target, 4, 2.0f, NULL), 2.0 * (0.5 + 2 + 0 + 0.25) / 4, 1e-7);
    /* Huber delta 1: 0.5*0.25, 1*(2-0.5), 0, 0.5*0.0625 */
    assert_float_equal(esr_loss_huber(pred, target, 4, 1.0f, 1.0f, NULL),
                       (0.125 + 1.5 + 0 + 0.03125) / 4, 1e-7);
    assert_float_equal(esr_loss_mse(pred, target, 0, 1.0f, NULL), 0.0, 0);
}

typedef double (*loss_fn)(const float *, const float *, size_t, float, float *);
static double huber_half(const float *p, const float *t, size_t n, float w, float *d)
{
    return esr_loss_huber(p, t, n, 0.5f, w, d);
}

static void test_gradients(void **state)
{
    (void)state;
    const loss_fn fns[] = {esr_loss_mse, esr_loss_l1, huber_half};
    for (int f = 0; f < 3; f++) {
        float d[4] = {1, 1, 1, 1}, p[4];
        fns[f](pred, target, 4, 3.0f, d); /* accumulates onto the ones */
        for (int i = 0; i < 4; i++) {
            if (pred[i] == target[i] && f == 1)
                continue; /* L1 kink: subgradient 0, checked below */
            for (int j = 0; j < 4; j++)
                p[j] = pred[j];
            const float h = 1e-3f;
            p[i] = pred[i] + h;
            double lp = fns[f](p, target, 4, 3.0f, NULL);
            p[i] = pred[i] - h;
            double lm = fns[f](p, target, 4, 3.0f, NULL);
            assert_float_equal(d[i] - 1.0f, (lp - lm) / (2 * h), 2e-3);
        }
    }
    float d[4] = {0};
    esr_loss_l1(pred, target, 4, 1.0f, d);
    assert_float_equal(d[2], 0.0f, 0);
}

static void test_value_independent_of_threads(void **state)
{
    (void)state;
    size_t n = 300001;
    float *p = malloc(n * sizeof(float)), *t = malloc(n * sizeof(float));
    for (size_t i = 0; i < n; i++) {
        p[i] = sinf((float)i * 0.001f);
        t[i] = cosf((float)i * 0.0007f);
    }
    int keep = omp_get_max_threads();
    omp_set_num_threads(1);
    double a = esr_loss_mse(p, t, n, 1.0f, NULL);
    omp_set_num_threads(2);
    double b = esr_loss_mse(p, t, n, 1.0f, NULL);
    omp_set_num_threads(keep);
    assert_true(a == b);
    free(p);
    free(t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_values_by_hand),
        cmocka_unit_test(test_gradients),
        cmocka_unit_test(test_value_independent_of_threads),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
