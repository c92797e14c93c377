/* The reflection estimator's directions (core/brdf_sampling.h): the spherical-Gaussian lobe's
 * density integrates to 1 and its samples have the analytic mean cosine; the balance-heuristic
 * estimate of the BRDF's directional albedo matches a brute-force cosine estimate (no bias) for
 * rough and glossy materials, and on a glossy one its spread is far below plain cosine
 * sampling's with as many directions (what it is for). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>

#include "core/brdf.h"
#include "core/brdf_sampling.h"
#include "core/rng.h"
#include "core/sampling.h"

static void test_lobe_density_and_mean(void **state)
{
    (void)state;
    const float lambdas[3] = {2.0f, 50.0f, 5000.0f};
    for (int l = 0; l < 3; l++) {
        const double lam = lambdas[l];
        /* integral over the sphere = 2 pi int_{-1}^{1} p(z) dz, midpoint rule fine near z = 1 */
        double integral = 0.0;
        const int N = 2000000;
        for (int i = 0; i < N; i++) {
            const double z = -1.0 + 2.0 * (i + 0.5) / N;
            integral += 2.0 * ESR_PI * esr_pdf_sg_lobe((float)lam, (float)z) * (2.0 / N);
        }
        assert_true(fabs(integral - 1.0) < 2e-3);
        struct esr_rng rng = esr_rng_init(7, (uint64_t)l);
        double sum = 0.0;
        const int S = 200000;
        for (int i = 0; i < S; i++) {
            struct esr_vec3 v = esr_sample_sg_lobe((float)lam, esr_rng_float(&rng), esr_rng_float(&rng));
            assert_true(fabs(esr_v3_length(v) - 1.0) < 1e-5);
            sum += v.z;
        }
        const double mean = 1.0 / tanh(lam) - 1.0 / lam; /* E[z] for p(z) ~ e^{lam z} on [-1, 1] */
        assert_true(fabs(sum / S - mean) < 3.0 * sqrt((1.0 - mean * mean + 1e-6) / S) + 1e-5);
    }
}

/* Mean and standard deviation over `trials` of sum_j R(wo, wi_j) wt_j (channel 0); parity 0 or 1:
 * of the even or the odd directions alone, twice their sum (half of them); -1: all. */
static void estimate(const struct esr_material *mat, const struct esr_brdf_dirs *d, int trials,
                     uint64_t seed, int parity, double *mean, double *sd)
{
    struct esr_vec3 wi[64];
    float wt[64];
    const int first = parity < 0 ? 0 : parity, stride = parity < 0 ? 1 : 2;
    double s = 0.0, s2 = 0.0;
    for (int t = 0; t < trials; t++) {
        struct esr_rng rng = esr_rng_init(seed, (uint64_t)t);
        esr_brdf_dirs_sample(d, &rng, wi, wt);
        double e = 0.0;
        for (int j = first; j < esr_brdf_dirs_count(d); j += stride) {
            float R[3];
            esr_brdf_eval(mat, d->n, d->wo[0], wi[j], R);
            e += (double)stride * R[0] * wt[j];
        }
        s += e;
        s2 += e * e;
    }
    *mean = s / trials;
    *sd = sqrt(fmax(s2 / trials - *mean * *mean, 0.0));
}

