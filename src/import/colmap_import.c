/* `esr import colmap`: plan the frames, choose the shared pinhole view and the scene's place,
 * then undistort every photo into a staging folder and write the JSON (see colmap_import.h). */
#include "import/colmap_import.h"

#include <cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "core/error.h"
#include "import/colmap_camera.h"
#include "import/colmap_test_views.h"
#include "import/colmap_undistort.h"
#include "io/dataset.h"
#include "io/exif_exposure.h"
#include "io/file.h"
#include "import/import_layout.h"
#include "io/staging.h"

/* One registered photo and what it becomes. */
struct frame_plan {
    const struct esr_colmap_image *image;
    int lights_on;
    int jpeg;                     /* else PNG */
    char out_name[ESR_NAME_MAX];  /* "<stem>_<off|on>" */
    char src_path[ESR_PATH_MAX];  /* IMAGES/<name> */
    char mask_path[ESR_PATH_MAX]; /* MASKS/<name>.png or MASKS/<name without extension>.png; "" */
};

static int compare_plans(const void *a, const void *b)
{
    return strcmp(((const struct frame_plan *)a)->image->name, ((const struct frame_plan *)b)->image->name);
}

static int ends_with(const char *s, const char *suffix)
{
    size_t n = strlen(s), m = strlen(suffix);
    if (n < m)
        return 0;
    for (size_t i = 0; i < m; i++)
        if ((s[n - m + i] | 0x20) != suffix[i]) /* ASCII case-insensitive for letters */
            return 0;
    return 1;
}

/* The mask of the photo `name` (its extension at name[ext]): COLMAP's name, else the stem's. */
static int find_mask(const char *masks_dir, const char *name, int ext, struct frame_plan *p)
{
    char stem[ESR_PATH_MAX];
    if (snprintf(p->mask_path, sizeof p->mask_path, "%s/%s.png", masks_dir, name) >= (int)sizeof p->mask_path ||
        snprintf(stem, sizeof stem, "%s/%.*s.png", masks_dir, ext, name) >= (int)sizeof stem)
        return ESR_FAIL("mask path for image '%s' is too long", name);
    if (esr_file_exists(p->mask_path))
        return ESR_OK;
    if (!esr_file_exists(stem))
        return ESR_FAIL("no mask for image '%s': with --masks every registered photo needs '%s' or '%s'", name,
                        p->mask_path, stem);
    memcpy(p->mask_path, stem, sizeof stem);
    return ESR_OK;
}

/* Lighting (from the first folder of the name), photo type, output name, source and mask path. */
static int plan_frame(const struct esr_colmap_import_opts *o, const char *model_file,
                      const struct esr_colmap_image *im, struct frame_plan *p)
{
    p->image = im;
    if (!strncmp(im->name, "off/", 4))
        p->lights_on = 0;
    else if (!strncmp(im->name, "on/", 3))
        p->lights_on = 1;
    else
        return ESR_FAIL("'%s': image %u '%s' is in neither off/ nor on/ (photos with the lights off go in "
                        "IMAGES/off/, with the lights on in IMAGES/on/)", model_file, im->id, im->name);
    const char *slash = strrchr(im->name, '/'), *base = slash + 1, *dot = strrchr(base, '.');
    p->jpeg = ends_with(im->name, ".jpg") || ends_with(im->name, ".jpeg");
    if (!p->jpeg && !ends_with(im->name, ".png"))
        return ESR_FAIL("'%s': image '%s' is neither JPEG (.jpg, .jpeg) nor PNG", model_file, im->name);
    int stem = (int)(dot - base);
    if (snprintf(p->out_name, sizeof p->out_name, "%.*s_%s", stem, base, p->lights_on ? "on" : "off") >=
            (int)sizeof p->out_name ||
        snprintf(p->src_path, sizeof p->src_path, "%s/%s", o->images_dir, im->name) >= (int)sizeof p->src_path)
        return ESR_FAIL("'%s': image name '%s' is too long", model_file, im->name);
    struct stat st;
    if (stat(p->src_path, &st) == 0 && !S_ISREG(st.st_mode))
        return ESR_FAIL("'%s' is not a file (image %u of the COLMAP model in '%s')", p->src_path,
                        im->id, o->model_dir);
    if (!esr_file_exists(p->src_path))
        return ESR_FAIL("'%s' is missing (image %u of the COLMAP model in '%s')", p->src_path, im->id, o->model_dir);
    return o->masks_dir ? find_mask(o->masks_dir, im->name, (int)(dot - im->name), p) : ESR_OK;
}

