/* The seed's simplified Disney BRDF (eqs. 5-8) against an independent double-precision
 * reference, hand-computed cases, reciprocity and energy. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <string.h>

#include "core/brdf.h"
#include "core/rng.h"
#include "core/sampling.h"

/* Reference written from the seed's equations in spherical angles, double precision. Directions
 * are given by (theta, phi) around n = +z so that the dot products come from trigonometry rather
 * than from vectors; Schlick's (1 - wo.h)^5 as brdf.h documents. */
struct dir_angles {
    double theta, phi;
};

static void ref_unit(struct dir_angles a, double v[3])
{
    v[0] = sin(a.theta) * cos(a.phi);
    v[1] = sin(a.theta) * sin(a.phi);
    v[2] = cos(a.theta);
}

static void ref_brdf(const double b[3], double r, double m, struct dir_angles wo, struct dir_angles wi, double out[3])
{
    double cos_o = cos(wo.theta), cos_i = cos(wi.theta);
    if (cos_o <= 0 || cos_i <= 0) {
        out[0] = out[1] = out[2] = 0;
        return;
    }
    /* angle between wo and wi by the spherical law of cosines; the half vector bisects it */
    double cos_oi = cos_o * cos_i + sin(wo.theta) * sin(wi.theta) * cos(wo.phi - wi.phi);
    double cos_oh = sqrt(0.5 * (1.0 + cos_oi)); /* half-angle formula: wo.h */
    double cos_nh = (cos_o + cos_i) / (2.0 * cos_oh);
    r = fmax(r, 0.02);
    double alpha = pow(r, 4.0);
    double d = exp(2.0 / alpha * (cos_nh - 1.0)) / (M_PI * alpha);
    double k = r * r / 2.0;
    double g = cos_o * cos_i / ((cos_o * (1 - k) + k) * (cos_i * (1 - k) + k));
    for (int c = 0; c < 3; c++) {
        double f0 = 0.04 * (1 - m) + b[c] * m;
        double f = f0 + (1 - f0) * pow(1.0 - cos_oh, 5.0);
        out[c] = d * f * g / (4.0 * cos_o) + cos_i * (1 - m) * b[c] / M_PI;
    }
}

static struct esr_vec3 to_vec(struct dir_angles a)
{
    double v[3];
    ref_unit(a, v);
    return esr_v3((float)v[0], (float)v[1], (float)v[2]);
}

static struct esr_material material(float b0, float b1, float b2, float r, float m)
{
    struct esr_material mat;
    mat.base[0] = b0;
    mat.base[1] = b1;
    mat.base[2] = b2;
    mat.roughness = r;
    mat.metallic = m;
    return mat;
}

static void test_matches_reference(void **state)
{
    (void)state;
    struct esr_rng rng = esr_rng_init(8, 0);
    const struct esr_vec3 n = esr_v3(0, 0, 1);
    for (int i = 0; i < 20000; i++) {
        struct esr_material mat = material(esr_rng_float(&rng), esr_rng_float(&rng), esr_rng_float(&rng),
                                           0.05f + 0.95f * esr_rng_float(&rng), esr_rng_float(&rng));
        struct dir_angles wo = {1.45 * esr_rng_float(&rng), 2 * M_PI * esr_rng_float(&rng)};
        struct dir_angles wi = {1.45 * esr_rng_float(&rng), 2 * M_PI * esr_rng_float(&rng)};
        double b[3] = {mat.base[0], mat.base[1], mat.base[2]}, want[3];
        float got[3];
        ref_brdf(b, mat.roughness, mat.metallic, wo, wi, want);
        esr_brdf_eval(&mat, n, to_vec(wo), to_vec(wi), got);
        for (int c = 0; c < 3; c++) {
            /* the sharp SG lobe amplifies float rounding of h.n by 2/r^4 in the exponent */
            double tol = 1e-4 + 2e-6 * 2.0 / pow(mat.roughness, 4.0);
            assert_true(fabs(got[c] - want[c]) <= tol * fmax(1e-3, want[c]));
        }
    }
}

/* A float unit vector's direction as exact angles (the reference then sees what esr sees). */
static struct dir_angles angles_of(struct esr_vec3 v)
{
    struct dir_angles a = {atan2(sqrt((double)v.x * v.x + (double)v.y * v.y), v.z), atan2(v.y, v.x)};
    return a;
}

