/* Analytic primitives of `esr synth`: intersections land on the surface with the right normal and
 * agree with an independent inside/outside march, area sampling stays on the surface and covers
 * it uniformly, and the tessellated mesh is closed, outward and of the right volume. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/rng.h"
#include "synth/scene.h"

static struct esr_synth_prim make(enum esr_synth_prim_kind kind, struct esr_vec3 a, struct esr_vec3 b)
{
    struct esr_synth_prim p;
    memset(&p, 0, sizeof p);
    p.kind = kind;
    p.a = a;
    p.b = b;
    p.light = -1;
    p.name = "p";
    return p;
}

static struct esr_synth_prim prims[3];

static int setup(void **state)
{
    (void)state;
    prims[0] = make(ESR_SYNTH_SPHERE, esr_v3(0.1f, -0.2f, 0.3f), esr_v3(0.4f, 0, 0));
    prims[1] = make(ESR_SYNTH_BOX, esr_v3(-0.3f, -0.2f, 0.0f), esr_v3(0.5f, 0.1f, 0.35f));
    prims[2] = make(ESR_SYNTH_CYLINDER, esr_v3(0.05f, 0.1f, -0.2f), esr_v3(0.3f, 0.6f, 0));
    return 0;
}

/* Reference: a point uniformly distributed over the whole surface by area (pdf 1 / area) and its
 * outward normal; u0 picks the face / part, (u1, u2) the position on it. */
static void sample_whole_surface(const struct esr_synth_prim *p, float u0, float u1, float u2, struct esr_vec3 *x,
                                 struct esr_vec3 *n)
{
    if (p->kind == ESR_SYNTH_SPHERE) {
        *n = esr_sample_sphere_uniform(u1, u2);
        *x = esr_v3_add(p->a, esr_v3_scale(*n, p->b.x));
        return;
    }
    if (p->kind == ESR_SYNTH_BOX) {
        struct esr_vec3 e = esr_v3_sub(p->b, p->a);
        float axy = e.x * e.y, ayz = e.y * e.z, azx = e.z * e.x;
        float pick = u0 * (axy + ayz + azx); /* axis by face-pair area, then side by halves */
        float lo[3] = {p->a.x, p->a.y, p->a.z}, ext[3] = {e.x, e.y, e.z};
        int axis = pick < axy ? 2 : (pick < axy + ayz ? 0 : 1);
        float area = axis == 2 ? axy : (axis == 0 ? ayz : azx);
        float start = axis == 2 ? 0.0f : (axis == 0 ? axy : axy + ayz);
        float v = (pick - start) / area; /* uniform in [0,1) again */
        int side = v >= 0.5f;
        float pos[3], nor[3] = {0.0f, 0.0f, 0.0f};
        int k1 = (axis + 1) % 3, k2 = (axis + 2) % 3;
        pos[axis] = lo[axis] + (side ? ext[axis] : 0.0f);
        pos[k1] = lo[k1] + u1 * ext[k1];
        pos[k2] = lo[k2] + u2 * ext[k2];
        nor[axis] = side ? 1.0f : -1.0f;
        *x = esr_v3(pos[0], pos[1], pos[2]);
        *n = esr_v3(nor[0], nor[1], nor[2]);
        return;
    }
    float r = p->b.x, h = p->b.y;
    float side_area = 2.0f * ESR_PI * r * h, cap_area = ESR_PI * r * r;
    float pick = u0 * (side_area + 2.0f * cap_area);
    float phi = 2.0f * ESR_PI * u1;
    if (pick < side_area) {
        *n = esr_v3(cosf(phi), sinf(phi), 0.0f);
        *x = esr_v3(p->a.x + r * n->x, p->a.y + r * n->y, p->a.z + u2 * h);
        return;
    }
    int top = pick >= side_area + cap_area;
    float rr = r * sqrtf(u2);
    *n = esr_v3(0.0f, 0.0f, top ? 1.0f : -1.0f);
    *x = esr_v3(p->a.x + rr * cosf(phi), p->a.y + rr * sinf(phi), p->a.z + (top ? h : 0.0f));
}

/* Inside test written independently of the intersection code. */
static int inside(const struct esr_synth_prim *p, struct esr_vec3 x)
{
    if (p->kind == ESR_SYNTH_SPHERE)
        return esr_v3_length(esr_v3_sub(x, p->a)) < p->b.x;
    if (p->kind == ESR_SYNTH_BOX)
        return x.x > p->a.x && x.x < p->b.x && x.y > p->a.y && x.y < p->b.y && x.z > p->a.z && x.z < p->b.z;
    float dx = x.x - p->a.x, dy = x.y - p->a.y;
    return dx * dx + dy * dy < p->b.x * p->b.x && x.z > p->a.z && x.z < p->a.z + p->b.y;
}

