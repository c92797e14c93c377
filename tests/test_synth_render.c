/* The path tracer of `esr synth` against independent references: a convex white object in a
 * uniform world (furnace: it must return world x directional albedo, computed by quadrature) and a
 * surface lit by a spherical emitter (direct lighting integrated numerically over the emitter's
 * surface), for a diffuse and a glossy receiver; plus thread-count independence. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <string.h>

#include "synth/synth.h"
#include "synth/trace.h"

static void add(struct esr_synth_scene *s, enum esr_synth_prim_kind kind, struct esr_vec3 a, struct esr_vec3 b,
                float base, float roughness, float metallic)
{
    struct esr_synth_prim *p = &s->prims[s->n_prims++];
    memset(p, 0, sizeof *p);
    p->kind = kind;
    p->a = a;
    p->b = b;
    p->mat.base[0] = p->mat.base[1] = p->mat.base[2] = base;
    p->mat.roughness = roughness;
    p->mat.metallic = metallic;
    p->light = -1;
    p->name = "prim";
}

/* A 1x1 camera at `from` looking at `at`, with a 0.5 mrad pixel: effectively one ray. */
static struct esr_camera pinhole(struct esr_vec3 from, struct esr_vec3 at)
{
    struct esr_vec3 z = esr_v3_normalize(esr_v3_sub(from, at));
    struct esr_vec3 x = esr_v3_normalize(esr_v3_cross(esr_v3(0, 1, 0), z));
    struct esr_vec3 y = esr_v3_cross(z, x);
    struct esr_camera cam;
    float cols[4][3] = {{x.x, x.y, x.z}, {y.x, y.y, y.z}, {z.x, z.y, z.z}, {from.x, from.y, from.z}};
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 4; c++)
            cam.c2w[r][c] = cols[c][r];
    cam.width = cam.height = 1;
    cam.focal = 2000.0f;
    return cam;
}

static void render_pixel(const struct esr_synth_trace_params *p, const struct esr_camera *cam, int spp, float out[4])
{
    struct esr_image img;
    assert_int_equal(esr_synth_render(p, cam, spp, 5, 0, &img), 0);
    memcpy(out, img.data, 4 * sizeof(float));
    esr_image_free(&img);
}

/* Directional albedo (per channel) by midpoint quadrature over the hemisphere. */
static void albedo_quadrature(const struct esr_material *m, struct esr_vec3 n, struct esr_vec3 wo, double out[3])
{
    struct esr_vec3 t, b;
    esr_v3_basis(n, &t, &b);
    const int nt = 600, np = 1200;
    out[0] = out[1] = out[2] = 0.0;
    for (int i = 0; i < nt; i++) {
        double th = (i + 0.5) * (M_PI / 2) / nt, w = sin(th) * (M_PI / 2 / nt) * (2 * M_PI / np);
        for (int j = 0; j < np; j++) {
            double ph = (j + 0.5) * 2 * M_PI / np;
            struct esr_vec3 local = esr_v3((float)(sin(th) * cos(ph)), (float)(sin(th) * sin(ph)), (float)cos(th));
            float f[3];
            esr_brdf_eval(m, n, wo, esr_v3_from_local(local, t, b, n), f);
            for (int c = 0; c < 3; c++)
                out[c] += f[c] * w;
        }
    }
}

