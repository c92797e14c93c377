/* The environment map's start (train/env_init.h) measures the surfaces' own lights-off radiance
 * from the previous model's render, which composites the surface over the background. With a
 * learned background (photos without alpha) the background is not white, and what the level
 * measures must not depend on it: a sphere with a soft edge (many rays partly transparent),
 * measured under two learned backgrounds, gives the same level. Taking the background as white
 * moved it by the background's difference times (1 - a) / a. With env_from_photos the level is
 * the photos' own pixels over the rays the model renders opaque, whatever colour the model has. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <string.h>

#include "fields/grid.h"
#include "model/model.h"
#include "test_model.h"
#include "train/env_init.h"

#define SIDE 64
#define NRAYS (SIDE * SIDE)

static void test_level_ignores_the_background(void **state)
{
    (void)state;
    struct esr_train_config cfg;
    test_small_config(&cfg, 0.5f);
    cfg.fine.res = 32;
    cfg.background = ESR_BACKGROUND_LEARNED;
    const float bmin[3] = {-1, -1, -1}, bmax[3] = {1, 1, 1};
    struct esr_model m;
    assert_int_equal(esr_model_init(&m, &cfg, ESR_STAGE_FINE, NULL, bmin, bmax), 0);
    assert_true(esr_model_has(&m, ESR_COMP_BACKGROUND));
    m.inv_s = 25.0f; /* a soft surface: the edge rays are partly transparent */
    const struct esr_grid *g = esr_model_grid(&m, ESR_COMP_SDF);
    float *sdf = esr_model_values(&m, ESR_COMP_SDF);
    for (int z = 0; z < g->nz; z++)
        for (int y = 0; y < g->ny; y++)
            for (int x = 0; x < g->nx; x++) {
                float p[3];
                esr_grid_voxel_pos(g, x, y, z, p);
                sdf[((size_t)z * g->ny + y) * g->nx + x] = sqrtf(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]) - 0.5f;
            }
    test_randomise(&m, ESR_COMP_OFF_FEAT, 0.5f, 5);
    test_randomise(&m, ESR_COMP_OFF_MLP, 0.3f, 6);
    static float o[NRAYS * 3], d[NRAYS * 3];
    for (int i = 0; i < NRAYS; i++) { /* straight down over [-0.7, 0.7]^2: the sphere and beyond */
        o[i * 3 + 0] = -0.7f + 1.4f * (float)(i % SIDE) / (SIDE - 1);
        o[i * 3 + 1] = -0.7f + 1.4f * (float)(i / SIDE) / (SIDE - 1);
        o[i * 3 + 2] = 0.95f;
        d[i * 3 + 0] = 0.0f;
        d[i * 3 + 1] = 0.0f;
        d[i * 3 + 2] = -1.0f;
    }
    float level[2][3], mean[2][3];
    const float logit[2] = {2.0f, -3.0f}; /* backgrounds 0.88 and 0.05 in sRGB */
    float *bg = esr_model_values(&m, ESR_COMP_BACKGROUND);
    for (int k = 0; k < 2; k++) {
        for (size_t i = 0; i < m.part[ESR_COMP_BACKGROUND].count; i++)
            bg[i] = logit[k];
        const struct esr_env_init_rays er = {o, d, NULL, NRAYS};
        assert_int_equal(esr_env_init_level(&m, &er, 3, 0, level[k], mean[k]), 0);
    }
    for (int c = 0; c < 3; c++) {
        assert_true(mean[0][c] > 0.0f);
        assert_float_equal(mean[0][c], mean[1][c], 1e-4f * mean[0][c] + 1e-6f);
        assert_float_equal(level[0][c], level[1][c], 1e-4f * level[0][c] + 1e-6f);
    }
    /* env_from_photos: the photos' pixels (sRGB 0.5 on the sphere, white beyond), made linear,
     * over the rays the model renders opaque, whatever the model's own colour */
    static float rgb[NRAYS * 3];
    for (int i = 0; i < NRAYS; i++) {
        const float x = o[i * 3], y = o[i * 3 + 1];
        for (int c = 0; c < 3; c++)
            rgb[i * 3 + c] = x * x + y * y < 0.25f ? 0.5f - 0.1f * (float)c : 1.0f;
    }
    const struct esr_env_init_rays er = {o, d, rgb, NRAYS};
    for (int k = 0; k < 2; k++) {
        test_randomise(&m, ESR_COMP_OFF_MLP, 0.3f, 6 + (uint64_t)k); /* another colour: no matter */
        assert_int_equal(esr_env_init_level(&m, &er, 3, 1, level[k], mean[k]), 0);
        for (int c = 0; c < 3; c++) {
            const float x = 0.5f - 0.1f * (float)c; /* sRGB to linear, written out */
            const float want = powf((x + 0.055f) / 1.055f, 2.4f);
            assert_float_equal(mean[k][c], want, 1e-5f);
            assert_float_equal(level[k][c], want / ESR_ENV_INIT_AV, 1e-4f);
        }
    }
    esr_model_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_level_ignores_the_background),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
