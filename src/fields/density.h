/* DVGO-style density -> alpha for the alphamask stage (METHOD.md stage 1):
 *     alpha = 1 - exp(-softplus(density + shift) * interval)
 * shift = log(1/(1 - alpha_init) - 1) makes a zero density give alpha_init at interval 1
 * (DVGO's act_shift). The interval is DVGO's stepsize * voxel_size_ratio (0.5 for half-voxel
 * steps on the base grid). The alphamask stage composites these alphas with render/composite.h
 * and chains d_alpha back through esr_density_alpha_bwd into the density grid's trilinear
 * backward. Per-element pure functions plus batch loops. */
#ifndef ESR_FIELDS_DENSITY_H
#define ESR_FIELDS_DENSITY_H

#include <math.h>
#include <stddef.h>

#include "core/simd.h"
#include "nn/activation.h"

#ifdef __cplusplus
extern "C" {
#endif

/* DVGO's act_shift for an initial alpha in (0, 1). */
ESR_INLINE float esr_density_shift(float alpha_init) { return logf(1.0f / (1.0f - alpha_init) - 1.0f); }

ESR_INLINE float esr_density_alpha_fwd(float density, float shift, float interval)
{
    return -expm1f(-esr_nn_softplus_fwd(density + shift) * interval);
}
/* d loss/d density given d loss/d alpha: (1 - alpha) * interval * sigmoid(density + shift). */
ESR_INLINE float esr_density_alpha_bwd(float density, float shift, float interval, float d_alpha)
{
    float sp = esr_nn_softplus_fwd(density + shift);
    return d_alpha * expf(-sp * interval) * interval * esr_nn_softplus_bwd(sp, 1.0f);
}

/* alpha[i] = esr_density_alpha_fwd(density[i], ...), i < n. Parallel. */
void esr_density_alpha_batch_fwd(const float *density, size_t n, float shift, float interval,
                                 float *alpha);
/* d_density[i] += esr_density_alpha_bwd(density[i], ..., d_alpha[i]). Parallel. */
void esr_density_alpha_batch_bwd(const float *density, size_t n, float shift, float interval,
                                 const float *d_alpha, float *d_density);

#ifdef __cplusplus
}
#endif
#endif
