/* First hit of rays on the zero level set of a 1-channel SDF voxel grid (shadow rays, depth and
 * normal maps, mesh-free surface queries): sphere tracing with a step that is provably safe for
 * the trilinear field, then false-position refinement of the sign change.
 *
 * Why not step by |f|: the grid's SDF is not a distance (no eikonal loss, |grad f| can be far
 * from 1), so |f| alone says nothing about how far the surface is. Inside one lattice cell the
 * trilinear field's partial derivative along axis a (in lattice units) is a bilinear blend of the
 * cell's four edge differences along a, so |df/dt| along the ray is at most
 *     L = sum_a M_a |d_a| s_a      (M_a = largest |edge difference| along a, s_a = lattice/world)
 * and no zero can lie closer than |f| / L while the ray stays in the cell. The same sum with the
 * largest edge differences of the whole grid, G, bounds |df/dt| everywhere in the box. The step:
 *     step = max(min(|f| / L, distance to the cell's exit), |f| / G) * safety, floored at min_step
 * The local bound is tight near the surface but only valid up to the cell exit (at most a cell
 * diagonal, sqrt 3 voxels; the next cell has its own L); the global one lets a near-metric SDF
 * take sphere-tracing strides through empty space (on a 128^3 sphere it cuts the mean steps per
 * camera ray from ~126 to ~11) and is merely small where a few steep cells inflate G. Both are
 * invariant to scaling f (5 f and 0.2 f march the same samples), so no metric SDF is assumed
 * and no surface thicker than min_step along the ray is ever skipped; only min_step (a floor
 * that stops the geometric approach of the surface from taking forever) can step over a
 * sliver thinner than itself. global_bound = 0 keeps only the cell-local bound (steps of at most
 * a cell; no pass over the grid, for small batches).
 * A sign change from f > 0 to f <= 0 between consecutive samples is refined by false position
 * with the Illinois fix (keeps the bracket like bisection, converges superlinearly).
 *
 * Rays whose first sample (t_min clipped to the box) has f <= 0 "start inside". Mode REPORT (the
 * default) reports a hit at that t flagged STARTED_INSIDE, so a caller sees self-intersection
 * instead of a silently wrong distance (a shadow ray whose end lies inside a surface is
 * blocked). Mode SKIP marches through the inside region (same safe step on |f|) and
 * returns the next entry into the surface after it, still flagged STARTED_INSIDE.
 *
 * Per-ray code is below as pure inline functions (C/C++ common subset, one thread per ray on a
 * GPU); esr_first_hit runs the batch in parallel. Points outside the box never matter: every
 * ray is clipped to the grid's box first, so rays missing the box miss cleanly. */
#ifndef ESR_VOLUME_FIRST_HIT_H
#define ESR_VOLUME_FIRST_HIT_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#include "core/simd.h"
#include "fields/grid.h"
#include "volume/ray.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Bits of the per-ray flags. */
#define ESR_FIRST_HIT_HIT 1u            /* t is a hit (a crossing, or t_min when started inside) */
#define ESR_FIRST_HIT_STARTED_INSIDE 2u /* f <= 0 at the first in-box sample */
#define ESR_FIRST_HIT_OUT_OF_STEPS 4u   /* max_steps ran out before the end of the ray: a miss
                                           that is "unknown", not "nothing there" */

enum esr_first_hit_inside {
    ESR_FIRST_HIT_INSIDE_REPORT = 0, /* started inside: hit at the first sample */
    ESR_FIRST_HIT_INSIDE_SKIP = 1,   /* started inside: march out, return the next entry */
};

struct esr_first_hit_params {
    int max_steps;    /* samples per ray before giving up (OUT_OF_STEPS) */
    float safety;     /* (0, 1]: fraction of the safe step |f| / L taken; 1 is exact */
    float min_step;   /* voxels (smallest voxel edge): floor on the step, the thinnest sliver
                         along the ray that may be stepped over, and the usual bracket width */
    float tol;        /* voxels: refinement stops once the bracket is this narrow */
    int refine_iters; /* false-position iterations at most */
    int inside;       /* enum esr_first_hit_inside */
    int global_bound; /* 1: compute G (one pass over the grid per call) for long strides in
                         empty space; 0: local cell bounds only */
};

