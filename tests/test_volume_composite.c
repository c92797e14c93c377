/* Compositing forward/backward, pruning rules, and an end-to-end gradient check through one
 * ray: SDF grid + colour grid -> samples -> NeuS alpha -> composite on white -> MSE. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "fields/grid.h"
#include "fields/sdf.h"
#include "volume/composite.h"
#include "volume/neus.h"
#include "volume/sampler.h"
#include "test_grad.h"

/* Straightforward reference: out = sum T_i a_i v_i + T_N bg in double, no pruning. */
static void reference(const float *alpha, const float *v, size_t n, int C, const float *bg, double *out)
{
    double T = 1.0;
    for (int c = 0; c < C; c++)
        out[c] = 0.0;
    for (size_t i = 0; i < n; i++) {
        for (int c = 0; c < C; c++)
            out[c] += T * alpha[i] * v[i * C + c];
        T *= 1.0 - alpha[i];
    }
    for (int c = 0; c < C; c++)
        out[c] += T * bg[c];
}

static void test_forward_and_pruning(void **state)
{
    (void)state;
    const size_t start[3] = {0, 4, 6};
    const float alpha[6] = {0.5f, 0.00005f, 0.25f, 1.0f, 0.2f, 0.3f};
    const float v[6 * 2] = {1, 2, 100, 100, 3, 4, 5, 6, 7, 8, 9, 10};
    const float bg[2] = {1.0f, 1.0f};
    float w[6], tl[2], out[4];
    esr_composite_weights(2, start, alpha, ESR_COMPOSITE_THRES, w, tl);
    assert_true(w[1] == 0.0f); /* alpha below threshold: dropped, no attenuation */
    assert_true(fabsf(w[2] - 0.125f) < 1e-7f && fabsf(w[3] - 0.375f) < 1e-7f);
    assert_true(tl[0] == 0.0f);
    assert_true(fabsf(tl[1] - 0.56f) < 1e-6f);
    struct esr_composite_args a = {2, start, alpha, w, tl, ESR_COMPOSITE_THRES, 2, v, bg, 0, NULL};
    esr_composite_fwd(&a, out);
    assert_true(fabsf(out[0] - (0.5f + 0.125f * 3 + 0.375f * 5)) < 1e-5f);
    assert_true(fabsf(out[1] - (1.0f + 0.125f * 4 + 0.375f * 6)) < 1e-5f);
    assert_true(fabsf(out[2] - (0.2f * 7 + 0.24f * 9 + 0.56f)) < 1e-5f);
    /* a weight below threshold: value never read (NaN there must not leak) but still attenuates */
    const size_t s1[2] = {0, 3};
    const float a1[3] = {0.9999f, 0.5f, 0.5f};
    const float v1[3] = {1.0f, NAN, NAN};
    float w1[3], t1, o1;
    esr_composite_weights(1, s1, a1, ESR_COMPOSITE_THRES, w1, &t1);
    assert_false(esr_composite_keep(w1[1], ESR_COMPOSITE_THRES));
    struct esr_composite_args b = {1, s1, a1, w1, &t1, ESR_COMPOSITE_THRES, 1, v1, bg, 0, NULL};
    esr_composite_fwd(&b, &o1);
    assert_true(fabsf(o1 - (0.9999f + 0.0001f * 0.25f)) < 1e-6f);
}

/* Backward against central differences of a double reference, several rays, random data with
 * per-ray background (as the LTS environment term uses). */
/* The front layer: a ray through a faint haze, a half-transparent surface and, 2 units further,
 * an opaque one composites only the first surface's samples (from the first weight above the
 * minimum to `depth` behind it), and the rest is the full composite minus it; a ray with one
 * surface gets all of it; an empty ray gets nothing. */