/* Near the mirror direction at the roughness floor, where 2 / r^4 (1.25e7 at 0.02) multiplies
 * any rounding error in 1 - h.n: computed as 1 - H.n / |H| in float, D came out up to 2400x off
 * at r = 0.02 and 8x at 0.03 (arguments from a review's probe). The reference takes the float
 * directions' own angles, so input rounding does not count against esr. */
static void test_near_mirror_at_low_roughness(void **state)
{
    (void)state;
    struct esr_rng rng = esr_rng_init(21, 0);
    const struct esr_vec3 n = esr_v3(0, 0, 1);
    const float rough[3] = {0.02f, 0.03f, 0.05f};
    for (int k = 0; k < 3; k++) {
        const double r2 = (double)rough[k] * rough[k];
        double worst = 0.0;
        for (int i = 0; i < 20000; i++) {
            struct esr_material mat = material(0.8f, 0.6f, 0.4f, rough[k], esr_rng_float(&rng));
            struct dir_angles wo = {0.05 + 1.45 * esr_rng_float(&rng), 2 * M_PI * esr_rng_float(&rng)};
            /* the mirror direction, off by up to ~4 r^2 (D down to about e^-16) */
            struct dir_angles wi = {wo.theta + 4.0 * r2 * (esr_rng_float(&rng) - 0.5),
                                    wo.phi + M_PI + 4.0 * r2 * (esr_rng_float(&rng) - 0.5) / sin(wo.theta)};
            const struct esr_vec3 vo = to_vec(wo), vi = to_vec(wi);
            double b[3] = {mat.base[0], mat.base[1], mat.base[2]}, want[3];
            float got[3];
            ref_brdf(b, mat.roughness, mat.metallic, angles_of(vo), angles_of(vi), want);
            esr_brdf_eval(&mat, n, vo, vi, got);
            for (int c = 0; c < 3; c++)
                if (want[c] > 1e-3)
                    worst = fmax(worst, fabs(got[c] - want[c]) / want[c]);
        }
        assert_true(worst < 2e-3);
    }
}

/* Normal incidence, wo = wi = n: h = n, D = 1/(pi r^4), G = 1, F = F0, so
 * R = F0/(4 pi r^4) + (1-m) b/pi. With r = 0.5: 1/(4 pi 0.0625) = 1.2732395. */
static void test_normal_incidence_by_hand(void **state)
{
    (void)state;
    const struct esr_vec3 n = esr_v3(0, 0, 1);
    float out[3];
    struct esr_material metal = material(0.9f, 0.5f, 0.1f, 0.5f, 1.0f); /* metallic: F0 = b, no diffuse */
    esr_brdf_eval(&metal, n, n, n, out);
    assert_float_equal(out[0], 0.9 * 1.2732395, 1e-5);
    assert_float_equal(out[1], 0.5 * 1.2732395, 1e-5);
    assert_float_equal(out[2], 0.1 * 1.2732395, 1e-5);
    struct esr_material plastic = material(0.9f, 0.5f, 0.1f, 0.5f, 0.0f); /* F0 = 0.04 + diffuse b/pi */
    esr_brdf_eval(&plastic, n, n, n, out);
    assert_float_equal(out[0], 0.04 * 1.2732395 + 0.9 / M_PI, 1e-5);
    assert_float_equal(out[2], 0.04 * 1.2732395 + 0.1 / M_PI, 1e-5);
}

/* Fresnel uses Schlick's (1 - wo.h)^5, not the seed's typeset (1 - (wo.h)^5) (see brdf.h).
 * wo, wi at +-60 degrees in one plane: h = n, wo.h = 0.5, n.wo = n.wi = 0.5, so with r = 1
 * (k = 0.5): D = 1/pi, G = 0.25/0.75^2 = 4/9, Schlick term 0.5^5 = 1/32, and for metallic b = 0
 * (F0 = 0): R = (1/pi)(1/32)(4/9)/(4 * 0.5) = 1/(144 pi) = 0.00221049. The typeset form would
 * give 0.96875 instead of 1/32, i.e. 31 times more. */
static void test_fresnel_is_schlick(void **state)
{
    (void)state;
    const struct esr_vec3 n = esr_v3(0, 0, 1);
    const float s = sqrtf(3.0f) / 2.0f;
    struct esr_material mat = material(0, 0, 0, 1.0f, 1.0f);
    float out[3];
    esr_brdf_eval(&mat, n, esr_v3(s, 0, 0.5f), esr_v3(-s, 0, 0.5f), out);
    assert_float_equal(out[0], 1.0 / (144.0 * M_PI), 1e-7);
}

