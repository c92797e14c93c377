/* Ray/box clipping and the ray-marching sampler. */
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
#include "core/rng.h"
#include "fields/mask.h"
#include "io/camera.h"
#include "io/dataset.h"
#include "volume/ray.h"
#include "volume/sampler.h"
#include "test_support.h"

static const float BMIN[3] = {-1.5f, -1.5f, -1.5f};
static const float BMAX[3] = {1.5f, 1.5f, 1.5f};

static void test_box_clip_cases(void **state)
{
    (void)state;
    float t0 = 0.0f, t1 = 0.0f;
    /* camera at distance 4 looking at the origin: enters at 2.5, leaves at 5.5 */
    const float o[3] = {0.0f, 0.0f, 4.0f}, d[3] = {0.0f, 0.0f, -1.0f};
    assert_int_equal(esr_ray_box_clip(o, d, BMIN, BMAX, 2.0f, 6.0f, &t0, &t1), 1);
    assert_true(fabsf(t0 - 2.5f) < 1e-6f && fabsf(t1 - 5.5f) < 1e-6f);
    /* near/far cut the interval */
    assert_int_equal(esr_ray_box_clip(o, d, BMIN, BMAX, 3.0f, 5.0f, &t0, &t1), 1);
    assert_true(t0 == 3.0f && t1 == 5.0f);
    /* misses: parallel to a slab outside it, pointing away, beyond far */
    const float o2[3] = {2.0f, 0.0f, 4.0f};
    assert_int_equal(esr_ray_box_clip(o2, d, BMIN, BMAX, 0.0f, 100.0f, &t0, &t1), 0);
    const float away[3] = {0.0f, 0.0f, 1.0f};
    assert_int_equal(esr_ray_box_clip(o, away, BMIN, BMAX, 0.0f, 100.0f, &t0, &t1), 0);
    assert_int_equal(esr_ray_box_clip(o, d, BMIN, BMAX, 0.0f, 2.0f, &t0, &t1), 0);
    /* diagonal ray from inside the box (secondary ray) */
    const float oi[3] = {0.5f, 0.5f, 0.5f};
    const float dd[3] = {0.57735027f, 0.57735027f, 0.57735027f};
    assert_int_equal(esr_ray_box_clip(oi, dd, BMIN, BMAX, 0.0f, 100.0f, &t0, &t1), 1);
    assert_true(t0 == 0.0f && fabsf(t1 - 1.0f / 0.57735027f) < 1e-5f);
    /* grazing an edge */
    const float og[3] = {1.5f, 1.5f, 4.0f};
    assert_int_equal(esr_ray_box_clip(og, d, BMIN, BMAX, 2.0f, 6.0f, &t0, &t1), 1);
}

static void test_sampler_positions_and_order(void **state)
{
    (void)state;
    struct esr_samples s;
    assert_int_equal(esr_samples_alloc(&s, 1000, 4), ESR_OK);
    struct esr_sample_params p;
    esr_sample_params_init(&p, BMIN, BMAX, 0.25f);
    const float o[9] = {0, 0, 4, 5, 5, 5, 0, 4, 0};
    const float d[9] = {0, 0, -1, 0, 0, 1, 0, -1, 0};
    assert_int_equal(esr_sample_rays(&p, o, d, 3, &s), ESR_OK);
    assert_int_equal(s.count, 24); /* 3 / 0.25 = 12 per hitting ray, ray 1 misses */
    assert_int_equal(s.ray_start[1], 12);
    assert_int_equal(s.ray_start[2], 12);
    assert_int_equal(s.ray_start[3], 24);
    for (size_t i = 0; i < 12; i++) {
        assert_int_equal(s.ray[i], 0);
        assert_true(fabsf(s.t[i] - (2.5f + (i + 0.5f) * 0.25f)) < 1e-5f);
        assert_true(fabsf(s.pos[i * 3 + 2] - (4.0f - s.t[i])) < 1e-5f);
        assert_int_equal(s.ray[12 + i], 2);
    }
    /* max per ray */
    p.max_per_ray = 5;
    assert_int_equal(esr_sample_rays(&p, o, d, 3, &s), ESR_OK);
    assert_int_equal(s.count, 10);
    p.max_per_ray = 0;
    /* capacity and bad parameters */
    struct esr_samples small;
    assert_int_equal(esr_samples_alloc(&small, 10, 4), ESR_OK);
    assert_int_equal(esr_sample_rays(&p, o, d, 3, &small), ESR_ERR);
    assert_int_equal(small.count, 24);
    assert_non_null(strstr(esr_error_message(), "24 samples needed"));
    esr_error_clear();
    assert_int_equal(esr_sample_rays(&p, o, d, 5, &s), ESR_ERR);
    esr_error_clear();
    p.step = 0.0f;
    assert_int_equal(esr_sample_rays(&p, o, d, 3, &s), ESR_ERR);
    esr_error_clear();
    esr_samples_free(&small);
    esr_samples_free(&s);
}

