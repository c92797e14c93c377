/* The seed's simplified Disney BRDF (eqs. 5-8), cosine term included:
 *   R = D F G / (4 n.wo) + (n.wi)(1-m) b/pi
 *   D = exp(2 (h.n - 1) / r^4) / (pi r^4)           spherical-Gaussian NDF (NeILF++)
 *   F = F0 + (1-F0)(1 - wo.h)^5, F0 = 0.04(1-m) + b m
 *   G = (n.wo)(n.wi) / (((n.wo)(1-k)+k)((n.wi)(1-k)+k)), k = r^2/2
 * The seed typesets Schlick's term as (1 - (wo.h)^5); we use Schlick's (1 - wo.h)^5, which the
 * cited Disney model and the authors' NeILF++ code use (the typeset form stays near 1 for most
 * angles, which no Fresnel curve does).
 *
 * Backward passes give the gradient with respect to the material only: the normal and the
 * directions carry none (the method detaches normals). Roughness is clamped to
 * ESR_BRDF_MIN_ROUGHNESS, so its gradient is zero below the clamp (it flows at the clamp value
 * itself, as a clamp's usually does); where wo or wi is below the surface R is 0 and so is every
 * gradient. The single evaluation, its backward and the batched estimator below share one
 * implementation of the formulas (core/brdf.c). */
#ifndef ESR_CORE_BRDF_H
#define ESR_CORE_BRDF_H

#include "core/vec3.h"

struct esr_material {
    float base[3];   /* base colour b, linear, [0,1] */
    float roughness; /* r in [0,1]; clamped to >= ESR_BRDF_MIN_ROUGHNESS inside */
    float metallic;  /* m in [0,1] */
};

#define ESR_BRDF_MIN_ROUGHNESS 0.02f

/* R(x, wo, wi) with the cosine factor; n, wo, wi unit vectors, wo pointing away from the surface.
 * Returns 0 when wi or wo is below the surface. */
void esr_brdf_eval(const struct esr_material *mat, struct esr_vec3 n, struct esr_vec3 wo, struct esr_vec3 wi,
                   float out[3]);

/* Given d_out = d loss / d R (3 channels), ADDS d loss / d (base, roughness, metallic) to *d_mat. */
void esr_brdf_eval_bwd(const struct esr_material *mat, struct esr_vec3 n, struct esr_vec3 wo, struct esr_vec3 wi,
                       const float d_out[3], struct esr_material *d_mat);

/* The incident half of the reflection estimator for one point: M directions and the radiance
 * arriving along them, structure of arrays with planes of M floats (no padding needed):
 *   wi[0..M) = x, wi[M..2M) = y, wi[2M..3M) = z     unit directions, pointing away from the point
 *   li[c*M + j]                                     incident radiance L_i of direction j, channel c
 *   weight[j]                                       Monte Carlo weight, e.g. 1/(M pdf_j)
 * One set serves every outgoing direction of the point (the LTS loss uses two). */
struct esr_brdf_incident {
    int count; /* M >= 0 */
    const float *wi;
    const float *li;
    const float *weight;
};

/* out[c] = sum_j li[c*M + j] R_c(wo, wi_j) weight[j] for material mat and normal n: the
 * reflected radiance estimate of seed eq. 4 without E(x) (weight 2 pi / M for its uniform
 * hemisphere sampling). Directions below the surface contribute 0. Allocation-free, no
 * threads; the per-(point, wo) terms are computed once and the loop over j vectorises. */
void esr_brdf_reflect_fwd(const struct esr_material *mat, struct esr_vec3 n, struct esr_vec3 wo,
                          const struct esr_brdf_incident *inc, float out[3]);

/* Given d_out = d loss / d out: ADDS d loss / d material to *d_mat (when not NULL) and
 * d loss / d li to d_li[c*M + j] (same layout as li; when not NULL; must not overlap the
 * inputs), so several outgoing directions sharing one incident set accumulate into one d_li. */
void esr_brdf_reflect_bwd(const struct esr_material *mat, struct esr_vec3 n, struct esr_vec3 wo,
                          const struct esr_brdf_incident *inc, const float d_out[3], struct esr_material *d_mat,
                          float *d_li);

#endif
