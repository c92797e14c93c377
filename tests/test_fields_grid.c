/* Dense voxel grids: trilinear interpolation, its adjoints, clamping, determinism, and the
 * hierarchical geometry feature. */
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
#include "fields/geo_feature.h"
#include "fields/grid.h"
#include "test_grad.h"

static const float BMIN[3] = {-1.5f, -1.0f, -0.5f};
static const float BMAX[3] = {1.5f, 2.0f, 0.7f};

static struct esr_grid make_grid(int C, int nx, int ny, int nz)
{
    struct esr_grid g;
    assert_int_equal(esr_grid_init(&g, C, nx, ny, nz, BMIN, BMAX), ESR_OK);
    return g;
}

/* value of channel c of a linear test field */
static float linear_field(const float p[3], int c) { return 0.3f + c + (0.7f - c) * p[0] - 1.2f * p[1] + (2.0f + c) * p[2]; }

static void fill_linear(const struct esr_grid *g, float *data)
{
    for (int iz = 0; iz < g->nz; iz++)
        for (int iy = 0; iy < g->ny; iy++)
            for (int ix = 0; ix < g->nx; ix++) {
                float p[3];
                esr_grid_voxel_pos(g, ix, iy, iz, p);
                for (int c = 0; c < g->channels; c++)
                    data[(((size_t)iz * g->ny + iy) * g->nx + ix) * g->channels + c] = linear_field(p, c);
            }
}

static void test_init_rejects_bad_grids(void **state)
{
    (void)state;
    struct esr_grid g;
    const float flat[3] = {1.5f, -1.0f, 0.7f};
    assert_int_equal(esr_grid_init(&g, 0, 4, 4, 4, BMIN, BMAX), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "channel"));
    esr_error_clear();
    assert_int_equal(esr_grid_init(&g, 1, 1, 4, 4, BMIN, BMAX), ESR_ERR);
    esr_error_clear();
    assert_int_equal(esr_grid_init(&g, 1, 4, 4, 4, BMIN, flat), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "axis 1"));
    esr_error_clear();
    g = make_grid(3, 5, 6, 7);
    assert_int_equal(esr_grid_count(&g), 5 * 6 * 7 * 3);
    assert_true(fabsf(esr_grid_voxel_size(&g, 1) - 3.0f / 5.0f) < 1e-6f);
}

/* Trilinear interpolation reproduces a linear field exactly, and its spatial gradient is the
 * field's slope; outside the box the value is clamped and the slope along that axis is 0. */
static void test_linear_field_and_point_gradient(void **state)
{
    (void)state;
    struct esr_grid g = make_grid(2, 5, 7, 4);
    float *data = malloc(esr_grid_count(&g) * sizeof(float));
    fill_linear(&g, data);
    enum { N = 200 };
    float pts[N * 3], out[N * 2], dp[N * 3];
    for (int i = 0; i < N; i++)
        for (int a = 0; a < 3; a++)
            test_fill_uniform(&pts[i * 3 + a], 1, BMIN[a], BMAX[a], (uint64_t)(i * 3 + a));
    esr_grid_sample_fwd(&g, data, pts, N, out);
    esr_grid_sample_dpoint(&g, data, 1, pts, N, dp);
    for (int i = 0; i < N; i++) {
        for (int c = 0; c < 2; c++)
            assert_true(test_close(out[i * 2 + c], linear_field(pts + i * 3, c), 1e-5, 1e-5));
        assert_true(test_close(dp[i * 3 + 0], -0.3, 1e-4, 1e-4));
        assert_true(test_close(dp[i * 3 + 1], -1.2, 1e-4, 1e-4));
        assert_true(test_close(dp[i * 3 + 2], 3.0, 1e-4, 1e-4));
    }
    /* outside along x: clamped to the x = bmax face */
    float q[3] = {BMAX[0] + 0.4f, 0.3f, 0.1f}, qc[3] = {BMAX[0], 0.3f, 0.1f}, v[2], vc[2], d[3];
    esr_grid_sample_fwd(&g, data, q, 1, v);
    esr_grid_sample_fwd(&g, data, qc, 1, vc);
    esr_grid_sample_dpoint(&g, data, 0, q, 1, d);
    assert_true(fabsf(v[0] - vc[0]) < 1e-5f && fabsf(v[1] - vc[1]) < 1e-5f);
    assert_true(d[0] == 0.0f);
    assert_true(test_close(d[1], -1.2, 1e-4, 1e-4));
    /* on the faces themselves (inside the closed box) the slope is the cell's, one-sided */
    for (int a = 0; a < 3; a++)
        for (int side = 0; side < 2; side++) {
            float f[3] = {0.3f * BMIN[0] + 0.7f * BMAX[0], 0.6f * BMIN[1] + 0.4f * BMAX[1],
                          0.5f * BMIN[2] + 0.5f * BMAX[2]};
            f[a] = side ? BMAX[a] : BMIN[a];
            esr_grid_sample_dpoint(&g, data, 1, f, 1, d);
            assert_true(test_close(d[0], -0.3, 1e-4, 1e-4));
            assert_true(test_close(d[1], -1.2, 1e-4, 1e-4));
            assert_true(test_close(d[2], 3.0, 1e-4, 1e-4));
        }
    /* the last lattice point's own position (as marching cubes places vertices), which may
     * round past the face */
    float corner[3];
    esr_grid_voxel_pos(&g, g.nx - 1, g.ny - 1, g.nz - 1, corner);
    esr_grid_sample_dpoint(&g, data, 1, corner, 1, d);
    assert_true(test_close(d[0], -0.3, 1e-4, 1e-4));
    assert_true(test_close(d[1], -1.2, 1e-4, 1e-4));
    assert_true(test_close(d[2], 3.0, 1e-4, 1e-4));
    free(data);
}

