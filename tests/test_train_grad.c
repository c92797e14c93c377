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

#ifdef _OPENMP
#include <omp.h>
#endif

#include "core/colour.h"
#include "core/error.h"
#include "core/rng.h"
#include "edit/finetune_loss.h"
#include "fields/env_sg.h"
#include "fields/sdf.h"
#include "model/model.h"
#include "train/lights/surface.h"
#include "train/lts.h"
#include "train/pdra_reg.h"
#include "train/render_loss.h"
#include "train/step.h"
#include "test_model.h"

#define N_RAYS 2
#define LAMBDA 0.5f

/* 1: the model learns its background (fields/background.h) and the second ray grazes the sphere,
 * so part of its colour is the background's */
static int learned_background;
/* the lts stage's directions per outgoing direction from the BRDF's lobe (0: cosine only) */
static int lobe_dirs;
static int split_loss; /* option lts_split */

struct fixture {
    struct esr_model m;
    struct esr_train_step st;
    float *analytic; /* the step's gradient, kept while central differences run */
};

/* lights[r] = lighting flag of ray r; estimator: the LTS loss's (lts and pdra stages). */
static void setup_stage(struct fixture *fx, enum esr_stage stage, const uint8_t lights[N_RAYS],
                        enum esr_lts_estimator estimator)
{
    struct esr_train_config cfg;
    test_small_config(&cfg, LAMBDA);
    cfg.lts_estimator = estimator;
    /* the BRDF lobe's directions (lts_lobe_dirs) follow the roughness, so a finite difference of
     * a BRDF entry moves them, while the gradient (rightly: they are samples) holds them fixed;
     * their estimator is tested on its own (test_core_brdf_sampling) */
    cfg.lts_lobe_dirs = cfg.pdra_lobe_dirs = lobe_dirs;
    cfg.lts_split = cfg.pdra_split = 0; /* set below, past validation */
    /* the full gradient of the loss, which finite differences see (test_geom_on_weight checks
     * the weighted one) */
    cfg.coarse.geom_on = cfg.fine.geom_on = 1.0f;
    cfg.background = learned_background ? ESR_BACKGROUND_LEARNED : ESR_BACKGROUND_WHITE;
    const float bmin[3] = {-1, -1, -1}, bmax[3] = {1, 1, 1};
    memset(fx, 0, sizeof(*fx));
    struct esr_model *m = &fx->m;
    assert_int_equal(esr_model_init(m, &cfg, stage, NULL, bmin, bmax), 0);
    /* set past esr_config_validate, which refuses a split without lobe directions for training's
     * sake: the gradient is the same code, and only there can the BRDF entries be compared */
    m->cfg.lts_split = m->cfg.pdra_split = split_loss;
    assert_int_equal(esr_sdf_init_sphere(esr_model_grid(m, ESR_COMP_SDF),
                                         esr_model_values(m, ESR_COMP_SDF), 0.5f),
                     0);
    /* a little noise on the sphere: its trilinear SDF is exactly flat in the centre cell, where
     * the NeuS cosine sits on its kink at 0 and no finite difference can be taken */
    test_randomise(m, ESR_COMP_SDF, 0.02f, 21);
    if (stage == ESR_STAGE_COARSE) {
        test_randomise(m, ESR_COMP_COLOUR_FEAT, 0.5f, 6);
    } else {
        /* features large enough to matter, and a non-trivial emission */
        test_randomise(m, ESR_COMP_OFF_FEAT, 0.5f, 5);
        test_randomise(m, ESR_COMP_EMO_FEAT, 0.5f, 15);
        esr_mlp_init_weights(esr_model_mlp(m, ESR_COMP_EMO_MLP), m->params.w, 9, 0.0f);
    }
    if (learned_background)
        test_randomise(m, ESR_COMP_BACKGROUND, 1.0f, 31);
    m->inv_s = 10.0f;
    assert_int_equal(esr_train_step_init(&fx->st, m, N_RAYS), 0);
    fx->analytic = malloc(m->params.count * sizeof(float));
    assert_non_null(fx->analytic);
    const float o[N_RAYS][3] = {{0.1f, -3.0f, 0.15f}, {-3.0f, 0.2f, learned_background ? 0.52f : -0.1f}};
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

/* Whether an analytic derivative agrees with a finite-difference one. */
static int agrees(double an, double fd)
{
    return fabs(fd - an) <= 0.05 * fmax(fabs(fd), fabs(an)) + 2e-4;
}

/* Entry i against central differences. A ReLU kink (or a grid cell boundary) within eps of the
 * current value makes the central difference average two slopes; such an entry is retried with
 * smaller steps, and at the smallest accepted when the analytic value matches one of the two
 * one-sided slopes (the derivative the backward pass takes on that side of the kink). */
static int entry_agrees(struct fixture *fx, size_t i, float eps, double *fd_out)
{
    float *w = fx->m.params.w;
    const float keep = w[i];
    const double an = fx->analytic[i];
    for (int attempt = 0; attempt < 3; attempt++, eps *= 0.1f) {
        w[i] = keep + eps;
        double lp = loss_at(fx);
        w[i] = keep - eps;
        double lm = loss_at(fx);
        w[i] = keep;
        *fd_out = (lp - lm) / (2.0 * eps);
        if (agrees(an, *fd_out))
            return 1;
        if (attempt == 2) {
            double l0 = loss_at(fx);
            return agrees(an, (lp - l0) / eps) || agrees(an, (l0 - lm) / eps);
        }
    }
    return 0;
}

/* Every entry of component c against finite differences; fails on any disagreement. */
/* The release build checks every entry. Under the sanitizers (what they check is the code
 * paths, which every entry's loss runs alike) every FD_STRIDE-th entry, from an offset that
 * moves with the component: the sweep's loss evaluations were the suite's longest test there
 * (295 s of a 756 s ASan run on 2 cores). */
#if defined(__SANITIZE_ADDRESS__)
#define FD_STRIDE 5
#else
#define FD_STRIDE 1
#endif

static void check_component(struct fixture *fx, enum esr_component c, float eps)
{
    const size_t off = fx->m.part[c].off, n = fx->m.part[c].count;
    size_t bad = 0;
    for (size_t i = off + (size_t)c % FD_STRIDE; i < off + n; i += FD_STRIDE) {
        double fd;
        if (!entry_agrees(fx, i, eps, &fd) && bad++ < 5)
            print_error("%s entry %zu: analytic %.6g vs central difference %.6g\n",
                        esr_component_info(c)->name, i - off, (double)fx->analytic[i], fd);
    }
    if (bad)
        fail_msg("%s: %zu of %zu entries disagree with finite differences",
                 esr_component_info(c)->name, bad, n);
}

static float eps_of(enum esr_component c)
{
    return c == ESR_COMP_SDF ? 2e-3f : 1e-2f;
}

/* Every trained component of the stage but those in `skip` (ESR_BIT masks), entry by entry. */
static void check_stage(struct fixture *fx, uint32_t skip)
{
    const uint32_t trained = esr_stage_info((enum esr_stage)fx->m.stage)->trained & ~skip;
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
    setup_stage(&fx, ESR_STAGE_FINE, lights, ESR_LTS_FIRST_HIT);
    analytic_gradient(&fx);
    /* lights-off rays never reach the emo branch */
    assert_true(all_zero(&fx, ESR_COMP_EMO_MLP));
    assert_true(all_zero(&fx, ESR_COMP_EMO_FEAT));
    assert_true(!all_zero(&fx, ESR_COMP_OFF_MLP) && !all_zero(&fx, ESR_COMP_SDF));
    check_stage(&fx, 0);
    teardown(&fx);
}

static void test_fine_gradients_mixed_lighting(void **state)
{
    (void)state;
    struct fixture fx;
    /* the lights-on ray first: the point fields reorder rows internally */
    const uint8_t lights[N_RAYS] = {1, 0};
    setup_stage(&fx, ESR_STAGE_FINE, lights, ESR_LTS_FIRST_HIT);
    analytic_gradient(&fx);
    assert_true(!all_zero(&fx, ESR_COMP_EMO_MLP) && !all_zero(&fx, ESR_COMP_OFF_MLP));
    /* Finite differences see through the stop-gradient, so only the components it does not
     * touch are compared here: on the lights-on ray L_off's dependence on the off branch and on
     * the SDF (through the geometry feature) is cut by design. The lights-off test checks those
     * components in full; test_model_point_fields checks that a mixed batch's gradient is the
     * sum of its lights-off and lights-on rows'. */
    check_component(&fx, ESR_COMP_EMO_FEAT, 1e-2f);
    check_component(&fx, ESR_COMP_EMO_MLP, 1e-2f);
    check_component(&fx, ESR_COMP_TONE_MLP, 1e-2f);
    teardown(&fx);
}

static void test_fine_lights_on_stop_gradient(void **state)
{
    (void)state;
    struct fixture fx;
    const uint8_t lights[N_RAYS] = {1, 1};
    setup_stage(&fx, ESR_STAGE_FINE, lights, ESR_LTS_FIRST_HIT);
    analytic_gradient(&fx);
    /* stop-gradient: lights-on rays do not train the off branch */
    assert_true(all_zero(&fx, ESR_COMP_OFF_MLP));
    assert_true(all_zero(&fx, ESR_COMP_OFF_FEAT));
    assert_true(!all_zero(&fx, ESR_COMP_EMO_MLP) && !all_zero(&fx, ESR_COMP_TONE_MLP));
    check_component(&fx, ESR_COMP_EMO_MLP, 1e-2f);
    check_component(&fx, ESR_COMP_EMO_FEAT, 1e-2f);
    teardown(&fx);
}

/* The SDF gradient of one step with the fine stage's geom_on weight w, into g. */
static void sdf_gradient(struct fixture *fx, float w, float *g)
{
    fx->m.cfg.fine.geom_on = w;
    analytic_gradient(fx);
    memcpy(g, fx->analytic + fx->m.part[ESR_COMP_SDF].off,
           fx->m.part[ESR_COMP_SDF].count * sizeof(float));
}

/* geom_on weighs the lights-on rays' pull on the surface (their opacities' gradient) and leaves
 * lights-off rays alone: the SDF gradient is affine in it, and moves with it only when a ray is
 * lit. */
static void test_geom_on_weight(void **state)
{
    (void)state;
    for (int lit = 0; lit < 2; lit++) {
        struct fixture fx;
        const uint8_t lights[N_RAYS] = {(uint8_t)lit, 0};
        setup_stage(&fx, ESR_STAGE_FINE, lights, ESR_LTS_FIRST_HIT);
        const size_t n = fx.m.part[ESR_COMP_SDF].count;
        float *g0 = malloc(n * sizeof(float)), *gh = malloc(n * sizeof(float));
        float *g1 = malloc(n * sizeof(float));
        assert_true(g0 && gh && g1);
        sdf_gradient(&fx, 0.0f, g0);
        sdf_gradient(&fx, 0.5f, gh);
        sdf_gradient(&fx, 1.0f, g1);
        double moved = 0.0, scale = 0.0;
        for (size_t i = 0; i < n; i++) {
            moved += fabs((double)g1[i] - g0[i]);
            scale += fabs((double)g1[i]);
            assert_float_equal(gh[i], 0.5f * (g0[i] + g1[i]), 1e-6f + 1e-4f * fabsf(g1[i]));
        }
        if (lit)
            assert_true(moved > 0.05 * scale);
        else
            assert_true(moved == 0.0);
        free(g0), free(gh), free(g1);
        teardown(&fx);
    }
}

/* Walls around the sphere at |x| = 0.9 and |y| = 0.9, open at the top and bottom: secondary rays
 * of the LTS loss hit a wall or leave the scene. */
static void add_walls(struct esr_model *m)
{
    const struct esr_grid *g = esr_model_grid(m, ESR_COMP_SDF);
    float *v = esr_model_values(m, ESR_COMP_SDF);
    for (int z = 0; z < g->nz; z++)
        for (int y = 0; y < g->ny; y++)
            for (int x = 0; x < g->nx; x++) {
                float p[3];
                esr_grid_voxel_pos(g, x, y, z, p);
                float *f = v + ((size_t)z * g->ny + y) * g->nx + x;
                *f = fminf(*f, 0.9f - fmaxf(fabsf(p[0]), fabsf(p[1])));
            }
}

static double max_abs(const struct fixture *fx, enum esr_component c)
{
    double mx = 0.0;
    for (size_t i = 0; i < fx->m.part[c].count; i++)
        mx = fmax(mx, fabs(fx->analytic[fx->m.part[c].off + i]));
    return mx;
}

/* The lts stage: rendering loss + the light-transport loss (E, BRDF, environment, radiance at
 * the points and at the secondary hits) with a weight that makes it dominate. The SDF is not
 * compared: the LTS points' normals and the secondary rays' hit positions move with it but are
 * detached by design (METHOD.md), so finite differences see dependencies the method cuts.
 * Lights-off primary rays keep the rendering loss free of the fine stage's stop-gradient; the
 * LTS term's L_emo = L_on - sg(L_off) equals the emo branch's output, so finite differences
 * agree with it. */
/* An lts or pdra fixture: lights-off rays, the LTS loss weighted to dominate, the sphere in
 * walls, a non-zero BRDF grid and broad coloured environment lobes. */
static void setup_emitter_stage(struct fixture *fx, enum esr_stage stage,
                                enum esr_lts_estimator estimator)
{
    const uint8_t lights[N_RAYS] = {0, 0};
    setup_stage(fx, stage, lights, estimator);
    fx->m.cfg.lts_weight = 1.0f;
    add_walls(&fx->m);
    test_randomise(&fx->m, ESR_COMP_BRDF_FEAT, 0.5f, 31);
    float *env = esr_model_values(&fx->m, ESR_COMP_ENV);
    const int K = fx->m.cfg.env_lobes;
    for (int k = 0; k < K; k++) {
        env[esr_env_sg_index(K, ESR_ENV_SG_LAMBDA, k)] = 1.0f; /* broad: escaping rays see them */
        for (int c = 0; c < 3; c++) /* coloured */
            env[esr_env_sg_index(K, (enum esr_env_sg_block)(ESR_ENV_SG_MU_R + c), k)] =
                0.3f * (float)(c + 1);
    }
}

static void check_lts_gradients(enum esr_lts_estimator estimator, int lobe, int split)
{
    struct fixture fx;
    lobe_dirs = lobe;
    split_loss = split;
    setup_emitter_stage(&fx, ESR_STAGE_LTS, estimator);
    lobe_dirs = 0;
    split_loss = 0;
    analytic_gradient(&fx);
    assert_true(fx.st.has_lts);
    const struct esr_lts_stats *ls = &fx.st.lts_stats;
    print_message("lts (estimator %d): %zu points, %zu secondary rays, %zu hits, mse off %.4g "
                  "emo %.4g\n", (int)estimator, ls->points, ls->secondary, ls->hits, ls->mse_off,
                  ls->mse_emo);
    assert_true(ls->points > 0 && ls->hits > 0 && ls->hits < ls->secondary);
    /* the light-transport terms are what trains these, and they must matter */
    assert_true(max_abs(&fx, ESR_COMP_EMIT_MLP) > 1e-3);
    assert_true(max_abs(&fx, ESR_COMP_BRDF_MLP) > 1e-3);
    assert_true(max_abs(&fx, ESR_COMP_ENV) > 1e-3);
    assert_true(max_abs(&fx, ESR_COMP_EMO_MLP) > 1e-3);
    /* with lobe directions the BRDF entries move the directions (setup_stage): not compared */
    check_stage(&fx, ESR_BIT(ESR_COMP_SDF) |
                         (lobe ? ESR_BIT(ESR_COMP_BRDF_FEAT) | ESR_BIT(ESR_COMP_BRDF_MLP) : 0));
    teardown(&fx);
}

static void test_lts_gradients(void **state)
{
    (void)state;
    check_lts_gradients(ESR_LTS_FIRST_HIT, 0, 0);
}

/* The same with directions from the BRDF's lobe (option lts_lobe_dirs): their weights reach
 * every other component's gradient. */
static void test_lts_lobe_gradients(void **state)
{
    (void)state;
    check_lts_gradients(ESR_LTS_FIRST_HIT, 2, 0);
}

/* Option lts_split: the loss is the product of the even and the odd directions' errors, whose
 * gradient takes, for each direction's terms, the other half's error. */
static void test_lts_split_gradients(void **state)
{
    (void)state;
    check_lts_gradients(ESR_LTS_FIRST_HIT, 0, 1);
    check_lts_gradients(ESR_LTS_FIRST_HIT, 2, 1); /* halves of both techniques' directions */
}

/* The faithful estimator: radiance composited along the secondary rays (their samples' radiance
 * rows, the environment weighted by the final transmittance). */
static void test_lts_volume_gradients(void **state)
{
    (void)state;
    check_lts_gradients(ESR_LTS_VOLUME, 0, 0);
}

/* Lights in the transport (pdra.lights_at, esr_lts_set_lights): a secondary ray whose first hit
 * lies on a light sees the light's calibrated emission, scale x E there (on the light's unseen
 * part scale x its mean field), and sends nothing back to the radiance field there. The light is
 * the walls' x > 0.5 side, its unseen part every other lattice point. The emo MLP feeds only
 * L_emo, so its finite differences agree only if the hits on the light take no gradient; E at
 * the hits is read without gradient too, so E's components (the emo feature grid feeds it) are
 * not compared. */
static void test_lts_lights_in_transport(void **state)
{
    (void)state;
    struct fixture fx;
    setup_emitter_stage(&fx, ESR_STAGE_LTS, ESR_LTS_FIRST_HIT);
    struct esr_model *m = &fx.m;
    const struct esr_grid *g = esr_model_grid(m, ESR_COMP_SDF);
    struct esr_lights L;
    memset(&L, 0, sizeof L);
    L.n = 1;
    L.grid = *g;
    L.grid.channels = 1;
    L.label = calloc(esr_grid_voxels(g), 1);
    assert_non_null(L.label);
    for (int z = 0; z < g->nz; z++)
        for (int y = 0; y < g->ny; y++)
            for (int x = 0; x < g->nx; x++) {
                float p[3];
                esr_grid_voxel_pos(g, x, y, z, p);
                if (p[0] > 0.5f)
                    L.label[((size_t)z * g->ny + y) * g->nx + x] =
                        (uint8_t)(1u | ((x + y + z) % 2 ? ESR_LIGHT_UNSEEN : 0u));
            }
    const float scale[3] = {2.0f, 3.0f, 4.0f}, field[3] = {0.7f, 0.5f, 0.3f};
    memcpy(L.light[0].scale, scale, sizeof scale);
    memcpy(L.light[0].field_rgb, field, sizeof field);
    assert_int_equal(esr_lts_set_lights(&fx.st.lts, m, &L), 0);
    assert_null(L.label); /* taken over */
    analytic_gradient(&fx);
    const struct esr_lts *l = &fx.st.lts;
    const size_t PM = fx.st.lts_stats.points * (size_t)l->M;
    size_t seen = 0, unseen = 0, other = 0;
    for (size_t i = 0; i < PM; i++) {
        if (l->hit_row[i] < 0)
            continue;
        const float *pos = l->hit_pos3 + i * 3;
        const uint8_t label = esr_lights_label_at(&l->lights, pos);
        assert_int_equal(l->emo_fixed[i], label != 0);
        if (!label) {
            other++;
            continue;
        }
        float E[3];
        assert_int_equal(esr_light_emission_at(m, pos, 1, E), 0);
        const int is_unseen = (label & ESR_LIGHT_UNSEEN) != 0;
        unseen += is_unseen;
        seen += !is_unseen;
        for (int c = 0; c < 3; c++) {
            const float want = scale[c] * (is_unseen ? field[c] : E[c]);
            assert_float_equal(l->li_emo3[i * 3 + c], want, 1e-5f * fmaxf(1.0f, want));
        }
    }
    print_message("lights in the transport: %zu hits on the light's seen part, %zu on its unseen "
                  "part, %zu elsewhere\n", seen, unseen, other);
    assert_true(seen > 0 && unseen > 0 && other > 0);
    assert_true(max_abs(&fx, ESR_COMP_EMO_MLP) > 1e-3);
    check_stage(&fx,
                ESR_BIT(ESR_COMP_SDF) | ESR_BIT(ESR_COMP_EMO_FEAT) | ESR_BIT(ESR_COMP_EMIT_MLP));
    teardown(&fx);
}

/* Option lts_brdf_emo 0: the BRDF learns from the lights-off error alone (its gradient is the one
 * a loss without the emo error gives), while E and the incident emo field keep the emo error's
 * gradient unchanged; 1 (the seed's) differs from both. */
static void test_lts_brdf_emo_share(void **state)
{
    (void)state;
    struct fixture fx;
    setup_emitter_stage(&fx, ESR_STAGE_LTS, ESR_LTS_FIRST_HIT);
    const size_t n = fx.m.params.count;
    float *g1 = malloc(n * sizeof(float)), *g0 = malloc(n * sizeof(float)), *goff = malloc(n * sizeof(float));
    assert_true(g1 && g0 && goff);
    analytic_gradient(&fx);
    memcpy(g1, fx.analytic, n * sizeof(float));
    fx.m.cfg.lts_brdf_emo = 0.0f;
    analytic_gradient(&fx);
    memcpy(g0, fx.analytic, n * sizeof(float));
    fx.m.cfg.lts_brdf_emo = 1.0f;
    fx.st.lts.emo = 0.0f; /* the emo error dropped */
    analytic_gradient(&fx);
    memcpy(goff, fx.analytic, n * sizeof(float));
    const enum esr_component brdf[2] = {ESR_COMP_BRDF_FEAT, ESR_COMP_BRDF_MLP};
    const enum esr_component emo[2] = {ESR_COMP_EMIT_MLP, ESR_COMP_EMO_MLP};
    double d_off = 0.0, d_seed = 0.0, mx = 0.0, d_emo = 0.0, mx_emo = 0.0;
    for (int c = 0; c < 2; c++) {
        const struct esr_part *pb = &fx.m.part[brdf[c]], *pe = &fx.m.part[emo[c]];
        for (size_t i = pb->off; i < pb->off + pb->count; i++) {
            d_off = fmax(d_off, fabs((double)g0[i] - goff[i]));
            d_seed = fmax(d_seed, fabs((double)g0[i] - g1[i]));
            mx = fmax(mx, fabs((double)g1[i]));
        }
        for (size_t i = pe->off; i < pe->off + pe->count; i++) {
            d_emo = fmax(d_emo, fabs((double)g0[i] - g1[i]));
            mx_emo = fmax(mx_emo, fabs((double)g1[i]));
        }
    }
    print_message("BRDF gradient: |share 0 - no emo error| %.3g, |share 0 - share 1| %.3g (max %.3g); "
                  "E / emo field |share 0 - share 1| %.3g (max %.3g)\n", d_off, d_seed, mx, d_emo, mx_emo);
    assert_true(mx > 1e-3 && mx_emo > 1e-3);
    assert_true(d_off <= 1e-5 * mx);   /* the lights-off error alone */
    assert_true(d_seed > 1e-2 * mx);   /* the seed's loss trains it from the emo error too */
    assert_true(d_emo <= 1e-6 * mx_emo); /* E and the incident emo field: untouched */
    free(g1), free(g0), free(goff);
    teardown(&fx);
}

/* lts_emo_base 0: the base colour's gradient is the lights-off error's alone, roughness's and
 * metallic's still the seed loss's (the lights' highlights), per point at the BRDF's outputs. */
static void test_lts_emo_base_share(void **state)
{
    (void)state;
    struct fixture fx;
    setup_emitter_stage(&fx, ESR_STAGE_LTS, ESR_LTS_FIRST_HIT);
    const size_t P = (size_t)fx.st.lts.P, n5 = P * ESR_BRDF_CHANNELS;
    float *d1 = malloc(n5 * sizeof(float)), *d0 = malloc(n5 * sizeof(float)), *doff = malloc(n5 * sizeof(float));
    assert_true(d1 && d0 && doff);
    analytic_gradient(&fx);
    memcpy(d1, fx.st.lts.d_brdf5, n5 * sizeof(float));
    fx.m.cfg.lts_emo_base = 0.0f;
    analytic_gradient(&fx);
    memcpy(d0, fx.st.lts.d_brdf5, n5 * sizeof(float));
    fx.m.cfg.lts_emo_base = 1.0f;
    fx.st.lts.emo = 0.0f; /* the emo error dropped */
    analytic_gradient(&fx);
    memcpy(doff, fx.st.lts.d_brdf5, n5 * sizeof(float));
    double base_off = 0, base_seed = 0, rm = 0, mx_base = 0, mx_rm = 0, rm_seed = 0;
    for (size_t p = 0; p < P; p++)
        for (int c = 0; c < ESR_BRDF_CHANNELS; c++) {
            const size_t i = p * ESR_BRDF_CHANNELS + (size_t)c;
            if (c < 3) {
                base_off = fmax(base_off, fabs((double)d0[i] - doff[i]));
                base_seed = fmax(base_seed, fabs((double)d1[i] - doff[i]));
                mx_base = fmax(mx_base, fabs((double)d1[i]));
            } else {
                rm = fmax(rm, fabs((double)d0[i] - d1[i]));
                rm_seed = fmax(rm_seed, fabs((double)d1[i] - doff[i]));
                mx_rm = fmax(mx_rm, fabs((double)d1[i]));
            }
        }
    print_message("base colour: |share 0 - no emo| %.3g, |seed - no emo| %.3g (max %.3g); "
                  "roughness/metallic |share 0 - seed| %.3g, |seed - no emo| %.3g (max %.3g)\n",
                  base_off, base_seed, mx_base, rm, rm_seed, mx_rm);
    assert_true(mx_base > 1e-4 && mx_rm > 1e-4);
    assert_true(base_seed > 1e-2 * mx_base); /* the emo error does reach the base colour */
    assert_true(rm_seed > 1e-2 * mx_rm);     /* and roughness / metallic */
    assert_true(base_off <= 1e-5 * mx_base); /* share 0: the lights-off error alone */
    assert_true(rm <= 1e-5 * mx_rm);         /* roughness / metallic: the seed's */
    free(d1), free(d0), free(doff);
    teardown(&fx);
}

/* The fine-tune's loss for the edit test (edit/finetune_loss.h): fixed direct light per point and
 * outgoing direction (the edited light brighter and bluer than the found one), whatever the
 * weights, then the loss. */
static int fixed_direct_loss(void *user, struct esr_lts *l, const struct esr_model *m,
                             const float *sdf, const struct esr_point_query *q, size_t P,
                             double *se_emo)
{
    struct esr_finetune_loss *fl = user;
    for (size_t i = 0; i < P * 2; i++)
        for (int c = 0; c < 3; c++) {
            fl->found3[i * 3 + c] = 0.2f + 0.05f * (float)c + 0.02f * (float)(i % 3);
            fl->direct3[i * 3 + c] = fl->found3[i * 3 + c] * (3.0f + 1.5f * (float)c);
        }
    return esr_finetune_loss_run(fl, l, m, sdf, q, P, se_emo);
}

/* Radiance fine-tuning's edit loss (edit/finetune_loss.c): the points' L_emo towards the
 * trained model's L_emo times the ratio of the edited and found transport estimates, each
 * channel's squared error weighted by the sRGB slope at the target. Its target and weights are
 * held (stop-gradient), so the fixture makes them constants of the tuned components: the sphere
 * alone (every secondary ray escapes, so no reflected L_emo enters the ratio), a direct-light hook
 * with fixed values, the trained model a copy of the weights, and lights-off primary rays (the
 * rendering loss does not read L_emo); then the emo grid and MLP, all that fine-tuning trains,
 * must match finite differences entry by entry. */
static void test_finetune_edit_gradients(void **state)
{
    (void)state;
    struct fixture fx;
    const uint8_t lights[N_RAYS] = {0, 0};
    setup_stage(&fx, ESR_STAGE_LTS, lights, ESR_LTS_FIRST_HIT);
    struct esr_model trained = fx.m;
    float *trained_w = malloc(fx.m.params.count * sizeof(float));
    assert_non_null(trained_w);
    memcpy(trained_w, fx.m.params.w, fx.m.params.count * sizeof(float));
    trained.params.w = trained_w;
    /* the model moves off the trained one, so the error is not the ratio's alone */
    test_randomise(&fx.m, ESR_COMP_EMO_FEAT, 0.3f, 41);
    struct esr_light_edit edits[ESR_MAX_LIGHTS];
    for (int k = 0; k < ESR_MAX_LIGHTS; k++)
        edits[k] = (struct esr_light_edit){2.0f, 0, 0.0f, 0.0f};
    struct esr_finetune_loss fl;
    assert_int_equal(esr_finetune_loss_init(&fl, &trained, fx.st.lts.P, fx.st.lts.M), 0);
    fl.edit = edits;
    const struct esr_lts_loss_hook hook = {fixed_direct_loss, &fl};
    fx.st.lts.hook = &hook;
    analytic_gradient(&fx);
    const struct esr_lts_stats *ls = &fx.st.lts_stats;
    print_message("finetune edit loss: %zu points, %zu secondary rays, %zu hits, weighted mse "
                  "emo %.4g; largest gradient: emo grid %.3g, emo MLP %.3g\n", ls->points,
                  ls->secondary, ls->hits, ls->mse_emo, max_abs(&fx, ESR_COMP_EMO_FEAT),
                  max_abs(&fx, ESR_COMP_EMO_MLP));
    assert_true(ls->points > 0 && ls->hits == 0 && ls->mse_emo > 0.0);
    assert_true(max_abs(&fx, ESR_COMP_EMO_MLP) > 1e-3);
    check_component(&fx, ESR_COMP_EMO_FEAT, eps_of(ESR_COMP_EMO_FEAT));
    check_component(&fx, ESR_COMP_EMO_MLP, eps_of(ESR_COMP_EMO_MLP));
    fx.st.lts.hook = NULL;
    esr_finetune_loss_free(&fl);
    teardown(&fx);
    free(trained_w);
}

/* The pdra stage: the lts terms with ray groups (one certain ray whose LTS points drop E and
 * whose composited E is suppressed, one uncertain ray) — every component but the SDF (as lts). */
static void check_pdra_gradients(int split)
{
    struct fixture fx;
    split_loss = split;
    setup_emitter_stage(&fx, ESR_STAGE_PDRA, ESR_LTS_FIRST_HIT);
    split_loss = 0;
    fx.m.cfg.pdra_supp = 1.0f;
    fx.m.cfg.pdra_sg = 0; /* the stop-gradient pair is invisible to FD: one plain MSE */
    test_randomise(&fx.m, ESR_COMP_EMO_FEAT, 1.0f, 32);
    /* k between the two rays' emission: one ray each side */
    fx.m.cfg.pdra_k0 = fx.m.cfg.pdra_k_end = 1e-6f;
    loss_at(&fx);
    float e[N_RAYS];
    for (int r = 0; r < N_RAYS; r++) {
        const float *v = fx.st.pdra.e_ray3 + r * 3;
        e[r] = fmaxf(v[0], fmaxf(v[1], v[2]));
    }
    fx.m.cfg.pdra_k0 = fx.m.cfg.pdra_k_end = 0.5f * (e[0] + e[1]);
    fx.m.cfg.pdra_k_frac = 1.0f; /* the cap: of 2 rays the percentile is the smaller E, below k0 */
    analytic_gradient(&fx);
    print_message("pdra: E per ray %.4g %.4g, k %.4g, %d certain, suppression %.4g\n", e[0], e[1],
                  (double)fx.st.pdra.k, fx.st.pdra.n_certain, fx.st.pdra.supp_loss);
    assert_int_equal(fx.st.pdra.n_certain, 1);
    assert_true(fx.st.pdra.supp_loss > 0.0);
    check_stage(&fx, ESR_BIT(ESR_COMP_SDF));
    teardown(&fx);
}

static void test_pdra_gradients(void **state)
{
    (void)state;
    check_pdra_gradients(0);
}

/* The same with option lts_split: certain points' reflection alone, uncertain ones' E as well. */
static void test_pdra_split_gradients(void **state)
{
    (void)state;
    check_pdra_gradients(1);
}

/* pdra's emission smoothness and final-transmittance entropy with the LTS and suppression terms
 * off: every gradient they add is exact, so every component is compared, the SDF included (they
 * reach it through the geometry feature and the alphas). Normal smoothness is checked on its own
 * below: its per-sample terms are not weighted by the samples' weights, so the kept list's
 * threshold (a sample entering or leaving it) is a jump finite differences cannot take. */
static void test_pdra_regulariser_gradients(void **state)
{
    (void)state;
    struct fixture fx;
    setup_emitter_stage(&fx, ESR_STAGE_PDRA, ESR_LTS_FIRST_HIT);
    fx.m.cfg.lts_weight = 0.0f;
    fx.m.cfg.pdra_supp = 0.0f;
    fx.m.cfg.pdra_w_es = 0.5f;
    fx.m.cfg.pdra_w_ns = 0.0f;
    fx.m.cfg.pdra_w_ent = 0.5f;
    test_randomise(&fx.m, ESR_COMP_EMO_FEAT, 1.0f, 33);
    analytic_gradient(&fx);
    print_message("pdra regularisers: emission smoothness %.4g, entropy %.4g\n",
                  fx.st.pdra.reg.es_loss, fx.st.ent_loss);
    assert_true(fx.st.pdra.reg.es_loss > 0.0 && fx.st.ent_loss > 0.0);
    assert_true(max_abs(&fx, ESR_COMP_EMIT_MLP) > 1e-4);
    check_stage(&fx, 0);
    teardown(&fx);
}

/* Normal smoothness on a fixed set of points: its SDF gradient against central differences of
 * its loss, every SDF entry. */
static void test_normal_smoothness_gradient(void **state)
{
    (void)state;
    struct fixture fx;
    setup_emitter_stage(&fx, ESR_STAGE_PDRA, ESR_LTS_FIRST_HIT);
    struct esr_model *m = &fx.m;
    m->cfg.pdra_w_es = 0.0f;
    m->cfg.pdra_w_ns = 1.0f;
    enum { NP = 24 };
    float pos[NP * 3], dir[NP * 3];
    for (int i = 0; i < NP; i++) { /* points around the sphere's surface */
        struct esr_rng r = esr_rng_init(41, (uint64_t)i);
        for (int a = 0; a < 3; a++) {
            pos[i * 3 + a] = 0.7f * (2.0f * esr_rng_float(&r) - 1.0f);
            dir[i * 3 + a] = a == 2 ? 1.0f : 0.0f;
        }
    }
    struct esr_march pts;
    memset(&pts, 0, sizeof pts);
    pts.n_kept = NP;
    pts.kpos3 = pos;
    pts.kdir3 = dir;
    const struct esr_grid *g = esr_model_grid(m, ESR_COMP_SDF);
    float *sdf = esr_model_values(m, ESR_COMP_SDF);
    const size_t ns = esr_grid_count(g);
    float *g_sdf = calloc(ns, sizeof(float)), *grads = calloc(m->params.count, sizeof(float));
    float emit[NP * 3] = {0}, d_emit[NP * 3] = {0};
    struct esr_pdra_reg *reg = &fx.st.pdra.reg;
    const struct esr_pdra_reg_batch rb = {&pts, emit, d_emit, 9};
    assert_int_equal(esr_pdra_reg_smooth(reg, m, sdf, g_sdf, grads, &rb), ESR_OK);
    assert_true(reg->ns_loss > 0.0);
    size_t bad = 0, nonzero = 0;
    float *junk = calloc(ns, sizeof(float));
    for (size_t i = 0; i < ns; i++) {
        /* an L1 kink within eps takes the one-sided slopes, as entry_agrees does */
        const float keep = sdf[i];
        double fd = 0.0, l[3];
        int ok = 0;
        for (float eps = 1e-3f; !ok && eps > 1e-6f; eps *= 0.1f) {
            const float at[3] = {keep + eps, keep - eps, keep};
            for (int k = 0; k < 3; k++) {
                sdf[i] = at[k];
                esr_pdra_reg_smooth(reg, m, sdf, junk, grads, &rb);
                l[k] = reg->ns_loss;
            }
            fd = (l[0] - l[1]) / (2.0 * eps);
            ok = agrees(g_sdf[i], fd) || agrees(g_sdf[i], (l[0] - l[2]) / eps) ||
                 agrees(g_sdf[i], (l[2] - l[1]) / eps);
        }
        sdf[i] = keep;
        nonzero += g_sdf[i] != 0.0f;
        if (!ok && bad++ < 5)
            print_error("sdf entry %zu: analytic %.6g vs central difference %.6g\n", i,
                        (double)g_sdf[i], fd);
    }
    free(junk);
    print_message("normal smoothness %.4g: %zu SDF entries with a gradient, %zu disagree\n",
                  reg->ns_loss, nonzero, bad);
    assert_true(nonzero > 0);
    assert_int_equal(bad, 0);
    free(g_sdf);
    free(grads);
    teardown(&fx);
}

static void test_coarse_gradients(void **state)
{
    (void)state;
    struct fixture fx;
    const uint8_t lights[N_RAYS] = {0, 1}; /* lighting flag input */
    setup_stage(&fx, ESR_STAGE_COARSE, lights, ESR_LTS_FIRST_HIT);
    analytic_gradient(&fx);
    assert_true(fx.st.sdf_view != NULL); /* the SDF gradient goes through the smoothing */
    check_stage(&fx, 0);
    teardown(&fx);
}

/* The learned background's gradient through both composites (fine: tone-mapped and linear;
 * coarse: LDR), every entry of every trained component. The grazing ray keeps a transmittance
 * well between 0 and 1, so both the background and the geometry in front of it matter. */
static void test_background_gradients(void **state)
{
    (void)state;
    learned_background = 1;
    const enum esr_stage stages[] = {ESR_STAGE_COARSE, ESR_STAGE_FINE};
    for (size_t i = 0; i < 2; i++) {
        struct fixture fx;
        const uint8_t lights[N_RAYS] = {0, 1};
        setup_stage(&fx, stages[i], lights, ESR_LTS_FIRST_HIT);
        analytic_gradient(&fx);
        const float t = fx.st.tr.march.t_last[1];
        if (!(t > 0.05f && t < 0.95f))
            fail_msg("the grazing ray's transmittance %.3f is not partial", (double)t);
        assert_false(all_zero(&fx, ESR_COMP_BACKGROUND));
        /* the background, and the SDF whose alpha it sits behind (the rest: the tests above) */
        check_stage(&fx, esr_stage_info(stages[i])->trained &
                             ~(ESR_BIT(ESR_COMP_BACKGROUND) | ESR_BIT(ESR_COMP_SDF)));
        teardown(&fx);
    }
    learned_background = 0;
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
#ifdef _OPENMP
    omp_set_num_threads(1); /* thousands of two-ray steps: threads only add overhead */
#endif
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_render_loss_by_hand),
        cmocka_unit_test(test_fine_gradients_lights_off),
        cmocka_unit_test(test_fine_gradients_mixed_lighting),
        cmocka_unit_test(test_fine_lights_on_stop_gradient),
        cmocka_unit_test(test_geom_on_weight),
        cmocka_unit_test(test_coarse_gradients),
        cmocka_unit_test(test_background_gradients),
        cmocka_unit_test(test_lts_gradients),
        cmocka_unit_test(test_lts_lobe_gradients),
        cmocka_unit_test(test_lts_split_gradients),
        cmocka_unit_test(test_lts_volume_gradients),
        cmocka_unit_test(test_lts_lights_in_transport),
        cmocka_unit_test(test_lts_brdf_emo_share),
        cmocka_unit_test(test_lts_emo_base_share),
        cmocka_unit_test(test_finetune_edit_gradients),
        cmocka_unit_test(test_pdra_gradients),
        cmocka_unit_test(test_pdra_split_gradients),
        cmocka_unit_test(test_pdra_regulariser_gradients),
        cmocka_unit_test(test_normal_smoothness_gradient),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
