/* The model's render outputs (model/model.h esr_model_render_rays) on the shared tiny run's pdra
 * model (tests/support/tiny_run.h): linear_other is the other lighting's render bit for bit, and
 * lights_emitted_only shows a light's pixels as the lights-off radiance plus its emission. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "model/model.h"
#include "test_support.h"
#include "tiny_run.h"

/* A render's linear_other (model.h) is the other lighting's linear render bit for bit, from
 * either side, with the lights' calibrated emission where lit. */
static void test_render_other_lighting(void **state)
{
    (void)state;
    struct pdra_view v;
    pdra_view_open(&v);
    const size_t px = v.px, n = px * 3;
    float *o = malloc(n * sizeof(float)), *d = malloc(n * sizeof(float));
    float *lin = malloc(n * sizeof(float)), *other = malloc(n * sizeof(float));
    assert_true(o && d && lin && other);
    esr_camera_pixel_rays(v.cam, o, d);
    for (int on = 0; on < 2; on++) {
        struct esr_render_out r = {.linear = lin, .linear_other = other};
        assert_int_equal(esr_model_render_rays(&v.m, o, d, px, on, &r), ESR_OK);
        assert_memory_equal(lin, on ? v.on : v.off, n * sizeof(float));
        assert_memory_equal(other, on ? v.off : v.on, n * sizeof(float));
    }
    assert_true(memcmp(v.on, v.off, n * sizeof(float)) != 0); /* the lights show */
    free(o), free(d), free(lin), free(other);
    pdra_view_close(&v);
}

/* lights_emitted_only (model.h): a lights-on render whose samples on a light show the lights-off
 * radiance plus the light's emission. Raising L_emo everywhere (the emo MLP's output bias +1:
 * L_emo = softplus, about x e where it is small) then barely moves the pixels whose strongest
 * sample is on a light, which the plain render moves with their L_emo; pixels with no sample on
 * a light render as without the flag, bit for bit. */
static void test_render_lights_emitted_only(void **state)
{
    (void)state;
    struct pdra_view v;
    pdra_view_open(&v);
    struct esr_model *m = &v.m;
    const size_t px = v.px, n = px * 3;
    float *o = malloc(n * sizeof(float)), *d = malloc(n * sizeof(float));
    float *lit = malloc(n * sizeof(float)), *plain[2], *only[2];
    assert_true(o && d && lit);
    for (int s = 0; s < 2; s++) {
        plain[s] = malloc(n * sizeof(float)), only[s] = malloc(n * sizeof(float));
        assert_true(plain[s] && only[s]);
    }
    esr_camera_pixel_rays(v.cam, o, d);
    const struct esr_mlp *mlp = esr_model_mlp(m, ESR_COMP_EMO_MLP);
    float *bias = m->params.w + mlp->b_off[mlp->n_layers - 1];
    for (int s = 0; s < 2; s++) {
        for (int c = 0; c < 3; c++)
            bias[c] += (float)s;
        struct esr_render_out r = {.linear = plain[s], .emitted_lights = lit};
        assert_int_equal(esr_model_render_rays(m, o, d, px, 1, &r), ESR_OK);
        struct esr_render_out f = {.linear = only[s], .lights_emitted_only = 1};
        assert_int_equal(esr_model_render_rays(m, o, d, px, 1, &f), ESR_OK);
    }
    size_t on_light = 0, untouched = 0;
    double moved_plain = 0.0, moved_only = 0.0;
    for (size_t p = 0; p < px; p++) {
        const int any_lit = lit[p * 3] != 0.0f || lit[p * 3 + 1] != 0.0f || lit[p * 3 + 2] != 0.0f;
        if (!any_lit) {
            assert_memory_equal(only[0] + p * 3, plain[0] + p * 3, 3 * sizeof(float));
            untouched++;
        }
        if (v.ids[p] < 0)
            continue;
        on_light++;
        moved_plain += plain[1][p * 3] - plain[0][p * 3];
        moved_only += only[1][p * 3] - only[0][p * 3];
    }
    print_message("lights_emitted_only: %zu pixels on a light: L_emo raised moves them %.3f (plain "
                  "%.3f); %zu pixels without a lit sample unchanged\n", on_light,
                  moved_only / (double)on_light, moved_plain / (double)on_light, untouched);
    assert_true(on_light > 0 && untouched > 0);
    assert_true(moved_plain / (double)on_light > 0.05);
    assert_true(moved_only < 0.25 * moved_plain);
    free(o), free(d), free(lit);
    for (int s = 0; s < 2; s++)
        free(plain[s]), free(only[s]);
    pdra_view_close(&v);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_render_other_lighting),
        cmocka_unit_test(test_render_lights_emitted_only),
    };
    return cmocka_run_group_tests(tests, tiny_setup, test_teardown_tmpdir);
}
