/* The component and stage tables (see components.h). */
#include "model/components.h"

#include <string.h>

#include "core/error.h"
#include "fields/background.h"
#include "fields/env_sg.h"
#include "model/material_fields.h"
#include "model/model.h"
#include "volume/neus.h"

/* ---- shapes ---- */

/* A cubic grid of `res` points per axis over the scene box, its values taken from m->params. */
static int take_grid(struct esr_model *m, enum esr_component c, int channels, int res)
{
    struct esr_part *p = &m->part[c];
    ESR_TRY(esr_grid_init(&p->grid, channels, res, res, res, m->scene_min, m->scene_max));
    p->count = esr_grid_count(&p->grid);
    return esr_nn_params_take(&m->params, p->count, &p->off);
}

static int take_mlp(struct esr_model *m, enum esr_component c, int n_in, int width, int depth,
                    int n_out, enum esr_nn_act out_act)
{
    struct esr_part *p = &m->part[c];
    struct esr_mlp_desc d;
    d.n_in = n_in;
    d.width = width;
    d.n_hidden = depth;
    d.n_out = n_out;
    d.hidden_act = ESR_NN_ACT_RELU;
    d.out_act = out_act;
    ESR_TRY(esr_mlp_init(&p->mlp, &d, &m->params));
    p->off = p->mlp.offset;
    p->count = p->mlp.count;
    return ESR_OK;
}

static int layout_density(struct esr_model *m, enum esr_component c)
{
    return take_grid(m, c, 1, m->cfg.alphamask.res);
}

static int layout_rgb_grid(struct esr_model *m, enum esr_component c)
{
    return take_grid(m, c, 6, m->cfg.alphamask.res); /* DVGO's direct colour grid, off | on */
}

static int layout_sdf(struct esr_model *m, enum esr_component c)
{
    return take_grid(m, c, 1, esr_stage_options(&m->cfg, (enum esr_stage)m->stage)->res);
}

static int layout_colour_feat(struct esr_model *m, enum esr_component c)
{
    return take_grid(m, c, m->cfg.coarse.feat_channels, m->cfg.coarse.res);
}

/* Fine feature grids at the coarse resolution: their Adam and TV passes touch every entry each
 * step, and the MLPs' PE(x) input carries the fine detail. */
static int layout_radiance_feat(struct esr_model *m, enum esr_component c)
{
    return take_grid(m, c, m->cfg.fine.feat_channels, m->cfg.coarse.res);
}

static int layout_colour_mlp(struct esr_model *m, enum esr_component c)
{
    const struct esr_stage_config *s = &m->cfg.coarse;
    int n_in = s->feat_channels + esr_pe_out_dims(&m->pe_dir) + 1; /* + lights flag */
    return take_mlp(m, c, n_in, s->mlp_width, s->mlp_depth, 3, ESR_NN_ACT_SIGMOID);
}

static int layout_radiance_mlp(struct esr_model *m, enum esr_component c)
{
    const struct esr_stage_config *s = &m->cfg.fine;
    int n_in = s->feat_channels + esr_pe_out_dims(&m->pe_pos) + esr_geo_feature_dim(&m->geo) +
               esr_pe_out_dims(&m->pe_dir);
    return take_mlp(m, c, n_in, s->mlp_width, s->mlp_depth, 3, ESR_NN_ACT_SOFTPLUS);
}

static int layout_tone_mlp(struct esr_model *m, enum esr_component c)
{
    return take_mlp(m, c, esr_pe_out_dims(&m->pe_tone), m->cfg.tone_width, 1, 3,
                    ESR_NN_ACT_SIGMOID);
}

/* Input of the emission and BRDF MLPs: the radiance MLPs' minus the view direction. */
static int material_mlp_inputs(const struct esr_model *m)
{
    return m->cfg.fine.feat_channels + esr_pe_out_dims(&m->pe_pos) + esr_geo_feature_dim(&m->geo);
}

static int layout_emit_mlp(struct esr_model *m, enum esr_component c)
{
    return take_mlp(m, c, material_mlp_inputs(m), m->cfg.field_width, m->cfg.field_depth, 3,
                    ESR_NN_ACT_SOFTPLUS);
}

static int layout_brdf_mlp(struct esr_model *m, enum esr_component c)
{
    return take_mlp(m, c, material_mlp_inputs(m), m->cfg.field_width, m->cfg.field_depth,
                    ESR_BRDF_CHANNELS, ESR_NN_ACT_SIGMOID);
}

static int layout_env(struct esr_model *m, enum esr_component c)
{
    struct esr_part *p = &m->part[c];
    p->count = esr_env_sg_param_count(m->cfg.env_lobes);
    return esr_nn_params_take(&m->params, p->count, &p->off);
}

