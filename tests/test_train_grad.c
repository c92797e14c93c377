/* End-to-end gradient of the training engine: two rays through a small fine-stage model (SDF
 * grid -> NeuS alpha, feature grids, geometry feature, PE, off/emo radiance MLPs, tone-mapper,
 * compositing on white, two-term rendering loss with a saturated target) and through a coarse
 * model (smoothed SDF, colour grid, colour MLP with the lighting flag) against central
 * differences of the loss, for the parameters with the largest analytic gradient in every
 * component. Also the loss formula by hand and the off-branch stop-gradient for on-rays. */
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
#include "model/render_sdf.h"
#include "model/trace.h"

#define N_RAYS 2
#define LAMBDA 0.5f

struct fixture {
    struct esr_model m;
    float *view, *g_view, *scratch; /* coarse: smoothed SDF the renderer sees, its gradient */
    struct esr_trace t;
    float orig[N_RAYS * 3], dir[N_RAYS * 3], tgt[N_RAYS * 3];
    float d_rgb[N_RAYS * 3], d_lin[N_RAYS * 3];
    int n_off;
};

static void small_config(struct esr_train_config *c)
{
    esr_config_defaults(c, ESR_PRESET_FAST);
    c->coarse.res = 16; /* coarse grids, and the fine stage's feature grids */
    c->fine.res = 16;
    c->fine.feat_channels = 2;
    c->fine.mlp_width = 16;
    c->fine.mlp_depth = 2;
    c->tone_width = 8;
    c->tone_pe = 2;
    c->pe_pos = 2;
    c->geo_scales = 2;
}

static void setup_stage(struct fixture *fx, int n_off, enum esr_stage stage)
{
    struct esr_train_config cfg;
    small_config(&cfg);
    const float bmin[3] = {-1, -1, -1}, bmax[3] = {1, 1, 1};
    memset(fx, 0, sizeof(*fx));
    assert_int_equal(esr_model_init(&fx->m, &cfg, stage, NULL, bmin, bmax), 0);
    float *w = fx->m.params.w;
    assert_int_equal(esr_sdf_init_sphere(&fx->m.sdf, w + fx->m.sdf_off, 0.5f), 0);
    if (stage == ESR_STAGE_COARSE) {
        size_t ns = esr_grid_count(&fx->m.sdf), nf = esr_grid_count(&fx->m.feat);
        fx->view = malloc(ns * sizeof(float));
        fx->g_view = malloc(ns * sizeof(float));
        fx->scratch = malloc(ns * sizeof(float));
        for (size_t i = 0; i < nf; i++) {
            struct esr_rng r = esr_rng_init(6, i);
            w[fx->m.feat_off + i] = esr_rng_float(&r) - 0.5f;
        }
    } else {
        /* features large enough to matter, and a non-trivial emission */
        size_t nf = esr_grid_count(&fx->m.feat_off_g);
        for (size_t i = 0; i < nf; i++) {
            struct esr_rng r = esr_rng_init(5, i);
            w[fx->m.feat_off_off + i] = esr_rng_float(&r) - 0.5f;
            w[fx->m.feat_emo_off + i] = esr_rng_float(&r) - 0.5f;
        }
        esr_mlp_init_weights(&fx->m.rad_emo, w, 9, 0.0f);
    }
    fx->m.inv_s = 10.0f;
    assert_int_equal(esr_trace_init(&fx->t, &fx->m, N_RAYS, 1), 0);
    const float o[N_RAYS][3] = {{0.1f, -3.0f, 0.15f}, {-3.0f, 0.2f, -0.1f}};
    const float d[N_RAYS][3] = {{0.02f, 1.0f, -0.03f}, {1.0f, -0.04f, 0.05f}};
    for (int r = 0; r < N_RAYS; r++) {
        float len = sqrtf(d[r][0] * d[r][0] + d[r][1] * d[r][1] + d[r][2] * d[r][2]);
        for (int a = 0; a < 3; a++) {
            fx->orig[r * 3 + a] = o[r][a];
            fx->dir[r * 3 + a] = d[r][a] / len;
            fx->tgt[r * 3 + a] = 0.2f + 0.25f * (float)(r + a);
        }
    }
    fx->tgt[2] = 1.0f; /* a saturated channel */
    fx->n_off = n_off;
}

static void setup(struct fixture *fx, int n_off) { setup_stage(fx, n_off, ESR_STAGE_FINE); }

static void teardown(struct fixture *fx)
{
    esr_trace_free(&fx->t);
    esr_model_free(&fx->m);
    free(fx->view);
    free(fx->g_view);
    free(fx->scratch);
}

/* The trainer's iteration without the optimiser: coarse renders the smoothed SDF and brings the
 * gradient back to the raw grid through the smoothing's adjoint. */
