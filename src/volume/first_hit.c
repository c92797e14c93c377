/* Batch first-hit queries: the per-ray marcher of first_hit.h over rays in parallel. */
#include "volume/first_hit.h"

#include <math.h>
#include <stdlib.h>

#include "core/error.h"
#include "fields/trilerp.h"

void esr_first_hit_params_init(struct esr_first_hit_params *p, const struct esr_grid *g)
{
    p->max_steps = 4 * (g->nx + g->ny + g->nz) + 256;
    p->safety = 1.0f;
    p->min_step = 0.02f;
    p->tol = 1e-4f;
    p->refine_iters = 24;
    p->inside = ESR_FIRST_HIT_INSIDE_REPORT;
    p->global_bound = 1;
}

/* One pass over the grid: fg->block_min[b], block b's smallest lattice value, faces included, and
 * with want_g, fg->gmax = G, the largest |difference| between lattice neighbours along each axis,
 * a bound on the trilinear field's partial derivatives (lattice units) anywhere in the box. A NaN
 * value is passed over: the cells it is a corner of interpolate to NaN everywhere, where no sign
 * change is ever seen, so skipping them finds what marching them finds. A task per row of blocks
 * (by, bz) streams its lattice rows (the faces' rows are read by the neighbouring tasks too) into
 * per-column minima and maxima, elementwise so they vectorise, and reduces those per block. */
ESR_HOT static void grid_bounds(const struct esr_grid *g, const float *v, int want_g,
                                struct esr_first_hit_grid *fg)
{
    enum { B = ESR_FIRST_HIT_BLOCK, XB = 32, XW = B * XB + 1 }; /* x-blocks, lattice columns per chunk */
    const int nx = g->nx, nbx = fg->nb[0], nby = fg->nb[1], nbz = fg->nb[2];
    const size_t sy = fg->sy, sz = fg->sz;
    float gx = 0.0f, gy = 0.0f, gz = 0.0f;
#pragma omp parallel for collapse(2) schedule(static) reduction(max : gx, gy, gz)
    for (int bz = 0; bz < nbz; bz++)
        for (int by = 0; by < nby; by++) {
            const int y0 = by * B, z0 = bz * B;
            const int y1 = y0 + B < g->ny - 1 ? y0 + B : g->ny - 1;
            const int z1 = z0 + B < g->nz - 1 ? z0 + B : g->nz - 1;
            float *out = fg->block_min + ((size_t)bz * (size_t)nby + (size_t)by) * (size_t)nbx;
            for (int c0 = 0; c0 < nbx; c0 += XB) {
                const int c1 = c0 + XB < nbx ? c0 + XB : nbx;
                const int xa = c0 * B, w = (c1 * B < nx - 1 ? c1 * B : nx - 1) - xa + 1;
                float cmin[XW], cg[3][XW];
                for (int x = 0; x < w; x++)
                    cmin[x] = INFINITY, cg[0][x] = cg[1][x] = cg[2][x] = 0.0f;
                for (int z = z0; z <= z1; z++)
                    for (int y = y0; y <= y1; y++) {
                        const float *row = v + (size_t)z * sz + (size_t)y * sy + (size_t)xa;
                        for (int x = 0; x < w; x++)
                            cmin[x] = esr_fh_min(row[x], cmin[x]);
                        if (!want_g)
                            continue;
                        for (int x = 0; x + 1 < w; x++)
                            cg[0][x] = esr_fh_max(fabsf(row[x + 1] - row[x]), cg[0][x]);
                        if (y < y1)
                            for (int x = 0; x < w; x++)
                                cg[1][x] = esr_fh_max(fabsf(row[x + sy] - row[x]), cg[1][x]);
                        if (z < z1)
                            for (int x = 0; x < w; x++)
                                cg[2][x] = esr_fh_max(fabsf(row[x + sz] - row[x]), cg[2][x]);
                    }
                for (int bx = c0; bx < c1; bx++) {
                    const int e = (bx + 1) * B - xa < w - 1 ? (bx + 1) * B - xa : w - 1;
                    float m = INFINITY;
                    for (int x = bx * B - xa; x <= e; x++)
                        m = esr_fh_min(cmin[x], m);
                    out[bx] = m;
                }
                for (int x = 0; x < w; x++) {
                    gx = esr_fh_max(cg[0][x], gx);
                    gy = esr_fh_max(cg[1][x], gy);
                    gz = esr_fh_max(cg[2][x], gz);
                }
            }
        }
    if (want_g) {
        fg->gmax[0] = gx;
        fg->gmax[1] = gy;
        fg->gmax[2] = gz;
    }
}

