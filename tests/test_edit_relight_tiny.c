/* The editor's relight modes (edit/editor.h, edit/relight.h) on the shared tiny run's pdra model
 * (tests/support/tiny_run.h): the ratio method (unedited: the lights-on render; all off: the
 * lights-off one; linear in the intensity; edits no light can take refused) and a fine-tuned
 * model's view (the fine-tuned render where no light is seen, the lights' own pixels lit as the
 * direct method lights them); the light groups mixed as an edit says equal the edit. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "edit/editor.h"
#include "edit/finetune.h"
#include "io/image.h"
#include "model/model.h"
#include "test_support.h"
#include "tiny_run.h"

/* The ratio method (edit/relight.h) on the pdra run: unedited it is the model's own lights-on
 * render where no light is seen; every light off leaves the lights-off render; intensity 2
 * doubles the lights' effect (the ratio of direct light is linear in the intensity). */
static void test_ratio_edits(void **state)
{
    (void)state;
    struct pdra_view v;
    pdra_view_open(&v);
    const float *on = v.on, *off = v.off;
    struct esr_editor ed;
    if (esr_editor_init(&ed, &v.m, &v.ds, ESR_EDIT_RATIO, 8, NULL) != ESR_OK)
        fail_msg("%s", esr_error_message());
    struct esr_image img[3];
    const float gain[3] = {0.0f, 1.0f, 2.0f};
    for (int g = 0; g < 3; g++) {
        struct esr_light_edit e[ESR_MAX_LIGHTS];
        for (int k = 0; k < ESR_MAX_LIGHTS; k++)
            e[k] = (struct esr_light_edit){gain[g], 0, 0.0f, 0.0f};
        assert_int_equal(esr_editor_set(&ed, e, 3), ESR_OK);
        assert_int_equal(esr_editor_view(&ed, v.cam, 3, &img[g]), ESR_OK);
    }
    double same = 0.0, dark = 0.0, lin = 0.0, effect = 0.0;
    size_t seen = 0;
    for (size_t p = 0; p < v.px; p++)
        for (int c = 0; c < 3; c++) {
            const size_t i = p * 3 + c;
            const double a = img[1].data[i] - img[0].data[i], b = img[2].data[i] - img[0].data[i];
            lin = fmax(lin, fabs(b - 2.0 * a));
            if (v.ids[p] >= 0)
                continue;
            seen += c == 0;
            same = fmax(same, fabs((double)img[1].data[i] - on[i]));
            dark = fmax(dark, fabs((double)img[0].data[i] - off[i]));
            effect = fmax(effect, fabs((double)on[i] - off[i]));
        }
    /* an edit no light can take is refused, naming the light and the value; without a recolour
     * the hue and saturation are not read */
    static const struct {
        struct esr_light_edit e;
        const char *why; /* NULL: accepted */
    } asks[] = {
        {{2e6f, 0, 0.0f, 0.0f}, "edit of light 0: intensity 2e+06 is not a number in [0, 1e+06]"},
        {{NAN, 0, 0.0f, 0.0f}, "edit of light 0: intensity nan is not a number"},
        {{-0.5f, 0, 0.0f, 0.0f}, "edit of light 0: intensity -0.5 is not a number"},
        {{1.0f, 1, 0.5f, 1.5f}, "edit of light 0: saturation 1.5 is not a number in [0, 1]"},
        {{1.0f, 1, -0.25f, 1.0f}, "edit of light 0: hue -0.25 is not a number in [0, 1]"},
        {{1.0f, 1, 0.25f, NAN}, "edit of light 0: saturation nan is not a number"},
        {{1e6f, 0, 7.0f, -3.0f}, NULL},
        {{0.0f, 1, 1.0f, 0.0f}, NULL},
    };
    for (size_t i = 0; i < sizeof asks / sizeof asks[0]; i++) {
        struct esr_light_edit e[ESR_MAX_LIGHTS];
        for (int k = 0; k < ESR_MAX_LIGHTS; k++)
            e[k] = (struct esr_light_edit){1.0f, 0, 0.0f, 0.0f};
        e[0] = asks[i].e;
        esr_error_clear();
        const int rc = esr_editor_set(&ed, e, 3);
        if (!asks[i].why) {
            assert_int_equal(rc, ESR_OK);
            continue;
        }
        assert_int_equal(rc, ESR_ERR);
        if (!strstr(esr_error_message(), asks[i].why))
            fail_msg("ask %zu: '%s' does not say '%s'", i, esr_error_message(), asks[i].why);
        struct esr_image none = {0};
        esr_error_clear();
        assert_int_equal(esr_relight_view(&ed.relight, &v.m, e, v.cam, 3, &none, NULL), ESR_ERR);
        assert_null(none.data);
    }
    esr_error_clear();
    print_message("ratio: %zu pixels see no light; lights' effect up to %.4f; unedited differs "
                  "from the lights-on render by %.2g, all off from the lights-off one by %.2g; "
                  "x2 - 2 x1 %.2g\n", seen, effect, same, dark, lin);
    assert_true(seen > 0 && effect > 0.0);
    assert_true(same < 1e-5);
    assert_true(dark < 1e-6 * (1.0 + effect));
    assert_true(lin < 1e-4 * (1.0 + effect));
    for (int g = 0; g < 3; g++)
        esr_image_free(&img[g]);
    esr_editor_free(&ed);
    pdra_view_close(&v);
}