static void test_below_surface_is_zero(void **state)
{
    (void)state;
    struct esr_material mat = material(0.5f, 0.5f, 0.5f, 0.3f, 0.2f);
    const struct esr_vec3 n = esr_v3(0, 0, 1), up = esr_v3(0.6f, 0, 0.8f), down = esr_v3(0.6f, 0, -0.8f);
    float out[3];
    esr_brdf_eval(&mat, n, up, down, out);
    assert_true(out[0] == 0 && out[1] == 0 && out[2] == 0);
    esr_brdf_eval(&mat, n, down, up, out);
    assert_true(out[0] == 0 && out[1] == 0 && out[2] == 0);
    esr_brdf_eval(&mat, n, esr_v3(1, 0, 0), up, out); /* grazing wo: n.wo = 0 */
    assert_true(out[0] == 0 && out[1] == 0 && out[2] == 0);
}

/* Without its cosine factor the BRDF is reciprocal: R(wo,wi)/(n.wi) = R(wi,wo)/(n.wo). That
 * holds for the diffuse part b(1-m)/pi and for the specular part (D, G and F are symmetric in wo
 * and wi). For dielectrics (m = 0) the diffuse part is also isolated and checked on its own. */
static void test_reciprocity(void **state)
{
    (void)state;
    struct esr_rng rng = esr_rng_init(9, 0);
    const struct esr_vec3 n = esr_v3(0, 0, 1);
    for (int i = 0; i < 5000; i++) {
        struct esr_material mat = material(esr_rng_float(&rng), esr_rng_float(&rng), esr_rng_float(&rng),
                                           0.1f + 0.9f * esr_rng_float(&rng), (i & 1) ? esr_rng_float(&rng) : 0.0f);
        struct esr_vec3 wo = esr_sample_hemisphere_uniform(0.05f + 0.95f * esr_rng_float(&rng), esr_rng_float(&rng));
        struct esr_vec3 wi = esr_sample_hemisphere_uniform(0.05f + 0.95f * esr_rng_float(&rng), esr_rng_float(&rng));
        float fwd[3], rev[3];
        esr_brdf_eval(&mat, n, wo, wi, fwd);
        esr_brdf_eval(&mat, n, wi, wo, rev);
        for (int c = 0; c < 3; c++) {
            double a = fwd[c] / wi.z, b = rev[c] / wo.z;
            assert_true(fabs(a - b) <= 1e-4 * fmax(1e-3, fabs(a)));
        }
        /* the diffuse part on its own: the BRDF minus the metallic-weighted specular is b(1-m)/pi */
        struct esr_material black = mat;
        black.base[0] = black.base[1] = black.base[2] = 0.0f; /* same specular when m = 0 */
        if (mat.metallic == 0.0f) {
            float spec[3];
            esr_brdf_eval(&black, n, wo, wi, spec);
            for (int c = 0; c < 3; c++)
                assert_true(fabs(fwd[c] - spec[c] - wi.z * mat.base[c] / M_PI) < 1e-6 * fmax(1.0f, fwd[c]));
        }
    }
}

/* Directional albedo a(wo) = integral over wi of R(wo, wi) dwi, by Monte Carlo with a 50/50
 * mixture of cosine sampling and sampling the half vector from the SG lobe (D(h)(h.n), inverted
 * in closed form), weighted by the mixture pdf so both the diffuse and sharp specular parts
 * converge. Returns the channel-0 albedo. */
