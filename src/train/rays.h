/* All training rays of a dataset phase, computed once before training (structure of arrays):
 * origins, unit directions and target colours composited on white, lights-off frames first so
 * rays [0, n_off) are lights-off and [n_off, n) lights-on. */
#ifndef ESR_TRAIN_RAYS_H
#define ESR_TRAIN_RAYS_H

#include <stddef.h>
#include <stdint.h>

#include "io/dataset.h"

struct esr_ray_set {
    size_t n, n_off;
    float *orig3, *dir3, *rgb3; /* [n * 3] each */
    int transparent;            /* some image has alpha < 1 somewhere (renders, masked photos) */
};

/* Loads every frame of `phase` (its PNG composited on white) and its pixel-centre rays; refuses,
 * before loading anything, a set that does not fit in memory (core/limits.h). */
int esr_ray_set_build(struct esr_ray_set *rs, const struct esr_dataset *ds, enum esr_phase_id phase);
/* Bytes a set of n_rays rays holds. */
size_t esr_ray_set_bytes(size_t n_rays);
void esr_ray_set_free(struct esr_ray_set *rs);

/* Draws a batch of n rays for iteration `step`, stratified by lighting: the off/on split follows
 * the set's proportion (at least one of each when the set has both), ray i of the batch is a pure
 * function of (seed, step, i). Writes origins/dirs/targets [n*3] and lights_on[n] (1 = a
 * lights-on ray). */
void esr_ray_set_draw(const struct esr_ray_set *rs, uint64_t seed, long step, int n, float *orig3,
                      float *dir3, float *rgb3, uint8_t *lights_on);

#endif
