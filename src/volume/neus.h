/* NeuS opacity (seed eqs. 1-3, eq. 2 here): for a ray section from x_i to x_{i+1}
 *     alpha_i = max((Phi_s(f_i) - Phi_s(f_{i+1})) / Phi_s(f_i), 0),   Phi_s(x) = sigmoid(s x)
 * with s the inverse standard deviation ("inv-s", METHOD.md: 5 + step/50 coarse, 20 + step/100
 * fine). Like the NeuS and Voxurf code, 1e-5 is added to numerator and denominator (so a section
 * deep inside the surface gets alpha 1 rather than 0/0) and alpha is clipped to [0, 1].
 * The section's end values may come from SDF samples at both ends, or, as NeuS/Voxurf do, from
 * one SDF value f at the section mid-point and the slope c = dot(dir, grad f):
 *     f_{prev,next} = f -/+ c' dt / 2,  c' = -(relu(-c/2 + 1/2)(1 - r) + relu(-c) r)
 * (r = cos-anneal ratio, 1 once annealed: c' = min(c, 0)). Pure per-sample functions. */
#ifndef ESR_VOLUME_NEUS_H
#define ESR_VOLUME_NEUS_H

#include <math.h>

#include "core/simd.h"

#define ESR_NEUS_EPS 1e-5f

ESR_INLINE float esr_neus_phi(float s, float x) { return 1.0f / (1.0f + expf(-s * x)); }

ESR_INLINE float esr_neus_alpha_fwd(float f_prev, float f_next, float s)
{
    float p = esr_neus_phi(s, f_prev);
    float q = esr_neus_phi(s, f_next);
    float a = (p - q + ESR_NEUS_EPS) / (p + ESR_NEUS_EPS);
    return fminf(fmaxf(a, 0.0f), 1.0f);
}

/* Given d loss/d alpha, adds nothing: writes d/d f_prev, d/d f_next and d/d s (any may be NULL).
 * Zero where the clip is active. */
ESR_INLINE void esr_neus_alpha_bwd(float f_prev, float f_next, float s, float d_alpha,
                                   float *d_prev, float *d_next, float *d_s)
{
    float p = esr_neus_phi(s, f_prev);
    float q = esr_neus_phi(s, f_next);
    float den = p + ESR_NEUS_EPS;
    float a = (p - q + ESR_NEUS_EPS) / den;
    float live = (a > 0.0f && a < 1.0f) ? d_alpha : 0.0f;
    /* alpha = 1 - q / (p + eps) */
    float da_dp = q / (den * den);
    float da_dq = -1.0f / den;
    float dp = p * (1.0f - p); /* dPhi/d(s x) */
    float dq = q * (1.0f - q);
    if (d_prev)
        *d_prev = live * da_dp * dp * s;
    if (d_next)
        *d_next = live * da_dq * dq * s;
    if (d_s)
        *d_s = live * (da_dp * dp * f_prev + da_dq * dq * f_next);
}

/* Mid-point estimate of the section's end values (see above). */
ESR_INLINE void esr_neus_section_fwd(float f_mid, float cos_dir_grad, float dt, float anneal,
                                     float *f_prev, float *f_next)
{
    float c1 = -cos_dir_grad * 0.5f + 0.5f;
    float c2 = -cos_dir_grad;
    float c = -((c1 > 0.0f ? c1 : 0.0f) * (1.0f - anneal) + (c2 > 0.0f ? c2 : 0.0f) * anneal);
    *f_prev = f_mid - c * dt * 0.5f;
    *f_next = f_mid + c * dt * 0.5f;
}
/* Backward of esr_neus_section_fwd: d loss/d f_mid and d loss/d cos from d/d f_prev, d/d f_next. */
ESR_INLINE void esr_neus_section_bwd(float cos_dir_grad, float dt, float anneal, float d_prev,
                                     float d_next, float *d_mid, float *d_cos)
{
    float c1 = -cos_dir_grad * 0.5f + 0.5f;
    float c2 = -cos_dir_grad;
    float dc_dcos = (c1 > 0.0f ? 0.5f : 0.0f) * (1.0f - anneal) + (c2 > 0.0f ? 1.0f : 0.0f) * anneal;
    float d_c = (d_next - d_prev) * dt * 0.5f;
    *d_mid = d_prev + d_next;
    *d_cos = d_c * dc_dcos;
}

/* The method's inv-s schedule: s = s0 + step / divisor (coarse 5, 50; fine 20, 100). */
ESR_INLINE float esr_neus_inv_s(float s0, float divisor, int step) { return s0 + (float)step / divisor; }

#endif
