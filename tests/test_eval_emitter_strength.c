/* The lights' strengths summarised (eval/emitter_strength.h) against values worked by hand, and
 * on a small `esr synth` dataset with made-up renders: no light is dropped (one too small for the
 * eroded mask is scored on its whole mask and flagged, one no view shows is listed unscored), the
 * image-space power counts a found light's own pixels, the light counts see a fleck that is no
 * true light; the JSON and the report carry them. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "eval/emitter_strength.h"
#include "eval/evaluate.h"
#include "io/dataset.h"
#include "io/image.h"
#include "test_support.h"

/* Geometric mean and worst light by hand:
 *   {0.5, 2}:        sqrt(0.5 * 2) = 1; |0.5 - 1| = 0.5, |2 - 1| = 1 -> worst 1, light 1
 *   {0.5, 0.8}:      sqrt(0.4) = 0.6324555; 0.5 / 0.6324555 = 0.7905694, 0.8 / 0.6324555 =
 *                    1.2649111 -> worst 0.2649111, light 1
 *   {0.9, 1, 1.1}:   cbrt(0.99) = 0.9966555; 1.1 / 0.9966555 = 1.1036913 -> worst 0.1036913
 *   {0, 2, 2}:       the dark light has no logarithm: scale 2, and it is 100% off (worst 1, light 0)
 *   {NAN, 3}:        the unscored light is skipped: scale 3, worst 0
 *   {} or {0}:       no scale (NAN) */
static void test_summary_by_hand(void **state)
{
    (void)state;
    struct esr_emitter_strength s;
    const double a[] = {0.5, 2.0};
    esr_emitter_strength_summarise(a, NULL, 2, &s);
    assert_float_equal(s.shared_scale, 1.0, 1e-12);
    assert_float_equal(s.worst_relative, 1.0, 1e-12);
    assert_int_equal(s.worst_light, 1);
    assert_int_equal(s.scored, 2);
    assert_int_equal(s.dark, 0);
    const double b[] = {0.5, 0.8};
    const int ids[] = {4, 7};
    esr_emitter_strength_summarise(b, ids, 2, &s);
    assert_float_equal(s.shared_scale, 0.6324555, 1e-7);
    assert_float_equal(s.worst_relative, 0.2649111, 1e-7);
    assert_int_equal(s.worst_light, 7);
    const double c[] = {0.9, 1.0, 1.1};
    esr_emitter_strength_summarise(c, NULL, 3, &s);
    assert_float_equal(s.shared_scale, 0.9966555, 1e-7);
    assert_float_equal(s.worst_relative, 0.1036913, 1e-7);
    assert_int_equal(s.worst_light, 2);
    const double d[] = {0.0, 2.0, 2.0};
    esr_emitter_strength_summarise(d, NULL, 3, &s);
    assert_float_equal(s.shared_scale, 2.0, 1e-12);
    assert_float_equal(s.worst_relative, 1.0, 1e-12);
    assert_int_equal(s.worst_light, 0);
    assert_int_equal(s.dark, 1);
    assert_int_equal(s.scored, 3);
    const double e[] = {NAN, 3.0};
    esr_emitter_strength_summarise(e, NULL, 2, &s);
    assert_float_equal(s.shared_scale, 3.0, 1e-12);
    assert_float_equal(s.worst_relative, 0.0, 1e-12);
    assert_int_equal(s.scored, 1);
    esr_emitter_strength_summarise(e, NULL, 0, &s);
    assert_true(isnan(s.shared_scale) && isnan(s.worst_relative));
    assert_int_equal(s.worst_light, -1);
    esr_emitter_strength_summarise(d, NULL, 1, &s); /* only the dark light */
    assert_true(isnan(s.shared_scale));
    assert_int_equal(s.dark, 1);
}

/* Rec. 709 luminance: (2,2,2) / (1,1,1) = 2; red over green = 0.2126 / 0.7152 = 0.2972595. */
static void test_luminance_ratio(void **state)
{
    (void)state;
    const double two[3] = {2, 2, 2}, one[3] = {1, 1, 1}, red[3] = {1, 0, 0}, green[3] = {0, 1, 0};
    const double black[3] = {0, 0, 0}, nan3[3] = {NAN, NAN, NAN};
    assert_float_equal(esr_emitter_luminance_ratio(two, one), 2.0, 1e-12);
    assert_float_equal(esr_emitter_luminance_ratio(red, green), 0.2972595, 1e-7);
    assert_true(isnan(esr_emitter_luminance_ratio(one, black)));
    assert_true(isnan(esr_emitter_luminance_ratio(nan3, one)));
}

static char *tmp;
static char out[8192];

static int setup(void **state)
{
    (void)state;
    tmp = test_make_tmpdir();
    char args[1024];
    snprintf(args, sizeof args, "synth --scene ratios --res 64 --spp 1 --train 1 --test 1 %s/ds", tmp);
    const int rc = test_run_esr(args, out, sizeof out);
    if (rc != 0)
        fprintf(stderr, "%s\n", out);
    return rc;
}

