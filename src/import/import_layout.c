/* The ESR-layout pieces the importers share (see import_layout.h). */
#include "import/import_layout.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/error.h"
#include "io/dir.h"
#include "io/json_file.h"

int esr_import_layout_dirs(const char *staging)
{
    char path[ESR_STAGED_PATH];
    snprintf(path, sizeof path, "%s/train", staging);
    ESR_TRY(esr_dir_create(path));
    snprintf(path, sizeof path, "%s/transforms", staging);
    return esr_dir_create(path);
}

int esr_import_write_image(const char *staging, const char *name, struct esr_image *img)
{
    char path[ESR_STAGED_PATH];
    snprintf(path, sizeof path, "%s/train/%s.png", staging, name);
    int status = esr_png_write(path, img, 8);
    esr_image_free(img);
    return status;
}

/* rgb (opaque) with the mask at mask_path as alpha. */
static int attach_mask(const struct esr_image *rgb, const char *mask_path, const char *photo_path,
                       struct esr_image *out)
{
    struct esr_image mask = {0};
    memset(out, 0, sizeof *out);
    ESR_TRY(esr_png_read(mask_path, &mask));
    int status = mask.width == rgb->width && mask.height == rgb->height
                     ? esr_image_alloc(out, rgb->width, rgb->height, 4)
                     : ESR_FAIL("'%s' is %dx%d but its photo '%s' is %dx%d", mask_path, mask.width,
                                mask.height, photo_path, rgb->width, rgb->height);
    if (status == ESR_OK) {
        const size_t np = (size_t)rgb->width * (size_t)rgb->height;
        for (size_t p = 0; p < np; p++) {
            memcpy(out->data + p * 4, rgb->data + p * 3, 3 * sizeof(float));
            out->data[p * 4 + 3] = mask.data[p * (size_t)mask.channels] * 255.0f > 127.5f ? 1.0f : 0.0f;
        }
    }
    esr_image_free(&mask);
    return status;
}

int esr_import_photo_pixels(struct esr_image *photo, const char *photo_path, const char *mask_path,
                            struct esr_image *out)
{
    static const float white[3] = {1.0f, 1.0f, 1.0f};
    struct esr_image rgb = {0};
    int status = esr_image_composite(photo, white, &rgb);
    esr_image_free(photo);
    if (status != ESR_OK || !mask_path[0]) {
        *out = rgb;
        return status;
    }
    status = attach_mask(&rgb, mask_path, photo_path, out);
    esr_image_free(&rgb);
    return status;
}

static cJSON *matrix_json(const double c2w[3][4])
{
    cJSON *rows = cJSON_CreateArray();
    for (int r = 0; r < 4; r++) {
        float row[4] = {0.0f, 0.0f, 0.0f, 1.0f};
        for (int c = 0; r < 3 && c < 4; c++)
            row[c] = (float)c2w[r][c];
        cJSON_AddItemToArray(rows, esr_json_float_array(row, 4));
    }
    return rows;
}

cJSON *esr_import_frame_json(const char *name, const double c2w[3][4], int lights_on)
{
    cJSON *f = cJSON_CreateObject(), *lights = cJSON_CreateArray(), *light = cJSON_CreateObject();
    static const float original_colour[3] = {0.0f, 0.0f, 1.0f};
    char file_path[ESR_NAME_MAX + 8];
    snprintf(file_path, sizeof file_path, "train/%s", name);
    cJSON_AddStringToObject(f, "file_path", file_path);
    cJSON_AddItemToObject(f, "transform_matrix", matrix_json(c2w));
    cJSON_AddStringToObject(light, "mode", lights_on ? "on" : "off");
    cJSON_AddNumberToObject(light, "intensity", lights_on ? 1.0 : 0.0);
    cJSON_AddItemToObject(light, "color", esr_json_float_array(original_colour, 3));
    cJSON_AddStringToObject(light, "mask_path", "");
    cJSON_AddItemToArray(lights, light);
    cJSON_AddItemToObject(f, "lights", lights);
    return f;
}

int esr_import_write_transforms(const char *staging, double camera_angle_x, cJSON *frames)
{
    cJSON *root = cJSON_CreateObject();
    cJSON_AddNumberToObject(root, "camera_angle_x", camera_angle_x);
    cJSON_AddItemToObject(root, "frames", frames);
    char path[ESR_STAGED_PATH];
    snprintf(path, sizeof path, "%s/transforms/transforms_train.json", staging);
    return esr_json_write_atomic(path, root);
}

void esr_import_camera_distance(const double c2w[3][4], double *dist_min, double *dist_max)
{
    double d = sqrt(c2w[0][3] * c2w[0][3] + c2w[1][3] * c2w[1][3] + c2w[2][3] * c2w[2][3]);
    *dist_min = fmin(*dist_min, d);
    *dist_max = fmax(*dist_max, d);
}

cJSON *esr_import_record(const char *source, const char *mapping, const struct esr_scene_frame *f)
{
    cJSON *root = cJSON_CreateObject(), *rot = cJSON_CreateArray();
    cJSON_AddStringToObject(root, "source", source);
    cJSON_AddStringToObject(root, "mapping", mapping);
    double centre[3] = {f->centre[0], f->centre[1], f->centre[2]};
    cJSON_AddItemToObject(root, "centre", cJSON_CreateDoubleArray(centre, 3));
    for (int i = 0; i < 3; i++)
        cJSON_AddItemToArray(rot, cJSON_CreateDoubleArray(f->rotation[i], 3));
    cJSON_AddItemToObject(root, "rotation", rot);
    cJSON_AddNumberToObject(root, "scale", f->scale);
    return root;
}

int esr_import_write_record(const char *staging, cJSON *root)
{
    char path[ESR_STAGED_PATH];
    snprintf(path, sizeof path, "%s/import.json", staging);
    return esr_json_write_atomic(path, root);
}