static void test_front_layer(void **state)
{
    (void)state;
    const size_t start[4] = {0, 6, 9, 10};
    /* ray 0: haze (weight below min), surface at t 1.0-1.2, surface at t 3.0-3.1 */
    const float alpha[10] = {0.001f, 0.3f, 0.2f, 0.1f, 0.6f, 0.9f, 0.5f, 0.5f, 0.5f, 0.00001f};
    const float t[10] = {0.5f, 1.0f, 1.1f, 1.2f, 3.0f, 3.1f, 2.0f, 2.05f, 2.1f, 1.0f};
    const float v[10 * 2] = {9, 9, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 1, 1, 2, 2, 3, 3, 4, 4};
    float w[10], tl[3], full[6], front[6], opac[3], tm[3];
    esr_composite_weights(3, start, alpha, ESR_COMPOSITE_THRES, w, tl);
    struct esr_composite_args a = {3, start, alpha, w, tl, ESR_COMPOSITE_THRES, 2, v, NULL, 0, NULL};
    esr_composite_fwd(&a, full);
    esr_composite_front(&a, t, 0.01f, 0.5f, front, opac, tm);
    const double w1 = w[1] + w[2] + w[3];
    assert_true(fabs(opac[0] - w1) < 1e-6);
    assert_true(fabs(tm[0] - (w[1] * 1.0 + w[2] * 1.1 + w[3] * 1.2) / w1) < 1e-6);
    assert_true(fabs(front[0] - (w[1] * 1 + w[2] * 3 + w[3] * 5)) < 1e-6);
    assert_true(fabs(front[1] - (w[1] * 2 + w[2] * 4 + w[3] * 6)) < 1e-6);
    /* what is left is the second surface and the haze */
    assert_true(fabs((full[0] - front[0]) - (w[0] * 9 + w[4] * 7 + w[5] * 9)) < 1e-5);
    /* one surface: all of it */
    assert_true(fabs(opac[1] - (1.0f - tl[1])) < 1e-6 && fabs(front[2] - full[2]) < 1e-6);
    assert_true(fabs(tm[1] - (w[6] * 2.0 + w[7] * 2.05 + w[8] * 2.1) / (1.0 - tl[1])) < 1e-6);
    /* nothing kept */
    assert_true(opac[2] == 0.0f && tm[2] == 0.0f && front[4] == 0.0f && front[5] == 0.0f);
}

static void test_backward_fd(void **state)
{
    (void)state;
    enum { R = 5, C = 3, MAXN = 12 };
    size_t start[R + 1] = {0};
    for (int r = 0; r < R; r++)
        start[r + 1] = start[r] + (size_t)(r * 3 % MAXN) + 1;
    size_t n = start[R];
    float *alpha = malloc(n * sizeof(float)), *v = malloc(n * C * sizeof(float));
    float *w = malloc(n * sizeof(float)), *da = calloc(n, sizeof(float)), *dv = calloc(n * C, sizeof(float));
    float bg[R * C], d_out[R * C], tl[R];
    test_fill_uniform(alpha, n, 0.01f, 0.9f, 31);
    test_fill_uniform(v, n * C, -1.0f, 2.0f, 32);
    test_fill_uniform(bg, R * C, 0.0f, 1.0f, 33);
    test_fill_uniform(d_out, R * C, -1.0f, 1.0f, 34);
    alpha[2] = 0.99999f; /* nearly opaque: the division-free backward must stay accurate */
    esr_composite_weights(R, start, alpha, 0.0f, w, tl);
    struct esr_composite_args a = {R, start, alpha, w, tl, 0.0f, C, v, bg, 1, NULL};
    esr_composite_bwd(&a, d_out, da, dv);
    for (int r = 0; r < R; r++) {
        size_t s0 = start[r], m = start[r + 1] - s0;
        for (size_t i = s0; i < s0 + m; i++) {
            double op[C], om[C];
            const float h = 1e-3f;
            float keep = alpha[i];
            alpha[i] = keep + h;
            reference(alpha + s0, v + s0 * C, m, C, bg + r * C, op);
            alpha[i] = keep - h;
            reference(alpha + s0, v + s0 * C, m, C, bg + r * C, om);
            alpha[i] = keep;
            double fd = 0.0;
            for (int c = 0; c < C; c++)
                fd += d_out[r * C + c] * (op[c] - om[c]) / (2.0 * h);
            assert_true(test_close(da[i], fd, 1e-4, 1e-3));
            for (int c = 0; c < C; c++)
                assert_true(test_close(dv[i * C + c], w[i] * d_out[r * C + c], 1e-7, 1e-6));
        }
    }
    free(alpha);
    free(v);
    free(w);
    free(da);
    free(dv);
}

/* ---- end to end ---- */

struct scene {
    struct esr_grid gs, gc;
    float *sdf, *col;
    struct esr_samples smp;
    float s, anneal, dt;
    float dir[3];
    float target[3];
};

