/* The environment map's starting brightness (lts stage). Images composited on white never show
 * the environment, and they fix only the product of albedo and light: a map twice as bright
 * with surfaces half as bright renders the same lights-off images. Where training starts decides
 * where it ends (lamp: started at the old ln 2 ~ 0.69 the map converged 5x too bright, the
 * albedo 5x too dark, and every light calibrated 2-3x too strong; started at 0.2 the map came
 * out within 1.5x of the truth). So the map starts at the level a mid-grey world would need:
 *     level = mean lights-off radiance of the surfaces the training cameras see / ENV_INIT_AV
 *     ENV_INIT_AV = 0.3 = albedo 0.5 x 0.6 of the sky visible on average
 * measured with the previous (fine) stage's model on lights-off training rays. */
#ifndef ESR_TRAIN_ENV_INIT_H
#define ESR_TRAIN_ENV_INIT_H

#include <stddef.h>
#include <stdint.h>

#include "model/model.h"

#define ESR_ENV_INIT_AV 0.3f

/* The level (and the mean surface radiance it came from) measured with model prev on up to 8192
 * of the n lights-off rays (orig3/dir3), picked at random with seed. ESR_ERR when no ray sees a
 * surface. */
int esr_env_init_level(const struct esr_model *prev, const float *orig3, const float *dir3,
                       size_t n, uint64_t seed, float *level, float *surface_mean);

#endif
