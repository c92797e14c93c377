/* Incident directions for estimating a point's reflected radiance under the seed's BRDF
 * (core/brdf.h): cosine-weighted directions, which suit its diffuse lobe, plus directions
 * reflected about half vectors drawn from its specular lobe around each outgoing direction
 * given, which a glossy surface needs (a few cosine directions almost never land in a sharp
 * lobe, and the squared error of so noisy an estimate pushed every surface towards rough),
 * combined by the balance heuristic (Veach's multi-sample form): each direction w's weight is
 *     1 / (n_cos p_cos(w) + sum_k n_lobe p_k(w))
 * so sum_j f(w_j) L(w_j) weight_j estimates the integral of f L without bias for every outgoing
 * direction, whichever proposal drew w_j. With n_lobe = 0 it is plain cosine sampling.
 *
 * The lobe: the BRDF's NDF is the spherical Gaussian exp(lambda (h.n - 1)), lambda = 2 / r^4;
 * h is drawn from it (normalised over the sphere), w = reflect(wo, h), and
 *     p_k(w) = p_h(h_k) / (4 wo_k.h_k),  h_k = normalize(wo_k + w).
 * The proposal's roughness is floored at ESR_BRDF_LOBE_MIN_ROUGHNESS: sharper lobes lose
 * their shape to float rounding of h.n (the estimate stays unbiased, the proposal is only
 * broader than the BRDF). */
#ifndef ESR_CORE_BRDF_SAMPLING_H
#define ESR_CORE_BRDF_SAMPLING_H

#include "core/rng.h"
#include "core/vec3.h"

#define ESR_BRDF_LOBE_MIN_ROUGHNESS 0.05f

/* A unit vector about +z from the spherical Gaussian exp(lambda (z - 1)) over the sphere, and its
 * density; lambda > 0. */
struct esr_vec3 esr_sample_sg_lobe(float lambda, float u1, float u2);
float esr_pdf_sg_lobe(float lambda, float cos_theta);

struct esr_brdf_dirs {
    struct esr_vec3 n, t, b; /* orthonormal frame, n the surface normal */
    struct esr_vec3 wo[2];   /* outgoing directions (unit, away from the surface) */
    int n_wo;                /* 0..2; one at or below the surface gets no lobe samples */
    float roughness;         /* the BRDF's at the point */
    int n_cos, n_lobe;       /* cosine directions (stratified), and lobe directions per wo */
    int paired;              /* 1: each cosine and each lobe stratum holds two independent
                                directions (2i, 2i + 1; n_cos and n_lobe even), so the even and
                                the odd ones are each an unbiased estimate on their own, with the
                                same weights (option lts_split, train/lts.h) */
};

/* The directions' count: n_cos + n_lobe per outgoing direction above the surface. */
int esr_brdf_dirs_count(const struct esr_brdf_dirs *d);
/* Draws esr_brdf_dirs_count(d) unit directions wi[] and their weights wt[] (0 for a lobe
 * direction that fell below the surface: it adds nothing) from rng. */
void esr_brdf_dirs_sample(const struct esr_brdf_dirs *d, struct esr_rng *rng, struct esr_vec3 *wi,
                          float *wt);

#endif