/* Spatial gradient against central differences on a random (non-linear) grid. */
static void test_point_gradient_fd(void **state)
{
    (void)state;
    struct esr_grid g = make_grid(1, 6, 5, 7);
    float *data = malloc(esr_grid_count(&g) * sizeof(float));
    test_fill_uniform(data, esr_grid_count(&g), -1.0f, 1.0f, 7);
    for (int i = 0; i < 50; i++) {
        float p[3], dp[3];
        for (int a = 0; a < 3; a++)
            test_fill_uniform(&p[a], 1, BMIN[a] + 0.05f, BMAX[a] - 0.05f, (uint64_t)(100 + i * 3 + a));
        esr_grid_sample_dpoint(&g, data, 0, p, 1, dp);
        for (int a = 0; a < 3; a++) {
            const float h = 1e-3f;
            float pp[3] = {p[0], p[1], p[2]}, pm[3] = {p[0], p[1], p[2]}, vp, vm;
            pp[a] += h;
            pm[a] -= h;
            esr_grid_sample_fwd(&g, data, pp, 1, &vp);
            esr_grid_sample_fwd(&g, data, pm, 1, &vm);
            /* skip points where the difference straddles a cell face (kink) */
            float u = (p[a] - g.bmin[a]) / esr_grid_voxel_size(&g, a);
            if (fabsf(u - roundf(u)) < 0.01f)
                continue;
            assert_true(test_close(dp[a], ((double)vp - vm) / (2.0 * h), 2e-2, 1e-2));
        }
        float v1, v2, dp2[3];
        esr_grid_sample_fwd(&g, data, p, 1, &v1);
        esr_grid_sample_value_dpoint(&g, data, p, 1, &v2, dp2);
        assert_true(fabsf(v1 - v2) < 1e-5f);
        for (int a = 0; a < 3; a++)
            assert_true(test_close(dp2[a], dp[a], 1e-4, 1e-4));
    }
    free(data);
}

/* Backward of the sampler against central differences of loss = <d_out, fwd(data)> on a few
 * entries, plus the adjoint identity over the whole grid. */
