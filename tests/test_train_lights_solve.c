/* The strength solve's fit (train/lights/solve.h, esr_lights_solve_fit) on rows made up for the
 * purpose: lights of known strength per channel, noise, outliers (a mirror's reflection the
 * direct transport does not carry), clipped rows that only bound the fit from below, and two
 * lights whose transports are proportional. The fit must give the strengths back within their
 * stated errors, ignore the outliers, follow the bounds, and say which pair it cannot tell apart. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/rng.h"
#include "train/lights/solve.h"

#define ROWS 4000
#define K 3

static const double truth[3][K] = {{2.0, 6.0, 12.0}, {1.5, 3.0, 9.0}, {1.0, 0.5, 6.0}};

static double normal(struct esr_rng *rng)
{
    const double u = 1.0 - (double)esr_rng_float(rng), v = (double)esr_rng_float(rng);
    return sqrt(-2.0 * log(u)) * cos(2.0 * M_PI * v);
}

struct rows {
    float a[ROWS * 3 * K], y[ROWS * 3];
    uint8_t kind[ROWS * 3];
};

/* Rows y = sum a_k s_k + noise; `outliers` of them get a large extra (always positive, as a
 * reflection adds light); rows whose y exceeds `clip` become lower bounds at clip. proportional:
 * light 1's column is light 0's times 0.5 (the two cannot be told apart). */
static void make(struct rows *r, double noise, double outliers, double clip, int proportional,
                 uint64_t seed)
{
    struct esr_rng rng = esr_rng_init(seed, 7);
    for (size_t i = 0; i < ROWS; i++)
        for (int c = 0; c < 3; c++) {
            const size_t at = i * 3 + (size_t)c;
            double fit = 0.0;
            for (int k = 0; k < K; k++) {
                double v = esr_rng_float(&rng) < 0.5 ? 0.0 : 0.02 * esr_rng_float(&rng);
                if (k == 1 && proportional)
                    v = 0.5 * r->a[at * K];
                r->a[at * K + (size_t)k] = (float)v;
                fit += v * truth[c][k];
            }
            double y = fit + noise * normal(&rng);
            if (esr_rng_float(&rng) < outliers)
                y += 0.5;
            r->kind[at] = 1;
            if (y > clip)
                y = clip, r->kind[at] = 2;
            r->y[at] = (float)y;
        }
}

/* The fit on the first n rows of r, columns a and (or NULL) a second estimate a2. */
static int fit(size_t n, float *a, float *a2, struct rows *r, double s[3][ESR_MAX_LIGHTS],
               double *cov, double sigma[3])
{
    const struct esr_solve_rows rw = {K, n, a, a2, r->y, r->kind};
    return esr_lights_solve_fit(&rw, s, cov, sigma);
}

static void start(double s[3][ESR_MAX_LIGHTS])
{
    for (int c = 0; c < 3; c++)
        for (int k = 0; k < ESR_MAX_LIGHTS; k++)
            s[c][k] = 1.0;
}

static void gives_back_strengths_despite_outliers(void **state)
{
    (void)state;
    struct rows *r = malloc(sizeof *r);
    assert_non_null(r);
    make(r, 0.002, 0.05, INFINITY, 0, 1);
    double s[3][ESR_MAX_LIGHTS], sigma[3];
    double *cov = malloc(3 * ESR_MAX_LIGHTS * ESR_MAX_LIGHTS * sizeof(double));
    start(s);
    assert_int_equal(fit((size_t)ROWS, r->a, NULL, r, s, cov, sigma), 0);
    for (int c = 0; c < 3; c++) {
        assert_true(sigma[c] > 0.0015 && sigma[c] < 0.003); /* the noise's, not the outliers' */
        for (int k = 0; k < K; k++) {
            const double se = sqrt(cov[(size_t)c * ESR_MAX_LIGHTS * ESR_MAX_LIGHTS + k * K + k]);
            assert_true(se > 0.0 && se < 0.05 * truth[c][k]);
            assert_true(fabs(s[c][k] - truth[c][k]) < 5.0 * se + 0.02 * truth[c][k]);
        }
    }
    /* plain least squares (no reweighting) would be pulled up by the outliers: the check that
     * the robust fit is what kept it near the truth */
    double plain = 0.0, g = 0.0;
    for (size_t i = 0; i < ROWS; i++) /* light 2 alone, channel 0, rows where only it reaches */
        if (r->a[i * 3 * K] == 0.0f && r->a[i * 3 * K + 1] == 0.0f && r->a[i * 3 * K + 2] > 0.0f) {
            plain += (double)r->a[i * 3 * K + 2] * r->y[i * 3];
            g += (double)r->a[i * 3 * K + 2] * r->a[i * 3 * K + 2];
        }
    assert_true(plain / g > 1.1 * truth[0][2]);
    free(cov);
    free(r);
}

