/* The step profile's accounting (core/profile.h): nested parts count exclusive time, work adds
 * up, nothing counts when off or inside a parallel region, an unbalanced exit is not counted. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <omp.h>

#include "core/profile.h"

/* waits s seconds of wall time */
static void busy(double s)
{
    const double t0 = omp_get_wtime();
    while (omp_get_wtime() - t0 < s) {
    }
}

static void test_nested_parts_count_exclusive_time(void **state)
{
    (void)state;
    esr_prof_reset();
    esr_prof_enable(1);
    const double t0 = omp_get_wtime();
    esr_prof_enter(ESR_PROF_FIELDS);
    busy(0.02);
    esr_prof_enter(ESR_PROF_MLP_FWD);
    busy(0.03);
    esr_prof_work(ESR_PROF_MLP_FWD, 1e9, 0.0);
    esr_prof_exit(ESR_PROF_MLP_FWD);
    busy(0.01);
    esr_prof_exit(ESR_PROF_FIELDS);
    const double total = omp_get_wtime() - t0;
    esr_prof_enable(0);
    struct esr_prof_totals p;
    esr_prof_totals(&p);
    /* the two parts add up to the time spent in either: nothing counted twice, nothing lost */
    assert_true(p.seconds[ESR_PROF_MLP_FWD] >= 0.03);
    assert_true(p.seconds[ESR_PROF_FIELDS] >= 0.03);
    assert_true(p.seconds[ESR_PROF_FIELDS] + p.seconds[ESR_PROF_MLP_FWD] <= total + 1e-9);
    assert_true(p.seconds[ESR_PROF_FIELDS] + p.seconds[ESR_PROF_MLP_FWD] >= total - 1e-3);
    assert_true(p.flops[ESR_PROF_MLP_FWD] == 1e9);
    assert_true(p.flops[ESR_PROF_FIELDS] == 0.0);
}

static void test_off_parallel_and_unbalanced_count_nothing(void **state)
{
    (void)state;
    esr_prof_reset();
    esr_prof_enter(ESR_PROF_ADAM); /* off */
    busy(0.005);
    esr_prof_exit(ESR_PROF_ADAM);
    esr_prof_enable(1);
#pragma omp parallel num_threads(2)
    {
        esr_prof_enter(ESR_PROF_MARCH); /* inside a parallel region: ignored by every thread */
        busy(0.005);
        esr_prof_work(ESR_PROF_MARCH, 5.0, 5.0);
        esr_prof_exit(ESR_PROF_MARCH);
    }
    esr_prof_enter(ESR_PROF_COMPOSITE);
    esr_prof_exit(ESR_PROF_REG); /* not the part entered: dropped */
    esr_prof_enable(0);
    struct esr_prof_totals p;
    esr_prof_totals(&p);
    for (int i = 0; i < ESR_PROF_PARTS; i++) {
        assert_true(p.seconds[i] == 0.0);
        assert_true(p.flops[i] == 0.0 && p.bytes[i] == 0.0);
    }
    assert_string_equal(esr_prof_part_name(ESR_PROF_LTS_SECONDARY), "lts secondary rays");
    assert_string_equal(esr_prof_part_name(ESR_PROF_PARTS), "?");
}

/* ESR_PROF_STEPS: a part outside the steps counts nothing; inside, it counts, and the steps'
 * own wall time adds up. */
static void test_steps_scope(void **state)
{
    (void)state;
    esr_prof_reset();
    esr_prof_enable(ESR_PROF_STEPS);
    esr_prof_enter(ESR_PROF_FIELDS); /* outside a step: e.g. the lights' estimation */
    busy(0.01);
    esr_prof_exit(ESR_PROF_FIELDS);
    double inside = 0.0;
    for (int k = 0; k < 2; k++) {
        const double t0 = omp_get_wtime();
        esr_prof_step_begin();
        busy(0.005);
        esr_prof_enter(ESR_PROF_MARCH);
        busy(0.01);
        esr_prof_exit(ESR_PROF_MARCH);
        esr_prof_step_end();
        inside += omp_get_wtime() - t0;
    }
    esr_prof_step_end(); /* no step open: nothing */
    esr_prof_enable(0);
    struct esr_prof_totals p;
    esr_prof_totals(&p);
    assert_true(p.seconds[ESR_PROF_FIELDS] == 0.0);
    assert_true(p.seconds[ESR_PROF_MARCH] >= 0.02);
    assert_int_equal(p.steps, 2);
    assert_true(p.step_seconds >= p.seconds[ESR_PROF_MARCH] + 0.01 && p.step_seconds <= inside + 1e-9);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_nested_parts_count_exclusive_time),
        cmocka_unit_test(test_off_parallel_and_unbalanced_count_nothing),
        cmocka_unit_test(test_steps_scope),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
