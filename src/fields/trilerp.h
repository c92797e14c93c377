/* Per-point trilinear interpolation on a struct esr_grid lattice: pure functions in the C/C++
 * common subset, so a CUDA backend can call them one thread per point. The batch loops are in
 * grid.c. A point is first "located" (cell, fractions, derivative of the lattice coordinate);
 * forward, backward and spatial-gradient kernels then only read that record. */
#ifndef ESR_FIELDS_TRILERP_H
#define ESR_FIELDS_TRILERP_H

#include <stddef.h>

#include "core/simd.h"
#include "fields/grid.h"

struct esr_trilerp {
    size_t base;    /* lattice index of the cell's corner (ix0, iy0, iz0) */
    size_t stride[3]; /* lattice-index step to the +1 corner along x, y, z */
    int iz0;        /* z-plane of the first corner (for z-plane ownership in backward passes) */
    float f[3];     /* position inside the cell, each in [0, 1] */
    float du[3];    /* d(lattice coordinate)/d(world) per axis; 0 where the point was clamped
                       (outside the box; on a face it is the cell's one-sided derivative) */
};

/* Locates p on g's lattice, clamping to the box (NaN coordinates clamp to the minimum). */
ESR_INLINE void esr_trilerp_locate(const struct esr_grid *g, const float p[3], struct esr_trilerp *t)
{
    int n[3];
    int i0[3];
    n[0] = g->nx;
    n[1] = g->ny;
    n[2] = g->nz;
    for (int a = 0; a < 3; a++) {
        float scale = (float)(n[a] - 1) / (g->bmax[a] - g->bmin[a]);
        float u = (p[a] - g->bmin[a]) * scale;
        float hi = (float)(n[a] - 1);
        t->du[a] = scale;
        /* clamped only when outside by more than rounding (or NaN): a point on a face has its
         * cell's one-sided derivative (the mesh's vertices on the box faces took 0 there; a
         * lattice point's position can round an ulp past the face) */
        if (!(u >= -1e-3f)) {
            u = 0.0f;
            t->du[a] = 0.0f;
        } else if (u > hi + 1e-3f) {
            u = hi;
            t->du[a] = 0.0f;
        } else {
            u = u < 0.0f ? 0.0f : u > hi ? hi : u;
        }
        i0[a] = (int)u;
        if (i0[a] > n[a] - 2)
            i0[a] = n[a] - 2;
        t->f[a] = u - (float)i0[a];
    }
    t->stride[0] = 1;
    t->stride[1] = (size_t)n[0];
    t->stride[2] = (size_t)n[0] * (size_t)n[1];
    t->base = (size_t)i0[0] + t->stride[1] * (size_t)i0[1] + t->stride[2] * (size_t)i0[2];
    t->iz0 = i0[2];
}

/* The lattice index of the point of g nearest to p (clamped to the box: per axis the corner of
 * p's cell that p is past the middle towards). */
ESR_INLINE size_t esr_trilerp_nearest(const struct esr_grid *g, const float p[3])
{
    struct esr_trilerp t;
    esr_trilerp_locate(g, p, &t);
    size_t i = t.base;
    for (int a = 0; a < 3; a++)
        if (t.f[a] >= 0.5f)
            i += t.stride[a];
    return i;
}

/* The z-plane of the cell containing world coordinate z (as esr_trilerp_locate computes it);
 * lets backward passes skip points whose corners are all outside a thread's planes cheaply. */
ESR_INLINE int esr_trilerp_iz0(const struct esr_grid *g, float z)
{
    float u = (z - g->bmin[2]) * ((float)(g->nz - 1) / (g->bmax[2] - g->bmin[2]));
    if (!(u > 0.0f))
        return 0;
    int i = u >= (float)(g->nz - 1) ? g->nz - 2 : (int)u;
    return i > g->nz - 2 ? g->nz - 2 : i;
}

