/* Relighting by radiance fine-tuning (the paper's main method, METHOD.md "Scene editing", the
 * seed's Tables 4 and 6): for one edit of the lights, everything but the emo feature grid and the
 * emo radiance MLP is frozen and L_emo is trained towards the LTS estimate of the edited scene
 * (edit/finetune_loss.h), so the lights-on render L_off + L_emo shows the edit with its reflections
 * and interreflections at the data-fitted L_emo's detail.
 *
 * Choices, each for a user who edits several lights and views:
 * - The edited emission itself is rendered analytically (the model's lights carry the edit while
 *   it is in place, model/lights.h), and the fields learn only the change of the reflected light.
 * - The edited lights' light comes in by light sampling (train/lights/direct.h: area samples and
 *   shadow rays with exactly the edited emission); interreflections from the fields along
 *   first-hit incident directions that do not end on a light. A small bright light is thus not
 *   left to the few hemisphere directions that happen to hit it (blotchy, dark results).
 * - The target is the trained L_emo scaled by the ratio of the transport's estimates with and
 *   without the edit (edit/finetune_loss.h says why): an edit that changes nothing changes nothing, and
 *   the light the reconstruction cannot attribute follows the lights in proportion.
 * - Points: surface samples of the training cameras' rays, all of them, not only those on the
 *   edited light (the authors' rays on the edited light's mask): the light the edit changes
 *   falls on every surface, and a point whose L_emo is not trained keeps the old lighting.
 * - The estimate is a fixed target each step (a fixed-point iteration of the edited transport).
 * - Many points per step and a few hundred steps: one fine-tune per distinct edit, reused by
 *   every view that shows it (the authors fine-tune 20,000 iterations per test image).
 * esr_finetune_restore puts the trained model back. */
#ifndef ESR_EDIT_FINETUNE_H
#define ESR_EDIT_FINETUNE_H

#include <stddef.h>
#include <stdint.h>

#include "edit/finetune_loss.h"
#include "io/dataset.h"
#include "model/model.h"
#include "train/lights/direct.h"
#include "train/lights/lights.h"
#include "train/lts.h"
#include "train/rays.h"
#include "volume/march.h"

#ifdef __cplusplus
extern "C" {
#endif

struct esr_finetune_opts {
    int iters;       /* Adam steps per edit */
    int rays;        /* primary rays per step (their surface samples are the points) */
    int points;      /* LTS points per step */
    int dirs;        /* incident directions per point */
    int light_spp;   /* area samples per point and light for the direct light */
    float lr_feat;   /* emo feature grid (sparse Adam), cosine-decayed to lr_final x */
    float lr_mlp;    /* emo radiance MLP */
    float lr_final;
};

void esr_finetune_default_opts(struct esr_finetune_opts *o);

struct esr_finetune_stats {
    int iters;
    double mse_first, mse_last; /* LTS emo MSE (sRGB-slope weighted) of the first and the last
                                   10% of the steps */
    double seconds;
};

struct esr_finetune {
    struct esr_finetune_opts o;
    struct esr_ray_set rays;       /* the training cameras' rays */
    float *trained_w;              /* every weight of the trained model (a copy) */
    float *trained_moments;        /* the tuned components' Adam moments as trained (m then v
                                      of each, in order): an edit starts them afresh */
    struct esr_model trained;      /* the trained model: m's description with trained_w */
    struct esr_march march;
    struct esr_lts lts;
    struct esr_finetune_loss loss; /* the LTS's loss while an edit is tuned (its hook) */
    struct esr_lts_loss_hook hook;
    struct esr_light_samples samples[ESR_MAX_LIGHTS]; /* calibrated emission */
    struct esr_light_shadows shadows; /* the frozen SDF, prepared once for the shadow rays */
    double *direct, *found;        /* [points * 2 * ESR_MAX_LIGHTS * 3] edited, as found */
    const struct esr_model *m;     /* for the LTS hook */
    uint64_t seed;
    long step;                     /* the light samples are a function of (seed, step) */
    float *g_sdf;                  /* SDF gradient the LTS adds into and nothing reads (the
                                      geometry is frozen); zeroed once */
    float *orig3, *dir3, *rgb3;    /* [rays * 3] */
    uint8_t *on;                   /* [rays] */
    int applied;                   /* an edit is in the model */
};

/* Workspace for fine-tuning model m (a finished pdra model with lights) on the training cameras
 * of ds. m must stay the same model until esr_finetune_free. */
int esr_finetune_init(struct esr_finetune *f, struct esr_model *m, const struct esr_dataset *ds,
                      const struct esr_finetune_opts *o);
void esr_finetune_free(struct esr_finetune *f);

/* Puts the trained model back, then fine-tunes its L_emo for edits (one per light of m) and puts
 * the edit in m's lights: lights-on renders of m now show the edit. Deterministic in seed for a
 * fixed thread count. */
int esr_finetune_apply(struct esr_finetune *f, struct esr_model *m,
                       const struct esr_light_edit *edits, uint64_t seed,
                       struct esr_finetune_stats *st);

/* The fine-tune's start (esr_finetune_apply calls it): the emo MLP's output biases shifted by
 * ln rho_c, rho_c = sum_K area_K E'_K,c / sum_K area_K E_K,c, the ratio of the lights' emitted
 * power per channel under the edit (kept within [1e-3, 1e3]; 1 for a channel no light emits).
 * Why: L_emo = softplus(z), and most of a lit scene's L_emo sits where softplus(z) ~ e^z
 * (floor radiance 0.05-1: z from -3 to 0.5), so the shift scales it by about rho, the change
 * the edit makes on average; Adam then only learns how it varies between the lights' regions
 * (lamp test_nvc: +0.3 dB at 300 steps; the steps alone gain that only at 900). rho (or
 * NULL) receives the ratio. */
void esr_finetune_start(struct esr_model *m, const struct esr_light_edit *edits, float rho[3]);

/* The trained model back, weights and Adam moments (no-op when no edit is applied). */
void esr_finetune_restore(struct esr_finetune *f, struct esr_model *m);

#ifdef __cplusplus
}
#endif
#endif
