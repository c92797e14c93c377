/* Coarse-stage SDF initialisation from the trained alphamask density (internal to src/train).
 * Starting NeuS from a sphere that encloses the object fails with a mask cache: inside the
 * mask the sphere's SDF is negative everywhere, the first masked sample is opaque with its alpha
 * clipped at 1, so no gradient ever moves the surface off the mask hull. Instead the voxels whose
 * density alpha exceeds a threshold are taken as "inside" and the SDF is their signed chamfer
 * distance (26-neighbour, two sweeps), in world units. */
#ifndef ESR_MODEL_SDF_INIT_H
#define ESR_MODEL_SDF_INIT_H

#include "model/model.h"

/* Fills m's SDF grid (coarse stage) from prev's density grid: inside = alpha(density at interval
 * step_vox) > alpha_thres. Returns ESR_OK and *used = 0 (SDF untouched) when nothing or
 * everything is inside. */
int esr_sdf_init_from_density(struct esr_model *m, const struct esr_model *prev, float alpha_thres,
                              int *used);

/* Fine stage: narrows m's mask cache (taken over from the alphamask stage) to the voxels whose
 * coarse SDF (prev, smoothed as the coarse renderer saw it) puts within band world units of the
 * surface, both by its value and by its first-order distance estimate |f| / |grad f|, so marching
 * skips both empty space and the solid interior. */
int esr_mask_narrow_to_sdf(struct esr_model *m, const struct esr_model *prev, float band);

#endif
