/* Whole-grid operations: sphere init, Gaussian smoothing (and adjoint), resampling, total
 * variation, density alpha and the mask cache. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "fields/density.h"
#include "fields/grid.h"
#include "fields/mask.h"
#include "fields/sdf.h"
#include "test_grad.h"

static const float BMIN[3] = {-1.5f, -1.5f, -1.5f};
static const float BMAX[3] = {1.5f, 1.5f, 1.5f};

static struct esr_grid make_grid(int C, int nx, int ny, int nz)
{
    struct esr_grid g;
    assert_int_equal(esr_grid_init(&g, C, nx, ny, nz, BMIN, BMAX), ESR_OK);
    return g;
}

static size_t vidx(const struct esr_grid *g, int x, int y, int z) { return ((size_t)z * g->ny + y) * g->nx + x; }

static void test_sphere_init(void **state)
{
    (void)state;
    struct esr_grid g = make_grid(1, 9, 9, 9);
    float *d = malloc(esr_grid_count(&g) * sizeof(float));
    assert_int_equal(esr_sdf_init_sphere(&g, d, 1.0f), ESR_OK);
    assert_true(fabsf(d[vidx(&g, 4, 4, 4)] + 1.0f) < 1e-6f);         /* centre: -r */
    assert_true(fabsf(d[vidx(&g, 8, 4, 4)] - 0.0f) < 1e-6f);         /* face centre: |x_n| = 1 */
    assert_true(fabsf(d[vidx(&g, 0, 0, 0)] - (sqrtf(3.0f) - 1.0f)) < 1e-5f);
    assert_true(fabsf(d[vidx(&g, 6, 4, 4)] + 0.5f) < 1e-6f);
    struct esr_grid g2 = make_grid(2, 4, 4, 4);
    assert_int_equal(esr_sdf_init_sphere(&g2, d, 1.0f), ESR_ERR);
    esr_error_clear();
    free(d);
}

/* Smoothing keeps constant and linear fields everywhere (reflected extension), really smooths
 * noise, and its backward is the exact transpose. */
static void test_smooth(void **state)
{
    (void)state;
    struct esr_grid g = make_grid(2, 7, 6, 8);
    size_t cnt = esr_grid_count(&g);
    float *src = malloc(cnt * sizeof(float)), *dst = malloc(cnt * sizeof(float));
    float *scr = malloc(cnt * sizeof(float)), *y = malloc(cnt * sizeof(float));
    float *adj = calloc(cnt, sizeof(float));
    for (int z = 0; z < g.nz; z++)
        for (int yy = 0; yy < g.ny; yy++)
            for (int x = 0; x < g.nx; x++) {
                src[vidx(&g, x, yy, z) * 2 + 0] = 0.75f;
                src[vidx(&g, x, yy, z) * 2 + 1] = 0.2f * x - 0.5f * yy + 0.3f * z + 1.0f;
            }
    assert_int_equal(esr_grid_smooth_fwd(&g, src, dst, scr, 5, 0.8f), ESR_OK);
    for (size_t e = 0; e < cnt; e++)
        assert_true(fabsf(dst[e] - src[e]) < 1e-5f);
    /* in place (src == dst) gives the same */
    memcpy(y, src, cnt * sizeof(float));
    assert_int_equal(esr_grid_smooth_fwd(&g, y, y, scr, 5, 0.8f), ESR_OK);
    assert_memory_equal(y, dst, cnt * sizeof(float));
    /* noise: variance drops */
    test_fill_uniform(src, cnt, -1.0f, 1.0f, 3);
    assert_int_equal(esr_grid_smooth_fwd(&g, src, dst, scr, 5, 0.8f), ESR_OK);
    assert_true(test_dot(dst, dst, cnt) < 0.5 * test_dot(src, src, cnt));
    /* adjoint: <S x, y> = <x, S^T y> */
    test_fill_uniform(y, cnt, -1.0f, 1.0f, 4);
    double lhs = test_dot(dst, y, cnt);
    assert_int_equal(esr_grid_smooth_bwd(&g, y, adj, scr, 5, 0.8f), ESR_OK);
    assert_true(test_close(lhs, test_dot(src, adj, cnt), 1e-4, 1e-4));
    assert_int_equal(esr_grid_smooth_fwd(&g, src, dst, scr, 4, 0.8f), ESR_ERR);
    esr_error_clear();
    struct esr_grid tiny = make_grid(1, 2, 8, 8);
    assert_int_equal(esr_grid_smooth_fwd(&tiny, src, dst, scr, 5, 0.8f), ESR_ERR);
    esr_error_clear();
    free(src);
    free(dst);
    free(scr);
    free(y);
    free(adj);
}

