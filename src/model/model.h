/* The trained scene model: configuration + fields + MLPs with every parameter in one flat buffer
 * (nn/params.h), so a checkpoint is config + weights (+ optimiser moments) + step.
 *
 * Which parts exist depends on the stage the model has reached:
 *   alphamask: density grid (DVGO) -> mask cache
 *   coarse:    SDF grid + colour feature grid + colour MLP (sigmoid, LDR sRGB directly; the
 *              lighting flag is one MLP input so off/on images share geometry)
 *   fine:      SDF grid (upsampled) + off/emo feature grids + off/emo radiance MLPs (softplus,
 *              linear HDR, L_on = L_off + L_emo) + tone-mapper m_theta (sigmoid) applied per
 *              sample before compositing (METHOD.md "Rendering loss and colour").
 * Rendering always composites on a white background. The coarse SDF starts as the signed
 * distance to the alphamask's occupied voxels (train/sdf_init.h), the fine SDF is the coarse one
 * resampled, and the fine stage narrows the mask cache to a band around the coarse surface.
 * A run directory holds one checkpoint per stage: RUN/ckpt_{alphamask,coarse,fine}.bin. */
#ifndef ESR_MODEL_MODEL_H
#define ESR_MODEL_MODEL_H

#include <stddef.h>
#include <stdint.h>

#include "fields/geo_feature.h"
#include "fields/grid.h"
#include "fields/mask.h"
#include "nn/adam.h"
#include "nn/encoding.h"
#include "nn/mlp.h"
#include "nn/params.h"
#include "model/config.h"

#ifdef __cplusplus
extern "C" {
#endif

enum esr_stage { ESR_STAGE_ALPHAMASK, ESR_STAGE_COARSE, ESR_STAGE_FINE, ESR_STAGE_COUNT };
/* "alphamask", "coarse", "fine"; NULL for an invalid stage. */
const char *esr_stage_name(enum esr_stage s);
int esr_stage_from_name(const char *name, enum esr_stage *out);

struct esr_model {
    struct esr_train_config cfg;
    int stage;            /* enum esr_stage the parameters belong to */
    long step;            /* iterations done in that stage */
    int stage_done;       /* 1 when `stage` finished all its iterations */
    float scene_min[3], scene_max[3]; /* box every grid spans */

    struct esr_nn_params params; /* every parameter (and its gradient) */
    struct esr_adam adam;        /* optimiser moments, same layout */

    /* alphamask */
    struct esr_grid density;  size_t density_off;
    float density_shift;      /* DVGO act_shift */
    /* mask cache (from the alphamask stage; all-occupied until then) */
    struct esr_mask mask;
    int has_mask;

    /* coarse + fine */
    struct esr_grid sdf;      size_t sdf_off;
    float inv_s;              /* NeuS s at the current step (esr_model_inv_s_at(step)) */
    /* coarse */
    struct esr_grid feat;     size_t feat_off;
    struct esr_mlp colour;
    /* fine */
    struct esr_grid feat_off_g, feat_emo_g; size_t feat_off_off, feat_emo_off;
    struct esr_mlp rad_off, rad_emo, tone;
    struct esr_geo_feature_params geo;
    struct esr_pe pe_pos, pe_dir, pe_tone;
};

/* A fresh model at the start of `stage` for the given config (fields initialised: sphere SDF,
 * small random features, Kaiming MLPs; deterministic in cfg->seed). When `prev` is non-NULL
 * (the finished previous stage) its mask cache is taken over and the SDF is resampled from it. */
int esr_model_init(struct esr_model *m, const struct esr_train_config *cfg, enum esr_stage stage,
                   const struct esr_model *prev, const float scene_min[3], const float scene_max[3]);
void esr_model_free(struct esr_model *m);

/* NeuS inv-s of m's stage after `step` iterations: s0 + step / s_div (METHOD.md); 0 for the
 * alphamask stage. */
float esr_model_inv_s_at(const struct esr_model *m, long step);

/* Loads a model: `path` is a checkpoint file, or a run directory (then the most advanced stage's
 * checkpoint in it is used: fine, else coarse, else alphamask). Fails naming the file on a
 * missing/truncated/corrupt checkpoint or a version mismatch. */
int esr_model_load(struct esr_model *m, const char *path);
/* Writes the model (config, stage, step, weights, Adam moments, mask cache) atomically
 * (temp + rename) with a version number. */
int esr_model_save(const struct esr_model *m, const char *path);

/* What esr_model_render_rays writes; any pointer may be NULL (not computed). */
struct esr_render_out {
    float *rgb;      /* [n*3] tone-mapped LDR in [0,1] composited on white (what PNGs compare to) */
    float *linear;   /* [n*3] linear HDR radiance composited on white (fine; coarse: sRGB^-1 of rgb) */
    float *depth;    /* [n]   expected ray distance of the surface (weights-normalised) */
    float *normal;   /* [n*3] composited unit SDF normal (world space, not normalised by opacity) */
    float *opacity;  /* [n]   1 - T_final */
};

/* Renders n rays (origins/dirs [n*3], dirs unit length) with lights on (1) or off (0). Only
 * coarse/fine models render (an alphamask-only model renders its density as grey).
 * Thread-safe for concurrent calls on one model; allocates its own scratch per call. */
int esr_model_render_rays(const struct esr_model *m, const float *origins, const float *dirs,
                          size_t n, int lights_on, const struct esr_render_out *out);

/* The (unsmoothed) SDF grid for marching cubes (level 0); *data points into the model's
 * parameters. ESR_ERR when the model has no SDF (alphamask stage). */
int esr_model_sdf_grid(const struct esr_model *m, const struct esr_grid **grid, const float **data);

#ifdef __cplusplus
}
#endif
#endif
