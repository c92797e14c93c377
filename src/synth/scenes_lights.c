/* Built-in scenes that measure how strongly each light emits (issue 48): identical small lights
 * close together, a large saturated emitter, lights of different strengths, a light half hidden in
 * a shade. Each light covers at least 40 pixels in at least half of the test views at the scene's
 * default resolution (tests/test_synth_scenes.c checks it from the rendered masks). */
#include "synth/scene_build.h"

/* A checkered floor disc like the default scene's, its top at z = 0. */
static void add_floor(struct esr_synth_scene *s)
{
    struct esr_synth_prim *p = esr_synth_add_prim(s, "floor", ESR_SYNTH_CYLINDER, esr_v3(0, 0, -0.06f),
                                                  esr_v3(1.2f, 0.06f, 0),
                                                  &(struct esr_material){{0.75f, 0.72f, 0.65f}, 0.7f, 0.0f});
    esr_synth_set_texture(p, ESR_SYNTH_TEX_CHECKER, 0.2f, 0.22f, 0.25f, 0.25f);
}

#define N_BULBS 7

/* Seven identical small bulbs on a sagging string, alternating sides so that a camera looking
 * along the string still sees them apart, over a box, a blue ball and a chrome ball that mirrors
 * them (a reflection esr must not count as a light). 160 px: a bulb is about 5 px across at 100. */
void esr_synth_build_bulbs(struct esr_synth_scene *s)
{
    static const char *const names[N_BULBS] = {"bulb_0", "bulb_1", "bulb_2", "bulb_3",
                                               "bulb_4", "bulb_5", "bulb_6"};
    esr_synth_init_scene(s, "bulbs", "7 identical small bulbs strung over a box, a ball and a chrome ball");
    s->res = 160;
    add_floor(s);
    for (int i = 0; i < N_BULBS; i++) {
        const float x = -0.75f + 0.25f * (float)i, sag = x / 0.75f;
        const float y = -0.15f + (i % 2 ? 0.13f : -0.13f), z = 0.78f + 0.2f * sag * sag;
        struct esr_synth_prim *p = esr_synth_add_prim(s, names[i], ESR_SYNTH_SPHERE, esr_v3(x, y, z),
                                                      esr_v3(0.09f, 0, 0),
                                                      &(struct esr_material){{0.9f, 0.9f, 0.85f}, 0.4f, 0.0f});
        esr_synth_add_light(s, p, 1.0f, 0.85f, 0.6f, 10.0f);
    }
    struct esr_synth_prim *p = esr_synth_add_prim(s, "striped_box", ESR_SYNTH_BOX, esr_v3(-0.7f, 0.25f, 0),
                                                  esr_v3(-0.3f, 0.65f, 0.35f),
                                                  &(struct esr_material){{0.85f, 0.8f, 0.3f}, 0.5f, 0.0f});
    esr_synth_set_texture(p, ESR_SYNTH_TEX_STRIPES, 0.15f, 0.35f, 0.6f, 0.1f);
    esr_synth_add_prim(s, "blue_ball", ESR_SYNTH_SPHERE, esr_v3(0.5f, 0.45f, 0.25f), esr_v3(0.25f, 0, 0),
                       &(struct esr_material){{0.15f, 0.3f, 0.75f}, 0.5f, 0.0f});
    esr_synth_add_prim(s, "chrome_ball", ESR_SYNTH_SPHERE, esr_v3(0.0f, 0.4f, 0.22f), esr_v3(0.22f, 0, 0),
                       &esr_synth_chrome);
}

/* The seed's Balls scene in spirit: a large red emitter ball (radiance 10 / 0.5 / 0.3) among
 * material balls, glossy and coloured, so its light and its reflections carry its hue. */
