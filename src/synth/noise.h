#ifndef ESR_SYNTH_NOISE_H
#define ESR_SYNTH_NOISE_H

#include "core/vec3.h"

/* Fractal value noise at x (metres) in [0, 1]: four octaves of a hashed lattice, trilinear with
 * smoothstep weights, the finest cell period/8 wide, contrast-stretched into blotches. Unlike a checker or stripes it never repeats,
 * so a feature matcher (COLMAP's SIFT) finds each patch in one place only, as on real surfaces. */
float esr_synth_noise(struct esr_vec3 x, float period);

#endif