static double albedo(const struct esr_material *mat, double theta_o, int n_samples, uint64_t stream)
{
    const struct esr_vec3 n = esr_v3(0, 0, 1);
    struct esr_vec3 wo = esr_v3((float)sin(theta_o), 0.0f, (float)cos(theta_o));
    double r = fmax(mat->roughness, ESR_BRDF_MIN_ROUGHNESS), alpha = pow(r, 4.0), floor_e = exp(-2.0 / alpha);
    struct esr_rng rng = esr_rng_init(10, stream);
    double sum = 0.0;
    for (int i = 0; i < n_samples; i++) {
        double u1 = esr_rng_float(&rng), u2 = esr_rng_float(&rng);
        struct esr_vec3 wi;
        if (esr_rng_float(&rng) < 0.5f) {
            wi = esr_sample_hemisphere_cosine((float)u1, (float)u2);
        } else {
            double mu = fmin(1.0, 1.0 + 0.5 * alpha * log(u1 * (1.0 - floor_e) + floor_e));
            double st = sqrt(fmax(0.0, 1.0 - mu * mu));
            struct esr_vec3 h = esr_v3((float)(st * cos(2 * M_PI * u2)), (float)(st * sin(2 * M_PI * u2)), (float)mu);
            float oh = esr_v3_dot(wo, h);
            wi = esr_v3_sub(esr_v3_scale(h, 2.0f * oh), wo);
        }
        if (wi.z <= 0.0f)
            continue;
        /* h.n - 1 without cancellation (the lobe at r = 0.02 is 4e-4 rad wide) */
        const double hx = (double)wo.x + wi.x, hy = (double)wo.y + wi.y, hz = (double)wo.z + wi.z;
        const double len = sqrt(hx * hx + hy * hy + hz * hz);
        const double mu_1 = -(hx * hx + hy * hy) / (len * (len + hz));
        const double oh = ((double)wo.x * hx + (double)wo.y * hy + (double)wo.z * hz) / len;
        double pdf_h = (2.0 / alpha) * exp(2.0 * mu_1 / alpha) / (1.0 - floor_e) / (2 * M_PI);
        double pdf = 0.5 * wi.z / M_PI + 0.5 * (oh > 0 ? pdf_h / (4.0 * oh) : 0.0);
        float f[3];
        esr_brdf_eval(mat, n, wo, wi, f);
        sum += f[0] / pdf;
    }
    return sum / n_samples;
}

/* The seed's model (eq. 5) is a Lambertian lobe with albedo exactly (1-m)b plus a specular lobe
 * with no (1-F) weight on the diffuse part. So:
 *  - the specular lobe alone (m = 1, b = 1, hence F = 1) must not create energy at any angle;
 *  - any material's albedo minus its diffuse (1-m)b must not exceed 1 either;
 *  - the total stays <= 1 for b <= 0.9 up to 1 rad from the normal. At grazing angles Schlick's F
 *    tends to 1 while the diffuse lobe is unchanged, so dielectrics exceed 1 there (measured
 *    here: up to ~1.6 at 1.5 rad, r <= 0.1, m = 0, b = 0.9). That is a property of eq. 5, which
 *    the method follows, not of this code. */
static void test_energy_conservation(void **state)
{
    (void)state;
    const float roughness[] = {0.02f, 0.05f, 0.1f, 0.2f, 0.35f, 0.5f, 0.75f, 1.0f};
    const float metallic[] = {0.0f, 0.25f, 0.5f, 0.75f, 1.0f};
    const double theta[] = {0.0, 0.5, 1.0, 1.3, 1.5};
    uint64_t stream = 0;
    for (size_t ir = 0; ir < sizeof roughness / sizeof roughness[0]; ir++) {
        struct esr_material lobe = material(1, 1, 1, roughness[ir], 1.0f);
        for (size_t it = 0; it < sizeof theta / sizeof theta[0]; it++) {
            double a = albedo(&lobe, theta[it], 20000, stream++);
            /* r = 0.02 (the clamp) too: the lobe is 4e-4 rad wide, 1 - h.n ~ 8e-8, below a
             * float ulp of h.n, so both the BRDF and the pdf above compute 1 - h.n without
             * cancellation (when both took it from a rounded h.n the estimate moved by a few %
             * with the rounding and needed 1.05) */
            assert_true(a <= 1.01);
            assert_true(a > 0.2); /* the lobe reflects something at every angle */
            for (size_t im = 0; im < sizeof metallic / sizeof metallic[0]; im++) {
                struct esr_material mat = material(0.9f, 0.9f, 0.9f, roughness[ir], metallic[im]);
                double total = albedo(&mat, theta[it], 4000, stream++);
                assert_true(total - (1.0 - metallic[im]) * 0.9 <= 1.01);
                if (theta[it] <= 1.0)
                    assert_true(total <= 1.01);
            }
        }
    }
    /* a near-mirror lobe at normal incidence keeps (almost) all energy: the SG NDF is normalised
     * for small r (an importance-sampled double-precision Python estimate gave 1.0000 at r = 0.05) */
    struct esr_material mirror = material(1, 1, 1, 0.05f, 1.0f);
    assert_true(fabs(albedo(&mirror, 0.0, 20000, stream++) - 1.0) < 0.01);
    /* Lambertian part: albedo of a purely diffuse-weighted material is (1-m)b + specular(F0=.04) */
    struct esr_material diffuse = material(0.5f, 0.5f, 0.5f, 1.0f, 0.0f);
    double a = albedo(&diffuse, 0.0, 20000, stream++);
    assert_true(a > 0.5 && a < 0.5 + 0.04 + 0.01);
}