/* Per-sample forward state of the pipeline (sized for the one ray). */
struct fwd_state {
    float f[64], dp[64 * 3], cosv[64], fp[64], fn[64], alpha[64], w[64], c[64 * 3], tl, out[3];
};

static double forward(struct scene *sc, struct fwd_state *st)
{
    size_t n = sc->smp.count;
    esr_grid_sample_fwd(&sc->gs, sc->sdf, sc->smp.pos, n, st->f);
    esr_grid_sample_dpoint(&sc->gs, sc->sdf, 0, sc->smp.pos, n, st->dp);
    esr_grid_sample_fwd(&sc->gc, sc->col, sc->smp.pos, n, st->c);
    for (size_t i = 0; i < n; i++) {
        const float *g = st->dp + i * 3;
        st->cosv[i] = sc->dir[0] * g[0] + sc->dir[1] * g[1] + sc->dir[2] * g[2];
        esr_neus_section_fwd(st->f[i], st->cosv[i], sc->dt, sc->anneal, &st->fp[i], &st->fn[i]);
        st->alpha[i] = esr_neus_alpha_fwd(st->fp[i], st->fn[i], sc->s);
    }
    esr_composite_weights(1, sc->smp.ray_start, st->alpha, ESR_COMPOSITE_THRES, st->w, &st->tl);
    const float white[3] = {1, 1, 1};
    struct esr_composite_args a = {1, sc->smp.ray_start, st->alpha, st->w, &st->tl, ESR_COMPOSITE_THRES, 3, st->c, white, 0, NULL};
    esr_composite_fwd(&a, st->out);
    double loss = 0.0;
    for (int c = 0; c < 3; c++)
        loss += ((double)st->out[c] - sc->target[c]) * ((double)st->out[c] - sc->target[c]);
    return loss;
}

static void backward(struct scene *sc, struct fwd_state *st, float *g_sdf, float *g_col)
{
    size_t n = sc->smp.count;
    float d_out[3], da[64] = {0}, dc[64 * 3] = {0}, d_mid[64], d_grad[64 * 3];
    for (int c = 0; c < 3; c++)
        d_out[c] = 2.0f * (st->out[c] - sc->target[c]);
    const float white[3] = {1, 1, 1};
    struct esr_composite_args a = {1, sc->smp.ray_start, st->alpha, st->w, &st->tl, ESR_COMPOSITE_THRES, 3, st->c, white, 0, NULL};
    esr_composite_bwd(&a, d_out, da, dc);
    for (size_t i = 0; i < n; i++) {
        float d_prev, d_next, d_cos;
        esr_neus_alpha_bwd(st->fp[i], st->fn[i], sc->s, da[i], &d_prev, &d_next, NULL);
        esr_neus_section_bwd(st->cosv[i], sc->dt, sc->anneal, d_prev, d_next, &d_mid[i], &d_cos);
        for (int k = 0; k < 3; k++)
            d_grad[i * 3 + k] = d_cos * sc->dir[k];
    }
    esr_grid_sample_bwd(&sc->gs, sc->smp.pos, n, d_mid, g_sdf);
    esr_grid_sample_dpoint_bwd(&sc->gs, 0, sc->smp.pos, n, d_grad, g_sdf);
    esr_grid_sample_bwd(&sc->gc, sc->smp.pos, n, dc, g_col);
}

