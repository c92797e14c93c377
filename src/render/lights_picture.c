/* The lights' picture (lights_picture.h). */
#include "render/lights_picture.h"

#include <stdio.h>
#include <string.h>

#include "core/error.h"
#include "io/camera.h"
#include "render/digit_font.h"

int esr_lights_picture_scale(int width)
{
    if (width <= 0 || width >= ESR_LIGHTS_PICTURE_MIN_WIDTH)
        return 1;
    return (ESR_LIGHTS_PICTURE_MIN_WIDTH + width - 1) / width;
}

/* Whether light i's centroid projects inside cam's image, and where (pixels of the photo). */
static int project(const struct esr_lights *L, int i, const struct esr_camera *cam, float *px,
                   float *py)
{
    return esr_camera_project(cam, L->light[i].centroid, px, py) && *px >= 0.0f && *py >= 0.0f &&
           *px < (float)cam->width && *py < (float)cam->height;
}

static const struct esr_frame *pick_frame(const struct esr_lights *L, const struct esr_phase *ph)
{
    const struct esr_frame *best = NULL;
    int best_n = -1, best_lit = 0;
    for (int f = 0; f < ph->n_frames; f++) {
        const struct esr_frame *fr = &ph->frames[f];
        int n = 0;
        for (int i = 0; i < L->n; i++) {
            float px, py;
            n += project(L, i, &fr->camera, &px, &py);
        }
        /* a lit frame shows the lights themselves; among those, the most centroids in view */
        if ((fr->lights_on && !best_lit) || (fr->lights_on == best_lit && n > best_n)) {
            best = fr, best_n = n, best_lit = fr->lights_on;
        }
    }
    return best;
}

static void put(struct esr_image *img, int x, int y, const float rgb[3])
{
    if (x < 0 || y < 0 || x >= img->width || y >= img->height)
        return;
    float *p = img->data + ((size_t)y * (size_t)img->width + (size_t)x) * 3;
    memcpy(p, rgb, 3 * sizeof(float));
}

/* A cross at (x, y), arms r pixels long, white on a black outline. */
static void cross(struct esr_image *img, int x, int y, int r)
{
    static const float black[3] = {0, 0, 0}, white[3] = {1, 1, 1};
    for (int d = -r - 1; d <= r + 1; d++)
        for (int w = -1; w <= 1; w++) {
            put(img, x + d, y + w, black);
            put(img, x + w, y + d, black);
        }
    for (int d = -r; d <= r; d++) {
        put(img, x + d, y, white);
        put(img, x, y + d, white);
    }
}

int esr_lights_picture(const struct esr_lights *L, const struct esr_dataset *ds,
                       struct esr_image *out, char *frame, size_t size, int shown[ESR_MAX_LIGHTS])
{
    memset(out, 0, sizeof *out);
    memset(shown, 0, ESR_MAX_LIGHTS * sizeof shown[0]);
    const struct esr_phase *ph = &ds->phases[ESR_PHASE_TRAIN];
    const struct esr_frame *fr = ph->present ? pick_frame(L, ph) : NULL;
    if (!fr)
        return ESR_FAIL("dataset %s: no training frame to draw the lights on", ds->root);
    snprintf(frame, size, "%s", fr->name);
    struct esr_image photo;
    ESR_TRY(esr_frame_load_rgb(ds, fr, &photo, NULL));
    const int k = esr_lights_picture_scale(photo.width);
    int rc = esr_image_alloc(out, photo.width * k, photo.height * k, 3);
    for (int y = 0; rc == ESR_OK && y < out->height; y++)
        for (int x = 0; x < out->width; x++)
            memcpy(out->data + ((size_t)y * (size_t)out->width + (size_t)x) * 3,
                   photo.data + ((size_t)(y / k) * (size_t)photo.width + (size_t)(x / k)) * 3,
                   3 * sizeof(float));
    esr_image_free(&photo);
    if (rc != ESR_OK)
        return rc;
    /* font pixels of 2 at the minimum width, more on a larger picture */
    const int s = out->width / 128 > 2 ? out->width / 128 : 2, arm = 2 * s;
    static const float fg[3] = {1, 1, 1}, bg[3] = {0, 0, 0};
    for (int i = 0; i < L->n; i++) {
        float px, py;
        if (!project(L, i, &fr->camera, &px, &py))
            continue;
        shown[i] = 1;
        const int x = (int)(px * (float)k), y = (int)(py * (float)k);
        cross(out, x, y, arm);
        int w, h;
        esr_digits_size(i, s, &w, &h);
        /* up and right of the cross, kept inside the picture */
        int bx = x + arm + 2, by = y - arm - h;
        if (bx + w > out->width)
            bx = x - arm - 2 - w;
        if (by < 0)
            by = y + arm + 2;
        esr_digits_draw(out, bx, by, i, s, fg, bg);
    }
    return ESR_OK;
}
