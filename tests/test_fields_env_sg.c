/* The spherical-Gaussian environment map (fields/env_sg.h): forward against a separate
 * double-precision evaluation of the formula, finite differences of every parameter, the
 * initialisation's promises. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "fields/env_sg.h"
#include "test_grad.h"

#define LOBES 5
#define NDIR 9

static void random_dirs(float *d, size_t n, uint64_t seed)
{
    test_fill_uniform(d, n * 3, -1.0f, 1.0f, seed);
    for (size_t i = 0; i < n; i++) {
        float *v = d + i * 3;
        float len = sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        for (int a = 0; a < 3; a++)
            v[a] /= len;
    }
}

/* Params with unnormalised axes, mixed-sign lambdas and amplitudes. */
static void random_params(float *p)
{
    test_fill_uniform(p, esr_env_sg_param_count(LOBES), -1.5f, 1.5f, 3);
    for (int k = 0; k < LOBES; k++)
        p[k * ESR_ENV_SG_LOBE_FLOATS + 3] *= 4.0f; /* sharpness, either sign */
}

/* The formula, written out in double: softplus(sum mu exp(|lambda| (d.xi/|xi| - 1))). */
static void reference(const double *p, const float *d, double out[3])
{
    double s[3] = {0, 0, 0};
    for (int k = 0; k < LOBES; k++) {
        const double *l = p + k * ESR_ENV_SG_LOBE_FLOATS;
        double len = sqrt(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]);
        double c = (d[0] * l[0] + d[1] * l[1] + d[2] * l[2]) / len;
        double e = exp(fabs(l[3]) * (c - 1.0));
        for (int ch = 0; ch < 3; ch++)
            s[ch] += l[4 + ch] * e;
    }
    for (int ch = 0; ch < 3; ch++)
        out[ch] = log1p(exp(s[ch]));
}

static void test_forward_matches_reference(void **state)
{
    (void)state;
    float p[LOBES * ESR_ENV_SG_LOBE_FLOATS], d[NDIR * 3], out[NDIR * 3];
    double pd[LOBES * ESR_ENV_SG_LOBE_FLOATS];
    random_params(p);
    for (size_t i = 0; i < sizeof p / sizeof p[0]; i++)
        pd[i] = p[i];
    random_dirs(d, NDIR, 5);
    esr_env_sg_fwd(p, LOBES, d, NDIR, out);
    for (int i = 0; i < NDIR; i++) {
        double ref[3];
        reference(pd, d + i * 3, ref);
        for (int c = 0; c < 3; c++)
            assert_true(test_close(out[i * 3 + c], ref[c], 1e-6, 1e-5));
    }
}

static void test_backward_every_parameter(void **state)
{
    (void)state;
    const size_t np = esr_env_sg_param_count(LOBES);
    float p[LOBES * ESR_ENV_SG_LOBE_FLOATS], d[NDIR * 3], up[NDIR * 3];
    float grad[LOBES * ESR_ENV_SG_LOBE_FLOATS];
    double pd[LOBES * ESR_ENV_SG_LOBE_FLOATS];
    random_params(p);
    random_dirs(d, NDIR, 6);
    test_fill_uniform(up, NDIR * 3, -1.0f, 1.0f, 7);
    memset(grad, 0, sizeof grad);
    esr_env_sg_bwd(p, LOBES, d, NDIR, up, grad);
    double worst = 0.0;
    for (size_t j = 0; j < np; j++) {
        for (size_t i = 0; i < np; i++)
            pd[i] = p[i];
        const double h = 1e-6 * fmax(1.0, fabs(pd[j]));
        double lo = 0.0, hi = 0.0, ref[3];
        pd[j] = p[j] + h;
        for (int i = 0; i < NDIR; i++) {
            reference(pd, d + i * 3, ref);
            for (int c = 0; c < 3; c++)
                hi += up[i * 3 + c] * ref[c];
        }
        pd[j] = p[j] - h;
        for (int i = 0; i < NDIR; i++) {
            reference(pd, d + i * 3, ref);
            for (int c = 0; c < 3; c++)
                lo += up[i * 3 + c] * ref[c];
        }
        double fd = (hi - lo) / (2 * h);
        double err = fabs(fd - grad[j]) / (1e-4 + fabs(fd));
        worst = fmax(worst, err);
        if (err > 1e-3)
            print_message("param %zu: analytic %g fd %g\n", j, (double)grad[j], fd);
        assert_true(err <= 1e-3);
    }
    print_message("env map backward: %zu parameters, worst relative error %.2e\n", np, worst);
    /* accumulates */
    float again[LOBES * ESR_ENV_SG_LOBE_FLOATS];
    memcpy(again, grad, sizeof grad);
    esr_env_sg_bwd(p, LOBES, d, NDIR, up, again);
    for (size_t j = 0; j < np; j++)
        assert_true(test_close(again[j], 2.0 * grad[j], 1e-7, 1e-5));
}

static void test_init(void **state)
{
    (void)state;
    enum { K = 48 };
    float p[K * ESR_ENV_SG_LOBE_FLOATS], q[K * ESR_ENV_SG_LOBE_FLOATS];
    esr_env_sg_init(p, K, 11);
    esr_env_sg_init(q, K, 11);
    assert_memory_equal(p, q, sizeof p);
    double min_angle = M_PI;
    for (int k = 0; k < K; k++) {
        const float *a = p + k * ESR_ENV_SG_LOBE_FLOATS;
        assert_true(fabsf(a[0] * a[0] + a[1] * a[1] + a[2] * a[2] - 1.0f) < 1e-5f);
        assert_true(a[3] >= 10.0f);
        for (int j = 0; j < k; j++) {
            const float *b = p + j * ESR_ENV_SG_LOBE_FLOATS;
            double c = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
            min_angle = fmin(min_angle, acos(fmin(1.0, c)));
        }
    }
    /* 48 evenly spread axes: neighbours ~30 degrees apart; a clumped init would fail this */
    assert_true(min_angle > 15.0 * M_PI / 180.0);
    float d[3] = {0, 0, 1}, out[3];
    esr_env_sg_fwd(p, K, d, 1, out);
    assert_true(fabsf(out[0] - logf(2.0f)) < 1e-6f); /* mu = 0: softplus(0) */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_forward_matches_reference),
        cmocka_unit_test(test_backward_every_parameter),
        cmocka_unit_test(test_init),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
