/* The trained scene as a relightable glTF asset (`esr export --gltf`; the seed names it as future
 * work, the authors export a PLY only): the marching-cubes surface (render/model_mesh.h) with the
 * reconstructed base colour per vertex (COLOR_0; the radiance colour for a model before lts),
 * mean roughness and metallic as factors, and each light found (model/lights.h) as its own named
 * node ("light_<id>") whose triangles emit its calibrated radiance: emissiveFactor = colour /
 * its largest channel, KHR_materials_emissive_strength = that channel (linear HDR). A triangle
 * belongs to a light when its centroid does. Any glTF viewer can then turn lights up, down or
 * off by their node. Coordinates are converted to glTF's +Y up (the scene's +Z up becomes +Y). */
#ifndef ESR_RENDER_MODEL_GLTF_H
#define ESR_RENDER_MODEL_GLTF_H

#include "model/model.h"

/* res as esr_model_mesh's (0 = the model's grid). *light_nodes: bit k set when light k got its
 * node; a light no triangle's centroid falls on (a small one at a low res) gets none, since a
 * glTF mesh needs triangles. */
int esr_model_gltf_write(const struct esr_model *m, int res, const char *path, int *light_nodes);

#endif
