/* Rendered normals (esr_model_render_rays, options normal_ksize/normal_sigma): a tilted plane
 * whose SDF carries voxel-scale noise, the failure the default scene's floors showed. The raw
 * trilinear gradient follows the noise; the normal from the smoothed SDF must be close to the
 * plane's true normal, and normal_ksize = 0 must give back the raw gradient. And the SDF as
 * first hits see it (model/render_sdf.h) against the render. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "model/model.h"
#include "model/render_sdf.h"
#include "render/model_mesh.h"
#include "train/lights/direct.h"
#include "volume/first_hit.h"
#include "test_grad.h"
#include "test_model.h"

#define SIDE 12
#define NRAYS (SIDE * SIDE)
#define RES 32

static const float PLANE_N[3] = {0.26f, -0.17f, 0.9503f}; /* normalised below */

/* Fine-stage model on [-1,1]^3 whose SDF is the signed distance to the plane through the origin
 * with normal PLANE_N, plus uniform noise of +-noise_vox voxels; normals smoothed by a kernel of
 * normal_ksize (sigma: the default). */
static void make_plane(struct esr_model *m, int normal_ksize, float noise_vox)
{
    struct esr_train_config cfg;
    test_small_config(&cfg, 0.5f);
    cfg.fine.res = RES;
    cfg.normal_ksize = normal_ksize;
    const float bmin[3] = {-1, -1, -1}, bmax[3] = {1, 1, 1};
    assert_int_equal(esr_model_init(m, &cfg, ESR_STAGE_FINE, NULL, bmin, bmax), 0);
    m->inv_s = 400.0f; /* a sharp surface, as after training */
    const struct esr_grid *g = esr_model_grid(m, ESR_COMP_SDF);
    float *v = esr_model_values(m, ESR_COMP_SDF);
    float len = sqrtf(PLANE_N[0] * PLANE_N[0] + PLANE_N[1] * PLANE_N[1] + PLANE_N[2] * PLANE_N[2]);
    float noise[RES * RES * RES];
    test_fill_uniform(noise, RES * RES * RES, -1.0f, 1.0f, 7);
    float vox = esr_grid_voxel_size(g, 0);
    for (int z = 0; z < g->nz; z++)
        for (int y = 0; y < g->ny; y++)
            for (int x = 0; x < g->nx; x++) {
                float p[3];
                esr_grid_voxel_pos(g, x, y, z, p);
                size_t i = ((size_t)z * g->ny + y) * g->nx + x;
                v[i] = (p[0] * PLANE_N[0] + p[1] * PLANE_N[1] + p[2] * PLANE_N[2]) / len +
                       noise_vox * vox * noise[i];
            }
}

/* Mean angle in degrees between the rendered normals of straight-down rays over the plane's
 * middle and the true normal. */
static double mean_normal_error(const struct esr_model *m)
{
    float o[NRAYS * 3], d[NRAYS * 3], nrm[NRAYS * 3], opac[NRAYS];
    for (int i = 0; i < NRAYS; i++) {
        o[i * 3 + 0] = -0.5f + (float)(i % SIDE) / (SIDE - 1);
        o[i * 3 + 1] = -0.5f + (float)(i / SIDE) / (SIDE - 1);
        o[i * 3 + 2] = 0.95f;
        d[i * 3 + 0] = 0.0f;
        d[i * 3 + 1] = 0.0f;
        d[i * 3 + 2] = -1.0f;
    }
    struct esr_render_out out = {.normal = nrm, .opacity = opac};
    assert_int_equal(esr_model_render_rays(m, o, d, NRAYS, 0, &out), 0);
    float len = sqrtf(PLANE_N[0] * PLANE_N[0] + PLANE_N[1] * PLANE_N[1] + PLANE_N[2] * PLANE_N[2]);
    double sum = 0;
    for (int i = 0; i < NRAYS; i++) {
        assert_true(opac[i] > 0.9f);
        const float *n = nrm + i * 3;
        float nl = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        float c = (n[0] * PLANE_N[0] + n[1] * PLANE_N[1] + n[2] * PLANE_N[2]) / (nl * len);
        sum += acos(fmin(1.0, fmax(-1.0, (double)c))) * 180.0 / M_PI;
    }
    return sum / NRAYS;
}

static void test_clean_plane_normals_exact_either_way(void **state)
{
    (void)state;
    for (int k = 0; k <= 7; k += 7) {
        struct esr_model m;
        make_plane(&m, k, 0.0f);
        /* a linear SDF has a constant gradient and Gaussian smoothing keeps it (point-reflected
         * borders extend it linearly) */
        assert_true(mean_normal_error(&m) < 0.05);
        esr_model_free(&m);
    }
}

