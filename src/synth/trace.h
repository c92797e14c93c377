/* The path tracer of `esr synth`: unidirectional path tracing with next-event estimation on the
 * emitters (points sampled by area) and on the uniform world light (cosine-weighted directions),
 * MIS with the power heuristic against BRDF sampling, Russian roulette, no clamping. */
#ifndef ESR_SYNTH_TRACE_H
#define ESR_SYNTH_TRACE_H

#include <stdint.h>

#include "core/rng.h"
#include "io/camera.h"
#include "io/image.h"
#include "synth/scene.h"

/* Everything one image's paths need: the scene plus this image's light state. */
struct esr_synth_trace_params {
    const struct esr_synth_scene *scene;
    float emission[ESR_SYNTH_MAX_LIGHTS][3]; /* emitted radiance of each light in this image (0 = off) */
    int lit[ESR_SYNTH_MAX_LIGHTS];           /* 1 when light k emits (NEE samples every lit light) */
    float world[3];                          /* world radiance (colour * strength) */
    int max_bounces;
    int backdrop;                            /* camera rays that escape see esr_synth_backdrop */
};

/* A distant backdrop the camera sees where a render would be transparent, as in a photograph
 * (a room around the object): a smooth function of the direction d (+Z up) with a floor, a
 * horizon band and stripes in azimuth, a quarter brighter when any light is on. It lights
 * nothing: the scene's own lighting stays that of its renders. Into rgb. */
void esr_synth_backdrop(struct esr_vec3 d, int lights_on, float rgb[3]);
/* the backdrop's brightness with a light on over all lights off */
#define ESR_SYNTH_BACKDROP_LIT_GAIN 1.25f

/* Fills p for scene s with light k emitting emission[k] (linear radiance). */
void esr_synth_trace_setup(const struct esr_synth_scene *s, const float emission[][3],
                           struct esr_synth_trace_params *p);
/* 1 when any light of p is lit (the backdrop is then ESR_SYNTH_BACKDROP_LIT_GAIN brighter). */
static inline int esr_synth_trace_any_lit(const struct esr_synth_trace_params *p)
{
    int any = 0;
    for (int k = 0; k < p->scene->n_lights; k++)
        any |= p->lit[k];
    return any;
}

/* Index of the first primitive hit by the ray (o, d) in (tmin, *t), or -1; *t becomes its distance
 * in units of |d|. */
int esr_synth_intersect(const struct esr_synth_scene *s, struct esr_vec3 o, struct esr_vec3 d, float tmin, float *t);

/* Radiance arriving at o from unit direction d along one random path, into rgb. Returns 1 when the
 * primary ray hit geometry, or escaped with p->backdrop (rgb = the backdrop), 0 when it escaped
 * without (rgb = 0: the film is transparent, the world only lights the scene). A path ends at its
 * first hit when nothing emits (world off, no light lit). */
int esr_synth_trace_path(const struct esr_synth_trace_params *p, struct esr_vec3 o, struct esr_vec3 d,
                         struct esr_rng *rng, float rgb[3]);

/* Renders cam with spp jittered samples per pixel (box filter) into out (allocated here):
 * RGBA, linear radiance premultiplied by alpha, alpha = fraction of samples whose primary ray hit.
 * Pixel i of image image_id uses RNG stream image_id * width * height + i of seed, so the result
 * does not depend on the thread count. */
int esr_synth_render(const struct esr_synth_trace_params *p, const struct esr_camera *cam, int spp, uint64_t seed,
                     uint64_t image_id, struct esr_image *out);
/* esr_synth_render with the sub-pixel positions drawn from their own stream, jitter_id's, instead
 * of the path stream: images rendered with the same jitter_id (and seed) sample the same camera
 * rays, so their coverage (alpha) is the same bit for bit whatever their lighting (synth/dataset.c
 * sums a camera's light basis). */
int esr_synth_render_shared_jitter(const struct esr_synth_trace_params *p, const struct esr_camera *cam, int spp,
                                   uint64_t seed, uint64_t image_id, uint64_t jitter_id, struct esr_image *out);

/* Per-pixel ground truth from one ray through each pixel centre (no anti-aliasing). */
struct esr_synth_gt {
    int *prim;                  /* [w*h] primitive hit, -1 for background */
    struct esr_image normal;    /* 3 channels, world-space outward unit normal (0 on background) */
    struct esr_image base;      /* 3 channels, linear base colour (texture applied) */
    struct esr_image roughness; /* 1 channel */
    struct esr_image metallic;  /* 1 channel */
    struct esr_image emission;  /* 3 channels, emitted radiance with every light "on" */
};

int esr_synth_render_gt(const struct esr_synth_scene *s, const struct esr_camera *cam, struct esr_synth_gt *out);
void esr_synth_gt_free(struct esr_synth_gt *gt);

#endif