static void test_sample_bwd(void **state)
{
    (void)state;
    struct esr_grid g = make_grid(3, 4, 5, 6);
    size_t cnt = esr_grid_count(&g);
    enum { N = 300 };
    float *data = malloc(cnt * sizeof(float)), *grad = calloc(cnt, sizeof(float));
    float pts[N * 3], d_out[N * 3], out[N * 3];
    test_fill_uniform(data, cnt, -1.0f, 1.0f, 1);
    for (int i = 0; i < N; i++)
        for (int a = 0; a < 3; a++)
            test_fill_uniform(&pts[i * 3 + a], 1, BMIN[a] - 0.2f, BMAX[a] + 0.2f, (uint64_t)(1000 + i * 3 + a));
    test_fill_uniform(d_out, N * 3, -1.0f, 1.0f, 2);
    esr_grid_sample_bwd(&g, pts, N, d_out, grad);
    for (size_t e = 0; e < cnt; e += 37) {
        const float h = 1e-2f;
        float keep = data[e];
        data[e] = keep + h;
        esr_grid_sample_fwd(&g, data, pts, N, out);
        double lp = test_dot(out, d_out, N * 3);
        data[e] = keep - h;
        esr_grid_sample_fwd(&g, data, pts, N, out);
        double lm = test_dot(out, d_out, N * 3);
        data[e] = keep;
        assert_true(test_close(grad[e], (lp - lm) / (2.0 * h), 1e-3, 1e-3));
    }
    esr_grid_sample_fwd(&g, data, pts, N, out);
    assert_true(test_close(test_dot(out, d_out, N * 3), test_dot(grad, data, cnt), 1e-3, 1e-4));
    free(data);
    free(grad);
}

/* The point-gradient's adjoint w.r.t. the grid: <d_dp, dpoint(data)> = <dpoint_bwd(d_dp), data>. */
static void test_dpoint_bwd_adjoint(void **state)
{
    (void)state;
    struct esr_grid g = make_grid(2, 5, 4, 6);
    size_t cnt = esr_grid_count(&g);
    enum { N = 200 };
    float *data = malloc(cnt * sizeof(float)), *grad = calloc(cnt, sizeof(float));
    float pts[N * 3], d_dp[N * 3], dp[N * 3];
    test_fill_uniform(data, cnt, -1.0f, 1.0f, 3);
    for (int i = 0; i < N; i++)
        for (int a = 0; a < 3; a++)
            test_fill_uniform(&pts[i * 3 + a], 1, BMIN[a], BMAX[a], (uint64_t)(5000 + i * 3 + a));
    test_fill_uniform(d_dp, N * 3, -1.0f, 1.0f, 4);
    esr_grid_sample_dpoint(&g, data, 1, pts, N, dp);
    esr_grid_sample_dpoint_bwd(&g, 1, pts, N, d_dp, grad);
    for (size_t e = 0; e < cnt; e += 2)
        assert_true(grad[e] == 0.0f); /* channel 0 untouched */
    assert_true(test_close(test_dot(dp, d_dp, N * 3), test_dot(grad, data, cnt), 1e-3, 1e-4));
    free(data);
    free(grad);
}

/* The fused SDF backward equals the value backward plus the point-gradient backward. */
static void test_value_dpoint_bwd(void **state)
{
    (void)state;
    struct esr_grid g = make_grid(1, 6, 5, 7);
    size_t cnt = esr_grid_count(&g);
    enum { N = 300 };
    float *ref = calloc(cnt, sizeof(float)), *grad = calloc(cnt, sizeof(float));
    float pts[N * 3], d_v[N], d_dp[N * 3];
    for (int i = 0; i < N; i++)
        for (int a = 0; a < 3; a++)
            test_fill_uniform(&pts[i * 3 + a], 1, BMIN[a] - 0.1f, BMAX[a] + 0.1f, (uint64_t)(7000 + i * 3 + a));
    test_fill_uniform(d_v, N, -1.0f, 1.0f, 5);
    test_fill_uniform(d_dp, N * 3, -1.0f, 1.0f, 6);
    esr_grid_sample_bwd(&g, pts, N, d_v, ref);
    esr_grid_sample_dpoint_bwd(&g, 0, pts, N, d_dp, ref);
    esr_grid_sample_value_dpoint_bwd(&g, pts, N, d_v, d_dp, grad);
    for (size_t e = 0; e < cnt; e++)
        assert_true(test_close(grad[e], ref[e], 1e-5, 1e-5));
    free(ref);
    free(grad);
}

