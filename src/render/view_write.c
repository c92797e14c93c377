/* The image files of a rendered view (render/view.h lists them). */
#include <float.h>
#include <math.h>
#include <stdio.h>

#include "core/colour.h"
#include "core/error.h"
#include "fields/env_sg.h"
#include "render/view.h"

/* Display images derived from the raw outputs, filled into pre-allocated same-size images. */
static void gamma_image(const struct esr_image *linear, float scale, struct esr_image *out)
{
    long long n = (long long)esr_image_count(linear);
#pragma omp parallel for schedule(static)
    for (long long i = 0; i < n; i++)
        out->data[i] = esr_srgb_from_linear(esr_clamp01(scale * linear->data[i]));
}

/* c = 0.5 (n_w + 1) on the surface, white where empty: with n_c = sum w n (the composited
 * normal) and opacity a this is 0.5 (n_c + a) + (1 - a), no division by a needed. */
static void normal_image(const struct esr_view_images *v, struct esr_image *out)
{
    long long n = (long long)v->opacity.width * v->opacity.height;
#pragma omp parallel for schedule(static)
    for (long long i = 0; i < n; i++) {
        float a = esr_clamp01(v->opacity.data[i]);
        for (int c = 0; c < 3; c++)
            out->data[3 * i + c] = esr_clamp01(0.5f * (v->normal.data[3 * i + c] + a) + (1.0f - a));
    }
}

/* RGBA: the raw composited normal (RGB) and the opacity (A). */
static void normal_opacity_image(const struct esr_view_images *v, struct esr_image *out)
{
    long long n = (long long)v->opacity.width * v->opacity.height;
    for (long long i = 0; i < n; i++) {
        for (int c = 0; c < 3; c++)
            out->data[4 * i + c] = v->normal.data[3 * i + c];
        out->data[4 * i + 3] = v->opacity.data[i];
    }
}

static void depth_image(const struct esr_view_images *v, struct esr_image *out)
{
    long long n = (long long)v->depth.width * v->depth.height;
    float lo = FLT_MAX, hi = -FLT_MAX;
    for (long long i = 0; i < n; i++) {
        if (v->opacity.data[i] > 0.5f && isfinite(v->depth.data[i])) {
            lo = fminf(lo, v->depth.data[i]);
            hi = fmaxf(hi, v->depth.data[i]);
        }
    }
    float scale = hi > lo ? 1.0f / (hi - lo) : 0.0f;
    for (long long i = 0; i < n; i++)
        out->data[i] = v->opacity.data[i] > 0.5f ? esr_clamp01((v->depth.data[i] - lo) * scale) : 1.0f;
}

int esr_view_path(char *out, size_t n, const char *dir, const char *name, const char *suffix)
{
    int len = snprintf(out, n, "%s/%s%s", dir, name, suffix);
    return len < 0 || (size_t)len >= n ? ESR_FAIL("path '%s/%s%s' is too long", dir, name, suffix) : ESR_OK;
}

static int write_png(const char *dir, const char *name, const char *suffix, const struct esr_image *img)
{
    char path[4096];
    ESR_TRY(esr_view_path(path, sizeof path, dir, name, suffix));
    return esr_png_write(path, img, 8);
}

static int write_exr(const char *dir, const char *name, const char *suffix, const struct esr_image *img)
{
    char path[4096];
    ESR_TRY(esr_view_path(path, sizeof path, dir, name, suffix));
    return esr_exr_write(path, img, 0);
}

/* N_emission.exr, N_emission.png, the emitter mask N_emitter.png and for lights-on views N_emo.exr
 * and N_emo.png (rgb3, grey: scratch). */
static int write_emission(const char *dir, const char *name, const struct esr_view_images *v,
                          struct esr_image *rgb3, struct esr_image *grey)
{
    ESR_TRY(write_exr(dir, name, "_emission.exr", &v->emitted));
    gamma_image(&v->emitted, v->emission_png_scale, rgb3);
    ESR_TRY(write_png(dir, name, "_emission.png", rgb3));
    if (v->emo.data) {
        ESR_TRY(write_exr(dir, name, "_emo.exr", &v->emo));
        gamma_image(&v->emo, 1.0f, rgb3);
        ESR_TRY(write_png(dir, name, "_emo.png", rgb3));
    }
    const long long n = (long long)grey->width * grey->height;
    for (long long i = 0; i < n; i++) {
        const float *e = v->emission.data + 3 * i;
        grey->data[i] = (v->light_id ? esr_view_light_code(e, v->light_id[i], v->emitter_k) > 0.0f
                                     : fmaxf(e[0], fmaxf(e[1], e[2])) > v->emitter_k)
                            ? 1.0f
                            : 0.0f;
    }
    ESR_TRY(write_png(dir, name, "_emitter.png", grey));
    if (!v->light_id)
        return ESR_OK;
    for (long long i = 0; i < n; i++)
        grey->data[i] = esr_view_light_code(v->emission.data + 3 * i, v->light_id[i], v->emitter_k);
    return write_png(dir, name, "_lights.png", grey);
}

