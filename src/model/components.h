/* What a model is made of, as data: the component table and the stage table.
 *
 * A *component* is one trained piece (a voxel grid or an MLP) with its name (checkpoints match
 * components by it), its kind (grids get sparse Adam with beta2 0.99 as in DVGO/Voxurf, MLPs
 * dense Adam with 0.999), which of the stage's learning rates and TV weights applies to it, and
 * how it is shaped and initialised. A *stage* is one row: its name, the components present and
 * the ones it trains, how alpha is computed (DVGO density or NeuS on the SDF), which head turns
 * points into colour, the learning-rate decay, the loss terms, the inv-s schedule (from the
 * stage's options) and what happens at its start and end (mask narrowing, mask building).
 *
 * The trainer, Adam, TV, layout, checkpoints and logging loop over these tables, so a new
 * component is one enum value + one row (+ its shape/init functions in components.c), and a new
 * stage is one enum value + one row. */
#ifndef ESR_MODEL_COMPONENTS_H
#define ESR_MODEL_COMPONENTS_H

#include <stddef.h>
#include <stdint.h>

#include "model/config.h"

#ifdef __cplusplus
extern "C" {
#endif

enum esr_component {
    ESR_COMP_DENSITY,     /* alphamask: DVGO density grid (1 channel) */
    ESR_COMP_RGB_GRID,    /* alphamask: direct colour grid, sigmoid logits off RGB | on RGB */
    ESR_COMP_SDF,         /* coarse, fine: SDF grid */
    ESR_COMP_COLOUR_FEAT, /* coarse: colour feature grid */
    ESR_COMP_COLOUR_MLP,  /* coarse: colour MLP on [feature | PE(dir) | lights flag], sigmoid */
    ESR_COMP_OFF_FEAT,    /* fine: feature grid of the lights-off radiance */
    ESR_COMP_EMO_FEAT,    /* fine: feature grid of the extra radiance with the lights on */
    ESR_COMP_OFF_MLP,     /* fine: L_off radiance MLP, softplus (linear HDR) */
    ESR_COMP_EMO_MLP,     /* fine: L_emo radiance MLP, softplus */
    ESR_COMP_TONE_MLP,    /* fine: tone-mapper m_theta on PE(linear RGB), sigmoid */
    ESR_COMP_EMIT_MLP,    /* lts: emission E(x) MLP on [emo feature | PE(x) | geometry], softplus */
    ESR_COMP_BRDF_FEAT,   /* lts: feature grid of the BRDF */
    ESR_COMP_BRDF_MLP,    /* lts: BRDF MLP -> base colour (3), roughness, metallic; sigmoid */
    ESR_COMP_ENV,         /* lts: spherical-Gaussian environment map (fields/env_sg.h) */
    ESR_COMP_BACKGROUND,  /* every stage, only with background = learned: fields/background.h */
    ESR_COMP_COUNT
};

/* Grids train with sparse Adam (beta2 0.99), MLPs and plain vectors with dense Adam (0.999). */
enum esr_component_kind { ESR_KIND_GRID, ESR_KIND_MLP, ESR_KIND_VECTOR };
/* Which learning rate of struct esr_stage_config a component trains with. */
enum esr_lr_class { ESR_LR_GRID, ESR_LR_FEAT, ESR_LR_MLP };
/* Which total-variation weight of struct esr_stage_config regularises a grid component. */
enum esr_tv_class { ESR_TV_NONE, ESR_TV_SDF, ESR_TV_FEAT };
/* How a component starts in a fresh stage. */
enum esr_init_kind {
    ESR_INIT_ZERO,   /* all zero (density: alpha_init comes from the shift; colour logits 0) */
    ESR_INIT_SDF,    /* signed distance to the previous stage's occupancy or its SDF resampled,
                        else a sphere */
    ESR_INIT_NOISE,  /* small uniform noise, so feature channels are not identical */
    ESR_INIT_KAIMING, /* MLP: Kaiming weights, last bias `last_bias` */
    ESR_INIT_ENV_SG   /* environment map: lobes spread over the sphere (esr_env_sg_init) */
};

struct esr_model;

struct esr_component_info {
    const char *name;             /* checkpoint and log name */
    enum esr_component_kind kind;
    enum esr_lr_class lr;
    enum esr_tv_class tv;
    enum esr_init_kind init;
    int seed_offset;              /* init randomness: (seed * 1000 + stage) + seed_offset */
    float last_bias;              /* ESR_INIT_KAIMING: the output layer's bias */
    /* Shapes the component in m (grid lattice or MLP description) and takes its parameter
     * range from m->params. Reads the config and m's encodings. */
    int (*layout)(struct esr_model *m, enum esr_component c);
};

const struct esr_component_info *esr_component_info(enum esr_component c);
/* Component by checkpoint name; ESR_COMP_COUNT when unknown. */
enum esr_component esr_component_from_name(const char *name);

enum esr_stage {
    ESR_STAGE_ALPHAMASK,
    ESR_STAGE_COARSE,
    ESR_STAGE_FINE,
    ESR_STAGE_LTS,
    ESR_STAGE_PDRA,
    ESR_STAGE_COUNT
};

enum esr_alpha_model { ESR_ALPHA_DENSITY, ESR_ALPHA_NEUS };
/* The head that turns kept samples into colour (model/point_fields.h). */
enum esr_head {
    ESR_HEAD_RGB_GRID,   /* sigmoid colour grid, LDR directly */
    ESR_HEAD_COLOUR_MLP, /* colour MLP, LDR directly */
    ESR_HEAD_RADIANCE    /* L_off (+ L_emo with the lights on), linear HDR + tone-mapper */
};
enum esr_lr_decay { ESR_DECAY_EXP, ESR_DECAY_COSINE };

#define ESR_BIT(c) (1u << (unsigned)(c))

struct esr_stage_info {
    const char *name;
    size_t options;           /* offsetof(struct esr_train_config, <stage>) */
    uint32_t present;         /* ESR_BIT(component) of every component the stage has */
    uint32_t trained;         /* the subset its optimiser updates */
    enum esr_alpha_model alpha;
    enum esr_head head;       /* also fixes the outputs: LDR only, or tone-mapped + linear */
    enum esr_lr_decay decay;
    int linear_loss;          /* adds lambda_tau * MSE(gamma(linear), C) (needs linear output) */
    int smoothed_sdf;         /* renders through the Gaussian-smoothed SDF (smooth_ksize) */
    int narrows_mask;         /* at its start: mask cache kept only near the previous SDF */
    int builds_mask;          /* at its end: mask cache from its density grid */
    int lts_loss;             /* adds the light-transport-segment loss (train/lts.h) */
    int ray_groups;           /* certain/uncertain rays by composited E vs k (train/pdra.h) */
    int finds_lights;         /* at its end: the emitters split into lights and their strength
                                 calibrated (train/lights/lights.h) */
};

const struct esr_stage_info *esr_stage_info(enum esr_stage s);
/* "alphamask", "coarse", "fine", "lts", "pdra"; NULL for an invalid stage. */
const char *esr_stage_name(enum esr_stage s);
int esr_stage_from_name(const char *name, enum esr_stage *out);
/* The stage's own options (cfg->alphamask / coarse / fine / lts / pdra). */
const struct esr_stage_config *esr_stage_options(const struct esr_train_config *cfg,
                                                 enum esr_stage s);
/* NeuS inv-s of stage s after `step` iterations (s0 + step / s_div of its options, via
 * esr_neus_inv_s); 0 for a density stage. The one schedule every caller uses. */
float esr_stage_inv_s(const struct esr_train_config *cfg, enum esr_stage s, long step);
/* 1 when stage s has component c. */
int esr_stage_has(enum esr_stage s, enum esr_component c);

#ifdef __cplusplus
}
#endif
#endif
