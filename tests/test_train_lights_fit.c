/* The lights' calibration fit (train/lights/fit.h) on rows made up for the purpose: two lights
 * of known strength, each with an undecided rim whose light the rows carry or not. The fit must
 * give the strengths back, and the rim choice must follow what the rows carry: a rim whose light
 * is in them emits, one whose light is not stays dark, and with only noise to tell them apart
 * nothing changes sides. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/rng.h"
#include "model/lights.h"
#include "train/lights/lights.h"
#include "train/lights/fit.h"

#define POINTS 1500
#define K 2

static const double truth[K] = {3.0, 5.0};

/* A standard normal draw (Box-Muller). */
static double normal(struct esr_rng *rng)
{
    const double u = 1.0 - (double)esr_rng_float(rng), v = (double)esr_rng_float(rng);
    return sqrt(-2.0 * log(u)) * cos(2.0 * M_PI * v);
}

struct made_rows {
    struct esr_calib_rows rows;
    double a[POINTS * 3 * K], ar[POINTS * 3 * K], emo[POINTS * 3], b[POINTS * 3], r[POINTS * 3];
};

/* Rows where light k's rim casts rim_gain[k] times its own light at the light's strength, with
 * relative noise `noise`: a_k and the rims' light (up to rim_size) drawn independently per point
 * and channel, as a rim lights other points than the light's seen part. B = 0 and no lights-off
 * correction. */
static void make_rows(struct made_rows *mr, const double rim_gain[K], double rim_size, double noise,
                      uint64_t seed)
{
    struct esr_rng rng = esr_rng_init(seed, 7);
    for (size_t i = 0; i < POINTS * 3; i++) {
        double y = 0.0;
        for (int k = 0; k < K; k++) {
            const double a = 0.05 + (double)esr_rng_float(&rng), ar = rim_size * (double)esr_rng_float(&rng);
            mr->a[i * K + (size_t)k] = a;
            mr->ar[i * K + (size_t)k] = ar;
            y += truth[k] * (a + rim_gain[k] * ar);
        }
        mr->emo[i] = y * (1.0 + noise * normal(&rng));
        mr->b[i] = 0.0;
        mr->r[i] = 1.0;
    }
    mr->rows = (struct esr_calib_rows){.n = POINTS, .cap = POINTS, .a = mr->a, .ar = mr->ar,
                                       .emo = mr->emo, .b = mr->b, .r = mr->r, .median = {1, 1, 1}};
}

static void two_lights(struct esr_lights *L)
{
    memset(L, 0, sizeof(*L));
    L->n = K;
    for (int k = 0; k < K; k++)
        L->light[k].area = 1.0f;
}

/* Decides the rims of rows whose rims cast rim_gain; the strengths fitted with that choice. */
static void decide(const double rim_gain[K], double rim_size, double noise, uint64_t seed,
                   int emits[ESR_MAX_LIGHTS], double scale[3][ESR_MAX_LIGHTS])
{
    static struct made_rows mr;
    make_rows(&mr, rim_gain, rim_size, noise, seed);
    struct esr_lights L;
    two_lights(&L);
    int fit[ESR_MAX_LIGHTS];
    assert_int_equal(esr_lights_fitted(&L, fit), K);
    const int has_rim[ESR_MAX_LIGHTS] = {1, 1};
    static double ca[POINTS * K], cy[POINTS];
    float t_on[ESR_MAX_LIGHTS];
    const struct esr_calib_problem pb = {&L, &mr.rows, fit, K, ca, cy};
    assert_int_equal(esr_calib_decide_rims(&pb, has_rim, emits, t_on), 0);
    for (int k = 0; k < K; k++) /* the sign says the choice */
        assert_true(emits[k] ? t_on[k] < -ESR_CALIB_RIM_T : t_on[k] > -ESR_CALIB_RIM_T);
    assert_int_equal(esr_calib_fit(&pb, emits, scale, NULL, NULL, NULL), 0);
}