/* Upsampling a linear field is exact; a channel mismatch is an error. */
static void test_resample_linear(void **state)
{
    (void)state;
    struct esr_grid a = make_grid(1, 5, 6, 7), b = make_grid(1, 17, 11, 9);
    float *src = malloc(esr_grid_count(&a) * sizeof(float)), *dst = malloc(esr_grid_count(&b) * sizeof(float));
    for (int z = 0; z < a.nz; z++)
        for (int y = 0; y < a.ny; y++)
            for (int x = 0; x < a.nx; x++) {
                float p[3];
                esr_grid_voxel_pos(&a, x, y, z, p);
                src[vidx(&a, x, y, z)] = 1.0f + 0.5f * p[0] - 2.0f * p[1] + 0.25f * p[2];
            }
    assert_int_equal(esr_grid_resample(&a, src, &b, dst), ESR_OK);
    for (int z = 0; z < b.nz; z++)
        for (int y = 0; y < b.ny; y++)
            for (int x = 0; x < b.nx; x++) {
                float p[3];
                esr_grid_voxel_pos(&b, x, y, z, p);
                assert_true(fabsf(dst[vidx(&b, x, y, z)] - (1.0f + 0.5f * p[0] - 2.0f * p[1] + 0.25f * p[2])) < 1e-5f);
            }
    struct esr_grid c = make_grid(2, 5, 5, 5);
    assert_int_equal(esr_grid_resample(&a, src, &c, dst), ESR_ERR);
    esr_error_clear();
    free(src);
    free(dst);
}

/* TV: value on a hand-checkable grid, and gradient against central differences on a multi-channel
 * grid (including the Huber region |d| > 1). */
static void test_tv(void **state)
{
    (void)state;
    struct esr_grid g = make_grid(1, 2, 2, 2);
    float d[8] = {0, 0, 0, 0, 0, 0, 0, 3.0f}; /* one corner at 3: three pairs with |d| = 3 */
    float grad[8] = {0};
    double loss;
    assert_int_equal(esr_grid_tv_add_grad(&g, d, 2.0f, grad, &loss), ESR_OK);
    assert_true(test_close(loss, 2.0 / 8.0 * 3.0 * 2.5, 1e-6, 1e-6));
    assert_true(test_close(grad[7], 2.0 / 8.0 * 3.0, 1e-6, 1e-6));
    assert_true(test_close(grad[6], -2.0 / 8.0, 1e-6, 1e-6));

    struct esr_grid h = make_grid(2, 5, 4, 6);
    size_t cnt = esr_grid_count(&h);
    float *v = malloc(cnt * sizeof(float)), *gr = calloc(cnt, sizeof(float));
    test_fill_uniform(v, cnt, -1.5f, 1.5f, 8);
    assert_int_equal(esr_grid_tv_add_grad(&h, v, 0.7f, gr, &loss), ESR_OK);
    for (size_t e = 0; e < cnt; e++) {
        float *scratch = calloc(cnt, sizeof(float));
        const float eps = 1e-3f;
        float keep = v[e];
        double lp, lm;
        v[e] = keep + eps;
        esr_grid_tv_add_grad(&h, v, 0.7f, scratch, &lp);
        v[e] = keep - eps;
        esr_grid_tv_add_grad(&h, v, 0.7f, scratch, &lm);
        v[e] = keep;
        free(scratch);
        assert_true(test_close(gr[e], (lp - lm) / (2.0 * eps), 1e-4, 2e-3));
    }
    free(v);
    free(gr);
}

