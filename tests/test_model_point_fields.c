/* Trace layer 2 on its own (model/point_fields.h): heads at arbitrary points, each row with its
 * own lighting flag. A batch that mixes lights-off and lights-on rows in any order must give
 * each row what a batch of only its kind gives it, and a gradient that is the sum of the two
 * kinds' gradients; the off branch of lights-on rows gets none (stop-gradient). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "fields/sdf.h"
#include "model/model.h"
#include "model/point_fields.h"
#include "test_grad.h"
#include "test_model.h"

#define N 7

static const uint8_t LIGHTS[N] = {1, 0, 1, 1, 0, 0, 1};

struct run {
    float tone[N * 3], lin[N * 3];
    float *grads, *g_sdf;
};

static void make_model(struct esr_model *m, enum esr_stage stage)
{
    struct esr_train_config cfg;
    test_small_config(&cfg, 0.5f);
    const float bmin[3] = {-1, -1, -1}, bmax[3] = {1, 1, 1};
    assert_int_equal(esr_model_init(m, &cfg, stage, NULL, bmin, bmax), 0);
    assert_int_equal(esr_sdf_init_sphere(esr_model_grid(m, ESR_COMP_SDF),
                                         esr_model_values(m, ESR_COMP_SDF), 0.5f), 0);
    test_randomise(m, ESR_COMP_SDF, 0.02f, 1);
    for (int c = 0; c < ESR_COMP_COUNT; c++)
        if (esr_model_has(m, (enum esr_component)c) && c != ESR_COMP_SDF)
            test_randomise(m, (enum esr_component)c, 0.3f, 10 + (uint64_t)c);
}

/* Rows `rows` of the fixed point set (all N when rows is NULL) through the fields, forward and
 * backward with fixed upstream gradients; results land in the caller's rows of `out`. */
static void run_rows(const struct esr_model *m, const int *rows, int n, const uint8_t *lights,
                     struct run *out)
{
    float pos[N * 3], dir[N * 3], all_pos[N * 3], all_dir[N * 3], d_tone[N * 3], d_lin[N * 3];
    float all_dt[N * 3], all_dl[N * 3];
    uint8_t on[N];
    test_fill_uniform(all_pos, N * 3, -0.6f, 0.6f, 2);
    test_fill_uniform(all_dir, N * 3, -1.0f, 1.0f, 3);
    test_fill_uniform(all_dt, N * 3, -1.0f, 1.0f, 4);
    test_fill_uniform(all_dl, N * 3, -1.0f, 1.0f, 5);
    for (int j = 0; j < n; j++) {
        int i = rows ? rows[j] : j;
        float len = sqrtf(all_dir[i * 3] * all_dir[i * 3] + all_dir[i * 3 + 1] * all_dir[i * 3 + 1] +
                          all_dir[i * 3 + 2] * all_dir[i * 3 + 2]);
        for (int a = 0; a < 3; a++) {
            pos[j * 3 + a] = all_pos[i * 3 + a];
            dir[j * 3 + a] = all_dir[i * 3 + a] / len;
            d_tone[j * 3 + a] = all_dt[i * 3 + a];
            d_lin[j * 3 + a] = all_dl[i * 3 + a];
        }
        on[j] = lights ? lights[i] : 0;
    }
    struct esr_point_fields pf;
    assert_int_equal(esr_point_fields_init(&pf, m, 4, 1), 0); /* grows on the first call */
    struct esr_point_query q = {(size_t)n, pos, dir, lights ? on : NULL};
    const float *sdf = esr_model_values(m, ESR_COMP_SDF);
    assert_int_equal(esr_point_fields_fwd(&pf, m, sdf, &q), 0);
    for (int j = 0; j < n; j++) {
        int i = rows ? rows[j] : j;
        for (int a = 0; a < 3; a++) {
            out->tone[i * 3 + a] = pf.tone3[j * 3 + a];
            out->lin[i * 3 + a] = pf.lin3 ? pf.lin3[j * 3 + a] : 0.0f;
        }
    }
    assert_int_equal(esr_point_fields_bwd(&pf, m, out->g_sdf, out->grads, d_tone,
                                          pf.lin3 ? d_lin : NULL), 0);
    esr_point_fields_free(&pf);
}

