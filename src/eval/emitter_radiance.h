/* Emitted radiance per light against the truth (issue: "every light's emitted radiance within
 * 15% of the truth"): for each light K that scene.json lists with its emitted radiance, the mean
 * of the rendered composited emission N_emission.exr over the pixels of K's ground-truth mask
 * (the frames' lights[K].mask_path), pooled over the evaluated views that have both. The mask is
 * eroded by one pixel first: a boundary pixel's composite mixes the emitter with what is beside
 * it (the true mask is a first-hit mask of the pixel centre).
 *   error_pct = 100 |mean - truth| / |truth|   (RGB vectors)
 *   ratio     = |mean| / |truth|               (how much of the light's strength was found)
 * No light is left out: one whose eroded mask is empty in every view (a light a few pixels
 * across) is scored on its whole mask and flagged (eroded = 0); one no evaluated view shows has
 * pixels 0 and NAN scores. eval/emitter_strength.h adds the luminance ratio and the power. */
#ifndef ESR_EVAL_EMITTER_RADIANCE_H
#define ESR_EVAL_EMITTER_RADIANCE_H

#include "io/dataset.h"

struct esr_emitter_radiance {
    int light;
    char name[64];
    long pixels;           /* mask pixels counted (after erosion when eroded, else the whole mask) */
    int eroded;            /* 1: scored on the eroded mask; 0: that was empty, on the whole mask */
    long mask_pixels;      /* the whole mask's pixels over the views */
    double mean[3], truth[3];
    double error_pct, ratio;
    double lum_ratio;      /* luminance of mean over that of truth (eval/emitter_strength.h) */
    double power, truth_power, power_ratio; /* image-space power, found and true (NAN: not scored) */
};

struct esr_emitter_radiance_result {
    int n;                 /* lights scored: every true light once an emission image is read (0: no
                              truth or no emission images) */
    struct esr_emitter_radiance lights[ESR_MAX_TRUE_LIGHTS];
};

/* Scores the frames idx[0..n) of `phase` with their renders in render_dir. */
int esr_emitter_radiance_eval(const struct esr_dataset *ds, enum esr_phase_id phase, const int *idx,
                              int n, const char *render_dir, struct esr_emitter_radiance_result *out);

#endif
