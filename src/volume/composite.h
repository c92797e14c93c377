/* Alpha compositing along rays (seed eqs. 1 and 3):
 *     w_i = T_i alpha_i,  T_i = prod_{j<i} (1 - alpha_j),  out = sum_i w_i v_i + T_N bg
 * with METHOD.md's pruning: a sample with alpha <= thres is dropped entirely (treated as
 * alpha = 0), and a sample with weight <= thres keeps attenuating the ray but its value is never
 * read (so the colour MLP need only run on "kept" samples, esr_composite_keep).
 * Samples are grouped by ray as in struct esr_samples (ray_start offsets).
 *
 * Backward re-marches each ray from the back with the suffix sum
 *     B_i = sum_{j>i, kept} (prod_{i<k<j} (1 - alpha_k)) alpha_j v_j + (prod_{k>i} (1 - alpha_k)) bg
 *     d out/d alpha_i = T_i (kept_i v_i - B_i),  d out/d v_i = w_i,   T_i = w_i / alpha_i
 * so no per-sample transmittance is stored (tiny-cuda-nn's trick, here in a form without the
 * division by 1 - alpha_i that breaks down for opaque samples).
 * The same functions composite any per-sample channels (colour, depth, normals, emission).
 * A loss on the final transmittance T_N is a composite with v = 0 and bg = 1. */
#ifndef ESR_VOLUME_COMPOSITE_H
#define ESR_VOLUME_COMPOSITE_H

#include <stddef.h>
#include <stdint.h>

#include "core/simd.h"

#ifdef __cplusplus
extern "C" {
#endif

#define ESR_COMPOSITE_THRES 1e-4f

/* Whether sample i's value enters the composite (and so must be evaluated). */
ESR_INLINE int esr_composite_keep(float weight, float thres) { return weight > thres; }

/* One ray: weight[i] = T_i alpha_i (0 where alpha <= thres); returns T_N. */
ESR_INLINE float esr_composite_ray_weights(const float *alpha, size_t n, float thres, float *weight)
{
    float T = 1.0f;
    for (size_t i = 0; i < n; i++) {
        float a = alpha[i];
        if (a <= thres) {
            weight[i] = 0.0f;
            continue;
        }
        weight[i] = T * a;
        T *= 1.0f - a;
    }
    return T;
}

struct esr_composite_args {
    int n_rays;
    const size_t *ray_start; /* [n_rays + 1] */
    const float *alpha;      /* per sample */
    const float *weight;     /* per sample, from esr_composite_weights */
    const float *t_last;     /* per ray T_N, from esr_composite_weights */
    float thres;             /* ESR_COMPOSITE_THRES in the method */
    int channels;            /* C */
    const float *values;     /* per sample * C, read only where esr_composite_keep; or per kept
                                row when value_row is set */
    const float *bg;         /* NULL: no background term; else C floats, or n_rays * C */
    int bg_per_ray;          /* 1: bg[r * C + c]; 0: bg[c] for every ray */
    const uint32_t *value_row; /* NULL: sample i's values at values[i * C]; else at row
                                  value_row[i] (kept samples only; d_values likewise) */
};

/* weight[] and t_last[] for every ray of the batch. Parallel over rays. */
void esr_composite_weights(int n_rays, const size_t *ray_start, const float *alpha, float thres,
                           float *weight, float *t_last);
/* Gradient of a loss on the final transmittances T_N = prod (1 - alpha_i) (samples with alpha <=
 * thres dropped, as in the weights): d_alpha[i] += d_t_last[r] * -prod_{j != i} (1 - alpha_j),
 * the product taken as prefix x suffix so an opaque sample (alpha = 1) is exact. Parallel. */
void esr_composite_t_last_bwd(int n_rays, const size_t *ray_start, const float *alpha, float thres,
                              const float *d_t_last, float *d_alpha);
/* out[r * C + c] = sum_{kept i of r} weight_i values[i*C + c] + t_last[r] bg_c. Parallel. */
void esr_composite_fwd(const struct esr_composite_args *a, float *out);
/* The ray's first surface, for shading a pixel that sees two (an object's silhouette against
 * what lies behind it): the composite of esr_composite_fwd (no background) restricted to the
 * kept samples from the first whose weight exceeds min_weight to `depth` further along the ray
 * (t: each sample's ray distance). Also per ray that layer's opacity (the sum of its weights)
 * and its weights-normalised distance (0 where it is empty). The rest of the ray is the full
 * composite minus this one. Parallel over rays. */
void esr_composite_front(const struct esr_composite_args *a, const float *t, float min_weight,
                         float depth, float *out, float *opacity, float *t_mean);
/* Given d_out[r * C + c]: d_alpha[i] += d loss/d alpha_i, d_values[i*C + c] += d loss/d v
 * (nothing written for samples that are not kept / dropped). Either output may be NULL.
 * Parallel over rays; each sample belongs to one ray so no races. */
void esr_composite_bwd(const struct esr_composite_args *a, const float *d_out, float *d_alpha,
                       float *d_values);

#ifdef __cplusplus
}
#endif
#endif
