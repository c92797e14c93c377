/* Weighted k-means (core/kmeans.h): blobs found as the clusters they are, their number decided
 * by the separation, small clusters dropped, weights counted, bad input refused. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>

#include "core/kmeans.h"
#include "core/rng.h"

#define N 3000

/* Three blobs in (roughness, metallic) of 1500, 1000 and 500 points at known centres, jittered
 * by +-0.02: found as three clusters, heaviest first, each centre within 0.005 of its blob's
 * own mean, every point in its blob's cluster. */
static void test_finds_blobs(void **state)
{
    (void)state;
    static float x[N * 2];
    static int32_t assign[N];
    const float truth[3][2] = {{0.8f, 0.05f}, {0.2f, 0.95f}, {0.35f, 0.1f}};
    const int count[3] = {1500, 1000, 500};
    double mean[3][2] = {{0}};
    int blob[N];
    struct esr_rng s = esr_rng_init(7, 0);
    for (int i = 0, b = 0, left = count[0]; i < N; i++, left--) {
        if (left == 0)
            left = count[++b];
        blob[i] = b;
        for (int c = 0; c < 2; c++) {
            x[i * 2 + c] = truth[b][c] + 0.04f * (esr_rng_float(&s) - 0.5f);
            mean[b][c] += x[i * 2 + c] / count[b];
        }
    }
    float centres[ESR_KMEANS_MAX_K * 2];
    int k = 0;
    const struct esr_kmeans_params p = {.x = x, .n = N, .dim = 2, .k_max = 8,
                                        .min_separation = 0.1f, .min_share = 0.01f, .iters = 50};
    double weights[ESR_KMEANS_MAX_K];
    assert_int_equal(esr_kmeans(&p, centres, assign, weights, &k), 0);
    assert_int_equal(k, 3);
    for (int b = 0; b < 3; b++) /* each cluster's weight: its blob's points */
        assert_true(weights[b] == count[b]);
    for (int b = 0; b < 3; b++) /* heaviest first: blob b is cluster b */
        for (int c = 0; c < 2; c++)
            assert_true(fabs(centres[b * 2 + c] - mean[b][c]) < 0.005);
    for (int i = 0; i < N; i++)
        assert_int_equal(assign[i], blob[i]);
    /* a separation wider than the blobs' distances leaves one cluster at the mean */
    const struct esr_kmeans_params wide = {.x = x, .n = N, .dim = 2, .k_max = 8,
                                           .min_separation = 2.0f, .iters = 50};
    assert_int_equal(esr_kmeans(&wide, centres, assign, NULL, &k), 0);
    assert_int_equal(k, 1);
    assert_true(fabs(centres[0] - (1500 * 0.8 + 1000 * 0.2 + 500 * 0.35) / N) < 0.005);
    /* k_max caps the count */
    const struct esr_kmeans_params two = {.x = x, .n = N, .dim = 2, .k_max = 2,
                                          .min_separation = 0.1f, .iters = 50};
    assert_int_equal(esr_kmeans(&two, centres, assign, NULL, &k), 0);
    assert_int_equal(k, 2);
}

/* Weights: two points of weight 3 and 1 at 0 and 1 in one cluster have their centre at 0.25;
 * a lone outlier of under min_share of the weight is no cluster of its own. */
static void test_weights_and_small_clusters(void **state)
{
    (void)state;
    const float x[2] = {0.0f, 1.0f}, w[2] = {3.0f, 1.0f};
    float c[ESR_KMEANS_MAX_K];
    int32_t a[2];
    int k = 0;
    const struct esr_kmeans_params one = {.x = x, .w = w, .n = 2, .dim = 1, .k_max = 1, .iters = 5};
    double wsum[ESR_KMEANS_MAX_K];
    assert_int_equal(esr_kmeans(&one, c, a, wsum, &k), 0);
    assert_int_equal(k, 1);
    assert_true(fabsf(c[0] - 0.25f) < 1e-6f);
    assert_true(wsum[0] == 4.0);
    /* 999 points at 0 and one at 5: at min_share 0.01 the outlier joins the big cluster */
    static float y[1000];
    static int32_t b[1000];
    y[999] = 5.0f;
    const struct esr_kmeans_params out = {.x = y, .n = 1000, .dim = 1, .k_max = 4,
                                          .min_separation = 0.1f, .min_share = 0.01f, .iters = 20};
    assert_int_equal(esr_kmeans(&out, c, b, NULL, &k), 0);
    assert_int_equal(k, 1);
    assert_int_equal(b[999], 0);
    assert_true(fabsf(c[0] - 0.005f) < 1e-6f);
    /* without the share it is its own cluster, the second */
    const struct esr_kmeans_params keep = {.x = y, .n = 1000, .dim = 1, .k_max = 4,
                                           .min_separation = 0.1f, .iters = 20};
    assert_int_equal(esr_kmeans(&keep, c, b, NULL, &k), 0);
    assert_int_equal(k, 2);
    assert_int_equal(b[999], 1);
    assert_true(c[0] == 0.0f && c[1] == 5.0f);
}

/* No points, no weight, bad parameters and non-finite input. */
static void test_edges_and_bad_input(void **state)
{
    (void)state;
    float c[ESR_KMEANS_MAX_K * 2];
    int32_t a[3];
    int k = 0;
    const struct esr_kmeans_params empty = {.dim = 2, .k_max = 4, .iters = 5};
    assert_int_equal(esr_kmeans(&empty, c, a, NULL, &k), 0);
    assert_int_equal(k, 1);
    const float x[6] = {0, 0, 1, 1, 2, 2}, zero[3] = {0, 0, 0};
    const struct esr_kmeans_params nowt = {.x = x, .w = zero, .n = 3, .dim = 2, .k_max = 4,
                                           .iters = 5};
    assert_int_equal(esr_kmeans(&nowt, c, a, NULL, &k), 0);
    assert_int_equal(k, 1);
    assert_true(c[0] == 1.0f && c[1] == 1.0f);
    const struct esr_kmeans_params bad_dim = {.x = x, .n = 3, .dim = 0, .k_max = 4};
    assert_int_not_equal(esr_kmeans(&bad_dim, c, a, NULL, &k), 0);
    const struct esr_kmeans_params bad_k = {.x = x, .n = 3, .dim = 2, .k_max = ESR_KMEANS_MAX_K + 1};
    assert_int_not_equal(esr_kmeans(&bad_k, c, a, NULL, &k), 0);
    const float nan_x[6] = {0, 0, NAN, 1, 2, 2}, neg_w[3] = {1, -1, 1};
    const struct esr_kmeans_params has_nan = {.x = nan_x, .n = 3, .dim = 2, .k_max = 2};
    assert_int_not_equal(esr_kmeans(&has_nan, c, a, NULL, &k), 0);
    const struct esr_kmeans_params has_neg = {.x = x, .w = neg_w, .n = 3, .dim = 2, .k_max = 2};
    assert_int_not_equal(esr_kmeans(&has_neg, c, a, NULL, &k), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_finds_blobs),
        cmocka_unit_test(test_weights_and_small_clusters),
        cmocka_unit_test(test_edges_and_bad_input),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