/* A fine-tuned model's view through the editor (edit/relight.h, the model mode): where no light
 * is seen, the fine-tuned lights-on render bit for bit; where a light is seen, the lights-off
 * radiance plus the light's edited emission plus the lights' direct light, which is never
 * negative and, with light 0 off and the others x1000, lights those pixels wherever the direct
 * method does (a tiny run with one light, or its second under the floor, lights none: said). */
static void test_finetune_view(void **state)
{
    (void)state;
    struct pdra_view v;
    pdra_view_open(&v);
    struct esr_model *m = &v.m;
    const size_t px = v.px, n = px * 3;
    struct esr_finetune_opts o;
    esr_finetune_default_opts(&o);
    o.iters = 20;
    o.rays = 128;
    o.points = 256;
    o.light_spp = 4;
    struct esr_editor ed;
    if (esr_editor_init(&ed, m, &v.ds, ESR_EDIT_FINETUNE, 8, &o) != ESR_OK)
        fail_msg("%s", esr_error_message());
    /* light 0 (the view's) off, the others x1000: the tiny scene's lights are small and far
     * apart, so at x2 the light one casts on another was 1e-5 on some runs, below what the
     * check below can tell from rounding beside the lit light's own emission */
    struct esr_light_edit e[ESR_MAX_LIGHTS];
    for (int k = 0; k < ESR_MAX_LIGHTS; k++)
        e[k] = (struct esr_light_edit){k == 0 ? 0.0f : 1000.0f, 0, 0.0f, 0.0f};
    assert_int_equal(esr_editor_set(&ed, e, 5), ESR_OK);
    struct esr_image img;
    assert_int_equal(esr_editor_view(&ed, v.cam, 3, &img), ESR_OK);
    float *o3 = malloc(n * sizeof(float)), *d3 = malloc(n * sizeof(float));
    float *on = malloc(n * sizeof(float)), *off = malloc(n * sizeof(float));
    float *lit = malloc(n * sizeof(float));
    assert_true(o3 && d3 && on && off && lit);
    esr_camera_pixel_rays(v.cam, o3, d3);
    struct esr_render_out ro = {.linear = on, .lights_emitted_only = 1};
    assert_int_equal(esr_model_render_rays(m, o3, d3, px, 1, &ro), ESR_OK);
    struct esr_render_out rf = {.linear = off, .emitted_lights = lit};
    assert_int_equal(esr_model_render_rays(m, o3, d3, px, 0, &rf), ESR_OK);
    /* the direct method on the same view and edit: the light it casts on the lights' pixels is
     * what the fine-tuned view shows there (whether any falls there is the tiny run's draw: a
     * run whose second light lies under the floor lights none) */
    struct esr_editor direct;
    struct esr_image img_direct;
    if (esr_editor_init(&direct, m, &v.ds, ESR_EDIT_DIRECT, 8, NULL) != ESR_OK)
        fail_msg("%s", esr_error_message());
    assert_int_equal(esr_editor_set(&direct, e, 5), ESR_OK);
    assert_int_equal(esr_editor_view(&direct, v.cam, 3, &img_direct), ESR_OK);
    esr_editor_free(&direct);
    size_t seen = 0, on_light = 0, lit_up = 0, direct_lit = 0;
    double most = 0.0; /* the most light a light's pixel gained, relative */
    for (size_t p = 0; p < px; p++) {
        if (v.ids[p] < 0) {
            assert_memory_equal(img.data + p * 3, on + p * 3, 3 * sizeof(float));
            seen++;
            continue;
        }
        on_light++;
        int up = 0, up_direct = 0;
        for (int c = 0; c < 3; c++) {
            const float base = off[p * 3 + c] + lit[p * 3 + c];
            up_direct |= img_direct.data[p * 3 + c] > base + 1e-4f * (1.0f + fabsf(base));
            assert_true(img.data[p * 3 + c] >= base - 1e-5f * (1.0f + fabsf(base)));
            up |= img.data[p * 3 + c] > base + 1e-4f * (1.0f + fabsf(base));
            most = fmax(most, (img.data[p * 3 + c] - base) / (1.0f + fabsf(base)));
        }
        lit_up += up;
        direct_lit += up_direct;
    }
    print_message("finetune view: %zu pixels see no light (the fine-tuned render), %zu see one, "
                  "%zu of them lit by the lights (by up to %.3g x (1 + base)); direct: %zu\n", seen,
                  on_light, lit_up, most, direct_lit);
    assert_true(seen > 0 && on_light > 0);
    assert_true(direct_lit == 0 || lit_up > 0);
    if (direct_lit == 0)
        print_message("finetune view: no light reaches another's pixels in this tiny run (%d "
                      "lights): the direct light there is not checked\n", m->lights.n);
    esr_image_free(&img_direct);
    free(o3), free(d3), free(on), free(off), free(lit);
    esr_image_free(&img);
    esr_editor_free(&ed);
    pdra_view_close(&v);
}