/* The frames sorted by name, every output name unique. */
static int plan_frames(const struct esr_colmap_import_opts *o, const struct esr_colmap_model *m,
                       struct frame_plan **out)
{
    char model_file[ESR_PATH_MAX];
    snprintf(model_file, sizeof model_file, "%s/images.%s", o->model_dir, !strcmp(m->format, "text") ? "txt" : "bin");
    if (m->n_images < 3)
        return ESR_FAIL("'%s' has %d registered images; esr needs at least 3", model_file, m->n_images);
    struct frame_plan *p = calloc((size_t)m->n_images, sizeof *p);
    if (!p)
        return ESR_FAIL("out of memory planning the import");
    int status = ESR_OK;
    for (int i = 0; i < m->n_images && status == ESR_OK; i++)
        status = plan_frame(o, model_file, &m->images[i], &p[i]);
    if (status == ESR_OK)
        qsort(p, (size_t)m->n_images, sizeof *p, compare_plans);
    for (int i = 0; i < m->n_images && status == ESR_OK; i++)
        for (int j = i + 1; j < m->n_images && status == ESR_OK; j++)
            if (!strcmp(p[i].out_name, p[j].out_name))
                status = ESR_FAIL("'%s': images '%s' and '%s' would both be written as '%s'; give them different "
                                  "file names", model_file, p[i].image->name, p[j].image->name, p[i].out_name);
    if (status != ESR_OK)
        free(p);
    else
        *out = p;
    return status;
}

/* The half extents the undistorted views of all registered photos cover: the smallest over the
 * cameras the images use, each camera once however many photos share it. */
static int common_extent(const struct esr_colmap_model *m, double *hx, double *hy)
{
    *hx = *hy = INFINITY;
    for (int c = 0; c < m->n_cameras; c++) {
        const struct esr_colmap_camera *cam = &m->cameras[c];
        int used = 0;
        for (int i = 0; i < m->n_images && !used; i++)
            used = m->images[i].camera_id == cam->id;
        if (!used)
            continue;
        double cx, cy;
        ESR_TRY(esr_colmap_valid_extent(cam, &cx, &cy));
        *hx = fmin(*hx, cx);
        *hy = fmin(*hy, cy);
    }
    return ESR_OK;
}

/* The one pinhole view every frame is written in: the field of view all cameras cover, the
 * longer side `size` pixels. */
static int choose_view(const struct esr_colmap_model *m, int size, struct esr_pinhole_view *v)
{
    double hx, hy;
    ESR_TRY(common_extent(m, &hx, &hy));
    return esr_pinhole_view_fit(hx, hy, size, v);
}

/* The true dataset's pinhole (align_to), and how much of its half field of view the COLMAP
 * cameras' valid extents cover. */
static int true_view(const struct esr_colmap_model *m, const struct esr_dataset *truth, struct esr_pinhole_view *v,
                     double *coverage)
{
    v->width = truth->width;
    v->height = truth->height;
    v->focal = truth->focal;
    double cx, cy;
    ESR_TRY(common_extent(m, &cx, &cy));
    *coverage = fmin(1.0, fmin(cx / (0.5 * v->width / v->focal), cy / (0.5 * v->height / v->focal)));
    return ESR_OK;
}

/* Where the scene goes and the view the photos are written in: by the model alone, or (truth
 * given) by the alignment to the true cameras in the true pinhole. */
static int place_scene(const struct esr_colmap_import_opts *o, const struct esr_colmap_model *m,
                       const struct esr_dataset *truth, struct esr_pinhole_view *view,
                       struct esr_colmap_import_result *r)
{
    if (!truth) {
        ESR_TRY(choose_view(m, o->size, view));
        return esr_colmap_scene_frame(m, &r->frame);
    }
    ESR_TRY(esr_colmap_align(m, truth, &r->alignment));
    esr_colmap_alignment_frame(&r->alignment, &r->frame);
    r->aligned = 1;
    return true_view(m, truth, view, &r->view_coverage);
}


static int write_frame_image(const struct esr_colmap_model *m, const struct frame_plan *p,
                             const struct esr_pinhole_view *view, const char *staging)
{
    const struct esr_colmap_camera *cam = esr_colmap_find_camera(m, p->image->camera_id);
    struct esr_image photo, out;
    /* as stored: COLMAP ignores the EXIF orientation, so its cameras describe these pixels */
    ESR_TRY(p->jpeg ? esr_jpeg_read_stored(p->src_path, &photo) : esr_png_read(p->src_path, &photo));
    if (photo.width != cam->width || photo.height != cam->height) {
        int status = ESR_FAIL("'%s' is %dx%d but its COLMAP camera %u is %dx%d", p->src_path, photo.width,
                              photo.height, cam->id, cam->width, cam->height);
        esr_image_free(&photo);
        return status;
    }
    struct esr_image pixels; /* the mask, if any, travels with the colours as alpha */
    ESR_TRY(esr_import_photo_pixels(&photo, p->src_path, p->mask_path, &pixels));
    int status = esr_colmap_undistort_image(cam, &pixels, view, &out);
    esr_image_free(&pixels);
    if (status != ESR_OK)
        return status;
    return esr_import_write_image(staging, p->out_name, &out);
}