/* Present only when the options ask for a learned background (count 0 = absent). */
static int layout_background(struct esr_model *m, enum esr_component c)
{
    struct esr_part *p = &m->part[c];
    p->count = m->cfg.background == ESR_BACKGROUND_LEARNED ? ESR_BACKGROUND_PARAMS : 0;
    return p->count ? esr_nn_params_take(&m->params, p->count, &p->off) : ESR_OK;
}

/* ---- the component table ---- */

static const struct esr_component_info components[ESR_COMP_COUNT] = {
    [ESR_COMP_DENSITY] = {"density", ESR_KIND_GRID, ESR_LR_GRID, ESR_TV_NONE, ESR_INIT_ZERO, 0, 0.0f,
                          layout_density},
    [ESR_COMP_RGB_GRID] = {"rgb_grid", ESR_KIND_GRID, ESR_LR_FEAT, ESR_TV_NONE, ESR_INIT_ZERO, 0,
                           0.0f, layout_rgb_grid},
    [ESR_COMP_SDF] = {"sdf", ESR_KIND_GRID, ESR_LR_GRID, ESR_TV_SDF, ESR_INIT_SDF, 0, 0.0f,
                      layout_sdf},
    [ESR_COMP_COLOUR_FEAT] = {"colour_feat", ESR_KIND_GRID, ESR_LR_FEAT, ESR_TV_FEAT, ESR_INIT_NOISE,
                              0, 0.0f, layout_colour_feat},
    [ESR_COMP_COLOUR_MLP] = {"colour_mlp", ESR_KIND_MLP, ESR_LR_MLP, ESR_TV_NONE, ESR_INIT_KAIMING,
                             1, 0.0f, layout_colour_mlp},
    [ESR_COMP_OFF_FEAT] = {"off_feat", ESR_KIND_GRID, ESR_LR_FEAT, ESR_TV_FEAT, ESR_INIT_NOISE, 0,
                           0.0f, layout_radiance_feat},
    [ESR_COMP_EMO_FEAT] = {"emo_feat", ESR_KIND_GRID, ESR_LR_FEAT, ESR_TV_FEAT, ESR_INIT_NOISE, 7,
                           0.0f, layout_radiance_feat},
    [ESR_COMP_OFF_MLP] = {"off_mlp", ESR_KIND_MLP, ESR_LR_MLP, ESR_TV_NONE, ESR_INIT_KAIMING, 1,
                          0.0f, layout_radiance_mlp},
    /* the extra radiance starts near zero: softplus(-5) ~ 0.007, so off-rays are not tinted */
    [ESR_COMP_EMO_MLP] = {"emo_mlp", ESR_KIND_MLP, ESR_LR_MLP, ESR_TV_NONE, ESR_INIT_KAIMING, 2,
                          -5.0f, layout_radiance_mlp},
    [ESR_COMP_TONE_MLP] = {"tone_mlp", ESR_KIND_MLP, ESR_LR_MLP, ESR_TV_NONE, ESR_INIT_KAIMING, 3,
                           0.0f, layout_tone_mlp},
    /* softplus(0) ~ 0.69: every point starts as a weak emitter and the light-transport loss
     * pulls E down where reflection explains the light (the authors' last bias 0) */
    [ESR_COMP_EMIT_MLP] = {"emit_mlp", ESR_KIND_MLP, ESR_LR_MLP, ESR_TV_NONE, ESR_INIT_KAIMING, 4,
                           0.0f, layout_emit_mlp},
    [ESR_COMP_BRDF_FEAT] = {"brdf_feat", ESR_KIND_GRID, ESR_LR_FEAT, ESR_TV_FEAT, ESR_INIT_ZERO, 0,
                            0.0f, layout_radiance_feat},
    [ESR_COMP_BRDF_MLP] = {"brdf_mlp", ESR_KIND_MLP, ESR_LR_MLP, ESR_TV_NONE, ESR_INIT_KAIMING, 5,
                           0.0f, layout_brdf_mlp},
    [ESR_COMP_ENV] = {"env", ESR_KIND_VECTOR, ESR_LR_MLP, ESR_TV_NONE, ESR_INIT_ENV_SG, 6, 0.0f,
                      layout_env},
    /* logits 0: grey until the data says otherwise; the feature learning rate (a texture) */
    [ESR_COMP_BACKGROUND] = {"background", ESR_KIND_VECTOR, ESR_LR_FEAT, ESR_TV_NONE, ESR_INIT_ZERO,
                             0, 0.0f, layout_background},
};

const struct esr_component_info *esr_component_info(enum esr_component c)
{
    return &components[c];
}

enum esr_component esr_component_from_name(const char *name)
{
    for (int c = 0; c < ESR_COMP_COUNT; c++)
        if (!strcmp(name, components[c].name))
            return (enum esr_component)c;
    return ESR_COMP_COUNT;
}

/* ---- the stage table ---- */

/* the background (absent unless learned) is in every stage and carries over from one to the next */
#define ALPHAMASK_PARTS                                                                           \
    (ESR_BIT(ESR_COMP_DENSITY) | ESR_BIT(ESR_COMP_RGB_GRID) | ESR_BIT(ESR_COMP_BACKGROUND))
