/* Built-in scenes of `esr synth`: analytic primitives with the seed's BRDF, emissive primitives
 * (one light each, colour V = 1 and an "on" strength) and a dim uniform world light. */
#ifndef ESR_SYNTH_SCENE_H
#define ESR_SYNTH_SCENE_H

#include "core/mesh.h"
#include "synth/prim.h"

#define ESR_SYNTH_MAX_PRIMS 24
#define ESR_SYNTH_MAX_LIGHTS 8

struct esr_synth_light {
    const char *name;
    float rgb[3];     /* linear emission colour, max channel 1 */
    float strength;   /* "on" emission strength; emitted radiance = rgb * strength */
    int prim;         /* the emissive primitive */
};

struct esr_synth_scene {
    const char *name;
    const char *summary;                  /* one line for `esr synth --scene list` */
    int n_prims;
    struct esr_synth_prim prims[ESR_SYNTH_MAX_PRIMS];
    int n_lights;
    struct esr_synth_light lights[ESR_SYNTH_MAX_LIGHTS];
    float world_rgb[3];                   /* uniform world colour (lights every image) */
    float world_strength;
    int max_bounces;                      /* path length limit (Russian roulette acts before) */
    /* Defaults of the dataset written for this scene. */
    int res, spp, n_train, n_test;        /* n_train views per lighting condition */
};

/* Number of built-in scenes and the i-th one's name (for listings). */
int esr_synth_scene_count(void);
const char *esr_synth_scene_name(int i);
/* Builds the scene called name into *out; fails naming the scene and the known ones. */
int esr_synth_scene_get(const char *name, struct esr_synth_scene *out);

/* Axis-aligned bounds of all primitives. */
void esr_synth_scene_bounds(const struct esr_synth_scene *s, float lo[3], float hi[3]);

/* Triangle mesh of every primitive (closed, outward-facing, one connected shell per primitive),
 * for surface ground truth (Chamfer distance). `segments` sets the tessellation (>= 8). */
int esr_synth_scene_mesh(const struct esr_synth_scene *s, int segments, struct esr_mesh *out);

#endif
