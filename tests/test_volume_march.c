/* Trace layer 1 on its own (volume/march.h): an SDF grid, no model. Per-ray t ranges and
 * random streams, the kept list against a serial filter, and the gradient of a composite over
 * the march with respect to every SDF value against central differences. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "fields/grid.h"
#include "fields/sdf.h"
#include "volume/composite.h"
#include "volume/march.h"
#include "test_grad.h"

#define RES 10
#define N_RAYS 4

struct scene {
    struct esr_grid grid;
    float *sdf;
    struct esr_march_geometry geom;
    float orig[N_RAYS * 3], dir[N_RAYS * 3];
};

/* A noisy sphere in [-1, 1]^3 (the noise keeps the trilinear SDF from being exactly flat in
 * the centre cell, where NeuS's cosine sits on its kink) and four rays through it. */
static void make_scene(struct scene *s)
{
    const float bmin[3] = {-1, -1, -1}, bmax[3] = {1, 1, 1};
    assert_int_equal(esr_grid_init(&s->grid, 1, RES, RES, RES, bmin, bmax), 0);
    size_t n = esr_grid_count(&s->grid);
    s->sdf = malloc(n * sizeof(float));
    float *noise = malloc(n * sizeof(float));
    assert_int_equal(esr_sdf_init_sphere(&s->grid, s->sdf, 0.5f), 0);
    test_fill_uniform(noise, n, -0.03f, 0.03f, 3);
    for (size_t i = 0; i < n; i++)
        s->sdf[i] += noise[i];
    free(noise);
    memset(&s->geom, 0, sizeof s->geom);
    s->geom.alpha = ESR_MARCH_NEUS;
    s->geom.grid = &s->grid;
    s->geom.values = s->sdf;
    s->geom.inv_s = 8.0f;
    s->geom.step = 0.5f * esr_grid_voxel_size(&s->grid, 0);
    for (int a = 0; a < 3; a++) {
        s->geom.bmin[a] = bmin[a];
        s->geom.bmax[a] = bmax[a];
    }
    const float o[N_RAYS][3] = {{0.1f, -3, 0.15f}, {-3, 0.2f, -0.1f}, {0.05f, 0.1f, 3}, {-2, -2, -2}};
    const float d[N_RAYS][3] = {{0.02f, 1, -0.03f}, {1, -0.04f, 0.05f}, {0, -0.02f, -1}, {1, 1.02f, 0.98f}};
    for (int r = 0; r < N_RAYS; r++) {
        float len = sqrtf(d[r][0] * d[r][0] + d[r][1] * d[r][1] + d[r][2] * d[r][2]);
        for (int a = 0; a < 3; a++) {
            s->orig[r * 3 + a] = o[r][a];
            s->dir[r * 3 + a] = d[r][a] / len;
        }
    }
}

static struct esr_march_rays rays_of(const struct scene *s, int n)
{
    struct esr_march_rays r;
    memset(&r, 0, sizeof r);
    r.n = n;
    r.origins = s->orig;
    r.dirs = s->dir;
    r.seed = 5;
    r.jitter = 1;
    return r;
}

static void test_t_range_and_streams(void **state)
{
    (void)state;
    struct scene s;
    make_scene(&s);
    struct esr_march mc;
    assert_int_equal(esr_march_init(&mc, N_RAYS, 1), 0);
    /* per-ray t ranges: every sample inside its ray's range */
    const float t_min[N_RAYS] = {2.7f, 0.0f, 2.9f, 3.0f}, t_max[N_RAYS] = {3.1f, 1e30f, 3.3f, 3.2f};
    struct esr_march_rays r = rays_of(&s, N_RAYS);
    r.t_min = t_min;
    r.t_max = t_max;
    assert_int_equal(esr_march_fwd(&mc, &s.geom, &r), 0);
    for (int k = 0; k < N_RAYS; k++) {
        assert_true(mc.smp.ray_start[k + 1] > mc.smp.ray_start[k]); /* each range meets the box */
        for (size_t i = mc.smp.ray_start[k]; i < mc.smp.ray_start[k + 1]; i++)
            assert_true(mc.smp.t[i] >= t_min[k] && mc.smp.t[i] <= t_max[k]);
    }
    /* a ray's own stream: the same jitter whatever its position in the batch */
    uint64_t streams[N_RAYS] = {40, 41, 42, 43};
    r = rays_of(&s, N_RAYS);
    r.streams = streams;
    assert_int_equal(esr_march_fwd(&mc, &s.geom, &r), 0);
    size_t n3 = mc.smp.ray_start[4] - mc.smp.ray_start[3];
    float *t3 = malloc(n3 * sizeof(float));
    memcpy(t3, mc.smp.t + mc.smp.ray_start[3], n3 * sizeof(float));
    /* ray 3 alone, as row 0 of a one-ray batch, with its stream */
    struct esr_march_rays one = rays_of(&s, 1);
    one.origins = s.orig + 9;
    one.dirs = s.dir + 9;
    one.streams = streams + 3;
    assert_int_equal(esr_march_fwd(&mc, &s.geom, &one), 0);
    assert_int_equal(mc.smp.ray_start[1], n3);
    assert_memory_equal(mc.smp.t, t3, n3 * sizeof(float));
    /* without streams, row 0 uses stream 0: different jitter */
    one.streams = NULL;
    assert_int_equal(esr_march_fwd(&mc, &s.geom, &one), 0);
    assert_true(mc.smp.ray_start[1] != n3 || memcmp(mc.smp.t, t3, n3 * sizeof(float)) != 0);
    free(t3);
    esr_march_free(&mc);
    free(s.sdf);
}

