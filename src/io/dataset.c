/* Dataset loading (JSON, validated) and file checks. See dataset.h and FORMAT.md. */
#include "io/dataset.h"

#include <cJSON.h>
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "core/error.h"
#include "io/exif_exposure.h"
#include "io/file.h"
#include "io/json_file.h"

static const char *const phase_names[ESR_PHASE_COUNT] = {"train", "test_nv", "test_nvi", "test_nvc", "test_nvic",
                                                         "val"};
static const char *const mode_names[ESR_LIGHT_MODE_COUNT] = {"off", "on", "i_change", "c_change", "ic_change"};

const char *esr_phase_name(enum esr_phase_id phase)
{
    return (unsigned)phase < ESR_PHASE_COUNT ? phase_names[phase] : "?";
}

int esr_phase_from_name(const char *name, enum esr_phase_id *out)
{
    for (int p = 0; p < ESR_PHASE_COUNT; p++)
        if (!strcmp(name, phase_names[p])) {
            *out = (enum esr_phase_id)p;
            return ESR_OK;
        }
    return ESR_FAIL("unknown phase '%s'", name);
}

const char *esr_light_mode_name(enum esr_light_mode mode)
{
    return (unsigned)mode < ESR_LIGHT_MODE_COUNT ? mode_names[mode] : "?";
}

const char *esr_phase_file_name(const struct esr_dataset *ds, enum esr_phase_id phase)
{
    static const char *const esr_files[ESR_PHASE_COUNT] = {
        "transforms/transforms_train.json", "transforms/transforms_test_nv.json", "transforms/transforms_test_nvi.json",
        "transforms/transforms_test_nvc.json", "transforms/transforms_test_nvic.json", NULL};
    static const char *const nerf_files[ESR_PHASE_COUNT] = {"transforms_train.json", "transforms_test.json", NULL,
                                                            NULL, NULL, "transforms_val.json"};
    if ((unsigned)phase >= ESR_PHASE_COUNT)
        return NULL;
    return ds->layout == ESR_LAYOUT_ESR ? esr_files[phase] : nerf_files[phase];
}

enum esr_light_mode esr_frame_mode(const struct esr_dataset *ds, const struct esr_frame *f)
{
    return ds->n_lights > 0 ? f->lights[0].mode : ESR_LIGHT_OFF;
}

/* ---- JSON parsing ---- */

/* What the frame parsers need to name the place of a problem. */
struct json_where {
    const char *file;
    int frame; /* -1: top level */
};

#define JSON_FAIL(w, ...) json_fail(w, __FILE__, __LINE__, __VA_ARGS__)
static int json_fail(const struct json_where *w, const char *src, int line, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
static int json_fail(const struct json_where *w, const char *src, int line, const char *fmt, ...)
{
    char what[512];
    va_list args;
    va_start(args, fmt);
    vsnprintf(what, sizeof what, fmt, args);
    va_end(args);
    if (w->frame >= 0)
        return esr_error_set(src, line, "'%s', frame %d: %s", w->file, w->frame, what);
    return esr_error_set(src, line, "'%s': %s", w->file, what);
}

static int json_number(const struct json_where *w, const cJSON *obj, const char *key, float *out)
{
    const cJSON *item = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!item)
        return JSON_FAIL(w, "missing key '%s'", key);
    if (!cJSON_IsNumber(item) || !(fabs(item->valuedouble) <= FLT_MAX))
        return JSON_FAIL(w, "'%s' must be a finite number", key);
    *out = (float)item->valuedouble;
    return ESR_OK;
}

static int json_string(const struct json_where *w, const cJSON *obj, const char *key, char *out, size_t n)
{
    const cJSON *item = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!item)
        return JSON_FAIL(w, "missing key '%s'", key);
    if (!cJSON_IsString(item))
        return JSON_FAIL(w, "'%s' must be a string", key);
    if (strlen(item->valuestring) >= n)
        return JSON_FAIL(w, "'%s' is too long", key);
    strcpy(out, item->valuestring);
    return ESR_OK;
}

