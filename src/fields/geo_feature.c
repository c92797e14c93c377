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

/* Sample j's axis and offset in voxels (j = 0: the centre, on the x line). */
static float sample_offset(const struct esr_geo_feature_params *p, int j, int *axis)
{
    if (j == 0) {
        *axis = 0;
        return 0.0f;
    }
    const int k = (j - 1) / 6, a = ((j - 1) % 6) / 2, s = (j - 1) % 2;
    *axis = a;
    return s ? p->scales[k] : -p->scales[k];
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
    int a;
    const float off = sample_offset(p, j, &a);
    q[a] += off * esr_grid_voxel_size(g, a);
}

/* The lattice lines of a point. With every scale a multiple of half a voxel and at most
 * LINE_REACH voxels, each sample lies on one of the three lattice lines through the point's cell
 * (along its axis, at the point's fractions on the other two), LINE_LEN lattice values long. The
 * SDF on each line is bilinear in the other two axes' corners, so 3 x 24 loads give all 1 + 6K
 * samples (25 full trilinear lookups take 200), and the backward pass scatters through the same
 * lines. Points within LINE_REACH + 1 voxels of the box's faces (whose samples the box clamps)
 * take the per-sample path. */
#define LINE_REACH 2
#define LINE_LEN (2 * LINE_REACH + 2) /* lattice values i0 - 2 .. i0 + 3 */
struct geo_lines {
    size_t base;       /* lattice index of the point's cell corner (i0x, i0y, i0z); the line
                          along axis a starts LINE_REACH steps of stride[a] before it */
    size_t stride[3];
    int iz0;
    float f[3];        /* the point's fractions in its cell */
    float L[3][LINE_LEN];
};

static int scales_on_lines(const struct esr_geo_feature_params *p)
{
    for (int k = 0; k < p->n_scales; k++) {
        const float twice = 2.0f * p->scales[k];
        if (twice != floorf(twice) || p->scales[k] > (float)LINE_REACH)
            return 0;
    }
    return 1;
}

/* Locates x for the line path; 0 when a sample could reach a face of the box. */
static int lines_locate(const struct esr_grid *g, const float x[3], struct geo_lines *l)
{
    struct esr_trilerp t;
    esr_trilerp_locate(g, x, &t);
    const int n[3] = {g->nx, g->ny, g->nz};
    const size_t i0[3] = {t.base % t.stride[1], t.base / t.stride[1] % (size_t)g->ny,
                          (size_t)t.iz0};
    for (int a = 0; a < 3; a++) {
        if (i0[a] < LINE_REACH || i0[a] + LINE_REACH + 1 >= (size_t)n[a] || t.du[a] == 0.0f)
            return 0;
        l->f[a] = t.f[a];
        l->stride[a] = t.stride[a];
    }
    l->base = t.base;
    l->iz0 = t.iz0;
    return 1;
}

/* The other two axes of axis a, in order. */
static void other_axes(int a, int *b, int *c)
{
    *b = a == 0 ? 1 : 0;
    *c = a == 2 ? 1 : 2;
}

static void lines_values(const float *sdf, struct geo_lines *l)
{
    for (int a = 0; a < 3; a++) {
        int b, c;
        other_axes(a, &b, &c);
        const size_t sb = l->stride[b], sc = l->stride[c];
        const float fb = l->f[b], fc = l->f[c];
        const float *v = sdf + l->base - LINE_REACH * l->stride[a];
        for (int j = 0; j < LINE_LEN; j++, v += l->stride[a]) {
            const float lo = v[0] + fb * (v[sb] - v[0]), hi = v[sc] + fb * (v[sb + sc] - v[sc]);
            l->L[a][j] = lo + fc * (hi - lo);
        }
    }
}

/* Where the sample at s voxels along axis a falls on its line: value index j and fraction. */
static int line_at(const struct geo_lines *l, int a, float s, float *fr)
{
    const float w = l->f[a] + s + (float)LINE_REACH;
    int j = (int)w;
    if (j > LINE_LEN - 2)
        j = LINE_LEN - 2;
    *fr = w - (float)j;
    return j;
}

/* SDF values at the 1 + 6K samples of one point; on_lines: scales_on_lines(p). */
static void eval_samples(const struct esr_grid *g, const float *sdf,
                         const struct esr_geo_feature_params *p, int on_lines, const float x[3],
                         float *v)
{
    struct geo_lines l;
    if (on_lines && lines_locate(g, x, &l)) {
        lines_values(sdf, &l);
        for (int j = 0; j < 1 + 6 * p->n_scales; j++) {
            int a;
            float fr;
            const float off = sample_offset(p, j, &a);
            const int at = line_at(&l, a, off, &fr);
            v[j] = l.L[a][at] + fr * (l.L[a][at + 1] - l.L[a][at]);
        }
        return;
    }
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
    const int K = p->n_scales, dim = esr_geo_feature_dim(p), on_lines = scales_on_lines(p);
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++) {
        float *f = feat + i * (size_t)dim;
        eval_samples(g, sdf, p, on_lines, pts + i * 3, f); /* centre + neighbours land in place */
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
static void sample_grads(const struct esr_grid *g, const struct esr_geo_feature_params *p,
                         const float *v, const float *d_feat, float *d_v)
{
    const int K = p->n_scales;
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

/* Adjoint of eval_samples' line path: d_v (one per sample) onto the lines, then onto the
 * lattice values in z-planes [lo, hi). */
static void lines_bwd(const struct esr_geo_feature_params *p, const struct geo_lines *l,
                      const float *d_v, int lo, int hi, float *grad)
{
    float dL[3][LINE_LEN] = {{0}};
    for (int j = 0; j < 1 + 6 * p->n_scales; j++) {
        int a;
        float fr;
        const float off = sample_offset(p, j, &a);
        const int k = line_at(l, a, off, &fr);
        dL[a][k] += (1.0f - fr) * d_v[j];
        dL[a][k + 1] += fr * d_v[j];
    }
    for (int a = 0; a < 3; a++) {
        int b, c;
        other_axes(a, &b, &c);
        const size_t sb = l->stride[b], sc = l->stride[c];
        const float fb = l->f[b], fc = l->f[c];
        /* z-plane of the line's first value and of its +c corners */
        const int z0 = a == 2 ? l->iz0 - LINE_REACH : l->iz0, zc = c == 2 ? 1 : 0;
        float *gv = grad + l->base - LINE_REACH * l->stride[a];
        for (int j = 0; j < LINE_LEN; j++, gv += l->stride[a]) {
            const int z = z0 + (a == 2 ? j : 0);
            const float d = dL[a][j];
            if (z >= lo && z < hi) {
                gv[0] += (1.0f - fb) * (1.0f - fc) * d;
                gv[sb] += fb * (1.0f - fc) * d;
            }
            if (z + zc >= lo && z + zc < hi) {
                gv[sc] += (1.0f - fb) * fc * d;
                gv[sb + sc] += fb * fc * d;
            }
        }
    }
}

int esr_geo_feature_bwd(const struct esr_grid *g, const struct esr_geo_feature_params *p,
                        const float *pts, size_t n, const float *feat, const float *d_feat,
                        float *grad)
{
    ESR_TRY(check(g, p));
    const int K = p->n_scales, dim = esr_geo_feature_dim(p);
    const int on_lines = scales_on_lines(p);
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
            sample_grads(g, p, feat + i * (size_t)dim, d_feat + i * (size_t)dim, d_v);
            struct geo_lines l;
            if (on_lines && lines_locate(g, x, &l)) {
                lines_bwd(p, &l, d_v, lo, hi, grad);
                continue;
            }
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