static void alloc_run(const struct esr_model *m, struct run *r)
{
    r->grads = calloc(m->params.count, sizeof(float));
    r->g_sdf = calloc(m->part[ESR_COMP_SDF].count, sizeof(float));
    assert_true(r->grads && r->g_sdf);
}

static void free_run(struct run *r)
{
    free(r->grads);
    free(r->g_sdf);
}

static void check_mixed_equals_split(enum esr_stage stage)
{
    struct esr_model m;
    make_model(&m, stage);
    struct run mixed, split;
    alloc_run(&m, &mixed);
    alloc_run(&m, &split);
    run_rows(&m, NULL, N, LIGHTS, &mixed);
    /* the same rows in two single-kind batches, gradients accumulated into one buffer */
    int off_rows[N], on_rows[N], n_off = 0, n_on = 0;
    for (int i = 0; i < N; i++) {
        if (LIGHTS[i])
            on_rows[n_on++] = i;
        else
            off_rows[n_off++] = i;
    }
    run_rows(&m, off_rows, n_off, LIGHTS, &split);
    run_rows(&m, on_rows, n_on, LIGHTS, &split);
    for (int i = 0; i < N * 3; i++) {
        assert_true(test_close(mixed.tone[i], split.tone[i], 1e-6, 1e-5));
        assert_true(test_close(mixed.lin[i], split.lin[i], 1e-6, 1e-5));
    }
    size_t live = 0;
    for (size_t e = 0; e < m.params.count; e++) {
        live += mixed.grads[e] != 0.0f;
        if (!test_close(mixed.grads[e], split.grads[e], 1e-6, 1e-4))
            fail_msg("parameter %zu: mixed batch %g vs split batches %g", e,
                     (double)mixed.grads[e], (double)split.grads[e]);
    }
    assert_true(live > 0);
    for (size_t e = 0; e < m.part[ESR_COMP_SDF].count; e++)
        assert_true(test_close(mixed.g_sdf[e], split.g_sdf[e], 1e-6, 1e-4));
    free_run(&mixed);
    free_run(&split);
    esr_model_free(&m);
}

static void test_radiance_mixed_equals_split(void **state)
{
    (void)state;
    check_mixed_equals_split(ESR_STAGE_FINE);
}

static void test_colour_mlp_mixed_equals_split(void **state)
{
    (void)state;
    check_mixed_equals_split(ESR_STAGE_COARSE);
}

static int component_zero(const struct esr_model *m, const float *grads, enum esr_component c)
{
    for (size_t i = 0; i < m->part[c].count; i++)
        if (grads[m->part[c].off + i] != 0.0f)
            return 0;
    return 1;
}

static void test_lights_flag_selects_branches(void **state)
{
    (void)state;
    struct esr_model m;
    make_model(&m, ESR_STAGE_FINE);
    static const uint8_t all_on[N] = {1, 1, 1, 1, 1, 1, 1};
    struct run on, off;
    alloc_run(&m, &on);
    alloc_run(&m, &off);
    run_rows(&m, NULL, N, all_on, &on);
    run_rows(&m, NULL, N, NULL, &off); /* NULL flags: every row lights-off */
    /* stop-gradient: lights-on rows never train the off branch; lights-off rows never reach emo */
    assert_true(component_zero(&m, on.grads, ESR_COMP_OFF_MLP));
    assert_true(component_zero(&m, on.grads, ESR_COMP_OFF_FEAT));
    assert_false(component_zero(&m, on.grads, ESR_COMP_EMO_MLP));
    assert_true(component_zero(&m, off.grads, ESR_COMP_EMO_MLP));
    assert_true(component_zero(&m, off.grads, ESR_COMP_EMO_FEAT));
    assert_false(component_zero(&m, off.grads, ESR_COMP_OFF_MLP));
    /* L_on = L_off + L_emo with L_emo > 0 (softplus): every lights-on channel is brighter */
    for (int i = 0; i < N * 3; i++)
        assert_true(on.lin[i] > off.lin[i]);
    free_run(&on);
    free_run(&off);
    esr_model_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_radiance_mixed_equals_split),
        cmocka_unit_test(test_colour_mlp_mixed_equals_split),
        cmocka_unit_test(test_lights_flag_selects_branches),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
