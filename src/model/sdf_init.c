/* Signed chamfer distance from alphamask occupancy (see sdf_init.h). */
#include "model/sdf_init.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "fields/density.h"
#include "fields/grid.h"
#include "fields/sdf.h"
#include "model/render_sdf.h"

/* One forward (or backward) sweep of the 26-neighbour chamfer transform: every voxel takes the
 * minimum over its already-visited neighbours of their distance plus the step length. */
static void sweep(float *d, int nx, int ny, int nz, int dir)
{
    int z0 = dir > 0 ? 0 : nz - 1, z1 = dir > 0 ? nz : -1;
    int y0 = dir > 0 ? 0 : ny - 1, y1 = dir > 0 ? ny : -1;
    int x0 = dir > 0 ? 0 : nx - 1, x1 = dir > 0 ? nx : -1;
    for (int z = z0; z != z1; z += dir)
        for (int y = y0; y != y1; y += dir)
            for (int x = x0; x != x1; x += dir) {
                size_t i = ((size_t)z * ny + y) * nx + x;
                float best = d[i];
                /* the 13 neighbours that precede (x, y, z) in this sweep order */
                for (int dz = -1; dz <= 0; dz++)
                    for (int dy = -1; dy <= 1; dy++)
                        for (int dx = -1; dx <= 1; dx++) {
                            if (dz == 0 && (dy > 0 || (dy == 0 && dx >= 0)))
                                continue;
                            int qx = x + dx * dir, qy = y + dy * dir, qz = z + dz * dir;
                            if (qx < 0 || qy < 0 || qz < 0 || qx >= nx || qy >= ny || qz >= nz)
                                continue;
                            float step = sqrtf((float)(dx * dx + dy * dy + dz * dz));
                            float v = d[((size_t)qz * ny + qy) * nx + qx] + step;
                            if (v < best)
                                best = v;
                        }
                d[i] = best;
            }
}

/* Distance (in voxels) from every voxel to the nearest voxel where seed[i] is set. */
static void chamfer(const unsigned char *seed, float *d, int nx, int ny, int nz)
{
    size_t n = (size_t)nx * ny * nz;
    for (size_t i = 0; i < n; i++)
        d[i] = seed[i] ? 0.0f : 1e9f;
    sweep(d, nx, ny, nz, 1);
    sweep(d, nx, ny, nz, -1);
}

int esr_sdf_init_from_density(struct esr_model *m, const struct esr_model *prev, float alpha_thres,
                              int *used)
{
    *used = 0;
    const struct esr_grid *g = esr_model_grid(m, ESR_COMP_SDF);
    size_t n = esr_grid_voxels(g);
    float *dens = malloc(n * sizeof(float)), *d_out = malloc(n * sizeof(float)),
          *d_in = malloc(n * sizeof(float));
    unsigned char *occ = malloc(n), *free_ = malloc(n);
    int rc = dens && d_out && d_in && occ && free_ ? ESR_OK
                                                   : ESR_FAIL("SDF init: out of memory");
    if (rc == ESR_OK)
        rc = esr_grid_resample(esr_model_grid(prev, ESR_COMP_DENSITY), esr_model_values(prev, ESR_COMP_DENSITY), g,
                               dens);
    size_t inside = 0;
    if (rc == ESR_OK) {
        for (size_t i = 0; i < n; i++) {
            float a = esr_density_alpha_fwd(dens[i], prev->density_shift,
                                            prev->cfg.alphamask.step_vox);
            occ[i] = a > alpha_thres;
            free_[i] = !occ[i];
            inside += occ[i];
        }
    }
    if (rc == ESR_OK && inside > 0 && inside < n) {
        chamfer(occ, d_out, g->nx, g->ny, g->nz);
        chamfer(free_, d_in, g->nx, g->ny, g->nz);
        float vs = esr_grid_voxel_size(g, 0);
        float *sdf = esr_model_values(m, ESR_COMP_SDF);
        for (size_t i = 0; i < n; i++)
            sdf[i] = (occ[i] ? -(d_in[i] - 0.5f) : d_out[i] - 0.5f) * vs;
        *used = 1;
    }
    free(dens);
    free(d_out);
    free(d_in);
    free(occ);
    free(free_);
    return rc;
}

int esr_mask_narrow_to_sdf(struct esr_model *m, const struct esr_model *prev, float band)
{
    struct esr_mask *k = &m->mask;
    size_t nv = (size_t)k->nx * k->ny * k->nz, ns = esr_grid_count(esr_model_grid(prev, ESR_COMP_SDF));
    float *view = malloc(ns * sizeof(float)), *scratch = malloc(ns * sizeof(float));
    float *pos = malloc(nv * 3 * sizeof(float)), *val = malloc(nv * sizeof(float));
    float *grad = malloc(nv * 3 * sizeof(float));
    int rc = view && scratch && pos && val && grad ? ESR_OK : ESR_FAIL("mask narrowing: out of memory");
    if (rc == ESR_OK)
        rc = esr_model_view_sdf(prev, esr_model_values(prev, ESR_COMP_SDF), view, scratch);
    if (rc == ESR_OK) {
        struct esr_grid lat;
        rc = esr_grid_init(&lat, 1, k->nx, k->ny, k->nz, k->bmin, k->bmax);
        for (int z = 0; rc == ESR_OK && z < k->nz; z++)
            for (int y = 0; y < k->ny; y++)
                for (int x = 0; x < k->nx; x++)
                    esr_grid_voxel_pos(&lat, x, y, z, pos + (((size_t)z * k->ny + y) * k->nx + x) * 3);
    }
    if (rc == ESR_OK) {
        esr_grid_sample_value_dpoint(esr_model_grid(prev, ESR_COMP_SDF), view, pos, nv, val, grad);
#pragma omp parallel for schedule(static)
        for (size_t i = 0; i < nv; i++) {
            /* The grid SDF is not metric (no eikonal loss; the smoothed-gradient TV flattens it),
             * so |f| alone overstates the band where the slope is below 1. Keep a voxel only
             * when both |f| and the first-order distance estimate |f| / |grad f| are within the
             * band: the estimate is what keeps the band tight, |f| guards flat regions. */
            const float *g = grad + i * 3;
            float slope = sqrtf(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
            float f = fabsf(val[i]);
            k->occ[i] = k->occ[i] && f <= band && f <= band * slope;
        }
    }
    free(view);
    free(scratch);
    free(pos);
    free(val);
    free(grad);
    return rc;
}