static void test_kept_list(void **state)
{
    (void)state;
    struct scene s;
    make_scene(&s);
    struct esr_march mc;
    assert_int_equal(esr_march_init(&mc, N_RAYS, 1), 0);
    struct esr_march_rays r = rays_of(&s, N_RAYS);
    assert_int_equal(esr_march_fwd(&mc, &s.geom, &r), 0);
    /* the serial reference: every sample with weight above the threshold, in sample order */
    size_t k = 0;
    for (int ray = 0; ray < N_RAYS; ray++) {
        assert_int_equal(mc.kept_start[ray], k);
        for (size_t i = mc.smp.ray_start[ray]; i < mc.smp.ray_start[ray + 1]; i++) {
            if (!esr_composite_keep(mc.weight[i], ESR_COMPOSITE_THRES))
                continue;
            assert_true(k < mc.n_kept);
            assert_int_equal(mc.kidx[k], i);
            assert_int_equal(mc.kray[k], ray);
            assert_int_equal(mc.kept_row[i], k);
            assert_memory_equal(mc.kpos3 + k * 3, mc.smp.pos + i * 3, 3 * sizeof(float));
            assert_memory_equal(mc.kdir3 + k * 3, s.dir + ray * 3, 3 * sizeof(float));
            k++;
        }
    }
    assert_int_equal(k, mc.n_kept);
    assert_int_equal(mc.kept_start[N_RAYS], k);
    assert_true(k >= N_RAYS); /* every ray hits the sphere */
    esr_march_free(&mc);
    free(s.sdf);
}

/* sum over rays of d_out . composite(values on kept rows, white background) */
static double composite_loss(struct esr_march *mc, const struct scene *s, const float *values,
                             const float *d_out)
{
    struct esr_march_rays r = rays_of(s, N_RAYS);
    assert_int_equal(esr_march_fwd(mc, &s->geom, &r), 0);
    static const float white[3] = {1, 1, 1};
    struct esr_composite_args a;
    esr_march_composite_args(mc, values, 3, white, 0, &a);
    float out[N_RAYS * 3];
    esr_composite_fwd(&a, out);
    return test_dot(out, d_out, N_RAYS * 3);
}

static void test_gradient_every_sdf_value(void **state)
{
    (void)state;
    struct scene s;
    make_scene(&s);
    struct esr_march mc;
    assert_int_equal(esr_march_init(&mc, N_RAYS, 1), 0);
    float d_out[N_RAYS * 3];
    test_fill_uniform(d_out, N_RAYS * 3, -1.0f, 1.0f, 8);
    /* values per kept row of the unperturbed march; perturbations that change the kept set
     * (a weight crossing the threshold: a true discontinuity) are skipped and counted */
    struct esr_march_rays r = rays_of(&s, N_RAYS);
    assert_int_equal(esr_march_fwd(&mc, &s.geom, &r), 0);
    const size_t nk = mc.n_kept;
    float *values = malloc(nk * 3 * sizeof(float));
    uint32_t *kidx = malloc(nk * sizeof(uint32_t));
    memcpy(kidx, mc.kidx, nk * sizeof(uint32_t));
    test_fill_uniform(values, nk * 3, 0.0f, 1.0f, 9);
    static const float white[3] = {1, 1, 1};
    struct esr_composite_args a;
    esr_march_composite_args(&mc, values, 3, white, 0, &a);
    esr_march_zero_d_alpha(&mc);
    esr_composite_bwd(&a, d_out, mc.d_alpha, NULL);
    const size_t n = esr_grid_count(&s.grid);
    float *grad = calloc(n, sizeof(float));
    esr_march_bwd(&mc, grad);
    size_t live = 0, skipped = 0;
    const float h = 1e-3f;
    for (size_t e = 0; e < n; e++) {
        float keep = s.sdf[e];
        s.sdf[e] = keep + h;
        double lp = composite_loss(&mc, &s, values, d_out);
        int same = mc.n_kept == nk && !memcmp(mc.kidx, kidx, nk * sizeof(uint32_t));
        s.sdf[e] = keep - h;
        double lm = composite_loss(&mc, &s, values, d_out);
        same &= mc.n_kept == nk && !memcmp(mc.kidx, kidx, nk * sizeof(uint32_t));
        s.sdf[e] = keep;
        if (!same) {
            skipped++;
            continue;
        }
        double fd = (lp - lm) / (2.0 * h);
        live += grad[e] != 0.0f;
        if (!test_close(grad[e], fd, 2e-4, 2e-2))
            fail_msg("SDF value %zu: analytic %g vs central difference %g", e, (double)grad[e], fd);
    }
    assert_true(live > 50);      /* the rays reach a good part of the grid */
    assert_true(skipped < n / 50); /* and the check was not skipped wholesale */
    free(grad);
    free(values);
    free(kidx);
    esr_march_free(&mc);
    free(s.sdf);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_t_range_and_streams),
        cmocka_unit_test(test_kept_list),
        cmocka_unit_test(test_gradient_every_sdf_value),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
