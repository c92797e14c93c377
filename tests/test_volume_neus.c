/* NeuS opacity (seed eq. 2) and the mid-point section estimate. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>

#include "volume/neus.h"
#include "test_grad.h"

/* Reference values computed independently in Python (float64):
 *   phi = lambda s, x: 1 / (1 + exp(-s x)); p, q = phi(s, f_prev), phi(s, f_next)
 *   alpha = clip((p - q + 1e-5) / (p + 1e-5), 0, 1) */
static void test_alpha_reference_values(void **state)
{
    (void)state;
    const struct {
        float fp, fn, s;
        double alpha;
    } cases[] = {
        {0.1f, -0.05f, 20.0f, 0.694664781773304},
        {0.3f, 0.25f, 5.0f, 0.04927272495008972},
        {-0.2f, -0.3f, 50.0f, 0.9944780867190259}, /* inside: the 1e-5 keeps alpha near 1 */
        {0.02f, 0.04f, 64.0f, 0.0},                 /* moving away from the surface: clipped */
        {0.5f, -0.5f, 3.0f, 0.7768725689904744},
    };
    for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++)
        assert_true(test_close(esr_neus_alpha_fwd(cases[i].fp, cases[i].fn, cases[i].s), cases[i].alpha, 2e-6, 2e-5));
    assert_true(esr_neus_inv_s(5.0f, 50.0f, 1000) == 25.0f);
}

static double alpha_d(double fp, double fn, double s)
{
    double p = 1.0 / (1.0 + exp(-s * fp)), q = 1.0 / (1.0 + exp(-s * fn));
    double a = (p - q + 1e-5) / (p + 1e-5);
    return a < 0 ? 0 : a > 1 ? 1 : a;
}

/* Backward w.r.t. both SDF values and s against central differences of a float64 forward. */
static void test_alpha_bwd_fd(void **state)
{
    (void)state;
    float v[3 * 40];
    test_fill_uniform(v, 3 * 40, 0.0f, 1.0f, 21);
    int checked = 0;
    for (int i = 0; i < 40; i++) {
        float fp = -0.3f + 0.6f * v[3 * i], fn = fp - 0.2f + 0.3f * v[3 * i + 1], s = 2.0f + 30.0f * v[3 * i + 2];
        float dp, dn, ds;
        esr_neus_alpha_bwd(fp, fn, s, 1.5f, &dp, &dn, &ds);
        double a = alpha_d(fp, fn, s);
        if (a <= 1e-3 || a >= 1.0 - 1e-3) {
            assert_true(dp == 0.0f && dn == 0.0f && ds == 0.0f); /* clipped */
            continue;
        }
        const double h = 1e-5;
        assert_true(test_close(dp, 1.5 * (alpha_d(fp + h, fn, s) - alpha_d(fp - h, fn, s)) / (2 * h), 1e-4, 1e-3));
        assert_true(test_close(dn, 1.5 * (alpha_d(fp, fn + h, s) - alpha_d(fp, fn - h, s)) / (2 * h), 1e-4, 1e-3));
        assert_true(test_close(ds, 1.5 * (alpha_d(fp, fn, s + h) - alpha_d(fp, fn, s - h)) / (2 * h), 1e-4, 1e-3));
        checked++;
    }
    assert_true(checked > 15);
}

/* Section ends: values by hand, backward by central differences (away from the relu kinks). */
static void test_section(void **state)
{
    (void)state;
    float fp, fn;
    esr_neus_section_fwd(0.2f, -0.8f, 0.1f, 1.0f, &fp, &fn); /* c' = -0.8 */
    assert_true(fabsf(fp - 0.24f) < 1e-6f && fabsf(fn - 0.16f) < 1e-6f);
    esr_neus_section_fwd(0.2f, 0.8f, 0.1f, 1.0f, &fp, &fn); /* leaving: c' = 0 */
    assert_true(fp == 0.2f && fn == 0.2f);
    esr_neus_section_fwd(0.2f, 0.6f, 0.1f, 0.0f, &fp, &fn); /* c' = -(0.2) */
    assert_true(fabsf(fp - 0.21f) < 1e-6f && fabsf(fn - 0.19f) < 1e-6f);
    const float coss[4] = {-0.9f, -0.3f, 0.4f, -1.7f}, anneals[3] = {0.0f, 0.4f, 1.0f};
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 3; j++) {
            float c = coss[i], r = anneals[j], dm, dc;
            esr_neus_section_bwd(c, 0.05f, r, 0.7f, -1.3f, &dm, &dc);
            const float h = 1e-3f;
            float a1, b1, a2, b2;
            esr_neus_section_fwd(0.1f + h, c, 0.05f, r, &a1, &b1);
            esr_neus_section_fwd(0.1f - h, c, 0.05f, r, &a2, &b2);
            assert_true(test_close(dm, (0.7 * (a1 - a2) - 1.3 * (b1 - b2)) / (2 * h), 1e-3, 1e-3));
            esr_neus_section_fwd(0.1f, c + h, 0.05f, r, &a1, &b1);
            esr_neus_section_fwd(0.1f, c - h, 0.05f, r, &a2, &b2);
            assert_true(test_close(dc, (0.7 * (a1 - a2) - 1.3 * (b1 - b2)) / (2 * h), 1e-4, 1e-2));
        }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_alpha_reference_values),
        cmocka_unit_test(test_alpha_bwd_fd),
        cmocka_unit_test(test_section),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
