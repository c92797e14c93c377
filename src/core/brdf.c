/* One implementation of the BRDF's formulas (brdf_prep per material, normal and wo; brdf_lane
 * per incident direction; brdf_lane_grad for the backward), used by the single evaluation and
 * by the batched estimator, whose loops over incident directions are branch-free so the compiler
 * vectorises them (ESR_HOT adds an AVX2/FMA clone).
 *
 * Gradients (r the clamped roughness, arg = 2 (h.n - 1) / r^4, A = n.wo (1-k) + k,
 * B = n.wi (1-k) + k, S = (1 - wo.h)^5, spec = D G / (4 n.wo)):
 *   R_c        = spec F_c + n.wi (1-m) b_c / pi,   F_c = F0_c (1 - S) + S
 *   dR_c/db_c  = spec (1 - S) m + n.wi (1-m) / pi
 *   dR_c/dm    = spec (1 - S) (b_c - 0.04) - n.wi b_c / pi
 *   dR_c/dr    = spec F_c (d ln D/dr + d ln G/dr)
 *              = spec F_c ((-4 arg - 4) / r - r (1 - n.wo) / A - r (1 - n.wi) / B)
 * (ln D = arg - ln(pi r^4), d arg/dr = -4 arg / r; ln G = ln(n.wo n.wi) - ln A - ln B,
 * dA/dr = r (1 - n.wo)). */
#include "core/brdf.h"

#include <math.h>
#include <stdint.h>
#include <string.h>

#include "core/fast_exp.h"
#include "core/sampling.h"

/* e^x for x <= 0 (core/fast_exp.h); below -80 it returns 0 (e^-80 = 1.8e-35: every result
 * stays a normal float). */
ESR_INLINE float brdf_exp(float x)
{
    float e = esr_exp_nonpos(x < -80.0f ? -80.0f : x);
    return x < -80.0f ? 0.0f : e;
}

/* Terms that depend on the material, the normal and wo only. */
struct brdf_wo {
    struct esr_vec3 n, wo;
    float n_wo;
    float inv_4nwo;    /* 1 / (4 n.wo) */
    float r;           /* clamped roughness */
    float sharp;       /* 2 / r^4 */
    float d_scale;     /* 1 / (pi r^4) */
    float k, one_k;    /* r^2 / 2, 1 - k */
    float g_o;         /* n.wo / A: G's wo factor */
    float dlog_arg;    /* -4 / r: d ln D / dr = dlog_arg (arg + 1) */
    float dlog_o;      /* -4 / r - r (1 - n.wo) / A: the wi-independent part of d ln(D G) / dr */
    float f0[3];       /* 0.04 (1-m) + b m */
    float diffuse[3];  /* (1-m) b / pi */
    int r_live;        /* the roughness is not clamped: its gradient flows */
};

/* Fills *p; returns 0 when wo is at or below the surface (R = 0 for every wi). */
static inline int brdf_prep(const struct esr_material *mat, struct esr_vec3 n, struct esr_vec3 wo,
                            struct brdf_wo *p)
{
    p->n_wo = esr_v3_dot(n, wo);
    if (p->n_wo <= 0.0f)
        return 0;
    p->n = n;
    p->wo = wo;
    p->r_live = mat->roughness >= ESR_BRDF_MIN_ROUGHNESS;
    float r = fmaxf(mat->roughness, ESR_BRDF_MIN_ROUGHNESS), r2 = r * r, r4 = r2 * r2;
    p->r = r;
    p->sharp = 2.0f / r4;
    p->d_scale = ESR_INV_PI / r4;
    p->k = 0.5f * r2;
    p->one_k = 1.0f - p->k;
    float inv_a = 1.0f / (p->n_wo * p->one_k + p->k);
    p->g_o = p->n_wo * inv_a;
    p->inv_4nwo = 0.25f / p->n_wo;
    p->dlog_arg = -4.0f / r;
    p->dlog_o = p->dlog_arg - r * (1.0f - p->n_wo) * inv_a;
    float m = mat->metallic;
    for (int c = 0; c < 3; c++) {
        p->f0[c] = 0.04f * (1.0f - m) + mat->base[c] * m;
        p->diffuse[c] = (1.0f - m) * mat->base[c] * ESR_INV_PI;
    }
    return 1;
}

/* The wi-dependent factors of R for one unit direction (x, y, z). Branch-free and finite for
 * every direction: below the surface n.wi is taken as 0, which zeroes spec and spec_dr through
 * their n.wi factor (so R = 0 there), and arg = 2 (h.n - 1) / r^4 is never positive (a sum of
 * squares over a positive denominator), so e^arg <= 1. */
struct brdf_lane { /* passed by value: an address-taken local in an omp simd body stops GCC vectorising it */
    float n_wi;    /* max(n.wi, 0) */
    float spec;    /* D G / (4 n.wo) */
    float schlick; /* (1 - wo.h)^5 */
    float spec_dr; /* d spec / d r (the clamped r) */
};

