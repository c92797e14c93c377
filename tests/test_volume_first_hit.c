/* First-hit queries on SDF grids (volume/first_hit): analytic SDFs sampled on the lattice, hits
 * against analytic intersections and against a dense reference march of the same trilinear field,
 * non-metric scalings, thin plates and spikes that an unbounded or |f|-sized step would skip,
 * rays that start inside, normals, thread-count independence, bad input, and a timing line. */
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
#include "fields/grid.h"
#include "fields/trilerp.h"
#include "volume/first_hit.h"
#include "volume/ray.h"
#include "test_support.h"

#define RES 65 /* lattice points per axis on [-1, 1]^3: voxel 1/32 */
static const float BMIN[3] = {-1.0f, -1.0f, -1.0f};
static const float BMAX[3] = {1.0f, 1.0f, 1.0f};
static const float VOX = 2.0f / (RES - 1);

/* ---- analytic SDFs ---- */

struct shape {
    int kind;       /* 0 sphere, 1 box, 2 plane, 3 z-slab, 4 two spheres */
    float c[3];     /* centre (sphere, box, slab: c[2] is the slab's mid plane) */
    float r;        /* sphere radius, slab half thickness, plane offset */
    float half[3];  /* box half extents; plane normal */
    float c2[3], r2; /* second sphere */
    float scale;    /* multiplies the SDF (non-metric tests) */
};

static float len3(const float v[3]) { return sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }
static float dot3(const float a[3], const float b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
static void normalize3(float v[3])
{
    float l = len3(v);
    v[0] /= l;
    v[1] /= l;
    v[2] /= l;
}

static float shape_sdf(const struct shape *s, const float p[3])
{
    float q[3] = {p[0] - s->c[0], p[1] - s->c[1], p[2] - s->c[2]};
    float f = 0.0f;
    switch (s->kind) {
    case 0:
        f = len3(q) - s->r;
        break;
    case 1: {
        float e[3], out[3];
        for (int a = 0; a < 3; a++) {
            e[a] = fabsf(q[a]) - s->half[a];
            out[a] = fmaxf(e[a], 0.0f);
        }
        f = len3(out) + fminf(fmaxf(e[0], fmaxf(e[1], e[2])), 0.0f);
        break;
    }
    case 2:
        f = dot3(p, s->half) - s->r;
        break;
    case 3:
        f = fabsf(q[2]) - s->r;
        break;
    case 4: {
        float q2[3] = {p[0] - s->c2[0], p[1] - s->c2[1], p[2] - s->c2[2]};
        f = fminf(len3(q) - s->r, len3(q2) - s->r2);
        break;
    }
    }
    return f * s->scale;
}

static struct shape sphere(float cx, float cy, float cz, float r)
{
    struct shape s;
    memset(&s, 0, sizeof(s));
    s.kind = 0;
    s.c[0] = cx;
    s.c[1] = cy;
    s.c[2] = cz;
    s.r = r;
    s.scale = 1.0f;
    return s;
}

/* Two spheres centred in the plane z = 0: (ax, 0) radius ar and (bx, by) radius br. */
static struct shape two_spheres(float ax, float ar, float bx, float by, float br)
{
    struct shape s = sphere(ax, 0.0f, 0.0f, ar);
    s.kind = 4;
    s.c2[0] = bx;
    s.c2[1] = by;
    s.r2 = br;
    return s;
}

/* A 1-channel RES^3 grid on [-1, 1]^3 and its values (unset; the caller frees them). */
static float *alloc_grid(struct esr_grid *g)
{
    assert_int_equal(esr_grid_init(g, 1, RES, RES, RES, BMIN, BMAX), ESR_OK);
    float *v = (float *)malloc(esr_grid_count(g) * sizeof(float));
    assert_non_null(v);
    return v;
}

/* Fills a RES^3 grid on [-1, 1]^3 from the analytic SDF at the lattice points. */
static float *make_grid(struct esr_grid *g, const struct shape *s)
{
    float *v = alloc_grid(g);
    for (int iz = 0; iz < RES; iz++)
        for (int iy = 0; iy < RES; iy++)
            for (int ix = 0; ix < RES; ix++) {
                float p[3];
                esr_grid_voxel_pos(g, ix, iy, iz, p);
                v[((size_t)iz * RES + (size_t)iy) * RES + (size_t)ix] = shape_sdf(s, p);
            }
    return v;
}

/* The trilinear field as fields/trilerp.h evaluates it (independent of the marcher's probe). */
static float tri(const struct esr_grid *g, const float *v, const float p[3])
{
    struct esr_trilerp t;
    float f;
    esr_trilerp_locate(g, p, &t);
    esr_trilerp_fwd(v, 1, &t, &f);
    return f;
}

/* Dense reference march of the trilinear field at `step` (world) over [t_min, t_max] clipped to
 * the box: t of the first sample with f <= 0 (INFINITY if none), *t_prev the sample before it. */
static float ref_crossing(const struct esr_grid *g, const float *v, const float o[3], const float d[3],
                          float t_min, float t_max, float step, float *t_prev)
{
    float t0, t1;
    *t_prev = INFINITY;
    if (!esr_ray_box_clip(o, d, BMIN, BMAX, t_min, t_max, &t0, &t1))
        return INFINITY;
    float prev = t0;
    for (long k = 0;; k++) {
        float t = fminf(t0 + (float)k * step, t1);
        float p[3] = {o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]};
        if (tri(g, v, p) <= 0.0f) {
            *t_prev = prev;
            return t;
        }
        if (t >= t1)
            return INFINITY;
        prev = t;
    }
}

/* Analytic entry t of o + t d into the sphere (c, r); INFINITY if the line misses it. */
static float sphere_entry(const float c[3], float r, const float o[3], const float d[3])
{
    double oc[3] = {o[0] - c[0], o[1] - c[1], o[2] - c[2]};
    double b = oc[0] * d[0] + oc[1] * d[1] + oc[2] * d[2];
    double cc = oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - (double)r * r;
    double disc = b * b - cc;
    return disc < 0.0 ? INFINITY : (float)(-b - sqrt(disc));
}

struct batch {
    size_t n;
    float *o, *d, *tmin, *tmax;
    float *t, *pos, *nrm;
    uint8_t *flags;
};

static void batch_alloc(struct batch *b, size_t n)
{
    b->n = n;
    b->o = (float *)calloc(n * 3, sizeof(float));
    b->d = (float *)calloc(n * 3, sizeof(float));
    b->tmin = (float *)calloc(n, sizeof(float));
    b->tmax = (float *)malloc(n * sizeof(float));
    b->t = (float *)calloc(n, sizeof(float));
    b->pos = (float *)calloc(n * 3, sizeof(float));
    b->nrm = (float *)calloc(n * 3, sizeof(float));
    b->flags = (uint8_t *)calloc(n, 1);
    assert_true(b->o && b->d && b->tmin && b->tmax && b->t && b->pos && b->nrm && b->flags);
    for (size_t i = 0; i < n; i++)
        b->tmax[i] = 100.0f;
}

