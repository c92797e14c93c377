/* Marching cubes (Lorensen & Cline 1987) on a 1-channel grid: the `level` iso-surface as an
 * indexed triangle mesh. The case table is generated from the cube-face contours (see
 * marching_cubes.c) with face ambiguities resolved consistently between neighbouring cells, and
 * vertices on shared cube edges are shared, so a surface that does not leave the grid gives a
 * closed, consistently oriented mesh (triangles face increasing field). Vertex normals are the
 * normalised trilinear gradient of the field, or where that is zero or points against the
 * vertex's triangles (a sheet thinner than a voxel) their area-weighted normal. */
#ifndef ESR_VOLUME_MARCHING_CUBES_H
#define ESR_VOLUME_MARCHING_CUBES_H

#include "fields/grid.h"
#include "core/mesh.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Extracts the level set of channel 0 of g (g->channels must be 1). *out is overwritten; free it
 * with esr_mesh_free (also after an error). An empty surface gives an empty mesh. */
int esr_marching_cubes(const struct esr_grid *g, const float *field, float level,
                       struct esr_mesh *out);

#ifdef __cplusplus
}
#endif
#endif
