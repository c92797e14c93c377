/* Direction samplers (sample, pdf, invert triples): unit length, support, round trip, and the
 * density of the samples against the pdf (Monte Carlo integrals and a chi-square histogram). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>

#include "core/rng.h"
#include "core/sampling.h"
#include "test_stats.h"

struct sampler {
    const char *name;
    struct esr_vec3 (*sample)(float u1, float u2);
    float (*pdf)(struct esr_vec3 local);
    void (*invert)(struct esr_vec3 local, float *u1, float *u2);
    double z_min;       /* support: z in [z_min, 1] */
    double solid_angle; /* measure of the support */
};

/* The samplers are always_inline; these wrappers give them addresses for the table. */
static struct esr_vec3 hu_sample(float a, float b) { return esr_sample_hemisphere_uniform(a, b); }
static float hu_pdf(struct esr_vec3 d) { return esr_pdf_hemisphere_uniform(d); }
static void hu_invert(struct esr_vec3 d, float *a, float *b) { esr_invert_hemisphere_uniform(d, a, b); }
static struct esr_vec3 hc_sample(float a, float b) { return esr_sample_hemisphere_cosine(a, b); }
static float hc_pdf(struct esr_vec3 d) { return esr_pdf_hemisphere_cosine(d); }
static void hc_invert(struct esr_vec3 d, float *a, float *b) { esr_invert_hemisphere_cosine(d, a, b); }
static struct esr_vec3 su_sample(float a, float b) { return esr_sample_sphere_uniform(a, b); }
static float su_pdf(struct esr_vec3 d) { return esr_pdf_sphere_uniform(d); }
static void su_invert(struct esr_vec3 d, float *a, float *b) { esr_invert_sphere_uniform(d, a, b); }

static const struct sampler samplers[] = {
    {"hemisphere uniform", hu_sample, hu_pdf, hu_invert, 0.0, 2.0 * M_PI},
    {"hemisphere cosine", hc_sample, hc_pdf, hc_invert, 0.0, 2.0 * M_PI},
    {"sphere uniform", su_sample, su_pdf, su_invert, -1.0, 4.0 * M_PI},
};
#define N_SAMPLERS (int)(sizeof samplers / sizeof samplers[0])

static void test_samples_unit_and_in_support(void **state)
{
    (void)state;
    for (int s = 0; s < N_SAMPLERS; s++) {
        struct esr_rng rng = esr_rng_init(1, (uint64_t)s);
        for (int i = 0; i < 100000; i++) {
            struct esr_vec3 d = samplers[s].sample(esr_rng_float(&rng), esr_rng_float(&rng));
            assert_true(fabsf(esr_v3_length(d) - 1.0f) < 2e-6f);
            assert_true(d.z >= samplers[s].z_min);
            assert_true(samplers[s].pdf(d) > 0.0f);
        }
        /* corners of the unit square are valid inputs too */
        const float corner[] = {0.0f, 0.999999940f};
        for (int a = 0; a < 2; a++)
            for (int b = 0; b < 2; b++)
                assert_true(fabsf(esr_v3_length(samplers[s].sample(corner[a], corner[b])) - 1.0f) < 2e-6f);
    }
    /* hemisphere pdfs vanish below the surface */
    assert_true(esr_pdf_hemisphere_uniform(esr_v3(0, 0.6f, -0.8f)) == 0.0f);
    assert_true(esr_pdf_hemisphere_cosine(esr_v3(0, 0.6f, -0.8f)) == 0.0f);
}

/* E[f/pdf] under the sampler equals the integral of f over its support: f = 1 gives the solid
 * angle, f = cos gives pi for the hemispheres. Tolerances are ~5 standard errors. */
static void test_monte_carlo_integrals(void **state)
{
    (void)state;
    enum { N = 200000 };
    for (int s = 0; s < N_SAMPLERS; s++) {
        struct esr_rng rng = esr_rng_init(2, (uint64_t)s);
        double sum_one = 0.0, sum_cos = 0.0;
        for (int i = 0; i < N; i++) {
            struct esr_vec3 d = samplers[s].sample(esr_rng_float(&rng), esr_rng_float(&rng));
            double inv_pdf = 1.0 / samplers[s].pdf(d);
            sum_one += inv_pdf;
            sum_cos += fmax(0.0, d.z) * inv_pdf;
        }
        double area = sum_one / N, cos_integral = sum_cos / N;
        /* 1/pdf of the cosine sampler (pi/z) has a heavy tail: allow 2 % there, exact elsewhere */
        double tol = s == 1 ? 0.02 : 1e-5;
        assert_true(fabs(area / samplers[s].solid_angle - 1.0) < tol);
        assert_true(fabs(cos_integral / M_PI - 1.0) < (s == 1 ? 1e-5 : 0.01));
    }
}