static void batch_free(struct batch *b)
{
    free(b->o);
    free(b->d);
    free(b->tmin);
    free(b->tmax);
    free(b->t);
    free(b->pos);
    free(b->nrm);
    free(b->flags);
}

static void batch_run(const struct esr_grid *g, const float *v, const struct esr_first_hit_params *p,
                      struct batch *b)
{
    struct esr_first_hit_rays rays = {b->o, b->d, b->tmin, b->tmax, b->n};
    struct esr_first_hit_out out = {b->t, b->flags, b->pos, b->nrm};
    assert_int_equal(esr_first_hit(g, v, p, &rays, &out), ESR_OK);
}

/* A ray starting `dist` from the sphere centre c, heading back parallel to the centre line at
 * impact parameter b_frac * r (its closest approach to c is b_frac * r). */
static void sphere_ray(struct esr_rng *rng, const float c[3], float r, float dist, float b_frac,
                       float o[3], float d[3])
{
    float u[3], w[3];
    do {
        for (int a = 0; a < 3; a++)
            u[a] = 2.0f * esr_rng_float(rng) - 1.0f;
    } while (len3(u) < 0.1f || len3(u) > 1.0f);
    normalize3(u);
    do {
        for (int a = 0; a < 3; a++)
            w[a] = 2.0f * esr_rng_float(rng) - 1.0f;
        float k = dot3(w, u);
        for (int a = 0; a < 3; a++)
            w[a] -= k * u[a];
    } while (len3(w) < 0.1f);
    normalize3(w);
    for (int a = 0; a < 3; a++) {
        o[a] = c[a] + dist * u[a] + b_frac * r * w[a];
        d[a] = -u[a];
    }
}

/* ---- tests ---- */

/* Sphere: hits match the analytic intersection within a small fraction of a voxel (the trilinear
 * surface differs from the sphere by O(voxel^2 / r)), lie on the trilinear zero set, and are the
 * first crossing the dense reference march finds. */
static void test_sphere_hits(void **state)
{
    (void)state;
    struct shape s = sphere(0.031f, -0.017f, 0.023f, 0.55f);
    struct esr_grid g;
    float *v = make_grid(&g, &s);
    struct esr_first_hit_params p;
    esr_first_hit_params_init(&p, &g);
    enum { R = 300 };
    struct batch b;
    batch_alloc(&b, R);
    struct esr_rng rng = esr_rng_init(7, 0);
    for (int i = 0; i < R; i++)
        sphere_ray(&rng, s.c, s.r, 2.5f, 0.85f * esr_rng_float(&rng), b.o + i * 3, b.d + i * 3);
    batch_run(&g, v, &p, &b);
    float max_err = 0.0f, max_f = 0.0f;
    for (int i = 0; i < R; i++) {
        const float *o = b.o + i * 3, *d = b.d + i * 3;
        assert_int_equal(b.flags[i], ESR_FIRST_HIT_HIT);
        float ta = sphere_entry(s.c, s.r, o, d);
        max_err = fmaxf(max_err, fabsf(b.t[i] - ta) / VOX);
        assert_true(fabsf(b.t[i] - ta) < 0.05f * VOX);
        for (int a = 0; a < 3; a++)
            assert_float_equal(b.pos[i * 3 + a], o[a] + b.t[i] * d[a], 1e-6);
        float f = tri(&g, v, b.pos + i * 3);
        max_f = fmaxf(max_f, fabsf(f) / VOX);
        assert_true(fabsf(f) < 1e-3f * VOX);
        float tp, tr = ref_crossing(&g, v, o, d, 0.0f, 100.0f, 0.005f * VOX, &tp);
        assert_true(b.t[i] >= tp - 1e-4f * VOX && b.t[i] <= tr + 1e-4f * VOX);
    }
    print_message("sphere: max |t - analytic| %.4f voxel, max |f(hit)| %.2e voxel\n",
                  (double)max_err, (double)max_f);
    batch_free(&b);
    free(v);
}

/* Axis-aligned box: near a face centre the box SDF is linear, so the trilinear surface is the
 * face itself and hits are exact up to rounding; the normal is the face normal. */
static void test_box_hits(void **state)
{
    (void)state;
    struct shape s;
    memset(&s, 0, sizeof(s));
    s.kind = 1;
    s.c[0] = 0.02f;
    s.c[1] = -0.04f;
    s.c[2] = 0.011f;
    s.half[0] = 0.4f;
    s.half[1] = 0.3f;
    s.half[2] = 0.5f;
    s.scale = 1.0f;
    struct esr_grid g;
    float *v = make_grid(&g, &s);
    struct esr_first_hit_params p;
    esr_first_hit_params_init(&p, &g);
    enum { R = 240 };
    struct batch b;
    batch_alloc(&b, R);
    int face[R];
    struct esr_rng rng = esr_rng_init(8, 0);
    for (int i = 0; i < R; i++) {
        int ax = i % 3, sg = (i / 3) % 2 ? 1 : -1;
        face[i] = ax * 2 + (sg > 0);
        /* a point on the face at least 3 voxels from its edges */
        float target[3];
        for (int a = 0; a < 3; a++)
            target[a] = s.c[a] + (a == ax ? sg * s.half[a]
                                          : (2.0f * esr_rng_float(&rng) - 1.0f) * (s.half[a] - 3.0f * VOX));
        /* from outside the face, up to ~60 degrees off its normal */
        float dir[3];
        for (int a = 0; a < 3; a++)
            dir[a] = a == ax ? -(float)sg : 1.6f * (esr_rng_float(&rng) - 0.5f);
        normalize3(dir);
        for (int a = 0; a < 3; a++) {
            b.d[i * 3 + a] = dir[a];
            b.o[i * 3 + a] = target[a] - 1.7f * dir[a];
        }
    }
    batch_run(&g, v, &p, &b);
    for (int i = 0; i < R; i++) {
        const float *o = b.o + i * 3, *d = b.d + i * 3;
        float lo[3], hi[3], t0 = 0.0f, t1 = 0.0f;
        for (int a = 0; a < 3; a++) {
            lo[a] = s.c[a] - s.half[a];
            hi[a] = s.c[a] + s.half[a];
        }
        assert_int_equal(esr_ray_box_clip(o, d, lo, hi, 0.0f, 100.0f, &t0, &t1), 1);
        assert_int_equal(b.flags[i], ESR_FIRST_HIT_HIT);
        assert_true(fabsf(b.t[i] - t0) < 1e-3f * VOX);
        int ax = face[i] / 2;
        float sg = face[i] % 2 ? 1.0f : -1.0f;
        for (int a = 0; a < 3; a++)
            assert_float_equal(b.nrm[i * 3 + a], a == ax ? sg : 0.0f, 1e-4);
    }
    batch_free(&b);
    free(v);
}

/* Oblique plane (linear, so trilinear is exact): every ray that crosses it inside the box hits at
 * the analytic t, rays moving away miss, rays starting behind it start inside. */
