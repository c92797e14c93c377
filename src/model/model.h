/* The trained scene model: configuration + components (model/components.h) with every parameter
 * in one flat buffer (nn/params.h), so a checkpoint is config + named parameter ranges (+ the
 * optimiser moments) + step.
 *
 * Which components exist depends on the stage the model has reached (the stage table):
 *   alphamask: density grid (DVGO) + direct colour grid -> mask cache
 *   coarse:    SDF grid + colour feature grid + colour MLP (sigmoid, LDR sRGB directly; the
 *              lighting flag is one MLP input so off/on images share geometry)
 *   fine:      SDF grid (upsampled) + off/emo feature grids + off/emo radiance MLPs (softplus,
 *              linear HDR, L_on = L_off + L_emo) + tone-mapper m_theta (sigmoid) applied per
 *              sample before compositing (METHOD.md "Rendering loss and colour").
 * Rendering always composites on a white background. The coarse SDF starts as the signed
 * distance to the alphamask's occupied voxels (model/sdf_init.h), the fine SDF is the coarse one
 * resampled, and the fine stage narrows the mask cache to a band around the coarse surface.
 * A run directory holds one checkpoint per stage: RUN/ckpt_<stage>.bin. */
#ifndef ESR_MODEL_MODEL_H
#define ESR_MODEL_MODEL_H

#include <stddef.h>
#include <stdint.h>

#include "fields/geo_feature.h"
#include "fields/grid.h"
#include "fields/mask.h"
#include "model/components.h"
#include "model/config.h"
#include "nn/adam.h"
#include "nn/encoding.h"
#include "nn/mlp.h"
#include "model/lights.h"
#include "nn/params.h"