static double circular_distance(double a, double b)
{
    double d = fabs(a - b);
    return fmin(d, 1.0 - d);
}

static void test_sample_invert_round_trip(void **state)
{
    (void)state;
    for (int s = 0; s < N_SAMPLERS; s++) {
        struct esr_rng rng = esr_rng_init(3, (uint64_t)s);
        for (int i = 0; i < 100000; i++) {
            float u1 = esr_rng_float(&rng), u2 = esr_rng_float(&rng), v1, v2;
            struct esr_vec3 d = samplers[s].sample(u1, u2);
            samplers[s].invert(d, &v1, &v2);
            assert_true(v1 >= 0.0f && v1 <= 1.0f && v2 >= 0.0f && v2 < 1.0f);
            assert_true(fabsf(v1 - u1) < 2e-6f);
            /* the azimuth is only defined away from the pole */
            if (d.x * d.x + d.y * d.y > 1e-6f)
                assert_true(circular_distance(v2, u2) < 2e-5);
        }
    }
}

/* Histogram over (z, azimuth) cells against the probability the pdf assigns to each cell, the
 * latter integrated by the midpoint rule (dω = dz dφ). */
static void test_density_matches_pdf(void **state)
{
    (void)state;
    enum { NZ = 10, NPHI = 12, N = 240000, SUB = 8 };
    for (int s = 0; s < N_SAMPLERS; s++) {
        double observed[NZ * NPHI] = {0}, expected[NZ * NPHI];
        double z0 = samplers[s].z_min, dz = (1.0 - z0) / NZ, dphi = 2.0 * M_PI / NPHI;
        struct esr_rng rng = esr_rng_init(4, (uint64_t)s);
        for (int i = 0; i < N; i++) {
            struct esr_vec3 d = samplers[s].sample(esr_rng_float(&rng), esr_rng_float(&rng));
            int iz = (int)((d.z - z0) / dz), ip = (int)(esr_azimuth_unit(d) * NPHI);
            iz = iz < NZ ? iz : NZ - 1;
            observed[iz * NPHI + ip] += 1.0;
        }
        double total = 0.0;
        for (int iz = 0; iz < NZ; iz++) {
            for (int ip = 0; ip < NPHI; ip++) {
                double p = 0.0;
                for (int a = 0; a < SUB; a++) {
                    for (int b = 0; b < SUB; b++) {
                        double z = z0 + (iz + (a + 0.5) / SUB) * dz, phi = (ip + (b + 0.5) / SUB) * dphi;
                        double r = sqrt(1.0 - z * z);
                        struct esr_vec3 d = esr_v3((float)(r * cos(phi)), (float)(r * sin(phi)), (float)z);
                        p += samplers[s].pdf(d) * (dz / SUB) * (dphi / SUB);
                    }
                }
                expected[iz * NPHI + ip] = p * N;
                total += p;
            }
        }
        assert_true(fabs(total - 1.0) < 1e-4); /* the pdf integrates to 1 */
        double chi2 = test_chi2_statistic(observed, expected, NZ * NPHI);
        assert_true(chi2 < test_chi2_critical(NZ * NPHI - 1, 4.0));
    }
}

/* A wrong pdf must fail the histogram check: the cosine samples against the uniform pdf. */
static void test_density_check_detects_mismatch(void **state)
{
    (void)state;
    enum { NZ = 10, N = 20000 };
    double observed[NZ] = {0}, expected[NZ];
    struct esr_rng rng = esr_rng_init(5, 0);
    for (int i = 0; i < N; i++) {
        struct esr_vec3 d = esr_sample_hemisphere_cosine(esr_rng_float(&rng), esr_rng_float(&rng));
        int iz = (int)(d.z * NZ);
        observed[iz < NZ ? iz : NZ - 1] += 1.0;
    }
    for (int i = 0; i < NZ; i++)
        expected[i] = (double)N / NZ; /* what uniform-in-z would give */
    assert_true(test_chi2_statistic(observed, expected, NZ) > test_chi2_critical(NZ - 1, 4.0));
}

/* Cosine-weighted samples have E[cos] = integral cos^2 / pi = 2/3 and E[cos^2] = 1/2
 * (tolerances ~5 standard errors: sd(cos) = sqrt(1/2 - 4/9) = 0.236, sd(cos^2) = sqrt(1/3 - 1/4)
 * = 0.289); a uniform sampler would give 1/2 and 1/3. */
