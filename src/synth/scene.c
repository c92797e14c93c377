#include "synth/scene.h"

#include <stdio.h>
#include <string.h>

#include "core/error.h"
#include "synth/scene_build.h"

static struct esr_synth_prim *add_prim(struct esr_synth_scene *s, const char *name, enum esr_synth_prim_kind kind,
                                       struct esr_vec3 a, struct esr_vec3 b, const struct esr_material *mat)
{
    struct esr_synth_prim *p = &s->prims[s->n_prims++];
    memset(p, 0, sizeof *p);
    p->kind = kind;
    p->a = a;
    p->b = b;
    p->mat = *mat;
    p->texture = ESR_SYNTH_TEX_NONE;
    p->light = -1;
    p->name = name;
    return p;
}

static void set_texture(struct esr_synth_prim *p, enum esr_synth_texture tex, float r, float g, float b, float period)
{
    p->texture = tex;
    p->base2[0] = r;
    p->base2[1] = g;
    p->base2[2] = b;
    p->tex_period = period;
}

static void add_light(struct esr_synth_scene *s, struct esr_synth_prim *p, float r, float g, float b, float strength)
{
    struct esr_synth_light *l = &s->lights[s->n_lights];
    p->light = s->n_lights++;
    l->name = p->name;
    l->rgb[0] = r;
    l->rgb[1] = g;
    l->rgb[2] = b;
    l->strength = strength;
    l->prim = (int)(p - s->prims);
}

/* World light and render settings shared by all scenes (the lamp scene's world). */
static void init_scene(struct esr_synth_scene *s, const char *name, const char *summary)
{
    memset(s, 0, sizeof *s);
    s->name = name;
    s->summary = summary;
    s->world_rgb[0] = 0.55f;
    s->world_rgb[1] = 0.65f;
    s->world_rgb[2] = 1.0f;
    s->world_strength = 0.25f;
    s->max_bounces = 8;
    s->res = 100;
    s->spp = 96;
    s->n_train = 50;
    s->n_test = 10;
}

const struct esr_material esr_synth_chrome = {{0.95f, 0.95f, 0.95f}, 0.05f, 1.0f};

/* The helpers under the names scene_build.h gives them (scenes_lights.c builds with them). */
struct esr_synth_prim *esr_synth_add_prim(struct esr_synth_scene *s, const char *name, enum esr_synth_prim_kind kind,
                                          struct esr_vec3 a, struct esr_vec3 b, const struct esr_material *mat)
{
    return add_prim(s, name, kind, a, b, mat);
}

void esr_synth_set_texture(struct esr_synth_prim *p, enum esr_synth_texture tex, float r, float g, float b,
                           float period)
{
    set_texture(p, tex, r, g, b, period);
}

void esr_synth_add_light(struct esr_synth_scene *s, struct esr_synth_prim *p, float r, float g, float b,
                         float strength)
{
    add_light(s, p, r, g, b, strength);
}

void esr_synth_init_scene(struct esr_synth_scene *s, const char *name, const char *summary)
{
    init_scene(s, name, summary);
}

/* A checkered floor slab, a warm lamp (pole + emissive shade), a small blue emissive orb and a few
 * diffuse and glossy objects. */
