/* Counter-based RNG: determinism per (seed, stream, counter), independent streams, uniformity. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>

#include "core/rng.h"
#include "test_stats.h"

#define CHI2_Z 4.0 /* false-alarm rate ~3e-5 per check; the seeds are fixed, so runs are repeatable */

static void test_same_seed_stream_same_sequence(void **state)
{
    (void)state;
    struct esr_rng a = esr_rng_init(1234, 56), b = esr_rng_init(1234, 56);
    uint32_t seq[64];
    for (int i = 0; i < 64; i++) {
        seq[i] = esr_rng_u32(&a);
        assert_int_equal(seq[i], esr_rng_u32(&b));
    }
    /* A value depends only on the counter: jumping straight to counter c gives draw c+1. */
    for (int c = 0; c < 64; c += 7) {
        struct esr_rng j = esr_rng_init(1234, 56);
        j.counter = (uint64_t)c;
        assert_int_equal(esr_rng_u32(&j), seq[c]);
    }
}

static int compare_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

/* Neighbouring streams and seeds start at unrelated values, and a stream's draws are not
 * correlated with its neighbour's. */
static void test_streams_differ(void **state)
{
    (void)state;
    enum { N = 4096 };
    uint32_t *first = malloc(sizeof *first * 2 * N);
    assert_non_null(first);
    for (int s = 0; s < N; s++) {
        struct esr_rng r = esr_rng_init(99, (uint64_t)s);
        struct esr_rng q = esr_rng_init((uint64_t)s, 0);
        first[s] = esr_rng_u32(&r);
        first[N + s] = esr_rng_u32(&q);
    }
    qsort(first, 2 * N, sizeof *first, compare_u32);
    int duplicates = 0;
    for (int i = 1; i < 2 * N; i++)
        duplicates += first[i] == first[i - 1];
    assert_true(duplicates <= 1); /* expected 8192^2/2^33 ~ 0.008 by chance */
    free(first);

    double sum_xy = 0.0;
    const int draws = 64;
    for (int s = 0; s < 1000; s++) {
        struct esr_rng a = esr_rng_init(5, (uint64_t)s), b = esr_rng_init(5, (uint64_t)s + 1);
        for (int i = 0; i < draws; i++)
            sum_xy += (esr_rng_float(&a) - 0.5) * (esr_rng_float(&b) - 0.5);
    }
    /* correlation estimate: sd of the mean product is (1/12)/sqrt(64000) ~ 3.3e-4 */
    assert_true(fabs(sum_xy / (1000.0 * draws)) < 5 * 3.3e-4);
}

static void test_float_range_and_uniformity(void **state)
{
    (void)state;
    enum { BINS = 64, N = 1 << 20 };
    double observed[BINS] = {0}, expected[BINS];
    struct esr_rng r = esr_rng_init(2024, 3);
    for (int i = 0; i < N; i++) {
        float u = esr_rng_float(&r);
        assert_true(u >= 0.0f && u < 1.0f);
        observed[(int)(u * BINS)] += 1.0;
    }
    for (int b = 0; b < BINS; b++)
        expected[b] = (double)N / BINS;
    assert_true(test_chi2_statistic(observed, expected, BINS) < test_chi2_critical(BINS - 1, CHI2_Z));
    /* the largest 24-bit value maps strictly below 1 */
    assert_true((float)(0xFFFFFFFFu >> 8) * (1.0f / 16777216.0f) < 1.0f);
}

/* Consecutive pairs fill the unit square evenly (catches lag-1 dependence). */
static void test_float_pairs_uniform(void **state)
{
    (void)state;
    enum { SIDE = 16, N = 1 << 19 };
    double observed[SIDE * SIDE] = {0}, expected[SIDE * SIDE];
    struct esr_rng r = esr_rng_init(77, 0);
    for (int i = 0; i < N; i++) {
        int x = (int)(esr_rng_float(&r) * SIDE), y = (int)(esr_rng_float(&r) * SIDE);
        observed[y * SIDE + x] += 1.0;
    }
    for (int b = 0; b < SIDE * SIDE; b++)
        expected[b] = (double)N / (SIDE * SIDE);
    assert_true(test_chi2_statistic(observed, expected, SIDE * SIDE) <
                test_chi2_critical(SIDE * SIDE - 1, CHI2_Z));
}

static void test_below_range_and_uniformity(void **state)
{
    (void)state;
    const uint32_t ns[] = {1, 2, 7, 10, 100, 1000};
    for (size_t k = 0; k < sizeof ns / sizeof ns[0]; k++) {
        uint32_t n = ns[k];
        int draws = 2000 * (int)n;
        double *observed = calloc(n, sizeof *observed), *expected = malloc(sizeof *expected * n);
        assert_non_null(observed);
        assert_non_null(expected);
        struct esr_rng r = esr_rng_init(31337, n);
        for (int i = 0; i < draws; i++) {
            uint32_t v = esr_rng_below(&r, n);
            assert_true(v < n);
            observed[v] += 1.0;
        }
        for (uint32_t b = 0; b < n; b++)
            expected[b] = (double)draws / n;
        if (n > 1)
            assert_true(test_chi2_statistic(observed, expected, n) < test_chi2_critical(n - 1, CHI2_Z));
        free(observed);
        free(expected);
    }
}

/* esr_rng_u64 is two u32 draws, the first one the high half, and advances the counter by two. */
static void test_u64_is_two_draws_high_first(void **state)
{
    (void)state;
    struct esr_rng a = esr_rng_init(7, 3), b = esr_rng_init(7, 3);
    for (int i = 0; i < 100; i++) {
        const uint64_t hi = esr_rng_u32(&b), lo = esr_rng_u32(&b);
        assert_true(esr_rng_u64(&a) == (hi << 32 | lo));
    }
    assert_true(esr_rng_u32(&a) == esr_rng_u32(&b));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_same_seed_stream_same_sequence),
        cmocka_unit_test(test_streams_differ),
        cmocka_unit_test(test_float_range_and_uniformity),
        cmocka_unit_test(test_float_pairs_uniform),
        cmocka_unit_test(test_below_range_and_uniformity),
        cmocka_unit_test(test_u64_is_two_draws_high_first),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
