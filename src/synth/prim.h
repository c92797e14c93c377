/* Analytic primitives of the built-in scenes: spheres, axis-aligned boxes and z-axis capped
 * cylinders, all closed. Exact ray intersection, surface normal, area and uniform-by-area point
 * sampling (for next-event estimation on emitters). Per-element pure functions, C/C++ common
 * subset, so a CUDA port can include this header unchanged. */
#ifndef ESR_SYNTH_PRIM_H
#define ESR_SYNTH_PRIM_H

#include <math.h>

#include "core/brdf.h"
#include "core/sampling.h"
#include "core/vec3.h"
#include "synth/noise.h"

enum esr_synth_prim_kind { ESR_SYNTH_SPHERE, ESR_SYNTH_BOX, ESR_SYNTH_CYLINDER };
enum esr_synth_texture { ESR_SYNTH_TEX_NONE, ESR_SYNTH_TEX_CHECKER, ESR_SYNTH_TEX_STRIPES, ESR_SYNTH_TEX_NOISE };

struct esr_synth_prim {
    enum esr_synth_prim_kind kind;
    struct esr_vec3 a;         /* sphere: centre; box: min corner; cylinder: centre of the bottom cap */
    struct esr_vec3 b;         /* sphere: (radius,0,0); box: max corner; cylinder: (radius, height, 0) */
    struct esr_material mat;   /* base colour is texture colour 0 */
    enum esr_synth_texture texture;
    float base2[3];            /* texture colour 1 */
    float tex_period;          /* size of one checker square / stripe / noise cell, metres */
    int light;                 /* index of the light this primitive is, -1 when not emissive */
    const char *name;          /* object name (scene.json) */
};

/* Nearest intersection distance in (tmin, tmax), or INFINITY. d need not be unit length. */
ESR_INLINE float esr_synth_prim_hit(const struct esr_synth_prim *p, struct esr_vec3 o, struct esr_vec3 d, float tmin,
                                    float tmax)
{
    float t0 = INFINITY, t1 = INFINITY;
    if (p->kind == ESR_SYNTH_SPHERE) {
        /* Distance from the centre to the ray's closest point, not b^2 - c, to avoid cancellation. */
        float dd = esr_v3_dot(d, d);
        struct esr_vec3 oc = esr_v3_sub(o, p->a);
        float tc = -esr_v3_dot(oc, d) / dd;
        struct esr_vec3 q = esr_v3_add(oc, esr_v3_scale(d, tc));
        float h2 = p->b.x * p->b.x - esr_v3_dot(q, q);
        if (h2 < 0.0f)
            return INFINITY;
        float dt = sqrtf(h2 / dd);
        t0 = tc - dt;
        t1 = tc + dt;
    } else if (p->kind == ESR_SYNTH_BOX) {
        float lo[3] = {p->a.x, p->a.y, p->a.z}, hi[3] = {p->b.x, p->b.y, p->b.z};
        float oo[3] = {o.x, o.y, o.z}, dv[3] = {d.x, d.y, d.z};
        float tn = -INFINITY, tf = INFINITY;
        for (int k = 0; k < 3; k++) {
            float inv = 1.0f / dv[k]; /* +-inf for axis-parallel rays: the slab test still works */
            float ta = (lo[k] - oo[k]) * inv, tb = (hi[k] - oo[k]) * inv;
            if (ta > tb) {
                float s = ta;
                ta = tb;
                tb = s;
            }
            if (!(ta <= tf && tb >= tn)) /* also rejects NaN from 0 * inf */
                return INFINITY;
            tn = fmaxf(tn, ta);
            tf = fminf(tf, tb);
        }
        t0 = tn;
        t1 = tf;
    } else {
        float r = p->b.x, z0 = p->a.z, z1 = p->a.z + p->b.y;
        float ox = o.x - p->a.x, oy = o.y - p->a.y;
        /* Infinite cylinder, then clip the interval by the two cap planes (a convex slab). */
        float qa = d.x * d.x + d.y * d.y, tn = -INFINITY, tf = INFINITY;
        if (qa > 0.0f) {
            float tc = -(ox * d.x + oy * d.y) / qa;
            float qx = ox + tc * d.x, qy = oy + tc * d.y;
            float h2 = r * r - (qx * qx + qy * qy);
            if (h2 < 0.0f)
                return INFINITY;
            float dt = sqrtf(h2 / qa);
            tn = tc - dt;
            tf = tc + dt;
        } else if (ox * ox + oy * oy > r * r) {
            return INFINITY;
        }
        float inv = 1.0f / d.z;
        float ta = (z0 - o.z) * inv, tb = (z1 - o.z) * inv;
        if (ta > tb) {
            float s = ta;
            ta = tb;
            tb = s;
        }
        if (!(ta <= tf && tb >= tn))
            return INFINITY;
        t0 = fmaxf(tn, ta);
        t1 = fminf(tf, tb);
        if (t0 > t1)
            return INFINITY;
    }
    if (t0 > tmin && t0 < tmax)
        return t0;
    if (t1 > tmin && t1 < tmax)
        return t1;
    return INFINITY;
}

