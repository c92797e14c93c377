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

/* The lights-off training rays the level is measured on: origins, directions and the photos'
 * pixels (sRGB composited on white, as the ray set holds them), n of each. */
struct esr_env_init_rays {
    const float *orig3, *dir3, *rgb3;
    size_t n;
};

/* The level per channel (and the mean surface radiance it came from), on rays picked at random
 * with seed. from_photos 0: the surfaces' radiance as model prev renders it on 8192 rays, a
 * partly transparent ray's divided by its opacity (the render's biases come with it: an edge
 * ray's own radiance is overestimated, and the fine model renders a little brighter than the
 * photos; both moved with the image resolution, 100 to 400 px: +21%). from_photos 1: the photos'
 * own pixels, made linear, over the 65536 rays prev renders opaque (opacity > 0.99): what the
 * photos say, with prev only deciding which rays see a surface. ESR_ERR when no ray sees one. */
int esr_env_init_level(const struct esr_model *prev, const struct esr_env_init_rays *rays,
                       uint64_t seed, int from_photos, float level[3], float surface_mean[3]);

#endif