static void test_end_to_end_one_ray(void **state)
{
    (void)state;
    struct scene sc;
    const float bmin[3] = {-1.5f, -1.5f, -1.5f}, bmax[3] = {1.5f, 1.5f, 1.5f};
    assert_int_equal(esr_grid_init(&sc.gs, 1, 9, 9, 9, bmin, bmax), ESR_OK);
    assert_int_equal(esr_grid_init(&sc.gc, 3, 5, 5, 5, bmin, bmax), ESR_OK);
    size_t ns = esr_grid_count(&sc.gs), nc = esr_grid_count(&sc.gc);
    sc.sdf = malloc(ns * sizeof(float));
    sc.col = malloc(nc * sizeof(float));
    assert_int_equal(esr_sdf_init_sphere(&sc.gs, sc.sdf, 0.6f), ESR_OK);
    float *noise = malloc(ns * sizeof(float));
    test_fill_uniform(noise, ns, -0.05f, 0.05f, 41);
    for (size_t e = 0; e < ns; e++)
        sc.sdf[e] += noise[e];
    test_fill_uniform(sc.col, nc, 0.0f, 1.0f, 42);
    sc.s = 8.0f;
    sc.anneal = 0.5f;
    const float o[3] = {0.3f, -0.2f, 4.0f};
    float dl = sqrtf(0.05f * 0.05f + 0.02f * 0.02f + 1.0f);
    sc.dir[0] = -0.05f / dl;
    sc.dir[1] = 0.02f / dl;
    sc.dir[2] = -1.0f / dl;
    sc.target[0] = 0.2f;
    sc.target[1] = 0.9f;
    sc.target[2] = 0.4f;
    sc.dt = 0.5f * esr_grid_voxel_size(&sc.gs, 0);
    struct esr_sample_params p;
    esr_sample_params_init(&p, bmin, bmax, sc.dt);
    assert_int_equal(esr_samples_alloc(&sc.smp, 64, 1), ESR_OK);
    assert_int_equal(esr_sample_rays(&p, o, sc.dir, 1, &sc.smp), ESR_OK);
    assert_true(sc.smp.count > 10 && sc.smp.count <= 64);

    struct fwd_state st;
    forward(&sc, &st);
    assert_true(st.tl < 0.9f); /* the ray does hit the sphere */
    float *g_sdf = calloc(ns, sizeof(float)), *g_col = calloc(nc, sizeof(float));
    backward(&sc, &st, g_sdf, g_col);
    int nonzero = 0;
    for (int pass = 0; pass < 2; pass++) {
        float *data = pass ? sc.col : sc.sdf, *grad = pass ? g_col : g_sdf;
        size_t cnt = pass ? nc : ns;
        for (size_t e = 0; e < cnt; e++) {
            if (grad[e] == 0.0f)
                continue;
            const float h = 1e-3f;
            float keep = data[e];
            data[e] = keep + h;
            double lp = forward(&sc, &st);
            data[e] = keep - h;
            double lm = forward(&sc, &st);
            data[e] = keep;
            assert_true(test_close(grad[e], (lp - lm) / (2.0 * h), 2e-3, 3e-2));
            nonzero++;
        }
    }
    assert_true(nonzero > 10);
    esr_samples_free(&sc.smp);
    free(sc.sdf);
    free(sc.col);
    free(noise);
    free(g_sdf);
    free(g_col);
}

/* d T_N / d alpha against central differences of esr_composite_weights' T_N, on a ray with a
 * pruned sample, and exactly on a ray with an opaque sample (alpha = 1: only it has a non-zero
 * derivative, minus the product of the others). */
static void test_t_last_backward(void **state)
{
    (void)state;
    float alpha[7] = {0.3f, 0.00005f, 0.6f, 0.2f, 0.9f, /* ray 2: */ 0.5f, 1.0f};
    const size_t start[3] = {0, 5, 7};
    float weight[7], t_last[2], d_alpha[7] = {0};
    const float d_t[2] = {1.5f, -2.0f};
    esr_composite_t_last_bwd(2, start, alpha, ESR_COMPOSITE_THRES, d_t, d_alpha);
    for (int i = 0; i < 5; i++) {
        const float keep = alpha[i], eps = 1e-3f;
        alpha[i] = keep + eps;
        esr_composite_weights(2, start, alpha, ESR_COMPOSITE_THRES, weight, t_last);
        const double tp = t_last[0];
        alpha[i] = keep - eps;
        esr_composite_weights(2, start, alpha, ESR_COMPOSITE_THRES, weight, t_last);
        const double tm = t_last[0];
        alpha[i] = keep;
        const double fd = i == 1 ? 0.0 : d_t[0] * (tp - tm) / (2.0 * eps); /* pruned: none */
        assert_float_equal(d_alpha[i], fd, 1e-4);
    }
    assert_float_equal(d_alpha[5], 0.0, 0.0);                /* 1 - alpha_6 = 0 */
    assert_float_equal(d_alpha[6], -d_t[1] * (1.0 - 0.5), 1e-7); /* -d x (1 - alpha_5) */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_forward_and_pruning),
        cmocka_unit_test(test_front_layer),
        cmocka_unit_test(test_backward_fd),
        cmocka_unit_test(test_end_to_end_one_ray),
        cmocka_unit_test(test_t_last_backward),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