/* A JSON array of exactly n finite numbers. */
static int json_vector(const struct json_where *w, const cJSON *arr, const char *what, float *out, int n)
{
    if (!cJSON_IsArray(arr) || cJSON_GetArraySize(arr) != n)
        return JSON_FAIL(w, "'%s' must be an array of %d numbers", what, n);
    for (int i = 0; i < n; i++) {
        const cJSON *v = cJSON_GetArrayItem(arr, i);
        if (!cJSON_IsNumber(v) || !(fabs(v->valuedouble) <= FLT_MAX)) /* finite as a float too */
            return JSON_FAIL(w, "'%s' has a non-finite or non-numeric entry", what);
        out[i] = (float)v->valuedouble;
    }
    return ESR_OK;
}

static int parse_matrix(const struct json_where *w, const cJSON *frame, struct esr_camera *cam)
{
    const cJSON *m = cJSON_GetObjectItemCaseSensitive(frame, "transform_matrix");
    if (!m)
        return JSON_FAIL(w, "missing key 'transform_matrix'");
    if (!cJSON_IsArray(m) || cJSON_GetArraySize(m) != 4)
        return JSON_FAIL(w, "'transform_matrix' must be 4 rows of 4 numbers");
    float last[4];
    for (int r = 0; r < 4; r++)
        ESR_TRY(json_vector(w, cJSON_GetArrayItem(m, r), "transform_matrix", r < 3 ? cam->c2w[r] : last, 4));
    float(*a)[4] = cam->c2w;
    double det = (double)a[0][0] * ((double)a[1][1] * a[2][2] - (double)a[1][2] * a[2][1]) -
                 (double)a[0][1] * ((double)a[1][0] * a[2][2] - (double)a[1][2] * a[2][0]) +
                 (double)a[0][2] * ((double)a[1][0] * a[2][1] - (double)a[1][1] * a[2][0]);
    if (fabs(det) < 1e-6)
        return JSON_FAIL(w, "'transform_matrix' is degenerate (rotation determinant %g)", det);
    /* Rays and projections take the 3x3 part as a rotation: a scaled, sheared or mirrored camera
     * would silently bend every ray. Float-rounded rotations are off by ~1e-7. */
    double off = 0.0;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double dot = (double)a[0][i] * a[0][j] + (double)a[1][i] * a[1][j] + (double)a[2][i] * a[2][j];
            off = fmax(off, fabs(dot - (i == j)));
        }
    if (!(off < 1e-3) || det < 0.0)
        return JSON_FAIL(w, "'transform_matrix' is not a rigid camera: its 3x3 part is no rotation "
                            "(|R^T R - I| = %.3g, determinant %.3g)", off, det);
    if (fabsf(last[0]) + fabsf(last[1]) + fabsf(last[2]) + fabsf(last[3] - 1.0f) > 1e-4f)
        return JSON_FAIL(w, "'transform_matrix' last row must be [0, 0, 0, 1]");
    return ESR_OK;
}

/* Paths in the JSON name files inside the dataset folder: an absolute path or a ".." component
 * could make esr read any file of the machine. */
static int check_inside(const struct json_where *w, const char *key, const char *path)
{
    const char *p = path;
    int escapes = path[0] == '/';
    while (!escapes && *p) {
        size_t n = strcspn(p, "/");
        escapes = n == 2 && p[0] == '.' && p[1] == '.';
        p += n + (p[n] == '/');
    }
    if (escapes)
        return JSON_FAIL(w, "'%s' = '%s' leaves the dataset folder (absolute path or '..')", key, path);
    return ESR_OK;
}

