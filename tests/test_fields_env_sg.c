/* Spherical-Gaussian environment map: forward against a separate double-precision evaluation,
 * every gradient entry against central differences of that evaluation, accumulation and thread
 * independence of the backward, initialisation, a start at a chosen colour, and the
 * equirectangular image's mapping. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/rng.h"
#include "core/sampling.h"
#include "fields/env_sg.h"
#include "test_grad.h"

/* The documented layout, written out here rather than read from the header's helper. */
static size_t at(int K, int block, int k) { return (size_t)block * (size_t)K + (size_t)k; }

/* env_c(d) = softplus(sum_k mu_kc exp(|lambda_k| (d . xi_k/|xi_k| - 1))), in double. */
static void ref_env(const double *p, int K, const double d[3], double out[3])
{
    for (int c = 0; c < 3; c++) {
        double s = 0.0;
        for (int k = 0; k < K; k++) {
            double x = p[at(K, 0, k)], y = p[at(K, 1, k)], z = p[at(K, 2, k)];
            double cosang = (d[0] * x + d[1] * y + d[2] * z) / sqrt(x * x + y * y + z * z);
            s += p[at(K, 4 + c, k)] * exp(fabs(p[at(K, 3, k)]) * (cosang - 1.0));
        }
        out[c] = s > 30.0 ? s + log1p(exp(-s)) : log1p(exp(s));
    }
}

/* Random parameters: axes of length 0.5..2 in any direction, |lambda| in [lam_lo, lam_hi) with
 * either sign, mu in [-mu_max, mu_max). */
static void random_params(float *p, int K, float lam_lo, float lam_hi, float mu_max, uint64_t seed)
{
    struct esr_rng rng = esr_rng_init(seed, 99);
    for (int k = 0; k < K; k++) {
        struct esr_vec3 u = esr_sample_sphere_uniform(esr_rng_float(&rng), esr_rng_float(&rng));
        float len = 0.5f + 1.5f * esr_rng_float(&rng);
        p[at(K, 0, k)] = u.x * len;
        p[at(K, 1, k)] = u.y * len;
        p[at(K, 2, k)] = u.z * len;
        float lam = lam_lo + (lam_hi - lam_lo) * esr_rng_float(&rng);
        p[at(K, 3, k)] = esr_rng_float(&rng) < 0.5f ? -lam : lam;
        for (int c = 0; c < 3; c++)
            p[at(K, 4 + c, k)] = mu_max * (2.0f * esr_rng_float(&rng) - 1.0f);
    }
}

static void random_dirs(float *d, size_t n, uint64_t seed)
{
    struct esr_rng rng = esr_rng_init(seed, 7);
    for (size_t i = 0; i < n; i++) {
        struct esr_vec3 u = esr_sample_sphere_uniform(esr_rng_float(&rng), esr_rng_float(&rng));
        d[i * 3] = u.x;
        d[i * 3 + 1] = u.y;
        d[i * 3 + 2] = u.z;
    }
}

static void test_counts_and_bad_lobes(void **state)
{
    (void)state;
    assert_int_equal(esr_env_sg_param_count(48), 336);
    assert_int_equal(esr_env_sg_param_count(1), 7);
    assert_int_equal(esr_env_sg_param_count(0), 0);
    assert_int_equal(esr_env_sg_param_count(ESR_ENV_SG_MAX_LOBES + 1), 0);
    assert_int_equal(esr_env_sg_check_lobes(ESR_ENV_SG_LOBES), ESR_OK);
    assert_int_equal(esr_env_sg_check_lobes(0), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "lobes"));
    esr_error_clear();
    for (int b = 0; b < ESR_ENV_SG_BLOCKS; b++)
        assert_int_equal(esr_env_sg_index(5, (enum esr_env_sg_block)b, 3), at(5, b, 3));
}

/* The forward against ref_env on random maps (48 and 3 lobes), including directions exactly on
 * a lobe's axis and a map large enough to reach softplus's linear region. */