/* Rays in, flat structure-of-arrays. */
struct esr_first_hit_rays {
    const float *origins; /* [n*3] */
    const float *dirs;    /* [n*3], normally unit; any nonzero length works (tolerances use |d|) */
    const float *t_min;   /* [n], NULL: 0 */
    const float *t_max;   /* [n], NULL: +infinity (the box clips every ray anyway) */
    size_t n;
};

/* Results; any pointer may be NULL. On a miss: t = INFINITY, pos = normal = 0. */
struct esr_first_hit_out {
    float *t;        /* [n] ray parameter of the hit */
    uint8_t *flags;  /* [n] ESR_FIRST_HIT_* bits */
    float *pos;      /* [n*3] o + t d */
    float *normal;   /* [n*3] normalised trilinear SDF gradient at pos (as
                        esr_grid_sample_value_dpoint computes it); 0 where the gradient is 0 */
};

/* Defaults for grid g: max_steps 4 (nx+ny+nz) + 256 (a ray crosses at most nx+ny+nz cells and
 * every cell costs at least one step), safety 1, min_step 0.02 voxel, tol 1e-4 voxel,
 * refine_iters 24, inside REPORT, global_bound 1. */
void esr_first_hit_params_init(struct esr_first_hit_params *p, const struct esr_grid *g);

/* First hit of every ray on the zero level set of the 1-channel grid g with values sdf
 * (f > 0 outside). Parallel over rays, results independent of the thread count; allocates only
 * the blocks' minima (a float per 8^3 cells).
 * Fails on a grid with channels != 1, bad parameters or missing inputs. */
int esr_first_hit(const struct esr_grid *g, const float *sdf, const struct esr_first_hit_params *p,
                  const struct esr_first_hit_rays *rays, const struct esr_first_hit_out *out);

/* ---- per-ray functions ---- */

/* max / min by comparison: compiles to maxss/minss (fmaxf/fminf are libm calls on baseline
 * x86-64); a NaN first argument yields the second. */
ESR_INLINE float esr_fh_max(float a, float b) { return a > b ? a : b; }
ESR_INLINE float esr_fh_min(float a, float b) { return a < b ? a : b; }

/* Cells per edge of the blocks whose lattice minimum lets the march skip them (see
 * esr_first_hit_block_skip). */
#define ESR_FIRST_HIT_BLOCK 8

/* The grid as the marcher reads it (derived once per batch). */
struct esr_first_hit_grid {
    const float *data;
    int n[3];
    size_t sy, sz;    /* lattice-index strides along y and z (x is 1) */
    float bmin[3], bmax[3];
    float scale[3];   /* lattice units per world unit */
    float voxel;      /* smallest voxel edge (world) */
    float gmax[3];    /* largest |edge difference| along each axis over the whole grid (lattice
                         units): G above; INFINITY = unknown, no global strides */
    float *block_min; /* per block of ESR_FIRST_HIT_BLOCK^3 cells, x fastest: the smallest value
                         at its lattice points (faces included; NaNs passed over); NULL = no
                         block skipping. Owned (esr_first_hit_grid_free). */
    int nb[3];        /* blocks per axis */
};

ESR_INLINE void esr_first_hit_grid_init(struct esr_first_hit_grid *fg, const struct esr_grid *g,
                                        const float *data)
{
    fg->data = data;
    fg->n[0] = g->nx;
    fg->n[1] = g->ny;
    fg->n[2] = g->nz;
    fg->sy = (size_t)g->nx;
    fg->sz = (size_t)g->nx * (size_t)g->ny;
    fg->voxel = INFINITY;
    fg->block_min = NULL;
    for (int a = 0; a < 3; a++) {
        fg->nb[a] = 0;
        fg->gmax[a] = INFINITY;
        fg->bmin[a] = g->bmin[a];
        fg->bmax[a] = g->bmax[a];
        fg->scale[a] = (float)(fg->n[a] - 1) / (g->bmax[a] - g->bmin[a]);
        fg->voxel = esr_fh_min(1.0f / fg->scale[a], fg->voxel);
    }
}