/* Smoothed-gradient TV: zero for a linear SDF (constant gradient, kept by the smoothing), and
 * gradient against central differences of its own loss on a noisy field. */
static void test_grad_tv(void **state)
{
    (void)state;
    struct esr_grid g = make_grid(1, 6, 7, 5);
    size_t nv = esr_grid_voxels(&g);
    float *f = malloc(nv * sizeof(float)), *gr = calloc(nv, sizeof(float));
    float *work = malloc(esr_sdf_grad_tv_work(&g) * sizeof(float));
    for (int z = 0; z < g.nz; z++)
        for (int y = 0; y < g.ny; y++)
            for (int x = 0; x < g.nx; x++)
                f[vidx(&g, x, y, z)] = 0.3f * x - 0.2f * y + 0.1f * z;
    double loss;
    assert_int_equal(esr_sdf_grad_tv_add_grad(&g, f, 1.0f, 5, 0.8f, work, gr, &loss), ESR_OK);
    assert_true(loss < 1e-10);
    for (size_t v = 0; v < nv; v++)
        assert_true(fabsf(gr[v]) < 1e-5f);
    test_fill_uniform(f, nv, -0.5f, 0.5f, 61);
    for (int ks = 1; ks <= 5; ks += 4) {
        memset(gr, 0, nv * sizeof(float));
        assert_int_equal(esr_sdf_grad_tv_add_grad(&g, f, 3.0f, ks, 0.8f, work, gr, &loss), ESR_OK);
        assert_true(loss > 0.0);
        float *scratch = calloc(nv, sizeof(float));
        for (size_t e = 0; e < nv; e += 5) {
            const float h = 1e-3f;
            float keep = f[e];
            double lp, lm;
            f[e] = keep + h;
            esr_sdf_grad_tv_add_grad(&g, f, 3.0f, ks, 0.8f, work, scratch, &lp);
            f[e] = keep - h;
            esr_sdf_grad_tv_add_grad(&g, f, 3.0f, ks, 0.8f, work, scratch, &lm);
            f[e] = keep;
            assert_true(test_close(gr[e], (lp - lm) / (2.0 * h), 1e-4, 5e-3));
        }
        free(scratch);
    }
    free(f);
    free(gr);
    free(work);
}

/* alpha = 1 - exp(-softplus(d + shift) interval) against direct values and central differences;
 * the shift gives alpha_init at interval 1. */
static void test_density_alpha(void **state)
{
    (void)state;
    float shift = esr_density_shift(1e-4f);
    assert_true(test_close(esr_density_alpha_fwd(0.0f, shift, 1.0f), 1e-4, 1e-8, 1e-3));
    const float ds[6] = {-30.0f, -3.0f, -0.2f, 0.0f, 1.5f, 25.0f};
    for (int i = 0; i < 6; i++) {
        double z = (double)ds[i] + 0.3, sp = log1p(exp(z)), interval = 0.7;
        double ref = 1.0 - exp(-sp * interval);
        assert_true(test_close(esr_density_alpha_fwd(ds[i], 0.3f, 0.7f), ref, 1e-7, 1e-5));
        double h = 1e-3;
        double ap = 1.0 - exp(-log1p(exp(z + h)) * interval), am = 1.0 - exp(-log1p(exp(z - h)) * interval);
        assert_true(test_close(esr_density_alpha_bwd(ds[i], 0.3f, 0.7f, 1.0f), (ap - am) / (2 * h), 1e-6, 1e-3));
        /* and the float forward itself, differenced */
        float fp = esr_density_alpha_fwd(ds[i] + 1e-2f, 0.3f, 0.7f), fm = esr_density_alpha_fwd(ds[i] - 1e-2f, 0.3f, 0.7f);
        assert_true(test_close(esr_density_alpha_bwd(ds[i], 0.3f, 0.7f, 2.0f), 2.0 * (fp - fm) / 2e-2, 1e-4, 1e-2));
    }
    float dens[3] = {-1.0f, 0.0f, 2.0f}, al[3], dd[3] = {0.5f, 0.5f, 0.5f}, da[3] = {1.0f, 2.0f, 3.0f};
    esr_density_alpha_batch_fwd(dens, 3, shift, 0.5f, al);
    esr_density_alpha_batch_bwd(dens, 3, shift, 0.5f, da, dd);
    for (int i = 0; i < 3; i++) {
        assert_true(al[i] == esr_density_alpha_fwd(dens[i], shift, 0.5f));
        assert_true(dd[i] == 0.5f + esr_density_alpha_bwd(dens[i], shift, 0.5f, da[i]));
    }
}