/* A camera closer to the scene than the old near plane (t = 2) still samples the box's near side:
 * from 1.8 above the origin the box [-1.5, 1.5]^3 starts at t = 0.3; from inside it, at t = 0. */
static void test_sampler_close_camera(void **state)
{
    (void)state;
    struct esr_samples s;
    assert_int_equal(esr_samples_alloc(&s, 100, 2), ESR_OK);
    struct esr_sample_params p;
    esr_sample_params_init(&p, BMIN, BMAX, 0.25f);
    const float o[6] = {0, 0, 1.8f, 0.5f, 0, 0.2f}, d[6] = {0, 0, -1, 0, 0, -1};
    assert_int_equal(esr_sample_rays(&p, o, d, 2, &s), ESR_OK);
    assert_int_equal(s.ray_start[1], 12); /* the whole 3 units of box */
    assert_true(fabsf(s.t[0] - (0.3f + 0.125f)) < 1e-5f);
    assert_int_equal(s.ray_start[2] - s.ray_start[1], 7); /* 1.7 units from inside: 6.8 steps */
    assert_true(fabsf(s.t[12] - 0.125f) < 1e-5f);
    esr_samples_free(&s);
}

/* b (a masked march) holds exactly the samples of a (the same march without the mask) that the
 * mask keeps, bit for bit: the sampler skips the steps outside the occupied box and across the
 * mask's empty blocks, and their random draws, without changing a sample. */
static void assert_mask_keeps_subset(const struct esr_samples *a, const struct esr_samples *b,
                                     const struct esr_mask *m, int R)
{
    size_t kept = 0;
    for (int r = 0; r < R; r++) {
        assert_int_equal(b->ray_start[r], kept);
        for (size_t i = a->ray_start[r]; i < a->ray_start[r + 1]; i++)
            if (esr_mask_query(m, a->pos + i * 3)) {
                assert_true(kept < b->count);
                assert_true(b->t[kept] == a->t[i] && b->ray[kept] == r);
                assert_memory_equal(b->pos + kept * 3, a->pos + i * 3, 3 * sizeof(float));
                kept++;
            }
    }
    assert_int_equal(kept, b->count);
}

/* Jittered samples stay in their strata, with one offset per ray (samples exactly a step apart,
 * as each NeuS section t -+ step / 2 assumes), are reproducible, independent of the thread
 * count, and masked-out space is skipped. */