static void test_plane_hits_and_misses(void **state)
{
    (void)state;
    struct shape s;
    memset(&s, 0, sizeof(s));
    s.kind = 2;
    s.half[0] = 0.3f;
    s.half[1] = -0.5f;
    s.half[2] = 0.81f;
    normalize3(s.half);
    s.r = 0.1f;
    s.scale = 1.0f;
    struct esr_grid g;
    float *v = make_grid(&g, &s);
    struct esr_first_hit_params p;
    esr_first_hit_params_init(&p, &g);
    enum { R = 400 };
    struct batch b;
    batch_alloc(&b, R);
    struct esr_rng rng = esr_rng_init(9, 0);
    for (int i = 0; i < R; i++) {
        float dir[3];
        for (int a = 0; a < 3; a++) {
            b.o[i * 3 + a] = 1.8f * (esr_rng_float(&rng) - 0.5f);
            dir[a] = 2.0f * esr_rng_float(&rng) - 1.0f;
        }
        normalize3(dir);
        memcpy(b.d + i * 3, dir, sizeof(dir));
    }
    batch_run(&g, v, &p, &b);
    int n_hit = 0, n_miss = 0, n_in = 0;
    for (int i = 0; i < R; i++) {
        const float *o = b.o + i * 3, *d = b.d + i * 3;
        float f0 = shape_sdf(&s, o), dn = dot3(d, s.half);
        float t0 = 0.0f, t1 = 0.0f;
        assert_int_equal(esr_ray_box_clip(o, d, BMIN, BMAX, 0.0f, 100.0f, &t0, &t1), 1);
        if (f0 <= 0.0f) {
            assert_int_equal(b.flags[i], ESR_FIRST_HIT_HIT | ESR_FIRST_HIT_STARTED_INSIDE);
            assert_true(b.t[i] == 0.0f);
            n_in++;
            continue;
        }
        float ta = dn < 0.0f ? f0 / -dn : INFINITY;
        if (fabsf(ta - t1) < 0.01f * VOX)
            continue; /* crossing on the box boundary: either answer is right */
        if (ta < t1) {
            assert_int_equal(b.flags[i], ESR_FIRST_HIT_HIT);
            assert_true(fabsf(b.t[i] - ta) < 1e-3f * VOX);
            for (int a = 0; a < 3; a++)
                assert_float_equal(b.nrm[i * 3 + a], s.half[a], 1e-4);
            n_hit++;
        } else {
            assert_int_equal(b.flags[i], 0);
            assert_true(isinf(b.t[i]));
            for (int a = 0; a < 3; a++)
                assert_true(b.pos[i * 3 + a] == 0.0f && b.nrm[i * 3 + a] == 0.0f);
            n_miss++;
        }
    }
    assert_true(n_hit > 50 && n_miss > 50 && n_in > 50);
    batch_free(&b);
    free(v);
}

/* Misses: rays pointing away, rays passing 2 voxels beside the sphere, rays missing the box,
 * degenerate rays (zero direction, NaN origin, t_min > t_max), t_max before the surface. */
static void test_misses(void **state)
{
    (void)state;
    struct shape s = sphere(0.031f, -0.017f, 0.023f, 0.55f);
    struct esr_grid g;
    float *v = make_grid(&g, &s);
    struct esr_first_hit_params p;
    esr_first_hit_params_init(&p, &g);
    enum { R = 200 };
    struct batch b;
    batch_alloc(&b, R);
    struct esr_rng rng = esr_rng_init(10, 0);
    for (int i = 0; i < R; i++) {
        float *o = b.o + i * 3, *d = b.d + i * 3;
        if (i < 80) { /* away: aim at the sphere, then turn around */
            sphere_ray(&rng, s.c, s.r, 0.8f, 0.5f, o, d);
            for (int a = 0; a < 3; a++)
                d[a] = -d[a];
        } else if (i < 160) { /* beside: impact parameter r + 2 voxels, closest point in the box */
            sphere_ray(&rng, s.c, s.r, 0.9f, 1.0f + 2.0f * VOX / s.r, o, d);
        } else if (i < 170) { /* box missed entirely */
            o[0] = 3.0f;
            o[1] = 3.0f;
            o[2] = 0.0f;
            d[0] = (i % 2) ? 1.0f : 0.0f;
            d[1] = (i % 2) ? 0.0f : -1.0f;
        } else if (i < 180) { /* zero direction */
            o[0] = 0.9f;
        } else if (i < 190) { /* NaN origin */
            o[0] = NAN;
            d[2] = -1.0f;
        } else { /* t_min > t_max, and t_max before the surface */
            sphere_ray(&rng, s.c, s.r, 2.0f, 0.3f, o, d);
            float ta = sphere_entry(s.c, s.r, o, d);
            if (i < 195) {
                b.tmin[i] = 1.0f;
                b.tmax[i] = 0.5f;
            } else {
                b.tmax[i] = ta - 1.0f * VOX;
            }
        }
    }
    batch_run(&g, v, &p, &b);
    for (int i = 0; i < R; i++) {
        assert_int_equal(b.flags[i], 0);
        assert_true(isinf(b.t[i]) && b.t[i] > 0.0f);
        for (int a = 0; a < 3; a++)
            assert_true(b.pos[i * 3 + a] == 0.0f && b.nrm[i * 3 + a] == 0.0f);
    }
    /* the same cut-off rays hit once t_max reaches one voxel past the surface */
    for (int i = 195; i < R; i++)
        b.tmax[i] += 2.0f * VOX;
    batch_run(&g, v, &p, &b);
    for (int i = 195; i < R; i++)
        assert_int_equal(b.flags[i], ESR_FIRST_HIT_HIT);
    batch_free(&b);
    free(v);
}

/* Grazing rays with impact parameters swept across r +- 1 voxel in 0.01-voxel steps: every answer
 * is a clean miss or a hit on the trilinear zero set, and agrees with the dense reference march. */
