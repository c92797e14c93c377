/* End-to-end gradient of the training step (train/step.h, the very function the trainer runs
 * every iteration): two rays through a small fine-stage model (SDF grid -> NeuS alpha, feature
 * grids, geometry feature, PE, off/emo radiance MLPs, tone-mapper, compositing on white, two-term
 * rendering loss with a saturated target) and through a coarse model (smoothed SDF, colour grid,
 * colour MLP with the lighting flag), against central differences of the loss for EVERY entry of
 * every component the stage trains (zero where the rays do not reach). Also the loss formula by
 * hand and the off-branch stop-gradient for lights-on rays. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/colour.h"
#include "core/rng.h"
#include "fields/sdf.h"
#include "model/model.h"
#include "train/render_loss.h"
#include "train/step.h"

#define N_RAYS 2
#define LAMBDA 0.5f

struct fixture {
    struct esr_model m;
    struct esr_train_step st;
    float *analytic; /* the step's gradient, kept while central differences run */
};

static void small_config(struct esr_train_config *c)
{
    esr_config_defaults(c, ESR_PRESET_FAST);
    c->coarse.res = 16; /* coarse grids, and the fine stage's feature grids */
    c->coarse.feat_channels = 2;
    c->coarse.mlp_width = 16;
    c->fine.res = 16;
    c->fine.feat_channels = 2;
    c->fine.mlp_width = 16;
    c->fine.mlp_depth = 2;
    c->tone_width = 8;
    c->tone_pe = 2;
    c->pe_pos = 2;
    c->geo_scales = 2;
    c->lambda_tau = LAMBDA;
}

/* Random values in [-0.5, 0.5) for a component, so features matter. */
static void randomise(struct esr_model *m, enum esr_component c, uint64_t seed)
{
    float *v = esr_model_values(m, c);
    for (size_t i = 0; i < m->part[c].count; i++) {
        struct esr_rng r = esr_rng_init(seed, i);
        v[i] = esr_rng_float(&r) - 0.5f;
    }
}

/* lights[r] = lighting flag of ray r. */
static void setup_stage(struct fixture *fx, enum esr_stage stage, const uint8_t lights[N_RAYS])
{
    struct esr_train_config cfg;
    small_config(&cfg);
    const float bmin[3] = {-1, -1, -1}, bmax[3] = {1, 1, 1};
    memset(fx, 0, sizeof(*fx));
    struct esr_model *m = &fx->m;
    assert_int_equal(esr_model_init(m, &cfg, stage, NULL, bmin, bmax), 0);
    assert_int_equal(esr_sdf_init_sphere(esr_model_grid(m, ESR_COMP_SDF),
                                         esr_model_values(m, ESR_COMP_SDF), 0.5f),
                     0);
    if (stage == ESR_STAGE_COARSE) {
        randomise(m, ESR_COMP_COLOUR_FEAT, 6);
    } else {
        /* features large enough to matter, and a non-trivial emission */
        randomise(m, ESR_COMP_OFF_FEAT, 5);
        randomise(m, ESR_COMP_EMO_FEAT, 15);
        esr_mlp_init_weights(esr_model_mlp(m, ESR_COMP_EMO_MLP), m->params.w, 9, 0.0f);
    }
    m->inv_s = 10.0f;
    assert_int_equal(esr_train_step_init(&fx->st, m, N_RAYS), 0);
    fx->analytic = malloc(m->params.count * sizeof(float));
    assert_non_null(fx->analytic);
    const float o[N_RAYS][3] = {{0.1f, -3.0f, 0.15f}, {-3.0f, 0.2f, -0.1f}};
    const float d[N_RAYS][3] = {{0.02f, 1.0f, -0.03f}, {1.0f, -0.04f, 0.05f}};
    for (int r = 0; r < N_RAYS; r++) {
        float len = sqrtf(d[r][0] * d[r][0] + d[r][1] * d[r][1] + d[r][2] * d[r][2]);
        for (int a = 0; a < 3; a++) {
            fx->st.orig3[r * 3 + a] = o[r][a];
            fx->st.dir3[r * 3 + a] = d[r][a] / len;
            fx->st.tgt3[r * 3 + a] = 0.2f + 0.25f * (float)(r + a);
        }
        fx->st.lights_on[r] = lights[r];
    }
    fx->st.tgt3[2] = 1.0f; /* a saturated channel */
}