static void test_cosine_mean_cos(void **state)
{
    (void)state;
    enum { N = 400000 };
    struct esr_rng rng = esr_rng_init(6, 0);
    double sum = 0.0, sum2 = 0.0;
    for (int i = 0; i < N; i++) {
        float u1 = esr_rng_float(&rng);
        struct esr_vec3 d = esr_sample_hemisphere_cosine(u1, esr_rng_float(&rng));
        sum += d.z;
        sum2 += (double)d.z * d.z;
    }
    assert_true(fabs(sum / N - 2.0 / 3.0) < 5.0 * 0.236 / sqrt(N));
    assert_true(fabs(sum2 / N - 0.5) < 5.0 * 0.289 / sqrt(N));
}

/* The frame of core/vec3.h (esr_v3_basis, from_local, to_local) around normals anywhere on the
 * sphere, the poles and the near-south-pole included (where naive frames divide by ~0):
 * orthonormal and right-handed (t x b = n), local z maps to n, to_local inverts from_local, and
 * cosine samples mapped to the world keep their pdf: n.w = local z, mean n.w = 2/3. */
static void test_frame_maps_local_to_world(void **state)
{
    (void)state;
    struct esr_rng rng = esr_rng_init(7, 0);
    for (int i = 0; i < 20000; i++) {
        struct esr_vec3 n;
        if (i < 4) {
            const struct esr_vec3 special[] = {{0, 0, 1}, {0, 0, -1}, {1, 0, 0}, {0, 1e-4f, -1}};
            n = esr_v3_normalize(special[i]);
        } else {
            float u1 = esr_rng_float(&rng);
            n = esr_sample_sphere_uniform(u1, esr_rng_float(&rng));
        }
        struct esr_vec3 t, b;
        esr_v3_basis(n, &t, &b);
        assert_true(fabsf(esr_v3_length(t) - 1.0f) < 1e-6f && fabsf(esr_v3_length(b) - 1.0f) < 1e-6f);
        assert_true(fabsf(esr_v3_dot(t, b)) < 1e-6f);
        assert_true(fabsf(esr_v3_dot(t, n)) < 1e-6f && fabsf(esr_v3_dot(b, n)) < 1e-6f);
        struct esr_vec3 tb = esr_v3_cross(t, b);
        assert_true(esr_v3_length(esr_v3_sub(tb, n)) < 2e-6f);
        assert_true(esr_v3_length(esr_v3_sub(esr_v3_from_local(esr_v3(0, 0, 1), t, b, n), n)) < 1e-6f);

        float u1 = esr_rng_float(&rng), u2 = esr_rng_float(&rng), v1, v2;
        struct esr_vec3 local = esr_sample_hemisphere_cosine(u1, u2);
        struct esr_vec3 w = esr_v3_from_local(local, t, b, n);
        assert_true(fabsf(esr_v3_length(w) - 1.0f) < 2e-6f);
        assert_true(fabsf(esr_v3_dot(w, n) - local.z) < 2e-6f);
        struct esr_vec3 back = esr_v3_to_local(w, t, b, n);
        assert_true(esr_v3_length(esr_v3_sub(back, local)) < 2e-6f);
        assert_true(fabsf(esr_pdf_hemisphere_cosine(back) - esr_v3_dot(w, n) * (float)M_1_PI) < 1e-6f);
        esr_invert_hemisphere_cosine(back, &v1, &v2); /* the world direction inverts to its u1 */
        assert_true(fabsf(v1 - u1) < 4e-6f);
    }
    /* mean n.w of world-space cosine samples around one tilted normal */
    const struct esr_vec3 n = esr_v3_normalize(esr_v3(0.3f, -0.5f, 0.2f));
    struct esr_vec3 t, b;
    esr_v3_basis(n, &t, &b);
    double sum = 0.0;
    enum { N = 200000 };
    for (int i = 0; i < N; i++) {
        float u1 = esr_rng_float(&rng);
        sum += esr_v3_dot(esr_v3_from_local(esr_sample_hemisphere_cosine(u1, esr_rng_float(&rng)), t, b, n), n);
    }
    assert_true(fabs(sum / N - 2.0 / 3.0) < 5.0 * 0.236 / sqrt(N));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_samples_unit_and_in_support),
        cmocka_unit_test(test_monte_carlo_integrals),
        cmocka_unit_test(test_sample_invert_round_trip),
        cmocka_unit_test(test_density_matches_pdf),
        cmocka_unit_test(test_density_check_detects_mismatch),
        cmocka_unit_test(test_cosine_mean_cos),
        cmocka_unit_test(test_frame_maps_local_to_world),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