/* Outward unit normal at a surface point x of p. */
ESR_INLINE struct esr_vec3 esr_synth_prim_normal(const struct esr_synth_prim *p, struct esr_vec3 x)
{
    if (p->kind == ESR_SYNTH_SPHERE)
        return esr_v3_normalize(esr_v3_sub(x, p->a));
    if (p->kind == ESR_SYNTH_BOX) {
        /* The face whose plane x is closest to, relative to the half extent. */
        struct esr_vec3 c = esr_v3_scale(esr_v3_add(p->a, p->b), 0.5f);
        struct esr_vec3 h = esr_v3_scale(esr_v3_sub(p->b, p->a), 0.5f);
        struct esr_vec3 q = esr_v3_sub(x, c);
        float rx = fabsf(q.x) / h.x, ry = fabsf(q.y) / h.y, rz = fabsf(q.z) / h.z;
        if (rx >= ry && rx >= rz)
            return esr_v3(copysignf(1.0f, q.x), 0.0f, 0.0f);
        if (ry >= rz)
            return esr_v3(0.0f, copysignf(1.0f, q.y), 0.0f);
        return esr_v3(0.0f, 0.0f, copysignf(1.0f, q.z));
    }
    float r = p->b.x, hh = 0.5f * p->b.y;
    float qx = x.x - p->a.x, qy = x.y - p->a.y, qz = x.z - (p->a.z + hh);
    float radial = sqrtf(qx * qx + qy * qy);
    if (hh - fabsf(qz) < r - radial)
        return esr_v3(0.0f, 0.0f, copysignf(1.0f, qz));
    return esr_v3(qx / radial, qy / radial, 0.0f);
}

ESR_INLINE float esr_synth_prim_area(const struct esr_synth_prim *p)
{
    if (p->kind == ESR_SYNTH_SPHERE)
        return 4.0f * ESR_PI * p->b.x * p->b.x;
    if (p->kind == ESR_SYNTH_BOX) {
        struct esr_vec3 e = esr_v3_sub(p->b, p->a);
        return 2.0f * (e.x * e.y + e.y * e.z + e.z * e.x);
    }
    return 2.0f * ESR_PI * p->b.x * (p->b.x + p->b.y);
}

/* Parts of p's surface that face a point x outside p: p is convex, so only they can exchange
 * light with x. Sphere: part 0, the cap inside the tangent cone from x. Box: part 2k + s, the face
 * with normal -/+ axis k (s = 0/1) when x lies beyond its plane. Cylinder: part 0, the arc of the
 * side within acos(r / d) of x's azimuth (d its distance from the axis); parts 1 and 2, the top
 * and bottom caps when x is above / below them. area[] (6 entries) gets each part's area, 0 for
 * parts that face away; returns their sum (0 when x is inside or on p). */
ESR_INLINE float esr_synth_prim_front_parts(const struct esr_synth_prim *p, struct esr_vec3 x, float area[6])
{
    for (int i = 0; i < 6; i++)
        area[i] = 0.0f;
    if (p->kind == ESR_SYNTH_SPHERE) {
        float d = esr_v3_length(esr_v3_sub(x, p->a)), r = p->b.x;
        if (d > r)
            area[0] = 2.0f * ESR_PI * r * r * (1.0f - r / d);
    } else if (p->kind == ESR_SYNTH_BOX) {
        float lo[3] = {p->a.x, p->a.y, p->a.z}, hi[3] = {p->b.x, p->b.y, p->b.z}, q[3] = {x.x, x.y, x.z};
        for (int k = 0; k < 3; k++) {
            int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
            float face = (hi[k1] - lo[k1]) * (hi[k2] - lo[k2]);
            area[2 * k] = q[k] < lo[k] ? face : 0.0f;
            area[2 * k + 1] = q[k] > hi[k] ? face : 0.0f;
        }
    } else {
        float r = p->b.x, h = p->b.y;
        float d = sqrtf((x.x - p->a.x) * (x.x - p->a.x) + (x.y - p->a.y) * (x.y - p->a.y));
        if (d > r)
            area[0] = 2.0f * acosf(r / d) * r * h;
        area[1] = x.z > p->a.z + h ? ESR_PI * r * r : 0.0f;
        area[2] = x.z < p->a.z ? ESR_PI * r * r : 0.0f;
    }
    float total = 0.0f;
    for (int i = 0; i < 6; i++)
        total += area[i];
    return total;
}

/* Area of the part of p that sampling towards x covers (esr_synth_prim_front_parts). */
ESR_INLINE float esr_synth_prim_area_toward(const struct esr_synth_prim *p, struct esr_vec3 x)
{
    float area[6];
    return esr_synth_prim_front_parts(p, x, area);
}

