/* Voxurf's hierarchical geometry feature (see geo_feature.h for the layout). */
#include "fields/geo_feature.h"

#include <math.h>

#include "core/error.h"
#include "fields/trilerp.h"

#define GEO_NORM_EPS 1e-5f
#define GEO_MAX_SAMPLES (1 + 6 * ESR_GEO_FEATURE_MAX_SCALES)

void esr_geo_feature_default(struct esr_geo_feature_params *p)
{
    static const float scales[4] = {0.5f, 1.0f, 1.5f, 2.0f};
    p->n_scales = 4;
    for (int k = 0; k < ESR_GEO_FEATURE_MAX_SCALES; k++)
        p->scales[k] = k < 4 ? scales[k] : 0.0f;
    p->normalize = 1;
}

int esr_geo_feature_dim(const struct esr_geo_feature_params *p) { return 1 + 9 * p->n_scales; }

static int check(const struct esr_grid *g, const struct esr_geo_feature_params *p)
{
    if (g->channels != 1)
        return ESR_FAIL("geometry feature: SDF grid must have 1 channel, has %d", g->channels);
    if (p->n_scales < 1 || p->n_scales > ESR_GEO_FEATURE_MAX_SCALES)
        return ESR_FAIL("geometry feature: %d scales, expected 1..%d", p->n_scales,
                        ESR_GEO_FEATURE_MAX_SCALES);
    for (int k = 0; k < p->n_scales; k++)
        if (!(p->scales[k] > 0.0f))
            return ESR_FAIL("geometry feature: scale %d is %g, must be > 0", k, (double)p->scales[k]);
    return ESR_OK;
}

/* Step h_{k,a} in world units. */
static float step_of(const struct esr_grid *g, const struct esr_geo_feature_params *p, int k, int a)
{
    return p->scales[k] * esr_grid_voxel_size(g, a);
}

/* Position of sample j (0 = centre, 1 + 6k + 2a + s = neighbour) around x. */
static void sample_pos(const struct esr_grid *g, const struct esr_geo_feature_params *p,
                       const float x[3], int j, float q[3])
{
    q[0] = x[0];
    q[1] = x[1];
    q[2] = x[2];
    if (j == 0)
        return;
    int k = (j - 1) / 6, a = ((j - 1) % 6) / 2, s = (j - 1) % 2;
    q[a] += (s ? 1.0f : -1.0f) * step_of(g, p, k, a);
}

/* SDF values at the 1 + 6K samples of one point. */
static void eval_samples(const struct esr_grid *g, const float *sdf,
                         const struct esr_geo_feature_params *p, const float x[3], float *v)
{
    for (int j = 0; j < 1 + 6 * p->n_scales; j++) {
        float q[3];
        struct esr_trilerp t;
        sample_pos(g, p, x, j, q);
        esr_trilerp_locate(g, q, &t);
        esr_trilerp_fwd(sdf, 1, &t, v + j);
    }
}

int esr_geo_feature_fwd(const struct esr_grid *g, const float *sdf,
                        const struct esr_geo_feature_params *p, const float *pts, size_t n,
                        float *feat)
{
    ESR_TRY(check(g, p));
    const int K = p->n_scales, dim = esr_geo_feature_dim(p);
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++) {
        float *f = feat + i * (size_t)dim;
        eval_samples(g, sdf, p, pts + i * 3, f); /* centre + neighbours land in place */
        for (int k = 0; k < K; k++) {
            float *gr = f + 1 + 6 * K + 3 * k;
            for (int a = 0; a < 3; a++)
                gr[a] = (f[1 + 6 * k + 2 * a + 1] - f[1 + 6 * k + 2 * a]) / (2.0f * step_of(g, p, k, a));
            if (p->normalize) {
                float inv = 1.0f / (sqrtf(gr[0] * gr[0] + gr[1] * gr[1] + gr[2] * gr[2]) + GEO_NORM_EPS);
                gr[0] *= inv;
                gr[1] *= inv;
                gr[2] *= inv;
            }
        }
    }
    return ESR_OK;
}

/* d loss / d (sample values) of one point from d loss / d feat. */
static void sample_grads(const struct esr_grid *g, const float *sdf,
                         const struct esr_geo_feature_params *p, const float x[3],
                         const float *d_feat, float *d_v)
{
    const int K = p->n_scales;
    float v[GEO_MAX_SAMPLES];
    if (p->normalize)
        eval_samples(g, sdf, p, x, v);
    for (int j = 0; j < 1 + 6 * K; j++)
        d_v[j] = d_feat[j];
    for (int k = 0; k < K; k++) {
        const float *d_n = d_feat + 1 + 6 * K + 3 * k;
        float h[3], d_g[3];
        for (int a = 0; a < 3; a++) {
            h[a] = step_of(g, p, k, a);
            d_g[a] = d_n[a];
        }
        if (p->normalize) {
            /* n = g / (L + e), L = |g|: dn/dg = I/(L+e) - g g^T / (L (L+e)^2) */
            float gr[3];
            for (int a = 0; a < 3; a++)
                gr[a] = (v[1 + 6 * k + 2 * a + 1] - v[1 + 6 * k + 2 * a]) / (2.0f * h[a]);
            float L = sqrtf(gr[0] * gr[0] + gr[1] * gr[1] + gr[2] * gr[2]);
            float den = L + GEO_NORM_EPS;
            float gd = gr[0] * d_n[0] + gr[1] * d_n[1] + gr[2] * d_n[2];
            float c = L > 0.0f ? gd / (L * den * den) : 0.0f;
            for (int a = 0; a < 3; a++)
                d_g[a] = d_n[a] / den - gr[a] * c;
        }
        for (int a = 0; a < 3; a++) {
            d_v[1 + 6 * k + 2 * a + 1] += d_g[a] / (2.0f * h[a]);
            d_v[1 + 6 * k + 2 * a] -= d_g[a] / (2.0f * h[a]);
        }
    }
}

int esr_geo_feature_bwd(const struct esr_grid *g, const float *sdf,
                        const struct esr_geo_feature_params *p, const float *pts, size_t n,
                        const float *d_feat, float *grad)
{
    ESR_TRY(check(g, p));
    const int K = p->n_scales, dim = esr_geo_feature_dim(p);
    float reach = 0.0f; /* largest z offset of a neighbour sample */
    for (int k = 0; k < K; k++)
        reach = fmaxf(reach, step_of(g, p, k, 2));
#pragma omp parallel
    {
        int lo, hi;
        esr_grid_own_planes(g, &lo, &hi);
        for (size_t i = 0; i < n; i++) {
            const float *x = pts + i * 3;
            if (esr_trilerp_iz0(g, x[2] + reach) + 1 < lo || esr_trilerp_iz0(g, x[2] - reach) >= hi)
                continue;
            float d_v[GEO_MAX_SAMPLES];
            sample_grads(g, sdf, p, x, d_feat + i * (size_t)dim, d_v);
            for (int j = 0; j < 1 + 6 * K; j++) {
                float q[3];
                struct esr_trilerp t;
                sample_pos(g, p, x, j, q);
                esr_trilerp_locate(g, q, &t);
                esr_trilerp_bwd(grad, 1, &t, d_v + j, lo, hi);
            }
        }
    }
    return ESR_OK;
}
