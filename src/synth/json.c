#include "synth/json.h"

#include "io/exif_exposure.h"

#include <cjson/cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/colour.h"
#include "core/error.h"
#include "io/json_file.h"

/* A float as the shortest decimal that reads back to it (cJSON would print 0.8f as
 * 0.800000011920929). */
static cJSON *num(float v)
{
    char buf[32];
    snprintf(buf, sizeof buf, "%.9g", v);
    double d = strtod(buf, NULL);
    for (int digits = 6; digits < 9; digits++) {
        snprintf(buf, sizeof buf, "%.*g", digits, v);
        if ((float)strtod(buf, NULL) == v) {
            d = strtod(buf, NULL);
            break;
        }
    }
    return cJSON_CreateNumber(d);
}

static cJSON *vec(const float *v, int n)
{
    cJSON *a = cJSON_CreateArray();
    for (int i = 0; i < n; i++)
        cJSON_AddItemToArray(a, num(v[i]));
    return a;
}

static cJSON *matrix(const struct esr_camera *cam)
{
    cJSON *m = cJSON_CreateArray();
    for (int r = 0; r < 3; r++)
        cJSON_AddItemToArray(m, vec(cam->c2w[r], 4));
    const float last[4] = {0.0f, 0.0f, 0.0f, 1.0f};
    cJSON_AddItemToArray(m, vec(last, 4));
    return m;
}

int esr_synth_json_transforms(const char *dir, const struct esr_synth_scene *s, const struct esr_synth_plan *plan,
                              enum esr_phase_id phase, const char *ext, const struct esr_exif_exposure *exposure)
{
    const char *pname = esr_phase_name(phase), *tag = esr_synth_mask_tag(phase);
    cJSON *root = cJSON_CreateObject();
    cJSON_AddNumberToObject(root, "camera_angle_x", ESR_SYNTH_CAMERA_ANGLE_X);
    cJSON *frames = cJSON_AddArrayToObject(root, "frames");
    for (int i = 0; i < plan->n_frames[phase]; i++) {
        const struct esr_synth_frame *f = &plan->frames[phase][i];
        const struct esr_camera *cam = phase == ESR_PHASE_TRAIN ? &plan->train_cams[f->cam] : &plan->test_cams[f->cam];
        char path[256];
        cJSON *fr = cJSON_CreateObject();
        snprintf(path, sizeof path, "%s/%s%s", pname, f->name, ext);
        cJSON_AddStringToObject(fr, "file_path", path);
        cJSON_AddItemToObject(fr, "transform_matrix", matrix(cam));
        cJSON *lights = cJSON_AddArrayToObject(fr, "lights");
        for (int k = 0; k < s->n_lights; k++) {
            cJSON *l = cJSON_CreateObject();
            cJSON_AddStringToObject(l, "mode", esr_light_mode_name(f->mode));
            if (tag)
                snprintf(path, sizeof path, "masks/%s_%s_l%d", tag, f->name, k);
            else
                path[0] = '\0';
            cJSON_AddStringToObject(l, "mask_path", path);
            cJSON_AddItemToObject(l, "color", vec(f->hsv[k], 3));
            cJSON_AddItemToObject(l, "intensity", num(f->intensity[k]));
            cJSON_AddItemToArray(lights, l);
        }
        if (exposure)
            cJSON_AddItemToObject(fr, "exposure", esr_exif_exposure_json(&exposure[i]));
        cJSON_AddItemToArray(frames, fr);
    }
    char file[4096];
    snprintf(file, sizeof file, "%s/transforms/transforms_%s.json", dir, pname);
    return esr_json_write_atomic(file, root);
}

static cJSON *scene_lights(const struct esr_synth_scene *s)
{
    cJSON *arr = cJSON_CreateArray();
    for (int k = 0; k < s->n_lights; k++) {
        const struct esr_synth_light *l = &s->lights[k];
        float hsv[3], radiance[3];
        esr_rgb_to_hsv(l->rgb, hsv);
        for (int c = 0; c < 3; c++)
            radiance[c] = l->rgb[c] * l->strength;
        cJSON *o = cJSON_CreateObject();
        cJSON_AddNumberToObject(o, "index", k);
        cJSON_AddStringToObject(o, "name", l->name);
        cJSON *objs = cJSON_AddArrayToObject(o, "objects");
        cJSON_AddItemToArray(objs, cJSON_CreateString(s->prims[l->prim].name));
        cJSON_AddItemToObject(o, "emission_rgb_linear", vec(l->rgb, 3));
        cJSON_AddItemToObject(o, "emission_hsv", vec(hsv, 3));
        cJSON_AddItemToObject(o, "emission_strength_on", num(l->strength));
        cJSON_AddItemToObject(o, "emitted_radiance_on", vec(radiance, 3));
        cJSON_AddItemToArray(arr, o);
    }
    return arr;
}