/* esr_first_hit_grid_init, plus G when global_bound is 1 and the blocks' minima (parallel passes
 * over the grid; the minima are allocated): what esr_first_hit does before marching, for callers
 * of esr_first_hit_ray. Fails only when out of memory; free with esr_first_hit_grid_free. */
int esr_first_hit_grid_prepare(struct esr_first_hit_grid *fg, const struct esr_grid *g,
                               const float *data, int global_bound);
void esr_first_hit_grid_free(struct esr_first_hit_grid *fg);

/* Along axis a at o + t d: the lattice coordinate *u (clamped to the lattice), *ds the lattice
 * units per unit t, and the index of the cell the ray is about to cross, chosen 1e-4 voxel ahead
 * along the ray, so a point lying on a cell face belongs to the cell the ray enters next. */
ESR_INLINE int esr_first_hit_cell(const struct esr_first_hit_grid *fg, const float o[3],
                                  const float d[3], float t, int a, float *u, float *ds)
{
    *ds = d[a] * fg->scale[a];
    const float hi = (float)(fg->n[a] - 1);
    *u = esr_fh_min(esr_fh_max((o[a] + t * d[a] - fg->bmin[a]) * fg->scale[a], 0.0f), hi);
    const float bias = *ds > 0.0f ? 1e-4f : (*ds < 0.0f ? -1e-4f : 0.0f);
    int i = (int)floorf(*u + bias);
    if (i > fg->n[a] - 2)
        i = fg->n[a] - 2;
    return i < 0 ? 0 : i;
}

/* The distance in t from lattice coordinate u to the exit of [lo, hi] moving at ds (INFINITY when
 * ds = 0). */
ESR_INLINE float esr_first_hit_exit(float u, float ds, float lo, float hi)
{
    return ds > 0.0f ? (hi - u) / ds : (ds < 0.0f ? (lo - u) / ds : INFINITY);
}

/* The distance in t from o + t d to the exit of the block the ray is crossing there, when every
 * lattice value of that block is positive, else 0. A trilinear cell's values are convex blends of
 * its corners, so such a block holds no surface anywhere and the march may cross it in one step:
 * through empty space a ray then takes a probe per block, not one per cell or per |f| / G stride
 * (the demo scene's secondary rays: ~82 probes each without). The block is chosen as
 * esr_first_hit_probe chooses the cell, 1e-4 voxel ahead along the ray. */
ESR_INLINE float esr_first_hit_block_skip(const struct esr_first_hit_grid *fg, const float o[3],
                                          const float d[3], float t)
{
    float ex = INFINITY;
    size_t b[3];
    for (int a = 0; a < 3; a++) {
        float u, ds;
        const int blk = esr_first_hit_cell(fg, o, d, t, a, &u, &ds) / ESR_FIRST_HIT_BLOCK;
        b[a] = (size_t)blk;
        ex = esr_fh_min(esr_first_hit_exit(u, ds, (float)(blk * ESR_FIRST_HIT_BLOCK),
                                           (float)((blk + 1) * ESR_FIRST_HIT_BLOCK)),
                        ex);
    }
    const float mn = fg->block_min[b[0] + (size_t)fg->nb[0] * (b[1] + (size_t)fg->nb[1] * b[2])];
    return mn > 0.0f && ex > 0.0f ? ex : 0.0f;
}

/* f at o + t d, and for the cell the ray is about to cross from there: *lip, the bound L on
 * |df/dt| inside it, and *exit, the distance in t to its exit (can be slightly negative by
 * rounding; callers floor the step). The cell is chosen 1e-4 voxel ahead along the ray, so a
 * sample lying on a cell face belongs to the cell the ray enters next, not the one it left. */
