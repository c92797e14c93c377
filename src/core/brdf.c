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