/* The light groups (edit/relight.h, esr_relight_layers) in both methods: unedited, the
 * lights-off layer plus every light's is the unedited view; and for a handful of edits (one
 * light off, one x3, one recoloured blue, all x0.5, every light recoloured at its own
 * intensity) the layers scaled as the edit says equal esr_relight_view of that edit to float
 * rounding: each light's samples draw from their own stream, and a recolour is its light's
 * unit-colour layer times the colour. */
static void test_layers_mix_is_the_edit(void **state)
{
    (void)state;
    struct pdra_view v;
    pdra_view_open(&v);
    const int K = v.m.lights.n;
    enum { N_EDITS = 6 };
    struct esr_light_edit e[N_EDITS][ESR_MAX_LIGHTS];
    for (int i = 0; i < N_EDITS; i++)
        for (int k = 0; k < ESR_MAX_LIGHTS; k++)
            e[i][k] = (struct esr_light_edit){1.0f, 0, 0.0f, 0.0f};
    e[1][0].intensity = 0.0f;                                  /* light 0 off */
    e[2][K - 1].intensity = 3.0f;                              /* the last x3 */
    e[3][0] = (struct esr_light_edit){1.0f, 1, 0.6f, 1.0f};    /* light 0 blue */
    for (int k = 0; k < K; k++) {
        e[4][k].intensity = 0.5f;                              /* all x0.5 */
        e[5][k] = (struct esr_light_edit){0.7f + (float)k, 1, 0.15f * (float)k, 0.8f};
    }
    static const enum esr_relight_mode modes[2] = {ESR_RELIGHT_DIRECT, ESR_RELIGHT_RATIO};
    for (int mi = 0; mi < 2; mi++) {
        struct esr_relight r;
        if (esr_relight_init(&r, &v.m, 8, modes[mi]) != ESR_OK)
            fail_msg("%s", esr_error_message());
        struct esr_relight_layers L;
        if (esr_relight_layers(&r, &v.m, v.cam, 3, &L, NULL) != ESR_OK)
            fail_msg("%s", esr_error_message());
        assert_int_equal(L.n_lights, K);
        double worst = 0.0, effect = 0.0;
        for (int i = 0; i < N_EDITS; i++) {
            struct esr_image edit, mix;
            assert_int_equal(esr_relight_view(&r, &v.m, e[i], v.cam, 3, &edit, NULL), ESR_OK);
            assert_int_equal(esr_relight_layers_mix(&L, e[i], &mix), ESR_OK);
            for (size_t j = 0; j < v.px * 3; j++) {
                double sum = L.off.data[j]; /* unedited: the layers' plain sum */
                for (int k = 0; k < K; k++)
                    sum += L.light[k].data[j];
                if (i == 0)
                    worst = fmax(worst, fabs(sum - edit.data[j]) / (1.0 + fabs(edit.data[j])));
                worst = fmax(worst, fabs((double)mix.data[j] - edit.data[j]) /
                                        (1.0 + fabs(edit.data[j])));
                effect = fmax(effect, fabs((double)edit.data[j] - L.off.data[j]));
            }
            esr_image_free(&edit), esr_image_free(&mix);
        }
        print_message("layers (%s, %d lights): the mixes differ from the edits by at most %.3g x "
                      "(1 + value); the lights' effect up to %.3g\n",
                      mi ? "ratio" : "direct", K, worst, effect);
        assert_true(effect > 1e-3);
        assert_true(worst < 1e-5);
        esr_relight_layers_free(&L);
        esr_relight_free(&r);
    }
    pdra_view_close(&v);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_layers_mix_is_the_edit),
        cmocka_unit_test(test_finetune_view),
        cmocka_unit_test(test_ratio_edits),
    };
    return cmocka_run_group_tests(tests, tiny_setup, test_teardown_tmpdir);
}