ESR_INLINE float esr_first_hit_probe(const struct esr_first_hit_grid *fg, const float o[3],
                                     const float d[3], float t, float *lip, float *exit)
{
    float fr[3], ad[3];
    size_t idx[3];
    float ex = INFINITY;
    for (int a = 0; a < 3; a++) {
        float u, ds;
        const int i = esr_first_hit_cell(fg, o, d, t, a, &u, &ds);
        fr[a] = u - (float)i; /* within 1e-4 of [0, 1]: trilinear is continuous across faces */
        idx[a] = (size_t)i;
        ex = esr_fh_min(esr_first_hit_exit(u, ds, (float)i, (float)(i + 1)), ex);
        ad[a] = fabsf(ds);
    }
    const float *v = fg->data + idx[0] + fg->sy * idx[1] + fg->sz * idx[2];
    const size_t sy = fg->sy, sz = fg->sz;
    const float c000 = v[0], c100 = v[1], c010 = v[sy], c110 = v[1 + sy];
    const float c001 = v[sz], c101 = v[1 + sz], c011 = v[sy + sz], c111 = v[1 + sy + sz];
    /* largest edge difference per axis bounds that axis' partial derivative in the cell */
    const float mx = esr_fh_max(esr_fh_max(fabsf(c100 - c000), fabsf(c110 - c010)),
                                esr_fh_max(fabsf(c101 - c001), fabsf(c111 - c011)));
    const float my = esr_fh_max(esr_fh_max(fabsf(c010 - c000), fabsf(c110 - c100)),
                                esr_fh_max(fabsf(c011 - c001), fabsf(c111 - c101)));
    const float mz = esr_fh_max(esr_fh_max(fabsf(c001 - c000), fabsf(c101 - c100)),
                                esr_fh_max(fabsf(c011 - c010), fabsf(c111 - c110)));
    *lip = mx * ad[0] + my * ad[1] + mz * ad[2];
    *exit = ex;
    const float fx = fr[0], fy = fr[1], fz = fr[2];
    const float c00 = c000 + fx * (c100 - c000), c10 = c010 + fx * (c110 - c010);
    const float c01 = c001 + fx * (c101 - c001), c11 = c011 + fx * (c111 - c011);
    const float c0 = c00 + fy * (c10 - c00), c1 = c01 + fy * (c11 - c01);
    return c0 + fz * (c1 - c0);
}

/* A bracket of the ray's first zero of f: f(a) = fa > 0 >= fb = f(b), a < b. */
struct esr_first_hit_bracket {
    float a, fa; /* the end outside the surface and f there */
    float b, fb; /* the end on or inside it and f there */
};

/* Zero of f in bracket br: false position with the Illinois fix (halve the weight of an end
 * that survives twice), midpoint when the secant point is not strictly inside the bracket, until
 * b - a <= tol or iters run out; returns the secant point of the last bracket (the midpoint if
 * that is degenerate). */
ESR_INLINE float esr_first_hit_refine(const struct esr_first_hit_grid *fg, const float o[3],
                                      const float d[3], const struct esr_first_hit_bracket *br,
                                      float tol, int iters)
{
    float a = br->a, fa = br->fa, b = br->b, fb = br->fb;
    float wa = fa, wb = fb, lip, ex;
    int side = 0;
    for (int k = 0; k < iters && b - a > tol; k++) {
        float c = a + (b - a) * (wa / (wa - wb));
        if (!(c > a && c < b))
            c = 0.5f * (a + b);
        if (!(c > a && c < b))
            break; /* a and b are adjacent floats */
        float fc = esr_first_hit_probe(fg, o, d, c, &lip, &ex);
        if (fc > 0.0f) {
            a = c;
            fa = wa = fc;
            if (side == 1)
                wb *= 0.5f;
            side = 1;
        } else {
            b = c;
            fb = wb = fc;
            if (fc == 0.0f)
                return c;
            if (side == -1)
                wa *= 0.5f;
            side = -1;
        }
    }
    float c = a + (b - a) * (fa / (fa - fb));
    return (c >= a && c <= b) ? c : 0.5f * (a + b);
}

/* Marches one ray o + t d over [t_min, t_max] clipped to the box. Returns the ESR_FIRST_HIT_*
 * flags and sets *t_hit (INFINITY on a miss). */
