/* Helpers that build the built-in scenes of synth/scene.h, shared by the files that define them
 * (scene.c: default, glossy, capture; scenes_lights.c: the scenes that test the lights' strengths). */
#ifndef ESR_SYNTH_SCENE_BUILD_H
#define ESR_SYNTH_SCENE_BUILD_H

#include "synth/scene.h"

/* Appends a primitive of material *mat (its plain base colour; a texture may follow), not
 * emissive, named name (a string literal); a and b as esr_synth_prim's. */
struct esr_synth_prim *esr_synth_add_prim(struct esr_synth_scene *s, const char *name, enum esr_synth_prim_kind kind,
                                          struct esr_vec3 a, struct esr_vec3 b, const struct esr_material *mat);
/* The mirror-like metal of the scenes' chrome balls. */
extern const struct esr_material esr_synth_chrome;
/* Gives p a procedural texture of base colours 0 (its own) and (r, g, b). */
void esr_synth_set_texture(struct esr_synth_prim *p, enum esr_synth_texture tex, float r, float g, float b,
                           float period);
/* Makes p the next light: colour (r, g, b) (max channel 1) times strength when on. */
void esr_synth_add_light(struct esr_synth_scene *s, struct esr_synth_prim *p, float r, float g, float b,
                         float strength);
/* Clears s and sets the world light and the dataset defaults every scene starts from. */
void esr_synth_init_scene(struct esr_synth_scene *s, const char *name, const char *summary);

/* Scenes built to measure how strongly each light emits (scenes_lights.c). */
void esr_synth_build_bulbs(struct esr_synth_scene *s);
void esr_synth_build_vivid(struct esr_synth_scene *s);
void esr_synth_build_ratios(struct esr_synth_scene *s);
void esr_synth_build_shaded(struct esr_synth_scene *s);

#endif