static void build_default(struct esr_synth_scene *s)
{
    init_scene(s, "default", "floor disc, warm lamp shade + blue orb (2 lights), diffuse and glossy objects");
    struct esr_synth_prim *p;
    p = add_prim(s, "floor", ESR_SYNTH_CYLINDER, esr_v3(0, 0, -0.06f), esr_v3(1.2f, 0.06f, 0),
                 &(struct esr_material){{0.75f, 0.72f, 0.65f}, 0.7f, 0.0f});
    set_texture(p, ESR_SYNTH_TEX_CHECKER, 0.2f, 0.22f, 0.25f, 0.25f);
    add_prim(s, "lamp_pole", ESR_SYNTH_CYLINDER, esr_v3(-0.55f, 0.4f, 0), esr_v3(0.03f, 0.62f, 0),
             &(struct esr_material){{0.6f, 0.6f, 0.6f}, 0.3f, 1.0f});
    p = add_prim(s, "lampshade", ESR_SYNTH_CYLINDER, esr_v3(-0.55f, 0.4f, 0.62f), esr_v3(0.2f, 0.22f, 0),
                 &(struct esr_material){{0.85f, 0.8f, 0.65f}, 0.8f, 0.0f});
    add_light(s, p, 1.0f, 0.8f, 0.55f, 8.0f);
    p = add_prim(s, "orb", ESR_SYNTH_SPHERE, esr_v3(0.6f, -0.45f, 0.14f), esr_v3(0.14f, 0, 0),
                 &(struct esr_material){{0.6f, 0.7f, 0.8f}, 0.4f, 0.0f});
    add_light(s, p, 0.2f, 0.5f, 1.0f, 12.0f);
    add_prim(s, "red_ball", ESR_SYNTH_SPHERE, esr_v3(0.15f, 0.05f, 0.32f), esr_v3(0.32f, 0, 0),
             &(struct esr_material){{0.8f, 0.15f, 0.1f}, 0.6f, 0.0f});
    add_prim(s, "metal_ball", ESR_SYNTH_SPHERE, esr_v3(-0.35f, -0.6f, 0.22f), esr_v3(0.22f, 0, 0),
             &(struct esr_material){{0.95f, 0.85f, 0.6f}, 0.25f, 1.0f});
    p = add_prim(s, "striped_box", ESR_SYNTH_BOX, esr_v3(0.35f, 0.4f, 0), esr_v3(0.75f, 0.8f, 0.4f),
                 &(struct esr_material){{0.9f, 0.85f, 0.2f}, 0.5f, 0.0f});
    set_texture(p, ESR_SYNTH_TEX_STRIPES, 0.1f, 0.3f, 0.7f, 0.1f);
    add_prim(s, "green_post", ESR_SYNTH_CYLINDER, esr_v3(-0.75f, -0.1f, 0), esr_v3(0.13f, 0.5f, 0),
             &(struct esr_material){{0.15f, 0.6f, 0.2f}, 0.35f, 0.0f});
}

/* The default scene as a real capture would show it: every surface but the lights' carries
 * non-repeating fractal noise. A checker and stripes repeat, so a feature matcher (COLMAP) places
 * some cameras at a wrong, look-alike pose; plain-coloured objects give it nothing, so the low
 * views, which see the floor edge-on, go unregistered. */
static void build_capture(struct esr_synth_scene *s)
{
    build_default(s);
    s->name = "capture";
    s->summary = "the default scene with non-repeating (noise) textures, for pose estimation";
    for (int i = 0; i < s->n_prims; i++) {
        struct esr_synth_prim *p = &s->prims[i];
        const float *b = p->mat.base;
        if (p->texture != ESR_SYNTH_TEX_NONE)
            set_texture(p, ESR_SYNTH_TEX_NOISE, p->base2[0], p->base2[1], p->base2[2], p->tex_period);
        else if (p->light < 0) /* blotches of a darker shade of its colour */
            set_texture(p, ESR_SYNTH_TEX_NOISE, 0.45f * b[0], 0.45f * b[1], 0.45f * b[2], 0.15f);
    }
}

/* Harder: a glossy metallic floor under a bright ball light, a small magenta emitter box, a glossy
 * back wall and mirror-like balls, so most light arrives through inter-reflections. */