static void test_furnace_convex_object(void **state)
{
    (void)state;
    const float roughness[] = {0.3f, 1.0f}, metallic[] = {0.0f, 1.0f};
    for (int v = 0; v < 2; v++) {
        struct esr_synth_scene s;
        memset(&s, 0, sizeof s);
        add(&s, ESR_SYNTH_SPHERE, esr_v3(0, 0, 0), esr_v3(0.5f, 0, 0), 1.0f, roughness[v], metallic[v]);
        s.world_rgb[0] = 0.55f, s.world_rgb[1] = 0.65f, s.world_rgb[2] = 1.0f;
        s.world_strength = 0.25f;
        s.max_bounces = 8;
        struct esr_synth_trace_params p;
        esr_synth_trace_setup(&s, NULL, &p);
        /* Looking at the sphere from 45 degrees off its pole: wo = n at the hit point. */
        struct esr_vec3 from = esr_v3(0, 2.0f, 2.0f), hitp = esr_v3(0, 0.35355339f, 0.35355339f);
        struct esr_camera cam = pinhole(from, esr_v3(0, 0, 0));
        float px[4];
        render_pixel(&p, &cam, 40000, px);
        double albedo[3];
        struct esr_vec3 n = esr_v3_normalize(hitp);
        albedo_quadrature(&s.prims[0].mat, n, n, albedo);
        assert_float_equal(px[3], 1.0f, 0.0f);
        for (int c = 0; c < 3; c++) {
            double expect = s.world_rgb[c] * s.world_strength * albedo[c];
            if (fabs(px[c] - expect) > 0.01 * expect) {
                fprintf(stderr, "variant %d channel %d: rendered %.5f, expected %.5f\n", v, c, px[c], expect);
                fail();
            }
        }
    }
}

/* Direct light from a sphere emitter at the floor point hitp seen from `from`, integrated over the
 * emitter's surface (no sampling): sum of Le R(wo, wi) cos_l / d^2 dA over the visible half. */
static void direct_reference(const struct esr_synth_scene *s, int emitter, const float le[3], struct esr_vec3 from,
                             struct esr_vec3 hitp, double out[3])
{
    const struct esr_synth_prim *e = &s->prims[emitter];
    const struct esr_material *m = &s->prims[0].mat;
    struct esr_vec3 n = esr_v3(0, 0, 1), wo = esr_v3_normalize(esr_v3_sub(from, hitp));
    const int nt = 800, np = 1600;
    double r = e->b.x;
    for (int i = 0; i < nt; i++) {
        double th = (i + 0.5) * M_PI / nt, da_th = r * r * sin(th) * (M_PI / nt) * (2 * M_PI / np);
        for (int j = 0; j < np; j++) {
            double ph = (j + 0.5) * 2 * M_PI / np;
            struct esr_vec3 ny = esr_v3((float)(sin(th) * cos(ph)), (float)(sin(th) * sin(ph)), (float)cos(th));
            struct esr_vec3 y = esr_v3_add(e->a, esr_v3_scale(ny, (float)r));
            struct esr_vec3 to = esr_v3_sub(y, hitp);
            double d2 = esr_v3_dot(to, to);
            struct esr_vec3 wi = esr_v3_scale(to, 1.0f / sqrtf((float)d2));
            double cos_l = -esr_v3_dot(ny, wi);
            if (cos_l <= 0.0)
                continue;
            float f[3];
            esr_brdf_eval(m, n, wo, wi, f);
            for (int c = 0; c < 3; c++)
                out[c] += le[c] * f[c] * cos_l / d2 * da_th;
        }
    }
}

