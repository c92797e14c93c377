/* The lights' strengths solved from the lights-on photos themselves (train/lights/lights.h's last step,
 * cfg lights_solve).
 *
 * The inverse problem. A lights-on training pixel whose camera ray meets a surface point x shows
 *     y = L_off(x) + sum_K s_K . (T_K(x) + g_K(x))          per linear channel
 *     T_K(x) = light K's direct light at x at unit strength: its emission field E over its surface,
 *              area-sampled, through the model's BRDF at x and a shadow ray (train/lights/direct.h,
 *              the direct relight's kernel: what `esr edit --method direct` renders with)
 *     g_K(x) = light K's own emission field where the pixel sees the light (a silhouette pixel
 *              mixes it with what lies behind)
 * Known: y (the photo, sRGB decoded), L_off (the lights-off radiance field, which the lights-off
 * photos pin), T_K and g_K (the trained geometry, BRDF and emission field). Estimated: s_K, per
 * light and channel. Evidence: every unclipped pixel; a clipped channel says only y >= 1, a lower
 * bound (a hinge: it counts while the fit is below it). Solved non-negative (active set), robust
 * (Huber reweighting: a mirror's reflection of a light is light the direct transport does not
 * carry), each row weighted as an image weighs its error (the sRGB curve's slope).
 *
 * What the photos cannot tell apart, said instead of guessed: the BRDF's base colour and the
 * environment share one scale with the lights (a brighter map and a darker floor give the same
 * lights-off photos; the lights then scale with the floor): the strengths are in the units the
 * trained base colour gives. Two lights whose transports are proportional over the pixels (two
 * bulbs side by side lighting the same floor) are fixed only in their sum: their estimates come
 * out strongly anti-correlated, and both are flagged (esr_light.inseparable). A light no unclipped
 * pixel constrains keeps the bound the clipped ones give and is marked (bound_only). Light that
 * reaches x after a bounce is not modelled: it is absorbed into the strengths (a few percent in an
 * open scene, more inside a shade).
 *
 * Rows: lights_solve_rays lights-on training rays, stratified over the set; a ray whose pixel sees
 * two surfaces (a silhouette against what lies behind it), or no surface, is left out. */
#ifndef ESR_TRAIN_LIGHTS_SOLVE_H
#define ESR_TRAIN_LIGHTS_SOLVE_H

#include <stddef.h>
#include <stdint.h>

#include "model/model.h"
#include "train/rays.h"

#ifdef __cplusplus
extern "C" {
#endif

/* a pixel channel below this (linear; sRGB 0.9) is an exact row, at or above ESR_SOLVE_CLIPPED
 * (sRGB 254.5/255) a lower bound, in between left out (a render's anti-aliased edge of a clipped
 * light mixes clipped samples) */
#define ESR_SOLVE_EXACT 0.79f
#define ESR_SOLVE_CLIPPED 0.99f
/* two lights' estimates correlated below -this are told apart only in their sum */
#define ESR_SOLVE_INSEPARABLE 0.9
/* a light whose strength's relative standard error exceeds this (its strength within 3 of them
 * of 0) is not shown emitting by the photos: esr_lights_estimate drops it (lights_solve_drop) */
#define ESR_SOLVE_MAX_ERR (1.0 / 3.0)
/* a light with fewer exact rows than this that its transport reaches is bound_only */
#define ESR_SOLVE_MIN_ROWS 100
/* no light's solved radiance exceeds this in a channel (photo units: 1 = white); a light the
 * clipped rows lift there through a transport of almost nothing is held at it and marked
 * bound_only (an undertrained model's field that lights no pixel) */
#define ESR_SOLVE_MAX_RADIANCE 1e4f

struct esr_lights_solve_info {
    long rays;                  /* rays rendered */
    long rows, bound_rows;      /* exact rows and lower-bound rows (pixel channels) */
    long light_rows[ESR_MAX_LIGHTS]; /* exact rows light K's transport or emission reaches */
    double sigma[3];            /* the residuals' robust scale per channel */
    float correction[3];        /* the lights-off correction's median (1: none) */
    double seconds;
};

/* Solves m's lights' strengths (scale, radiance, power, calib_points, strength_err, inseparable,
 * bound_only) from the lights-on rays of rs; the lights' surface and labels are as found. On
 * failure the lights are left as they were. No lights, or no lights-on rays: nothing to do. */
int esr_lights_solve(struct esr_model *m, const struct esr_ray_set *rs, uint64_t seed,
                     struct esr_lights_solve_info *info);

/* The solve's rows: per channel c, row i's columns a[(i * 3 + c) * K + k] (weighted), target
 * y[i * 3 + c] (weighted) and kind[i * 3 + c] (0: left out, 1: exact, 2: lower bound y <= fit);
 * a2 (or NULL) a second, independent estimate of the same columns: the normal equations then take
 * a^T a2 (symmetrised) for a^T a, so that the columns' sampling noise does not bias the scales
 * towards 0 (errors in the variables), and the fit the mean of the two. */
struct esr_solve_rows {
    int K;
    size_t n;
    float *a, *a2, *y;
    uint8_t *kind;
};
/* The solve's fit on rows made up for the purpose (tests) and on the rendered ones. s[c][k]
 * starts the fit (a light no row reaches keeps it) and receives it; cov [3 * ESR_MAX_LIGHTS^2]
 * (or NULL) the estimates' covariance, channel c's entry (k, j) at c * ESR_MAX_LIGHTS^2 + k * K +
 * j; sigma [3] the residuals' robust scale. Returns 0, -1 when out of memory. */
int esr_lights_solve_fit(const struct esr_solve_rows *rows, double s[3][ESR_MAX_LIGHTS],
                         double *cov, double sigma[3]);

#ifdef __cplusplus
}
#endif
#endif