static void test_fwd_matches_reference(void **state)
{
    (void)state;
    enum { N = 700 }; /* above the kernel's parallel threshold */
    const int lobes[2] = {ESR_ENV_SG_LOBES, 3};
    for (int t = 0; t < 2; t++) {
        const int K = lobes[t];
        const size_t P = esr_env_sg_param_count(K);
        float *p = malloc(P * sizeof(float)), *dirs = malloc(N * 3 * sizeof(float));
        float *out = malloc(N * 3 * sizeof(float));
        double *pd = malloc(P * sizeof(double));
        random_params(p, K, 1.0f, 60.0f, t == 0 ? 2.0f : 30.0f, 11 + (uint64_t)t);
        random_dirs(dirs, N, 5 + (uint64_t)t);
        if (t == 1) /* a bright lobe 0: the sum on its axis is far into softplus's linear branch */
            for (int c = 0; c < 3; c++)
                p[at(K, 4 + c, 0)] = 40.0f + (float)c;
        for (int k = 0; k < K && k < 10; k++) { /* a direction on axis k */
            float x = p[at(K, 0, k)], y = p[at(K, 1, k)], z = p[at(K, 2, k)], len = sqrtf(x * x + y * y + z * z);
            dirs[k * 3] = x / len;
            dirs[k * 3 + 1] = y / len;
            dirs[k * 3 + 2] = z / len;
        }
        for (size_t j = 0; j < P; j++)
            pd[j] = p[j];
        esr_env_sg_fwd(p, K, dirs, N, out);
        double big = 0.0;
        for (int i = 0; i < N; i++) {
            const double d[3] = {dirs[i * 3], dirs[i * 3 + 1], dirs[i * 3 + 2]};
            double ref[3];
            ref_env(pd, K, d, ref);
            for (int c = 0; c < 3; c++) {
                big = fmax(big, ref[c]);
                if (!test_close(out[i * 3 + c], ref[c], 1e-6, 2e-5))
                    fail_msg("K %d, direction %d, channel %d: %.8g vs reference %.8g", K, i, c,
                             (double)out[i * 3 + c], ref[c]);
            }
        }
        if (t == 1)
            assert_true(big > 25.0); /* the linear branch of the softplus was exercised */
        free(p);
        free(dirs);
        free(out);
        free(pd);
    }
}

/* Every parameter entry of a 4-lobe map: the backward against central differences (in double,
 * of the reference) of loss = sum_i sum_c d_rgb[i,c] env_c(d_i), directions near the lobes so
 * every entry's gradient is sizeable. */
static void test_bwd_fd_every_entry(void **state)
{
    (void)state;
    enum { K = 4, N = 8, P = 7 * K };
    float p[P], dirs[N * 3], d_rgb[N * 3], grad[P];
    double pd[P];
    random_params(p, K, 2.0f, 12.0f, 1.5f, 21);
    test_fill_uniform(d_rgb, N * 3, -1.0f, 1.0f, 22);
    struct esr_rng rng = esr_rng_init(23, 0);
    for (int i = 0; i < N; i++) { /* axis of lobe i % K plus a random offset, normalised */
        int k = i % K;
        double v[3], len = 0.0;
        for (int a = 0; a < 3; a++) {
            v[a] = p[at(K, a, k)] / sqrt((double)p[at(K, 0, k)] * p[at(K, 0, k)] + (double)p[at(K, 1, k)] * p[at(K, 1, k)] +
                                         (double)p[at(K, 2, k)] * p[at(K, 2, k)]) +
                   0.4 * (esr_rng_float(&rng) - 0.5);
            len += v[a] * v[a];
        }
        for (int a = 0; a < 3; a++)
            dirs[i * 3 + a] = (float)(v[a] / sqrt(len));
    }
    memset(grad, 0, sizeof grad);
    esr_env_sg_bwd(p, K, dirs, N, d_rgb, grad);
    for (int j = 0; j < P; j++)
        pd[j] = p[j];
    double fd[P], gmax = 0.0;
    for (int j = 0; j < P; j++) {
        const double h = 1e-5 * fmax(1.0, fabs(pd[j])), keep = pd[j];
        double loss[2];
        for (int side = 0; side < 2; side++) {
            pd[j] = keep + (side ? -h : h);
            loss[side] = 0.0;
            for (int i = 0; i < N; i++) {
                const double d[3] = {dirs[i * 3], dirs[i * 3 + 1], dirs[i * 3 + 2]};
                double e[3];
                ref_env(pd, K, d, e);
                for (int c = 0; c < 3; c++)
                    loss[side] += d_rgb[i * 3 + c] * e[c];
            }
        }
        pd[j] = keep;
        fd[j] = (loss[0] - loss[1]) / (2.0 * h);
        gmax = fmax(gmax, fabs(fd[j]));
    }
    double max_rel = 0.0;
    for (int j = 0; j < P; j++) {
        double err = fabs(grad[j] - fd[j]), rel = err / fmax(fabs(fd[j]), 1e-3 * gmax);
        max_rel = fmax(max_rel, rel);
        if (!test_close(grad[j], fd[j], 1e-6 * gmax, 1e-4))
            fail_msg("entry %d (block %d, lobe %d): analytic %.8g vs central difference %.8g", j, j / K,
                     j % K, (double)grad[j], fd[j]);
        assert_true(fabs(fd[j]) > 1e-4 * gmax); /* every entry carries a real gradient */
    }
    print_message("env_sg gradient, %d entries: max relative error %.3g (largest |grad| %.3g)\n", P,
                  max_rel, gmax);
}