static float surface_distance(const struct esr_synth_prim *p, struct esr_vec3 x)
{
    /* Distance to the surface for points on or near it. */
    if (p->kind == ESR_SYNTH_SPHERE)
        return fabsf(esr_v3_length(esr_v3_sub(x, p->a)) - p->b.x);
    if (p->kind == ESR_SYNTH_BOX) {
        float d = INFINITY;
        float lo[3] = {p->a.x, p->a.y, p->a.z}, hi[3] = {p->b.x, p->b.y, p->b.z}, v[3] = {x.x, x.y, x.z};
        for (int k = 0; k < 3; k++)
            d = fminf(d, fminf(fabsf(v[k] - lo[k]), fabsf(v[k] - hi[k])));
        return d;
    }
    float r = sqrtf((x.x - p->a.x) * (x.x - p->a.x) + (x.y - p->a.y) * (x.y - p->a.y));
    return fminf(fabsf(r - p->b.x), fminf(fabsf(x.z - p->a.z), fabsf(x.z - p->a.z - p->b.y)));
}

static void test_rays_against_march(void **state)
{
    (void)state;
    struct esr_rng rng = esr_rng_init(1, 0);
    for (int k = 0; k < 3; k++) {
        const struct esr_synth_prim *p = &prims[k];
        int hits = 0;
        for (int i = 0; i < 3000; i++) {
            /* Rays from a box around the object towards a random point near it. */
            struct esr_vec3 o = esr_v3(4 * esr_rng_float(&rng) - 2, 4 * esr_rng_float(&rng) - 2, 4 * esr_rng_float(&rng) - 2);
            if (inside(p, o))
                continue;
            struct esr_vec3 target = esr_v3(esr_rng_float(&rng) - 0.5f, esr_rng_float(&rng) - 0.5f, esr_rng_float(&rng) - 0.3f);
            struct esr_vec3 d = esr_v3_normalize(esr_v3_sub(target, o));
            if (i % 7 == 0) /* axis-parallel rays exercise the slab and cap code paths */
                d = esr_v3(0, 0, o.z > 0 ? -1.0f : 1.0f);
            float t = esr_synth_prim_hit(p, o, d, 0.0f, INFINITY);
            /* March: the first sample inside the object. */
            float t_march = INFINITY;
            for (int s = 1; s < 4000; s++) {
                if (inside(p, esr_v3_add(o, esr_v3_scale(d, s * 0.002f)))) {
                    t_march = s * 0.002f;
                    break;
                }
            }
            if (isinf(t_march)) {
                /* The march can step over a sliver thinner than 2 mm; otherwise a miss. */
                assert_true(isinf(t) || surface_distance(p, esr_v3_add(o, esr_v3_scale(d, t + 0.002f))) < 0.003f);
                continue;
            }
            hits++;
            assert_false(isinf(t));
            assert_true(t <= t_march + 1e-4f && t >= t_march - 0.0021f);
            struct esr_vec3 x = esr_v3_add(o, esr_v3_scale(d, t));
            assert_true(surface_distance(p, x) < 1e-4f);
            struct esr_vec3 n = esr_synth_prim_normal(p, x);
            assert_float_equal(esr_v3_length(n), 1.0f, 1e-5f);
            assert_true(esr_v3_dot(n, d) <= 1e-6f); /* entering from outside: normal faces the ray */
            assert_false(inside(p, esr_v3_add(x, esr_v3_scale(n, 1e-3f))));
            /* From inside, the exit is found (tmin past the entry). */
            float t_exit = esr_synth_prim_hit(p, o, d, t + 1e-4f, INFINITY);
            assert_false(isinf(t_exit));
            assert_true(esr_v3_dot(esr_synth_prim_normal(p, esr_v3_add(o, esr_v3_scale(d, t_exit))), d) >= -1e-6f);
        }
        assert_true(hits > 300);
    }
}

/* Area sampling: points lie on the surface with the analytic normal, and the fraction landing in
 * the upper half (z above the centre) matches that half's share of the area. */