void esr_synth_build_vivid(struct esr_synth_scene *s)
{
    esr_synth_init_scene(s, "vivid", "a large saturated red emitter ball among glossy and coloured balls");
    s->spp = 128;
    struct esr_synth_prim *p = esr_synth_add_prim(s, "floor", ESR_SYNTH_CYLINDER, esr_v3(0, 0, -0.06f),
                                                  esr_v3(1.2f, 0.06f, 0),
                                                  &(struct esr_material){{0.6f, 0.6f, 0.6f}, 0.6f, 0.0f});
    esr_synth_set_texture(p, ESR_SYNTH_TEX_CHECKER, 0.45f, 0.45f, 0.47f, 0.3f);
    p = esr_synth_add_prim(s, "red_light", ESR_SYNTH_SPHERE, esr_v3(0, 0, 0.35f), esr_v3(0.35f, 0, 0),
                           &(struct esr_material){{0.8f, 0.2f, 0.2f}, 0.5f, 0.0f});
    esr_synth_add_light(s, p, 1.0f, 0.05f, 0.03f, 10.0f);
    esr_synth_add_prim(s, "gold_ball", ESR_SYNTH_SPHERE, esr_v3(0.6f, 0.55f, 0.22f), esr_v3(0.22f, 0, 0),
                       &(struct esr_material){{1.0f, 0.78f, 0.35f}, 0.15f, 1.0f});
    esr_synth_add_prim(s, "blue_gloss_ball", ESR_SYNTH_SPHERE, esr_v3(-0.6f, 0.35f, 0.2f), esr_v3(0.2f, 0, 0),
                       &(struct esr_material){{0.1f, 0.25f, 0.8f}, 0.1f, 0.0f});
    esr_synth_add_prim(s, "green_ball", ESR_SYNTH_SPHERE, esr_v3(0.45f, -0.55f, 0.18f), esr_v3(0.18f, 0, 0),
                       &(struct esr_material){{0.2f, 0.7f, 0.25f}, 0.8f, 0.0f});
    esr_synth_add_prim(s, "chrome_ball", ESR_SYNTH_SPHERE, esr_v3(-0.5f, -0.5f, 0.2f), esr_v3(0.2f, 0, 0),
                       &esr_synth_chrome);
    esr_synth_add_prim(s, "white_gloss_ball", ESR_SYNTH_SPHERE, esr_v3(0.05f, 0.75f, 0.15f), esr_v3(0.15f, 0, 0),
                       &(struct esr_material){{0.9f, 0.9f, 0.9f}, 0.2f, 0.0f});
    esr_synth_add_prim(s, "yellow_ball", ESR_SYNTH_SPHERE, esr_v3(-0.85f, -0.05f, 0.15f), esr_v3(0.15f, 0, 0),
                       &(struct esr_material){{0.9f, 0.75f, 0.1f}, 0.5f, 0.0f});
}

/* Three lights of strengths 1 : 3 : 8 (3, 9, 24), each its own colour and shape: a pale blue
 * ball, a green box, an orange post. */
void esr_synth_build_ratios(struct esr_synth_scene *s)
{
    esr_synth_init_scene(s, "ratios", "3 lights of strengths 1:3:8 and different colours and shapes");
    add_floor(s);
    struct esr_synth_prim *p;
    p = esr_synth_add_prim(s, "blue_ball_light", ESR_SYNTH_SPHERE, esr_v3(-0.55f, -0.35f, 0.16f), esr_v3(0.16f, 0, 0),
                           &(struct esr_material){{0.7f, 0.75f, 0.8f}, 0.5f, 0.0f});
    esr_synth_add_light(s, p, 0.35f, 0.7f, 1.0f, 3.0f);
    p = esr_synth_add_prim(s, "green_box_light", ESR_SYNTH_BOX, esr_v3(0.35f, -0.6f, 0), esr_v3(0.6f, -0.35f, 0.25f),
                           &(struct esr_material){{0.7f, 0.8f, 0.7f}, 0.5f, 0.0f});
    esr_synth_add_light(s, p, 0.55f, 1.0f, 0.35f, 9.0f);
    p = esr_synth_add_prim(s, "orange_post_light", ESR_SYNTH_CYLINDER, esr_v3(0.25f, 0.5f, 0), esr_v3(0.12f, 0.4f, 0),
                           &(struct esr_material){{0.8f, 0.7f, 0.6f}, 0.5f, 0.0f});
    esr_synth_add_light(s, p, 1.0f, 0.5f, 0.2f, 24.0f);
    esr_synth_add_prim(s, "white_block", ESR_SYNTH_BOX, esr_v3(-0.75f, 0.2f, 0), esr_v3(-0.35f, 0.6f, 0.4f),
                       &(struct esr_material){{0.8f, 0.8f, 0.8f}, 0.7f, 0.0f});
    esr_synth_add_prim(s, "grey_gloss_ball", ESR_SYNTH_SPHERE, esr_v3(0.0f, 0.0f, 0.22f), esr_v3(0.22f, 0, 0),
                       &(struct esr_material){{0.8f, 0.8f, 0.8f}, 0.2f, 0.5f});
}

