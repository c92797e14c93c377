/* Hemisphere sampling in the local frame (z = normal): sample, pdf, and inverse, as triples. */
#ifndef ESR_CORE_SAMPLING_H
#define ESR_CORE_SAMPLING_H

#include <math.h>

#include "core/vec3.h"

#define ESR_PI 3.14159265358979323846f
#define ESR_INV_PI 0.31830988618379067154f
#define ESR_INV_2PI 0.15915494309189533577f

/* Uniform over the upper hemisphere; pdf 1/(2 pi) (the seed's eq. 4 uses this). */
ESR_INLINE struct esr_vec3 esr_sample_hemisphere_uniform(float u1, float u2)
{
    float z = u1;
    float r = sqrtf(fmaxf(0.0f, 1.0f - z * z));
    float phi = 2.0f * ESR_PI * u2;
    return esr_v3(r * cosf(phi), r * sinf(phi), z);
}
ESR_INLINE float esr_pdf_hemisphere_uniform(struct esr_vec3 local) { return local.z >= 0.0f ? ESR_INV_2PI : 0.0f; }
ESR_INLINE void esr_invert_hemisphere_uniform(struct esr_vec3 local, float *u1, float *u2)
{
    float phi = atan2f(local.y, local.x);
    if (phi < 0.0f)
        phi += 2.0f * ESR_PI;
    *u1 = local.z;
    *u2 = phi / (2.0f * ESR_PI);
}

/* Cosine-weighted over the upper hemisphere (Malley's method); pdf cos(theta)/pi. */
ESR_INLINE struct esr_vec3 esr_sample_hemisphere_cosine(float u1, float u2)
{
    float r = sqrtf(u1);
    float phi = 2.0f * ESR_PI * u2;
    return esr_v3(r * cosf(phi), r * sinf(phi), sqrtf(fmaxf(0.0f, 1.0f - u1)));
}
ESR_INLINE float esr_pdf_hemisphere_cosine(struct esr_vec3 local) { return local.z > 0.0f ? local.z * ESR_INV_PI : 0.0f; }
ESR_INLINE void esr_invert_hemisphere_cosine(struct esr_vec3 local, float *u1, float *u2)
{
    float phi = atan2f(local.y, local.x);
    if (phi < 0.0f)
        phi += 2.0f * ESR_PI;
    *u1 = local.x * local.x + local.y * local.y;
    *u2 = phi / (2.0f * ESR_PI);
}

/* Uniform over the whole sphere; pdf 1/(4 pi). */
ESR_INLINE struct esr_vec3 esr_sample_sphere_uniform(float u1, float u2)
{
    float z = 1.0f - 2.0f * u1;
    float r = sqrtf(fmaxf(0.0f, 1.0f - z * z));
    float phi = 2.0f * ESR_PI * u2;
    return esr_v3(r * cosf(phi), r * sinf(phi), z);
}

#endif