static int parse_light(const struct json_where *w, const cJSON *obj, struct esr_light_state *light)
{
    char mode[32];
    if (!cJSON_IsObject(obj))
        return JSON_FAIL(w, "each entry of 'lights' must be an object");
    ESR_TRY(json_string(w, obj, "mode", mode, sizeof mode));
    int m = 0;
    while (m < ESR_LIGHT_MODE_COUNT && strcmp(mode, mode_names[m]))
        m++;
    if (m == ESR_LIGHT_MODE_COUNT)
        return JSON_FAIL(w, "unknown light mode '%s'", mode);
    light->mode = (enum esr_light_mode)m;
    ESR_TRY(json_number(w, obj, "intensity", &light->intensity));
    if (light->intensity < 0.0f)
        return JSON_FAIL(w, "light intensity %g is negative (a multiplier of its 'on' strength)",
                         (double)light->intensity);
    if (light->mode == ESR_LIGHT_OFF && light->intensity != 0.0f)
        return JSON_FAIL(w, "a light in mode 'off' has intensity %g (an off light has 0)",
                         (double)light->intensity);
    if (light->mode == ESR_LIGHT_ON && light->intensity == 0.0f)
        return JSON_FAIL(w, "a light in mode 'on' has intensity 0 (an on light's is above 0; an "
                            "unlit one is mode 'off')");
    const cJSON *color = cJSON_GetObjectItemCaseSensitive(obj, "color");
    if (!color)
        return JSON_FAIL(w, "missing key 'color'");
    ESR_TRY(json_vector(w, color, "color", light->hsv, 3));
    for (int c = 0; c < 3; c++)
        if (!(light->hsv[c] >= 0.0f && light->hsv[c] <= 1.0f))
            return JSON_FAIL(w, "light color [%g, %g, %g] is not an HSV triple in [0, 1]",
                             (double)light->hsv[0], (double)light->hsv[1], (double)light->hsv[2]);
    light->mask_path[0] = '\0';
    if (cJSON_GetObjectItemCaseSensitive(obj, "mask_path"))
        ESR_TRY(json_string(w, obj, "mask_path", light->mask_path, sizeof light->mask_path));
    return check_inside(w, "mask_path", light->mask_path);
}

/* Lights of an ESR frame; the first frame parsed fixes the dataset's light count. */
static int parse_lights(const struct json_where *w, const cJSON *frame, struct esr_dataset *ds, struct esr_frame *f)
{
    const cJSON *lights = cJSON_GetObjectItemCaseSensitive(frame, "lights");
    if (!lights)
        return JSON_FAIL(w, "missing key 'lights'");
    if (!cJSON_IsArray(lights))
        return JSON_FAIL(w, "'lights' must be an array");
    int n = cJSON_GetArraySize(lights);
    if (ds->n_lights < 0)
        ds->n_lights = n;
    if (n != ds->n_lights)
        return JSON_FAIL(w, "has %d lights but earlier frames have %d", n, ds->n_lights);
    if (n == 0)
        return ESR_OK;
    f->lights = calloc((size_t)n, sizeof *f->lights);
    if (!f->lights)
        return JSON_FAIL(w, "out of memory");
    for (int k = 0; k < n; k++) {
        ESR_TRY(parse_light(w, cJSON_GetArrayItem(lights, k), &f->lights[k]));
        if (f->lights[k].intensity > 0.0f)
            f->lights_on = 1;
    }
    return ESR_OK;
}

/* Length of the image extension a file_path may carry (".png", ".jpg", ".jpeg"), else 0. */
static size_t frame_image_extension(const char *file_path)
{
    static const char *const exts[] = {".png", ".jpg", ".jpeg"};
    size_t len = strlen(file_path);
    for (size_t i = 0; i < sizeof exts / sizeof exts[0]; i++) {
        size_t m = strlen(exts[i]);
        if (len > m && !strcmp(file_path + len - m, exts[i]))
            return m;
    }
    return 0;
}

/* The frame's optional "exposure" {"exposure_time_s", "f_number", "iso"}. */
static int parse_exposure(const struct json_where *w, const cJSON *frame, struct esr_frame *f)
{
    const cJSON *ex = cJSON_GetObjectItemCaseSensitive(frame, "exposure");
    if (!ex)
        return ESR_OK;
    if (!cJSON_IsObject(ex))
        return JSON_FAIL(w, "'exposure' must be an object {\"exposure_time_s\", \"f_number\", \"iso\"}");
    float t = 0.0f, n = 0.0f, iso = 0.0f;
    ESR_TRY(json_number(w, ex, "exposure_time_s", &t));
    ESR_TRY(json_number(w, ex, "f_number", &n));
    ESR_TRY(json_number(w, ex, "iso", &iso));
    if (iso != floorf(iso) || !(iso >= 1.0f && iso <= 1e6f))
        return JSON_FAIL(w, "'exposure': 'iso' must be a whole number in [1, 1000000]");
    const struct esr_exif_exposure e = {t, n, (int)iso};
    char why[96];
    if (esr_exif_exposure_check(&e, why, sizeof why) != 0)
        return JSON_FAIL(w, "'exposure': %s", why);
    f->has_exposure = 1;
    f->exposure_ev = log2(esr_exif_relative_exposure(&e));
    return ESR_OK;
}