static void clipped_rows_bound_from_below(void **state)
{
    (void)state;
    struct rows *r = malloc(sizeof *r);
    assert_non_null(r);
    /* clip below most of the light: without the bounds the fit would see only dim rows */
    make(r, 0.001, 0.0, 0.12, 0, 2);
    long bounds = 0;
    for (size_t i = 0; i < ROWS * 3; i++)
        bounds += r->kind[i] == 2;
    assert_true(bounds > ROWS / 4);
    double s[3][ESR_MAX_LIGHTS], sigma[3];
    start(s);
    assert_int_equal(fit((size_t)ROWS, r->a, NULL, r, s, NULL, sigma), 0);
    for (int c = 0; c < 3; c++)
        for (int k = 0; k < K; k++)
            assert_true(fabs(s[c][k] / truth[c][k] - 1.0) < 0.05);
    /* a light every row of which is clipped (light 2, bounded at 0.05): the fit lifts it to
     * the bound the rows give, no further, and without those rows it stays where it started */
    make(r, 0.001, 0.0, INFINITY, 0, 5);
    for (size_t i = 0; i < ROWS * 3; i++)
        if (r->a[i * K + 2] > 0.0f) /* brighter: clipped; dimmer: too close to the clip to keep */
            r->kind[i] = r->y[i] > 0.05f ? 2 : 0, r->y[i] = 0.05f;
    start(s);
    assert_int_equal(fit((size_t)ROWS, r->a, NULL, r, s, NULL, sigma), 0);
    for (int c = 0; c < 3; c++) {
        assert_true(s[c][2] > 1.5 && s[c][2] < 1.05 * truth[c][2]);
        long below = 0, bound = 0;
        for (size_t i = 0; i < ROWS; i++) {
            const size_t at = i * 3 + (size_t)c;
            if (r->kind[at] != 2)
                continue;
            double fit = 0.0;
            for (int k = 0; k < K; k++)
                fit += (double)r->a[at * K + (size_t)k] * s[c][k];
            bound++;
            below += fit < r->y[at] - 0.005;
        }
        assert_true(bound > 100 && below < bound / 20); /* the bounds hold, up to the noise */
    }
    for (size_t i = 0; i < ROWS * 3; i++)
        if (r->kind[i] == 2)
            r->kind[i] = 0;
    start(s);
    assert_int_equal(fit((size_t)ROWS, r->a, NULL, r, s, NULL, sigma), 0);
    for (int c = 0; c < 3; c++)
        assert_true(fabs(s[c][2] - 1.0) < 0.05);
    free(r);
}

static void proportional_lights_are_anticorrelated(void **state)
{
    (void)state;
    struct rows *r = malloc(sizeof *r);
    assert_non_null(r);
    make(r, 0.002, 0.0, INFINITY, 1, 3);
    double s[3][ESR_MAX_LIGHTS], sigma[3];
    double *cov = malloc(3 * ESR_MAX_LIGHTS * ESR_MAX_LIGHTS * sizeof(double));
    start(s);
    assert_int_equal(fit((size_t)ROWS, r->a, NULL, r, s, cov, sigma), 0);
    for (int c = 0; c < 3; c++) {
        /* only s0 + 0.5 s1 is fixed: that comes back, and the two estimates are opposite */
        assert_true(fabs(s[c][0] + 0.5 * s[c][1] - (truth[c][0] + 0.5 * truth[c][1])) <
                    0.03 * (truth[c][0] + 0.5 * truth[c][1]));
        const double *cv = cov + (size_t)c * ESR_MAX_LIGHTS * ESR_MAX_LIGHTS;
        if (s[c][0] > 0.0 && s[c][1] > 0.0) /* both off their bound: the ridge alone separates them */
            assert_true(cv[1] / sqrt(cv[0] * cv[K + 1]) < -ESR_SOLVE_INSEPARABLE);
        assert_true(fabs(s[c][2] / truth[c][2] - 1.0) < 0.03); /* the third stays apart */
    }
    free(cov);
    free(r);
}

