/* Relighting by direct illumination (the seed's "direct" method, Tables 5 and 7; absent from the
 * authors' code): a view with every light edited is
 *     L(x) = L_off(x) + sum_K sum over light K's surface of E'_K(y) R(x, wo, wi) |n_y . wi| / d^2 dA
 *            + the lights' edited emission as the camera sees it (each sample on a light
 *              composites its light's edited emission: a pixel on a light's edge shows it in
 *              proportion)
 * with L_off the lights-off radiance field, R the reconstructed BRDF (cosine included) at the
 * camera ray's surface point x (its expected depth; where the ray sees two surfaces, an object's
 * silhouette against what lies behind it, each is lit at its own point with its own BRDF and
 * weighted by its opacity), y area-sampled over light K's surface
 * samples (train/lights/lights.h) with a shadow ray to each (first hit of the SDF before y: occluded),
 * and E'_K = the light's calibrated emission times its intensity, recoloured to the edit's hue and
 * saturation with V kept (seed eqs. 10-15). Light reaching x only after a bounce is left out
 * (what the method is), so it reaches any colour, including ones never seen in training.
 *
 * The ratio method (esr's own) keeps what the model learned of the lights-on scene instead: at
 * a pixel that sees no light,
 *     L(x) = L_off(x) + emitted'(x) + (L_on(x) - L_off(x) - emitted(x)) (D'(x) + f mean D') /
 *                                                                       (D(x) + f mean D)
 * per channel (emitted, emitted': the lights' composited emission as found and edited; what is
 * left of L_on - L_off is reflected light), with D' and D the direct light above with the edited
 * and the found emission (the same samples and shadow rays), the means over the view's surface,
 * f = 0.1. Unedited it
 * is the model's own lights-on render; the strength calibration's error cancels in the ratio
 * (only the lights' relative strengths matter), and light after bounces follows the edit as
 * the direct light at the pixel does. A pixel that sees a light renders as in direct.
 *
 * The model mode is how a fine-tuned model (edit/finetune.h) is rendered: the model's own
 * lights-on radiance (each sample on a light as the lights-off radiance plus its light's edited
 * emission), and a pixel that sees a light as in direct. Fine-tuning leaves the points on a light
 * out (their L_emo is the saturated emitter), so without the direct light a light's surface
 * would show none of the other lights' light: a blue lampshade under a yellow bulb at twice its
 * strength is white in the truth where the bulb lights it. */
#ifndef ESR_EDIT_RELIGHT_H
#define ESR_EDIT_RELIGHT_H

#include <stdint.h>

#include "io/camera.h"
#include "io/image.h"
#include "model/model.h"
#include "train/lights/direct.h"
#include "train/lights/lights.h"

#ifdef __cplusplus
extern "C" {
#endif

enum esr_relight_mode {
    ESR_RELIGHT_DIRECT, /* lights-off radiance + the edited lights' direct light */
    ESR_RELIGHT_RATIO,  /* the model's reflected light times the edited over the found direct light */
    ESR_RELIGHT_MODEL,  /* the model's lights-on radiance; direct where a pixel sees a light */
};

/* What a relight needs once per model: each light's surface samples, the smoothed SDF for
 * normals, the SDF prepared for shadow rays (its global bound: a pass over the grid). */
struct esr_relight {
    int n_lights;
    struct esr_light_samples samples[ESR_MAX_LIGHTS];
    int spp;            /* light samples per pixel and light */
    int mode;           /* enum esr_relight_mode */
    float *normal_sdf;  /* the smoothed SDF the normals come from (model/render_sdf.h), once */
    struct esr_light_shadows shadows; /* the SDF as shadow rays march it, prepared once */
};

int esr_relight_init(struct esr_relight *r, const struct esr_model *m, int spp,
                     enum esr_relight_mode mode);
void esr_relight_free(struct esr_relight *r);

/* What a view's direct light cost (esr bench reports it). */
struct esr_relight_stats {
    size_t shadow_rays;    /* shadow rays traced */
    double direct_seconds; /* the direct light's pass: sampling, shadow rays, BRDF */
};

/* The edited view of cam: linear RGB on white into *out (allocated, 3 channels). edits has one
 * entry per light of m. Deterministic in seed. stats: NULL, or filled. */
int esr_relight_view(const struct esr_relight *r, const struct esr_model *m,
                     const struct esr_light_edit *edits, const struct esr_camera *cam,
                     uint64_t seed, struct esr_image *out, struct esr_relight_stats *stats);

/* A view as light groups (`esr lightmix`): the lights-off layer and, per light, its layer at its
 * found emission (its visible emission and the light it casts: direct, or in the ratio method
 * its share of the reflected light) and its layer at unit colour times each emitting point's
 * value V (what a recolour multiplies, model/lights.h). Both methods are linear in each light's
 * emission, and each light's samples draw from their own stream, so an edit of the view is
 *     off + sum_K w_K * (recolour_K ? value_K : light_K)     (w_K: esr_light_edit_weights)
 * to float rounding (esr_relight_layers_mix); unedited, off plus every light_K. */
struct esr_relight_layers {
    int n_lights;
    struct esr_image off;                   /* linear RGB on white, 3 channels */
    struct esr_image light[ESR_MAX_LIGHTS]; /* [n_lights] */
    struct esr_image value[ESR_MAX_LIGHTS]; /* [n_lights] */
};

/* The layers of cam's view (direct or ratio mode; allocated), with the seed esr_relight_view
 * takes for the same view. */
int esr_relight_layers(const struct esr_relight *r, const struct esr_model *m,
                       const struct esr_camera *cam, uint64_t seed, struct esr_relight_layers *L,
                       struct esr_relight_stats *stats);
void esr_relight_layers_free(struct esr_relight_layers *L);
/* The edited view the layers give (one edit per light; checked): into *out (allocated). */
int esr_relight_layers_mix(const struct esr_relight_layers *L, const struct esr_light_edit *edits,
                           struct esr_image *out);

#ifdef __cplusplus
}
#endif
#endif