static int parse_frame(const struct json_where *w, const cJSON *obj, struct esr_dataset *ds, struct esr_frame *f)
{
    if (!cJSON_IsObject(obj))
        return JSON_FAIL(w, "frame must be an object");
    ESR_TRY(json_string(w, obj, "file_path", f->file_path, sizeof f->file_path));
    if (!f->file_path[0])
        return JSON_FAIL(w, "'file_path' is empty");
    ESR_TRY(check_inside(w, "file_path", f->file_path));
    const char *slash = strrchr(f->file_path, '/');
    const char *base = slash ? slash + 1 : f->file_path;
    if (strlen(base) >= sizeof f->name)
        return JSON_FAIL(w, "'file_path' name is too long");
    strcpy(f->name, base);
    f->name[strlen(f->name) - frame_image_extension(f->name)] = '\0';
    ESR_TRY(parse_matrix(w, obj, &f->camera));
    ESR_TRY(parse_exposure(w, obj, f));
    if (ds->layout == ESR_LAYOUT_ESR)
        ESR_TRY(parse_lights(w, obj, ds, f));
    return ESR_OK;
}

static cJSON *parse_json_text(const char *text, size_t size, const char *name)
{
    char quoted[4200];
    snprintf(quoted, sizeof quoted, "'%s'", name);
    return esr_json_parse_whole(text, size, quoted);
}

/* Two frames of a phase naming one image are a mistake in the file (a copy-paste), never two
 * views: refused rather than trained on twice. */
static int check_unique_frames(const struct json_where *where, const struct esr_phase *ph)
{
    for (int i = 1; i < ph->n_frames; i++)
        for (int j = 0; j < i; j++)
            if (!strcmp(ph->frames[i].file_path, ph->frames[j].file_path)) {
                struct json_where w = {where->file, i};
                return JSON_FAIL(&w, "repeats frame %d ('file_path' '%s')", j, ph->frames[i].file_path);
            }
    return ESR_OK;
}

static int parse_phase(struct esr_dataset *ds, enum esr_phase_id phase, const cJSON *root, const char *name)
{
    struct json_where w = {name, -1};
    struct esr_phase *ph = &ds->phases[phase];
    int status = ESR_OK;
    float angle = 0.0f;
    const cJSON *frames = cJSON_GetObjectItemCaseSensitive(root, "frames");
    if (!cJSON_IsObject(root))
        status = JSON_FAIL(&w, "top level must be an object");
    else if (json_number(&w, root, "camera_angle_x", &angle) != ESR_OK)
        status = ESR_ERR;
    else if (!(angle > 0.0f && angle < 3.1f))
        status = JSON_FAIL(&w, "'camera_angle_x' = %g is not a field of view in radians", (double)angle);
    else if (ds->camera_angle_x > 0.0f && fabsf(angle - ds->camera_angle_x) > 1e-6f)
        status = JSON_FAIL(&w, "'camera_angle_x' differs from the other phases");
    else if (!frames)
        status = JSON_FAIL(&w, "missing key 'frames'");
    else if (!cJSON_IsArray(frames) || cJSON_GetArraySize(frames) == 0)
        status = JSON_FAIL(&w, "'frames' must be a non-empty array");
    if (status == ESR_OK) {
        ds->camera_angle_x = angle;
        ph->present = 1;
        ph->n_frames = cJSON_GetArraySize(frames);
        ph->frames = calloc((size_t)ph->n_frames, sizeof *ph->frames);
        if (!ph->frames)
            status = JSON_FAIL(&w, "out of memory");
        for (int i = 0; i < ph->n_frames && status == ESR_OK; i++) {
            w.frame = i;
            status = parse_frame(&w, cJSON_GetArrayItem(frames, i), ds, &ph->frames[i]);
        }
        if (status == ESR_OK)
            status = check_unique_frames(&w, ph);
    }
    return status;
}

