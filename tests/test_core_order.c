/* Sorting and the median (core/order.h) against hand-worked answers. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "core/order.h"

static void test_sorts_ascending(void **state)
{
    (void)state;
    float f[6] = {3.5f, -1.0f, 2.0f, 2.0f, 0.0f, -7.25f};
    const float fw[6] = {-7.25f, -1.0f, 0.0f, 2.0f, 2.0f, 3.5f};
    esr_sort_floats(f, 6);
    for (int i = 0; i < 6; i++)
        assert_true(f[i] == fw[i]);
    double d[5] = {1e300, -2.0, 0.5, -1e-300, 3.0};
    const double dw[5] = {-2.0, -1e-300, 0.5, 3.0, 1e300};
    esr_sort_doubles(d, 5);
    for (int i = 0; i < 5; i++)
        assert_true(d[i] == dw[i]);
}

static void test_median_odd_and_even(void **state)
{
    (void)state;
    double odd[5] = {9.0, 1.0, 4.0, 7.0, 2.0};
    assert_true(esr_median_doubles(odd, 5) == 4.0);
    double even[4] = {10.0, 1.0, 4.0, 3.0}; /* middle two 3 and 4 */
    assert_true(esr_median_doubles(even, 4) == 3.5);
    double one[1] = {-6.0};
    assert_true(esr_median_doubles(one, 1) == -6.0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sorts_ascending),
        cmocka_unit_test(test_median_odd_and_even),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
