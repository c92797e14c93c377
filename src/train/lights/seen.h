/* Which surface the training views see (train/lights/find.c grows a light over what they do not):
 * the surface area the views show round each SDF lattice point, foreshortened and summed over
 * the views, a measure that does not depend on how many pixels the images have. */
#ifndef ESR_TRAIN_LIGHT_SEEN_H
#define ESR_TRAIN_LIGHT_SEEN_H

#include <stddef.h>
#include <stdint.h>

#include "fields/grid.h"
#include "train/rays.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The width across ray r of rs of the surface its pixel covers at ray parameter t: the distance
 * there to the nearer of its two neighbours in the set at the same t (t times the pixel's angle
 * for a pinhole camera, the spacing of parallel rays). A set holds each image's pixel-centre
 * rays row after row (train/rays.h), so the nearer neighbour is in the row. 0 for a set of one
 * ray. */
float esr_seen_footprint(const struct esr_ray_set *rs, size_t r, float t);

/* The first hit of every ray of rs on sdf (on grid g), each standing for its footprint's square,
 * added to area[] at the lattice point nearest the hit, and also to area_clearly[] (may be NULL)
 * for the rays clearly(rs, r) says see clearly. Both arrays hold esr_grid_voxels(g) floats,
 * zeroed by the caller. */
int esr_seen_area(const struct esr_grid *g, const float *sdf, const struct esr_ray_set *rs,
                  int (*clearly)(const struct esr_ray_set *rs, size_t r), float *area,
                  float *area_clearly);

/* seen[i] = 1 where the area within lattice point i and its 26 neighbours reaches need (need 0:
 * where it is above 0, some ray's hit: the default, lights_seen_area 0). At lights_seen_area 2
 * cell faces h^2 a point is seen where the views show 2 of the about 9 a flat surface has round
 * it, as one view showing it at 13 degrees from grazing, or a fifth of it head-on. A lower bar
 * counts single hits again where pixels are large (at 0.5 a 50 px and a 200 px view of a steep
 * plane mark 3.4% apart, at 2 1%; test_train_lights_seen). */
void esr_seen_marks(const struct esr_grid *g, const float *area, float need, uint8_t *seen);

#ifdef __cplusplus
}
#endif

#endif
