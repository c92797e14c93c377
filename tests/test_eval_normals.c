/* Angular error of rendered normals (eval/normals.h): the angle against values computed here by
 * other formulas, which pixels are scored, the statistics, and how a frame finds its
 * ground-truth map. The evaluation of whole render directories is in test_eval_evaluate.c and,
 * end to end through `esr eval`, in test_cli_render.c. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "core/error.h"
#include "eval/normals.h"
#include "io/dataset.h"
#include "io/image.h"
#include "test_support.h"

#define DEG (180.0 / M_PI)

static void expect_angle(float ax, float ay, float az, float bx, float by, float bz, double expect, double tol)
{
    const float a[3] = {ax, ay, az}, b[3] = {bx, by, bz};
    double got = esr_normal_angle_deg(a, b), back = esr_normal_angle_deg(b, a);
    if (!(fabs(got - expect) <= tol) || !(fabs(back - expect) <= tol))
        fail_msg("angle (%g %g %g) vs (%g %g %g): got %.9g / %.9g, expected %.9g", ax, ay, az, bx, by, bz, got, back,
                 expect);
}

static void test_angle_known_vectors(void **state)
{
    (void)state;
    expect_angle(1, 0, 0, 0, 1, 0, 90.0, 1e-12);
    expect_angle(0, 0, 1, 0, 0, 1, 0.0, 0.0);
    expect_angle(1, 0, 0, 1, 1, 0, 45.0, 1e-12);
    expect_angle(0, 1, 0, 0, -1, 0, 180.0, 0.0);
    expect_angle(0.3f, -0.4f, 0.5f, -0.3f, 0.4f, -0.5f, 180.0, 1e-12);
    /* unnormalised inputs: only the directions count */
    expect_angle(3, 0, 0, 0, 0, 0.5f, 90.0, 1e-12);
    expect_angle(2, 2, 0, 0, 5, 0, 45.0, 1e-12);
    expect_angle(0.01f, 0.01f, 0.01f, 7, 7, 7, 0.0, 1e-5);
    expect_angle(1, 2, 3, -2, 1, 0, 90.0, 1e-12); /* dot product 0 */
    /* (1,2,2)/3 . (2,-1,2)/3 = 4/9; 120 degrees in the xy plane: cos = -1/2 */
    expect_angle(1, 2, 2, 2, -1, 2, acos(4.0 / 9.0) * DEG, 1e-9);
    expect_angle(1, 0, 0, -0.5f, (float)(sqrt(3.0) / 2.0), 0, 120.0, 1e-5);
    expect_angle(0, 0, 2, 0, 1, 1, 45.0, 1e-12);
    /* near 0 degrees the error is still resolved (an acos of a float dot would give 0) */
    expect_angle(1, 0, 0, 1, 1e-4f, 0, atan(1e-4) * DEG, 1e-9);
}

static void test_angle_degenerate(void **state)
{
    (void)state;
    const float zero[3] = {0, 0, 0}, x[3] = {1, 0, 0}, inf[3] = {INFINITY, 0, 0}, nan3[3] = {NAN, 0, 1};
    assert_true(isnan(esr_normal_angle_deg(zero, x)));
    assert_true(isnan(esr_normal_angle_deg(x, zero)));
    assert_true(isnan(esr_normal_angle_deg(inf, x)));
    assert_true(isnan(esr_normal_angle_deg(x, nan3)));
}

/* One pixel of each case; pred = composited normal + opacity, gt = normal (0 on background). */
static const struct {
    float pred[4], gt[3];
} pixels[] = {
    {{0, 0, 0.9f, 0.9f}, {0, 0, 1}},      /* scored: 0 degrees */
    {{0, 0.8f, 0, 0.8f}, {1, 0, 0}},      /* scored: 90 degrees */
    {{1, 0, 0, 0.4f}, {1, 0, 0}},         /* surface, prediction not opaque: not scored */
    {{0, 1, 0, 1.0f}, {0, 0, 0}},         /* background in the ground truth: ignored */
    {{1, 0, 0, 0.5f}, {1, 0, 0}},         /* opacity exactly 0.5: not scored */
    {{0, 0, 0, 1.0f}, {0, 1, 0}},         /* opaque but no normal (alphamask stage): not scored */
    {{0.5f, 0.5f, 0, 0.75f}, {0, 2, 0}},  /* scored: 45 degrees, unnormalised on both sides */
};
#define N_PIX ((int)(sizeof pixels / sizeof pixels[0]))

static void make_maps(struct esr_image *pred, struct esr_image *gt, int gt_channels)
{
    assert_int_equal(esr_image_alloc(pred, N_PIX, 1, 4), ESR_OK);
    assert_int_equal(esr_image_alloc(gt, N_PIX, 1, gt_channels), ESR_OK);
    for (int i = 0; i < N_PIX; i++) {
        memcpy(pred->data + 4 * i, pixels[i].pred, sizeof pixels[i].pred);
        memcpy(gt->data + gt_channels * i, pixels[i].gt, sizeof pixels[i].gt);
        if (gt_channels == 4)
            gt->data[4 * i + 3] = 1.0f; /* as esr_exr_read returns a 3-channel file */
    }
}

