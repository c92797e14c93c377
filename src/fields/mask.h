/* The mask cache (METHOD.md stage 1): one byte per lattice point saying whether the space around
 * it may be occupied. Every later stage drops ray samples whose nearest lattice point is empty.
 * Built from the trained alphamask density grid (or from an SDF grid), then dilated so that thin
 * surfaces between lattice points are not cut. */
#ifndef ESR_FIELDS_MASK_H
#define ESR_FIELDS_MASK_H

#include <stddef.h>
#include <stdint.h>

#include "core/simd.h"
#include "fields/grid.h"

#ifdef __cplusplus
extern "C" {
#endif

struct esr_mask {
    int nx, ny, nz;
    float bmin[3], bmax[3];
    float scale[3];  /* (n - 1) / (bmax - bmin) per axis: world -> lattice coordinate */
    uint8_t *occ;    /* nx*ny*nz bytes, x fastest; 1 = possibly occupied; owned */
};

/* Allocates an all-occupied mask on the lattice of g (channels ignored). */
int esr_mask_alloc(struct esr_mask *m, const struct esr_grid *g);
void esr_mask_free(struct esr_mask *m);
/* Number of occupied lattice points. */
size_t esr_mask_count(const struct esr_mask *m);

/* occ = dilate(alpha(density) >= thres, radius): alpha from density.h with the given shift and
 * interval, dilation = max over the (2 radius + 1)^3 neighbourhood (DVGO uses radius 1).
 * g must have 1 channel and the same lattice as m. */
int esr_mask_from_density(struct esr_mask *m, const struct esr_grid *g, const float *density,
                          float shift, float interval, float thres, int radius);
/* occ = dilate(|sdf| <= band, radius); same lattice rules. */
int esr_mask_from_sdf(struct esr_mask *m, const struct esr_grid *g, const float *sdf, float band,
                      int radius);

/* The world box holding every point whose nearest lattice point is occupied (the occupied lattice
 * points' box, grown by a voxel: half for the rounding, half for margin); 0 when none is. */
int esr_mask_occupied_box(const struct esr_mask *m, float bmin[3], float bmax[3]);

/* Blocks of ESR_MASK_BLOCK^3 lattice points, x fastest, esr_mask_block_dims of them per axis
 * (ceil(n / ESR_MASK_BLOCK)): any[b] = 1 when one of block b's points is occupied. Marchers skip
 * the empty blocks whole (volume/sampler.h). any holds the product of the dims bytes. */
#define ESR_MASK_BLOCK 8
void esr_mask_block_dims(const struct esr_mask *m, int nb[3]);
void esr_mask_blocks(const struct esr_mask *m, uint8_t *any);

/* 1 when the lattice point nearest to p is occupied; 0 more than half a voxel outside the box.
 * Pure, per point. */
ESR_INLINE int esr_mask_query(const struct esr_mask *m, const float p[3])
{
    int i[3];
    const int n[3] = {m->nx, m->ny, m->nz};
    for (int a = 0; a < 3; a++) {
        float u = (p[a] - m->bmin[a]) * m->scale[a] + 0.5f;
        if (!(u >= 0.0f) || u >= (float)n[a])
            return 0;
        i[a] = (int)u;
    }
    return m->occ[((size_t)i[2] * (size_t)m->ny + (size_t)i[1]) * (size_t)m->nx + (size_t)i[0]];
}

#ifdef __cplusplus
}
#endif
#endif
