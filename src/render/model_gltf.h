/* The trained scene as a relightable glTF asset (`esr export --gltf`; the seed names it as future
 * work, the authors export a PLY only): the marching-cubes surface (render/model_mesh.h) with the
 * reconstructed base colour per vertex (COLOR_0; the radiance colour for a model before lts),
 * split into a few materials by the roughness and metallic the model gives its triangles
 * (weighted k-means, core/kmeans.h: every renderer reads a material's factors, while few read
 * per-vertex roughness), and each light found (model/lights.h) as its own named
 * node ("light_<id>") whose triangles emit its calibrated radiance: emissiveFactor = colour /
 * its largest channel, KHR_materials_emissive_strength = that channel (linear HDR). A triangle
 * belongs to a light when its centroid does. Any glTF viewer can then turn lights up, down or
 * off by their node. Coordinates are converted to glTF's +Y up (the scene's +Z up becomes +Y). */
#ifndef ESR_RENDER_MODEL_GLTF_H
#define ESR_RENDER_MODEL_GLTF_H

#include "model/model.h"

/* material clusters: centres at least this far apart in (roughness, metallic), each at least
 * this share of the surface's area */
#define ESR_GLTF_MATERIAL_SEPARATION 0.1f
#define ESR_GLTF_MATERIAL_MIN_SHARE 0.01f
#define ESR_GLTF_MAX_MATERIALS 16

struct esr_gltf_options {
    int res;           /* as esr_model_mesh's (0 = the model's grid) */
    int max_materials; /* 1..ESR_GLTF_MAX_MATERIALS: the surface's materials at most */
};

struct esr_gltf_summary {
    int light_nodes; /* bit k set when light k got its node; a light no triangle's centroid
                        falls on (a small one at a low res) gets none: a glTF mesh needs
                        triangles */
    int n_materials; /* the surface's */
    float roughness[ESR_GLTF_MAX_MATERIALS], metallic[ESR_GLTF_MAX_MATERIALS];
    float share[ESR_GLTF_MAX_MATERIALS]; /* of the surface's area */
};

int esr_model_gltf_write(const struct esr_model *m, const struct esr_gltf_options *o,
                         const char *path, struct esr_gltf_summary *out);

#endif