static void test_smoothed_normals_reject_voxel_noise(void **state)
{
    (void)state;
    struct esr_model raw, smooth;
    make_plane(&raw, 0, 0.3f);
    struct esr_train_config defaults;
    esr_config_defaults(&defaults, ESR_PRESET_FAST);
    make_plane(&smooth, defaults.normal_ksize, 0.3f); /* the default options */
    assert_true(smooth.cfg.normal_ksize > 1);
    double e_raw = mean_normal_error(&raw), e_smooth = mean_normal_error(&smooth);
    print_message("plane with +-0.3 voxel SDF noise: raw gradient %.2f deg, smoothed %.2f deg\n",
                  e_raw, e_smooth);
    assert_true(e_raw > 10.0);       /* the noise is visible in the raw normals ... */
    assert_true(e_smooth < 3.0);     /* ... and gone from the smoothed ones */
    esr_model_free(&raw);
    esr_model_free(&smooth);
}

static void test_normal_sdf_off_when_ksize_below_two(void **state)
{
    (void)state;
    struct esr_model m;
    make_plane(&m, 1, 0.3f);
    float *nsdf = (float *)1;
    assert_int_equal(esr_model_normal_sdf(&m, &nsdf), 0);
    assert_null(nsdf);
    esr_model_free(&m);
}

/* A fine-stage model on [-1,1]^3 whose SDF is the union of a sphere at (sx, 0, 0) of radius sr
 * and a blob at (bx, 0, 0) of radius br; its mask cache is left to the caller. */
static void sphere_and_blob(struct esr_model *m, float sx, float sr, float bx, float br)
{
    struct esr_train_config cfg;
    test_small_config(&cfg, 0.5f);
    cfg.fine.res = RES;
    const float bmin[3] = {-1, -1, -1}, bmax[3] = {1, 1, 1};
    assert_int_equal(esr_model_init(m, &cfg, ESR_STAGE_FINE, NULL, bmin, bmax), 0);
    m->inv_s = 400.0f;
    const struct esr_grid *g = esr_model_grid(m, ESR_COMP_SDF);
    float *v = esr_model_values(m, ESR_COMP_SDF);
    for (int z = 0; z < g->nz; z++)
        for (int y = 0; y < g->ny; y++)
            for (int x = 0; x < g->nx; x++) {
                float p[3];
                esr_grid_voxel_pos(g, x, y, z, p);
                const float sphere = sqrtf((p[0] - sx) * (p[0] - sx) + p[1] * p[1] + p[2] * p[2]) - sr;
                const float blob = sqrtf((p[0] - bx) * (p[0] - bx) + p[1] * p[1] + p[2] * p[2]) - br;
                v[esr_grid_index(g, x, y, z)] = fminf(sphere, blob);
            }
}

/* A first-hit march sees what the renderer sees: a solid sphere at +x inside the mask cache
 * and, at -x, a blob of negative SDF in space the mask marks empty (a trained SDF drifts there,
 * where no sample ever reaches). A ray along +x renders the sphere; the raw SDF's first hit is
 * the blob, the first-hit SDF's is the sphere, where the render puts the surface; a shadow ray
 * across the blob passes. */