static cJSON *scene_objects(const struct esr_synth_scene *s)
{
    static const char *const kinds[] = {"sphere", "box", "cylinder"};
    static const char *const textures[] = {"none", "checker", "stripes", "noise"};
    cJSON *arr = cJSON_CreateArray();
    for (int i = 0; i < s->n_prims; i++) {
        const struct esr_synth_prim *p = &s->prims[i];
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "name", p->name);
        cJSON_AddStringToObject(o, "shape", kinds[p->kind]);
        float a[3] = {p->a.x, p->a.y, p->a.z}, b[3] = {p->b.x, p->b.y, p->b.z};
        if (p->kind == ESR_SYNTH_SPHERE) {
            cJSON_AddItemToObject(o, "centre", vec(a, 3));
            cJSON_AddItemToObject(o, "radius", num(b[0]));
        } else if (p->kind == ESR_SYNTH_BOX) {
            cJSON_AddItemToObject(o, "min", vec(a, 3));
            cJSON_AddItemToObject(o, "max", vec(b, 3));
        } else {
            cJSON_AddItemToObject(o, "base_centre", vec(a, 3));
            cJSON_AddItemToObject(o, "radius", num(b[0]));
            cJSON_AddItemToObject(o, "height", num(b[1]));
        }
        cJSON_AddItemToObject(o, "base_color", vec(p->mat.base, 3));
        cJSON_AddStringToObject(o, "texture", textures[p->texture]);
        if (p->texture != ESR_SYNTH_TEX_NONE) {
            cJSON_AddItemToObject(o, "base_color_2", vec(p->base2, 3));
            cJSON_AddItemToObject(o, "texture_period", num(p->tex_period));
        }
        cJSON_AddItemToObject(o, "roughness", num(p->mat.roughness));
        cJSON_AddItemToObject(o, "metallic", num(p->mat.metallic));
        cJSON_AddNumberToObject(o, "light", p->light);
        cJSON_AddItemToArray(arr, o);
    }
    return arr;
}

static cJSON *palette(void)
{
    cJSON *arr = cJSON_CreateArray();
    for (int i = 0; i < ESR_SYNTH_PALETTE_SIZE; i++) {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "name", esr_synth_palette_name[i]);
        cJSON_AddItemToObject(o, "hue", num(roundf(esr_synth_palette_hue[i] * 1e6f) / 1e6f));
        cJSON_AddNumberToObject(o, "saturation", 1.0);
        cJSON_AddItemToArray(arr, o);
    }
    return arr;
}