/* The backward adds into grad_params (start + the result from zero, up to the rounding of a fused
 * multiply-add) and gives bitwise the same result with 1, 2 and 3 threads over several
 * direction chunks. */
static void test_bwd_accumulates_and_is_thread_independent(void **state)
{
    (void)state;
    enum { N = 3000 };
    const int K = 45; /* thread shares of 22/23 and 15 lobes: not multiples of a vector width */
    const size_t P = esr_env_sg_param_count(K);
    float *p = malloc(P * sizeof(float)), *dirs = malloc(N * 3 * sizeof(float));
    float *d_rgb = malloc(N * 3 * sizeof(float)), *start = malloc(P * sizeof(float));
    float *from_zero = calloc(P, sizeof(float)), *got[3];
    random_params(p, K, 1.0f, 40.0f, 1.0f, 31);
    random_dirs(dirs, N, 32);
    test_fill_uniform(d_rgb, N * 3, -1.0f, 1.0f, 33);
    test_fill_uniform(start, P, -5.0f, 5.0f, 34);
    const int saved = omp_get_max_threads();
    omp_set_num_threads(1);
    esr_env_sg_bwd(p, K, dirs, N, d_rgb, from_zero);
    for (int t = 0; t < 3; t++) {
        got[t] = malloc(P * sizeof(float));
        memcpy(got[t], start, P * sizeof(float));
        omp_set_num_threads(t + 1);
        esr_env_sg_bwd(p, K, dirs, N, d_rgb, got[t]);
    }
    omp_set_num_threads(saved);
    for (size_t j = 0; j < P; j++) {
        if (!test_close(got[0][j], (double)start[j] + from_zero[j], 1e-6, 1e-6))
            fail_msg("entry %zu: %.9g after adding to %.9g, %.9g from zero", j, (double)got[0][j],
                     (double)start[j], (double)from_zero[j]);
        assert_true(from_zero[j] != 0.0f);
    }
    assert_memory_equal(got[0], got[1], P * sizeof(float));
    assert_memory_equal(got[0], got[2], P * sizeof(float));
    for (int t = 0; t < 3; t++)
        free(got[t]);
    free(p);
    free(dirs);
    free(d_rgb);
    free(start);
    free(from_zero);
}

static double axis_angle(const float *p, int K, int a, int b)
{
    double dot = 0.0;
    for (int c = 0; c < 3; c++)
        dot += (double)p[at(K, c, a)] * p[at(K, c, b)];
    return acos(fmin(1.0, fmax(-1.0, dot)));
}

/* Unit axes spread over the sphere (smallest pairwise angle, centroid at the origin, both
 * hemispheres equally), lambda = 10 + |20 N(0,1)| (>= 10, mean ~ 10 + 20 sqrt(2/pi)), mu = 0 so
 * the map is ln 2 everywhere, and the same values for the same seed. */
