/* Mask cache construction: threshold a density or SDF grid, then dilate. */
#include "fields/mask.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "fields/density.h"

int esr_mask_alloc(struct esr_mask *m, const struct esr_grid *g)
{
    memset(m, 0, sizeof(*m));
    size_t n = esr_grid_voxels(g);
    m->occ = (uint8_t *)malloc(n);
    if (!m->occ)
        return ESR_FAIL("mask cache: out of memory for %zu voxels", n);
    memset(m->occ, 1, n);
    m->nx = g->nx;
    m->ny = g->ny;
    m->nz = g->nz;
    for (int a = 0; a < 3; a++) {
        m->bmin[a] = g->bmin[a];
        m->bmax[a] = g->bmax[a];
        m->scale[a] = 1.0f / esr_grid_voxel_size(g, a);
    }
    return ESR_OK;
}

void esr_mask_free(struct esr_mask *m)
{
    free(m->occ);
    memset(m, 0, sizeof(*m));
}

size_t esr_mask_count(const struct esr_mask *m)
{
    size_t n = (size_t)m->nx * m->ny * m->nz, count = 0;
#pragma omp parallel for reduction(+ : count) schedule(static)
    for (size_t i = 0; i < n; i++)
        count += m->occ[i] != 0;
    return count;
}

int esr_mask_occupied_box(const struct esr_mask *m, float bmin[3], float bmax[3])
{
    int lo[3] = {m->nx, m->ny, m->nz}, hi[3] = {-1, -1, -1};
    for (int z = 0; z < m->nz; z++)
        for (int y = 0; y < m->ny; y++) {
            const uint8_t *row = m->occ + ((size_t)z * (size_t)m->ny + (size_t)y) * (size_t)m->nx;
            uint8_t any = 0; /* most rows are empty: OR them first (vectorises) */
            for (int x = 0; x < m->nx; x++)
                any |= row[x];
            if (!any)
                continue;
            int x0 = 0, last = m->nx - 1;
            while (!row[x0])
                x0++;
            while (!row[last])
                last--;
            const int at[3] = {x0, y, z}, at_hi[3] = {last, y, z};
            for (int a = 0; a < 3; a++) {
                lo[a] = at[a] < lo[a] ? at[a] : lo[a];
                hi[a] = at_hi[a] > hi[a] ? at_hi[a] : hi[a];
            }
        }
    if (hi[0] < 0)
        return 0;
    for (int a = 0; a < 3; a++) {
        bmin[a] = m->bmin[a] + ((float)lo[a] - 1.0f) / m->scale[a];
        bmax[a] = m->bmin[a] + ((float)hi[a] + 1.0f) / m->scale[a];
    }
    return 1;
}

void esr_mask_block_dims(const struct esr_mask *m, int nb[3])
{
    nb[0] = (m->nx + ESR_MASK_BLOCK - 1) / ESR_MASK_BLOCK;
    nb[1] = (m->ny + ESR_MASK_BLOCK - 1) / ESR_MASK_BLOCK;
    nb[2] = (m->nz + ESR_MASK_BLOCK - 1) / ESR_MASK_BLOCK;
}

void esr_mask_blocks(const struct esr_mask *m, uint8_t *any)
{
    int nb[3];
    esr_mask_block_dims(m, nb);
    memset(any, 0, (size_t)nb[0] * (size_t)nb[1] * (size_t)nb[2]);
    for (int z = 0; z < m->nz; z++)
        for (int y = 0; y < m->ny; y++) {
            const uint8_t *row = m->occ + ((size_t)z * (size_t)m->ny + (size_t)y) * (size_t)m->nx;
            uint8_t *out = any + ((size_t)(z / ESR_MASK_BLOCK) * (size_t)nb[1] +
                                  (size_t)(y / ESR_MASK_BLOCK)) * (size_t)nb[0];
            for (int x = 0; x < m->nx; x++)
                out[x / ESR_MASK_BLOCK] |= row[x] != 0;
        }
}

static int check_lattice(const struct esr_mask *m, const struct esr_grid *g)
{
    if (g->channels != 1)
        return ESR_FAIL("mask cache: source grid must have 1 channel, has %d", g->channels);
    if (!m->occ || g->nx != m->nx || g->ny != m->ny || g->nz != m->nz)
        return ESR_FAIL("mask cache: source grid %dx%dx%d does not match the mask's %dx%dx%d", g->nx,
                        g->ny, g->nz, m->nx, m->ny, m->nz);
    return ESR_OK;
}

/* occ = max over the (2r+1)^3 neighbourhood of seed (separable: one axis at a time). */
static int dilate(struct esr_mask *m, uint8_t *seed, int r)
{
    if (r < 0)
        return ESR_FAIL("mask cache: dilation radius %d must be >= 0", r);
    const int n[3] = {m->nx, m->ny, m->nz};
    const size_t s[3] = {1, (size_t)m->nx, (size_t)m->nx * m->ny};
    uint8_t *bufs[2] = {seed, m->occ};
    for (int axis = 0; axis < 3; axis++) {
        const uint8_t *src = bufs[axis % 2];
        uint8_t *dst = bufs[(axis + 1) % 2];
#pragma omp parallel for schedule(static)
        for (int iz = 0; iz < n[2]; iz++)
            for (int iy = 0; iy < n[1]; iy++)
                for (int ix = 0; ix < n[0]; ix++) {
                    const int i[3] = {ix, iy, iz};
                    size_t v = ix + s[1] * iy + s[2] * iz;
                    uint8_t any = 0;
                    for (int k = -r; k <= r && !any; k++) {
                        int j = i[axis] + k;
                        if (j >= 0 && j < n[axis])
                            any = src[v + (ptrdiff_t)k * (ptrdiff_t)s[axis]];
                    }
                    dst[v] = any ? 1 : 0;
                }
    }
    /* three passes: seed -> occ -> seed -> occ, so the result is in m->occ */
    return ESR_OK;
}

/* Shared body: seed[v] = occupied(v), then dilate into m->occ. */
static int build(struct esr_mask *m, const struct esr_grid *g, const float *field, int kind,
                 float a, float b, float c, int r)
{
    ESR_TRY(check_lattice(m, g));
    size_t n = esr_grid_voxels(g);
    uint8_t *seed = (uint8_t *)malloc(n);
    if (!seed)
        return ESR_FAIL("mask cache: out of memory for %zu voxels", n);
#pragma omp parallel for schedule(static)
    for (size_t v = 0; v < n; v++)
        seed[v] = kind == 0 ? esr_density_alpha_fwd(field[v], a, b) >= c : fabsf(field[v]) <= a;
    int rc = dilate(m, seed, r);
    free(seed);
    return rc;
}

int esr_mask_from_density(struct esr_mask *m, const struct esr_grid *g, const float *density,
                          float shift, float interval, float thres, int radius)
{
    return build(m, g, density, 0, shift, interval, thres, radius);
}

int esr_mask_from_sdf(struct esr_mask *m, const struct esr_grid *g, const float *sdf, float band,
                      int radius)
{
    return build(m, g, sdf, 1, band, 0.0f, 0.0f, radius);
}
