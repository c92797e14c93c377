/* The environment map of the lts stage: 48 spherical Gaussians (METHOD.md "Stages 4-5"),
 *     env(d)_c = softplus( sum_k mu_kc exp(|lambda_k| (d . xi_k / |xi_k| - 1)) )
 * Parameters per lobe, consecutive: xi (3, the axis, normalised inside), lambda (1, sharpness),
 * mu (3, RGB amplitude): ESR_ENV_SG_LOBE_FLOATS floats. Only the light-off model sees it: rays
 * that leave the scene carry env(d) T_last in the off estimate. */
#ifndef ESR_FIELDS_ENV_SG_H
#define ESR_FIELDS_ENV_SG_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define ESR_ENV_SG_LOBE_FLOATS 7

size_t esr_env_sg_param_count(int lobes);
/* Axes on a Fibonacci spiral (evenly over the sphere), lambda = 10 + |20 N(0,1)| (the authors'
 * init), mu = 0: env = softplus(0) = 0.69 grey everywhere at the start. Deterministic in seed. */
void esr_env_sg_init(float *params, int lobes, uint64_t seed);
/* env at n unit directions dirs [n*3] into rgb [n*3]. Parallel, allocation-free. */
void esr_env_sg_fwd(const float *params, int lobes, const float *dirs, size_t n, float *rgb);
/* ADDS d loss/d params into grad given d loss/d rgb. Serial over the directions, so the sum is
 * the same for any thread count (the LTS loss calls it on a few thousand directions). */
void esr_env_sg_bwd(const float *params, int lobes, const float *dirs, size_t n,
                    const float *d_rgb, float *grad);

#ifdef __cplusplus
}
#endif
#endif
