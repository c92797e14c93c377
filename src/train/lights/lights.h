/* Lights as objects (after the pdra stage): which surfaces emit, split into separate lights, and
 * how strongly each emits (model/lights.h holds the result).
 *
 * Finding: the SDF lattice points next to the zero level set (a sign change to an axis
 * neighbour), outside the space the renderer skips (model/render_sdf.h), are projected onto
 * the surface; E is evaluated there, and a point emits when any
 * channel of E exceeds the emitter threshold k (the pdra stage's final k) and the point is on the
 * outer surface (the cameras' free space touches it from outside). Emitting points are
 * split into 26-connected components; components below LIGHTS_MIN_SHARE of the emitting points
 * (or LIGHTS_MIN_POINTS) are noise and dropped; the rest, largest first, are the lights. Each
 * light then grows over its unseen part: outer surface points 26-connected to it that no
 * training ray's first hit reaches (within a lattice point), such as a lampshade's bottom that
 * the SDF closes and no camera looks up at. They are labelled ESR_LIGHT_UNSEEN and emit the
 * light's mean field E (their own E learned only from the light they cast, which clipped images
 * understate); the light's area, points, centroid and power count them (it emits over all of
 * its surface), its mean field E only the part found emitting. Next to that, each light has an
 * undecided rim (ESR_LIGHT_UNDECIDED): outer surface points one lattice point from it that some
 * ray reaches, but only lights-off rays (which show no emission) or lights-on rays whose photo is
 * clipped white (which any emitter, or the floor beside a strong one, shows): a rounded
 * lampshade's lower edge, which only grazing rays touch. Whether it emits is the calibration's
 * to decide (below), and it then joins the light's unseen part or leaves it.
 *
 * Strength: the emission field learns from LDR images, where every emitter is clipped to white,
 * so E comes out near 1 whatever the true strength. What does pin the strength is the light the
 * emitters cast on the rest of the scene: at a non-emitting surface point x the emo radiance the
 * images show must equal what the lights and the other surfaces send there,
 *     L_emo(x, wo) = sum_K s_K . A_K(x) + B(x)   (per channel)
 *     A_K(x) = the light that light K's field E sends to x: area samples over K's surface (64 per
 *              point), E(y) R(x, wo, wi) |n_y . wi| dA / d^2, a shadow ray to each
 *     B(x)   = the other incident emo radiance (other surfaces, the lights' own reflected part
 *              L_emo(y) - E(y)), from CALIB_DIRS hemisphere directions (cosine-weighted;
 *              with the lobe directions of the model's stage, pdra.lobe_dirs for a pdra model,
 *              some from the BRDF's lobe) and their first hits
 * (seed eq. 4 with the trained BRDF; sampling the lights by area, not by direction, keeps A
 * nearly noise-free, and noise in A would bias a small light's least-squares scale towards 0).
 * The scales s_K come from least squares over calib_points points seen by the lights-off
 * training cameras, per channel, A and B times (unless correct_base is 0, below) the point's
 * lights-off correction of its base
 * colour, L_off / L^_off (the trained lights-off radiance over its LTS estimate; base colour
 * next to a light absorbed some of the light it casts), over that ratio's median (the estimate
 * runs 15-30% above L_off everywhere), each row weighted as an image would weigh its error (the sRGB
 * curve's slope at the point's lights-on radiance, core/colour.h esr_image_error_scale: a dim
 * floor far from the lights counts as much in a relit image as a bright one beside them; lamp's
 * lampshade 40% -> 23% off, the default scene's 88% -> 68%), with a small ridge towards 1 so
 * that a light no point sees keeps its field strength, and no scale below 0 (a light solved
 * negative is set to 0 and the others solved again), made robust by Huber reweighting (points
 * the BRDF cannot explain, a mirror's reflection, pull with a bounded force). A light under
 * ESR_LIGHTS_SMALL_SHARE of the lights' area is not fitted but takes the fitted lights' mean scale,
 * at which its light enters the fit (esr_lights_fitted, esr_lights_share_scale,
 * esr_lights_fit_columns). A light's undecided rim joins it when the fit with its light
 * explains the rows clearly better (train/lights/fit.h, esr_calib_decide_rims): both scenes'
 * lampshades gain the outer ring of the bottom the SDF closes (a closed shade's bottom emits,
 * and so, seen from below, does an open one's inside), while the rim of floor and sphere around
 * the default scene's orb, and lamp's bulb's, stay dark. Caveat: images fix the product of albedo
 * and light, so s_K is only as right as the reconstructed base colour (see docs); its colour is
 * set right afterwards by the lights' silhouettes (esr_lights_balance, below). */
