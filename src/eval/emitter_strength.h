/* How strongly each light emits, against the truth, in the terms that say what is wrong (issue
 * 48): whether the lights share one scale (the environment x albedo ambiguity lets every light be
 * off by the same factor) or differ from each other, and whether esr found the right number.
 *
 * Per true light K (eval/emitter_radiance.h scores its mean rendered emission):
 *   lum_ratio   = Y(mean) / Y(truth), Y the Rec. 709 luminance
 *   power       = sum over the evaluated views and over K's pixels of Y(rendered emission): the
 *                 image-space power (projected area in pixels x radiance), what a relight
 *                 multiplies. K's pixels: those the renders' light ids (N_lights.png) give to an
 *                 esr light that follows K (eval/light_split.h), so a found light too large or
 *                 too small counts as such; K's true mask where a view has no light ids
 *   truth_power = the same over K's true masks with Y(truth)
 *   power_ratio = power / truth_power
 * Summary over the lights with a lum_ratio:
 *   shared_scale   = geometric mean of the positive lum_ratios (a light found dark, ratio 0,
 *                    has no logarithm: it is left out of the mean and counted in `dark`)
 *   worst_relative = max over them of |lum_ratio / shared_scale - 1| (a dark light: 1) */
#ifndef ESR_EVAL_EMITTER_STRENGTH_H
#define ESR_EVAL_EMITTER_STRENGTH_H

#include <stdio.h>

#include "eval/emitter_radiance.h"
#include "eval/light_split.h"
#include "io/dataset.h"

struct cJSON;

struct esr_emitter_strength {
    int lights_true;       /* the dataset's lights */
    int lights_found;      /* esr's lights: the model's count (set by `esr eval` when the run has
                              one), else the distinct light ids of the N_lights.png renders; -1
                              unknown */
    const char *found_from; /* "model", "renders" or NULL (unknown) */
    int lights_wrong;      /* esr lights of the renders that follow no true light (a reflection
                              counted as a light); -1 unknown */
    int scored;            /* lights with a lum_ratio */
    int dark;              /* of them, found with no light (lum_ratio 0) */
    double shared_scale;   /* NAN when no light has a positive lum_ratio */
    double worst_relative; /* NAN when shared_scale is */
    int worst_light;       /* the dataset light of worst_relative, -1 when none */
    int power_views;       /* views whose power came from the renders' light ids */
};

/* Y(found) / Y(truth); NAN when the truth has no luminance or found is not finite. */
double esr_emitter_luminance_ratio(const double found[3], const double truth[3]);

/* The summary of n luminance ratios (entries NAN: not scored, skipped) of dataset lights
 * light[0..n) (NULL: 0..n-1) into out's scored, dark, shared_scale, worst_relative, worst_light;
 * the other fields are left as they are. */
void esr_emitter_strength_summarise(const double *ratio, const int *light, int n,
                                    struct esr_emitter_strength *out);

/* The power of each light of rad (scored by esr_emitter_radiance_eval over the same frames), the
 * light counts and the summary, from the renders in render_dir and split (its dataset_light;
 * views 0: no light ids). */
int esr_emitter_strength_eval(const struct esr_dataset *ds, enum esr_phase_id phase,
                              const int *idx, int n, const char *render_dir,
                              const struct esr_light_split *split,
                              struct esr_emitter_radiance_result *rad,
                              struct esr_emitter_strength *out);

/* Adds "emitter_strength": {"shared_scale", "worst_relative", "worst_light", "lights_found",
 * "lights_found_from", "lights_wrong", "lights_true", "lights_scored", "lights_dark",
 * "power": definition} to root (null for NAN / unknown). */
void esr_emitter_strength_add_json(struct cJSON *root, const struct esr_emitter_strength *s);
/* Adds a light's "eroded", "mask_pixels", "luminance_ratio", "power", "truth_power" and
 * "power_ratio" to its emitter_radiance entry. */
void esr_emitter_strength_add_light_json(struct cJSON *obj, const struct esr_emitter_radiance *r);

/* The per-light table and the summary line for report.html. */
void esr_emitter_strength_put_html(FILE *out, const struct esr_emitter_radiance_result *rad,
                                   const struct esr_emitter_strength *s);
/* The summary for the terminal, one line per light and one for the scene. */
void esr_emitter_strength_print(FILE *out, const struct esr_emitter_radiance_result *rad,
                                const struct esr_emitter_strength *s);

#endif
