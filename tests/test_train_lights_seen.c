/* Which surface the training views see (train/lights/seen.h): the area the views show, each
 * ray's hit standing for its pixel's footprint, must be the projected area of the surface in the
 * views whatever the images' size. A pinhole camera looks down on a plane, level and then steep
 * (rays meeting it at about 63 degrees from its normal), through 50 x 50 and 200 x 200 pixels; the
 * reference is the sum over the same pixels of t^2 times each pixel's exact solid angle
 * (cos^3 of its angle off the axis times its area on the image plane at distance 1), which
 * esr_seen_footprint does not use. Also: a parallel bundle's footprint is its spacing, and the
 * marks follow the area. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "fields/grid.h"
#include "train/lights/seen.h"
#include "train/rays.h"

#define RES 48
/* the default lights_seen_area, in cell faces */
#define SEEN_AREA 2.0f
#define MAX_W 200
/* the camera at (0, 0, EYE) looks down -z; the image spans [-HALF, HALF]^2 at distance 1 */
#define EYE 2.0f
#define HALF 0.2f

/* the plane z = Z0 + slope y, as an SDF on the grid */
#define Z0 0.3f

static float orig[MAX_W * MAX_W * 3], dir[MAX_W * MAX_W * 3];

static void plane_sdf(const struct esr_grid *g, float slope, float *sdf)
{
    const float norm = sqrtf(1.0f + slope * slope);
    for (int z = 0; z < g->nz; z++)
        for (int y = 0; y < g->ny; y++)
            for (int x = 0; x < g->nx; x++) {
                float p[3];
                esr_grid_voxel_pos(g, x, y, z, p);
                sdf[esr_grid_index(g, x, y, z)] = (p[2] - Z0 - slope * p[1]) / norm;
            }
}

/* The w x w pixel-centre rays, row after row; returns the reference area: the sum of t^2 times
 * the pixel's solid angle over the rays that meet the plane inside the box [-1, 1]^3. */
static double camera(int w, float slope, struct esr_ray_set *rs)
{
    const double pix = 2.0 * HALF / w;
    double ref = 0.0;
    size_t r = 0;
    for (int i = 0; i < w; i++)
        for (int j = 0; j < w; j++, r++) {
            const double u = -HALF + (j + 0.5) * pix, v = HALF - (i + 0.5) * pix;
            const double len = sqrt(u * u + v * v + 1.0);
            const double d[3] = {u / len, v / len, -1.0 / len};
            for (int a = 0; a < 3; a++)
                orig[r * 3 + a] = a == 2 ? EYE : 0.0f, dir[r * 3 + a] = (float)d[a];
            /* EYE + s d_z = Z0 + slope s d_y */
            const double s = (EYE - Z0) / (slope * d[1] - d[2]);
            const double hit[3] = {s * d[0], s * d[1], EYE + s * d[2]};
            if (s > 0.0 && fabs(hit[0]) < 1.0 && fabs(hit[1]) < 1.0 && fabs(hit[2]) < 1.0)
                ref += s * s * pix * pix / (len * len * len);
        }
    memset(rs, 0, sizeof *rs);
    rs->n = r, rs->n_off = r, rs->orig3 = orig, rs->dir3 = dir;
    return ref;
}

static double total(const float *a, size_t n)
{
    double s = 0.0;
    for (size_t i = 0; i < n; i++)
        s += a[i];
    return s;
}

static void test_seen_area_is_the_projected_area_at_any_image_size(void **state)
{
    (void)state;
    struct esr_grid g;
    const float bmin[3] = {-1, -1, -1}, bmax[3] = {1, 1, 1};
    assert_int_equal(esr_grid_init(&g, 1, RES, RES, RES, bmin, bmax), 0);
    const size_t N = esr_grid_voxels(&g);
    float *sdf = malloc(N * sizeof(float)), *area = malloc(N * sizeof(float));
    uint8_t *seen = malloc(N), *seen_hi = malloc(N);
    assert_non_null(sdf), assert_non_null(area), assert_non_null(seen), assert_non_null(seen_hi);
    const float slopes[2] = {0.0f, 2.0f};
    for (int p = 0; p < 2; p++) {
        plane_sdf(&g, slopes[p], sdf);
        double got[2];
        long marked[2];
        for (int k = 0; k < 2; k++) {
            const int w = k ? MAX_W : MAX_W / 4;
            struct esr_ray_set rs;
            const double ref = camera(w, slopes[p], &rs);
            memset(area, 0, N * sizeof(float));
            assert_int_equal(esr_seen_area(&g, sdf, &rs, NULL, area, NULL), 0);
            got[k] = total(area, N);
            const float h = esr_grid_voxel_size(&g, 0);
            esr_seen_marks(&g, area, SEEN_AREA * h * h, k ? seen_hi : seen);
            marked[k] = 0;
            for (size_t i = 0; i < N; i++)
                marked[k] += (k ? seen_hi : seen)[i];
            print_message("plane of slope %.0f, %d x %d pixels: seen area %.4f, reference %.4f; %ld "
                          "lattice points seen\n", (double)slopes[p], w, w, got[k], ref, marked[k]);
            assert_true(fabs(got[k] - ref) < 0.01 * ref);
        }
        /* the same area at either size, and the marks with it */
        assert_true(fabs(got[1] - got[0]) < 0.005 * got[0]);
        assert_true(labs(marked[1] - marked[0]) < marked[0] / 50);
    }
    free(sdf), free(area), free(seen), free(seen_hi);
}

/* Parallel rays 0.05 apart: each footprint is the spacing, at any distance along them; one ray
 * alone has none. */
static void test_footprint_of_parallel_rays_is_their_spacing(void **state)
{
    (void)state;
    float o[9] = {0, 0, 0, 0.05f, 0, 0, 0.10f, 0, 0}, d[9] = {0, 0, 1, 0, 0, 1, 0, 0, 1};
    struct esr_ray_set rs;
    memset(&rs, 0, sizeof rs);
    rs.n = 3, rs.orig3 = o, rs.dir3 = d;
    for (size_t r = 0; r < 3; r++)
        for (float t = 0.0f; t < 4.0f; t += 1.5f)
            assert_float_equal(esr_seen_footprint(&rs, r, t), 0.05f, 1e-6f);
    rs.n = 1;
    assert_float_equal(esr_seen_footprint(&rs, 0, 1.0f), 0.0f, 0.0f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_seen_area_is_the_projected_area_at_any_image_size),
        cmocka_unit_test(test_footprint_of_parallel_rays_is_their_spacing),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