int esr_first_hit_grid_prepare(struct esr_first_hit_grid *fg, const struct esr_grid *g,
                               const float *data, int global_bound_on)
{
    esr_first_hit_grid_init(fg, g, data);
    for (int a = 0; a < 3; a++) /* cells n - 1 per axis, in blocks of B */
        fg->nb[a] = (fg->n[a] - 2) / ESR_FIRST_HIT_BLOCK + 1;
    fg->block_min = malloc((size_t)fg->nb[0] * (size_t)fg->nb[1] * (size_t)fg->nb[2] * sizeof(float));
    if (!fg->block_min)
        return ESR_FAIL("first hit: out of memory for the block minima of a %dx%dx%d grid", g->nx,
                        g->ny, g->nz);
    grid_bounds(g, data, global_bound_on, fg);
    return ESR_OK;
}

void esr_first_hit_grid_free(struct esr_first_hit_grid *fg)
{
    free(fg->block_min);
    fg->block_min = NULL;
}

int esr_first_hit_shadow_setup(struct esr_first_hit_grid *fg, struct esr_first_hit_params *p,
                               const struct esr_grid *g, const float *sdf)
{
    if (g->channels != 1)
        return ESR_FAIL("shadow rays: the SDF grid must have 1 channel, not %d", g->channels);
    esr_first_hit_params_init(p, g);
    p->refine_iters = 0;
    return esr_first_hit_grid_prepare(fg, g, sdf, p->global_bound);
}

ESR_HOT static void first_hit_batch(const struct esr_grid *g, const struct esr_first_hit_grid *fg,
                                    const struct esr_first_hit_params *p,
                                    const struct esr_first_hit_rays *rays,
                                    const struct esr_first_hit_out *out)
{
    const size_t n = rays->n;
    /* rays near surfaces cost many more steps than rays through empty space: dynamic chunks.
     * Each ray writes only its own outputs, so the result does not depend on the schedule. */
#pragma omp parallel for schedule(dynamic, 64)
    for (size_t i = 0; i < n; i++) {
        const float *o = rays->origins + i * 3, *d = rays->dirs + i * 3;
        float t_min = rays->t_min ? rays->t_min[i] : 0.0f;
        float t_max = rays->t_max ? rays->t_max[i] : INFINITY;
        float t;
        unsigned flags = esr_first_hit_ray(fg, p, o, d, t_min, t_max, &t);
        int hit = (flags & ESR_FIRST_HIT_HIT) != 0;
        float pos[3] = {0.0f, 0.0f, 0.0f};
        if (hit)
            for (int a = 0; a < 3; a++)
                pos[a] = o[a] + t * d[a];
        if (out->t)
            out->t[i] = t;
        if (out->flags)
            out->flags[i] = (uint8_t)flags;
        if (out->pos)
            for (int a = 0; a < 3; a++)
                out->pos[i * 3 + a] = pos[a];
        if (out->normal) {
            float nrm[3] = {0.0f, 0.0f, 0.0f};
            if (hit) {
                /* the same kernel as esr_grid_sample_value_dpoint, so normals agree with it */
                struct esr_trilerp tl;
                esr_trilerp_locate(g, pos, &tl);
                (void)esr_trilerp_value_dpoint(fg->data, &tl, nrm);
                float len = sqrtf(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
                float inv = len > 0.0f ? 1.0f / len : 0.0f;
                for (int a = 0; a < 3; a++)
                    nrm[a] *= inv;
            }
            for (int a = 0; a < 3; a++)
                out->normal[i * 3 + a] = nrm[a];
        }
    }
}

int esr_first_hit(const struct esr_grid *g, const float *sdf, const struct esr_first_hit_params *p,
                  const struct esr_first_hit_rays *rays, const struct esr_first_hit_out *out)
{
    if (g->channels != 1)
        return ESR_FAIL("first hit: the SDF grid must have 1 channel, not %d", g->channels);
    if (p->max_steps < 1 || !(p->safety > 0.0f && p->safety <= 1.0f) || !(p->min_step > 0.0f) ||
        !(p->tol > 0.0f) || p->refine_iters < 0 ||
        (p->inside != ESR_FIRST_HIT_INSIDE_REPORT && p->inside != ESR_FIRST_HIT_INSIDE_SKIP) ||
        (p->global_bound != 0 && p->global_bound != 1))
        return ESR_FAIL("first hit: bad parameters (max_steps %d, safety %g in (0, 1], min_step "
                        "%g, tol %g, refine_iters %d, inside mode %d, global_bound %d)",
                        p->max_steps, (double)p->safety, (double)p->min_step, (double)p->tol,
                        p->refine_iters, p->inside, p->global_bound);
    if (rays->n == 0)
        return ESR_OK;
    if (!sdf || !rays->origins || !rays->dirs)
        return ESR_FAIL("first hit: %s missing", !sdf ? "SDF values" : "ray origins or directions");
    struct esr_first_hit_grid fg;
    ESR_TRY(esr_first_hit_grid_prepare(&fg, g, sdf, p->global_bound));
    first_hit_batch(g, &fg, p, rays, out);
    esr_first_hit_grid_free(&fg);
    return ESR_OK;
}
