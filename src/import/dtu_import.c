/* `esr import dtu`: list the photos and their masks, read their cameras, choose the shared
 * pinhole view and the scene's place, then resample every photo into a staging folder and write
 * the JSON (see dtu_import.h). */
#include "import/dtu_import.h"

#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#include "core/error.h"
#include "import/colmap_undistort.h"
#include "import/dtu_cameras.h"
#include "io/file.h"
#include "import/import_layout.h"
#include "io/staging.h"

#define MAX_FRAMES 100000

/* One photo and what it becomes. */
struct dtu_frame {
    int index;                  /* camera index: the number in the photo's name */
    char file[ESR_NAME_MAX];    /* "000000.png" */
    char stem[ESR_NAME_MAX];    /* "000000" */
    char image[ESR_PATH_MAX];   /* SCAN/image/<file> */
    char mask[ESR_PATH_MAX];    /* SCAN/mask/..., "" without masks */
    struct esr_dtu_camera cam;
};

static int is_dir(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISDIR(st.st_mode);
}

static int image_extension(const char *name)
{
    const char *dot = strrchr(name, '.');
    return dot && (!strcasecmp(dot, ".png") || !strcasecmp(dot, ".jpg") || !strcasecmp(dot, ".jpeg"));
}

/* By stem, then file name, so photos that would get the same output name are neighbours. */
static int compare_frames(const void *a, const void *b)
{
    const struct dtu_frame *x = (const struct dtu_frame *)a, *y = (const struct dtu_frame *)b;
    int c = strcmp(x->stem, y->stem);
    return c ? c : strcmp(x->file, y->file);
}

/* The photo `file` of SCAN/image: its index from the digits of its stem. */
static int plan_photo(const char *scan, const char *file, struct dtu_frame *f)
{
    const char *dot = strrchr(file, '.');
    size_t stem = (size_t)(dot - file);
    if (stem == 0 || stem > 9 || strspn(file, "0123456789") != stem)
        return ESR_FAIL("'%s/image/%s': a DTU photo is named by its camera index (000000.png, 000001.png, ...)",
                        scan, file);
    f->index = atoi(file);
    if (snprintf(f->file, sizeof f->file, "%s", file) >= (int)sizeof f->file ||
        snprintf(f->image, sizeof f->image, "%s/image/%s", scan, file) >= (int)sizeof f->image)
        return ESR_FAIL("'%s/image/%s': path too long", scan, file);
    snprintf(f->stem, sizeof f->stem, "%.*s", (int)stem, file);
    return ESR_OK;
}

/* The photos of SCAN/image, sorted by name. */
static int list_photos(const char *scan, struct dtu_frame **out, int *n_out)
{
    char dir[ESR_PATH_MAX + 16];
    snprintf(dir, sizeof dir, "%s/image", scan);
    DIR *d = opendir(dir);
    if (!d)
        return ESR_FAIL("'%s' is missing or unreadable: a DTU scan has its photos in image/ (000000.png, ...)", dir);
    struct dtu_frame *f = NULL;
    int n = 0, cap = 0, status = ESR_OK;
    for (struct dirent *e; status == ESR_OK && (e = readdir(d));) {
        if (e->d_name[0] == '.' || !image_extension(e->d_name))
            continue;
        if (n == MAX_FRAMES) {
            status = ESR_FAIL("'%s' holds more than %d photos", dir, MAX_FRAMES);
            break;
        }
        if (n == cap) {
            cap = cap ? 2 * cap : 64;
            struct dtu_frame *g = realloc(f, (size_t)cap * sizeof *g);
            if (!g) {
                status = ESR_FAIL("out of memory listing '%s'", dir);
                break;
            }
            f = g;
        }
        memset(&f[n], 0, sizeof f[n]);
        status = plan_photo(scan, e->d_name, &f[n++]);
    }
    closedir(d);
    if (status == ESR_OK && n == 0)
        status = ESR_FAIL("'%s' holds no photos (.png, .jpg)", dir);
    if (status != ESR_OK) {
        free(f);
        return status;
    }
    qsort(f, (size_t)n, sizeof *f, compare_frames);
    for (int i = 1; i < n; i++)
        if (!strcmp(f[i - 1].stem, f[i].stem)) {
            status = ESR_FAIL("'%s' and '%s' would both be written as '%s_off'; keep one", f[i - 1].image,
                              f[i].image, f[i].stem);
            free(f);
            return status;
        }
    *out = f;
    *n_out = n;
    return ESR_OK;
}