int esr_dataset_parse_transforms(struct esr_dataset *ds, enum esr_phase_id phase, const char *text, size_t size,
                                 const char *name)
{
    cJSON *root = parse_json_text(text, size, name);
    if (!root)
        return ESR_ERR;
    int status = parse_phase(ds, phase, root, name);
    cJSON_Delete(root);
    return status;
}

static int load_phase(struct esr_dataset *ds, enum esr_phase_id phase, const char *path)
{
    unsigned char *text;
    size_t size;
    ESR_TRY(esr_file_read_all(path, &text, &size));
    int status = esr_dataset_parse_transforms(ds, phase, (const char *)text, size, path);
    free(text);
    return status;
}

/* scene.json's "lights": name and emitted radiance of each, in index order (ground truth for
 * evaluation; a light without "emitted_radiance_on" ends the list). */
static int load_true_lights(const struct json_where *w, const cJSON *lights, struct esr_dataset *ds)
{
    ds->n_true_lights = 0;
    if (!cJSON_IsArray(lights))
        return ESR_OK;
    const int n = cJSON_GetArraySize(lights);
    for (int i = 0; i < n && i < ESR_MAX_TRUE_LIGHTS; i++) {
        const cJSON *l = cJSON_GetArrayItem(lights, i);
        const cJSON *rad = cJSON_GetObjectItemCaseSensitive(l, "emitted_radiance_on");
        if (!rad)
            break;
        struct esr_true_light *t = &ds->true_lights[i];
        ESR_TRY(json_vector(w, rad, "lights[].emitted_radiance_on", t->radiance, 3));
        const cJSON *name = cJSON_GetObjectItemCaseSensitive(l, "name");
        snprintf(t->name, sizeof t->name, "%s", cJSON_IsString(name) ? name->valuestring : "");
        ds->n_true_lights = i + 1;
    }
    return ESR_OK;
}

/* scene.json is ground truth and optional; when present it must parse, and its box and lights
 * are used (defaults otherwise). */
static int load_scene_truth(struct esr_dataset *ds)
{
    for (int k = 0; k < 3; k++) {
        ds->bbox_min[k] = -1.5f;
        ds->bbox_max[k] = 1.5f;
    }
    char path[ESR_PATH_MAX + 16];
    snprintf(path, sizeof path, "%s/scene.json", ds->root);
    if (!esr_file_exists(path))
        return ESR_OK;
    unsigned char *text;
    size_t size;
    ESR_TRY(esr_file_read_all(path, &text, &size));
    int status = esr_dataset_parse_scene(ds, (const char *)text, size, path);
    free(text);
    return status;
}

/* The model's grids have res^3 points over the box and everything that measures in voxels
 * (light areas, shadow-ray offsets, smoothing) takes them as cubes, so a box whose sides differ is
 * widened to a cube of its longest side about its centre (more empty space, never less scene). */
static void make_box_cubic(struct esr_dataset *ds)
{
    float side = 0.0f;
    for (int k = 0; k < 3; k++)
        side = fmaxf(side, ds->bbox_max[k] - ds->bbox_min[k]);
    for (int k = 0; k < 3; k++) {
        const float len = ds->bbox_max[k] - ds->bbox_min[k];
        if (len >= side * (1.0f - 1e-6f))
            continue;
        const float centre = 0.5f * (ds->bbox_min[k] + ds->bbox_max[k]);
        ds->bbox_min[k] = centre - 0.5f * side;
        ds->bbox_max[k] = centre + 0.5f * side;
        ds->bbox_made_cubic = 1;
    }
}

int esr_dataset_parse_scene(struct esr_dataset *ds, const char *text, size_t size, const char *name)
{
    cJSON *root = parse_json_text(text, size, name);
    if (!root)
        return ESR_ERR;
    struct json_where w = {name, -1};
    const cJSON *box = cJSON_GetObjectItemCaseSensitive(root, "bounding_box");
    int status = ESR_OK;
    if (box) {
        status = json_vector(&w, cJSON_GetObjectItemCaseSensitive(box, "min"), "bounding_box.min", ds->bbox_min, 3);
        if (status == ESR_OK)
            status = json_vector(&w, cJSON_GetObjectItemCaseSensitive(box, "max"), "bounding_box.max", ds->bbox_max, 3);
        for (int k = 0; k < 3 && status == ESR_OK; k++)
            if (!(ds->bbox_min[k] < ds->bbox_max[k]))
                status = JSON_FAIL(&w, "'bounding_box' min must be below max");
        ds->bbox_from_scene = status == ESR_OK;
        if (status == ESR_OK)
            make_box_cubic(ds);
    }
    if (status == ESR_OK)
        status = load_true_lights(&w, cJSON_GetObjectItemCaseSensitive(root, "lights"), ds);
    cJSON_Delete(root);
    return status;
}