float esr_view_light_code(const float e[3], int32_t light_id, float k)
{
    return fmaxf(e[0], fmaxf(e[1], e[2])) > k && light_id >= 0 ? (float)(light_id + 1) / 255.0f
                                                                 : 0.0f;
}

/* Channels [c0, c0 + n) of the composited material image divided by opacity (the surface's
 * value), sRGB-encoded when srgb, on white where nothing was hit; into out (n channels). */
static void material_image(const struct esr_view_images *v, int c0, int n, int srgb,
                           struct esr_image *out)
{
    const long long np = (long long)v->opacity.width * v->opacity.height;
    for (long long i = 0; i < np; i++) {
        const float a = v->opacity.data[i];
        for (int c = 0; c < n; c++) {
            float x = a > 1e-4f ? v->material[5 * i + c0 + c] / a : 0.0f;
            if (srgb)
                x = esr_srgb_from_linear(esr_clamp01(x));
            out->data[n * i + c] = esr_clamp01(a * x + (1.0f - a));
        }
    }
}

/* N_basecolor.png, N_roughness.png, N_metallic.png (rgb3, grey: scratch). */
static int write_material(const char *dir, const char *name, const struct esr_view_images *v,
                          struct esr_image *rgb3, struct esr_image *grey)
{
    material_image(v, 0, 3, 1, rgb3);
    ESR_TRY(write_png(dir, name, "_basecolor.png", rgb3));
    material_image(v, 3, 1, 0, grey);
    ESR_TRY(write_png(dir, name, "_roughness.png", grey));
    material_image(v, 4, 1, 0, grey);
    return write_png(dir, name, "_metallic.png", grey);
}

int esr_view_write_env(const char *dir, const struct esr_model *m)
{
    if (!esr_model_has(m, ESR_COMP_ENV))
        return ESR_OK;
    struct esr_image lin = {0}, srgb = {0};
    int status = esr_image_alloc(&lin, 256, 128, 3);
    if (status == ESR_OK)
        status = esr_image_alloc(&srgb, 256, 128, 3);
    if (status == ESR_OK)
        status = esr_env_sg_equirect(esr_model_values(m, ESR_COMP_ENV), m->cfg.env_lobes, 256, 128,
                                     lin.data);
    if (status == ESR_OK)
        esr_lights_balance_env(&m->lights, lin.data, (size_t)lin.width * (size_t)lin.height);
    if (status == ESR_OK)
        status = write_exr(dir, "env", ".exr", &lin);
    if (status == ESR_OK) {
        gamma_image(&lin, 1.0f, &srgb);
        status = write_png(dir, "env", ".png", &srgb);
    }
    esr_image_free(&lin);
    esr_image_free(&srgb);
    return status;
}

int esr_view_write(const char *dir, const char *name, const struct esr_view_images *v)
{
    struct esr_image rgb3 = {0}, grey = {0}, rgba = {0};
    int w = v->rgb.width, h = v->rgb.height;
    int status = esr_image_alloc(&rgb3, w, h, 3);
    if (status == ESR_OK)
        status = esr_image_alloc(&grey, w, h, 1);
    if (status == ESR_OK)
        status = esr_image_alloc(&rgba, w, h, 4);
    if (status == ESR_OK)
        status = write_png(dir, name, ".png", &v->rgb);
    if (status == ESR_OK) {
        gamma_image(&v->linear, 1.0f, &rgb3);
        status = write_png(dir, name, "_linear.png", &rgb3);
    }
    if (status == ESR_OK)
        status = write_exr(dir, name, ".exr", &v->linear);
    if (status == ESR_OK) {
        normal_image(v, &rgb3);
        status = write_png(dir, name, "_normal.png", &rgb3);
    }
    if (status == ESR_OK) {
        normal_opacity_image(v, &rgba);
        status = write_exr(dir, name, "_normal.exr", &rgba);
    }
    if (status == ESR_OK) {
        depth_image(v, &grey);
        status = write_png(dir, name, "_depth.png", &grey);
    }
    if (status == ESR_OK)
        status = write_exr(dir, name, "_depth.exr", &v->depth);
    if (status == ESR_OK && v->emission.data)
        status = write_emission(dir, name, v, &rgb3, &grey);
    if (status == ESR_OK && v->material)
        status = write_material(dir, name, v, &rgb3, &grey);
    esr_image_free(&rgb3);
    esr_image_free(&grey);
    esr_image_free(&rgba);
    return status;
}