static void test_init(void **state)
{
    (void)state;
    const int K = ESR_ENV_SG_LOBES;
    const size_t P = esr_env_sg_param_count(K);
    float *a = malloc(P * sizeof(float)), *b = malloc(P * sizeof(float)), *c = malloc(P * sizeof(float));
    esr_env_sg_init(a, K, 7);
    esr_env_sg_init(b, K, 7);
    esr_env_sg_init(c, K, 8);
    assert_memory_equal(a, b, P * sizeof(float));
    assert_memory_equal(a, c, 3 * K * sizeof(float)); /* axes do not depend on the seed */
    assert_memory_not_equal(a + 3 * K, c + 3 * K, K * sizeof(float));
    double mean[3] = {0, 0, 0}, min_angle = M_PI, lam_sum = 0.0;
    int up = 0;
    for (int k = 0; k < K; k++) {
        double len = 0.0;
        for (int ax = 0; ax < 3; ax++) {
            len += (double)a[at(K, ax, k)] * a[at(K, ax, k)];
            mean[ax] += a[at(K, ax, k)] / K;
        }
        assert_true(fabs(sqrt(len) - 1.0) < 1e-6);
        up += a[at(K, 2, k)] > 0.0f;
        float lam = a[at(K, 3, k)];
        assert_true(lam >= 10.0f && lam < 10.0f + 20.0f * 7.0f);
        lam_sum += lam;
        for (int ch = 0; ch < 3; ch++)
            assert_true(a[at(K, 4 + ch, k)] == 0.0f);
        for (int j = 0; j < k; j++)
            min_angle = fmin(min_angle, axis_angle(a, K, j, k));
    }
    /* 48 points evenly spread are ~29 degrees apart (sqrt(4 pi / 48) rad); the spiral gets 25.8 */
    print_message("env_sg init: smallest angle between axes %.1f deg, mean lambda %.1f\n",
                  min_angle * 180.0 / M_PI, lam_sum / K);
    assert_true(min_angle > 22.0 * M_PI / 180.0);
    assert_true(sqrt(mean[0] * mean[0] + mean[1] * mean[1] + mean[2] * mean[2]) < 0.02);
    assert_int_equal(up, K / 2);
    assert_true(lam_sum / K > 10.0 + 16.0 - 6.0 && lam_sum / K < 10.0 + 16.0 + 6.0);
    float dirs[5 * 3], out[5 * 3];
    random_dirs(dirs, 5, 9);
    esr_env_sg_fwd(a, K, dirs, 5, out);
    for (int j = 0; j < 15; j++)
        assert_true(fabsf(out[j] - logf(2.0f)) < 1e-6f);
    free(a);
    free(b);
    free(c);
}

/* A start at a chosen colour: each channel's mean over the sphere (4096 random directions, not
 * the setter's 512-point spiral) is its level, every lobe of a channel shares one mu, and a
 * channel's level leaves the others' mu alone. */
static void test_set_level(void **state)
{
    (void)state;
    const int K = ESR_ENV_SG_LOBES;
    enum { N = 4096 };
    const size_t P = esr_env_sg_param_count(K);
    float *p = malloc(P * sizeof(float)), *q = malloc(P * sizeof(float));
    float *dirs = malloc(N * 3 * sizeof(float)), *rgb = malloc(N * 3 * sizeof(float));
    random_dirs(dirs, N, 17);
    esr_env_sg_init(p, K, 3);
    const float level[3] = {0.05f, 0.3f, 1.7f};
    esr_env_sg_set_level(p, K, level);
    esr_env_sg_fwd(p, K, dirs, N, rgb);
    for (int c = 0; c < 3; c++) {
        double mean = 0.0;
        for (int i = 0; i < N; i++)
            mean += rgb[i * 3 + c] / N;
        print_message("channel %d: level %.3f, mean %.4f, mu %.4f\n", c, (double)level[c], mean,
                      (double)p[at(K, 4 + c, 0)]);
        assert_true(fabs(mean - level[c]) < 0.02 * level[c]);
        for (int k = 1; k < K; k++)
            assert_true(p[at(K, 4 + c, k)] == p[at(K, 4 + c, 0)]);
    }
    memcpy(q, p, P * sizeof(float));
    const float red_only[3] = {0.5f, 0.3f, 1.7f};
    esr_env_sg_set_level(q, K, red_only);
    assert_true(q[at(K, 4, 0)] > p[at(K, 4, 0)]);
    assert_memory_equal(q + at(K, 5, 0), p + at(K, 5, 0), 2 * (size_t)K * sizeof(float));
    free(p), free(q), free(dirs), free(rgb);
}