/* Light 0's rim is in the rows, light 1's is not: 0's emits, 1's stays dark, and the strengths
 * come back within a few percent in every channel (the fit without the rim would make light 0
 * stronger to stand in for it). */
static void test_rim_in_the_rows_emits(void **state)
{
    (void)state;
    const double gain[K] = {1.0, 0.0};
    int emits[ESR_MAX_LIGHTS];
    double scale[3][ESR_MAX_LIGHTS];
    decide(gain, 0.5, 0.05, 11, emits, scale);
    print_message("rims cast (1, 0): emits (%d, %d), strengths %.3f %.3f (truth 3, 5)\n", emits[0],
                  emits[1], scale[0][0], scale[0][1]);
    assert_int_equal(emits[0], 1);
    assert_int_equal(emits[1], 0);
    for (int c = 0; c < 3; c++)
        for (int k = 0; k < K; k++)
            assert_true(fabs(scale[c][k] - truth[k]) < 0.03 * truth[k]);
}

/* The other way round, and both. */
static void test_rim_choice_follows_the_rows(void **state)
{
    (void)state;
    const double gains[3][K] = {{0.0, 1.0}, {1.0, 1.0}, {0.0, 0.0}};
    const int want[3][K] = {{0, 1}, {1, 1}, {0, 0}};
    for (int t = 0; t < 3; t++) {
        int emits[ESR_MAX_LIGHTS];
        double scale[3][ESR_MAX_LIGHTS];
        decide(gains[t], 0.5, 0.05, 11, emits, scale);
        assert_int_equal(emits[0], want[t][0]);
        assert_int_equal(emits[1], want[t][1]);
    }
}

/* Rims too faint to tell (a fiftieth of their lights' light, half of it in the rows, noise 20%)
 * change nothing, over 16 draws: the choice is one the rows make clearly. Taking any lower loss
 * instead (ESR_CALIB_RIM_T 0) turns rims on in 16 of these 32 chances. */
static void test_rim_in_the_noise_stays_dark(void **state)
{
    (void)state;
    const double gain[K] = {0.5, 0.5};
    int on = 0;
    for (uint64_t seed = 1; seed <= 16; seed++) {
        int emits[ESR_MAX_LIGHTS];
        double scale[3][ESR_MAX_LIGHTS];
        decide(gain, 0.01, 0.2, seed, emits, scale);
        on += emits[0] + emits[1];
    }
    print_message("rims in the noise: %d of 32 turned on\n", on);
    assert_int_equal(on, 0);
}

/* What the trainer and `esr lights` say about a rim: nothing without one, the choice and how
 * clearly otherwise. */
static void test_rim_text(void **state)
{
    (void)state;
    struct esr_lights L;
    two_lights(&L);
    char line[320];
    assert_int_equal(esr_lights_rim_text(&L, 0, line, sizeof line), 0);
    assert_string_equal(line, "");
    L.rim[0] = (struct esr_light_rim){145, 1, -7.4f};
    L.rim[1] = (struct esr_light_rim){1, 0, 1.0f};
    assert_int_equal(esr_lights_rim_text(&L, 0, line, sizeof line), 1);
    assert_non_null(strstr(line, "light 0: its rim of 145 surface points"));
    assert_non_null(strstr(line, "emits"));
    assert_non_null(strstr(line, "by 7.4 standard errors"));
    assert_int_equal(esr_lights_rim_text(&L, 1, line, sizeof line), 1);
    assert_non_null(strstr(line, "rim of 1 surface point that"));
    assert_non_null(strstr(line, "stays dark"));
    assert_non_null(strstr(line, "(-1.0 standard errors, 3 needed)"));
    assert_int_equal(esr_lights_rim_text(&L, 2, line, sizeof line), 0); /* no such light */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rim_in_the_rows_emits),
        cmocka_unit_test(test_rim_choice_follows_the_rows),
        cmocka_unit_test(test_rim_in_the_noise_stays_dark),
        cmocka_unit_test(test_rim_text),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