/* Size most common among the first few training images that decode (the check compares every
 * other image with it and reports those that differ or do not decode: `esr info` lists every
 * problem, where a broken or odd-sized first image used to stop it or make every other image
 * "wrong"). Fails with the first image's error when none decodes. */
#define SIZE_VOTES 5
static int load_size(struct esr_dataset *ds)
{
    const struct esr_phase *train = &ds->phases[ESR_PHASE_TRAIN];
    char path[ESR_PATH_MAX * 2 + 8], first_error[1024] = "";
    int w[SIZE_VOTES], h[SIZE_VOTES], got = 0;
    for (int f = 0; f < train->n_frames && got < SIZE_VOTES; f++) {
        esr_frame_image_path(ds, &train->frames[f], path, sizeof path);
        struct esr_image img;
        if (esr_image_read(path, &img) == ESR_OK) {
            w[got] = img.width;
            h[got++] = img.height;
            esr_image_free(&img);
        } else {
            if (f == 0)
                snprintf(first_error, sizeof first_error, "%s", esr_error_message());
            esr_error_clear();
        }
    }
    if (got == 0)
        return ESR_FAIL("%s", first_error);
    int best = 0, best_votes = 0;
    for (int a = 0; a < got; a++) {
        int votes = 0;
        for (int b = 0; b < got; b++)
            votes += w[b] == w[a] && h[b] == h[a];
        if (votes > best_votes) {
            best = a;
            best_votes = votes;
        }
    }
    ds->width = w[best];
    ds->height = h[best];
    ds->focal = esr_focal_from_fov(ds->width, ds->camera_angle_x);
    for (int p = 0; p < ESR_PHASE_COUNT; p++)
        for (int i = 0; i < ds->phases[p].n_frames; i++) {
            struct esr_camera *cam = &ds->phases[p].frames[i].camera;
            cam->width = ds->width;
            cam->height = ds->height;
            cam->focal = ds->focal;
        }
    return ESR_OK;
}

static int load_all(const char *dir, struct esr_dataset *ds)
{
    if (strlen(dir) >= sizeof ds->root)
        return ESR_FAIL("dataset path too long: '%s'", dir);
    strcpy(ds->root, dir);
    char path[ESR_PATH_MAX + 64];
    snprintf(path, sizeof path, "%s/transforms/transforms_train.json", dir);
    if (esr_file_exists(path)) {
        ds->layout = ESR_LAYOUT_ESR;
    } else {
        snprintf(path, sizeof path, "%s/transforms_train.json", dir);
        if (!esr_file_exists(path))
            return ESR_FAIL("'%s' is not a dataset: neither transforms/transforms_train.json (ESR layout) nor "
                            "transforms_train.json (NeRF-synthetic) exists",
                            dir);
        ds->layout = ESR_LAYOUT_NERF_SYNTHETIC;
    }
    for (int p = 0; p < ESR_PHASE_COUNT; p++) {
        const char *file = esr_phase_file_name(ds, (enum esr_phase_id)p);
        if (!file)
            continue;
        snprintf(path, sizeof path, "%s/%s", dir, file);
        if (p != ESR_PHASE_TRAIN && !esr_file_exists(path))
            continue;
        ESR_TRY(load_phase(ds, (enum esr_phase_id)p, path));
    }
    if (ds->n_lights < 0)
        ds->n_lights = 0;
    ESR_TRY(load_scene_truth(ds));
    return load_size(ds);
}

const char *esr_dataset_bbox_source(const struct esr_dataset *ds)
{
    return ds->bbox_made_cubic ? "scene.json, widened to a cube" : ds->bbox_from_scene ? "scene.json" : "default";
}