/* The EXIF exposure of a JPEG photo: 1 with *e, 0 when it has none or absurd values (counted in
 * r, the first reason kept), -1 when the file cannot be read. */
static int photo_exposure(const struct frame_plan *p, struct esr_exif_exposure *e, struct esr_colmap_import_result *r)
{
    unsigned char *data = NULL;
    size_t size = 0;
    if (esr_file_read_all(p->src_path, &data, &size) != ESR_OK)
        return -1;
    char why[160];
    const int got = esr_exif_exposure_read(data, size, e, why, sizeof why);
    free(data);
    if (got < 0 && r->n_exposure_bad++ == 0)
        snprintf(r->exposure_bad, sizeof r->exposure_bad, "'%s': %s", p->src_path, why);
    r->n_exposure += got > 0;
    return got > 0;
}

/* transforms_train.json, and the range of camera distances the result reports. */
static int write_transforms(const struct frame_plan *plans, int n, const char *staging,
                            struct esr_colmap_import_result *r)
{
    cJSON *frames = cJSON_CreateArray();
    r->cam_dist_min = INFINITY;
    r->cam_dist_max = 0.0;
    for (int i = 0; i < n; i++) {
        double c2w[3][4], placed[3][4];
        esr_colmap_camera_to_world(plans[i].image, c2w);
        esr_scene_frame_apply(&r->frame, c2w, placed);
        esr_import_camera_distance(placed, &r->cam_dist_min, &r->cam_dist_max);
        cJSON *f = esr_import_frame_json(plans[i].out_name, placed, plans[i].lights_on);
        cJSON_AddStringToObject(f, "colmap_image", plans[i].image->name);
        struct esr_exif_exposure e;
        const int ex = plans[i].jpeg ? photo_exposure(&plans[i], &e, r) : 0;
        if (ex < 0) {
            cJSON_Delete(f);
            cJSON_Delete(frames);
            return ESR_ERR;
        }
        if (ex > 0)
            cJSON_AddItemToObject(f, "exposure", esr_exif_exposure_json(&e));
        cJSON_AddItemToArray(frames, f);
    }
    return esr_import_write_transforms(staging, r->camera_angle_x, frames);
}

/* import.json's record of the comparison with the true cameras. */
static cJSON *alignment_json(const struct esr_colmap_import_opts *o, const struct esr_colmap_import_result *r)
{
    const struct esr_colmap_alignment *a = &r->alignment;
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "true_dataset", o->align_to);
    cJSON_AddNumberToObject(j, "registered_images", a->n_registered);
    cJSON_AddNumberToObject(j, "matched_images", a->n_matched);
    cJSON_AddNumberToObject(j, "true_train_frames", a->n_true);
    cJSON_AddNumberToObject(j, "rotation_error_median_deg", a->rot_median_deg);
    cJSON_AddNumberToObject(j, "rotation_error_max_deg", a->rot_max_deg);
    cJSON_AddNumberToObject(j, "position_error_median", a->pos_median);
    cJSON_AddNumberToObject(j, "position_error_max", a->pos_max);
    cJSON_AddNumberToObject(j, "scene_radius", a->scene_radius);
    cJSON_AddNumberToObject(j, "position_error_median_rel", a->pos_median_rel);
    cJSON_AddNumberToObject(j, "position_error_max_rel", a->pos_max_rel);
    cJSON_AddNumberToObject(j, "inliers", a->n_inliers);
    cJSON_AddNumberToObject(j, "inlier_threshold", a->inlier_threshold);
    cJSON_AddNumberToObject(j, "inlier_rotation_error_median_deg", a->rot_median_inliers_deg);
    cJSON_AddNumberToObject(j, "inlier_rotation_error_max_deg", a->rot_max_inliers_deg);
    cJSON_AddNumberToObject(j, "inlier_position_error_median", a->pos_median_inliers);
    cJSON_AddNumberToObject(j, "inlier_position_error_max", a->pos_max_inliers);
    cJSON_AddNumberToObject(j, "colmap_to_true_scale", a->colmap_to_true.scale);
    cJSON_AddNumberToObject(j, "view_coverage", r->view_coverage);
    cJSON_AddNumberToObject(j, "test_views", r->n_test_views);
    return j;
}

