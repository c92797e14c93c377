/* Free space seen by the cameras: the lattice points of a grid that some camera ray passes
 * through before it reaches the surface (space carving).
 *
 * Why: an SDF trained from images has sign changes where no camera looks (bubbles inside
 * solids, the underside of a floor slab, the space under it), and the fields defined there (E,
 * the BRDF) are never constrained. A surface point counts as part of the scene's outer surface
 * only when the free space touches its outside (the point moved a little along its normal);
 * lights built from unseen surfaces would add area that casts no light (esr lights).
 *
 * A ray marks every lattice point it passes (nearest point, half-voxel steps) from where it
 * enters the grid's box to margin voxels before its first hit on the zero level set (to the
 * box's exit when it hits nothing). Deterministic; parallel over rays. */
#ifndef ESR_VOLUME_FREE_SPACE_H
#define ESR_VOLUME_FREE_SPACE_H

#include <stddef.h>
#include <stdint.h>

#include "fields/grid.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Rays carved at most; a larger ray set is thinned evenly. */
#define ESR_FREE_SPACE_MAX_RAYS (1u << 20)

/* free_out[lattice index] = 1 where a ray (orig3/dir3 [n*3], unit directions) passed, else 0;
 * free_out holds esr_grid_voxels(g) bytes. sdf is g's 1-channel data (f > 0 outside). */
int esr_free_space_carve(const struct esr_grid *g, const float *sdf, const float *orig3,
                         const float *dir3, size_t n, float margin_voxels, uint8_t *free_out);

/* 1 when p lies in a cell of g with a free corner. */
int esr_free_space_at(const struct esr_grid *g, const uint8_t *free_mask, const float p[3]);

#ifdef __cplusplus
}
#endif
#endif
