/* The surface of a trained model as a mesh (`esr export`): marching cubes on the model's SDF grid
 * (level 0), optionally resampled first, with vertex normals and colours from the model. */
#ifndef ESR_RENDER_MODEL_MESH_H
#define ESR_RENDER_MODEL_MESH_H

#include "core/mesh.h"
#include "model/model.h"

#define ESR_MODEL_MESH_RES_MIN 8
#define ESR_MODEL_MESH_RES_MAX 1024

/* Extracts the zero level set of the model's SDF grid (esr_model_sdf_grid) as renders show it:
 * no surface in space the renderer skips (model/render_sdf.h, esr_model_first_hit_sdf). res = 0
 * uses that lattice as it is; else the SDF is first trilinearly resampled to res^3 lattice
 * points over the same box (res in ESR_MODEL_MESH_RES_MIN..MAX). Normals point out of the surface (increasing
 * SDF). With `colours`, each vertex gets the model's linear radiance with the lights off, clipped
 * to [0,1], seen along its normal: a ray starting 3 SDF voxels outside the vertex and looking
 * back at it (the model API has no point query, so the colour is what that short ray renders;
 * opacity below 1 blends in the white background). *out is overwritten; free it with
 * esr_mesh_free (also after an error). Fails when the model has no SDF (alphamask stage). */
int esr_model_mesh(const struct esr_model *m, int res, int colours, struct esr_mesh *out);

#endif