/* Mask cache from a density grid and from an SDF grid, with dilation and point queries. */
static void test_mask_cache(void **state)
{
    (void)state;
    struct esr_grid g = make_grid(1, 11, 11, 11);
    size_t nv = esr_grid_voxels(&g);
    float *dens = malloc(nv * sizeof(float));
    for (size_t i = 0; i < nv; i++)
        dens[i] = -20.0f;
    dens[vidx(&g, 5, 5, 5)] = 10.0f;
    struct esr_mask m;
    assert_int_equal(esr_mask_alloc(&m, &g), ESR_OK);
    assert_int_equal(esr_mask_count(&m), nv);
    assert_int_equal(esr_mask_from_density(&m, &g, dens, 0.0f, 1.0f, 1e-3f, 0), ESR_OK);
    assert_int_equal(esr_mask_count(&m), 1);
    assert_int_equal(esr_mask_from_density(&m, &g, dens, 0.0f, 1.0f, 1e-3f, 1), ESR_OK);
    assert_int_equal(esr_mask_count(&m), 27);
    const float centre[3] = {0.1f, -0.1f, 0.12f}, near_edge[3] = {0.35f, 0.0f, 0.0f};
    const float far_pt[3] = {0.5f, 0.0f, 0.0f}, outside[3] = {2.0f, 0.0f, 0.0f};
    assert_int_equal(esr_mask_query(&m, centre), 1);
    assert_int_equal(esr_mask_query(&m, near_edge), 1); /* nearest lattice point x = 0.3 */
    assert_int_equal(esr_mask_query(&m, far_pt), 0);     /* nearest x = 0.6 */
    assert_int_equal(esr_mask_query(&m, outside), 0);
    /* SDF band: a sphere shell */
    assert_int_equal(esr_sdf_init_sphere(&g, dens, 0.5f), ESR_OK);
    assert_int_equal(esr_mask_from_sdf(&m, &g, dens, 0.11f, 0), ESR_OK);
    size_t shell = esr_mask_count(&m);
    assert_true(shell > 0 && shell < nv / 4);
    const float on_shell[3] = {0.8f, 0.0f, 0.0f}; /* nearest lattice x = 0.9: |x_n| = 0.6 */
    assert_int_equal(esr_mask_query(&m, on_shell), 1);
    assert_int_equal(esr_mask_query(&m, centre), 0);
    struct esr_grid other = make_grid(1, 5, 5, 5);
    assert_int_equal(esr_mask_from_sdf(&m, &other, dens, 0.1f, 0), ESR_ERR);
    esr_error_clear();
    esr_mask_free(&m);
    free(dens);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sphere_init),       cmocka_unit_test(test_smooth),
        cmocka_unit_test(test_resample_linear),   cmocka_unit_test(test_tv),
        cmocka_unit_test(test_grad_tv),           cmocka_unit_test(test_density_alpha),
        cmocka_unit_test(test_mask_cache),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
