/* The two-term rendering loss of METHOD.md ("Rendering loss and colour"), per ray channel:
 *     (clamp(c_tone, 0, 1) - C)^2 + lambda_tau (gamma(x) - C)^2,
 *     x = c_lin, or min(c_lin, 1) where the ground truth is saturated (C >= 1),
 * with c_tone the composited tone-mapped colour, c_lin the composited linear radiance (both on
 * white) and gamma the sRGB OETF. Coarse/alphamask stages use only the first term
 * (lambda_tau = 0). Per-element pure functions plus the batch mean. */
#ifndef ESR_TRAIN_RENDER_LOSS_H
#define ESR_TRAIN_RENDER_LOSS_H

#include <stddef.h>

#include "core/colour.h"
#include "core/simd.h"

/* Linear value that enters gamma (saturated targets clamp it at 1). */
ESR_INLINE float esr_render_loss_lin_clamp(float lin, float target)
{
    return target >= 1.0f && lin > 1.0f ? 1.0f : lin;
}

ESR_INLINE float esr_render_loss_fwd(float tone, float lin, float target, float lambda_tau)
{
    float c = tone < 0.0f ? 0.0f : (tone > 1.0f ? 1.0f : tone);
    float e = c - target;
    float g = esr_srgb_from_linear(esr_render_loss_lin_clamp(lin, target)) - target;
    return e * e + lambda_tau * g * g;
}

/* d/d tone and d/d lin of esr_render_loss_fwd (0 where a clamp is active). */
ESR_INLINE void esr_render_loss_bwd(float tone, float lin, float target, float lambda_tau,
                                    float *d_tone, float *d_lin)
{
    *d_tone = tone >= 0.0f && tone <= 1.0f ? 2.0f * (tone - target) : 0.0f;
    float x = esr_render_loss_lin_clamp(lin, target);
    if (x != lin || lambda_tau == 0.0f) {
        *d_lin = 0.0f;
        return;
    }
    float g = esr_srgb_from_linear(x) - target;
    *d_lin = 2.0f * lambda_tau * g * esr_srgb_from_linear_grad(x);
}

struct esr_render_loss_result {
    double loss;      /* mean over n*3 values of the full loss */
    double mse_tone;  /* mean (clamp(tone) - C)^2, for PSNR */
    double mse_lin;   /* mean (gamma(x) - C)^2 */
};

/* Batch over n rays x 3: fills the result and writes d_tone, d_lin (may be NULL) scaled by
 * 1/(3n) (the mean). */
void esr_render_loss_batch(const float *tone3, const float *lin3, const float *target3, size_t n,
                           float lambda_tau, float *d_tone3, float *d_lin3,
                           struct esr_render_loss_result *res);

#endif