static void test_first_hits_see_no_surface_where_renders_skip(void **state)
{
    (void)state;
    struct esr_model m;
    sphere_and_blob(&m, 0.5f, 0.25f, -0.5f, 0.15f);
    const struct esr_grid *g = esr_model_grid(&m, ESR_COMP_SDF);
    const float *v = esr_model_values(&m, ESR_COMP_SDF);
    struct esr_mask *k = &m.mask; /* occupied for x >= -0.1 only */
    esr_mask_free(k);
    assert_int_equal(esr_mask_alloc(k, g), 0);
    m.has_mask = 1;
    for (int z = 0; z < k->nz; z++)
        for (int y = 0; y < k->ny; y++)
            for (int x = 0; x < k->nx; x++)
                k->occ[((size_t)z * k->ny + y) * k->nx + x] = k->bmin[0] + (float)x / k->scale[0] >= -0.1f;
    const float o[3] = {-0.95f, 0.01f, 0.02f}, d[3] = {1.0f, 0.0f, 0.0f};
    float depth, opac;
    struct esr_render_out out = {.depth = &depth, .opacity = &opac};
    assert_int_equal(esr_model_render_rays(&m, o, d, 1, 0, &out), 0);
    assert_true(opac > 0.9f);
    float *seen = NULL;
    assert_int_equal(esr_model_first_hit_sdf(&m, &seen), 0);
    struct esr_first_hit_params fp;
    esr_first_hit_params_init(&fp, g);
    const struct esr_first_hit_rays fr = {o, d, NULL, NULL, 1};
    float t_raw, t_seen;
    const struct esr_first_hit_out raw_out = {&t_raw, NULL, NULL, NULL}, seen_out = {&t_seen, NULL, NULL, NULL};
    assert_int_equal(esr_first_hit(g, v, &fp, &fr, &raw_out), 0);
    assert_int_equal(esr_first_hit(g, seen, &fp, &fr, &seen_out), 0);
    print_message("ray along +x: render depth %.3f, first hit %.3f on the raw SDF, %.3f as first "
                  "hits see it\n", (double)(depth / opac), (double)t_raw, (double)t_seen);
    assert_true(fabsf(t_raw - 0.30f) < 0.05f);           /* the blob's near side */
    assert_true(fabsf(t_seen - 1.20f) < 0.05f);          /* the sphere's */
    assert_true(fabsf(t_seen - depth / opac) < 0.05f);   /* where the render has it */
    struct esr_light_shadows sh;
    assert_int_equal(esr_light_shadows_init(&sh, &m), 0);
    const float a[3] = {-0.95f, 0.0f, 0.0f}, b[3] = {-0.1f, 0.0f, 0.0f}, c[3] = {0.9f, 0.0f, 0.0f};
    assert_false(esr_first_hit_segment_blocked(&sh.grid, &sh.params, a, b)); /* across the blob */
    assert_true(esr_first_hit_segment_blocked(&sh.grid, &sh.params, a, c));  /* into the sphere */
    esr_light_shadows_free(&sh);
    free(seen);
    esr_model_free(&m);
}

/* The mesh shows what renders show, with the renderer's usual mask: a band of 3 voxels round a
 * solid sphere skips both the air beyond it and the sphere's inside. A blob of negative SDF in
 * the air is no part of the mesh, and the inside, which the band's end encloses, grows no
 * second shell. */
static void test_mesh_is_the_rendered_surface(void **state)
{
    (void)state;
    struct esr_model m;
    sphere_and_blob(&m, 0.3f, 0.5f, -0.7f, 0.1f);
    const struct esr_grid *g = esr_model_grid(&m, ESR_COMP_SDF);
    const float h = esr_grid_voxel_size(g, 0);
    /* the band round the sphere only: the blob lies outside it */
    float *band = malloc(esr_grid_voxels(g) * sizeof(float));
    for (int z = 0; z < g->nz; z++)
        for (int y = 0; y < g->ny; y++)
            for (int x = 0; x < g->nx; x++) {
                float p[3];
                esr_grid_voxel_pos(g, x, y, z, p);
                band[esr_grid_index(g, x, y, z)] =
                    sqrtf((p[0] - 0.3f) * (p[0] - 0.3f) + p[1] * p[1] + p[2] * p[2]) - 0.5f;
            }
    esr_mask_free(&m.mask);
    assert_int_equal(esr_mask_alloc(&m.mask, g), 0);
    assert_int_equal(esr_mask_from_sdf(&m.mask, g, band, 3.0f * h, 0), 0);
    m.has_mask = 1;
    free(band);
    struct esr_mesh mesh;
    assert_int_equal(esr_model_mesh(&m, 0, 0, &mesh), 0);
    float rmin = INFINITY, xmin = INFINITY;
    for (size_t i = 0; i < mesh.n_vertices; i++) {
        const float *q = mesh.pos + 3 * i;
        rmin = fminf(rmin, sqrtf((q[0] - 0.3f) * (q[0] - 0.3f) + q[1] * q[1] + q[2] * q[2]));
        xmin = fminf(xmin, q[0]);
    }
    print_message("mesh of a sphere (radius 0.5) in a 3-voxel band mask, a blob in the air: %zu "
                  "vertices, nearest the centre %.3f, lowest x %.3f\n", mesh.n_vertices,
                  (double)rmin, (double)xmin);
    assert_true(mesh.n_vertices > 100);
    assert_true(rmin > 0.5f - h);   /* no shell inside */
    assert_true(xmin > -0.2f - h);  /* no blob (the sphere reaches down to x = -0.2) */
    esr_mesh_free(&mesh);
    esr_model_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_clean_plane_normals_exact_either_way),
        cmocka_unit_test(test_smoothed_normals_reject_voxel_noise),
        cmocka_unit_test(test_normal_sdf_off_when_ksize_below_two),
        cmocka_unit_test(test_first_hits_see_no_surface_where_renders_skip),
        cmocka_unit_test(test_mesh_is_the_rendered_surface),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