static void teardown(struct fixture *fx)
{
    esr_train_step_free(&fx->st);
    esr_model_free(&fx->m);
    free(fx->analytic);
}

static double loss_at(struct fixture *fx)
{
    struct esr_render_loss_result res;
    assert_int_equal(esr_train_step_run(&fx->st, &fx->m, N_RAYS, 77, &res), 0);
    return res.loss;
}

/* Runs the step once and keeps its gradient as the analytic one. */
static void analytic_gradient(struct fixture *fx)
{
    loss_at(fx);
    memcpy(fx->analytic, fx->m.params.g, fx->m.params.count * sizeof(float));
}

/* Every entry of component c against a central difference; returns how many entries carry a
 * non-zero gradient (so a caller can insist the rays reach the component). */
static size_t check_component(struct fixture *fx, enum esr_component c, float eps)
{
    struct esr_model *m = &fx->m;
    float *w = m->params.w;
    const size_t off = m->part[c].off, n = m->part[c].count;
    size_t bad = 0, live = 0;
    for (size_t i = off; i < off + n; i++) {
        float an = fx->analytic[i], keep = w[i];
        w[i] = keep + eps;
        double lp = loss_at(fx);
        w[i] = keep - eps;
        double lm = loss_at(fx);
        w[i] = keep;
        double fd = (lp - lm) / (2.0 * eps);
        live += an != 0.0f;
        double tol = 0.05 * fmax(fabs(fd), fabs(an)) + 2e-4;
        if (fabs(fd - an) > tol && bad++ < 5)
            print_error("%s entry %zu: analytic %.6g vs central difference %.6g\n",
                        esr_component_info(c)->name, i - off, (double)an, fd);
    }
    if (bad)
        fail_msg("%s: %zu of %zu entries disagree with central differences",
                 esr_component_info(c)->name, bad, n);
    return live;
}

static float eps_of(enum esr_component c)
{
    return c == ESR_COMP_SDF ? 2e-3f : 1e-2f;
}

/* Every trained component of the stage, entry by entry. */
static void check_stage(struct fixture *fx)
{
    const uint32_t trained = esr_stage_info((enum esr_stage)fx->m.stage)->trained;
    for (int c = 0; c < ESR_COMP_COUNT; c++)
        if (trained & ESR_BIT(c))
            check_component(fx, (enum esr_component)c, eps_of((enum esr_component)c));
}

static int all_zero(const struct fixture *fx, enum esr_component c)
{
    for (size_t i = 0; i < fx->m.part[c].count; i++)
        if (fx->analytic[fx->m.part[c].off + i] != 0.0f)
            return 0;
    return 1;
}

static void test_fine_gradients_lights_off(void **state)
{
    (void)state;
    struct fixture fx;
    const uint8_t lights[N_RAYS] = {0, 0};
    setup_stage(&fx, ESR_STAGE_FINE, lights);
    analytic_gradient(&fx);
    /* lights-off rays never reach the emo branch */
    assert_true(all_zero(&fx, ESR_COMP_EMO_MLP));
    assert_true(all_zero(&fx, ESR_COMP_EMO_FEAT));
    assert_true(!all_zero(&fx, ESR_COMP_OFF_MLP) && !all_zero(&fx, ESR_COMP_SDF));
    check_stage(&fx);
    teardown(&fx);
}

