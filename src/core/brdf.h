/* The seed's simplified Disney BRDF (eqs. 5-8), cosine term included:
 *   R = D F G / (4 n.wo) + (n.wi)(1-m) b/pi
 *   D = exp(2 (h.n - 1) / r^4) / (pi r^4)           spherical-Gaussian NDF (NeILF++)
 *   F = F0 + (1-F0)(1 - wo.h)^5, F0 = 0.04(1-m) + b m
 *   G = (n.wo)(n.wi) / (((n.wo)(1-k)+k)((n.wi)(1-k)+k)), k = r^2/2
 * The seed typesets Schlick's term as (1 - (wo.h)^5); we use Schlick's (1 - wo.h)^5, which the
 * cited Disney model and the authors' NeILF++ code use (the typeset form stays near 1 for most
 * angles, which no Fresnel curve does). */
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
/* Backward of esr_brdf_eval: ADDS d loss/d base, roughness, metallic into *d_mat given
 * d loss/d out. The normal and directions get none (the method detaches normals). Zero gradient
 * below the surface and for roughness under ESR_BRDF_MIN_ROUGHNESS (the clamp). */
void esr_brdf_eval_bwd(const struct esr_material *mat, struct esr_vec3 n, struct esr_vec3 wo,
                       struct esr_vec3 wi, const float d_out[3], struct esr_material *d_mat);

#endif