/* Each photo's mask: mask/<stem>.png, else mask/<index as %03d>.png (NeuS's naming). */
static int find_masks(const char *scan, struct dtu_frame *f, int n)
{
    for (int i = 0; i < n; i++) {
        snprintf(f[i].mask, sizeof f[i].mask, "%s/mask/%s.png", scan, f[i].stem);
        if (esr_file_exists(f[i].mask))
            continue;
        snprintf(f[i].mask, sizeof f[i].mask, "%s/mask/%03d.png", scan, f[i].index);
        if (!esr_file_exists(f[i].mask))
            return ESR_FAIL("'%s' is missing: the scan has mask/, so every photo needs its mask ('%s')", f[i].mask,
                            f[i].image);
    }
    return ESR_OK;
}

static int read_cameras(const char *scan, struct dtu_frame *f, int n)
{
    char path[ESR_PATH_MAX + 32];
    snprintf(path, sizeof path, "%s/cameras_sphere.npz", scan);
    struct esr_npz z;
    ESR_TRY(esr_npz_open(path, &z));
    int status = ESR_OK;
    for (int i = 0; i < n && status == ESR_OK; i++)
        status = esr_dtu_camera_read(&z, f[i].index, f[i].image, &f[i].cam);
    esr_npz_close(&z);
    return status;
}

/* The one pinhole view every frame is written in: what all cameras cover of a width x height
 * photo, `size` pixels on the longer side. */
static int choose_view(const struct dtu_frame *f, int n, int width, int height, int size,
                       struct esr_pinhole_view *v)
{
    double hx = INFINITY, hy = INFINITY;
    for (int i = 0; i < n; i++) {
        double cx, cy;
        char what[ESR_PATH_MAX + 32];
        snprintf(what, sizeof what, "the camera of '%s'", f[i].image);
        ESR_TRY(esr_undistort_extent(&f[i].cam.k, width, height, what, &cx, &cy));
        hx = fmin(hx, cx);
        hy = fmin(hy, cy);
    }
    return esr_pinhole_view_fit(hx, hy, size, v);
}

/* The photo as RGB on white, with the mask as a fourth channel when there is one. */
static int read_photo(const struct dtu_frame *f, int width, int height, struct esr_image *out)
{
    struct esr_image photo;
    ESR_TRY(esr_image_read(f->image, &photo));
    if (photo.width != width || photo.height != height) {
        int status = ESR_FAIL("'%s' is %dx%d but the scan's first photo is %dx%d", f->image, photo.width,
                              photo.height, width, height);
        esr_image_free(&photo);
        return status;
    }
    return esr_import_photo_pixels(&photo, f->image, f->mask, out);
}

static int write_frame_image(const struct dtu_frame *f, int width, int height, const struct esr_pinhole_view *view,
                             const char *staging)
{
    struct esr_image photo, out;
    ESR_TRY(read_photo(f, width, height, &photo));
    int status = esr_undistort_resample(&f->cam.k, &photo, view, &out);
    esr_image_free(&photo);
    if (status != ESR_OK)
        return status;
    char name[ESR_NAME_MAX + 8];
    snprintf(name, sizeof name, "%s_off", f->stem);
    return esr_import_write_image(staging, name, &out);
}

static int write_transforms(const struct dtu_frame *f, int n, const char *staging, struct esr_dtu_import_result *r)
{
    cJSON *frames = cJSON_CreateArray();
    r->cam_dist_min = INFINITY;
    r->cam_dist_max = 0.0;
    for (int i = 0; i < n; i++) {
        double placed[3][4];
        char name[ESR_NAME_MAX + 8], image[ESR_NAME_MAX + 8];
        esr_scene_frame_apply(&r->frame, f[i].cam.c2w, placed);
        esr_import_camera_distance(placed, &r->cam_dist_min, &r->cam_dist_max);
        snprintf(name, sizeof name, "%s_off", f[i].stem);
        snprintf(image, sizeof image, "image/%s", f[i].file);
        cJSON *frame = esr_import_frame_json(name, placed, 0);
        cJSON_AddStringToObject(frame, "dtu_image", image);
        cJSON_AddNumberToObject(frame, "dtu_camera", f[i].index);
        cJSON_AddItemToArray(frames, frame);
    }
    return esr_import_write_transforms(staging, r->camera_angle_x, frames);
}