ESR_INLINE unsigned esr_first_hit_ray(const struct esr_first_hit_grid *fg,
                                      const struct esr_first_hit_params *p, const float o[3],
                                      const float d[3], float t_min, float t_max, float *t_hit)
{
    *t_hit = INFINITY;
    const float dlen = sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if (!(dlen > 0.0f) || !isfinite(dlen) || !isfinite(o[0]) || !isfinite(o[1]) ||
        !isfinite(o[2]) || !(t_min <= t_max))
        return 0;
    float t0, t1;
    if (!esr_ray_box_clip(o, d, fg->bmin, fg->bmax, t_min, t_max, &t0, &t1) || !isfinite(t0) ||
        !isfinite(t1))
        return 0;
    const float min_step = p->min_step * fg->voxel / dlen;
    const float tol = p->tol * fg->voxel / dlen;
    /* G along this ray; INFINITY (or NaN from 0 * INFINITY) disables the global stride */
    float glip = 0.0f;
    for (int a = 0; a < 3; a++)
        glip += d[a] == 0.0f ? 0.0f : fg->gmax[a] * fabsf(d[a] * fg->scale[a]);
    const float ginv = glip > 0.0f && isfinite(glip) ? 1.0f / glip : 0.0f;
    unsigned flags = 0;
    float lip, ex;
    float t = t0;
    float f = esr_first_hit_probe(fg, o, d, t, &lip, &ex);
    if (f <= 0.0f) {
        flags |= ESR_FIRST_HIT_STARTED_INSIDE;
        if (p->inside == ESR_FIRST_HIT_INSIDE_REPORT) {
            *t_hit = t0;
            return flags | ESR_FIRST_HIT_HIT;
        }
    }
    for (int k = 0; k < p->max_steps; k++) {
        if (t >= t1)
            return flags;
        const float af = fabsf(f);
        float s = ex; /* lip == 0: constant cell, go to its exit */
        if (lip > 0.0f)
            s = esr_fh_min(af / lip, s);
        s = esr_fh_max(af * ginv, s) * p->safety; /* both are safe: take the longer */
        if (fg->block_min && f > 0.0f) /* so is crossing a block without surface */
            s = esr_fh_max(esr_first_hit_block_skip(fg, o, d, t), s);
        s = esr_fh_max(s, min_step);              /* also catches a NaN step */
        float tn = esr_fh_min(t + s, t1);
        if (!(tn > t)) /* t so large that the step rounds away: creep by one ulp */
            tn = esr_fh_min(nextafterf(t, INFINITY), t1);
        float fn = esr_first_hit_probe(fg, o, d, tn, &lip, &ex);
        if (f > 0.0f && fn <= 0.0f) {
            const struct esr_first_hit_bracket br = {t, f, tn, fn};
            *t_hit = esr_first_hit_refine(fg, o, d, &br, tol, p->refine_iters);
            return flags | ESR_FIRST_HIT_HIT;
        }
        t = tn;
        f = fn;
    }
    return t < t1 ? flags | ESR_FIRST_HIT_OUT_OF_STEPS : flags;
}

/* fg and p for shadow rays (esr_first_hit_segment_blocked) on the 1-channel grid g with values
 * sdf: the defaults with no refinement of the hit (a shadow ray only asks whether anything is in
 * the way), G and the blocks' minima computed once (free fg with esr_first_hit_grid_free).
 * Fails on a grid with channels != 1 or out of memory. */
int esr_first_hit_shadow_setup(struct esr_first_hit_grid *fg, struct esr_first_hit_params *p,
                               const struct esr_grid *g, const float *sdf);

/* Whether the SDF has a surface on the segment from a (a lit point, already offset off its
 * surface) to b (a light sample, already pulled back off the light): a shadow ray. It is
 * marched from b towards a, because most blocked shadow rays are blocked by the light's own
 * body (samples on the far side of a lampshade, a bulb seen through its shade) within a few
 * voxels of b, while from a the march first runs across the scene hugging surfaces; on lamp's
 * shadow rays (85% blocked) that is a third of the probes. An end inside the surface counts as
 * blocked either way. fg and p: from esr_first_hit_shadow_setup. */
ESR_INLINE int esr_first_hit_segment_blocked(const struct esr_first_hit_grid *fg,
                                             const struct esr_first_hit_params *p,
                                             const float a[3], const float b[3])
{
    const float d[3] = {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
    float t;
    return (esr_first_hit_ray(fg, p, b, d, 0.0f, 1.0f, &t) & ESR_FIRST_HIT_HIT) != 0;
}

#ifdef __cplusplus
}
#endif
#endif
