/* Whole camera views through the trained model: every pixel's ray (pixel centres) is rendered by
 * esr_model_render_rays, and the outputs are stored as the image files `esr render`
 * writes and `esr eval` reads (eval/evaluate.h). */
#ifndef ESR_RENDER_VIEW_H
#define ESR_RENDER_VIEW_H

#include <cjson/cJSON.h>
#include <stdint.h>

#include "io/camera.h"
#include "io/dataset.h"
#include "io/image.h"
#include "model/model.h"

struct esr_view_images {
    struct esr_image rgb;     /* 3 ch: tone-mapped LDR on white */
    struct esr_image linear;  /* 3 ch: linear HDR radiance on white */
    struct esr_image depth;   /* 1 ch: expected ray distance */
    struct esr_image normal;  /* 3 ch: composited world-space normal (sum of weights * normal) */
    struct esr_image opacity; /* 1 ch: 1 - final transmittance */
    struct esr_image emission; /* 3 ch: composited emission E of the field, linear HDR (lts
                                  stage on; else empty: data NULL); the emitter mask's source */
    struct esr_image emitted;  /* 3 ch: composited emitted radiance: a model with lights, E at
                                  its light's calibrated strength on the lights and 0 elsewhere
                                  (model/lights.h); else E, like emission */
    struct esr_image emo;      /* 3 ch: lights-on views of an lts+ model: the emission's effect,
                                  linear on - linear off (the illumination decomposition); else
                                  empty */
    float *material;          /* [w*h*5]: composited base colour (3), roughness, metallic (lts
                                 stage on; else NULL) — five channels, more than an esr_image */
    int32_t *light_id;        /* [w*h]: the light (model/lights.h) each pixel's surface lies on,
                                 -1 for none (a model with lights; else NULL) */
    float emitter_k;          /* emitter mask: emission above this in any channel */
    float emission_png_scale; /* N_emission.png shows emitted x this before the sRGB curve: 1 /
                                 the brightest light's largest channel when that is above 1 (a
                                 model with lights; the same in every view, so the lights keep
                                 their colour and relative strength instead of clipping white),
                                 else 1 */
};

/* Renders every pixel of cam with the lights on (1) or off (0) in one model call (the model
 * batches and parallelises inside it, and prepares its SDF view once per call). *out is
 * overwritten; free it with esr_view_images_free (also after an error). */
int esr_view_render(const struct esr_model *m, const struct esr_camera *cam, int lights_on,
                    struct esr_view_images *out);
void esr_view_images_free(struct esr_view_images *v);

/* Writes the view's files into dir (which must exist), N = name:
 *   N.png          tone-mapped RGB, 8-bit
 *   N_linear.png   sRGB OETF of the linear RGB clipped to [0,1], 8-bit
 *   N.exr          linear RGB (float)
 *   N_normal.png   normal mapped to [0,1] as (n + 1) / 2, composited on white by opacity
 *   N_normal.exr   raw composited normal sum w n (RGB, not normalised) and opacity (A), float
 *   N_depth.png    depth normalised to [0,1] between the nearest and farthest pixel of opacity
 *                  > 0.5 (0 = nearest); pixels of lower opacity are white
 *   N_depth.exr    raw depth (float, one channel)
 * and with an emission image (lts stage on):
 *   N_emission.exr composited emitted radiance (a model with lights: E at its light's
 *                  calibrated strength on the lights, nothing elsewhere; else E; linear RGB, float)
 *   N_emission.png times emission_png_scale (over the brightest light's largest channel when
 *                  above 1), its sRGB OETF clipped to [0,1], 8-bit
 *   N_emitter.png  emitter mask, grey 0 or 255: any channel of the field's E above emitter_k
 *                  and, for a model with lights, the pixel's surface on one of them
 *   N_emo.exr, N_emo.png  lights-on views: the emission's effect, linear on - off (float; PNG:
 *                  sRGB OETF clipped), so that off + emo = on (the illumination decomposition)
 *   N_lights.png   a model with lights: grey, 0 off the emitter mask, else 1 + the id of the
 *                  light the pixel's surface lies on (light K in code value K + 1)
 *   N_basecolor.png  base colour (sRGB OETF of the linear value), N_roughness.png,
 *   N_metallic.png   (grey), each divided by opacity and composited on white
 * Fails naming the file on a write error. */