ESR_INLINE struct brdf_lane brdf_lane(const struct brdf_wo *p, float x, float y, float z)
{
    float n_wi = p->n.x * x + p->n.y * y + p->n.z * z;
    n_wi = n_wi > 0.0f ? n_wi : 0.0f;
    /* |wo + wi| from the summed components, not from 2 + 2 wo.wi, which cancels catastrophically
     * near grazing mirror pairs; the 1e-30 only matters for wi = -wo (below the surface), where
     * it keeps the quotients finite */
    float hx = p->wo.x + x, hy = p->wo.y + y, hz = p->wo.z + z;
    float len2 = hx * hx + hy * hy + hz * hz + 1e-30f, len = sqrtf(len2);
    float o_h = 0.5f * len; /* wo.h = (1 + wo.wi) / |wo + wi| = |wo + wi| / 2 */
    float t = 1.0f - (o_h < 1.0f ? o_h : 1.0f), t2 = t * t;
    /* 1 - h.n = |H x n|^2 / (|H| (|H| + H.n)) for H = wo + wi: no cancellation near the mirror
     * direction, where 2 / r^4 multiplies its error (1 - H.n / |H| in float put D off by up to
     * e^13 in the exponent on a review's near-mirror pairs at the roughness floor) */
    float cx = hy * p->n.z - hz * p->n.y, cy = hz * p->n.x - hx * p->n.z, cz = hx * p->n.y - hy * p->n.x;
    float h_n = hx * p->n.x + hy * p->n.y + hz * p->n.z;
    float den = len * (len + h_n);
    float arg = -p->sharp * (cx * cx + cy * cy + cz * cz) / (den > 1e-30f ? den : 1e-30f);
    arg = arg > -1e4f ? arg : -1e4f; /* e^arg is 0 long before; keeps arg d ln D/dr finite */
    float inv_b = 1.0f / (n_wi * p->one_k + p->k);
    struct brdf_lane l;
    l.n_wi = n_wi;
    l.spec = p->d_scale * brdf_exp(arg) * p->g_o * n_wi * inv_b * p->inv_4nwo;
    l.schlick = t2 * t2 * t;
    l.spec_dr = l.spec * (p->dlog_arg * arg + p->dlog_o - p->r * (1.0f - n_wi) * inv_b);
    return l;
}

ESR_INLINE float brdf_fresnel(const struct brdf_wo *p, struct brdf_lane l, int c)
{
    return p->f0[c] + (1.0f - p->f0[c]) * l.schlick;
}

ESR_INLINE float brdf_value(const struct brdf_wo *p, struct brdf_lane l, int c)
{
    return l.spec * brdf_fresnel(p, l, c) + l.n_wi * p->diffuse[c];
}

/* Sums from which the material gradient follows (brdf_finish): for t_c = d loss / d R_c,
 * spec_s[c] += t_c spec (1 - S), cos_i[c] += t_c n.wi, rough += sum_c t_c F_c d spec/dr. */
struct brdf_sums {
    float spec_s[3], cos_i[3], rough;
};

ESR_INLINE struct brdf_sums brdf_lane_grad(const struct brdf_wo *p, struct brdf_lane l, float t0, float t1,
                                           float t2)
{
    struct brdf_sums s;
    float spec_s = l.spec * (1.0f - l.schlick);
    s.spec_s[0] = t0 * spec_s;
    s.spec_s[1] = t1 * spec_s;
    s.spec_s[2] = t2 * spec_s;
    s.cos_i[0] = t0 * l.n_wi;
    s.cos_i[1] = t1 * l.n_wi;
    s.cos_i[2] = t2 * l.n_wi;
    s.rough = (t0 * brdf_fresnel(p, l, 0) + t1 * brdf_fresnel(p, l, 1) + t2 * brdf_fresnel(p, l, 2)) * l.spec_dr;
    return s;
}

/* Adds the material gradient that the sums imply. */
static void brdf_finish(const struct esr_material *mat, const struct brdf_wo *p, const struct brdf_sums *s,
                        struct esr_material *d_mat)
{
    float m = mat->metallic, d_m = 0.0f;
    for (int c = 0; c < 3; c++) {
        d_mat->base[c] += m * s->spec_s[c] + (1.0f - m) * ESR_INV_PI * s->cos_i[c];
        d_m += (mat->base[c] - 0.04f) * s->spec_s[c] - mat->base[c] * ESR_INV_PI * s->cos_i[c];
    }
    d_mat->metallic += d_m;
    if (p->r_live)
        d_mat->roughness += s->rough;
}

void esr_brdf_eval(const struct esr_material *mat, struct esr_vec3 n, struct esr_vec3 wo, struct esr_vec3 wi,
                   float out[3])
{
    struct brdf_wo p;
    if (!brdf_prep(mat, n, wo, &p)) {
        out[0] = out[1] = out[2] = 0.0f;
        return;
    }
    struct brdf_lane l = brdf_lane(&p, wi.x, wi.y, wi.z);
    for (int c = 0; c < 3; c++)
        out[c] = brdf_value(&p, l, c);
}

