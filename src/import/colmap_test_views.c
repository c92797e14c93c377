/* The true dataset's test_nv phase copied into an aligned import (see colmap_test_views.h). */
#include "import/colmap_test_views.h"

#include <stdio.h>
#include <string.h>

#include <cjson/cJSON.h>

#include "core/error.h"
#include "io/dir.h"
#include "io/file.h"
#include "io/json_file.h"

#define COPY_PATH (ESR_PATH_MAX * 2 + 32)

/* Copies src to dst (atomically) when src exists and `optional`; a missing required src fails. */
static int copy_file(const char *src, const char *dst, int optional)
{
    if (optional && !esr_file_exists(src))
        return ESR_OK;
    return esr_file_copy(src, dst);
}

/* The parent folder of path made (mkdir -p). */
static int make_parent(const char *path)
{
    char dir[COPY_PATH];
    snprintf(dir, sizeof dir, "%s", path);
    char *slash = strrchr(dir, '/');
    if (!slash)
        return ESR_OK;
    *slash = '\0';
    return esr_dir_create(dir);
}

/* The frame's image, EXR and emission mask from truth into out (the same dataset rooted at
 * out_dir: the path helpers then give the destinations). */
static int copy_frame_files(const struct esr_dataset *truth, const struct esr_dataset *out, const struct esr_frame *f)
{
    void (*const path_of[3])(const struct esr_dataset *, const struct esr_frame *, char *, size_t) = {
        esr_frame_image_path, esr_frame_exr_path, esr_frame_emission_path};
    for (int k = 0; k < 3; k++) {
        char src[COPY_PATH], dst[COPY_PATH];
        path_of[k](truth, f, src, sizeof src);
        path_of[k](out, f, dst, sizeof dst);
        ESR_TRY(make_parent(dst));
        ESR_TRY(copy_file(src, dst, k > 0)); /* the EXR and mask serve only some scores */
    }
    return ESR_OK;
}

static cJSON *frame_json(const struct esr_frame *f)
{
    cJSON *frame = cJSON_CreateObject(), *rows = cJSON_CreateArray(), *lights = cJSON_CreateArray(),
          *light = cJSON_CreateObject();
    static const float original_colour[3] = {0.0f, 0.0f, 1.0f}, last_row[4] = {0.0f, 0.0f, 0.0f, 1.0f};
    for (int r = 0; r < 3; r++)
        cJSON_AddItemToArray(rows, esr_json_float_array(f->camera.c2w[r], 4));
    cJSON_AddItemToArray(rows, esr_json_float_array(last_row, 4));
    cJSON_AddStringToObject(frame, "file_path", f->file_path);
    cJSON_AddItemToObject(frame, "transform_matrix", rows);
    cJSON_AddStringToObject(light, "mode", f->lights_on ? "on" : "off");
    cJSON_AddNumberToObject(light, "intensity", f->lights_on ? 1.0 : 0.0);
    cJSON_AddItemToObject(light, "color", esr_json_float_array(original_colour, 3));
    cJSON_AddStringToObject(light, "mask_path", "");
    cJSON_AddItemToArray(lights, light);
    cJSON_AddItemToObject(frame, "lights", lights);
    return frame;
}

int esr_colmap_write_test_views(const struct esr_dataset *truth, double camera_angle_x, const char *out_dir,
                                int *n_views)
{
    const struct esr_phase *nv = &truth->phases[ESR_PHASE_TEST_NV];
    *n_views = 0;
    if (!nv->present || nv->n_frames < 1)
        return ESR_FAIL("'%s' has no test_nv phase to score the import on", truth->root);
    struct esr_dataset out = *truth; /* shallow: only its root differs, never freed */
    if (snprintf(out.root, sizeof out.root, "%s", out_dir) >= (int)sizeof out.root)
        return ESR_FAIL("output path '%s' is too long", out_dir);
    cJSON *root = cJSON_CreateObject(), *frames = cJSON_CreateArray();
    cJSON_AddNumberToObject(root, "camera_angle_x", camera_angle_x);
    cJSON_AddItemToObject(root, "frames", frames);
    int status = ESR_OK;
    for (int i = 0; i < nv->n_frames && status == ESR_OK; i++) {
        status = copy_frame_files(truth, &out, &nv->frames[i]);
        cJSON_AddItemToArray(frames, frame_json(&nv->frames[i]));
    }
    if (status != ESR_OK) {
        cJSON_Delete(root);
        return status;
    }
    char path[COPY_PATH];
    snprintf(path, sizeof path, "%s/transforms/transforms_test_nv.json", out_dir);
    ESR_TRY(esr_json_write_atomic(path, root));
    *n_views = nv->n_frames;
    return ESR_OK;
}
