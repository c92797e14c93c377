/* Geometry metrics: exact nearest neighbours, area-uniform surface sampling, Chamfer on meshes
 * with known offsets, and the PLY reader those meshes come through. */
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
#include "core/rng.h"
#include "eval/chamfer.h"
#include "eval/kdtree.h"
#include "io/ply.h"
#include "test_support.h"

/* Unit square [0,1]^2 at height z, two triangles (or four vertices + n_tri = 2). */
static void make_square(struct esr_mesh *m, float z, float size)
{
    memset(m, 0, sizeof *m);
    m->n_vertices = 4;
    m->n_triangles = 2;
    m->pos = (float *)calloc(12, sizeof(float));
    m->normal = (float *)calloc(12, sizeof(float));
    m->tri = (uint32_t *)malloc(6 * sizeof(uint32_t));
    const float xy[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    for (int i = 0; i < 4; i++) {
        m->pos[i * 3] = xy[i][0] * size;
        m->pos[i * 3 + 1] = xy[i][1] * size;
        m->pos[i * 3 + 2] = z;
        m->normal[i * 3 + 2] = 1.0f;
    }
    const uint32_t tri[6] = {0, 1, 2, 0, 2, 3};
    memcpy(m->tri, tri, sizeof tri);
}

static void test_nearest_matches_brute_force(void **state)
{
    (void)state;
    enum { NA = 700, NB = 900 };
    float *a = malloc(NA * 3 * sizeof(float)), *b = malloc(NB * 3 * sizeof(float));
    struct esr_rng rng = esr_rng_init(7, 0);
    for (int i = 0; i < NA * 3; i++)
        a[i] = esr_rng_float(&rng) * 3.0f - 1.0f; /* partly outside b's box */
    for (int i = 0; i < NB * 3; i++)
        b[i] = esr_rng_float(&rng) * (i % 3 == 2 ? 0.05f : 1.0f); /* a thin slab, like a surface */
    double brute = 0.0;
    for (int i = 0; i < NA; i++) {
        double best = INFINITY;
        for (int j = 0; j < NB; j++) {
            double d = 0.0;
            for (int k = 0; k < 3; k++)
                d += ((double)a[i * 3 + k] - b[j * 3 + k]) * ((double)a[i * 3 + k] - b[j * 3 + k]);
            best = fmin(best, d);
        }
        brute += sqrt(best);
    }
    brute /= NA;
    double fast;
    assert_int_equal(esr_mean_nearest_distance(a, NA, b, NB, &fast), ESR_OK);
    assert_true(fabs(fast - brute) < 1e-6 * brute);
    free(a);
    free(b);
}

static void test_surface_samples_are_area_uniform(void **state)
{
    (void)state;
    struct esr_mesh m;
    make_square(&m, 0.0f, 2.0f);
    enum { N = 40000 };
    float *p = malloc(N * 3 * sizeof(float));
    assert_int_equal(esr_mesh_sample_surface(&m, N, 3, p), ESR_OK);
    int quadrant[4] = {0};
    for (int i = 0; i < N; i++) {
        assert_true(p[i * 3] >= 0.0f && p[i * 3] <= 2.0f && p[i * 3 + 1] >= 0.0f && p[i * 3 + 1] <= 2.0f);
        quadrant[(p[i * 3] > 1.0f) + 2 * (p[i * 3 + 1] > 1.0f)]++;
    }
    for (int q = 0; q < 4; q++) /* each quadrant holds a quarter of the area: 10000 +- 4 sigma */
        assert_true(abs(quadrant[q] - N / 4) < 350);
    free(p);
    esr_mesh_free(&m);
}

static void test_chamfer_of_offset_squares(void **state)
{
    (void)state;
    struct esr_mesh a, b;
    make_square(&a, 0.0f, 1.0f);
    make_square(&b, 0.1f, 1.0f);
    struct esr_chamfer_result r;
    assert_int_equal(esr_chamfer_meshes(&a, &b, 20000, 11, &r), ESR_OK);
    /* every point is 0.1 above/below the other square; sampling gaps add ~1e-3 */
    assert_true(r.accuracy > 0.1 && r.accuracy < 0.102);
    assert_true(r.completeness > 0.1 && r.completeness < 0.102);
    assert_true(fabs(r.chamfer - 0.5 * (r.accuracy + r.completeness)) < 1e-12);
    assert_int_equal(esr_chamfer_meshes(&a, &a, 20000, 11, &r), ESR_OK);
    assert_true(r.chamfer < 0.006); /* same surface: only the sampling gap */
    esr_mesh_free(&a);
    esr_mesh_free(&b);
}

static void test_ply_round_trip_and_ascii(void **state)
{
    (void)state;
    char *dir = test_make_tmpdir();
    char path[512];
    struct esr_mesh a, back;
    make_square(&a, 0.25f, 1.0f);
    snprintf(path, sizeof path, "%s/square.ply", dir);
    assert_int_equal(esr_ply_write(path, &a), ESR_OK);
    assert_int_equal(esr_ply_read(path, &back), ESR_OK);
    assert_int_equal(back.n_vertices, 4);
    assert_int_equal(back.n_triangles, 2);
    assert_memory_equal(back.pos, a.pos, 12 * sizeof(float));
    assert_memory_equal(back.tri, a.tri, 6 * sizeof(uint32_t));
    esr_mesh_free(&back);

    snprintf(path, sizeof path, "%s/quad.ply", dir);
    assert_int_equal(test_write_file(path, "ply\nformat ascii 1.0\ncomment a quad\nelement vertex 4\n"
                                           "property double x\nproperty double y\nproperty double z\n"
                                           "element face 1\nproperty list uchar int vertex_indices\n"
                                           "end_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n"), 0);
    assert_int_equal(esr_ply_read(path, &back), ESR_OK);
    assert_int_equal(back.n_triangles, 2);
    assert_int_equal(back.tri[5], 3);
    esr_mesh_free(&back);

    const char *bad[] = {
        "not a ply\n",
        "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n",
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n3 0 1 5\n",
        "ply\nformat binary_big_endian 1.0\nelement vertex 0\nend_header\n",
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n0 0\n",
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        assert_int_equal(test_write_file(path, bad[i]), 0);
        esr_error_clear();
        if (esr_ply_read(path, &back) != ESR_ERR || !strstr(esr_error_message(), "quad.ply"))
            fail_msg("bad PLY case %zu: '%s'", i, esr_error_message());
    }
    esr_error_clear();
    esr_mesh_free(&a);
    test_rmtree(dir);
    free(dir);
}

/* The k-d tree on a lattice (many equal coordinates: the median split must cope with ties) and
 * with queries far outside the indexed set, against a brute-force scan per query. */
static void test_kdtree_exact_on_ties_and_far_queries(void **state)
{
    (void)state;
    enum { SIDE = 9, NB = SIDE * SIDE * 3, NQ = 400 };
    float b[NB * 3];
    int n = 0;
    for (int z = 0; z < 3; z++) /* three identical layers in z: every xy point repeated */
        for (int y = 0; y < SIDE; y++)
            for (int x = 0; x < SIDE; x++) {
                b[n * 3] = (float)(x / 3); /* groups of three equal x values */
                b[n * 3 + 1] = (float)y * 0.5f;
                b[n * 3 + 2] = z == 2 ? 0.0f : 0.25f;
                n++;
            }
    struct esr_kdtree tree;
    assert_int_equal(esr_kdtree_build(&tree, b, NB), ESR_OK);
    struct esr_rng rng = esr_rng_init(11, 0);
    for (int i = 0; i < NQ; i++) {
        float q[3];
        for (int k = 0; k < 3; k++) /* up to 20 units from a set that spans ~4 */
            q[k] = (esr_rng_float(&rng) - 0.5f) * (i % 2 ? 40.0f : 6.0f);
        float best = INFINITY;
        for (int j = 0; j < NB; j++) {
            float dx = b[j * 3] - q[0], dy = b[j * 3 + 1] - q[1], dz = b[j * 3 + 2] - q[2];
            best = fminf(best, dx * dx + dy * dy + dz * dz);
        }
        assert_float_equal(esr_kdtree_nearest_sq(&tree, q), best, 1e-5f * (1.0f + best));
    }
    esr_kdtree_free(&tree);
    assert_int_equal(esr_kdtree_build(&tree, b, 0), ESR_ERR); /* empty set: clear error */
    esr_error_clear();
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_nearest_matches_brute_force),
        cmocka_unit_test(test_kdtree_exact_on_ties_and_far_queries),
        cmocka_unit_test(test_surface_samples_are_area_uniform),
        cmocka_unit_test(test_chamfer_of_offset_squares),
        cmocka_unit_test(test_ply_round_trip_and_ascii),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