int esr_dataset_load(const char *dir, struct esr_dataset *ds)
{
    memset(ds, 0, sizeof *ds);
    ds->n_lights = -1; /* fixed by the first frame with lights */
    if (load_all(dir, ds) != ESR_OK) {
        esr_dataset_free(ds);
        return ESR_ERR;
    }
    return ESR_OK;
}

void esr_dataset_free(struct esr_dataset *ds)
{
    for (int p = 0; p < ESR_PHASE_COUNT; p++) {
        struct esr_phase *ph = &ds->phases[p];
        for (int i = 0; i < ph->n_frames && ph->frames; i++)
            free(ph->frames[i].lights);
        free(ph->frames);
        ph->frames = NULL;
        ph->n_frames = 0;
        ph->present = 0;
    }
}

/* ---- paths ---- */

void esr_frame_image_path(const struct esr_dataset *ds, const struct esr_frame *f, char *out, size_t n)
{
    snprintf(out, n, "%s/%s%s", ds->root, f->file_path, frame_image_extension(f->file_path) ? "" : ".png");
}

/* "<root>/<dir of file_path>/<sub>/<name><ext>" */
static void frame_side_path(const struct esr_dataset *ds, const struct esr_frame *f, const char *sub,
                            const char *ext, char *out, size_t n)
{
    const char *slash = strrchr(f->file_path, '/');
    int dir_len = slash ? (int)(slash - f->file_path) : 0;
    snprintf(out, n, "%s/%.*s%s%s/%s%s", ds->root, dir_len, f->file_path, dir_len ? "/" : "", sub, f->name, ext);
}

void esr_frame_exr_path(const struct esr_dataset *ds, const struct esr_frame *f, char *out, size_t n)
{
    frame_side_path(ds, f, "exr", ".exr", out, n);
}

void esr_frame_emission_path(const struct esr_dataset *ds, const struct esr_frame *f, char *out, size_t n)
{
    frame_side_path(ds, f, "emission", ".png", out, n);
}

void esr_frame_light_mask_path(const struct esr_dataset *ds, const struct esr_frame *f, int light, char *out,
                               size_t n)
{
    if (light < 0 || light >= ds->n_lights || !f->lights[light].mask_path[0]) {
        if (n)
            out[0] = '\0';
        return;
    }
    snprintf(out, n, "%s/%s.png", ds->root, f->lights[light].mask_path);
}

int esr_frame_load_rgb(const struct esr_dataset *ds, const struct esr_frame *f, struct esr_image *rgb,
                       struct esr_image *alpha)
{
    char path[ESR_PATH_MAX * 2 + 8];
    esr_frame_image_path(ds, f, path, sizeof path);
    struct esr_image img;
    ESR_TRY(esr_image_read(path, &img));
    int status = ESR_OK;
    if (img.width != ds->width || img.height != ds->height)
        status = ESR_FAIL("'%s' is %dx%d, the dataset's images are %dx%d", path, img.width, img.height, ds->width,
                          ds->height);
    else if (img.channels < 3)
        status = ESR_FAIL("'%s' is not an RGB(A) image (%d channels)", path, img.channels);
    static const float white[3] = {1.0f, 1.0f, 1.0f};
    if (status == ESR_OK)
        status = esr_image_composite(&img, white, rgb);
    if (status == ESR_OK && alpha) {
        status = esr_image_alloc(alpha, img.width, img.height, 1);
        size_t n = (size_t)img.width * (size_t)img.height;
        for (size_t p = 0; p < n && status == ESR_OK; p++)
            alpha->data[p] = img.channels == 4 ? img.data[p * 4 + 3] : 1.0f;
        if (status != ESR_OK)
            esr_image_free(rgb);
    }
    esr_image_free(&img);
    return status;
}

/* ---- file checks ---- */

#define CHECK_MSG 768

/* Problems of one frame, collected per frame so the check can run in parallel and still report
 * in frame order. */
struct frame_problems {
    int count;
    char text[4][CHECK_MSG]; /* the first few; count keeps the total */
};

static void add_problem(struct frame_problems *fp, const char *message)
{
    if (fp->count < 4)
        snprintf(fp->text[fp->count], CHECK_MSG, "%s", message);
    fp->count++;
}