static void test_grazing(void **state)
{
    (void)state;
    struct shape s = sphere(0.031f, -0.017f, 0.023f, 0.55f);
    struct esr_grid g;
    float *v = make_grid(&g, &s);
    struct esr_first_hit_params p;
    esr_first_hit_params_init(&p, &g);
    enum { K = 201, DIRS = 3 };
    struct batch b;
    batch_alloc(&b, K * DIRS);
    struct esr_rng rng = esr_rng_init(11, 0);
    for (int j = 0; j < DIRS; j++)
        for (int k = 0; k < K; k++) {
            struct esr_rng r2 = rng; /* the same direction for every offset of this j */
            float off = (float)(k - K / 2) * 0.01f * VOX;
            sphere_ray(&r2, s.c, s.r, 1.2f, 1.0f + off / s.r, b.o + (j * K + k) * 3,
                       b.d + (j * K + k) * 3);
            if (k == K - 1)
                rng = r2;
        }
    batch_run(&g, v, &p, &b);
    int hits = 0, misses = 0;
    for (size_t i = 0; i < b.n; i++) {
        const float *o = b.o + i * 3, *d = b.d + i * 3;
        assert_true(b.flags[i] == 0 || b.flags[i] == ESR_FIRST_HIT_HIT);
        float tp, tr = ref_crossing(&g, v, o, d, 0.0f, 100.0f, 0.005f * VOX, &tp);
        if (b.flags[i] == 0) {
            assert_true(isinf(tr));
            misses++;
            continue;
        }
        hits++;
        assert_true(isfinite(b.t[i]));
        for (int a = 0; a < 3; a++)
            assert_true(isfinite(b.pos[i * 3 + a]) && isfinite(b.nrm[i * 3 + a]));
        assert_true(fabsf(tri(&g, v, b.pos + i * 3)) < 1e-3f * VOX);
        /* a hit the reference's 0.005-voxel samples step over can only be a sliver */
        if (isfinite(tr))
            assert_true(b.t[i] >= tp - 1e-4f * VOX && b.t[i] <= tr + 1e-4f * VOX);
    }
    print_message("grazing: %d hits, %d misses over r +- 1 voxel\n", hits, misses);
    assert_true(hits > 150 && misses > 150);
    batch_free(&b);
    free(v);
}

/* Rays starting inside or on the surface: REPORT gives a hit at t_min flagged inside; SKIP marches
 * out and finds the next entry (or misses); shadow rays from offset surface points do not hit
 * their own (convex) surface. */
static void test_inside_and_shadow_rays(void **state)
{
    (void)state;
    const struct shape s = two_spheres(-0.45f, 0.3f, 0.45f, 0.0f, 0.3f);
    struct esr_grid g;
    float *v = make_grid(&g, &s);
    struct esr_first_hit_params p;
    esr_first_hit_params_init(&p, &g);
    struct batch b;
    batch_alloc(&b, 3);
    /* 0: from A's centre towards B; 1: from A's centre away from B; 2: as 0 with t_min 0.1 */
    const float ox = -0.45f, dx[3] = {1.0f, -1.0f, 1.0f};
    for (int i = 0; i < 3; i++) {
        b.o[i * 3] = ox;
        b.d[i * 3] = dx[i];
    }
    b.tmin[2] = 0.1f;
    batch_run(&g, v, &p, &b);
    for (int i = 0; i < 3; i++) {
        assert_int_equal(b.flags[i], ESR_FIRST_HIT_HIT | ESR_FIRST_HIT_STARTED_INSIDE);
        assert_true(b.t[i] == b.tmin[i]);
        assert_float_equal(b.pos[i * 3], ox + b.tmin[i] * dx[i], 1e-6);
    }
    p.inside = ESR_FIRST_HIT_INSIDE_SKIP;
    batch_run(&g, v, &p, &b);
    assert_int_equal(b.flags[1], ESR_FIRST_HIT_STARTED_INSIDE);
    assert_true(isinf(b.t[1]));
    for (int i = 0; i < 3; i += 2) {
        /* out of A, then into B at x = 0.15 (on the lattice line y = z = 0 the field is linear
         * in x there, so the trilinear surface is exact) */
        assert_int_equal(b.flags[i], ESR_FIRST_HIT_HIT | ESR_FIRST_HIT_STARTED_INSIDE);
        assert_true(fabsf(b.pos[i * 3] - 0.15f) < 1e-3f * VOX);
        assert_true(b.nrm[i * 3] < -0.99f); /* one-sided y/z differences on the lattice line */
    }
    batch_free(&b);

    /* shadow rays: primary hits on sphere A, origins offset half a voxel along the normal */
    p.inside = ESR_FIRST_HIT_INSIDE_REPORT;
    enum { P = 40, D = 32 };
    struct batch prim, sh;
    batch_alloc(&prim, P);
    batch_alloc(&sh, P * D);
    struct esr_rng rng = esr_rng_init(12, 0);
    for (int i = 0; i < P; i++)
        sphere_ray(&rng, s.c, s.r, 0.5f, 0.9f * esr_rng_float(&rng), prim.o + i * 3, prim.d + i * 3);
    batch_run(&g, v, &p, &prim);
    for (int i = 0; i < P; i++) {
        assert_int_equal(prim.flags[i], ESR_FIRST_HIT_HIT);
        float q[3] = {prim.pos[i * 3] - s.c[0], prim.pos[i * 3 + 1], prim.pos[i * 3 + 2]};
        assert_true(fabsf(len3(q) - s.r) < 0.05f * VOX); /* on A */
        const float *n = prim.nrm + i * 3;
        for (int j = 0; j < D; j++) {
            float *o = sh.o + (i * D + j) * 3, *d = sh.d + (i * D + j) * 3;
            for (int a = 0; a < 3; a++) {
                o[a] = prim.pos[i * 3 + a] + 0.5f * VOX * n[a];
                d[a] = 2.0f * esr_rng_float(&rng) - 1.0f;
            }
            normalize3(d);
            float c = dot3(d, n);
            if (j % 2 == 0 && c < 0.1f) /* even: leaving the surface (>= ~6 degrees) */
                for (int a = 0; a < 3; a++)
                    d[a] += (0.2f - c) * n[a];
            else if (j % 2 == 1 && c > -0.5f) /* odd: into the surface */
                for (int a = 0; a < 3; a++)
                    d[a] -= (0.6f + c) * n[a];
            normalize3(d);
        }
    }
    batch_run(&g, v, &p, &sh);
    for (int i = 0; i < P * D; i++) {
        const float *o = sh.o + i * 3, *d = sh.d + i * 3;
        /* even rays may still reach sphere B: compare with the analytic answer */
        float tb = sphere_entry(s.c2, s.r2, o, d);
        if (i % 2 == 0 && (isinf(tb) || tb < 0.0f)) {
            assert_int_equal(sh.flags[i], 0);
        } else if (i % 2 == 1) {
            assert_int_equal(sh.flags[i], ESR_FIRST_HIT_HIT);
            assert_true(sh.t[i] < 2.5f * VOX); /* within 0.5 voxel / cos 60 degrees, plus slack */
        }
    }
    batch_free(&prim);
    batch_free(&sh);
    free(v);
}

/* Distance from point c to the segment [a, b]. */
static float segment_distance(const float c[3], const float a[3], const float b[3])
{
    float ab[3], ac[3];
    for (int k = 0; k < 3; k++)
        ab[k] = b[k] - a[k], ac[k] = c[k] - a[k];
    float t = dot3(ac, ab) / dot3(ab, ab);
    t = t < 0.0f ? 0.0f : (t > 1.0f ? 1.0f : t);
    float q[3];
    for (int k = 0; k < 3; k++)
        q[k] = a[k] + t * ab[k] - c[k];
    return len3(q);
}

/* Shadow segments (esr_first_hit_segment_blocked, marched from b back to a): blocked exactly when
 * the segment passes through one of two spheres, by the analytic distance from the centres (a
 * margin of half a voxel either side of the radius is left undecided), the same answer both ways
 * round and as a forward march from a; an end inside a sphere is blocked. */