static void test_area_sampling(void **state)
{
    (void)state;
    struct esr_rng rng = esr_rng_init(2, 0);
    for (int k = 0; k < 3; k++) {
        const struct esr_synth_prim *p = &prims[k];
        float zc = p->kind == ESR_SYNTH_SPHERE ? p->a.z : p->kind == ESR_SYNTH_BOX ? 0.5f * (p->a.z + p->b.z) : p->a.z + 0.5f * p->b.y;
        int upper = 0;
        const int n = 100000;
        for (int i = 0; i < n; i++) {
            struct esr_vec3 x, nor;
            sample_whole_surface(p, esr_rng_float(&rng), esr_rng_float(&rng), esr_rng_float(&rng), &x, &nor);
            assert_true(surface_distance(p, x) < 1e-5f);
            struct esr_vec3 expect = esr_synth_prim_normal(p, x);
            assert_true(esr_v3_dot(expect, nor) > 0.999f);
            upper += x.z > zc;
        }
        /* Every primitive here is mirror-symmetric in z about zc, so half the area is above. */
        assert_float_equal((double)upper / n, 0.5, 0.006);
    }
    /* Areas against closed forms. */
    assert_float_equal(esr_synth_prim_area(&prims[0]), 4 * M_PI * 0.16, 1e-5);
    assert_float_equal(esr_synth_prim_area(&prims[1]), 2 * (0.8 * 0.3 + 0.3 * 0.35 + 0.35 * 0.8), 1e-5);
    assert_float_equal(esr_synth_prim_area(&prims[2]), 2 * M_PI * 0.3 * 0.6 + 2 * M_PI * 0.09, 1e-5);
}

/* Test functions of a surface point y seen from x: a smooth function of position, and 1 - cos
 * at the surface, which weights the silhouette where a too narrow region would show. */
static void toward_functions(struct esr_vec3 x, struct esr_vec3 y, struct esr_vec3 ny, double f[2])
{
    struct esr_vec3 to = esr_v3_normalize(esr_v3_sub(x, y));
    f[0] = y.x * y.x + y.z;
    f[1] = 1.0 - esr_v3_dot(ny, to);
}

/* Sampling towards a shading point: only front-facing points on the surface; the sampled area
 * equals the front-facing share of the whole surface (estimated by whole-surface sampling), and
 * integrals of test functions over the sampled region (A * E[f]) match the same integrals by
 * whole-surface sampling restricted to the front-facing part (checks region and uniformity).
 * Points around each primitive: above, beside at mid-height, below, on a face plane. */
static void test_area_sampling_toward(void **state)
{
    (void)state;
    const struct esr_vec3 xs[] = {esr_v3(1.5f, 0.3f, 0.9f), esr_v3(0.1f, -0.2f, 0.75f), esr_v3(-0.6f, 0.4f, -0.5f),
                                  esr_v3(0.6f, 0.55f, 0.1f), esr_v3(-0.7f, -0.1f, 0.2f)};
    const int nx = (int)(sizeof xs / sizeof xs[0]);
    for (int k = 0; k < 3; k++) {
        for (int v = 0; v < nx; v++) {
            const struct esr_synth_prim *p = &prims[k];
            struct esr_vec3 x = xs[v];
            struct esr_rng rng = esr_rng_init(4, (uint64_t)(k * nx + v));
            const int n = 200000;
            double sum_toward[2] = {0, 0}, sum_full[2] = {0, 0}, f[2];
            long front_full = 0, off_normal = 0;
            for (int i = 0; i < n; i++) {
                struct esr_vec3 y, ny;
                float sampled = esr_synth_prim_sample_toward(p, x, esr_rng_float(&rng), esr_rng_float(&rng),
                                                             esr_rng_float(&rng), &y, &ny);
                assert_true(sampled == esr_synth_prim_area_toward(p, x));
                assert_true(esr_v3_dot(ny, esr_v3_sub(x, y)) >= -1e-5f);
                assert_true(surface_distance(p, y) < 1e-5f);
                /* a point exactly on an edge (u = 0 or 1) may be assigned the neighbouring face */
                off_normal += esr_v3_dot(esr_synth_prim_normal(p, y), ny) <= 0.999f;
                toward_functions(x, y, ny, f);
                sum_toward[0] += f[0];
                sum_toward[1] += f[1];
                sample_whole_surface(p, esr_rng_float(&rng), esr_rng_float(&rng), esr_rng_float(&rng), &y, &ny);
                if (esr_v3_dot(ny, esr_v3_sub(x, y)) > 0.0f) { /* grazing faces send no light */
                    toward_functions(x, y, ny, f);
                    sum_full[0] += f[0];
                    sum_full[1] += f[1];
                    front_full++;
                }
            }
            assert_true(off_normal <= 2);
            double area = esr_synth_prim_area_toward(p, x), whole = esr_synth_prim_area(p);
            assert_true(fabs(area - whole * (double)front_full / n) < 0.005 * whole);
            for (int j = 0; j < 2; j++) {
                double a = area * sum_toward[j] / n, b = whole * sum_full[j] / n;
                assert_true(fabs(a - b) < 0.01 * fabs(b) + 1e-3);
            }
        }
    }
}

