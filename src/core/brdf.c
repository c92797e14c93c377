#include "core/brdf.h"

#include <math.h>

#include "core/sampling.h"

void esr_brdf_eval(const struct esr_material *mat, struct esr_vec3 n, struct esr_vec3 wo, struct esr_vec3 wi,
                   float out[3])
{
    float n_wo = esr_v3_dot(n, wo);
    float n_wi = esr_v3_dot(n, wi);
    if (n_wo <= 0.0f || n_wi <= 0.0f) {
        out[0] = out[1] = out[2] = 0.0f;
        return;
    }
    struct esr_vec3 h = esr_v3_normalize(esr_v3_add(wo, wi));
    float r = fmaxf(mat->roughness, ESR_BRDF_MIN_ROUGHNESS);
    float r4 = r * r * r * r;
    float d = expf(2.0f / r4 * (esr_v3_dot(h, n) - 1.0f)) / (ESR_PI * r4);
    float k = 0.5f * r * r;
    float g = n_wo * n_wi / ((n_wo * (1.0f - k) + k) * (n_wi * (1.0f - k) + k));
    float schlick = powf(1.0f - fminf(fmaxf(esr_v3_dot(wo, h), 0.0f), 1.0f), 5.0f);
    float m = mat->metallic;
    for (int c = 0; c < 3; c++) {
        float f0 = 0.04f * (1.0f - m) + mat->base[c] * m;
        float fresnel = f0 + (1.0f - f0) * schlick;
        out[c] = d * fresnel * g / (4.0f * n_wo) + n_wi * (1.0f - m) * mat->base[c] * ESR_INV_PI;
    }
}

void esr_brdf_eval_bwd(const struct esr_material *mat, struct esr_vec3 n, struct esr_vec3 wo,
                       struct esr_vec3 wi, const float d_out[3], struct esr_material *d_mat)
{
    float n_wo = esr_v3_dot(n, wo);
    float n_wi = esr_v3_dot(n, wi);
    if (n_wo <= 0.0f || n_wi <= 0.0f)
        return;
    struct esr_vec3 h = esr_v3_normalize(esr_v3_add(wo, wi));
    const int r_free = mat->roughness > ESR_BRDF_MIN_ROUGHNESS; /* below: clamped, no gradient */
    float r = fmaxf(mat->roughness, ESR_BRDF_MIN_ROUGHNESS);
    float r4 = r * r * r * r;
    float hn1 = esr_v3_dot(h, n) - 1.0f;
    float d = expf(2.0f / r4 * hn1) / (ESR_PI * r4);
    /* dD/dr = D (-8 hn1 / r^5 - 4 / r) from D = exp(2 hn1 r^-4) / (pi r^4) */
    float dd_dr = d * (-8.0f * hn1 / (r4 * r) - 4.0f / r);
    float k = 0.5f * r * r;
    float A = n_wo * (1.0f - k) + k, B = n_wi * (1.0f - k) + k;
    float g = n_wo * n_wi / (A * B);
    /* dG/dk = -G ((1 - n.wo)/A + (1 - n.wi)/B), dk/dr = r */
    float dg_dr = -g * ((1.0f - n_wo) / A + (1.0f - n_wi) / B) * r;
    float schlick = powf(1.0f - fminf(fmaxf(esr_v3_dot(wo, h), 0.0f), 1.0f), 5.0f);
    float m = mat->metallic;
    float spec = d * g / (4.0f * n_wo); /* R_c = spec F_c + n.wi (1-m) b_c / pi */
    float d_spec_dr = (dd_dr * g + d * dg_dr) / (4.0f * n_wo);
    for (int c = 0; c < 3; c++) {
        float f0 = 0.04f * (1.0f - m) + mat->base[c] * m;
        float fresnel = f0 + (1.0f - f0) * schlick;
        float df_df0 = 1.0f - schlick;
        float g_c = d_out[c];
        d_mat->base[c] += g_c * (spec * df_df0 * m + n_wi * (1.0f - m) * ESR_INV_PI);
        d_mat->metallic += g_c * (spec * df_df0 * (mat->base[c] - 0.04f) -
                                  n_wi * mat->base[c] * ESR_INV_PI);
        if (r_free)
            d_mat->roughness += g_c * d_spec_dr * fresnel;
    }
}
