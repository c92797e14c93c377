/* Reconstruction losses over n values: the value (mean over n, times weight) is returned in
 * double, and the gradient weight * d mean / d pred is *added* to d_pred when it is non-NULL, so
 * several weighted losses can share one gradient buffer. Per-element pure functions for a later
 * CUDA port sit beside the batched versions. */
#ifndef ESR_NN_LOSS_H
#define ESR_NN_LOSS_H

#include <math.h>
#include <stddef.h>

#include "core/simd.h"

#ifdef __cplusplus
extern "C" {
#endif

ESR_INLINE float esr_mse_fwd(float p, float t) { return (p - t) * (p - t); }
ESR_INLINE float esr_mse_bwd(float p, float t) { return 2.0f * (p - t); }
ESR_INLINE float esr_l1_fwd(float p, float t) { return fabsf(p - t); }
/* Subgradient 0 at p == t (as PyTorch's sign). */
ESR_INLINE float esr_l1_bwd(float p, float t) { return p > t ? 1.0f : (p < t ? -1.0f : 0.0f); }
/* Huber (PyTorch's HuberLoss): 0.5 d^2 for |d| < delta, else delta (|d| - 0.5 delta). */
ESR_INLINE float esr_huber_fwd(float p, float t, float delta)
{
    float d = fabsf(p - t);
    return d < delta ? 0.5f * d * d : delta * (d - 0.5f * delta);
}
ESR_INLINE float esr_huber_bwd(float p, float t, float delta)
{
    float d = p - t;
    return d > delta ? delta : (d < -delta ? -delta : d);
}

/* weight * mean((pred - target)^2); d_pred += weight * 2 (pred - target) / n. */
double esr_loss_mse(const float *pred, const float *target, size_t n, float weight, float *d_pred);
/* weight * mean|pred - target|; d_pred += weight * sign(pred - target) / n. */
double esr_loss_l1(const float *pred, const float *target, size_t n, float weight, float *d_pred);
/* weight * mean huber_delta(pred - target); d_pred += weight * huber'(...) / n. */
double esr_loss_huber(const float *pred, const float *target, size_t n, float delta, float weight,
                      float *d_pred);

#ifdef __cplusplus
}
#endif
#endif