static void nothing_reaches_a_light(void **state)
{
    (void)state;
    struct rows *r = malloc(sizeof *r);
    assert_non_null(r);
    make(r, 0.002, 0.0, INFINITY, 0, 4);
    for (size_t i = 0; i < ROWS * 3; i++) /* light 1 lights no row: y loses its part */
        r->a[i * K + 1] = 0.0f;
    double s[3][ESR_MAX_LIGHTS], sigma[3];
    start(s);
    for (int c = 0; c < 3; c++)
        s[c][1] = 4.0; /* where it starts, it stays: no row says otherwise */
    assert_int_equal(fit((size_t)0, r->a, NULL, r, s, NULL, sigma), 0);
    assert_int_equal(fit((size_t)ROWS, r->a, NULL, r, s, NULL, sigma), 0);
    for (int c = 0; c < 3; c++) {
        assert_true(isfinite(s[c][0]) && s[c][0] >= 0.0);
        assert_true(fabs(s[c][1] - 4.0) < 1e-6);
    }
    free(r);
}

/* Columns measured with noise (a light's direct light from a few area samples): the plain fit's
 * scale comes out low (errors in the variables), the fit on two independent halves does not. */
static void noisy_columns_unbiased_with_two_halves(void **state)
{
    (void)state;
    struct rows *r = malloc(sizeof *r), *r2 = malloc(sizeof *r2);
    assert_non_null(r);
    assert_non_null(r2);
    make(r, 0.05, 0.0, INFINITY, 0, 6); /* the photos' noise dominates the residuals */
    memcpy(r2, r, sizeof *r);
    struct esr_rng rng = esr_rng_init(6, 8);
    for (size_t i = 0; i < ROWS * 3 * K; i++) { /* 30% relative noise on each half */
        const float t = r->a[i];
        r->a[i] = t * (float)(1.0 + 0.3 * normal(&rng));
        r2->a[i] = t * (float)(1.0 + 0.3 * normal(&rng));
    }
    double s[3][ESR_MAX_LIGHTS], sp[3][ESR_MAX_LIGHTS], sigma[3];
    start(s);
    start(sp);
    assert_int_equal(fit((size_t)ROWS, r->a, r2->a, r, s, NULL, sigma), 0);
    assert_int_equal(fit((size_t)ROWS, r->a, NULL, r, sp, NULL, sigma), 0);
    double worst = 0.0, worst_plain = 0.0;
    for (int c = 0; c < 3; c++) {
        for (int k = 0; k < K; k++) {
            worst = fmax(worst, fabs(s[c][k] / truth[c][k] - 1.0));
            worst_plain = fmax(worst_plain, fabs(sp[c][k] / truth[c][k] - 1.0));
        }
        /* the brightest light, whose noise the plain fit attenuates most */
        assert_true(sp[c][2] < 0.95 * truth[c][2]);
        assert_true(fabs(s[c][2] / truth[c][2] - 1.0) < 0.04);
    }
    assert_true(worst < 0.15 && worst < 0.6 * worst_plain);
    free(r);
    free(r2);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(gives_back_strengths_despite_outliers),
        cmocka_unit_test(clipped_rows_bound_from_below),
        cmocka_unit_test(proportional_lights_are_anticorrelated),
        cmocka_unit_test(nothing_reaches_a_light),
        cmocka_unit_test(noisy_columns_unbiased_with_two_halves),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