static int teardown(void **state)
{
    (void)state;
    test_rmtree(tmp);
    free(tmp);
    return 0;
}

static double lum(const float rgb[3]) { return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]; }

static void read_mask(const char *path, struct esr_image *m)
{
    if (esr_png_read(path, m) != 0)
        fail_msg("cannot read %s", path);
}

/* The ratios scene at 64 px, its one test camera's two views (off, on). Made-up renders:
 *   light 0: its true mask, emission 0.5 x truth, light id 0, and one pixel beside the masks
 *            with id 0 and the same emission (esr found it one pixel too large);
 *   light 1: its masks replaced by one pixel of it (no eroded pixel), emission 0.8 x truth there,
 *            light id 1;
 *   light 2: its masks emptied (no view shows it);
 *   a fleck: one more pixel outside the masks, light id 2, emission 1 (no true light).
 * So: light 0 scored eroded, luminance ratio 0.5, power ratio 0.5 (m + 1) / m for its mask of m
 * pixels per view; light 1 on its whole mask (2 pixels), 0.8, power 0.8; light 2 listed with 0
 * pixels and no scores; shared scale sqrt(0.4), worst 0.2649111 (light 1); 3 lights found in the
 * renders, 1 of them wrong, 3 true. */
static void test_on_dataset(void **state)
{
    (void)state;
    char dir[2048], render[2048], path[4096];
    snprintf(dir, sizeof dir, "%s/ds", tmp);
    snprintf(render, sizeof render, "%s/render", tmp);
    assert_int_equal(mkdir(render, 0755), 0);
    struct esr_dataset ds;
    assert_int_equal(esr_dataset_load(dir, &ds), 0);
    assert_int_equal(ds.n_true_lights, 3);
    const struct esr_phase *nv = &ds.phases[ESR_PHASE_TEST_NV];
    assert_int_equal(nv->n_frames, 2);
    const int W = ds.width, H = ds.height, np = W * H;
    long m0 = 0; /* light 0's mask pixels, per view (the two views share the camera) */
    for (int i = 0; i < nv->n_frames; i++) {
        const struct esr_frame *f = &nv->frames[i];
        struct esr_image mask[3], em, ids;
        for (int k = 0; k < 3; k++) {
            esr_frame_light_mask_path(&ds, f, k, path, sizeof path);
            read_mask(path, &mask[k]);
        }
        int one = -1, extra = -1, fleck = -1; /* light 1's kept pixel, light 0's extra, the fleck */
        m0 = 0;
        for (int p = 0; p < np; p++) {
            const int in0 = mask[0].data[p] > 0.5f, in1 = mask[1].data[p] > 0.5f, in2 = mask[2].data[p] > 0.5f;
            m0 += in0;
            if (in1 && one < 0)
                one = p;
            else if (!in0 && !in1 && !in2 && extra < 0)
                extra = p;
            else if (!in0 && !in1 && !in2 && fleck < 0)
                fleck = p;
        }
        assert_true(one >= 0 && extra >= 0 && fleck >= 0);
        assert_true(m0 > 9); /* large enough to have eroded pixels */
        assert_int_equal(esr_image_alloc(&em, W, H, 3), 0);
        assert_int_equal(esr_image_alloc(&ids, W, H, 1), 0);
        for (int p = 0; p < np; p++) {
            const int in0 = mask[0].data[p] > 0.5f || p == extra;
            const int id = in0 ? 1 : p == one ? 2 : p == fleck ? 3 : 0;
            ids.data[p] = (float)id / 255.0f;
            for (int c = 0; c < 3; c++)
                em.data[3 * p + c] = in0 ? 0.5f * ds.true_lights[0].radiance[c]
                                   : p == one ? 0.8f * ds.true_lights[1].radiance[c]
                                   : p == fleck ? 1.0f
                                                : 0.0f;
        }
        for (int p = 0; p < np; p++) {
            mask[1].data[p] = p == one ? 1.0f : 0.0f;
            mask[2].data[p] = 0.0f;
        }
        for (int k = 1; k < 3; k++) {
            esr_frame_light_mask_path(&ds, f, k, path, sizeof path);
            assert_int_equal(esr_png_write(path, &mask[k], 8), 0);
        }
        snprintf(path, sizeof path, "%s/%s_emission.exr", render, f->name);
        assert_int_equal(esr_exr_write(path, &em, 0), 0);
        snprintf(path, sizeof path, "%s/%s_lights.png", render, f->name);
        assert_int_equal(esr_png_write(path, &ids, 8), 0);
        for (int k = 0; k < 3; k++)
            esr_image_free(&mask[k]);
        esr_image_free(&em);
        esr_image_free(&ids);
    }
    const int idx[2] = {0, 1};
    struct esr_eval_result res;
    memset(&res, 0, sizeof res);
    res.phase = ESR_PHASE_TEST_NV;
    assert_int_equal(esr_emitter_radiance_eval(&ds, ESR_PHASE_TEST_NV, idx, 2, render, &res.radiance), 0);
    assert_int_equal(esr_light_split_eval(&ds, ESR_PHASE_TEST_NV, idx, 2, render, &res.split), 0);
    assert_int_equal(esr_emitter_strength_eval(&ds, ESR_PHASE_TEST_NV, idx, 2, render, &res.split, &res.radiance,
                                               &res.strength),
                     0);
    const struct esr_emitter_radiance_result *r = &res.radiance;
    assert_int_equal(r->n, 3); /* none dropped */
    assert_int_equal(r->lights[0].eroded, 1);
    assert_true(r->lights[0].pixels > 0 && r->lights[0].pixels < 2 * m0);
    assert_int_equal(r->lights[0].mask_pixels, 2 * m0);
    assert_float_equal(r->lights[0].lum_ratio, 0.5, 1e-6);
    assert_float_equal(r->lights[0].power_ratio, 0.5 * (double)(m0 + 1) / (double)m0, 1e-6);
    assert_float_equal(r->lights[0].truth_power, 2.0 * (double)m0 * lum(ds.true_lights[0].radiance), 1e-3);
    assert_int_equal(r->lights[1].eroded, 0);
    assert_int_equal(r->lights[1].pixels, 2);
    assert_float_equal(r->lights[1].lum_ratio, 0.8, 1e-6);
    assert_float_equal(r->lights[1].power_ratio, 0.8, 1e-6);
    assert_int_equal(r->lights[2].pixels, 0);
    assert_true(isnan(r->lights[2].lum_ratio) && isnan(r->lights[2].power_ratio));
    const struct esr_emitter_strength *s = &res.strength;
    assert_float_equal(s->shared_scale, 0.6324555, 1e-6);
    assert_float_equal(s->worst_relative, 0.2649111, 1e-6);
    assert_int_equal(s->worst_light, 1);
    assert_int_equal(s->scored, 2);
    assert_int_equal(s->lights_found, 3);
    assert_string_equal(s->found_from, "renders");
    assert_int_equal(s->lights_wrong, 1);
    assert_int_equal(s->lights_true, 3);

    /* the JSON */
    char json[4096];
    snprintf(json, sizeof json, "%s/eval.json", tmp);
    assert_int_equal(esr_eval_write_json(json, &ds, &res), 0);
    cJSON *root = test_read_json(json);
    assert_non_null(root);
    const cJSON *st = cJSON_GetObjectItemCaseSensitive(root, "emitter_strength");
    assert_non_null(st);
    assert_float_equal(cJSON_GetObjectItemCaseSensitive(st, "shared_scale")->valuedouble, 0.6324555, 1e-6);
    assert_float_equal(cJSON_GetObjectItemCaseSensitive(st, "worst_relative")->valuedouble, 0.2649111, 1e-6);
    assert_int_equal(cJSON_GetObjectItemCaseSensitive(st, "lights_found")->valueint, 3);
    assert_int_equal(cJSON_GetObjectItemCaseSensitive(st, "lights_true")->valueint, 3);
    const cJSON *arr = cJSON_GetObjectItemCaseSensitive(root, "emitter_radiance");
    assert_int_equal(cJSON_GetArraySize(arr), 3);
    assert_true(cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(cJSON_GetArrayItem(arr, 0), "eroded")));
    assert_true(cJSON_IsFalse(cJSON_GetObjectItemCaseSensitive(cJSON_GetArrayItem(arr, 1), "eroded")));
    assert_true(cJSON_IsNull(cJSON_GetObjectItemCaseSensitive(cJSON_GetArrayItem(arr, 2), "power_ratio")));
    assert_float_equal(cJSON_GetObjectItemCaseSensitive(cJSON_GetArrayItem(arr, 1), "power_ratio")->valuedouble,
                       0.8, 1e-6);
    cJSON_Delete(root);

    /* the report's table and the terminal's lines */
    char html[4096];
    snprintf(html, sizeof html, "%s/strength.html", tmp);
    FILE *fh = fopen(html, "w");
    assert_non_null(fh);
    esr_emitter_strength_put_html(fh, &res.radiance, &res.strength);
    esr_emitter_strength_print(fh, &res.radiance, &res.strength);
    fclose(fh);
    fh = fopen(html, "r");
    static char text[16384];
    const size_t got = fread(text, 1, sizeof text - 1, fh);
    text[got] = '\0';
    fclose(fh);
    assert_non_null(strstr(text, "shared scale 0.632"));
    assert_non_null(strstr(text, "worst light 1 at 26.5%"));
    assert_non_null(strstr(text, "whole mask"));
    assert_non_null(strstr(text, "not seen"));
    assert_non_null(strstr(text, "3 lights found (renders) for 3 true"));
    assert_non_null(strstr(text, "1 rendered light(s) follow no true light"));
    assert_non_null(strstr(text, "light 1 (green_box_light): luminance x0.800 of the truth (x1.265 of the shared "
                                 "scale), power x0.800; scored on its whole mask"));
    assert_non_null(strstr(text, "strength: shared scale 0.632, worst light 1 26.5% from it"));
    esr_dataset_free(&ds);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_summary_by_hand),
        cmocka_unit_test(test_luminance_ratio),
        cmocka_unit_test(test_on_dataset),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