static int cmp_u64(const void *x, const void *y)
{
    uint64_t a = *(const uint64_t *)x, b = *(const uint64_t *)y;
    return (a > b) - (a < b);
}

/* Every directed edge appears once and its reverse once (closed, consistently oriented), and the
 * signed volume of each scene matches the sum of its primitives' volumes (outward, right size). */
static void test_mesh_closed_and_outward(void **state)
{
    (void)state;
    for (int sc = 0; sc < esr_synth_scene_count(); sc++) {
        struct esr_synth_scene s;
        assert_int_equal(esr_synth_scene_get(esr_synth_scene_name(sc), &s), 0);
        struct esr_mesh m;
        assert_int_equal(esr_synth_scene_mesh(&s, 64, &m), 0);
        size_t ne = 3 * m.n_triangles;
        uint64_t *edges = malloc(ne * sizeof *edges), *rev = malloc(ne * sizeof *rev);
        double volume = 0.0;
        for (size_t t = 0; t < m.n_triangles; t++) {
            const uint32_t *v = m.tri + 3 * t;
            for (int e = 0; e < 3; e++) {
                uint32_t a = v[e], b = v[(e + 1) % 3];
                edges[3 * t + e] = (uint64_t)a << 32 | b;
                rev[3 * t + e] = (uint64_t)b << 32 | a;
            }
            const float *p0 = m.pos + 3 * v[0], *p1 = m.pos + 3 * v[1], *p2 = m.pos + 3 * v[2];
            volume += (p0[0] * ((double)p1[1] * p2[2] - (double)p1[2] * p2[1]) -
                       p0[1] * ((double)p1[0] * p2[2] - (double)p1[2] * p2[0]) +
                       p0[2] * ((double)p1[0] * p2[1] - (double)p1[1] * p2[0])) / 6.0;
        }
        qsort(edges, ne, sizeof *edges, cmp_u64);
        qsort(rev, ne, sizeof *rev, cmp_u64);
        for (size_t i = 0; i < ne; i++) {
            assert_true(i == 0 || edges[i] != edges[i - 1]); /* no directed edge twice */
            assert_true(edges[i] == rev[i]);                  /* each one's reverse exists */
        }
        double expect = 0.0;
        for (int i = 0; i < s.n_prims; i++) {
            const struct esr_synth_prim *p = &s.prims[i];
            if (p->kind == ESR_SYNTH_SPHERE)
                expect += 4.0 / 3.0 * M_PI * pow(p->b.x, 3);
            else if (p->kind == ESR_SYNTH_BOX)
                expect += (double)(p->b.x - p->a.x) * (p->b.y - p->a.y) * (p->b.z - p->a.z);
            else
                expect += M_PI * p->b.x * p->b.x * p->b.y;
        }
        assert_true(fabs(volume - expect) < 0.01 * expect); /* 64-gon facets lose ~0.3% */
        free(edges);
        free(rev);
        esr_mesh_free(&m);
    }
}

static void test_scenes_fit_the_box(void **state)
{
    (void)state;
    for (int sc = 0; sc < esr_synth_scene_count(); sc++) {
        struct esr_synth_scene s;
        assert_int_equal(esr_synth_scene_get(esr_synth_scene_name(sc), &s), 0);
        float lo[3], hi[3];
        esr_synth_scene_bounds(&s, lo, hi);
        for (int k = 0; k < 2; k++)
            assert_true(lo[k] >= -1.2f && hi[k] <= 1.2f);
        assert_true(lo[2] >= -0.1f && hi[2] <= 1.5f);
        /* one light is a scene too (FORMAT.md's L = 1 column: vivid, shaded) */
        assert_true(s.n_lights >= 1 && s.n_lights <= ESR_SYNTH_MAX_LIGHTS);
        for (int l = 0; l < s.n_lights; l++) /* V = max(rgb) = 1, as the edit rule assumes */
            assert_float_equal(fmaxf(s.lights[l].rgb[0], fmaxf(s.lights[l].rgb[1], s.lights[l].rgb[2])), 1.0f, 0.0f);
    }
    struct esr_synth_scene s;
    assert_int_equal(esr_synth_scene_get("nope", &s), -1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rays_against_march),
        cmocka_unit_test(test_area_sampling),
        cmocka_unit_test(test_area_sampling_toward),
        cmocka_unit_test(test_mesh_closed_and_outward),
        cmocka_unit_test(test_scenes_fit_the_box),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
