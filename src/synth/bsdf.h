/* Importance sampling of the seed's BRDF (core/brdf.h): a mixture of a cosine-weighted hemisphere
 * for the diffuse lobe and the spherical-Gaussian NDF for the specular lobe. Sample and pdf as a
 * pair (the pdf is the full mixture density, so it serves MIS); per-element pure functions. */
#ifndef ESR_SYNTH_BSDF_H
#define ESR_SYNTH_BSDF_H

#include <math.h>

#include "core/brdf.h"
#include "core/sampling.h"
#include "core/vec3.h"

/* The NDF D(h) = exp(a (cos - 1)) / (pi r^4), a = 2 / r^4, is sampled in proportion to D over the
 * hemisphere of half vectors: pdf_h(h) = a exp(a (cos - 1)) / (2 pi (1 - exp(-a))). */
ESR_INLINE float esr_synth_sg_sharpness(float roughness)
{
    float r = fmaxf(roughness, ESR_BRDF_MIN_ROUGHNESS);
    return 2.0f / (r * r * r * r);
}

ESR_INLINE float esr_synth_sg_pdf_h(float sharpness, float cos_h)
{
    if (cos_h <= 0.0f)
        return 0.0f;
    return sharpness * expf(sharpness * (cos_h - 1.0f)) / (2.0f * ESR_PI * -expm1f(-sharpness));
}

/* Half vector in the local frame (z = normal) by inverting the CDF of cos_h; 1 - cos_h is formed
 * directly so that sharp lobes (a ~ 1e7) keep their precision. */
ESR_INLINE struct esr_vec3 esr_synth_sg_sample_h(float sharpness, float u1, float u2)
{
    float one_minus_cos = -log1pf(-u1 * -expm1f(-sharpness)) / sharpness;
    one_minus_cos = fminf(fmaxf(one_minus_cos, 0.0f), 1.0f);
    float cos_h = 1.0f - one_minus_cos;
    float sin_h = sqrtf(one_minus_cos * (2.0f - one_minus_cos));
    float phi = 2.0f * ESR_PI * u2;
    return esr_v3(sin_h * cosf(phi), sin_h * sinf(phi), cos_h);
}

/* Probability of picking the specular lobe: its normal-incidence reflectance against the diffuse
 * albedo, kept in [0.25, 0.9] so that neither lobe is starved at grazing angles (Fresnel raises
 * the specular part there); 1 for purely metallic surfaces, which have no diffuse lobe. */
ESR_INLINE float esr_synth_spec_prob(const struct esr_material *m)
{
    float lum = 0.2126f * m->base[0] + 0.7152f * m->base[1] + 0.0722f * m->base[2];
    float wd = (1.0f - m->metallic) * lum;
    if (wd <= 0.0f)
        return 1.0f;
    float ws = 0.04f * (1.0f - m->metallic) + lum * m->metallic;
    return fminf(fmaxf(ws / (ws + wd), 0.25f), 0.9f);
}

/* Solid-angle density of esr_synth_bsdf_sample producing wi; 0 below the surface (those samples
 * are rejected, and the BRDF is 0 there). */
ESR_INLINE float esr_synth_bsdf_pdf(const struct esr_material *m, struct esr_vec3 n, struct esr_vec3 wo,
                                    struct esr_vec3 wi)
{
    float n_wi = esr_v3_dot(n, wi);
    if (n_wi <= 0.0f || esr_v3_dot(n, wo) <= 0.0f)
        return 0.0f;
    float ps = esr_synth_spec_prob(m);
    struct esr_vec3 h = esr_v3_normalize(esr_v3_add(wo, wi));
    float wo_h = esr_v3_dot(wo, h);
    float spec = wo_h > 0.0f ? esr_synth_sg_pdf_h(esr_synth_sg_sharpness(m->roughness), esr_v3_dot(n, h)) / (4.0f * wo_h)
                             : 0.0f;
    return ps * spec + (1.0f - ps) * n_wi * ESR_INV_PI;
}

/* Draws wi for outgoing direction wo at a surface with normal n (all unit, world space) from
 * three uniforms; returns 0 when the draw falls below the surface (terminate the path), else 1
 * with *pdf = esr_synth_bsdf_pdf(m, n, wo, *wi). */
ESR_INLINE int esr_synth_bsdf_sample(const struct esr_material *m, struct esr_vec3 n, struct esr_vec3 wo, float u0,
                                     float u1, float u2, struct esr_vec3 *wi, float *pdf)
{
    struct esr_vec3 t, b;
    esr_v3_basis(n, &t, &b);
    if (u0 < esr_synth_spec_prob(m)) {
        struct esr_vec3 h = esr_v3_from_local(esr_synth_sg_sample_h(esr_synth_sg_sharpness(m->roughness), u1, u2), t, b, n);
        *wi = esr_v3_sub(esr_v3_scale(h, 2.0f * esr_v3_dot(wo, h)), wo);
    } else {
        *wi = esr_v3_from_local(esr_sample_hemisphere_cosine(u1, u2), t, b, n);
    }
    *wi = esr_v3_normalize(*wi);
    *pdf = esr_synth_bsdf_pdf(m, n, wo, *wi);
    return *pdf > 0.0f;
}

#endif