static void test_mis_unbiased_and_sharper(void **state)
{
    (void)state;
    struct esr_brdf_dirs d = {0};
    d.n = esr_v3_normalize(esr_v3(0.2f, -0.1f, 1.0f));
    esr_v3_basis(d.n, &d.t, &d.b);
    d.wo[0] = esr_v3_normalize(esr_v3(0.6f, 0.3f, 0.7f));
    d.wo[1] = esr_v3_normalize(esr_v3(-0.5f, 0.2f, 0.4f));
    d.n_wo = 2;
    /* 1.0: the lobe's half vectors below the surface reflect wo into the hemisphere too, and
     * their density counts (a rough lobe's estimate was 0.5% high without it) */
    const float rough[4] = {1.0f, 0.8f, 0.3f, 0.2f};
    for (int i = 0; i < 4; i++) {
        const struct esr_material mat = {{0.7f, 0.7f, 0.7f}, rough[i], 0.8f};
        d.roughness = rough[i];
        /* the reference: cosine-weighted quadrature on a jittered 4000 x 4000 grid of (u1, u2),
         * fine enough to resolve the sharpest lobe here (width ~0.03 rad) */
        const int G = 4000;
        double ref = 0.0;
        struct esr_rng rng = esr_rng_init(11, (uint64_t)i);
        for (int a = 0; a < G; a++)
            for (int c = 0; c < G; c++) {
                const float u1 = ((float)a + esr_rng_float(&rng)) / (float)G;
                const float u2 = ((float)c + esr_rng_float(&rng)) / (float)G;
                const struct esr_vec3 loc = esr_sample_hemisphere_cosine(u1, u2);
                if (loc.z <= 0.0f)
                    continue;
                float R[3];
                esr_brdf_eval(&mat, d.n, d.wo[0], esr_v3_from_local(loc, d.t, d.b, d.n), R);
                ref += (double)R[0] / (loc.z * ESR_INV_PI);
            }
        ref /= (double)G * G;
        double mis, mis_sd, cos_only, cos_sd;
        d.n_cos = 24, d.n_lobe = 4;
        assert_int_equal(esr_brdf_dirs_count(&d), 32);
        estimate(&mat, &d, 40000, 3, -1, &mis, &mis_sd);
        d.n_cos = 32, d.n_lobe = 0;
        estimate(&mat, &d, 40000, 5, -1, &cos_only, &cos_sd);
        assert_true(fabs(mis - ref) < 4.0 * mis_sd / sqrt(40000.0) + 1e-3 * ref);
        assert_true(fabs(cos_only - ref) < 4.0 * cos_sd / sqrt(40000.0) + 1e-3 * ref);
        if (rough[i] <= 0.3f) /* glossy: the lobe directions cut the spread several times */
            assert_true(mis_sd < 0.5 * cos_sd);
    }
    /* an outgoing direction below the surface gets no lobe samples */
    d.wo[1] = esr_v3_scale(d.n, -1.0f);
    d.n_cos = 24, d.n_lobe = 4;
    assert_int_equal(esr_brdf_dirs_count(&d), 28);
}

/* Option lts_split's directions (paired strata): the even and the odd directions are each an
 * unbiased estimate, which the loss's product of their errors needs, also with directions from
 * the BRDF's lobe (each half then holds half of each technique's directions); with one direction
 * per stratum the even ones cover only every other ring of the hemisphere and are not. */
static void test_paired_halves_unbiased(void **state)
{
    (void)state;
    struct esr_brdf_dirs d = {0};
    d.n = esr_v3(0.0f, 0.0f, 1.0f);
    esr_v3_basis(d.n, &d.t, &d.b);
    d.wo[0] = esr_v3_normalize(esr_v3(0.8f, 0.0f, 0.3f)); /* grazing: the integrand leans */
    d.n_wo = 1;
    d.roughness = 0.6f;
    d.n_cos = 16;
    const struct esr_material mat = {{0.7f, 0.7f, 0.7f}, 0.6f, 0.2f};
    const int N = 100000;
    /* the reference: all directions of an unpaired set (unbiased, test_mis_unbiased_and_sharper) */
    struct esr_brdf_dirs all = d;
    all.n_cos = 32;
    double ref, ref_sd;
    estimate(&mat, &all, N, 9, -1, &ref, &ref_sd);
    const double tol_ref = 4.0 * ref_sd / sqrt((double)N);
    d.paired = 1;
    for (int lobe = 0; lobe <= 4; lobe += 4) { /* cosine alone, and with lobe directions */
        d.n_cos = 16 - lobe;
        d.n_lobe = lobe;
        for (int parity = 0; parity < 2; parity++) {
            double m, sd;
            estimate(&mat, &d, N, 21 + (uint64_t)(parity + 2 * lobe), parity, &m, &sd);
            print_message("paired, %d lobe directions, parity %d: %.5f vs %.5f (sd %.4f)\n", lobe,
                          parity, m, ref, sd);
            assert_true(fabs(m - ref) < 4.0 * sd / sqrt((double)N) + tol_ref);
        }
    }
    d.paired = 0;
    d.n_cos = 16;
    d.n_lobe = 0;
    double even, odd, sd0, sd1;
    estimate(&mat, &d, N, 31, 0, &even, &sd0);
    estimate(&mat, &d, N, 31, 1, &odd, &sd1);
    print_message("unpaired: even %.5f, odd %.5f\n", even, odd);
    assert_true(fabs(even - odd) > 8.0 * (sd0 + sd1) / sqrt((double)N));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_lobe_density_and_mean),
        cmocka_unit_test(test_mis_unbiased_and_sharper),
        cmocka_unit_test(test_paired_halves_unbiased),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
