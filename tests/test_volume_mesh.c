/* Marching cubes on a sphere SDF and the PLY writer. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "fields/sdf.h"
#include "io/ply.h"
#include "volume/marching_cubes.h"
#include "test_grad.h"
#include "test_support.h"

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

/* Every undirected edge is used by exactly two triangles, once in each direction (closed and
 * consistently oriented). */
static void assert_closed_oriented(const struct esr_mesh *m)
{
    size_t ne = m->n_triangles * 3;
    uint64_t *dir = malloc(ne * sizeof(uint64_t));
    for (size_t t = 0; t < m->n_triangles; t++)
        for (int k = 0; k < 3; k++) {
            uint64_t a = m->tri[t * 3 + k], b = m->tri[t * 3 + (k + 1) % 3];
            assert_true(a != b);
            dir[t * 3 + k] = a << 32 | b;
        }
    qsort(dir, ne, sizeof(uint64_t), cmp_u64);
    for (size_t i = 0; i < ne; i++) {
        assert_true(i == 0 || dir[i] != dir[i - 1]); /* no directed edge twice */
        uint64_t rev = (dir[i] & 0xffffffffu) << 32 | dir[i] >> 32;
        assert_non_null(bsearch(&rev, dir, ne, sizeof(uint64_t), cmp_u64));
    }
    free(dir);
}