int esr_view_write(const char *dir, const char *name, const struct esr_view_images *v);

/* N_lights.png's code value of a pixel: 0 off the emitter mask (no channel of the field's
 * emission e above k) or on no light, else (light id + 1) / 255. */
float esr_view_light_code(const float e[3], int32_t light_id, float k);

/* The model's environment map (lts stage on) as dir/env.exr (linear RGB) and dir/env.png (sRGB
 * OETF clipped), equirectangular 256 x 128, +Z (up) in row 0 (fields/env_sg.h); nothing for a
 * model without one. */
int esr_view_write_env(const char *dir, const struct esr_model *m);

/* Path of one of those files: "<dir>/<name><suffix>" (suffix e.g. "_linear.png"). Fails when it
 * does not fit in n bytes. */
int esr_view_path(char *out, size_t n, const char *dir, const char *name, const char *suffix);

/* 1 when the files esr eval reads (N.png, N_linear.png, N.exr, N_normal.exr) all exist in dir
 * (render directories written before N_normal.exr existed count as incomplete). */
int esr_view_outputs_exist(const char *dir, const char *name);

/* Progress of esr_view_render_frames, reported after each written frame. */
struct esr_view_progress {
    const char *name; /* frame just written */
    int done, total;
    double seconds;   /* rendering + writing time of that frame */
};
typedef void (*esr_view_progress_fn)(void *user, const struct esr_view_progress *p);

/* Renders frames idx[0..n) of `phase` into dir (created if absent), each with its own camera and
 * lighting (frame mode "off" or "on"), writing the files of esr_view_write, then records the
 * model's stage, step and fingerprint and the frames rendered by that model, each with its
 * view's fingerprint, in dir/render.json (frames of an earlier model are dropped from the
 * record), plus the
 * environment map (esr_view_write_env). Edit frames (i_change, c_change, ic_change) are refused
 * before anything is rendered: edit/editor.h renders those.
 * `progress` may be NULL. */
int esr_view_render_frames(const struct esr_model *m, const struct esr_dataset *ds, enum esr_phase_id phase,
                           const int *idx, int n, const char *dir, esr_view_progress_fn progress, void *user);

/* What a view's files mean; render.json records it, so that renders written before a change
 * of meaning are stale (2: with lights found, N_emission.exr and N_emitter.png are the lights';
 * 3: the record names the model by its fingerprint and each frame by its view's; 4: a light's
 * unseen part emits its mean field, N_emission.png is scaled by emission_png_scale, rays are
 * never cut at 2048 samples). */
#define ESR_VIEW_OUTPUTS_VERSION 4

/* current[i] = 1 when frame idx[i] of `phase` has its outputs in dir and dir/render.json says
 * this model (esr_model_fingerprint) rendered it from the view the dataset has now (camera,
 * size, lighting) with today's outputs, else 0 (render again): another run's model, lights found
 * again, or another dataset's cameras (`esr eval --data`) make renders stale. */
void esr_view_current(const char *dir, const struct esr_model *m, const struct esr_dataset *ds,
                      enum esr_phase_id phase, const int *idx, int n, uint8_t *current);
/* A stamp's text (size bytes, no NUL needed) read for the model of fingerprint `model` (16 hex
 * digits): its "frames" object, frame name -> view fingerprint (the caller deletes it), when
 * the stamp names that model and ESR_VIEW_OUTPUTS_VERSION, else NULL (unparsable, another
 * model's or older outputs: render again). Never an error. */
cJSON *esr_view_stamp_frames(const char *text, size_t size, const char *model);

#endif