/* import.json: where the normalised frame went, and what was read. */
static int write_record(const struct esr_dtu_import_opts *o, const struct esr_dtu_import_result *r,
                        const char *staging)
{
    cJSON *root = esr_import_record(
        "dtu", "esr = scale * rotation * (x - centre), x in the normalised frame (world = scale_mat x)", &r->frame);
    cJSON_AddStringToObject(root, "scan", o->scan_dir);
    cJSON_AddStringToObject(root, "cameras", "cameras_sphere.npz");
    cJSON_AddBoolToObject(root, "masks", r->masks);
    cJSON_AddStringToObject(root, "alpha", r->masks ? "mask/ (> 127 foreground)" : "none");
    cJSON_AddNumberToObject(root, "source_width", r->source_width);
    cJSON_AddNumberToObject(root, "source_height", r->source_height);
    cJSON_AddNumberToObject(root, "focal", r->focal);
    return esr_import_write_record(staging, root);
}

static int write_dataset(const struct esr_dtu_import_opts *o, const struct dtu_frame *f, int n,
                         const struct esr_pinhole_view *view, struct esr_dtu_import_result *r, const char *staging)
{
    ESR_TRY(esr_import_layout_dirs(staging));
    for (int i = 0; i < n; i++) {
        ESR_TRY(write_frame_image(&f[i], r->source_width, r->source_height, view, staging));
        if (o->progress)
            o->progress(o->user, i + 1, n);
    }
    ESR_TRY(write_transforms(f, n, staging, r));
    return write_record(o, r, staging);
}

/* The size of the first photo, which every photo must share. */
static int photo_size(const struct dtu_frame *f, int *width, int *height)
{
    struct esr_image img;
    ESR_TRY(esr_image_read(f->image, &img));
    *width = img.width;
    *height = img.height;
    esr_image_free(&img);
    return ESR_OK;
}

/* Everything once the photos are listed. */
static int import_frames(const struct esr_dtu_import_opts *o, struct dtu_frame *f, int n,
                         struct esr_dtu_import_result *r)
{
    char mask_dir[ESR_PATH_MAX + 16];
    snprintf(mask_dir, sizeof mask_dir, "%s/mask", o->scan_dir);
    r->masks = is_dir(mask_dir);
    if (r->masks)
        ESR_TRY(find_masks(o->scan_dir, f, n));
    ESR_TRY(read_cameras(o->scan_dir, f, n));
    ESR_TRY(photo_size(&f[0], &r->source_width, &r->source_height));
    struct esr_pinhole_view view;
    ESR_TRY(choose_view(f, n, r->source_width, r->source_height, o->size, &view));
    double (*c2w)[3][4] = malloc((size_t)n * sizeof *c2w);
    if (!c2w)
        return ESR_FAIL("out of memory placing the scene");
    for (int i = 0; i < n; i++)
        memcpy(c2w[i], f[i].cam.c2w, sizeof c2w[i]);
    memset(&r->frame, 0, sizeof r->frame);
    r->frame.radius = 1.0; /* the normalised frame's unit sphere holds the object */
    int status = esr_scene_frame_place((const double (*)[3][4])c2w, n, &r->frame);
    free(c2w);
    ESR_TRY(status);
    r->n_frames = n;
    r->width = view.width;
    r->height = view.height;
    r->focal = view.focal;
    r->camera_angle_x = 2.0 * atan(0.5 * view.width / view.focal);
    char staging[ESR_PATH_MAX];
    const char *const inputs[] = {o->scan_dir};
    ESR_TRY(esr_staging_check_apart(o->out_dir, inputs, 1));
    ESR_TRY(esr_staging_begin(o->out_dir, o->force, staging, sizeof staging));
    status = write_dataset(o, f, n, &view, r, staging);
    if (status == ESR_OK)
        status = esr_staging_commit(staging, o->out_dir);
    if (status != ESR_OK)
        esr_remove_tree(staging); /* keeps the first (real) error message */
    return status;
}

int esr_dtu_import(const struct esr_dtu_import_opts *o, struct esr_dtu_import_result *r)
{
    memset(r, 0, sizeof *r);
    if (o->size < 8 || o->size > 16384)
        return ESR_FAIL("output size %d is outside 8..16384 pixels", o->size);
    struct dtu_frame *f = NULL;
    int n = 0;
    ESR_TRY(list_photos(o->scan_dir, &f, &n));
    int status = import_frames(o, f, n, r);
    free(f);
    return status;
}