static int argmax_pixel(const float *img, int n)
{
    int best = 0;
    for (int i = 1; i < n; i++)
        if (img[i * 3] + img[i * 3 + 1] + img[i * 3 + 2] > img[best * 3] + img[best * 3 + 1] + img[best * 3 + 2])
            best = i;
    return best;
}

/* Every pixel is the forward of the direction its centre maps to (computed here from the
 * documented convention); a sharp lobe up (+Z) lands in row 0, one along +Y at a quarter turn
 * on the horizon; bad sizes are refused. */
static void test_equirect(void **state)
{
    (void)state;
    enum { W = 24, H = 12, K = 5 };
    float p[7 * K], img[W * H * 3];
    random_params(p, K, 2.0f, 30.0f, 2.0f, 41);
    assert_int_equal(esr_env_sg_equirect(p, K, W, H, img), ESR_OK);
    for (int row = 0; row < H; row++)
        for (int col = 0; col < W; col++) {
            double theta = M_PI * (row + 0.5) / H, phi = 2.0 * M_PI * (col + 0.5) / W;
            float d[3] = {(float)(sin(theta) * cos(phi)), (float)(sin(theta) * sin(phi)), (float)cos(theta)};
            float e[3], v[3];
            esr_env_sg_equirect_dir(W, H, row, col, e);
            for (int a = 0; a < 3; a++)
                assert_true(fabsf(e[a] - d[a]) < 1e-6f);
            esr_env_sg_fwd(p, K, d, 1, v);
            for (int c = 0; c < 3; c++)
                assert_true(test_close(img[(row * W + col) * 3 + c], v[c], 1e-6, 1e-5));
        }
    /* one sharp lobe; unnormalised axis and negative lambda on purpose */
    float up[7] = {0.0f, 0.0f, 2.5f, -30.0f, 4.0f, 3.0f, 2.0f};
    assert_int_equal(esr_env_sg_equirect(up, 1, W, H, img), ESR_OK);
    int best = argmax_pixel(img, W * H);
    assert_int_equal(best / W, 0);
    assert_true(img[best * 3] > 3.0f); /* 4 exp(30 (cos 7.5 deg - 1)) = 3.1 at the row's centres */
    for (int col = 0; col < W; col++) /* the bottom row sees nothing of it: softplus(0) */
        assert_true(fabsf(img[((H - 1) * W + col) * 3] - logf(2.0f)) < 1e-4f);
    float side[7] = {0.0f, 1.0f, 0.0f, 80.0f, 4.0f, 3.0f, 2.0f};
    assert_int_equal(esr_env_sg_equirect(side, 1, W, H, img), ESR_OK);
    best = argmax_pixel(img, W * H);
    assert_true(best / W == H / 2 - 1 || best / W == H / 2);
    assert_true(best % W == W / 4 - 1 || best % W == W / 4);
    assert_int_equal(esr_env_sg_equirect(up, 1, 0, H, img), ESR_ERR);
    esr_error_clear();
    assert_int_equal(esr_env_sg_equirect(up, 0, W, H, img), ESR_ERR);
    esr_error_clear();
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_counts_and_bad_lobes),
        cmocka_unit_test(test_fwd_matches_reference),
        cmocka_unit_test(test_bwd_fd_every_entry),
        cmocka_unit_test(test_bwd_accumulates_and_is_thread_independent),
        cmocka_unit_test(test_init),
        cmocka_unit_test(test_set_level),
        cmocka_unit_test(test_equirect),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
