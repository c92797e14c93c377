/* Voxurf's hierarchical geometry feature of an SDF grid, fed to the fine-stage radiance MLPs
 * (METHOD.md stage 3): at each point x, with h_{k,a} = scale_k voxels along axis a,
 *     feat[0]                  = f(x)
 *     feat[1 + 6k + 2a + s]    = f(x + (2s-1) h_{k,a} e_a)          s = 0 (minus), 1 (plus)
 *     feat[1 + 6K + 3k + a]    = g_{k,a} = (f(x + h e_a) - f(x - h e_a)) / (2 h_{k,a})
 * and, when `normalize` is set, the k-th gradient triple is divided by (|g_k| + 1e-5) as Voxurf
 * does (so it is a unit normal estimate at that scale). Feature size 1 + 9K. Neighbour points
 * outside the box are clamped to it, like Voxurf's index clamping. */
#ifndef ESR_FIELDS_GEO_FEATURE_H
#define ESR_FIELDS_GEO_FEATURE_H

#include <stddef.h>

#include "fields/grid.h"

#ifdef __cplusplus
extern "C" {
#endif

#define ESR_GEO_FEATURE_MAX_SCALES 8

struct esr_geo_feature_params {
    int n_scales;                              /* K, 1..ESR_GEO_FEATURE_MAX_SCALES */
    float scales[ESR_GEO_FEATURE_MAX_SCALES];  /* offsets in voxels, e.g. {0.5, 1, 1.5, 2} */
    int normalize;                             /* 1: unit FD normals (Voxurf), 0: raw FD gradients */
};

/* The METHOD.md setting: K = 4, scales {0.5, 1, 1.5, 2}, normalised. */
void esr_geo_feature_default(struct esr_geo_feature_params *p);
/* 1 + 9K. */
int esr_geo_feature_dim(const struct esr_geo_feature_params *p);

/* feat[i*dim ..] for the n points pts[i*3..]; the SDF is channel 0 of g (g->channels must be 1).
 * Fails on a bad grid or parameters. Parallel. */
int esr_geo_feature_fwd(const struct esr_grid *g, const float *sdf,
                        const struct esr_geo_feature_params *p, const float *pts, size_t n,
                        float *feat);
/* Adjoint w.r.t. the SDF values: grad += d feat/d sdf ^T d_feat. feat: the forward's output for
 * the same points and SDF (the normalisation's Jacobian reads its samples). Accumulates;
 * deterministic (z-plane ownership, see grid.h). */
int esr_geo_feature_bwd(const struct esr_grid *g, const struct esr_geo_feature_params *p,
                        const float *pts, size_t n, const float *feat, const float *d_feat,
                        float *grad);

#ifdef __cplusplus
}
#endif
#endif