#ifndef ESR_TRAIN_LIGHTS_H
#define ESR_TRAIN_LIGHTS_H

#include <stddef.h>
#include <stdint.h>

#include "model/model.h"
#include "train/rays.h"

#ifdef __cplusplus
extern "C" {
#endif


/* The lights, start to end: the one entry point training and `esr lights` call. */
struct esr_lights_estimate_opts {
    int find;         /* 1: find them anew (esr_lights_find); 0: keep m's lights (after --drop) */
    int correct_base; /* as esr_lights_calibrate's */
    int balance;      /* 1: settle the rims' report and the colour balance (esr_lights_balance);
                         0: calibrate only (pdra's hand-over to its light transport) */
    uint64_t seed;    /* the calibration's */
};
#define ESR_LIGHTS_REPORT_LINES (2 * ESR_MAX_LIGHTS + 8)
/* What happened, as lines for a log or a terminal (warning[i]: line i is a warning). */
struct esr_lights_report {
    int n;
    int warning[ESR_LIGHTS_REPORT_LINES];
    char line[ESR_LIGHTS_REPORT_LINES][400];
};
/* Finds (o->find) the lights of m from the training rays rs, calibrates their strength
 * (m->cfg.lights_calib_points lights-off rays), then (o->balance) says each decided rim and
 * balances their colour by their silhouettes in the lights-on photos. Fails on a ray set without
 * lights-off rays. */
int esr_lights_estimate(struct esr_model *m, const struct esr_ray_set *rs,
                        const struct esr_lights_estimate_opts *o, struct esr_lights_report *rep);

/* Labels the emitting surface of m into lights (m->lights, replacing any), scales 1. Only the
 * outer surface counts: points that the free space seen along the cameras' rays (orig3/dir3
 * [n_rays*3], volume/free_space.h) touches from outside; the emission field is unconstrained on
 * surfaces no camera looks at (inside solids, under a floor), and they would cast no light. */
int esr_lights_find(struct esr_model *m, const struct esr_ray_set *rs);
/* Settles the lights' undecided rims (ESR_LIGHT_UNDECIDED): light K's joins it as unseen
 * surface when emits[K], else leaves it; then, when there was any, measures the lights' points,
 * centroid, area and power again. */
int esr_lights_settle(struct esr_model *m, const int emits[ESR_MAX_LIGHTS]);

/* Calibrates the strength of m's lights from calib_points surface points of the lights-off rays
 * (orig3/dir3 [n*3]; rays drawn at random, seeded). Sets scale, radiance, power, calib_points;
 * on failure (n 0, out of memory) the lights are left as they were. When no point away from the
 * lights is lit by them (esr_lights_uncalibrated), each keeps its field's strength.
 * correct_base 1: each point's direct light is multiplied by its base colour's lights-off
 * correction (L_off / L^_off over its median), the strengths a user gets; 0: the BRDF is taken
 * as it stands, the strengths it explains the light with (what pdra's light transport is given
 * part way through the stage, pdra.lights_at: the rest of the stage then trains the BRDF to
 * them, see docs/design.md). */
int esr_lights_calibrate(struct esr_model *m, const float *orig3, const float *dir3, size_t n,
                         int calib_points, uint64_t seed, int correct_base);
/* 1 when the last calibration fitted no light on any point (see esr_lights_calibrate), which the
 * trainer and `esr lights` say in these words. */
int esr_lights_uncalibrated(const struct esr_lights *L);
#define ESR_LIGHTS_UNCALIBRATED_TEXT                                                              \
    "no lit surface point away from the lights could calibrate their strength: each keeps its "  \
    "field's (clipped, too weak) strength"

/* What esr_lights_balance measured. */
struct esr_lights_balance_info {
    float applied[3];                     /* the balance this call applied (1 1 1: none) */
    int used;                             /* lights whose silhouettes voted */
    long rows[ESR_MAX_LIGHTS];            /* each light's silhouette pixels (0: not measured) */
    float silhouette[ESR_MAX_LIGHTS][3];  /* the scale its silhouette implies, per channel */
};
/* The lights' colour from their own silhouettes. The images fix only the product of base colour
 * and light per channel, so the calibrated lights take the colour of the environment map's start
 * (the grey-world guess, train/env_init.h): under a blue sky every light comes out too red. The
 * lights-on photos hold one more clue: where a light covers part of a pixel against a dark
 * surface (its silhouette), the pixel is not clipped and shows the light's own colour, mixed
 * with what lies behind it. Over the lights-on rays of the training set rs (its photos' sRGB)
 * whose composited light field (scale 1) g_K reaches BALANCE_MIN_FIELD and whose photo is
 * unclipped, photo - rest = c_K g_K per channel by least squares, rest being the render with
 * light K dark and the others at their scales. The magnitude of c_K is not trusted (the
 * reconstructed silhouette is a voxel wide, a pixel's coverage is not), its colour is: for every
 * fitted light with BALANCE_MIN_ROWS such pixels, log(s_K / c_K) less its mean over channels is
 * the calibration's colour error; their mean weighted by pixels, b, is one error shared by all
 * lights (the base colour's and the map's). The lights' scales are divided by b and the
 * balance (model/lights.h) multiplied by it: base colour x b, map / b, so the lights-off
 * radiance the model explains and the light the lights cast on the scene (base colour x
 * strength) stay as calibrated. The default scene: lampshade and orb silhouettes (1.18, 0.93,
 * 0.63) and (0.27, 0.65, 1.39) against true colours 8 : 6.4 : 4.4 and 2.4 : 6 : 12. A light
 * too small to fit has no colour of its own and does not vote. Renders the rays through each
 * fitted light's box twice (its labelled points' box grown by 2 voxels), in batches; the lights'
 * scales are restored when it fails. info may not be NULL. */
int esr_lights_balance(struct esr_model *m, const struct esr_ray_set *rs,
                       struct esr_lights_balance_info *info);
/* One line on what esr_lights_balance did (logs, `esr lights`). */
void esr_lights_balance_text(const struct esr_model *m, const struct esr_lights_balance_info *info,
                             char *out, size_t size);
/* The balance b [3] from n lights' silhouette scales sil, calibrated scales and silhouette pixel
 * counts (see esr_lights_balance); returns the lights that voted (0: b = 1 1 1). */
int esr_lights_balance_solve(int n, const float sil[][3], const float scale[][3], const long rows[],
                             float b[3]);
/* The lights the calibration fits (ids into fit[], their count returned): those of at least
 * ESR_LIGHTS_SMALL_SHARE of all the lights' area. A smaller one casts little light from a few
 * close area samples, so a shortfall spread over the scene (light after several bounces, a
 * light's part no camera sees) can be loaded onto it at hundreds of times its field (lamp: a
 * mirror sphere's reflection of the lampshade, area 0.011 of 0.88, came out at 323x, fitted over
 * the whole floor). */
#define ESR_LIGHTS_SMALL_SHARE 0.05
/* How the trainer and `esr lights` say that lights were left out (esr_lights.n_left_out, then
 * ESR_MAX_LIGHTS). */
#define ESR_LIGHTS_LEFT_OUT_FMT "%d more emitting region(s) left out: esr keeps the %d largest as lights"
/* How listings and logs say a light's scale was borrowed. */
#define ESR_LIGHT_BORROWED_TEXT "too small to fit: the fitted lights' area-weighted mean"
int esr_lights_fitted(const struct esr_lights *L, int *fit);
/* 1 when light id is one esr_lights_fitted fits, 0 when its scale is borrowed (listings mark it:
 * a small lamp, or a mirror's reflection of a light that the images cannot tell from one). */
int esr_light_strength_fitted(const struct esr_lights *L, int id);

/* Gives every light esr_lights_fitted leaves out the fitted lights' area-weighted mean scale in
 * channel c (1 when none is fitted): the images clip every light alike, so that mean is the best
 * guess of its exposure. */
void esr_lights_share_scale(struct esr_lights *L, int c);
/* One calibration row's columns, one per fitted light (fit [nf] from esr_lights_fitted): light
 * fit[f]'s a[fit[f]] plus its area share among the fitted lights times the lights left out's
 * sum of a (a [L->n], each light's contribution at scale 1). A light left out takes that
 * area-weighted mean scale (esr_lights_share_scale), so its light counts in the fit at the
 * scale it will have; left out of the fit, it was counted twice: once in the fitted lights'
 * scales, which absorbed it, and again at the borrowed scale. */
void esr_lights_fit_columns(const struct esr_lights *L, const int *fit, int nf, const double *a,
                            double *cols);

#ifdef __cplusplus
}
#endif
#endif