/* The z-plane ownership scheme gives bit-identical gradients for 1, 2 and 3 threads. */
static void test_bwd_deterministic_across_threads(void **state)
{
    (void)state;
    struct esr_grid g = make_grid(2, 8, 8, 9);
    size_t cnt = esr_grid_count(&g);
    enum { N = 4000 };
    float *pts = malloc(N * 3 * sizeof(float)), *d_out = malloc(N * 2 * sizeof(float));
    float *ref = calloc(cnt, sizeof(float)), *grad = calloc(cnt, sizeof(float));
    for (int i = 0; i < N; i++)
        for (int a = 0; a < 3; a++)
            test_fill_uniform(&pts[i * 3 + a], 1, BMIN[a], BMAX[a], (uint64_t)(9000 + i * 3 + a));
    test_fill_uniform(d_out, N * 2, -1.0f, 1.0f, 5);
    int saved = omp_get_max_threads();
    omp_set_num_threads(1);
    esr_grid_sample_bwd(&g, pts, N, d_out, ref);
    for (int nt = 2; nt <= 3; nt++) {
        memset(grad, 0, cnt * sizeof(float));
        omp_set_num_threads(nt);
        esr_grid_sample_bwd(&g, pts, N, d_out, grad);
        assert_memory_equal(ref, grad, cnt * sizeof(float));
    }
    omp_set_num_threads(saved);
    free(pts);
    free(d_out);
    free(ref);
    free(grad);
}

/* Geometry feature of a linear SDF: neighbours are exact, FD gradients equal the slope, and the
 * normalised version is the unit slope. */
static void test_geo_feature_linear(void **state)
{
    (void)state;
    struct esr_grid g = make_grid(1, 12, 12, 12);
    float *sdf = malloc(esr_grid_count(&g) * sizeof(float));
    fill_linear(&g, sdf);
    struct esr_geo_feature_params p;
    esr_geo_feature_default(&p);
    assert_int_equal(esr_geo_feature_dim(&p), 37);
    const float x[3] = {0.1f, 0.4f, 0.05f}; /* >= 2 voxels from every face */
    float f[37];
    p.normalize = 0;
    assert_int_equal(esr_geo_feature_fwd(&g, sdf, &p, x, 1, f), ESR_OK);
    assert_true(test_close(f[0], linear_field(x, 0), 1e-5, 1e-5));
    float q[3] = {x[0], x[1], x[2] + 1.5f * esr_grid_voxel_size(&g, 2)};
    assert_true(test_close(f[1 + 6 * 2 + 2 * 2 + 1], linear_field(q, 0), 1e-5, 1e-5));
    const float slope[3] = {0.7f, -1.2f, 2.0f};
    for (int k = 0; k < 4; k++)
        for (int a = 0; a < 3; a++)
            assert_true(test_close(f[1 + 24 + 3 * k + a], slope[a], 1e-3, 1e-3));
    p.normalize = 1;
    assert_int_equal(esr_geo_feature_fwd(&g, sdf, &p, x, 1, f), ESR_OK);
    float len = sqrtf(0.49f + 1.44f + 4.0f);
    for (int a = 0; a < 3; a++)
        assert_true(test_close(f[1 + 24 + a], slope[a] / len, 1e-4, 1e-4));
    p.n_scales = 0;
    assert_int_equal(esr_geo_feature_fwd(&g, sdf, &p, x, 1, f), ESR_ERR);
    esr_error_clear();
    free(sdf);
}

/* Each feature sample equals a trilinear lookup at its own position, on the lattice-line path
 * (points at least 3 voxels inside the box) and the per-sample one (near the faces) alike, for
 * the default scales and for scales off the half-voxel lines. */
static void test_geo_feature_samples_match_lookups(void **state)
{
    (void)state;
    struct esr_grid g = make_grid(1, 24, 25, 26);
    const size_t cnt = esr_grid_count(&g);
    enum { N = 300, D = 37 };
    float *sdf = malloc(cnt * sizeof(float)), pts[N * 3], feat[N * D];
    test_fill_uniform(sdf, cnt, -1.0f, 1.0f, 21);
    for (int i = 0; i < N; i++)
        for (int a = 0; a < 3; a++)
            test_fill_uniform(&pts[i * 3 + a], 1, BMIN[a], BMAX[a], (uint64_t)(900 + i * 3 + a));
    struct esr_geo_feature_params p;
    esr_geo_feature_default(&p);
    int inner = 0;
    for (int i = 0; i < N; i++) {
        int in = 1;
        for (int a = 0; a < 3; a++) {
            const float h = esr_grid_voxel_size(&g, a);
            in &= pts[i * 3 + a] > BMIN[a] + 3 * h && pts[i * 3 + a] < BMAX[a] - 3 * h;
        }
        inner += in;
    }
    assert_true(inner > N / 3 && inner < N); /* both paths are exercised */
    for (int variant = 0; variant < 2; variant++) {
        if (variant == 1)
            p.scales[1] = 0.8f; /* not on a lattice line: every point per sample */
        assert_int_equal(esr_geo_feature_fwd(&g, sdf, &p, pts, N, feat), ESR_OK);
        for (int i = 0; i < N; i++)
            for (int j = 0; j < 1 + 6 * p.n_scales; j++) {
                float q[3] = {pts[i * 3], pts[i * 3 + 1], pts[i * 3 + 2]}, v;
                if (j > 0) {
                    const int k = (j - 1) / 6, a = ((j - 1) % 6) / 2, s = (j - 1) % 2;
                    q[a] += (s ? 1.0f : -1.0f) * p.scales[k] * esr_grid_voxel_size(&g, a);
                }
                esr_grid_sample_fwd(&g, sdf, q, 1, &v);
                if (!test_close(feat[i * D + j], v, 1e-5, 1e-5))
                    fail_msg("variant %d, point %d, sample %d: %g, lookup %g", variant, i, j,
                             (double)feat[i * D + j], (double)v);
            }
    }
    free(sdf);
}

