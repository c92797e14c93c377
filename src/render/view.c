/* Rendering a camera view. */
#include "render/view.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"

static int alloc_images(struct esr_view_images *v, int w, int h)
{
    ESR_TRY(esr_image_alloc(&v->rgb, w, h, 3));
    ESR_TRY(esr_image_alloc(&v->linear, w, h, 3));
    ESR_TRY(esr_image_alloc(&v->depth, w, h, 1));
    ESR_TRY(esr_image_alloc(&v->normal, w, h, 3));
    return esr_image_alloc(&v->opacity, w, h, 1);
}

int esr_view_render(const struct esr_model *m, const struct esr_camera *cam, int lights_on,
                    struct esr_view_images *out)
{
    memset(out, 0, sizeof *out);
    if (cam->width < 1 || cam->height < 1)
        return ESR_FAIL("camera has an empty image (%dx%d)", cam->width, cam->height);
    ESR_TRY(alloc_images(out, cam->width, cam->height));
    const int fields = esr_model_has(m, ESR_COMP_EMIT_MLP);
    if (fields) {
        ESR_TRY(esr_image_alloc(&out->emission, cam->width, cam->height, 3));
        ESR_TRY(esr_image_alloc(&out->emitted, cam->width, cam->height, 3));
        if (lights_on)
            ESR_TRY(esr_image_alloc(&out->emo, cam->width, cam->height, 3));
        if (m->lights.n > 0 &&
            !(out->light_id = malloc((size_t)cam->width * (size_t)cam->height * sizeof(int32_t))))
            return ESR_FAIL("out of memory for a %dx%d light-id image", cam->width, cam->height);
        out->material = malloc((size_t)cam->width * (size_t)cam->height * 5 * sizeof(float));
        if (!out->material)
            return ESR_FAIL("out of memory for a %dx%d material image", cam->width, cam->height);
    }
    out->emitter_k = m->cfg.emitter_k;
    out->emission_png_scale = 1.0f;
    for (int k = 0; k < m->lights.n; k++) {
        const float *rad = m->lights.light[k].radiance;
        const float peak = fmaxf(rad[0], fmaxf(rad[1], rad[2]));
        if (peak > 0.0f && 1.0f / peak < out->emission_png_scale)
            out->emission_png_scale = 1.0f / peak;
    }
    size_t n = (size_t)cam->width * (size_t)cam->height;
    float *origins = malloc(n * 3 * sizeof *origins), *dirs = malloc(n * 3 * sizeof *dirs);
    int status = origins && dirs ? ESR_OK : ESR_FAIL("out of memory for %zu camera rays", n);
    if (status == ESR_OK)
        esr_camera_pixel_rays(cam, origins, dirs);
    if (status == ESR_OK) {
        /* with lights, the emitted radiance is theirs: E elsewhere is not a light (a reflection
         * the search left out, E below k on the rest of the surface) */
        const int lit = m->lights.n > 0;
        struct esr_render_out o = {.rgb = out->rgb.data,         .linear = out->linear.data,
                                   .depth = out->depth.data,     .normal = out->normal.data,
                                   .opacity = out->opacity.data, .emission = out->emission.data,
                                   .emitted = lit ? NULL : out->emitted.data,
                                   .emitted_lights = lit ? out->emitted.data : NULL,
                                   .material = out->material,    .light_id = out->light_id,
                                   .linear_other = out->emo.data}; /* lights off, for emo */
        status = esr_model_render_rays(m, origins, dirs, n, lights_on, &o);
    }
    for (size_t i = 0; status == ESR_OK && out->emo.data && i < n * 3; i++)
        out->emo.data[i] = out->linear.data[i] - out->emo.data[i];
    free(origins);
    free(dirs);
    return status;
}

void esr_view_images_free(struct esr_view_images *v)
{
    esr_image_free(&v->rgb);
    esr_image_free(&v->linear);
    esr_image_free(&v->depth);
    esr_image_free(&v->normal);
    esr_image_free(&v->opacity);
    esr_image_free(&v->emission);
    esr_image_free(&v->emitted);
    esr_image_free(&v->emo);
    free(v->material);
    v->material = NULL;
    free(v->light_id);
    v->light_id = NULL;
}