/* d/d(base, roughness, metallic) of esr_brdf_eval_bwd against central differences of the
 * double-precision reference, at many random configurations (roughness kept off the clamp). */
static void test_backward_matches_finite_differences(void **state)
{
    (void)state;
    struct esr_rng rng = esr_rng_init(77, 0);
    int checked = 0;
    double worst = 0.0;
    for (int t = 0; t < 300; t++) {
        double b[3] = {esr_rng_float(&rng), esr_rng_float(&rng), esr_rng_float(&rng)};
        double r = 0.25 + 0.7 * esr_rng_float(&rng), m = esr_rng_float(&rng);
        struct dir_angles wo = {1.3 * esr_rng_float(&rng), 2 * M_PI * esr_rng_float(&rng)};
        struct dir_angles wi = {1.3 * esr_rng_float(&rng), 2 * M_PI * esr_rng_float(&rng)};
        float d_out[3] = {esr_rng_float(&rng) - 0.5f, esr_rng_float(&rng) - 0.5f,
                          esr_rng_float(&rng) - 0.5f};
        struct esr_material mat = material((float)b[0], (float)b[1], (float)b[2], (float)r, (float)m);
        struct esr_material d_mat;
        memset(&d_mat, 0, sizeof d_mat);
        esr_brdf_eval_bwd(&mat, esr_v3(0, 0, 1), to_vec(wo), to_vec(wi), d_out, &d_mat);
        const float analytic[5] = {d_mat.base[0], d_mat.base[1], d_mat.base[2], d_mat.roughness,
                                   d_mat.metallic};
        for (int p = 0; p < 5; p++) {
            const double h = 1e-5;
            double lo[3], hi[3], x[5] = {b[0], b[1], b[2], r, m};
            x[p] += h;
            ref_brdf(x, x[3], x[4], wo, wi, hi);
            x[p] -= 2 * h;
            ref_brdf(x, x[3], x[4], wo, wi, lo);
            double fd = 0.0;
            for (int c = 0; c < 3; c++)
                fd += d_out[c] * (hi[c] - lo[c]) / (2 * h);
            double err = fabs(fd - analytic[p]) / (1e-3 + fabs(fd));
            worst = fmax(worst, err);
            if (err > 2e-3)
                print_message("config %d param %d: analytic %g fd %g\n", t, p, analytic[p], fd);
            assert_true(err <= 2e-3);
            checked++;
        }
    }
    print_message("BRDF backward: %d derivatives, worst relative error %.2e\n", checked, worst);
}

/* Below the roughness clamp the forward is constant in roughness: its gradient is exactly 0;
 * the gradient accumulates (adds) into d_mat. */
static void test_backward_clamp_and_accumulate(void **state)
{
    (void)state;
    struct esr_material mat = material(0.3f, 0.5f, 0.7f, 0.01f, 0.4f), d_mat;
    memset(&d_mat, 0, sizeof d_mat);
    const float d_out[3] = {1, 1, 1};
    struct dir_angles wo = {0.4, 0.1}, wi = {0.5, 3.0};
    esr_brdf_eval_bwd(&mat, esr_v3(0, 0, 1), to_vec(wo), to_vec(wi), d_out, &d_mat);
    assert_true(d_mat.roughness == 0.0f);
    float once = d_mat.base[1];
    assert_true(once != 0.0f);
    esr_brdf_eval_bwd(&mat, esr_v3(0, 0, 1), to_vec(wo), to_vec(wi), d_out, &d_mat);
    assert_true(fabsf(d_mat.base[1] - 2.0f * once) <= 1e-6f * fabsf(once));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_matches_reference),
        cmocka_unit_test(test_near_mirror_at_low_roughness),
        cmocka_unit_test(test_normal_incidence_by_hand),
        cmocka_unit_test(test_fresnel_is_schlick),
        cmocka_unit_test(test_below_surface_is_zero),
        cmocka_unit_test(test_reciprocity),
        cmocka_unit_test(test_energy_conservation),
        cmocka_unit_test(test_backward_matches_finite_differences),
        cmocka_unit_test(test_backward_clamp_and_accumulate),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
