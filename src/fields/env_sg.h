/* The environment map of the lts/pdra stages (METHOD.md "Stages 4-5 in detail"): K spherical
 * Gaussians with a softplus on the sum, per RGB channel c,
 *     env_c(d) = softplus( sum_k mu_kc exp(|lambda_k| (d . xi_k / |xi_k| - 1)) )
 * for a unit direction d. The axes xi_k are stored unnormalised and normalised on every call
 * (the gradient goes through the normalisation); the sharpness enters as |lambda_k|.
 *
 * Parameters: one flat float range (normally a component of struct esr_nn_params), in seven
 * structure-of-arrays blocks of K floats each, block b holding entry b*K + k for lobe k:
 *     [ xi_x | xi_y | xi_z | lambda | mu_r | mu_g | mu_b ]           7K floats in all
 * (enum esr_env_sg_block; esr_env_sg_index gives the position). Blocks keep each quantity
 * contiguous so the per-lobe loops and Adam run on unit-stride data.
 *
 * Directions are in esr's world frame: +Z up (Blender world, ../shared/scenes/FORMAT.md; the
 * built-in scenes stand on a floor at z = 0). esr_env_sg_equirect maps row 0 to +Z.
 *
 * Backward passes are deterministic for any thread count without atomics: per-direction work
 * runs in parallel, and each thread then owns a range of lobes and sums its lobes' gradients
 * over the directions in direction order (see env_sg.c). */
#ifndef ESR_FIELDS_ENV_SG_H
#define ESR_FIELDS_ENV_SG_H

#include <stddef.h>
#include <stdint.h>

#include "core/simd.h"

#ifdef __cplusplus
extern "C" {
#endif

/* METHOD.md's lobe count. */
#define ESR_ENV_SG_LOBES 48
/* The kernels keep per-lobe data on the stack; lobe counts run 1..ESR_ENV_SG_MAX_LOBES. */
#define ESR_ENV_SG_MAX_LOBES 128

enum esr_env_sg_block {
    ESR_ENV_SG_XI_X,
    ESR_ENV_SG_XI_Y,
    ESR_ENV_SG_XI_Z,
    ESR_ENV_SG_LAMBDA,
    ESR_ENV_SG_MU_R,
    ESR_ENV_SG_MU_G,
    ESR_ENV_SG_MU_B,
    ESR_ENV_SG_BLOCKS /* 7 */
};

/* Position of lobe k's entry of block b in the flat array of a K-lobe map. */
ESR_INLINE size_t esr_env_sg_index(int lobes, enum esr_env_sg_block b, int k)
{
    return (size_t)b * (size_t)lobes + (size_t)k;
}

/* ESR_OK when 1 <= lobes <= ESR_ENV_SG_MAX_LOBES, else ESR_ERR with a message. Every other
 * function below expects a lobe count that passes this check. */
int esr_env_sg_check_lobes(int lobes);
/* Number of floats of a K-lobe map: 7K (0 when the lobe count fails the check). */
size_t esr_env_sg_param_count(int lobes);

/* Fills params[0 .. 7K): axes on a Fibonacci spiral (evenly spread over the sphere, unit
 * length), lambda_k = 10 + |20 N(0,1)| (the authors' initialisation; N from a Box-Muller on
 * esr_rng stream k of `seed`), mu = 0 so the initial map is a uniform grey softplus(0) = ln 2
 * ~ 0.69 in every direction and channel (see env_sg.c). Deterministic per seed. */
void esr_env_sg_init(float *params, int lobes, uint64_t seed);

/* Sets every mu of channel c of an initialised map to one value such that the map's mean over
 * the sphere in that channel is level[c] (> 0; bisection on a 512-direction Fibonacci sphere): a
 * uniform start at a chosen brightness and colour instead of ln 2 grey. */
void esr_env_sg_set_level(float *params, int lobes, const float level[3]);

/* rgb_out[i*3 + c] = env_c(dirs[i*3 .. i*3+2]) for i < n; dirs are unit vectors. Parallel over
 * directions for large n; allocates nothing. */
void esr_env_sg_fwd(const float *params, int lobes, const float *dirs, size_t n, float *rgb_out);
/* Adjoint of esr_env_sg_fwd: grad_params[j] += sum_i sum_c d_rgb[i*3 + c] d env_c(d_i)/d params[j]
 * for every j < 7K (directions are constants). Accumulates, never overwrites; allocates nothing;
 * bitwise the same result for any thread count. */
void esr_env_sg_bwd(const float *params, int lobes, const float *dirs, size_t n, const float *d_rgb,
                    float *grad_params);

/* The unit direction at the centre of pixel (row, col) of a width x height equirectangular
 * (latitude-longitude) image: polar angle theta = pi (row + 0.5) / height from +Z, so row 0 looks
 * up (+Z) and the last row down; azimuth phi = 2 pi (col + 0.5) / width, counter-clockwise
 * seen from above, from +X (phi = 0) through +Y (phi = pi/2):
 *     dir = (sin theta cos phi, sin theta sin phi, cos theta). */
void esr_env_sg_equirect_dir(int width, int height, int row, int col, float dir[3]);
/* The map as a width x height equirectangular image, rgb_out[(row*width + col)*3 + c] =
 * env_c(esr_env_sg_equirect_dir(width, height, row, col)): linear HDR RGB, for EXR/PNG output.
 * ESR_ERR on a bad lobe count or size, or when its scratch buffer cannot be allocated. */
int esr_env_sg_equirect(const float *params, int lobes, int width, int height, float *rgb_out);

#ifdef __cplusplus
}
#endif
#endif