#ifdef __cplusplus
extern "C" {
#endif

/* One component's place in a model: its parameter range and its shape. */
struct esr_part {
    size_t off, count;    /* range of m->params (count 0: the stage does not have it) */
    struct esr_grid grid; /* ESR_KIND_GRID: the lattice */
    struct esr_mlp mlp;   /* ESR_KIND_MLP: the network (mlp.offset == off) */
};

struct esr_model {
    struct esr_train_config cfg;
    int stage;            /* enum esr_stage the parameters belong to */
    long step;            /* iterations done in that stage */
    int stage_done;       /* 1 when `stage` finished all its iterations */
    float scene_min[3], scene_max[3]; /* box every grid spans */

    struct esr_nn_params params; /* every parameter (and its gradient) */
    struct esr_adam adam;        /* optimiser moments, same layout */
    struct esr_part part[ESR_COMP_COUNT];

    float density_shift;  /* DVGO act_shift of the density grid */
    struct esr_mask mask; /* mask cache (from the alphamask stage; all-occupied until then) */
    int has_mask;
    struct esr_lights lights; /* the lights found after pdra (n 0: none / not yet) */
    float inv_s;          /* NeuS s at the current step (esr_stage_inv_s) */
    float lr_scale;       /* the stage's learning rates x this: 1, halved after each non-finite
                             step (train/trainer.c), kept in the checkpoint so a resumed stage
                             trains at the rate the stopped one had */
    /* encodings and the geometry feature the MLP components read */
    struct esr_geo_feature_params geo;
    struct esr_pe pe_pos, pe_dir, pe_tone;
};

/* 1 when m's stage has component c. */
static inline int esr_model_has(const struct esr_model *m, enum esr_component c)
{
    return m->part[c].count > 0;
}
static inline const struct esr_grid *esr_model_grid(const struct esr_model *m, enum esr_component c)
{
    return &m->part[c].grid;
}
static inline const struct esr_mlp *esr_model_mlp(const struct esr_model *m, enum esr_component c)
{
    return &m->part[c].mlp;
}
/* The component's values (grid data) inside the flat parameter buffer. */
static inline float *esr_model_values(const struct esr_model *m, enum esr_component c)
{
    return m->params.w + m->part[c].off;
}

/* A fresh model at the start of `stage` for the given config (fields initialised: sphere SDF,
 * small random features, Kaiming MLPs; deterministic in cfg->seed). When `prev` is non-NULL
 * (the finished previous stage) its mask cache is taken over and the SDF is resampled from it. */
int esr_model_init(struct esr_model *m, const struct esr_train_config *cfg, enum esr_stage stage,
                   const struct esr_model *prev, const float scene_min[3], const float scene_max[3]);
void esr_model_free(struct esr_model *m);
/* Bytes a fresh model of `stage` would take (parameters with their gradients and Adam moments,
 * the mask cache taken over from prev, which may be NULL), counted without allocating; *n_params
 * (may be NULL) its parameter count. esr_model_init refuses a model that does not fit. */
int esr_model_memory_need(const struct esr_train_config *cfg, enum esr_stage stage,
                          const struct esr_model *prev, const float scene_min[3],
                          const float scene_max[3], size_t *bytes, size_t *n_params);
/* Bytes an allocated model holds, counted the same way. */
size_t esr_model_memory_held(const struct esr_model *m);
/* A 64-bit fingerprint of what a render of m depends on: stage, step, every parameter, the mask
 * cache and the lights (esr_lights_fingerprint). Renders record it (render/view.h), so another
 * run's model at the same stage and step, or lights found again, make them stale. */
uint64_t esr_model_fingerprint(const struct esr_model *m);

/* Loads a model: `path` is a checkpoint file, or a run directory (then the most advanced stage's
 * checkpoint in it is used). The checkpoint stores its options as JSON and its parameters as
 * named components: options the file lacks take their preset default, components the stage has
 * but the file lacks keep their fresh initial values; a component of a different size, one this
 * build does not know, a truncated file or a wrong version is refused naming the file and the
 * mismatch. */
int esr_model_load(struct esr_model *m, const char *path);
/* The same from a checkpoint's size bytes in memory; name stands for the file in messages. */
int esr_model_load_buffer(struct esr_model *m, const void *data, size_t size, const char *name);
/* The model whose lights a run found: RUN/ckpt_pdra.bin, refused (model freed) when it is missing
 * or its stage has not finished. */
int esr_model_load_finished_pdra(struct esr_model *m, const char *run);
/* Writes the model (options as JSON, stage, step, the component table, weights, Adam moments,
 * mask cache) atomically (temp + rename) with a format version. */
int esr_model_save(const struct esr_model *m, const char *path);

/* A ray's first surface (esr_render_out.front_*): from its first sample of weight above this,
 * this many voxels deep (a NeuS surface's weights span about a voxel) */
#define ESR_FRONT_MIN_WEIGHT 0.02f
#define ESR_FRONT_DEPTH_VOX 3.0f

/* What esr_model_render_rays writes; any pointer may be NULL (not computed). */
struct esr_render_out {
    float *rgb;      /* [n*3] tone-mapped LDR in [0,1] composited on the model's background: white,
                        or its learned one (fields/background.h); what PNGs compare to */
    float *linear;   /* [n*3] linear HDR radiance composited on the background (fine; coarse:
                        sRGB^-1 of rgb) */
    float *depth;    /* [n]   expected ray distance of the surface (weights-normalised) */
    float *normal;   /* [n*3] composited unit SDF normal (world space, not normalised by opacity) */
    float *opacity;  /* [n]   1 - T_final */
    float *emission; /* [n*3] composited emission E of the field (linear HDR, no background); lts
                        stage on, ignored by models without an emission field */
    float *emitted;  /* [n*3] composited emitted radiance: E times its light's strength scale
                        (model/lights.h; = emission for a model without lights), like emission.
                        A model with lights also adds emitted - emission to `linear` of
                        lights-on renders: the emitters at their calibrated strength */
    float *emitted_lights; /* [n*3] as emitted, from the samples on a light only (E elsewhere
                              is not a light's: none of it) */
    float *emitted_each_light;       /* [lights.n * n*3] emitted_lights of light K's samples
                                        only at K * n*3 (the lights' sum: emitted_lights) */
    float *emitted_value_each_light; /* [lights.n * n*3] the same with each sample's value V
                                        (model/lights.h) on every channel: what a recolour
                                        multiplies (edit/relight.h's layers) */
    float *material; /* [n*5] composited BRDF: base colour (3, linear), roughness, metallic (no
                        background: multiply out by opacity); lts stage on, like emission */
    /* The ray's first surface where it sees two (a silhouette against what lies behind it), for
     * shading each on its own (edit/relight): the kept samples from the first of weight above
     * ESR_FRONT_MIN_WEIGHT to ESR_FRONT_DEPTH_VOX voxels behind it (volume/composite.h
     * esr_composite_front). All three or none, with `material`: */
    float *front_opacity;  /* [n]   their weights' sum (opacity minus it: the rest of the ray) */
    float *front_depth;    /* [n]   their weights-normalised ray distance (0 where none) */
    float *front_material; /* [n*5] their composited BRDF, as `material` */
    int32_t *light_id; /* [n] the light (model/lights.h) at the ray's strongest kept sample, -1
                          where none (also for a model without lights) */
    float *linear_other; /* [n*3] `linear` of the other lighting (lights off for a lights-on
                            render and on for off), from the same march: both for one march */
    int lights_emitted_only; /* 1: in a lights-on radiance (`linear`, or `linear_other` of a
                                lights-off render), a sample on a light shows the lights-off
                                radiance plus its light's emitted radiance (edited when the
                                model's lights carry an edit) instead of L_emo + the emitted -
                                E: fine-tuning for an edit never trains L_emo there */
};

/* Whether a ray sees two surfaces, from its render's opacity a and depth and its first surface's
 * front_opacity a1 and front_depth d1 (esr_render_out): the rest of the ray holds more than
 * ESR_RENDER_LAYER_OPACITY at ESR_RENDER_LAYER_GAP_VOX voxels (of edge voxel) or more behind
 * the first surface. *d2 receives the rest's weights-normalised depth (0 when it holds none).
 * Direct relighting lights such a pixel as two layers (edit/relight.c); the lights' strength
 * solve leaves it out (train/lights/solve.c). */
#define ESR_RENDER_LAYER_OPACITY 0.05f
#define ESR_RENDER_LAYER_GAP_VOX 2.0f
static inline int esr_render_two_surfaces(float a, float depth, float a1, float d1, float voxel,
                                          float *d2)
{
    const float a2 = a - a1;
    *d2 = a2 > 0.0f ? (depth * a - d1 * a1) / a2 : 0.0f;
    return a1 > 0.0f && a2 > ESR_RENDER_LAYER_OPACITY && *d2 - d1 > ESR_RENDER_LAYER_GAP_VOX * voxel;
}

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
