/* The environment map's start (lts stage). Images composited on white never show the
 * environment, and they fix only the product of albedo and light, per channel: a map twice as
 * bright with surfaces half as bright renders the same lights-off images, and so does a bluer map
 * over yellower surfaces. Where training starts decides where it ends (lamp: started at the old
 * ln 2 ~ 0.69 the map converged 5x too bright, the albedo 5x too dark, and every light
 * calibrated 2-3x too strong; started at 0.2 the map came out within 1.5x of the truth; the
 * default scene's map, started grey under a blue sky, stayed grey, its surfaces came out 0.74x
 * their true base colour in red and 1.16x in blue, and its lights as much too red). So the map
 * starts where a scene that averages mid-grey would need it, per channel:
 *     level_c = mean lights-off radiance of the surfaces the training cameras see, channel c
 *               / ENV_INIT_AV
 *     ENV_INIT_AV = 0.3 = albedo 0.5 x 0.6 of the sky visible on average
 * measured with the previous (fine) stage's model on lights-off training rays. The grey-world
 * assumption is a camera's automatic white balance: on white-balanced photos the map starts
 * about grey. */
#ifndef ESR_TRAIN_ENV_INIT_H
#define ESR_TRAIN_ENV_INIT_H

#include <stddef.h>
#include <stdint.h>

#include "model/model.h"

#define ESR_ENV_INIT_AV 0.3f

/* The level per channel (and the mean surface radiance it came from) measured with model prev
 * on up to 8192 of the n lights-off rays (orig3/dir3), picked at random with seed. ESR_ERR when
 * no ray sees a surface. */
int esr_env_init_level(const struct esr_model *prev, const float *orig3, const float *dir3,
                       size_t n, uint64_t seed, float level[3], float surface_mean[3]);

#endif