static void test_sphere_mesh(void **state)
{
    (void)state;
    struct esr_grid g;
    const float bmin[3] = {-1.5f, -1.5f, -1.5f}, bmax[3] = {1.5f, 1.5f, 1.5f};
    assert_int_equal(esr_grid_init(&g, 1, 24, 25, 26, bmin, bmax), ESR_OK);
    float *sdf = malloc(esr_grid_count(&g) * sizeof(float));
    assert_int_equal(esr_sdf_init_sphere(&g, sdf, 0.7f), ESR_OK); /* world radius 1.05 */
    struct esr_mesh m;
    assert_int_equal(esr_marching_cubes(&g, sdf, 0.0f, &m), ESR_OK);
    assert_true(m.n_triangles > 500);
    assert_closed_oriented(&m);
    /* vertices near the sphere, normals radial; triangles face outwards */
    float vs = esr_grid_voxel_size(&g, 0);
    for (size_t i = 0; i < m.n_vertices; i++) {
        const float *p = m.pos + i * 3, *n = m.normal + i * 3;
        float r = sqrtf(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
        assert_true(fabsf(r - 1.05f) < 0.1f * vs);
        assert_true((p[0] * n[0] + p[1] * n[1] + p[2] * n[2]) / r > 0.98f);
    }
    double area = 0.0;
    for (size_t t = 0; t < m.n_triangles; t++) {
        const float *a = m.pos + m.tri[t * 3] * 3, *b = m.pos + m.tri[t * 3 + 1] * 3, *c = m.pos + m.tri[t * 3 + 2] * 3;
        float u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        float cr[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
        assert_true(cr[0] * a[0] + cr[1] * a[1] + cr[2] * a[2] > 0.0f);
        area += 0.5 * sqrt((double)cr[0] * cr[0] + (double)cr[1] * cr[1] + (double)cr[2] * cr[2]);
    }
    assert_true(fabs(area - 4.0 * M_PI * 1.05 * 1.05) < 0.02 * 4.0 * M_PI * 1.05 * 1.05);
    esr_mesh_free(&m);
    free(sdf);
}

/* A sheet thinner than a voxel (a hollow sphere's wall, 0.04 thick on 0.05 voxels): the field's
 * trilinear gradient at a vertex of one face sees the other face too, and pointed against the
 * vertex's own triangles at hundreds of vertices (dark patches in a smooth-shaded viewer). Every
 * vertex normal is a unit vector on its triangles' side. */
static void test_thin_sheet_normals(void **state)
{
    (void)state;
    struct esr_grid g;
    const float bmin[3] = {-1.6f, -1.6f, -1.6f}, bmax[3] = {1.6f, 1.6f, 1.6f};
    assert_int_equal(esr_grid_init(&g, 1, 64, 64, 64, bmin, bmax), ESR_OK);
    float *f = malloc(esr_grid_count(&g) * sizeof(float));
    for (int z = 0; z < 64; z++)
        for (int y = 0; y < 64; y++)
            for (int x = 0; x < 64; x++) {
                float p[3];
                esr_grid_voxel_pos(&g, x, y, z, p);
                const float r = sqrtf(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
                f[((size_t)z * 64 + y) * 64 + x] = fabsf(r - 1.0f) - 0.02f;
            }
    struct esr_mesh m;
    assert_int_equal(esr_marching_cubes(&g, f, 0.0f, &m), ESR_OK);
    assert_true(m.n_triangles > 1000);
    double *acc = calloc(m.n_vertices * 3, sizeof(double));
    for (size_t t = 0; t < m.n_triangles; t++) {
        const float *a = m.pos + m.tri[t * 3] * 3, *b = m.pos + m.tri[t * 3 + 1] * 3, *c = m.pos + m.tri[t * 3 + 2] * 3;
        const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        const double cr[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
        for (int k = 0; k < 3; k++)
            for (int a3 = 0; a3 < 3; a3++)
                acc[(size_t)m.tri[t * 3 + k] * 3 + a3] += cr[a3];
    }
    size_t against = 0;
    for (size_t i = 0; i < m.n_vertices; i++) {
        const float *n = m.normal + i * 3;
        assert_float_equal(n[0] * n[0] + n[1] * n[1] + n[2] * n[2], 1.0f, 1e-4f);
        against += n[0] * acc[i * 3] + n[1] * acc[i * 3 + 1] + n[2] * acc[i * 3 + 2] <= 0.0;
    }
    print_message("thin sheet: %zu vertices, %zu with normals against their triangles\n", m.n_vertices, against);
    assert_int_equal(against, 0);
    free(acc);
    esr_mesh_free(&m);
    free(f);
}

/* Random fields exercise every case, ambiguous faces included: still closed and oriented
 * (surfaces touching the grid boundary are avoided by a positive rim). */
static void test_random_field_closed(void **state)
{
    (void)state;
    struct esr_grid g;
    const float bmin[3] = {0, 0, 0}, bmax[3] = {1, 1, 1};
    assert_int_equal(esr_grid_init(&g, 1, 12, 12, 12, bmin, bmax), ESR_OK);
    float *f = malloc(esr_grid_count(&g) * sizeof(float));
    test_fill_uniform(f, esr_grid_count(&g), -1.0f, 1.0f, 51);
    for (int z = 0; z < 12; z++)
        for (int y = 0; y < 12; y++)
            for (int x = 0; x < 12; x++)
                if (x == 0 || y == 0 || z == 0 || x == 11 || y == 11 || z == 11)
                    f[(z * 12 + y) * 12 + x] = 1.0f;
    struct esr_mesh m;
    assert_int_equal(esr_marching_cubes(&g, f, 0.0f, &m), ESR_OK);
    assert_true(m.n_triangles > 1000);
    assert_closed_oriented(&m);
    esr_mesh_free(&m);
    /* empty surface, and a multi-channel grid is an error */
    for (size_t e = 0; e < esr_grid_count(&g); e++)
        f[e] = 1.0f;
    assert_int_equal(esr_marching_cubes(&g, f, 0.0f, &m), ESR_OK);
    assert_int_equal(m.n_triangles, 0);
    esr_mesh_free(&m);
    g.channels = 2;
    assert_int_equal(esr_marching_cubes(&g, f, 0.0f, &m), ESR_ERR);
    esr_error_clear();
    esr_mesh_free(&m);
    free(f);
}

static void test_ply_write(void **state)
{
    (void)state;
    float pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0}, nrm[9] = {0, 0, 1, 0, 0, 1, 0, 0, 1};
    uint32_t tri[3] = {0, 1, 2};
    struct esr_mesh m = {3, 1, pos, nrm, NULL, tri};
    char *dir = test_make_tmpdir();
    char path[1024];
    snprintf(path, sizeof(path), "%s/m.ply", dir);
    assert_int_equal(esr_ply_write(path, &m), ESR_OK);
    FILE *fp = fopen(path, "rb");
    assert_non_null(fp);
    char buf[1024];
    size_t got = fread(buf, 1, sizeof(buf) - 1, fp);
    fclose(fp);
    buf[got] = '\0';
    assert_non_null(strstr(buf, "format binary_little_endian 1.0"));
    assert_non_null(strstr(buf, "element vertex 3"));
    assert_non_null(strstr(buf, "element face 1"));
    assert_null(strstr(buf, "red"));
    const char *end = strstr(buf, "end_header\n") + strlen("end_header\n");
    size_t hdr = (size_t)(end - buf);
    assert_int_equal(got, hdr + 3 * 24 + 13);
    float x1;
    memcpy(&x1, buf + hdr + 24, 4);
    assert_true(x1 == 1.0f);
    assert_int_equal((unsigned char)buf[hdr + 72], 3);
    /* with colours */
    assert_int_equal(esr_mesh_alloc_colours(&m), ESR_OK);
    m.colour[0] = 1.0f;
    assert_int_equal(esr_ply_write(path, &m), ESR_OK);
    fp = fopen(path, "rb");
    got = fread(buf, 1, sizeof(buf) - 1, fp);
    fclose(fp);
    buf[got] = '\0';
    assert_non_null(strstr(buf, "property uchar red"));
    end = strstr(buf, "end_header\n") + strlen("end_header\n");
    hdr = (size_t)(end - buf);
    assert_int_equal(got, hdr + 3 * 27 + 13);
    assert_int_equal((unsigned char)buf[hdr + 24], 255);
    /* unwritable path: one clear error */
    assert_int_equal(esr_ply_write("/nonexistent-dir/x.ply", &m), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "/nonexistent-dir/x.ply"));
    esr_error_clear();
    free(m.colour);
    test_rmtree(dir);
    free(dir); /* test_make_tmpdir returns a heap copy */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sphere_mesh),
        cmocka_unit_test(test_thin_sheet_normals),
        cmocka_unit_test(test_random_field_closed),
        cmocka_unit_test(test_ply_write),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
