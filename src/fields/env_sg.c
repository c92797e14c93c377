/* Spherical-Gaussian environment map (see env_sg.h). */
#include "fields/env_sg.h"

#include <math.h>

#include "core/rng.h"
#include "nn/activation.h"

size_t esr_env_sg_param_count(int lobes)
{
    return (size_t)(lobes > 0 ? lobes : 0) * ESR_ENV_SG_LOBE_FLOATS;
}

void esr_env_sg_init(float *params, int lobes, uint64_t seed)
{
    const double golden = 3.14159265358979323846 * (3.0 - sqrt(5.0));
    for (int k = 0; k < lobes; k++) {
        float *p = params + (size_t)k * ESR_ENV_SG_LOBE_FLOATS;
        double z = 1.0 - (2.0 * k + 1.0) / lobes, r = sqrt(fmax(0.0, 1.0 - z * z));
        p[0] = (float)(r * cos(golden * k));
        p[1] = (float)(r * sin(golden * k));
        p[2] = (float)z;
        struct esr_rng rng = esr_rng_init(seed, (uint64_t)k);
        /* Box-Muller */
        double u1 = fmax(esr_rng_float(&rng), 1e-12), u2 = esr_rng_float(&rng);
        double gauss = sqrt(-2.0 * log(u1)) * cos(2.0 * 3.14159265358979323846 * u2);
        p[3] = (float)(10.0 + fabs(20.0 * gauss));
        p[4] = p[5] = p[6] = 0.0f;
    }
}

/* Unit axis of lobe p and 1/|xi|. */
static float lobe_axis(const float *p, float a[3])
{
    float len = sqrtf(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    float inv = len > 1e-12f ? 1.0f / len : 0.0f;
    for (int i = 0; i < 3; i++)
        a[i] = p[i] * inv;
    return inv;
}

/* Pre-activation sum of direction d. */
static void pre_activation(const float *params, int lobes, const float *d, float s[3])
{
    s[0] = s[1] = s[2] = 0.0f;
    for (int k = 0; k < lobes; k++) {
        const float *p = params + (size_t)k * ESR_ENV_SG_LOBE_FLOATS;
        float a[3];
        lobe_axis(p, a);
        float e = expf(fabsf(p[3]) * (d[0] * a[0] + d[1] * a[1] + d[2] * a[2] - 1.0f));
        for (int c = 0; c < 3; c++)
            s[c] += p[4 + c] * e;
    }
}

void esr_env_sg_fwd(const float *params, int lobes, const float *dirs, size_t n, float *rgb)
{
#pragma omp parallel for schedule(static) if (n > 1024)
    for (size_t i = 0; i < n; i++) {
        float s[3];
        pre_activation(params, lobes, dirs + i * 3, s);
        for (int c = 0; c < 3; c++)
            rgb[i * 3 + c] = esr_nn_softplus_fwd(s[c]);
    }
}

void esr_env_sg_bwd(const float *params, int lobes, const float *dirs, size_t n,
                    const float *d_rgb, float *grad)
{
    for (size_t i = 0; i < n; i++) {
        const float *d = dirs + i * 3;
        float s[3], g[3];
        pre_activation(params, lobes, d, s);
        for (int c = 0; c < 3; c++)
            g[c] = d_rgb[i * 3 + c] * esr_nn_sigmoid_fwd(s[c]); /* softplus' = sigmoid */
        if (g[0] == 0.0f && g[1] == 0.0f && g[2] == 0.0f)
            continue;
        for (int k = 0; k < lobes; k++) {
            const float *p = params + (size_t)k * ESR_ENV_SG_LOBE_FLOATS;
            float *gp = grad + (size_t)k * ESR_ENV_SG_LOBE_FLOATS;
            float a[3];
            float inv = lobe_axis(p, a);
            float cosang = d[0] * a[0] + d[1] * a[1] + d[2] * a[2];
            float lam = fabsf(p[3]), e = expf(lam * (cosang - 1.0f));
            float d_e = 0.0f;
            for (int c = 0; c < 3; c++) {
                gp[4 + c] += g[c] * e;
                d_e += g[c] * p[4 + c];
            }
            if (d_e == 0.0f)
                continue;
            gp[3] += d_e * e * (cosang - 1.0f) * (p[3] >= 0.0f ? 1.0f : -1.0f);
            /* d cos / d xi = (d - a (a . d)) / |xi| */
            float d_cos = d_e * e * lam;
            for (int j = 0; j < 3; j++)
                gp[j] += d_cos * (d[j] - a[j] * cosang) * inv;
        }
    }
}