/* Lattice index and weight of corner k (bit 0: +x, bit 1: +y, bit 2: +z). */
ESR_INLINE size_t esr_trilerp_corner(const struct esr_trilerp *t, int k, float *w)
{
    float wx = (k & 1) ? t->f[0] : 1.0f - t->f[0];
    float wy = (k & 2) ? t->f[1] : 1.0f - t->f[1];
    float wz = (k & 4) ? t->f[2] : 1.0f - t->f[2];
    *w = wx * wy * wz;
    return t->base + ((k & 1) ? t->stride[0] : 0) + ((k & 2) ? t->stride[1] : 0) +
           ((k & 4) ? t->stride[2] : 0);
}

/* d(weight of corner k)/d(world p_a), a = 0..2 (includes du, so 0 along clamped axes). */
ESR_INLINE void esr_trilerp_corner_dw(const struct esr_trilerp *t, int k, float dw[3])
{
    float w[3], s[3];
    for (int a = 0; a < 3; a++) {
        int bit = (k >> a) & 1;
        w[a] = bit ? t->f[a] : 1.0f - t->f[a];
        s[a] = (bit ? 1.0f : -1.0f) * t->du[a];
    }
    dw[0] = s[0] * w[1] * w[2];
    dw[1] = w[0] * s[1] * w[2];
    dw[2] = w[0] * w[1] * s[2];
}

/* out[c] = sum_k w_k data[corner_k * C + c] for c < C. The eight corner rows are gathered first
 * so their loads are issued together (the grid is usually far larger than the caches). */
ESR_INLINE void esr_trilerp_fwd_rows(const float *ESR_RESTRICT data, const int C,
                                     const struct esr_trilerp *t, float *ESR_RESTRICT out)
{
    const float *row[8];
    float w[8];
    for (int k = 0; k < 8; k++)
        row[k] = data + esr_trilerp_corner(t, k, &w[k]) * (size_t)C;
    for (int c = 0; c < C; c++) {
        float acc = 0.0f;
        for (int k = 0; k < 8; k++)
            acc += w[k] * row[k][c];
        out[c] = acc;
    }
}

ESR_INLINE void esr_trilerp_fwd(const float *ESR_RESTRICT data, int C, const struct esr_trilerp *t,
                                float *ESR_RESTRICT out)
{
    switch (C) { /* the grids' channel counts as constants, so the loops unroll */
    case 1:
        esr_trilerp_fwd_rows(data, 1, t, out);
        break;
    case 6:
        esr_trilerp_fwd_rows(data, 6, t, out);
        break;
    default:
        esr_trilerp_fwd_rows(data, C, t, out);
    }
}

/* plane[off[q] * C + c] += wxy[q] wz d[c]: one z-plane's four corners of a backward pass. */
ESR_INLINE void esr_trilerp_add_rows(float *ESR_RESTRICT plane, const size_t off[4], const float wxy[4],
                                     float wz, const float *ESR_RESTRICT d, const int C)
{
    for (int q = 0; q < 4; q++) {
        const float w = wxy[q] * wz;
        float *gv = plane + off[q] * (size_t)C;
        for (int c = 0; c < C; c++)
            gv[c] += w * d[c];
    }
}

/* Scatters w_k * d_out[c] into grad for the corners whose z-plane lies in [z_lo, z_hi)
 * (pass 0, INT_MAX for all). The caller guarantees no other thread writes those planes. */
ESR_INLINE void esr_trilerp_bwd(float *ESR_RESTRICT grad, int C, const struct esr_trilerp *t,
                                const float *ESR_RESTRICT d_out, int z_lo, int z_hi)
{
    /* a z-plane's four corners at a time, weights as esr_trilerp_corner forms them */
    const float fx = t->f[0], fy = t->f[1];
    const float wxy[4] = {(1.0f - fx) * (1.0f - fy), fx * (1.0f - fy), (1.0f - fx) * fy, fx * fy};
    const size_t off[4] = {0, t->stride[0], t->stride[1], t->stride[0] + t->stride[1]};
    for (int zk = 0; zk < 2; zk++) {
        const int z = t->iz0 + zk;
        if (z < z_lo || z >= z_hi)
            continue;
        const float wz = zk ? t->f[2] : 1.0f - t->f[2];
        float *plane = grad + (t->base + (zk ? t->stride[2] : 0)) * (size_t)C;
        /* the grids' channel counts as constants, so the row loops unroll */
        switch (C) {
        case 1: /* SDF, density */
            esr_trilerp_add_rows(plane, off, wxy, wz, d_out, 1);
            break;
        case 6: /* feature grids */
            esr_trilerp_add_rows(plane, off, wxy, wz, d_out, 6);
            break;
        default:
            esr_trilerp_add_rows(plane, off, wxy, wz, d_out, C);
        }
    }
}