static double loss_at(struct fixture *fx, int with_grad)
{
    struct esr_model *m = &fx->m;
    const float *sdf = m->params.w + m->sdf_off;
    float *g_sdf = m->params.g + m->sdf_off;
    int coarse = m->stage == ESR_STAGE_COARSE, smooth = coarse && m->cfg.smooth_ksize > 1;
    if (smooth) {
        assert_int_equal(esr_model_view_sdf(m, sdf, fx->view, fx->scratch), 0);
        sdf = fx->view;
        g_sdf = fx->g_view;
        memset(g_sdf, 0, esr_grid_count(&m->sdf) * sizeof(float));
    }
    assert_int_equal(esr_trace_fwd(&fx->t, m, sdf, fx->orig, fx->dir, N_RAYS, fx->n_off, 77), 0);
    struct esr_render_loss_result res;
    float lambda = coarse ? 0.0f : LAMBDA;
    esr_render_loss_batch(fx->t.rgb3, fx->t.lin_rgb3, fx->tgt, N_RAYS, lambda, fx->d_rgb,
                          fx->d_lin, &res);
    if (with_grad) {
        esr_nn_params_zero_grad(&m->params, 0, m->params.count);
        assert_int_equal(esr_trace_bwd(&fx->t, m, sdf, g_sdf, m->params.g, fx->d_rgb,
                                       coarse ? NULL : fx->d_lin),
                         0);
        if (smooth)
            assert_int_equal(esr_grid_smooth_bwd(&m->sdf, fx->g_view, m->params.g + m->sdf_off,
                                                 fx->scratch, m->cfg.smooth_ksize,
                                                 m->cfg.smooth_sigma),
                             0);
    }
    return res.loss;
}

/* Checks the k entries of [off, off+n) with the largest |analytic gradient|. */
static void check_range(struct fixture *fx, const char *what, size_t off, size_t n, float eps)
{
    float *w = fx->m.params.w;
    const float *g = fx->m.params.g;
    int picked[3] = {-1, -1, -1};
    for (int k = 0; k < 3; k++) {
        float best = 0.0f;
        for (size_t i = 0; i < n; i++) {
            int used = 0;
            for (int j = 0; j < k; j++)
                used |= picked[j] == (int)i;
            if (!used && fabsf(g[off + i]) > best) {
                best = fabsf(g[off + i]);
                picked[k] = (int)i;
            }
        }
    }
    assert_true(picked[0] >= 0); /* the component receives gradient at all */
    for (int k = 0; k < 3 && picked[k] >= 0; k++) {
        size_t i = off + (size_t)picked[k];
        float an = g[i], keep = w[i];
        w[i] = keep + eps;
        double lp = loss_at(fx, 0);
        w[i] = keep - eps;
        double lm = loss_at(fx, 0);
        w[i] = keep;
        double fd = (lp - lm) / (2.0 * eps);
        double tol = 0.05 * fmax(fabs(fd), fabs(an)) + 2e-4;
        if (fabs(fd - an) > tol)
            fail_msg("%s entry %zu: analytic %.6g vs central difference %.6g", what, i - off,
                     (double)an, fd);
    }
}

static void test_fine_gradients_lights_off(void **state)
{
    (void)state;
    struct fixture fx;
    setup(&fx, N_RAYS);
    loss_at(&fx, 1);
    struct esr_model *m = &fx.m;
    check_range(&fx, "sdf", m->sdf_off, esr_grid_count(&m->sdf), 2e-3f);
    check_range(&fx, "feat_off", m->feat_off_off, esr_grid_count(&m->feat_off_g), 1e-2f);
    check_range(&fx, "rad_off", m->rad_off.offset, m->rad_off.count, 1e-2f);
    check_range(&fx, "tone", m->tone.offset, m->tone.count, 1e-2f);
    /* lights-off rays never reach the emo branch */
    for (size_t i = 0; i < m->rad_emo.count; i++)
        assert_true(m->params.g[m->rad_emo.offset + i] == 0.0f);
    teardown(&fx);
}

static void test_fine_gradients_lights_on(void **state)
{
    (void)state;
    struct fixture fx;
    setup(&fx, 0);
    loss_at(&fx, 1);
    struct esr_model *m = &fx.m;
    check_range(&fx, "feat_emo", m->feat_emo_off, esr_grid_count(&m->feat_emo_g), 1e-2f);
    check_range(&fx, "rad_emo", m->rad_emo.offset, m->rad_emo.count, 1e-2f);
    check_range(&fx, "tone", m->tone.offset, m->tone.count, 1e-2f);
    /* stop-gradient: on-rays do not train the off branch */
    for (size_t i = 0; i < m->rad_off.count; i++)
        assert_true(m->params.g[m->rad_off.offset + i] == 0.0f);
    for (size_t i = 0; i < esr_grid_count(&m->feat_off_g); i++)
        assert_true(m->params.g[m->feat_off_off + i] == 0.0f);
    teardown(&fx);
}

static void test_coarse_gradients(void **state)
{
    (void)state;
    struct fixture fx;
    setup_stage(&fx, 1, ESR_STAGE_COARSE); /* one off-ray, one on-ray (lighting flag input) */
    loss_at(&fx, 1);
    struct esr_model *m = &fx.m;
    check_range(&fx, "sdf (through smoothing)", m->sdf_off, esr_grid_count(&m->sdf), 1e-3f);
    check_range(&fx, "feat", m->feat_off, esr_grid_count(&m->feat), 1e-2f);
    check_range(&fx, "colour", m->colour.offset, m->colour.count, 1e-2f);
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
        cmocka_unit_test(test_fine_gradients_lights_on),
        cmocka_unit_test(test_coarse_gradients),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
