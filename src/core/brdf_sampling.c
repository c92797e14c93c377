/* Incident directions for the reflection estimator (see brdf_sampling.h). */
#include "core/brdf_sampling.h"

#include <math.h>

#include "core/sampling.h"

struct esr_vec3 esr_sample_sg_lobe(float lambda, float u1, float u2)
{
    /* inverse of the CDF of z = cos(theta): P(z) = (e^{lambda (z - 1)} - e^{-2 lambda}) /
     * (1 - e^{-2 lambda}) */
    float z = 1.0f + log1pf(u1 * expm1f(-2.0f * lambda)) / lambda;
    z = fminf(1.0f, fmaxf(-1.0f, z));
    return esr_direction_from_polar(z, sqrtf(fmaxf(0.0f, 1.0f - z * z)), u2);
}

float esr_pdf_sg_lobe(float lambda, float cos_theta)
{
    return lambda * expf(lambda * (cos_theta - 1.0f)) / (2.0f * ESR_PI * -expm1f(-2.0f * lambda));
}

/* Whether outgoing direction k gets lobe samples. */
static int lobe_live(const struct esr_brdf_dirs *d, int k)
{
    return d->n_lobe > 0 && esr_v3_dot(d->wo[k], d->n) > 0.0f;
}

int esr_brdf_dirs_count(const struct esr_brdf_dirs *d)
{
    int m = d->n_cos;
    for (int k = 0; k < d->n_wo; k++)
        m += lobe_live(d, k) ? d->n_lobe : 0;
    return m;
}

/* The proposal's NDF sharpness for roughness r (floored, see brdf_sampling.h). */
static float lobe_lambda(float roughness)
{
    const float r = fmaxf(roughness, ESR_BRDF_LOBE_MIN_ROUGHNESS), r2 = r * r;
    return 2.0f / (r2 * r2);
}

/* wo reflected about a half vector from the NDF of roughness r (frame t, b, n); it may lie below
 * the surface. */
static struct esr_vec3 lobe_sample(struct esr_vec3 n, struct esr_vec3 t, struct esr_vec3 b, struct esr_vec3 wo,
                                   float roughness, float u1, float u2)
{
    const struct esr_vec3 h = esr_v3_from_local(esr_sample_sg_lobe(lobe_lambda(roughness), u1, u2), t, b, n);
    return esr_v3_sub(esr_v3_scale(h, 2.0f * esr_v3_dot(wo, h)), wo);
}

/* lobe_sample's density in solid angle at wi (above the surface). The half vector is drawn over
 * the whole sphere and h and -h reflect wo to the same wi, so both carry density there (the
 * second matters for rough lobes only: it is e^(-2 lambda h.n) of the first). */
static float lobe_pdf(struct esr_vec3 n, struct esr_vec3 wo, struct esr_vec3 wi, float roughness)
{
    const struct esr_vec3 h = esr_v3_add(wo, wi);
    const float len = esr_v3_length(h);
    if (len < 1e-6f)
        return 0.0f;
    const struct esr_vec3 hn = esr_v3_scale(h, 1.0f / len);
    const float wo_h = esr_v3_dot(wo, hn);
    if (wo_h <= 0.0f)
        return 0.0f;
    const float lambda = lobe_lambda(roughness), h_n = esr_v3_dot(hn, n);
    return (esr_pdf_sg_lobe(lambda, h_n) + esr_pdf_sg_lobe(lambda, -h_n)) / (4.0f * wo_h);
}

void esr_brdf_dirs_sample(const struct esr_brdf_dirs *d, struct esr_rng *rng, struct esr_vec3 *wi,
                          float *wt)
{
    int j = 0;
    for (int i = 0; i < d->n_cos; i++, j++) { /* stratified in u1 so few still cover the hemisphere */
        const int stratum = d->paired ? i / 2 : i, strata = d->paired ? d->n_cos / 2 : d->n_cos;
        const float u1 = ((float)stratum + esr_rng_float(rng)) / (float)strata, u2 = esr_rng_float(rng);
        const struct esr_vec3 loc = esr_sample_hemisphere_cosine(u1, u2);
        wi[j] = esr_v3_from_local(loc, d->t, d->b, d->n);
        wt[j] = loc.z; /* its cosine, exact in the local frame (below) */
    }
    for (int k = 0; k < d->n_wo; k++) {
        if (!lobe_live(d, k))
            continue;
        for (int i = 0; i < d->n_lobe; i++, j++) {
            const int stratum = d->paired ? i / 2 : i, strata = d->paired ? d->n_lobe / 2 : d->n_lobe;
            const float u1 = ((float)stratum + esr_rng_float(rng)) / (float)strata, u2 = esr_rng_float(rng);
            wi[j] = lobe_sample(d->n, d->t, d->b, d->wo[k], d->roughness, u1, u2);
        }
    }
    for (int i = 0; i < j; i++) {
        const float cos_n = i < d->n_cos ? wt[i] : esr_v3_dot(wi[i], d->n);
        if (cos_n <= 0.0f) { /* a reflection below the surface: nothing arrives from there */
            wi[i] = d->n;
            wt[i] = 0.0f;
            continue;
        }
        float p = (float)d->n_cos * (cos_n * ESR_INV_PI);
        for (int k = 0; k < d->n_wo; k++)
            if (lobe_live(d, k))
                p += (float)d->n_lobe * lobe_pdf(d->n, d->wo[k], wi[i], d->roughness);
        wt[i] = 1.0f / fmaxf(p, 1e-6f);
    }
}