/* Spatial gradient of channel ch: dp[a] = d value_ch / d p_a. */
ESR_INLINE void esr_trilerp_dpoint(const float *data, int C, int ch, const struct esr_trilerp *t,
                                   float dp[3])
{
    dp[0] = dp[1] = dp[2] = 0.0f;
    for (int k = 0; k < 8; k++) {
        float w, dw[3];
        float v = data[esr_trilerp_corner(t, k, &w) * (size_t)C + (size_t)ch];
        esr_trilerp_corner_dw(t, k, dw);
        dp[0] += dw[0] * v;
        dp[1] += dw[1] * v;
        dp[2] += dw[2] * v;
    }
}

/* Value and spatial gradient of a 1-channel grid in one pass over the corners (SDF queries). */
ESR_INLINE float esr_trilerp_value_dpoint(const float *data, const struct esr_trilerp *t, float dp[3])
{
    const float *v0 = data + t->base;
    const size_t sx = t->stride[0], sy = t->stride[1], sz = t->stride[2];
    const float c000 = v0[0], c100 = v0[sx], c010 = v0[sy], c110 = v0[sx + sy];
    const float c001 = v0[sz], c101 = v0[sx + sz], c011 = v0[sy + sz], c111 = v0[sx + sy + sz];
    const float fx = t->f[0], fy = t->f[1], fz = t->f[2];
    /* interpolate along x, then y, then z, keeping the x/y/z differences for the gradient */
    const float c00 = c000 + fx * (c100 - c000), c10 = c010 + fx * (c110 - c010);
    const float c01 = c001 + fx * (c101 - c001), c11 = c011 + fx * (c111 - c011);
    const float c0 = c00 + fy * (c10 - c00), c1 = c01 + fy * (c11 - c01);
    const float dx0 = (c100 - c000) + fy * ((c110 - c010) - (c100 - c000));
    const float dx1 = (c101 - c001) + fy * ((c111 - c011) - (c101 - c001));
    dp[0] = (dx0 + fz * (dx1 - dx0)) * t->du[0];
    dp[1] = ((c10 - c00) + fz * ((c11 - c01) - (c10 - c00))) * t->du[1];
    dp[2] = (c1 - c0) * t->du[2];
    return c0 + fz * (c1 - c0);
}

/* Adjoint of value and spatial gradient of channel ch, restricted to z-planes [z_lo, z_hi):
 * grad[corner_k*C + ch] += w_k d_value + dw_k . d_dp (the point-gradient is linear in the grid
 * values). d_value = 0 gives the adjoint of esr_trilerp_dpoint alone. */
ESR_INLINE void esr_trilerp_value_dpoint_bwd(float *grad, int C, int ch, const struct esr_trilerp *t,
                                             float d_value, const float d_dp[3], int z_lo, int z_hi)
{
    for (int k = 0; k < 8; k++) {
        int z = t->iz0 + ((k >> 2) & 1);
        if (z < z_lo || z >= z_hi)
            continue;
        float w, dw[3];
        size_t idx = esr_trilerp_corner(t, k, &w);
        esr_trilerp_corner_dw(t, k, dw);
        grad[idx * (size_t)C + (size_t)ch] += w * d_value + dw[0] * d_dp[0] + dw[1] * d_dp[1] + dw[2] * d_dp[2];
    }
}

#endif