/* Any image the dataset names (PNG, JPEG or EXR by its extension) must decode at the dataset's
 * size; a frame's photo must also be RGB(A) (training reads colour; a grey photo is refused here
 * rather than when training reaches it); masks are grey by design. */
enum image_kind { IMAGE_PHOTO, IMAGE_OTHER };

static void check_image(const struct esr_dataset *ds, const char *path, enum image_kind kind,
                        struct frame_problems *fp)
{
    struct esr_image img;
    esr_error_clear();
    if (esr_image_read(path, &img) != ESR_OK) {
        add_problem(fp, esr_error_message());
        esr_error_clear();
        return;
    }
    if (img.width != ds->width || img.height != ds->height) {
        char msg[CHECK_MSG];
        snprintf(msg, sizeof msg, "'%s' is %dx%d, the dataset's images are %dx%d", path, img.width, img.height,
                 ds->width, ds->height);
        add_problem(fp, msg);
    }
    if (kind == IMAGE_PHOTO && img.channels < 3) {
        char msg[CHECK_MSG];
        snprintf(msg, sizeof msg, "'%s' is not an RGB(A) image (%d channels)", path, img.channels);
        add_problem(fp, msg);
    }
    esr_image_free(&img);
}

static int dir_exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISDIR(st.st_mode);
}

static void check_frame(const struct esr_dataset *ds, const struct esr_frame *f, int with_exr, int with_emission,
                        struct frame_problems *fp)
{
    char path[ESR_PATH_MAX * 2 + 32];
    esr_frame_image_path(ds, f, path, sizeof path);
    check_image(ds, path, IMAGE_PHOTO, fp);
    if (with_exr) {
        esr_frame_exr_path(ds, f, path, sizeof path);
        check_image(ds, path, IMAGE_OTHER, fp);
    }
    if (with_emission) {
        esr_frame_emission_path(ds, f, path, sizeof path);
        check_image(ds, path, IMAGE_OTHER, fp);
    }
    for (int k = 0; k < ds->n_lights; k++) {
        esr_frame_light_mask_path(ds, f, k, path, sizeof path);
        if (path[0])
            check_image(ds, path, IMAGE_OTHER, fp);
    }
}

int esr_dataset_check(const struct esr_dataset *ds, esr_problem_fn report, void *user)
{
    int total = 0;
    for (int p = 0; p < ESR_PHASE_COUNT; p++) {
        const struct esr_phase *ph = &ds->phases[p];
        if (!ph->present)
            continue;
        /* EXRs / emission masks are checked where the phase has those folders (test phases). */
        int with_exr = 0, with_emission = 0;
        if (p != ESR_PHASE_TRAIN && ds->layout == ESR_LAYOUT_ESR) {
            char dir[ESR_PATH_MAX + 64];
            snprintf(dir, sizeof dir, "%s/%s/exr", ds->root, phase_names[p]);
            with_exr = dir_exists(dir);
            snprintf(dir, sizeof dir, "%s/%s/emission", ds->root, phase_names[p]);
            with_emission = dir_exists(dir);
        }
        struct frame_problems *fps = calloc((size_t)ph->n_frames, sizeof *fps);
        if (!fps)
            return ESR_FAIL("out of memory checking '%s'", ds->root);
#pragma omp parallel for schedule(dynamic, 4)
        for (int i = 0; i < ph->n_frames; i++)
            check_frame(ds, &ph->frames[i], with_exr, with_emission, &fps[i]);
        for (int i = 0; i < ph->n_frames; i++) {
            for (int k = 0; k < fps[i].count && k < 4; k++)
                report(user, fps[i].text[k]);
            if (fps[i].count > 4) {
                char msg[256];
                snprintf(msg, sizeof msg, "%s frame %d: %d more problems", phase_names[p], i, fps[i].count - 4);
                report(user, msg);
            }
            total += fps[i].count;
        }
        free(fps);
    }
    return total;
}

int esr_frame_off_partner(const char *name, char *out, size_t n)
{
    const size_t len = strlen(name);
    if (len < 3 || strcmp(name + len - 3, "_on") != 0)
        return 0;
    return snprintf(out, n, "%.*s_off", (int)(len - 3), name) < (int)n;
}