static void test_sampler_jitter_and_mask(void **state)
{
    (void)state;
    enum { R = 64 };
    float o[R * 3], d[R * 3];
    for (int r = 0; r < R; r++) {
        float ang = 0.1f * r;
        o[r * 3 + 0] = 4.0f * cosf(ang);
        o[r * 3 + 1] = 4.0f * sinf(ang);
        o[r * 3 + 2] = 0.3f;
        d[r * 3 + 0] = -cosf(ang);
        d[r * 3 + 1] = -sinf(ang);
        d[r * 3 + 2] = 0.0f;
    }
    struct esr_sample_params p;
    esr_sample_params_init(&p, BMIN, BMAX, 0.05f);
    p.jitter = 1;
    p.seed = 42;
    struct esr_samples a, b;
    assert_int_equal(esr_samples_alloc(&a, 20000, R), ESR_OK);
    assert_int_equal(esr_samples_alloc(&b, 20000, R), ESR_OK);
    int saved = omp_get_max_threads();
    omp_set_num_threads(1);
    assert_int_equal(esr_sample_rays(&p, o, d, R, &a), ESR_OK);
    omp_set_num_threads(3);
    assert_int_equal(esr_sample_rays(&p, o, d, R, &b), ESR_OK);
    omp_set_num_threads(saved);
    assert_int_equal(a.count, b.count);
    assert_memory_equal(a.t, b.t, a.count * sizeof(float));
    double mean_u = 0.0;
    size_t n_u = 0;
    for (int r = 0; r < R; r++) {
        float t0 = 0.0f, t1 = 0.0f;
        assert_int_equal(esr_ray_box_clip(o + r * 3, d + r * 3, BMIN, BMAX, 0.0f, 1e30f, &t0, &t1), 1);
        const float u0 = (a.t[a.ray_start[r]] - t0) / p.step;
        for (size_t i = a.ray_start[r]; i < a.ray_start[r + 1]; i++) {
            float u = (a.t[i] - t0) / p.step - (float)(i - a.ray_start[r]);
            assert_true(u >= -1e-3f && u <= 1.0f + 1e-3f);
            assert_true(fabsf(u - u0) < 2e-3f); /* the ray's one offset */
            assert_true(a.t[i] <= t1 + 1e-6f);
            mean_u += u;
            n_u++;
        }
    }
    mean_u /= (double)n_u;
    assert_true(fabs(mean_u - 0.5) < 0.05);
    /* mask: only a ball of radius ~0.6 occupied */
    struct esr_grid g;
    assert_int_equal(esr_grid_init(&g, 1, 31, 31, 31, BMIN, BMAX), ESR_OK);
    struct esr_mask m;
    assert_int_equal(esr_mask_alloc(&m, &g), ESR_OK);
    for (int z = 0; z < 31; z++)
        for (int y = 0; y < 31; y++)
            for (int x = 0; x < 31; x++) {
                float q[3];
                esr_grid_voxel_pos(&g, x, y, z, q);
                m.occ[(z * 31 + y) * 31 + x] = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] < 0.36f;
            }
    p.mask = &m;
    assert_int_equal(esr_sample_rays(&p, o, d, R, &b), ESR_OK);
    assert_true(b.count > 0 && b.count < a.count / 3);
    assert_mask_keeps_subset(&a, &b, &m, R);
    float lo[3], hi[3];
    assert_int_equal(esr_mask_occupied_box(&m, lo, hi), 1);
    float qlo[3] = {1e30f, 1e30f, 1e30f}, qhi[3] = {-1e30f, -1e30f, -1e30f};
    for (int i = 0; i < 31 * 31 * 31; i++) /* the occupied lattice points' box */
        if (m.occ[i]) {
            float q[3];
            esr_grid_voxel_pos(&g, i % 31, i / 31 % 31, i / (31 * 31), q);
            for (int k = 0; k < 3; k++) {
                qlo[k] = fminf(qlo[k], q[k]);
                qhi[k] = fmaxf(qhi[k], q[k]);
            }
        }
    for (int k = 0; k < 3; k++) { /* grown by a voxel (0.1) */
        assert_true(fabsf(lo[k] - (qlo[k] - 0.1f)) < 1e-5f);
        assert_true(fabsf(hi[k] - (qhi[k] + 0.1f)) < 1e-5f);
    }
    memset(m.occ, 0, 31 * 31 * 31);
    assert_int_equal(esr_mask_occupied_box(&m, lo, hi), 0);
    assert_int_equal(esr_sample_rays(&p, o, d, R, &b), ESR_OK);
    assert_int_equal(b.count, 0);
    assert_int_equal(b.ray_start[R], 0);
    esr_mask_free(&m);
    esr_samples_free(&a);
    esr_samples_free(&b);
}