int esr_synth_json_scene(const char *dir, const struct esr_synth_scene *s, const struct esr_synth_plan *plan,
                         const struct esr_synth_settings *set)
{
    cJSON *root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "scene", s->name);
    cJSON_AddStringToObject(root, "generator", "esr synth (path tracer in src/synth)");
    const float res[2] = {(float)set->res, (float)set->res};
    cJSON_AddItemToObject(root, "resolution", vec(res, 2));
    cJSON_AddNumberToObject(root, "camera_angle_x", ESR_SYNTH_CAMERA_ANGLE_X);
    cJSON_AddNumberToObject(root, "camera_radius", ESR_SYNTH_CAMERA_RADIUS);
    const float elev[2] = {(float)ESR_SYNTH_ELEVATION_MIN_DEG, (float)ESR_SYNTH_ELEVATION_MAX_DEG};
    cJSON_AddItemToObject(root, "camera_elevation_deg", vec(elev, 2));
    cJSON_AddStringToObject(root, "camera_distribution",
                            "uniform over the sphere band's area; train and test from separate RNG streams of seed");
    char seed[32];
    snprintf(seed, sizeof seed, "%llu", set->seed);
    cJSON_AddStringToObject(root, "seed", seed); /* a string: 64-bit seeds do not fit a JSON double */
    cJSON_AddNumberToObject(root, "samples_per_pixel", set->spp);
    cJSON_AddNumberToObject(root, "max_bounces", s->max_bounces);
    cJSON_AddStringToObject(root, "integrator",
                            "path tracing, NEE on emitters (area sampling) and world (cosine), MIS power heuristic, "
                            "Russian roulette from the 3rd bounce");
    cJSON_AddStringToObject(root, "pixel_filter", "box, width 1 px, jittered samples");
    cJSON_AddBoolToObject(root, "denoising", 0);
    cJSON_AddNumberToObject(root, "clamp_direct", 0.0);
    cJSON_AddNumberToObject(root, "clamp_indirect", 0.0);
    cJSON_AddStringToObject(root, "view_transform", "Standard");
    cJSON_AddBoolToObject(root, "film_transparent", 1);
    cJSON *world = cJSON_AddObjectToObject(root, "world");
    cJSON_AddStringToObject(world, "type", "uniform");
    cJSON_AddItemToObject(world, "color_rgb_linear", vec(s->world_rgb, 3));
    cJSON_AddItemToObject(world, "strength", num(s->world_strength));
    cJSON *bbox = cJSON_AddObjectToObject(root, "bounding_box");
    const float bmin[3] = {-1.5f, -1.5f, -1.5f}, bmax[3] = {1.5f, 1.5f, 1.5f};
    float lo[3], hi[3];
    esr_synth_scene_bounds(s, lo, hi);
    cJSON_AddItemToObject(bbox, "min", vec(bmin, 3));
    cJSON_AddItemToObject(bbox, "max", vec(bmax, 3));
    cJSON_AddItemToObject(bbox, "tight_min", vec(lo, 3));
    cJSON_AddItemToObject(bbox, "tight_max", vec(hi, 3));
    cJSON_AddItemToObject(root, "lights", scene_lights(s));
    cJSON_AddItemToObject(root, "edit_palette", palette());
    cJSON_AddStringToObject(root, "edit_colour_rule",
                            "edited emission rgb = hsv_to_rgb(h, s, V) with V = max channel of the original emission "
                            "rgb; strength = original strength * intensity");
    cJSON_AddItemToObject(root, "objects", scene_objects(s));
    cJSON *counts = cJSON_AddObjectToObject(root, "counts");
    enum esr_phase_id phases[] = {ESR_PHASE_TRAIN, ESR_PHASE_TEST_NV, ESR_PHASE_TEST_NVI, ESR_PHASE_TEST_NVC,
                                  ESR_PHASE_TEST_NVIC};
    for (int i = 0; i < 5; i++)
        cJSON_AddNumberToObject(counts, esr_phase_name(phases[i]), plan->n_frames[phases[i]]);
    cJSON *gt = cJSON_AddObjectToObject(root, "ground_truth");
    cJSON_AddStringToObject(gt, "mesh", "gt/mesh.ply");
    cJSON_AddStringToObject(gt, "maps", "gt/c<CCC>_{normal,base_color,emission}.exr (RGB), "
                                        "gt/c<CCC>_{roughness,metallic}.exr (Y); one ray per pixel centre, "
                                        "per test camera; normal = world-space outward unit normal, 0 on background; "
                                        "emission = radiance with the light on");
    char file[4096];
    snprintf(file, sizeof file, "%s/scene.json", dir);
    return esr_json_write_atomic(file, root);
}

int esr_synth_json_photos(const char *dir, const struct esr_synth_plan *plan, const struct esr_photo_options *opt,
                          const struct esr_photo_truth *truth)
{
    cJSON *root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "model",
                            "pixel = curve(clip(2^exposure_stops * wb_gain[c] * linear[c], 0, 1)), linear the "
                            "render over white where it is transparent; lights-off set's mean exposure_stops is 0");
    cJSON_AddStringToObject(root, "curve", esr_photo_curve_name(opt->curve));
    cJSON_AddNumberToObject(root, "exposure_jitter", opt->exposure_jitter);
    cJSON_AddNumberToObject(root, "on_exposure", opt->on_exposure);
    cJSON_AddNumberToObject(root, "wb_jitter", opt->wb_jitter);
    cJSON_AddBoolToObject(root, "wb_follow", opt->wb_follow);
    cJSON_AddNumberToObject(root, "noise", opt->noise);
    cJSON_AddNumberToObject(root, "jpeg_quality", opt->jpeg_quality);
    cJSON_AddBoolToObject(root, "exif", opt->exif);
    cJSON *frames = cJSON_AddArrayToObject(root, "frames");
    for (int i = 0; i < plan->n_frames[ESR_PHASE_TRAIN]; i++) {
        const struct esr_synth_frame *f = &plan->frames[ESR_PHASE_TRAIN][i];
        char path[256];
        cJSON *fr = cJSON_CreateObject();
        snprintf(path, sizeof path, "%s/%s%s", esr_phase_name(ESR_PHASE_TRAIN), f->name, esr_synth_train_ext(opt));
        cJSON_AddStringToObject(fr, "file_path", path);
        cJSON_AddStringToObject(fr, "mode", esr_light_mode_name(f->mode));
        cJSON_AddNumberToObject(fr, "exposure_stops", truth[i].stops);
        cJSON *g = cJSON_AddArrayToObject(fr, "wb_gain");
        for (int c = 0; c < 3; c++)
            cJSON_AddItemToArray(g, cJSON_CreateNumber(truth[i].gain[c]));
        cJSON_AddItemToArray(frames, fr);
    }
    char file[4096];
    snprintf(file, sizeof file, "%s/gt/photos.json", dir);
    return esr_json_write_atomic(file, root);
}