static void test_masking(void **state)
{
    (void)state;
    for (int gt_channels = 3; gt_channels <= 4; gt_channels++) {
        struct esr_image pred, gt;
        struct esr_normal_errors e;
        memset(&e, 0, sizeof e);
        make_maps(&pred, &gt, gt_channels);
        assert_int_equal(esr_normal_errors_add(&e, &pred, &gt), ESR_OK);
        assert_int_equal(e.n_gt, 6);
        assert_int_equal(e.n, 3);
        assert_true(fabsf(e.deg[0]) < 1e-6f && fabsf(e.deg[1] - 90.0f) < 1e-4f && fabsf(e.deg[2] - 45.0f) < 1e-4f);
        /* a second view appends */
        assert_int_equal(esr_normal_errors_add(&e, &pred, &gt), ESR_OK);
        assert_int_equal(e.n_gt, 12);
        assert_int_equal(e.n, 6);
        struct esr_normal_stats s = esr_normal_stats_of(e.deg, e.n, e.n_gt);
        assert_int_equal(s.n, 6);
        assert_int_equal(s.n_gt, 12);
        assert_true(fabs(s.mean_deg - 45.0) < 1e-4);
        assert_true(fabs(s.median_deg - 45.0) < 1e-4);
        assert_true(fabs(s.frac_good - 1.0 / 3.0) < 1e-12);
        assert_true(fabs(s.coverage - 0.5) < 1e-12);
        esr_normal_errors_free(&e);
        esr_image_free(&pred);
        esr_image_free(&gt);
    }
}

static void test_masking_errors(void **state)
{
    (void)state;
    struct esr_image pred, gt, small;
    struct esr_normal_errors e;
    memset(&e, 0, sizeof e);
    make_maps(&pred, &gt, 3);
    assert_int_equal(esr_image_alloc(&small, 2, 1, 3), ESR_OK);
    memset(small.data, 0, esr_image_count(&small) * sizeof(float));
    esr_error_clear();
    assert_int_equal(esr_normal_errors_add(&e, &pred, &small), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "7x1 but the ground truth is 2x1"));
    esr_error_clear();
    assert_int_equal(esr_normal_errors_add(&e, &gt, &gt), ESR_ERR); /* no opacity channel */
    assert_non_null(strstr(esr_error_message(), "expected 4"));
    esr_error_clear();
    assert_int_equal(e.n, 0);
    esr_normal_errors_free(&e);
    esr_image_free(&pred);
    esr_image_free(&gt);
    esr_image_free(&small);
}

static void test_stats(void **state)
{
    (void)state;
    float odd[] = {30.0f, 10.0f, 2.0f, 9.5f, 50.0f};
    struct esr_normal_stats s = esr_normal_stats_of(odd, 5, 10);
    assert_true(fabs(s.mean_deg - 101.5 / 5.0) < 1e-6);
    assert_true(s.median_deg == 10.0);
    assert_true(fabs(s.frac_good - 0.4) < 1e-12); /* 2 and 9.5; 10 itself is not under 10 */
    assert_true(fabs(s.coverage - 0.5) < 1e-12);
    float even[] = {4.0f, 1.0f, 20.0f, 3.0f};
    s = esr_normal_stats_of(even, 4, 4);
    assert_true(s.median_deg == 3.5);
    assert_true(s.coverage == 1.0);
    s = esr_normal_stats_of(NULL, 0, 3);
    assert_int_equal(s.n, 0);
    assert_true(isnan(s.mean_deg) && isnan(s.median_deg) && isnan(s.frac_good));
    assert_true(s.coverage == 0.0);
    s = esr_normal_stats_of(NULL, 0, 0);
    assert_true(isnan(s.coverage));
}

/* c<CCC>_<condition> maps to gt/c<CCC>_normal.exr when that file exists; other names never. */
static void test_gt_path(void **state)
{
    (void)state;
    struct esr_dataset ds;
    struct esr_frame f;
    char path[2048], expect[2048];
    memset(&ds, 0, sizeof ds);
    memset(&f, 0, sizeof f);
    snprintf(ds.root, sizeof ds.root, "%s", test_tmpdir);
    snprintf(expect, sizeof expect, "%s/gt", test_tmpdir);
    assert_int_equal(mkdir(expect, 0755), 0);
    snprintf(expect, sizeof expect, "%s/gt/c007_normal.exr", test_tmpdir);
    assert_int_equal(test_write_file(expect, "x"), 0);
    static const char *const yes[] = {"c007_off", "c007_on", "c007_ic1"};
    for (int i = 0; i < 3; i++) {
        snprintf(f.name, sizeof f.name, "%s", yes[i]);
        path[0] = '\0';
        assert_int_equal(esr_normal_gt_path(&ds, &f, path, sizeof path), 1);
        assert_string_equal(path, expect);
    }
    static const char *const no[] = {"c008_off", "r_007", "c_off", "c007", "c07x_off", "x007_off", "C007_off"};
    for (int i = 0; i < 7; i++) {
        snprintf(f.name, sizeof f.name, "%s", no[i]);
        if (esr_normal_gt_path(&ds, &f, path, sizeof path))
            fail_msg("frame '%s' should have no ground-truth normal map", no[i]);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_angle_known_vectors), cmocka_unit_test(test_angle_degenerate),
        cmocka_unit_test(test_masking),             cmocka_unit_test(test_masking_errors),
        cmocka_unit_test(test_stats),               cmocka_unit_test(test_gt_path),
    };
    return cmocka_run_group_tests(tests, test_setup_tmpdir, test_teardown_tmpdir);
}