/* A lamp whose bulb hangs in a square shade open at top and bottom (four thin walls): the side
 * views see the bulb's lower cap below the shade, the high views see its top through the
 * opening, and the shade's inside is lit by it. 160 px: at 100 the visible cap is too small. The
 * bulb's centre is at the shade's lower edge: half of it hangs below. */
void esr_synth_build_shaded(struct esr_synth_scene *s)
{
    esr_synth_init_scene(s, "shaded", "a bulb half hidden in a square lampshade, a ball and a glossy box");
    s->res = 160;
    /* The shade's lit inside lights the floor through its opening, as indirect light only: at 192
     * spp a test view is 36 dB from the same view at 512 (the default scene at 96 / 384: 38.5). */
    s->spp = 192;
    add_floor(s);
    const float cx = -0.25f, cy = 0.2f, r = 0.15f, bz = 0.6f; /* the bulb */
    /* the shade's inner half width (11 cm from the bulb: nearer, the walls' light is noisier),
     * its walls' thickness, bottom and top */
    const float in = 0.26f, th = 0.02f, z0 = 0.6f, z1 = 0.92f;
    esr_synth_add_prim(s, "lamp_foot", ESR_SYNTH_CYLINDER, esr_v3(cx, cy, 0), esr_v3(0.18f, 0.03f, 0),
                       &(struct esr_material){{0.3f, 0.3f, 0.32f}, 0.3f, 1.0f});
    esr_synth_add_prim(s, "lamp_pole", ESR_SYNTH_CYLINDER, esr_v3(cx, cy, 0.03f), esr_v3(0.02f, bz - r - 0.03f, 0),
                       &(struct esr_material){{0.6f, 0.6f, 0.6f}, 0.3f, 1.0f});
    struct esr_synth_prim *p = esr_synth_add_prim(s, "bulb", ESR_SYNTH_SPHERE, esr_v3(cx, cy, bz), esr_v3(r, 0, 0),
                                                  &(struct esr_material){{0.9f, 0.9f, 0.85f}, 0.4f, 0.0f});
    esr_synth_add_light(s, p, 1.0f, 0.9f, 0.7f, 15.0f);
    /* Walls meet without overlapping: the x walls span the full width, the y walls fit between. */
    const struct esr_material shade = {{0.9f, 0.85f, 0.7f}, 0.9f, 0.0f};
    esr_synth_add_prim(s, "shade_east", ESR_SYNTH_BOX, esr_v3(cx + in, cy - in - th, z0),
                       esr_v3(cx + in + th, cy + in + th, z1), &shade);
    esr_synth_add_prim(s, "shade_west", ESR_SYNTH_BOX, esr_v3(cx - in - th, cy - in - th, z0),
                       esr_v3(cx - in, cy + in + th, z1), &shade);
    esr_synth_add_prim(s, "shade_north", ESR_SYNTH_BOX, esr_v3(cx - in, cy + in, z0), esr_v3(cx + in, cy + in + th, z1),
                       &shade);
    esr_synth_add_prim(s, "shade_south", ESR_SYNTH_BOX, esr_v3(cx - in, cy - in - th, z0), esr_v3(cx + in, cy - in, z1),
                       &shade);
    esr_synth_add_prim(s, "blue_ball", ESR_SYNTH_SPHERE, esr_v3(0.5f, -0.3f, 0.25f), esr_v3(0.25f, 0, 0),
                       &(struct esr_material){{0.15f, 0.3f, 0.75f}, 0.4f, 0.0f});
    p = esr_synth_add_prim(s, "glossy_box", ESR_SYNTH_BOX, esr_v3(0.25f, 0.35f, 0), esr_v3(0.65f, 0.7f, 0.3f),
                           &(struct esr_material){{0.8f, 0.75f, 0.6f}, 0.15f, 0.3f});
    esr_synth_set_texture(p, ESR_SYNTH_TEX_STRIPES, 0.5f, 0.2f, 0.15f, 0.1f);
}