static void test_segment_blocked(void **state)
{
    (void)state;
    const struct shape s = two_spheres(-0.4f, 0.3f, 0.4f, 0.2f, 0.25f);
    struct esr_grid g;
    float *v = make_grid(&g, &s);
    struct esr_first_hit_params p;
    struct esr_first_hit_grid fg;
    assert_int_equal(esr_first_hit_shadow_setup(&fg, &p, &g, v), ESR_OK);
    struct esr_rng rng = esr_rng_init(31, 0);
    int blocked = 0, clear = 0;
    for (int i = 0; i < 4000; i++) {
        float a[3], b[3];
        for (int k = 0; k < 3; k++)
            a[k] = 1.8f * esr_rng_float(&rng) - 0.9f, b[k] = 1.8f * esr_rng_float(&rng) - 0.9f;
        const float da = fminf(len3((float[3]){a[0] - s.c[0], a[1], a[2]}) - s.r,
                               len3((float[3]){a[0] - s.c2[0], a[1] - s.c2[1], a[2]}) - s.r2);
        const float db = fminf(len3((float[3]){b[0] - s.c[0], b[1], b[2]}) - s.r,
                               len3((float[3]){b[0] - s.c2[0], b[1] - s.c2[1], b[2]}) - s.r2);
        const int got = esr_first_hit_segment_blocked(&fg, &p, a, b);
        if (da < -VOX || db < -VOX) { /* an end inside */
            assert_true(got);
            continue;
        }
        if (da < VOX || db < VOX)
            continue;
        const float m = fminf(segment_distance(s.c, a, b) - s.r, segment_distance(s.c2, a, b) - s.r2);
        if (fabsf(m) < 0.5f * VOX)
            continue;
        assert_int_equal(got, m < 0.0f);
        assert_int_equal(esr_first_hit_segment_blocked(&fg, &p, b, a), got);
        const float d[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        float t;
        assert_int_equal((esr_first_hit_ray(&fg, &p, a, d, 0.0f, 1.0f, &t) & ESR_FIRST_HIT_HIT) != 0,
                         got);
        blocked += got;
        clear += !got;
    }
    print_message("segments: %d blocked, %d clear\n", blocked, clear);
    assert_true(blocked > 300 && clear > 300); /* both outcomes well exercised */
    esr_first_hit_grid_free(&fg);
    free(v);
}

/* Rays starting exactly on the zero set (a plane through a lattice plane) start inside. */
static void test_on_surface(void **state)
{
    (void)state;
    struct shape s;
    memset(&s, 0, sizeof(s));
    s.kind = 2;
    s.half[2] = 1.0f;
    s.r = 0.25f; /* z = 0.25 is lattice plane 40 */
    s.scale = 1.0f;
    struct esr_grid g;
    float *v = make_grid(&g, &s);
    struct esr_first_hit_params p;
    esr_first_hit_params_init(&p, &g);
    struct batch b;
    batch_alloc(&b, 3);
    const float dz[3] = {1.0f, -1.0f, 0.0f};
    for (int i = 0; i < 3; i++) {
        b.o[i * 3 + 0] = 0.1f;
        b.o[i * 3 + 2] = 0.25f;
        b.d[i * 3 + 2] = dz[i];
        b.d[i * 3 + 0] = i == 2 ? 1.0f : 0.0f;
    }
    batch_run(&g, v, &p, &b);
    for (int i = 0; i < 3; i++) {
        assert_int_equal(b.flags[i], ESR_FIRST_HIT_HIT | ESR_FIRST_HIT_STARTED_INSIDE);
        assert_true(b.t[i] == 0.0f);
        assert_float_equal(b.nrm[i * 3 + 2], 1.0f, 1e-6);
    }
    p.inside = ESR_FIRST_HIT_INSIDE_SKIP;
    batch_run(&g, v, &p, &b);
    for (int i = 0; i < 3; i++) {
        assert_int_equal(b.flags[i], ESR_FIRST_HIT_STARTED_INSIDE);
        assert_true(isinf(b.t[i]));
    }
    batch_free(&b);
    free(v);
}

/* The sphere SDF times 5 and times 0.2 (no longer a distance) gives the same hits, and so does
 * a 100x scaling under a coarse min_step (an |f|-sized step would overshoot or crawl). */
static void test_non_metric_scaling(void **state)
{
    (void)state;
    struct shape s = sphere(0.031f, -0.017f, 0.023f, 0.55f);
    struct esr_grid g;
    float *v1 = make_grid(&g, &s);
    s.scale = 5.0f;
    float *v5 = make_grid(&g, &s);
    s.scale = 0.2f;
    float *v02 = make_grid(&g, &s);
    struct esr_first_hit_params p;
    esr_first_hit_params_init(&p, &g);
    enum { R = 300 };
    struct batch b1, b5, b02;
    batch_alloc(&b1, R);
    batch_alloc(&b5, R);
    batch_alloc(&b02, R);
    struct esr_rng rng = esr_rng_init(13, 0);
    for (int i = 0; i < R; i++)
        sphere_ray(&rng, s.c, s.r, 2.0f, 1.05f * esr_rng_float(&rng), b1.o + i * 3, b1.d + i * 3);
    memcpy(b5.o, b1.o, R * 3 * sizeof(float));
    memcpy(b5.d, b1.d, R * 3 * sizeof(float));
    memcpy(b02.o, b1.o, R * 3 * sizeof(float));
    memcpy(b02.d, b1.d, R * 3 * sizeof(float));
    batch_run(&g, v1, &p, &b1);
    batch_run(&g, v5, &p, &b5);
    batch_run(&g, v02, &p, &b02);
    /* cell-local bounds only: the same hits again */
    struct batch bl;
    batch_alloc(&bl, R);
    memcpy(bl.o, b1.o, R * 3 * sizeof(float));
    memcpy(bl.d, b1.d, R * 3 * sizeof(float));
    p.global_bound = 0;
    batch_run(&g, v5, &p, &bl);
    int hits = 0;
    for (int i = 0; i < R; i++) {
        assert_int_equal(b1.flags[i], bl.flags[i]);
        if (b1.flags[i])
            assert_true(fabsf(b1.t[i] - bl.t[i]) < 1e-3f * VOX);
        assert_int_equal(b1.flags[i], b5.flags[i]);
        assert_int_equal(b1.flags[i], b02.flags[i]);
        if (!b1.flags[i])
            continue;
        hits++;
        assert_true(fabsf(b1.t[i] - b5.t[i]) < 1e-3f * VOX);
        assert_true(fabsf(b1.t[i] - b02.t[i]) < 1e-3f * VOX);
        float ta = sphere_entry(s.c, s.r, b1.o + i * 3, b1.d + i * 3);
        float b_imp = 0.0f; /* impact parameter, to skip near-tangent rays */
        {
            const float *o = b1.o + i * 3, *d = b1.d + i * 3;
            float oc[3] = {s.c[0] - o[0], s.c[1] - o[1], s.c[2] - o[2]};
            float tc = dot3(oc, d);
            float q[3] = {oc[0] - tc * d[0], oc[1] - tc * d[1], oc[2] - tc * d[2]};
            b_imp = len3(q);
        }
        if (b_imp < 0.9f * s.r)
            assert_true(fabsf(b5.t[i] - ta) < 0.05f * VOX);
    }
    assert_true(hits > 200);
    batch_free(&bl);
    batch_free(&b1);
    batch_free(&b5);
    batch_free(&b02);
    free(v1);
    free(v5);
    free(v02);
}

/* A slab 0.3 voxels thick centred on a lattice plane (so its trilinear zero set is exactly
 * |z - z0| = 0.15 voxel), for SDF scales 1, 5, 0.2 and 50, rays from above and below at 0-80
 * degrees and 37 sub-voxel phases: none may step over it. */
static void test_thin_plate(void **state)
{
    (void)state;
    struct shape s;
    memset(&s, 0, sizeof(s));
    s.kind = 3;
    s.c[2] = -1.0f + 37.0f * VOX;
    s.r = 0.15f * VOX;
    const float scales[4] = {1.0f, 5.0f, 0.2f, 50.0f};
    const float angles[4] = {0.0f, 30.0f, 60.0f, 80.0f};
    enum { PH = 37 };
    struct batch b;
    batch_alloc(&b, 2 * 4 * PH);
    for (int side = 0; side < 2; side++)
        for (int k = 0; k < 4; k++)
            for (int ph = 0; ph < PH; ph++) {
                int i = (side * 4 + k) * PH + ph;
                float th = angles[k] * 3.14159265f / 180.0f, az = 0.37f * (float)ph;
                float sg = side ? 1.0f : -1.0f; /* side 0 from above, moving down */
                float *o = b.o + i * 3, *d = b.d + i * 3;
                d[0] = sinf(th) * cosf(az);
                d[1] = sinf(th) * sinf(az);
                d[2] = sg * cosf(th);
                /* start (4 + ph/PH) voxels from the mid plane along z, near x = y = 0 */
                float dz = (4.0f + (float)ph / PH) * VOX;
                o[2] = s.c[2] - sg * dz;
                o[0] = -d[0] / fabsf(d[2]) * dz + 0.001f * ph;
                o[1] = -d[1] / fabsf(d[2]) * dz;
            }
    for (int sc = 0; sc < 4; sc++) {
        s.scale = scales[sc];
        struct esr_grid g;
        float *v = make_grid(&g, &s);
        struct esr_first_hit_params p;
        esr_first_hit_params_init(&p, &g);
        for (p.global_bound = 0; p.global_bound < 2; p.global_bound++) {
            batch_run(&g, v, &p, &b);
            for (size_t i = 0; i < b.n; i++) {
                const float *o = b.o + i * 3, *d = b.d + i * 3;
                float face = s.c[2] + (d[2] < 0.0f ? s.r : -s.r);
                float ta = (face - o[2]) / d[2];
                if (b.flags[i] != ESR_FIRST_HIT_HIT)
                    fail_msg("scale %g global bound %d ray %zu (dir z %g): flags %d, plate "
                             "stepped over", (double)scales[sc], p.global_bound, i, (double)d[2],
                             b.flags[i]);
                assert_true(fabsf(b.t[i] - ta) < 1e-3f * VOX);
            }
        }
        free(v);
    }
    batch_free(&b);
}

/* Far field +1 (32 voxels: wildly non-metric) with one lattice point at -0.1: the negative
 * blob around it is ~0.18 voxel across. Rays through that point from any direction must hit it. */
static void test_spike(void **state)
{
    (void)state;
    struct esr_grid g;
    float *v = alloc_grid(&g);
    for (size_t i = 0; i < esr_grid_count(&g); i++)
        v[i] = 1.0f;
    const int ix = 30, iy = 33, iz = 29;
    v[((size_t)iz * RES + iy) * RES + ix] = -0.1f;
    float P[3];
    esr_grid_voxel_pos(&g, ix, iy, iz, P);
    struct esr_first_hit_params p;
    esr_first_hit_params_init(&p, &g);
    enum { R = 200 };
    struct batch b;
    batch_alloc(&b, R);
    struct esr_rng rng = esr_rng_init(14, 0);
    for (int i = 0; i < R; i++) {
        float *o = b.o + i * 3, *d = b.d + i * 3;
        do {
            for (int a = 0; a < 3; a++)
                d[a] = 2.0f * esr_rng_float(&rng) - 1.0f;
        } while (len3(d) < 0.1f || len3(d) > 1.0f);
        normalize3(d);
        float dist = 0.3f + 0.01f * (float)i; /* many phases relative to the lattice */
        for (int a = 0; a < 3; a++)
            o[a] = P[a] - dist * d[a];
    }
    for (p.global_bound = 0; p.global_bound < 2; p.global_bound++) {
        batch_run(&g, v, &p, &b);
        for (int i = 0; i < R; i++) {
            float dist = 0.3f + 0.01f * (float)i;
            assert_int_equal(b.flags[i], ESR_FIRST_HIT_HIT);
            assert_true(b.t[i] <= dist && b.t[i] > dist - 0.1f * VOX);
            assert_true(fabsf(tri(&g, v, b.pos + i * 3)) < 2e-3f); /* |grad| ~ 1.1 per voxel */
        }
    }
    batch_free(&b);
    free(v);
}

/* Fills v (RES^3 on [-1, 1]^3) with three spheres' SDF scaled by a bumpy factor in [0.2, 1.8]:
 * non-metric and steep in places, so G allows only short strides. */
static void bumpy_spheres(const struct esr_grid *g, float *v)
{
    const float c[3][3] = {{-0.45f, -0.3f, 0.1f}, {0.4f, 0.35f, -0.2f}, {0.1f, 0.2f, 0.55f}};
    const float r[3] = {0.4f, 0.3f, 0.25f};
    for (int iz = 0; iz < RES; iz++)
        for (int iy = 0; iy < RES; iy++)
            for (int ix = 0; ix < RES; ix++) {
                float q[3];
                esr_grid_voxel_pos(g, ix, iy, iz, q);
                float f = INFINITY;
                for (int k = 0; k < 3; k++)
                    f = fminf(f, len3((float[3]){q[0] - c[k][0], q[1] - c[k][1], q[2] - c[k][2]}) - r[k]);
                v[((size_t)iz * RES + iy) * RES + ix] =
                    f * (1.0f + 0.8f * sinf(9.0f * q[0]) * sinf(7.0f * q[1] + 2.0f * q[2]));
            }
}

/* A ray from a random point of the box's inner 95% in a random direction; 0 when the drawn
 * direction is too short to normalise (the ray is dropped). */
static int random_box_ray(struct esr_rng *rng, float o[3], float d[3])
{
    for (int a = 0; a < 3; a++)
        o[a] = 1.9f * esr_rng_float(rng) - 0.95f, d[a] = 2.0f * esr_rng_float(rng) - 1.0f;
    if (len3(d) < 0.1f)
        return 0;
    normalize3(d);
    return 1;
}

/* The grid of v prepared with its blocks' minima (with), and the same without them. */
static void prepare_with_without(const struct esr_grid *g, const float *v,
                                 struct esr_first_hit_grid *with, struct esr_first_hit_grid *without)
{
    assert_int_equal(esr_first_hit_grid_prepare(with, g, v, 1), ESR_OK);
    assert_non_null(with->block_min);
    *without = *with;
    without->block_min = NULL;
}

/* Block skipping (esr_first_hit_block_skip) finds the hits the march without it finds (random
 * rays through bumpy spheres, then with NaNs among the values), and it is what lets rays cross
 * empty space in a probe per block:
 * through a field positive everywhere with one steep lattice point (G large, so only the cells'
 * own bounds stride, at most a cell each), 26 probes (the 8 + 8 + 8 blocks a ray can cross, and
 * the ends) take every ray to the box's end with blocks; without them most run out. */
static void test_block_skip_same_hits(void **state)
{
    (void)state;
    struct esr_grid g;
    float *v = alloc_grid(&g);
    bumpy_spheres(&g, v);
    struct esr_first_hit_params p;
    esr_first_hit_params_init(&p, &g);
    struct esr_first_hit_grid with, without;
    prepare_with_without(&g, v, &with, &without);
    struct esr_rng rng = esr_rng_init(23, 0);
    int hits = 0, misses = 0;
    for (int i = 0; i < 6000; i++) {
        if (i == 3000) { /* NaNs in empty space and on a surface: the same hits either way */
            esr_first_hit_grid_free(&with);
            for (int k = 0; k < 40; k++)
                v[(size_t)(esr_rng_float(&rng) * (float)esr_grid_count(&g))] = NAN;
            v[((size_t)32 * RES + 22) * RES + 18] = NAN; /* next to the first sphere's surface */
            prepare_with_without(&g, v, &with, &without);
        }
        float o[3], d[3];
        if (!random_box_ray(&rng, o, d))
            continue;
        float t1, t2;
        const unsigned f1 = esr_first_hit_ray(&with, &p, o, d, 0.0f, INFINITY, &t1);
        const unsigned f2 = esr_first_hit_ray(&without, &p, o, d, 0.0f, INFINITY, &t2);
        assert_int_equal(f1, f2);
        if (f1 & ESR_FIRST_HIT_HIT)
            assert_true(fabsf(t1 - t2) < 1e-3f * VOX);
        hits += (f1 & ESR_FIRST_HIT_HIT) != 0;
        misses += f1 == 0;
    }
    esr_first_hit_grid_free(&with);

    for (size_t i = 0; i < esr_grid_count(&g); i++) /* empty, with a steep spot */
        v[i] = 0.3f + 0.1f * sinf(0.37f * (float)i);
    v[((size_t)40 * RES + 20) * RES + 50] = 50.0f;
    prepare_with_without(&g, v, &with, &without);
    struct esr_first_hit_params few = p;
    few.max_steps = 3 * 8 + 2;
    int through = 0, ran_out = 0, rays = 0;
    for (int i = 0; i < 2000; i++) {
        float o[3], d[3], t;
        if (!random_box_ray(&rng, o, d))
            continue;
        rays++;
        through += esr_first_hit_ray(&with, &few, o, d, 0.0f, INFINITY, &t) == 0;
        ran_out += esr_first_hit_ray(&without, &few, o, d, 0.0f, INFINITY, &t) ==
                   ESR_FIRST_HIT_OUT_OF_STEPS;
    }
    print_message("block skip: %d hits and %d misses as without; through empty space in %d probes: "
                  "%d of %d rays with blocks, %d run out without\n", hits, misses, few.max_steps,
                  through, rays, ran_out);
    assert_true(hits > 500 && misses > 300);
    assert_int_equal(through, rays);
    assert_true(ran_out > rays / 2);
    esr_first_hit_grid_free(&with);
    free(v);
}

/* Normals: the normalised trilinear gradient at the hit, as esr_grid_sample_value_dpoint gives it,
 * and close to the sphere's analytic normal. */
static void test_normals(void **state)
{
    (void)state;
    struct shape s = sphere(0.031f, -0.017f, 0.023f, 0.55f);
    struct esr_grid g;
    float *v = make_grid(&g, &s);
    struct esr_first_hit_params p;
    esr_first_hit_params_init(&p, &g);
    enum { R = 300 };
    struct batch b;
    batch_alloc(&b, R);
    struct esr_rng rng = esr_rng_init(15, 0);
    for (int i = 0; i < R; i++)
        sphere_ray(&rng, s.c, s.r, 2.5f, 0.95f * esr_rng_float(&rng), b.o + i * 3, b.d + i * 3);
    batch_run(&g, v, &p, &b);
    float val[R], grad[R * 3];
    esr_grid_sample_value_dpoint(&g, v, b.pos, R, val, grad);
    float max_deg = 0.0f;
    for (int i = 0; i < R; i++) {
        assert_int_equal(b.flags[i], ESR_FIRST_HIT_HIT);
        float *gr = grad + i * 3, an[3];
        normalize3(gr);
        for (int a = 0; a < 3; a++) {
            assert_float_equal(b.nrm[i * 3 + a], gr[a], 1e-6);
            an[a] = b.pos[i * 3 + a] - s.c[a];
        }
        normalize3(an);
        float c = fminf(dot3(an, b.nrm + i * 3), 1.0f);
        max_deg = fmaxf(max_deg, acosf(c) * 57.29578f);
    }
    /* the trilinear gradient is a one-sided difference across the cell, off by up to about
     * voxel / (2 r) radians per axis (r = 17.6 voxels here: ~1.6 degrees) */
    print_message("normals: max angle to the analytic sphere normal %.3f degrees\n", (double)max_deg);
    assert_true(max_deg < 3.0f);
    batch_free(&b);
    free(v);
}

/* Same bits for 1 and 2 threads; NULL outputs allowed; the per-ray function agrees with the batch. */
static void test_threads_null_outputs_scalar(void **state)
{
    (void)state;
    struct shape s = sphere(0.031f, -0.017f, 0.023f, 0.55f);
    struct esr_grid g;
    float *v = make_grid(&g, &s);
    struct esr_first_hit_params p;
    esr_first_hit_params_init(&p, &g);
    enum { R = 2000 };
    struct batch a, b;
    batch_alloc(&a, R);
    batch_alloc(&b, R);
    struct esr_rng rng = esr_rng_init(16, 0);
    for (int i = 0; i < R; i++)
        sphere_ray(&rng, s.c, s.r, 1.5f, 1.2f * esr_rng_float(&rng), a.o + i * 3, a.d + i * 3);
    memcpy(b.o, a.o, R * 3 * sizeof(float));
    memcpy(b.d, a.d, R * 3 * sizeof(float));
    int saved = omp_get_max_threads();
    omp_set_num_threads(1);
    batch_run(&g, v, &p, &a);
    omp_set_num_threads(2);
    batch_run(&g, v, &p, &b);
    omp_set_num_threads(saved);
    assert_memory_equal(a.t, b.t, R * sizeof(float));
    assert_memory_equal(a.flags, b.flags, R);
    assert_memory_equal(a.pos, b.pos, R * 3 * sizeof(float));
    assert_memory_equal(a.nrm, b.nrm, R * 3 * sizeof(float));
    /* only t requested, no t_min / t_max arrays */
    float *t = (float *)malloc(R * sizeof(float));
    assert_non_null(t);
    struct esr_first_hit_rays rays = {a.o, a.d, NULL, NULL, R};
    struct esr_first_hit_out out = {t, NULL, NULL, NULL};
    assert_int_equal(esr_first_hit(&g, v, &p, &rays, &out), ESR_OK);
    assert_memory_equal(a.t, t, R * sizeof(float));
    struct esr_first_hit_grid fg;
    assert_int_equal(esr_first_hit_grid_prepare(&fg, &g, v, 1), ESR_OK);
    for (int i = 0; i < R; i++) {
        float ts;
        unsigned f = esr_first_hit_ray(&fg, &p, a.o + i * 3, a.d + i * 3, 0.0f, INFINITY, &ts);
        /* the batch may run an FMA clone (ESR_HOT), so equal up to rounding, not bitwise */
        assert_int_equal(f, a.flags[i]);
        assert_true(ts == a.t[i] || fabsf(ts - a.t[i]) < 1e-4f * VOX);
    }
    esr_first_hit_grid_free(&fg);
    free(t);
    batch_free(&a);
    batch_free(&b);
    free(v);
}

static void test_bad_arguments(void **state)
{
    (void)state;
    struct esr_grid g3;
    assert_int_equal(esr_grid_init(&g3, 3, 4, 4, 4, BMIN, BMAX), ESR_OK);
    struct esr_first_hit_params p;
    esr_first_hit_params_init(&p, &g3);
    float o[3] = {0, 0, 0}, d[3] = {1, 0, 0}, vals[4 * 4 * 4 * 3] = {0}, t;
    struct esr_first_hit_rays rays = {o, d, NULL, NULL, 1};
    struct esr_first_hit_out out = {&t, NULL, NULL, NULL};
    assert_int_equal(esr_first_hit(&g3, vals, &p, &rays, &out), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "1 channel"));
    esr_error_clear();
    struct esr_grid g;
    assert_int_equal(esr_grid_init(&g, 1, 4, 4, 4, BMIN, BMAX), ESR_OK);
    struct esr_first_hit_params bad[5];
    for (int k = 0; k < 5; k++)
        esr_first_hit_params_init(&bad[k], &g);
    bad[0].safety = 0.0f;
    bad[1].safety = 1.5f;
    bad[2].min_step = 0.0f;
    bad[3].max_steps = 0;
    bad[4].inside = 7;
    for (int k = 0; k < 5; k++) {
        assert_int_equal(esr_first_hit(&g, vals, &bad[k], &rays, &out), ESR_ERR);
        assert_non_null(strstr(esr_error_message(), "bad parameters"));
        esr_error_clear();
    }
    esr_first_hit_params_init(&p, &g);
    struct esr_first_hit_rays none = {NULL, NULL, NULL, NULL, 0};
    assert_int_equal(esr_first_hit(&g, NULL, &p, &none, &out), ESR_OK);
    struct esr_first_hit_rays no_dirs = {o, NULL, NULL, NULL, 1};
    assert_int_equal(esr_first_hit(&g, vals, &p, &no_dirs, &out), ESR_ERR);
    esr_error_clear();
}