/* The mask's empty blocks are crossed without changing a sample: blobs scattered through a 67^3
 * mask (blocks of 8 with a partial last one), rays from every direction, with and without jitter;
 * the block summary marks exactly the blocks with an occupied point. */
static void test_sampler_empty_blocks(void **state)
{
    (void)state;
    enum { R = 400, N = 67 };
    struct esr_grid g;
    assert_int_equal(esr_grid_init(&g, 1, N, N, N, BMIN, BMAX), ESR_OK);
    struct esr_mask m;
    assert_int_equal(esr_mask_alloc(&m, &g), ESR_OK);
    struct esr_rng rng = esr_rng_init(5, 0);
    float blob[12][4];
    for (int k = 0; k < 12; k++) {
        for (int a = 0; a < 3; a++)
            blob[k][a] = 1.6f * esr_rng_float(&rng) - 0.8f;
        blob[k][3] = 0.05f + 0.1f * esr_rng_float(&rng);
    }
    for (int z = 0; z < N; z++)
        for (int y = 0; y < N; y++)
            for (int x = 0; x < N; x++) {
                float q[3];
                esr_grid_voxel_pos(&g, x, y, z, q);
                uint8_t occ = 0;
                for (int k = 0; k < 12; k++) {
                    const float dx = q[0] - blob[k][0], dy = q[1] - blob[k][1], dz = q[2] - blob[k][2];
                    occ |= dx * dx + dy * dy + dz * dz < blob[k][3] * blob[k][3];
                }
                m.occ[((size_t)z * N + y) * N + x] = occ;
            }
    int nb[3];
    esr_mask_block_dims(&m, nb);
    assert_int_equal(nb[0], 9);
    uint8_t *any = malloc((size_t)nb[0] * nb[1] * nb[2]);
    assert_non_null(any);
    esr_mask_blocks(&m, any);
    int empty = 0;
    for (int b = 0; b < nb[0] * nb[1] * nb[2]; b++) {
        const int bx = b % nb[0], by = b / nb[0] % nb[1], bz = b / (nb[0] * nb[1]);
        uint8_t want = 0;
        for (int z = bz * 8; z < bz * 8 + 8 && z < N; z++)
            for (int y = by * 8; y < by * 8 + 8 && y < N; y++)
                for (int x = bx * 8; x < bx * 8 + 8 && x < N; x++)
                    want |= m.occ[((size_t)z * N + y) * N + x];
        assert_int_equal(any[b], want);
        empty += !want;
    }
    assert_true(empty > nb[0] * nb[1] * nb[2] / 3);
    free(any);
    float o[R * 3], d[R * 3];
    for (int r = 0; r < R; r++) {
        float len;
        do {
            for (int a = 0; a < 3; a++)
                d[r * 3 + a] = 2.0f * esr_rng_float(&rng) - 1.0f;
            len = sqrtf(d[r * 3] * d[r * 3] + d[r * 3 + 1] * d[r * 3 + 1] + d[r * 3 + 2] * d[r * 3 + 2]);
        } while (len < 0.2f || len > 1.0f);
        for (int a = 0; a < 3; a++) {
            d[r * 3 + a] /= len;
            o[r * 3 + a] = 0.5f * (esr_rng_float(&rng) - 0.5f) - 3.0f * d[r * 3 + a];
        }
    }
    struct esr_samples a, b;
    assert_int_equal(esr_samples_alloc(&a, 200000, R), ESR_OK);
    assert_int_equal(esr_samples_alloc(&b, 200000, R), ESR_OK);
    for (int jitter = 0; jitter < 2; jitter++) {
        struct esr_sample_params p;
        esr_sample_params_init(&p, BMIN, BMAX, 0.5f * 2.0f / (N - 1));
        p.jitter = jitter;
        p.seed = 9;
        assert_int_equal(esr_sample_rays(&p, o, d, R, &a), ESR_OK);
        p.mask = &m;
        assert_int_equal(esr_sample_rays(&p, o, d, R, &b), ESR_OK);
        assert_true(b.count > 500 && b.count < a.count / 4);
        assert_mask_keeps_subset(&a, &b, &m, R);
    }
    esr_samples_free(&a);
    esr_samples_free(&b);
    esr_mask_free(&m);
}