#define COARSE_PARTS                                                                              \
    (ESR_BIT(ESR_COMP_SDF) | ESR_BIT(ESR_COMP_COLOUR_FEAT) | ESR_BIT(ESR_COMP_COLOUR_MLP) |       \
     ESR_BIT(ESR_COMP_BACKGROUND))
#define FINE_PARTS                                                                                \
    (ESR_BIT(ESR_COMP_SDF) | ESR_BIT(ESR_COMP_OFF_FEAT) | ESR_BIT(ESR_COMP_EMO_FEAT) |            \
     ESR_BIT(ESR_COMP_OFF_MLP) | ESR_BIT(ESR_COMP_EMO_MLP) | ESR_BIT(ESR_COMP_TONE_MLP) |         \
     ESR_BIT(ESR_COMP_BACKGROUND))

#define LTS_PARTS                                                                                 \
    (FINE_PARTS | ESR_BIT(ESR_COMP_EMIT_MLP) | ESR_BIT(ESR_COMP_BRDF_FEAT) |                      \
     ESR_BIT(ESR_COMP_BRDF_MLP) | ESR_BIT(ESR_COMP_ENV))

static const struct esr_stage_info stages[ESR_STAGE_COUNT] = {
    [ESR_STAGE_ALPHAMASK] = {.name = "alphamask",
                             .options = offsetof(struct esr_train_config, alphamask),
                             .present = ALPHAMASK_PARTS,
                             .trained = ALPHAMASK_PARTS,
                             .alpha = ESR_ALPHA_DENSITY,
                             .head = ESR_HEAD_RGB_GRID,
                             .decay = ESR_DECAY_EXP,
                             .builds_mask = 1},
    [ESR_STAGE_COARSE] = {.name = "coarse",
                          .options = offsetof(struct esr_train_config, coarse),
                          .present = COARSE_PARTS,
                          .trained = COARSE_PARTS,
                          .alpha = ESR_ALPHA_NEUS,
                          .head = ESR_HEAD_COLOUR_MLP,
                          .decay = ESR_DECAY_EXP,
                          .smoothed_sdf = 1},
    [ESR_STAGE_FINE] = {.name = "fine",
                        .options = offsetof(struct esr_train_config, fine),
                        .present = FINE_PARTS,
                        .trained = FINE_PARTS,
                        .alpha = ESR_ALPHA_NEUS,
                        .head = ESR_HEAD_RADIANCE,
                        .decay = ESR_DECAY_COSINE,
                        .linear_loss = 1,
                        .narrows_mask = 1},
    [ESR_STAGE_LTS] = {.name = "lts",
                       .options = offsetof(struct esr_train_config, lts),
                       .present = LTS_PARTS,
                       .trained = LTS_PARTS,
                       .alpha = ESR_ALPHA_NEUS,
                       .head = ESR_HEAD_RADIANCE,
                       .decay = ESR_DECAY_COSINE,
                       .linear_loss = 1,
                       .lts_loss = 1},
    [ESR_STAGE_PDRA] = {.name = "pdra",
                        .options = offsetof(struct esr_train_config, pdra),
                        .present = LTS_PARTS,
                        .trained = LTS_PARTS,
                        .alpha = ESR_ALPHA_NEUS,
                        .head = ESR_HEAD_RADIANCE,
                        .decay = ESR_DECAY_COSINE,
                        .linear_loss = 1,
                        .lts_loss = 1,
                        .ray_groups = 1,
                        .finds_lights = 1},
};

const struct esr_stage_info *esr_stage_info(enum esr_stage s)
{
    return &stages[s];
}

const char *esr_stage_name(enum esr_stage s)
{
    return s >= 0 && s < ESR_STAGE_COUNT ? stages[s].name : NULL;
}

int esr_stage_from_name(const char *name, enum esr_stage *out)
{
    for (int i = 0; i < ESR_STAGE_COUNT; i++)
        if (!strcmp(name, stages[i].name)) {
            *out = (enum esr_stage)i;
            return ESR_OK;
        }
    return ESR_FAIL("unknown stage '%s' (valid: alphamask, coarse, fine, lts, pdra)", name);
}

const struct esr_stage_config *esr_stage_options(const struct esr_train_config *cfg,
                                                 enum esr_stage s)
{
    return (const struct esr_stage_config *)((const char *)cfg + stages[s].options);
}

float esr_stage_inv_s(const struct esr_train_config *cfg, enum esr_stage s, long step)
{
    if (stages[s].alpha != ESR_ALPHA_NEUS)
        return 0.0f;
    const struct esr_stage_config *o = esr_stage_options(cfg, s);
    return esr_neus_inv_s(o->s0, o->s_div, (int)step);
}

int esr_stage_has(enum esr_stage s, enum esr_component c)
{
    return (stages[s].present & ESR_BIT(c)) != 0;
}
