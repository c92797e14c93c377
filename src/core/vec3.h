/* Small 3-vector helpers (float), usable from C17 and C++17 alike. */
#ifndef ESR_CORE_VEC3_H
#define ESR_CORE_VEC3_H

#include <math.h>
#include <stddef.h>

#include "core/simd.h"

struct esr_vec3 {
    float x, y, z;
};

ESR_INLINE struct esr_vec3 esr_v3(float x, float y, float z)
{
    struct esr_vec3 v;
    v.x = x;
    v.y = y;
    v.z = z;
    return v;
}

/* Element i of a flat xyz array (a[i*3 .. i*3+2]). */
ESR_INLINE struct esr_vec3 esr_v3_at(const float *a, size_t i)
{
    return esr_v3(a[i * 3], a[i * 3 + 1], a[i * 3 + 2]);
}
ESR_INLINE struct esr_vec3 esr_v3_add(struct esr_vec3 a, struct esr_vec3 b) { return esr_v3(a.x + b.x, a.y + b.y, a.z + b.z); }
ESR_INLINE struct esr_vec3 esr_v3_sub(struct esr_vec3 a, struct esr_vec3 b) { return esr_v3(a.x - b.x, a.y - b.y, a.z - b.z); }
ESR_INLINE struct esr_vec3 esr_v3_mul(struct esr_vec3 a, struct esr_vec3 b) { return esr_v3(a.x * b.x, a.y * b.y, a.z * b.z); }
ESR_INLINE struct esr_vec3 esr_v3_scale(struct esr_vec3 a, float s) { return esr_v3(a.x * s, a.y * s, a.z * s); }
ESR_INLINE float esr_v3_dot(struct esr_vec3 a, struct esr_vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
ESR_INLINE struct esr_vec3 esr_v3_cross(struct esr_vec3 a, struct esr_vec3 b)
{
    return esr_v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
ESR_INLINE float esr_v3_length(struct esr_vec3 a) { return sqrtf(esr_v3_dot(a, a)); }
ESR_INLINE struct esr_vec3 esr_v3_normalize(struct esr_vec3 a)
{
    float len = esr_v3_length(a);
    return len > 0.0f ? esr_v3_scale(a, 1.0f / len) : a;
}
ESR_INLINE float esr_v3_max_component(struct esr_vec3 a) { return fmaxf(a.x, fmaxf(a.y, a.z)); }

/* Orthonormal basis around unit normal n (Duff et al. 2017, branchless, no singularity). */
ESR_INLINE void esr_v3_basis(struct esr_vec3 n, struct esr_vec3 *t, struct esr_vec3 *b)
{
    float sign = copysignf(1.0f, n.z);
    float a = -1.0f / (sign + n.z);
    float c = n.x * n.y * a;
    *t = esr_v3(1.0f + sign * n.x * n.x * a, sign * c, -sign * n.x);
    *b = esr_v3(c, sign + n.y * n.y * a, -n.y);
}
/* Maps a local direction (z = normal) into the frame (t, b, n). */
ESR_INLINE struct esr_vec3 esr_v3_from_local(struct esr_vec3 local, struct esr_vec3 t, struct esr_vec3 b, struct esr_vec3 n)
{
    return esr_v3_add(esr_v3_add(esr_v3_scale(t, local.x), esr_v3_scale(b, local.y)), esr_v3_scale(n, local.z));
}
/* The inverse of esr_v3_from_local: a world direction's coordinates in the frame (t, b, n), e.g.
 * to evaluate a local-frame pdf or inverse (core/sampling.h) at a world direction. */
ESR_INLINE struct esr_vec3 esr_v3_to_local(struct esr_vec3 world, struct esr_vec3 t, struct esr_vec3 b, struct esr_vec3 n)
{
    return esr_v3(esr_v3_dot(world, t), esr_v3_dot(world, b), esr_v3_dot(world, n));
}

#endif