static void build_glossy(struct esr_synth_scene *s)
{
    init_scene(s, "glossy", "glossy floor and wall near a ball light + small magenta emitter, strong inter-reflections");
    s->spp = 128;
    struct esr_synth_prim *p;
    p = add_prim(s, "floor", ESR_SYNTH_CYLINDER, esr_v3(0, 0, -0.06f), esr_v3(1.2f, 0.06f, 0),
                 &(struct esr_material){{0.8f, 0.8f, 0.78f}, 0.15f, 0.6f});
    set_texture(p, ESR_SYNTH_TEX_CHECKER, 0.45f, 0.45f, 0.5f, 0.3f);
    p = add_prim(s, "wall", ESR_SYNTH_BOX, esr_v3(-1.0f, 0.75f, 0), esr_v3(1.0f, 0.85f, 0.9f),
                 &(struct esr_material){{0.85f, 0.85f, 0.85f}, 0.2f, 0.3f});
    set_texture(p, ESR_SYNTH_TEX_STRIPES, 0.3f, 0.35f, 0.45f, 0.2f);
    p = add_prim(s, "ball_light", ESR_SYNTH_SPHERE, esr_v3(0.0f, 0.1f, 0.45f), esr_v3(0.16f, 0, 0),
                 &(struct esr_material){{0.9f, 0.9f, 0.9f}, 0.5f, 0.0f});
    add_light(s, p, 1.0f, 0.9f, 0.75f, 10.0f);
    p = add_prim(s, "emitter_box", ESR_SYNTH_BOX, esr_v3(0.65f, -0.55f, 0), esr_v3(0.8f, -0.4f, 0.15f),
                 &(struct esr_material){{0.5f, 0.5f, 0.5f}, 0.5f, 0.0f});
    add_light(s, p, 1.0f, 0.25f, 0.8f, 15.0f);
    add_prim(s, "gold_ball", ESR_SYNTH_SPHERE, esr_v3(-0.5f, -0.25f, 0.3f), esr_v3(0.3f, 0, 0),
             &(struct esr_material){{1.0f, 0.78f, 0.35f}, 0.1f, 1.0f});
    add_prim(s, "chrome_ball", ESR_SYNTH_SPHERE, esr_v3(0.45f, 0.3f, 0.2f), esr_v3(0.2f, 0, 0), &esr_synth_chrome);
    add_prim(s, "copper_post", ESR_SYNTH_CYLINDER, esr_v3(-0.1f, -0.75f, 0), esr_v3(0.12f, 0.6f, 0),
             &(struct esr_material){{0.95f, 0.6f, 0.45f}, 0.3f, 1.0f});
    add_prim(s, "white_block", ESR_SYNTH_BOX, esr_v3(-0.95f, 0.2f, 0), esr_v3(-0.65f, 0.5f, 0.3f),
             &(struct esr_material){{0.8f, 0.8f, 0.8f}, 0.8f, 0.0f});
}

static const struct {
    const char *name;
    void (*build)(struct esr_synth_scene *);
} scenes[] = {
    {"default", build_default},
    {"glossy", build_glossy},
    {"capture", build_capture},
    {"bulbs", esr_synth_build_bulbs},
    {"vivid", esr_synth_build_vivid},
    {"ratios", esr_synth_build_ratios},
    {"shaded", esr_synth_build_shaded},
};
#define N_SCENES (int)(sizeof scenes / sizeof scenes[0])

int esr_synth_scene_count(void) { return N_SCENES; }

const char *esr_synth_scene_name(int i) { return i >= 0 && i < N_SCENES ? scenes[i].name : NULL; }

int esr_synth_scene_get(const char *name, struct esr_synth_scene *out)
{
    for (int i = 0; i < N_SCENES; i++) {
        if (!strcmp(name, scenes[i].name)) {
            scenes[i].build(out);
            return ESR_OK;
        }
    }
    char known[256] = "";
    for (int i = 0; i < N_SCENES; i++)
        snprintf(known + strlen(known), sizeof known - strlen(known), "%s%s", i ? ", " : "", scenes[i].name);
    return ESR_FAIL("unknown scene '%s' (built-in scenes: %s)", name, known);
}

void esr_synth_scene_bounds(const struct esr_synth_scene *s, float lo[3], float hi[3])
{
    for (int k = 0; k < 3; k++) {
        lo[k] = INFINITY;
        hi[k] = -INFINITY;
    }
    for (int i = 0; i < s->n_prims; i++) {
        const struct esr_synth_prim *p = &s->prims[i];
        float plo[3], phi[3];
        if (p->kind == ESR_SYNTH_SPHERE) {
            float c[3] = {p->a.x, p->a.y, p->a.z};
            for (int k = 0; k < 3; k++) {
                plo[k] = c[k] - p->b.x;
                phi[k] = c[k] + p->b.x;
            }
        } else if (p->kind == ESR_SYNTH_BOX) {
            plo[0] = p->a.x, plo[1] = p->a.y, plo[2] = p->a.z;
            phi[0] = p->b.x, phi[1] = p->b.y, phi[2] = p->b.z;
        } else {
            plo[0] = p->a.x - p->b.x, plo[1] = p->a.y - p->b.x, plo[2] = p->a.z;
            phi[0] = p->a.x + p->b.x, phi[1] = p->a.y + p->b.x, phi[2] = p->a.z + p->b.y;
        }
        for (int k = 0; k < 3; k++) {
            lo[k] = fminf(lo[k], plo[k]);
            hi[k] = fmaxf(hi[k], phi[k]);
        }
    }
}