/* Real scene: every pixel ray of a training camera, marched through the dataset's box at
 * 0.5 voxel of a 96^3 grid: the centre ray hits, samples stay in the box and inside [2, 6], and
 * each hitting ray gets its clipped length / step samples. */
static void test_lamp_camera_rays(void **state)
{
    (void)state;
    const char *dir = test_shared_scene("lamp");
    if (!dir)
        skip();
    struct esr_dataset ds;
    assert_int_equal(esr_dataset_load(dir, &ds), ESR_OK);
    const struct esr_frame *f = &ds.phases[ESR_PHASE_TRAIN].frames[0];
    const int W = f->camera.width, H = f->camera.height, R = W * H;
    float *o = malloc((size_t)R * 3 * sizeof(float)), *d = malloc((size_t)R * 3 * sizeof(float));
    for (int j = 0; j < H; j++)
        for (int i = 0; i < W; i++)
            esr_camera_ray(&f->camera, i + 0.5f, j + 0.5f, o + (j * W + i) * 3, d + (j * W + i) * 3);
    float step = 0.5f * (ds.bbox_max[0] - ds.bbox_min[0]) / 95.0f;
    struct esr_sample_params p;
    esr_sample_params_init(&p, ds.bbox_min, ds.bbox_max, step);
    struct esr_samples s;
    assert_int_equal(esr_samples_alloc(&s, (size_t)R * 400, R), ESR_OK);
    assert_int_equal(esr_sample_rays(&p, o, d, R, &s), ESR_OK);
    int centre = (H / 2) * W + W / 2;
    assert_true(s.ray_start[centre + 1] - s.ray_start[centre] > 100);
    for (int r = 0; r < R; r++) {
        float t0 = 0.0f, t1 = 0.0f;
        size_t cnt = s.ray_start[r + 1] - s.ray_start[r];
        if (!esr_ray_box_clip(o + r * 3, d + r * 3, ds.bbox_min, ds.bbox_max, 0.0f, 1e30f, &t0, &t1)) {
            assert_int_equal(cnt, 0);
            continue;
        }
        assert_true(fabs((double)cnt - (t1 - t0) / step) <= 1.0);
    }
    for (size_t i = 0; i < s.count; i++) {
        assert_true(s.t[i] >= 0.0f && s.t[i] <= 8.0f); /* cameras at 4, the box's diagonal 5.2 */
        for (int a = 0; a < 3; a++)
            assert_true(s.pos[i * 3 + a] >= ds.bbox_min[a] - 1e-4f && s.pos[i * 3 + a] <= ds.bbox_max[a] + 1e-4f);
    }
    esr_samples_free(&s);
    free(o);
    free(d);
    esr_dataset_free(&ds);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_box_clip_cases),
        cmocka_unit_test(test_sampler_positions_and_order),
        cmocka_unit_test(test_sampler_close_camera),
        cmocka_unit_test(test_sampler_jitter_and_mask),
        cmocka_unit_test(test_sampler_empty_blocks),
        cmocka_unit_test(test_lamp_camera_rays),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