static void test_fine_gradients_mixed_lighting(void **state)
{
    (void)state;
    struct fixture fx;
    /* the lights-on ray first: the point fields reorder rows internally */
    const uint8_t lights[N_RAYS] = {1, 0};
    setup_stage(&fx, ESR_STAGE_FINE, lights);
    analytic_gradient(&fx);
    assert_true(!all_zero(&fx, ESR_COMP_EMO_MLP) && !all_zero(&fx, ESR_COMP_OFF_MLP));
    check_stage(&fx);
    teardown(&fx);
}

static void test_fine_lights_on_stop_gradient(void **state)
{
    (void)state;
    struct fixture fx;
    const uint8_t lights[N_RAYS] = {1, 1};
    setup_stage(&fx, ESR_STAGE_FINE, lights);
    analytic_gradient(&fx);
    /* stop-gradient: lights-on rays do not train the off branch */
    assert_true(all_zero(&fx, ESR_COMP_OFF_MLP));
    assert_true(all_zero(&fx, ESR_COMP_OFF_FEAT));
    assert_true(!all_zero(&fx, ESR_COMP_EMO_MLP) && !all_zero(&fx, ESR_COMP_TONE_MLP));
    check_component(&fx, ESR_COMP_EMO_MLP, 1e-2f);
    check_component(&fx, ESR_COMP_EMO_FEAT, 1e-2f);
    teardown(&fx);
}

static void test_coarse_gradients(void **state)
{
    (void)state;
    struct fixture fx;
    const uint8_t lights[N_RAYS] = {0, 1}; /* lighting flag input */
    setup_stage(&fx, ESR_STAGE_COARSE, lights);
    analytic_gradient(&fx);
    assert_true(fx.st.sdf_view != NULL); /* the SDF gradient goes through the smoothing */
    check_stage(&fx);
    teardown(&fx);
}

static void test_render_loss_by_hand(void **state)
{
    (void)state;
    /* tone 0.5 vs 0.4, lin 0.2 (unsaturated): 0.01 + l (srgb(0.2) - 0.4)^2 */
    float s = esr_srgb_from_linear(0.2f);
    double want = 0.01 + 0.5 * (s - 0.4) * (s - 0.4);
    assert_float_equal(esr_render_loss_fwd(0.5f, 0.2f, 0.4f, 0.5f), want, 1e-6);
    /* saturated target: linear 3 clamps to 1, gamma(1) = 1 = target, no gradient on lin */
    float dt, dl;
    assert_float_equal(esr_render_loss_fwd(1.0f, 3.0f, 1.0f, 0.5f), 0.0, 1e-7);
    esr_render_loss_bwd(0.9f, 3.0f, 1.0f, 0.5f, &dt, &dl);
    assert_float_equal(dt, 2.0f * (0.9f - 1.0f), 1e-6);
    assert_true(dl == 0.0f);
    /* unsaturated target keeps an over-bright linear value in the loss */
    esr_render_loss_bwd(0.5f, 1.5f, 0.8f, 0.5f, &dt, &dl);
    assert_true(dl > 0.0f);
    /* central differences of the per-element pair */
    const float lin = 0.3f, tone = 0.6f, t = 0.45f, h = 1e-3f;
    esr_render_loss_bwd(tone, lin, t, 0.5f, &dt, &dl);
    double fd_t = (esr_render_loss_fwd(tone + h, lin, t, 0.5f) - esr_render_loss_fwd(tone - h, lin, t, 0.5f)) / (2 * h);
    double fd_l = (esr_render_loss_fwd(tone, lin + h, t, 0.5f) - esr_render_loss_fwd(tone, lin - h, t, 0.5f)) / (2 * h);
    assert_float_equal(dt, fd_t, 2e-3);
    assert_float_equal(dl, fd_l, 2e-3);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_render_loss_by_hand),
        cmocka_unit_test(test_fine_gradients_lights_off),
        cmocka_unit_test(test_fine_gradients_mixed_lighting),
        cmocka_unit_test(test_fine_lights_on_stop_gradient),
        cmocka_unit_test(test_coarse_gradients),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