/* Geometry feature backward (with and without normalisation) against central differences. */
static void test_geo_feature_bwd_fd(void **state)
{
    (void)state;
    /* points inside (the lattice-line path) and near the faces (per sample) alike */
    struct esr_grid g = make_grid(1, 9, 10, 9);
    size_t cnt = esr_grid_count(&g);
    enum { N = 40, D = 37 };
    float *sdf = malloc(cnt * sizeof(float)), *grad = malloc(cnt * sizeof(float));
    float pts[N * 3], d_feat[N * D], feat[N * D];
    /* a smooth-ish SDF plus noise, so FD normals are well defined */
    fill_linear(&g, sdf);
    float *noise = malloc(cnt * sizeof(float));
    test_fill_uniform(noise, cnt, -0.2f, 0.2f, 11);
    for (size_t e = 0; e < cnt; e++)
        sdf[e] += noise[e];
    for (int i = 0; i < N; i++)
        for (int a = 0; a < 3; a++)
            test_fill_uniform(&pts[i * 3 + a], 1, BMIN[a], BMAX[a], (uint64_t)(300 + i * 3 + a));
    test_fill_uniform(d_feat, N * D, -1.0f, 1.0f, 12);
    struct esr_geo_feature_params p;
    esr_geo_feature_default(&p);
    for (int norm = 0; norm <= 1; norm++) {
        p.normalize = norm;
        memset(grad, 0, cnt * sizeof(float));
        assert_int_equal(esr_geo_feature_fwd(&g, sdf, &p, pts, N, feat), ESR_OK);
        assert_int_equal(esr_geo_feature_bwd(&g, &p, pts, N, feat, d_feat, grad), ESR_OK);
        for (size_t e = 0; e < cnt; e++) {
            const float h = 2e-3f;
            float keep = sdf[e];
            sdf[e] = keep + h;
            esr_geo_feature_fwd(&g, sdf, &p, pts, N, feat);
            double lp = test_dot(feat, d_feat, N * D);
            sdf[e] = keep - h;
            esr_geo_feature_fwd(&g, sdf, &p, pts, N, feat);
            double lm = test_dot(feat, d_feat, N * D);
            sdf[e] = keep;
            /* every entry, not a sample of them */
            if (!test_close(grad[e], (lp - lm) / (2.0 * h), 1e-3, 1e-2))
                fail_msg("normalize %d, entry %zu: analytic %g vs central difference %g", norm, e,
                         (double)grad[e], (lp - lm) / (2.0 * h));
        }
    }
    free(sdf);
    free(grad);
    free(noise);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_init_rejects_bad_grids),
        cmocka_unit_test(test_linear_field_and_point_gradient),
        cmocka_unit_test(test_point_gradient_fd),
        cmocka_unit_test(test_sample_bwd),
        cmocka_unit_test(test_dpoint_bwd_adjoint),
        cmocka_unit_test(test_value_dpoint_bwd),
        cmocka_unit_test(test_bwd_deterministic_across_threads),
        cmocka_unit_test(test_geo_feature_linear),
        cmocka_unit_test(test_geo_feature_samples_match_lookups),
        cmocka_unit_test(test_geo_feature_bwd_fd),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
