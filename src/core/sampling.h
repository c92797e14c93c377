/* Hemisphere sampling in the local frame (z = normal): sample, pdf, and inverse, as triples. */
#ifndef ESR_CORE_SAMPLING_H
#define ESR_CORE_SAMPLING_H

#include <math.h>

#include "core/vec3.h"

#define ESR_PI 3.14159265358979323846f
#define ESR_INV_PI 0.31830988618379067154f
#define ESR_INV_2PI 0.15915494309189533577f

/* Azimuth of a local direction as a fraction of a turn, in [0, 1): the inverse of phi = 2 pi u2. */
ESR_INLINE float esr_azimuth_unit(struct esr_vec3 local)
{
    float u = atan2f(local.y, local.x) * ESR_INV_2PI;
    if (u < 0.0f)
        u += 1.0f;
    return u < 1.0f ? u : 0.0f; /* -tiny + 1 rounds to 1, which is azimuth 0 */
}

/* The direction with cos(theta) = z, sin(theta) = r and azimuth 2 pi u2. */
ESR_INLINE struct esr_vec3 esr_direction_from_polar(float z, float r, float u2)
{
    float phi = 2.0f * ESR_PI * u2;
    return esr_v3(r * cosf(phi), r * sinf(phi), z);
}

/* Uniform over the upper hemisphere; pdf 1/(2 pi) (the seed's eq. 4 uses this). */
ESR_INLINE struct esr_vec3 esr_sample_hemisphere_uniform(float u1, float u2)
{
    return esr_direction_from_polar(u1, sqrtf(fmaxf(0.0f, 1.0f - u1 * u1)), u2);
}
ESR_INLINE float esr_pdf_hemisphere_uniform(struct esr_vec3 local) { return local.z >= 0.0f ? ESR_INV_2PI : 0.0f; }
ESR_INLINE void esr_invert_hemisphere_uniform(struct esr_vec3 local, float *u1, float *u2)
{
    *u1 = local.z;
    *u2 = esr_azimuth_unit(local);
}

/* Cosine-weighted over the upper hemisphere (Malley's method); pdf cos(theta)/pi. */
ESR_INLINE struct esr_vec3 esr_sample_hemisphere_cosine(float u1, float u2)
{
    return esr_direction_from_polar(sqrtf(fmaxf(0.0f, 1.0f - u1)), sqrtf(u1), u2);
}
ESR_INLINE float esr_pdf_hemisphere_cosine(struct esr_vec3 local) { return local.z > 0.0f ? local.z * ESR_INV_PI : 0.0f; }
ESR_INLINE void esr_invert_hemisphere_cosine(struct esr_vec3 local, float *u1, float *u2)
{
    *u1 = local.x * local.x + local.y * local.y;
    *u2 = esr_azimuth_unit(local);
}

/* Uniform over the whole sphere; pdf 1/(4 pi). */
ESR_INLINE struct esr_vec3 esr_sample_sphere_uniform(float u1, float u2)
{
    float z = 1.0f - 2.0f * u1;
    return esr_direction_from_polar(z, sqrtf(fmaxf(0.0f, 1.0f - z * z)), u2);
}
ESR_INLINE float esr_pdf_sphere_uniform(struct esr_vec3 local)
{
    (void)local;
    return 0.25f * ESR_INV_PI;
}
ESR_INLINE void esr_invert_sphere_uniform(struct esr_vec3 local, float *u1, float *u2)
{
    *u1 = 0.5f * (1.0f - local.z);
    *u2 = esr_azimuth_unit(local);
}

#endif