/* Timing only (no assertion on speed): 100k camera rays at a 128^3 sphere grid. */
static void test_timing_report(void **state)
{
    (void)state;
    const int n = 128;
    const float lo[3] = {-1.5f, -1.5f, -1.5f}, hi[3] = {1.5f, 1.5f, 1.5f};
    struct esr_grid g;
    assert_int_equal(esr_grid_init(&g, 1, n, n, n, lo, hi), ESR_OK);
    float *v = (float *)malloc(esr_grid_count(&g) * sizeof(float));
    assert_non_null(v);
    for (int iz = 0; iz < n; iz++)
        for (int iy = 0; iy < n; iy++)
            for (int ix = 0; ix < n; ix++) {
                float q[3];
                esr_grid_voxel_pos(&g, ix, iy, iz, q);
                v[((size_t)iz * n + iy) * n + ix] = len3(q) - 0.8f;
            }
    struct esr_first_hit_params p;
    esr_first_hit_params_init(&p, &g);
    enum { R = 100000 };
    struct batch b;
    batch_alloc(&b, R);
    struct esr_rng rng = esr_rng_init(17, 0);
    for (int i = 0; i < R; i++) {
        /* a camera 4 units away looking at the centre, rays over a 2.4 x 2.4 window */
        float *o = b.o + i * 3, *d = b.d + i * 3;
        o[0] = 0.3f;
        o[1] = -0.5f;
        o[2] = 4.0f;
        float target[3] = {2.4f * (esr_rng_float(&rng) - 0.5f), 2.4f * (esr_rng_float(&rng) - 0.5f), 0.0f};
        for (int a = 0; a < 3; a++)
            d[a] = target[a] - o[a];
        normalize3(d);
    }
    batch_run(&g, v, &p, &b); /* warm-up */
    double t0 = omp_get_wtime();
    batch_run(&g, v, &p, &b);
    double sec = omp_get_wtime() - t0;
    int hits = 0, oos = 0;
    for (int i = 0; i < R; i++) {
        hits += (b.flags[i] & ESR_FIRST_HIT_HIT) != 0;
        oos += (b.flags[i] & ESR_FIRST_HIT_OUT_OF_STEPS) != 0;
    }
    print_message("timing: %d rays on a 128^3 sphere grid, %d threads: %.1f ms, %.2f M rays/s "
                  "(%d hits)\n", R, omp_get_max_threads(), sec * 1e3, R / sec * 1e-6, hits);
    assert_int_equal(oos, 0);
    assert_true(hits > R / 4);
    batch_free(&b);
    free(v);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sphere_hits),
        cmocka_unit_test(test_box_hits),
        cmocka_unit_test(test_plane_hits_and_misses),
        cmocka_unit_test(test_misses),
        cmocka_unit_test(test_grazing),
        cmocka_unit_test(test_inside_and_shadow_rays),
        cmocka_unit_test(test_segment_blocked),
        cmocka_unit_test(test_block_skip_same_hits),
        cmocka_unit_test(test_on_surface),
        cmocka_unit_test(test_non_metric_scaling),
        cmocka_unit_test(test_thin_plate),
        cmocka_unit_test(test_spike),
        cmocka_unit_test(test_normals),
        cmocka_unit_test(test_threads_null_outputs_scalar),
        cmocka_unit_test(test_bad_arguments),
        cmocka_unit_test(test_timing_report),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