static void test_direct_light_matches_integral(void **state)
{
    (void)state;
    /* Variant 2 adds a second, smaller emitter: both lights are sampled at every vertex. */
    const float base[] = {0.5f, 0.8f, 0.6f}, roughness[] = {1.0f, 0.3f, 0.7f}, metallic[] = {0.0f, 1.0f, 0.2f};
    for (int v = 0; v < 3; v++) {
        struct esr_synth_scene s;
        memset(&s, 0, sizeof s);
        add(&s, ESR_SYNTH_BOX, esr_v3(-3, -3, -0.1f), esr_v3(3, 3, 0), base[v], roughness[v], metallic[v]);
        add(&s, ESR_SYNTH_SPHERE, esr_v3(0, 0, 0.8f), esr_v3(0.2f, 0, 0), 0.0f, 1.0f, 0.0f);
        s.prims[1].light = 0;
        s.n_lights = 1;
        s.lights[0].prim = 1;
        if (v == 2) {
            add(&s, ESR_SYNTH_SPHERE, esr_v3(0.6f, 0.5f, 0.4f), esr_v3(0.1f, 0, 0), 0.0f, 1.0f, 0.0f);
            s.prims[2].light = 1;
            s.n_lights = 2;
            s.lights[1].prim = 2;
        }
        s.max_bounces = 8;
        const float le[2][3] = {{10.0f, 6.0f, 3.0f}, {2.0f, 5.0f, 12.0f}};
        struct esr_synth_trace_params p;
        esr_synth_trace_setup(&s, le, &p);
        /* The glossy variant looks along the mirror direction of the emitter's centre. */
        struct esr_vec3 from = esr_v3(0.9f, 0, 1.6f), hitp = esr_v3(0.3f, 0, 0);
        struct esr_camera cam = pinhole(from, hitp);
        float px[4];
        render_pixel(&p, &cam, 40000, px);
        double expect[3];
        expect[0] = expect[1] = expect[2] = 0.0;
        for (int k = 0; k < s.n_lights; k++)
            direct_reference(&s, s.lights[k].prim, le[k], from, hitp, expect);
        for (int c = 0; c < 3; c++) {
            if (fabs(px[c] - expect[c]) > 0.015 * expect[c]) {
                fprintf(stderr, "variant %d channel %d: rendered %.5f, expected %.5f\n", v, c, px[c], expect[c]);
                fail();
            }
        }
    }
}

static void test_thread_count_independent(void **state)
{
    (void)state;
    struct esr_synth_scene s;
    assert_int_equal(esr_synth_scene_get("default", &s), 0);
    float le[ESR_SYNTH_MAX_LIGHTS][3];
    for (int k = 0; k < s.n_lights; k++)
        for (int c = 0; c < 3; c++)
            le[k][c] = s.lights[k].rgb[c] * s.lights[k].strength;
    struct esr_synth_trace_params p;
    esr_synth_trace_setup(&s, (const float(*)[3])le, &p);
    struct esr_camera cam = pinhole(esr_v3(3.0f, -2.0f, 1.8f), esr_v3(0, 0, 0.2f));
    cam.width = cam.height = 24;
    cam.focal = 35.0f;
    struct esr_image a, b, c;
    int threads = omp_get_max_threads();
    omp_set_num_threads(1);
    assert_int_equal(esr_synth_render(&p, &cam, 4, 9, 3, &a), 0);
    omp_set_num_threads(3);
    assert_int_equal(esr_synth_render(&p, &cam, 4, 9, 3, &b), 0);
    assert_int_equal(esr_synth_render(&p, &cam, 4, 9, 4, &c), 0);
    omp_set_num_threads(threads);
    assert_memory_equal(a.data, b.data, esr_image_count(&a) * sizeof(float));
    assert_true(memcmp(a.data, c.data, esr_image_count(&a) * sizeof(float)) != 0); /* other image, other noise */
    int background = 0, edge = 0;
    for (int i = 0; i < 24 * 24; i++) {
        float alpha = a.data[4 * i + 3];
        assert_true(alpha >= 0.0f && alpha <= 1.0f);
        if (alpha == 0.0f) {
            background++;
            assert_true(a.data[4 * i] == 0.0f && a.data[4 * i + 1] == 0.0f && a.data[4 * i + 2] == 0.0f);
        } else if (alpha < 1.0f) {
            edge++;
        }
    }
    assert_true(background > 0 && edge > 0);
    esr_image_free(&a);
    esr_image_free(&b);
    esr_image_free(&c);
}

/* Images rendered with a shared jitter stream sample the same camera rays whatever their lighting:
 * the same alpha bit for bit (with the path stream's jitter they differ at the edges). With
 * nothing lit and the world off (trace.c ends such paths at their first hit): black where the
 * scene is, the backdrop (gain 1: no light on) where it is not, alpha 1. */