/* import.json: where the COLMAP world went, so poses can be mapped back. */
static int write_record(const struct esr_colmap_import_opts *o, const struct esr_colmap_import_result *r,
                        const char *staging)
{
    cJSON *root = esr_import_record("colmap", "esr = scale * rotation * (colmap - centre)", &r->frame);
    cJSON_AddStringToObject(root, "model", o->model_dir);
    cJSON_AddStringToObject(root, "model_format", r->format);
    cJSON_AddStringToObject(root, "images", o->images_dir);
    cJSON_AddBoolToObject(root, "placed_by_points", r->frame.from_points);
    cJSON_AddStringToObject(root, "placed_by", r->aligned ? "alignment" : r->frame.from_points ? "points" : "cameras");
    cJSON_AddNumberToObject(root, "focal", r->focal);
    cJSON_AddBoolToObject(root, "masks", o->masks_dir != NULL);
    cJSON_AddStringToObject(root, "alpha", o->masks_dir ? o->masks_dir : "none");
    cJSON_AddNumberToObject(root, "exif_exposure_frames", r->n_exposure);
    if (r->aligned)
        cJSON_AddItemToObject(root, "alignment", alignment_json(o, r));
    return esr_import_write_record(staging, root);
}

/* Everything written into staging. */
static int write_dataset(const struct esr_colmap_import_opts *o, const struct esr_colmap_model *m,
                         const struct frame_plan *plans, const struct esr_pinhole_view *view,
                         const struct esr_dataset *truth, struct esr_colmap_import_result *r, const char *staging)
{
    ESR_TRY(esr_import_layout_dirs(staging));
    for (int i = 0; i < m->n_images; i++) {
        ESR_TRY(write_frame_image(m, &plans[i], view, staging));
        if (o->progress)
            o->progress(o->user, i + 1, m->n_images);
    }
    ESR_TRY(write_transforms(plans, m->n_images, staging, r));
    if (truth)
        ESR_TRY(esr_colmap_write_test_views(truth, r->camera_angle_x, staging, &r->n_test_views));
    return write_record(o, r, staging);
}

static int import_model(const struct esr_colmap_import_opts *o, const struct esr_colmap_model *m,
                        const struct esr_dataset *truth, struct esr_colmap_import_result *r)
{
    struct frame_plan *plans = NULL;
    struct esr_pinhole_view view;
    ESR_TRY(plan_frames(o, m, &plans));
    int status = place_scene(o, m, truth, &view, r);
    char staging[ESR_PATH_MAX];
    const char *const inputs[] = {o->model_dir, o->images_dir, o->masks_dir, o->align_to};
    if (status == ESR_OK)
        status = esr_staging_check_apart(o->out_dir, inputs, 4);
    if (status == ESR_OK)
        status = esr_staging_begin(o->out_dir, o->force, staging, sizeof staging);
    if (status == ESR_OK) {
        r->format = m->format;
        r->n_frames = m->n_images;
        for (int i = 0; i < m->n_images; i++)
            r->n_on += plans[i].lights_on;
        r->n_off = r->n_frames - r->n_on;
        r->width = view.width;
        r->height = view.height;
        r->focal = view.focal;
        /* the true value itself when aligned: the phases' camera_angle_x must agree exactly */
        r->camera_angle_x = truth ? truth->camera_angle_x : 2.0 * atan(0.5 * view.width / view.focal);
        status = write_dataset(o, m, plans, &view, truth, r, staging);
        if (status == ESR_OK)
            status = esr_staging_commit(staging, o->out_dir);
        if (status != ESR_OK)
            esr_remove_tree(staging); /* keeps the first (real) error message */
    }
    free(plans);
    return status;
}

int esr_colmap_import(const struct esr_colmap_import_opts *o, struct esr_colmap_import_result *r)
{
    memset(r, 0, sizeof *r);
    if (o->size < 8 || o->size > 16384)
        return ESR_FAIL("output size %d is outside 8..16384 pixels", o->size);
    struct esr_dataset truth;
    if (o->align_to)
        ESR_TRY(esr_dataset_load(o->align_to, &truth));
    struct esr_colmap_model m;
    int status = esr_colmap_model_read(o->model_dir, &m);
    if (status == ESR_OK) {
        status = import_model(o, &m, o->align_to ? &truth : NULL, r);
        esr_colmap_model_free(&m);
    }
    if (o->align_to)
        esr_dataset_free(&truth);
    return status;
}