void esr_brdf_eval_bwd(const struct esr_material *mat, struct esr_vec3 n, struct esr_vec3 wo, struct esr_vec3 wi,
                       const float d_out[3], struct esr_material *d_mat)
{
    struct brdf_wo p;
    if (!brdf_prep(mat, n, wo, &p))
        return;
    struct brdf_lane l = brdf_lane(&p, wi.x, wi.y, wi.z);
    struct brdf_sums s = brdf_lane_grad(&p, l, d_out[0], d_out[1], d_out[2]);
    brdf_finish(mat, &p, &s, d_mat);
}

ESR_HOT void esr_brdf_reflect_fwd(const struct esr_material *mat, struct esr_vec3 n, struct esr_vec3 wo,
                                  const struct esr_brdf_incident *inc, float out[3])
{
    out[0] = out[1] = out[2] = 0.0f;
    struct brdf_wo p;
    if (inc->count <= 0 || !brdf_prep(mat, n, wo, &p))
        return;
    const int count = inc->count;
    const float *ESR_RESTRICT wx = inc->wi, *ESR_RESTRICT wy = wx + count, *ESR_RESTRICT wz = wy + count;
    const float *ESR_RESTRICT l0 = inc->li, *ESR_RESTRICT l1 = l0 + count, *ESR_RESTRICT l2 = l1 + count;
    const float *ESR_RESTRICT weight = inc->weight;
    float s0 = 0.0f, s1 = 0.0f, s2 = 0.0f;
#pragma omp simd reduction(+ : s0, s1, s2)
    for (int j = 0; j < count; j++) {
        struct brdf_lane l = brdf_lane(&p, wx[j], wy[j], wz[j]);
        float w = weight[j];
        s0 += w * l0[j] * brdf_value(&p, l, 0);
        s1 += w * l1[j] * brdf_value(&p, l, 1);
        s2 += w * l2[j] * brdf_value(&p, l, 2);
    }
    out[0] = s0;
    out[1] = s1;
    out[2] = s2;
}

/* The backward loop; always inlined into esr_brdf_reflect_bwd with a literal want_li, so the
 * d_li stores are compiled in or out rather than tested per direction. */
ESR_INLINE void reflect_bwd_loop(const struct brdf_wo *pp, const struct esr_brdf_incident *inc, const float d_out[3],
                                 float *ESR_RESTRICT d_li, int want_li, struct brdf_sums *sums)
{
    const struct brdf_wo p = *pp;
    const int count = inc->count;
    const float *ESR_RESTRICT wx = inc->wi, *ESR_RESTRICT wy = wx + count, *ESR_RESTRICT wz = wy + count;
    const float *ESR_RESTRICT l0 = inc->li, *ESR_RESTRICT l1 = l0 + count, *ESR_RESTRICT l2 = l1 + count;
    const float *ESR_RESTRICT weight = inc->weight;
    const float g0 = d_out[0], g1 = d_out[1], g2 = d_out[2];
    float a0 = 0.0f, a1 = 0.0f, a2 = 0.0f, b0 = 0.0f, b1 = 0.0f, b2 = 0.0f, rough = 0.0f;
#pragma omp simd reduction(+ : a0, a1, a2, b0, b1, b2, rough)
    for (int j = 0; j < count; j++) {
        struct brdf_lane l = brdf_lane(&p, wx[j], wy[j], wz[j]);
        float w = weight[j], e0 = g0 * w, e1 = g1 * w, e2 = g2 * w;
        if (want_li) {
            d_li[j] += e0 * brdf_value(&p, l, 0);
            d_li[count + j] += e1 * brdf_value(&p, l, 1);
            d_li[2 * count + j] += e2 * brdf_value(&p, l, 2);
        }
        struct brdf_sums s = brdf_lane_grad(&p, l, e0 * l0[j], e1 * l1[j], e2 * l2[j]);
        a0 += s.spec_s[0];
        a1 += s.spec_s[1];
        a2 += s.spec_s[2];
        b0 += s.cos_i[0];
        b1 += s.cos_i[1];
        b2 += s.cos_i[2];
        rough += s.rough;
    }
    sums->spec_s[0] = a0;
    sums->spec_s[1] = a1;
    sums->spec_s[2] = a2;
    sums->cos_i[0] = b0;
    sums->cos_i[1] = b1;
    sums->cos_i[2] = b2;
    sums->rough = rough;
}

ESR_HOT void esr_brdf_reflect_bwd(const struct esr_material *mat, struct esr_vec3 n, struct esr_vec3 wo,
                                  const struct esr_brdf_incident *inc, const float d_out[3], struct esr_material *d_mat,
                                  float *d_li)
{
    struct brdf_wo p;
    if (inc->count <= 0 || !brdf_prep(mat, n, wo, &p))
        return;
    struct brdf_sums sums;
    if (d_li)
        reflect_bwd_loop(&p, inc, d_out, d_li, 1, &sums);
    else
        reflect_bwd_loop(&p, inc, d_out, NULL, 0, &sums);
    if (d_mat)
        brdf_finish(mat, &p, &sums, d_mat);
}