static void test_shared_jitter_and_nothing_lit(void **state)
{
    (void)state;
    struct esr_synth_scene s;
    assert_int_equal(esr_synth_scene_get("default", &s), 0);
    float none[ESR_SYNTH_MAX_LIGHTS][3], one[ESR_SYNTH_MAX_LIGHTS][3];
    memset(none, 0, sizeof none);
    memset(one, 0, sizeof one);
    one[0][0] = one[0][1] = one[0][2] = 1.0f;
    struct esr_synth_trace_params world, light, dark;
    esr_synth_trace_setup(&s, (const float(*)[3])none, &world);
    esr_synth_trace_setup(&s, (const float(*)[3])one, &light);
    memset(light.world, 0, sizeof light.world);
    esr_synth_trace_setup(&s, (const float(*)[3])none, &dark);
    memset(dark.world, 0, sizeof dark.world);
    dark.backdrop = 1;
    struct esr_camera cam = pinhole(esr_v3(3.0f, -2.0f, 1.8f), esr_v3(0, 0, 0.2f));
    cam.width = cam.height = 24;
    cam.focal = 35.0f;
    struct esr_image a, b, c, d;
    assert_int_equal(esr_synth_render_shared_jitter(&world, &cam, 8, 9, 1, 5, &a), 0);
    assert_int_equal(esr_synth_render_shared_jitter(&light, &cam, 8, 9, 2, 5, &b), 0);
    assert_int_equal(esr_synth_render(&light, &cam, 8, 9, 2, &c), 0);
    assert_int_equal(esr_synth_render_shared_jitter(&dark, &cam, 8, 9, 3, 5, &d), 0);
    int edge = 0, alpha_differs = 0, background = 0;
    for (int i = 0; i < 24 * 24; i++) {
        const float alpha = a.data[4 * i + 3];
        assert_float_equal(b.data[4 * i + 3], alpha, 0.0f);
        edge += alpha > 0.0f && alpha < 1.0f;
        alpha_differs += c.data[4 * i + 3] != alpha;
        assert_float_equal(d.data[4 * i + 3], 1.0f, 0.0f);
        if (alpha > 0.0f)
            continue;
        background++; /* the backdrop seen along the pixel's camera rays, nothing else */
        float o[3], dir[3], rgb[3];
        esr_camera_ray(&cam, (float)(i % 24) + 0.5f, (float)(i / 24) + 0.5f, o, dir);
        esr_synth_backdrop(esr_v3(dir[0], dir[1], dir[2]), 0, rgb);
        for (int ch = 0; ch < 3; ch++)
            assert_float_equal(d.data[4 * i + ch], rgb[ch], 0.1f * rgb[ch]); /* across the pixel */
    }
    assert_true(edge > 0 && alpha_differs > 0 && background > 0);
    for (int i = 0; i < 24 * 24; i++) /* a pixel the scene covers holds no light: black */
        if (a.data[4 * i + 3] == 1.0f)
            for (int ch = 0; ch < 3; ch++)
                assert_float_equal(d.data[4 * i + ch], 0.0f, 0.0f);
    esr_image_free(&a);
    esr_image_free(&b);
    esr_image_free(&c);
    esr_image_free(&d);
}

/* The benchmark workload runs and reports consistent figures (its speed is for `esr bench`). */
static void test_bench_reports(void **state)
{
    (void)state;
    struct esr_synth_bench_result r;
    assert_int_equal(esr_synth_bench(&r), 0);
    assert_int_equal(r.samples, 4LL * 64 * 64 * 16);
    assert_true(r.seconds > 0.0 && isfinite(r.samples_per_s));
    assert_float_equal(r.samples_per_s, r.samples / r.seconds, 1e-6 * r.samples_per_s);
    assert_float_equal(r.pixels_per_s * 16, r.samples_per_s, 1e-6 * r.samples_per_s);
    fprintf(stderr, "synth bench: %.2f Msamples/s\n", r.samples_per_s * 1e-6);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_furnace_convex_object),
        cmocka_unit_test(test_direct_light_matches_integral),
        cmocka_unit_test(test_thread_count_independent),
        cmocka_unit_test(test_shared_jitter_and_nothing_lit),
        cmocka_unit_test(test_bench_reports),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