/* A point uniformly distributed by area over the parts of p facing x and its outward normal:
 * u0 picks the part by area, (u1, u2) the position. Returns their total area (the pdf is its
 * inverse); 0, with y and n untouched, when no part faces x.
 * Skipping the parts that face away halves the wasted shadow rays of next-event estimation on a
 * box or cylinder light. The sphere's cap facing x is sampled by Archimedes' hat-box theorem: the
 * cap's height is uniform in cos around the axis towards x. */
ESR_INLINE float esr_synth_prim_sample_toward(const struct esr_synth_prim *p, struct esr_vec3 x, float u0, float u1,
                                              float u2, struct esr_vec3 *y, struct esr_vec3 *n)
{
    float area[6];
    const float total = esr_synth_prim_front_parts(p, x, area);
    if (total <= 0.0f)
        return 0.0f;
    float pick = u0 * total;
    int part = 0;
    while (part < 5 && (pick >= area[part] || area[part] == 0.0f)) {
        pick -= area[part];
        part++;
    }
    while (part > 0 && area[part] == 0.0f) /* rounding ran past the last non-empty part */
        part--;
    if (p->kind == ESR_SYNTH_SPHERE) {
        struct esr_vec3 axis = esr_v3_sub(x, p->a);
        float d = esr_v3_length(axis), r = p->b.x;
        axis = esr_v3_scale(axis, 1.0f / d);
        float z = 1.0f - u1 * (1.0f - r / d);
        float s = sqrtf(fmaxf(0.0f, 1.0f - z * z)), phi = 2.0f * ESR_PI * u2;
        struct esr_vec3 t, b;
        esr_v3_basis(axis, &t, &b);
        *n = esr_v3_from_local(esr_v3(s * cosf(phi), s * sinf(phi), z), t, b, axis);
        *y = esr_v3_add(p->a, esr_v3_scale(*n, r));
    } else if (p->kind == ESR_SYNTH_BOX) {
        float lo[3] = {p->a.x, p->a.y, p->a.z}, hi[3] = {p->b.x, p->b.y, p->b.z}, pos[3], nor[3] = {0, 0, 0};
        int k = part / 2, side = part % 2, k1 = (k + 1) % 3, k2 = (k + 2) % 3;
        pos[k] = side ? hi[k] : lo[k];
        pos[k1] = lo[k1] + u1 * (hi[k1] - lo[k1]);
        pos[k2] = lo[k2] + u2 * (hi[k2] - lo[k2]);
        nor[k] = side ? 1.0f : -1.0f;
        *y = esr_v3(pos[0], pos[1], pos[2]);
        *n = esr_v3(nor[0], nor[1], nor[2]);
    } else {
        float r = p->b.x, h = p->b.y;
        if (part == 0) {
            float dx = x.x - p->a.x, dy = x.y - p->a.y, d = sqrtf(dx * dx + dy * dy);
            float phi = atan2f(dy, dx) + acosf(r / d) * (2.0f * u1 - 1.0f);
            *n = esr_v3(cosf(phi), sinf(phi), 0.0f);
            *y = esr_v3(p->a.x + r * n->x, p->a.y + r * n->y, p->a.z + u2 * h);
        } else {
            int top = part == 1;
            float rr = r * sqrtf(u1), phi = 2.0f * ESR_PI * u2;
            *n = esr_v3(0.0f, 0.0f, top ? 1.0f : -1.0f);
            *y = esr_v3(p->a.x + rr * cosf(phi), p->a.y + rr * sinf(phi), p->a.z + (top ? h : 0.0f));
        }
    }
    return total;
}

/* Material at surface point x: the procedural texture picks base colour 0 or 1 (checker in x,y
 * for floors, stripes across x+z), so multi-view geometry has texture to lock onto, or blends the
 * two by fractal noise (non-repeating, like the surfaces of a real capture). */
ESR_INLINE struct esr_material esr_synth_prim_material(const struct esr_synth_prim *p, struct esr_vec3 x)
{
    struct esr_material m = p->mat;
    float w = 0.0f; /* weight of base colour 1 */
    if (p->texture == ESR_SYNTH_TEX_CHECKER)
        w = (float)(((int)floorf(x.x / p->tex_period) + (int)floorf(x.y / p->tex_period)) & 1);
    else if (p->texture == ESR_SYNTH_TEX_STRIPES)
        w = (float)((int)floorf((x.x + x.z) / p->tex_period) & 1);
    else if (p->texture == ESR_SYNTH_TEX_NOISE)
        w = esr_synth_noise(x, p->tex_period);
    for (int c = 0; c < 3; c++) /* w = 1 gives base colour 1 exactly */
        m.base[c] = w == 1.0f ? p->base2[c] : m.base[c] + w * (p->base2[c] - m.base[c]);
    return m;
}

#endif
