/* `esr synth` end to end: plan, render the train frames and each test camera's light basis, compose
 * the test frames, masks and ground truth, JSON, then publish the staging directory. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

#include "core/colour.h"
#include "core/error.h"
#include "core/rng.h"
#include "io/exif_exposure.h"
#include "io/ply.h"
#include "io/staging.h"
#include "synth/json.h"
#include "synth/plan.h"
#include "synth/synth.h"
#include "synth/trace.h"

#define PATH_LEN 4096
#define MESH_SEGMENTS 64

static const enum esr_phase_id phases[] = {ESR_PHASE_TRAIN, ESR_PHASE_TEST_NV, ESR_PHASE_TEST_NVI,
                                           ESR_PHASE_TEST_NVC, ESR_PHASE_TEST_NVIC};
#define N_PHASES 5

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int make_dir(const char *root, const char *sub)
{
    char path[PATH_LEN];
    snprintf(path, sizeof path, "%s/%s", root, sub);
    if (mkdir(path, 0777) != 0 && errno != EEXIST)
        return ESR_FAIL("cannot create directory '%s': %s", path, strerror(errno));
    return ESR_OK;
}

static int make_layout(const char *root)
{
    static const char *const dirs[] = {"transforms", "train", "test_nv", "test_nv/exr", "test_nv/emission",
                                       "test_nvi", "test_nvi/exr", "test_nvc", "test_nvc/exr", "test_nvic",
                                       "test_nvic/exr", "masks", "gt"};
    for (size_t i = 0; i < sizeof dirs / sizeof dirs[0]; i++)
        ESR_TRY(make_dir(root, dirs[i]));
    return ESR_OK;
}

/* Premultiplied linear RGBA -> the dataset's PNG: straight alpha, sRGB of clip(rgb / alpha). */
static int write_png_from_linear(const char *path, const struct esr_image *lin, struct esr_image *tmp)
{
    size_t n = (size_t)lin->width * (size_t)lin->height;
    for (size_t i = 0; i < n; i++) {
        const float *src = lin->data + 4 * i;
        float *dst = tmp->data + 4 * i, a = src[3];
        for (int c = 0; c < 3; c++)
            dst[c] = a > 0.0f ? esr_srgb_from_linear(fminf(fmaxf(src[c] / a, 0.0f), 1.0f)) : 0.0f;
        dst[3] = a;
    }
    return esr_png_write(path, tmp, 8);
}

/* Grey 0/255 mask of the pixels whose centre ray hits light `light` (-1: any emitter). */
static int write_mask(const char *path, const struct esr_synth_scene *s, const int *prim, int light,
                      struct esr_image *mask)
{
    size_t n = (size_t)mask->width * (size_t)mask->height;
    for (size_t i = 0; i < n; i++) {
        int k = prim[i] >= 0 ? s->prims[prim[i]].light : -1;
        mask->data[i] = (k >= 0 && (light < 0 || k == light)) ? 1.0f : 0.0f;
    }
    return esr_png_write(path, mask, 8);
}

/* A train photo (photo.h) to its PNG or JPEG: opaque over white where the render is not, exposed by
 * 2^stops times the white-balance gains, clipped, through the camera's tone curve. */
static int write_photo(const char *path, const struct esr_image *lin, const struct esr_photo_truth *t,
                       const struct esr_photo_options *opt, struct esr_rng *noise, struct esr_image *tmp)
{
    const size_t n = (size_t)lin->width * (size_t)lin->height;
    const double exposure = exp2(t->stops);
    for (size_t i = 0; i < n; i++) {
        const float *src = lin->data + 4 * i;
        float *dst = tmp->data + 4 * i;
        for (int c = 0; c < 3; c++) {
            const double scene = (double)src[c] + (1.0 - (double)src[3]); /* premultiplied over white */
            const double grain = opt->noise > 0.0 ? opt->noise * (double)esr_rng_normal(noise) : 0.0;
            dst[c] = (float)esr_photo_encode(opt->curve, exposure * t->gain[c] * scene + grain);
        }
        dst[3] = 1.0f;
    }
    if (opt->jpeg_quality && opt->exif) {
        struct esr_exif_exposure e;
        esr_photo_exif(t, &e);
        unsigned char *app1;
        size_t size;
        ESR_TRY(esr_exif_exposure_payload(&e, &app1, &size));
        const int rc = esr_jpeg_write(path, tmp, opt->jpeg_quality, app1, size);
        free(app1);
        return rc;
    }
    if (opt->jpeg_quality)
        return esr_jpeg_write(path, tmp, opt->jpeg_quality, NULL, 0);
    return esr_png_write(path, tmp, 8);
}

struct job {
    const char *root;
    const struct esr_synth_scene *scene;
    const struct esr_synth_plan *plan;
    const struct esr_synth_options *opt;
    int res, spp;
    uint64_t image_id;               /* next RNG image index */
    const struct esr_photo_truth *photos; /* per train frame; NULL: plain renders */
    struct esr_image lin, png, mask; /* scratch */
};

/* Masks of one test frame: per light in masks/, and the union in test_nv/emission/. */
static int write_frame_masks(struct job *j, enum esr_phase_id ph, const struct esr_synth_frame *f, const int *prim)
{
    char path[PATH_LEN];
    for (int k = 0; k < j->scene->n_lights; k++) {
        snprintf(path, sizeof path, "%s/masks/%s_%s_l%d.png", j->root, esr_synth_mask_tag(ph), f->name, k);
        ESR_TRY(write_mask(path, j->scene, prim, k, &j->mask));
    }
    if (ph == ESR_PHASE_TEST_NV) {
        snprintf(path, sizeof path, "%s/test_nv/emission/%s.png", j->root, f->name);
        ESR_TRY(write_mask(path, j->scene, prim, -1, &j->mask));
    }
    return ESR_OK;
}

static int write_gt_maps(struct job *j, int cam, const struct esr_synth_gt *gt)
{
    const struct {
        const char *name;
        const struct esr_image *img;
    } maps[] = {{"normal", &gt->normal},
                {"base_color", &gt->base},
                {"roughness", &gt->roughness},
                {"metallic", &gt->metallic},
                {"emission", &gt->emission}};
    char path[PATH_LEN];
    for (size_t i = 0; i < sizeof maps / sizeof maps[0]; i++) {
        snprintf(path, sizeof path, "%s/gt/c%03d_%s.exr", j->root, cam, maps[i].name);
        ESR_TRY(esr_exr_write(path, maps[i].img, 0));
    }
    return ESR_OK;
}

static void report(const struct job *j, const char *phase, int done, int total, long images, double t0)
{
    if (!j->opt->progress)
        return;
    struct esr_synth_progress p;
    p.phase = phase;
    p.done = done;
    p.total = total;
    p.elapsed_s = now_s() - t0;
    p.samples_per_s = p.elapsed_s > 0.0 ? (double)images * j->res * j->res * j->spp / p.elapsed_s : 0.0;
    j->opt->progress(j->opt->user, &p);
}

/* One frame's image to the dataset: the PNG, and for a test frame the linear EXR. */
static int write_frame_image(struct job *j, enum esr_phase_id ph, const struct esr_synth_frame *f)
{
    char path[PATH_LEN];
    if (ph == ESR_PHASE_TRAIN && j->photos) {
        snprintf(path, sizeof path, "%s/%s/%s.%s", j->root, esr_phase_name(ph), f->name,
                 j->opt->photo.jpeg_quality ? "jpg" : "png");
        const long i = f - j->plan->frames[ESR_PHASE_TRAIN];
        struct esr_rng noise = esr_rng_init(j->opt->seed, ESR_PHOTO_NOISE_STREAM + (uint64_t)i);
        return write_photo(path, &j->lin, &j->photos[i], &j->opt->photo, &noise, &j->png);
    }
    snprintf(path, sizeof path, "%s/%s/%s.png", j->root, esr_phase_name(ph), f->name);
    ESR_TRY(write_png_from_linear(path, &j->lin, &j->png));
    if (ph == ESR_PHASE_TRAIN)
        return ESR_OK;
    snprintf(path, sizeof path, "%s/%s/exr/%s.exr", j->root, esr_phase_name(ph), f->name);
    return esr_exr_write(path, &j->lin, 1);
}

/* Renders cam under the world light world_on (0/1) and the lights' emission into out, the
 * camera seeing the backdrop where it sees no scene when backdrop is 1; with its camera rays
 * from jitter stream *jitter_id when not NULL (esr_synth_render_shared_jitter). */
static int render_image(struct job *j, const struct esr_camera *cam, const float emission[][3], int world_on,
                        int backdrop, const uint64_t *jitter_id, struct esr_image *out)
{
    struct esr_synth_trace_params params;
    esr_synth_trace_setup(j->scene, emission, &params);
    params.backdrop = backdrop;
    if (!world_on)
        memset(params.world, 0, sizeof params.world);
    const uint64_t id = j->image_id++;
    return jitter_id ? esr_synth_render_shared_jitter(&params, cam, j->spp, j->opt->seed, id, *jitter_id, out)
                     : esr_synth_render(&params, cam, j->spp, j->opt->seed, id, out);
}

static int render_train(struct job *j)
{
    const int n = j->plan->n_frames[ESR_PHASE_TRAIN];
    int rc = ESR_OK;
    const double t0 = now_s();
    for (int i = 0; i < n && rc == ESR_OK; i++) {
        const struct esr_synth_frame *f = &j->plan->frames[ESR_PHASE_TRAIN][i];
        rc = render_image(j, &j->plan->train_cams[f->cam], (const float(*)[3])f->emission, 1,
                          j->opt->backdrop, NULL, &j->lin);
        if (rc == ESR_OK)
            rc = write_frame_image(j, ESR_PHASE_TRAIN, f);
        esr_image_free(&j->lin);
        report(j, "train", i + 1, n, i + 1, t0);
    }
    return rc;
}

/* A test camera's light basis. Light transport is linear in the emitted radiance and acts on
 * each colour channel alone (no BRDF mixes channels), so every frame of the camera, whatever its
 * lights' intensities and colours, is
 *     world + sum_k e_k (x) light_k [+ b backdrop]   (per channel)
 * with world the image under the world light alone, light_k under light k alone at unit
 * emission, e_k the frame's emitted radiance of light k; alpha is the world image's coverage.
 * With --backdrop the camera sees the backdrop where it sees no scene (alpha 1): its image
 * comes from the camera rays alone (nothing is lit, so paths end at their first hit), times
 * b = ESR_SYNTH_BACKDROP_LIT_GAIN when any light is on, 1 when all are off. The 1 + K (+ 1)
 * images are rendered once per camera instead of one image per frame (the default scene: 3
 * instead of 9), and the frames of a camera differ by exactly the lights' light, without
 * path-tracing noise of their own. */
struct light_basis {
    struct esr_image world, light[ESR_SYNTH_MAX_LIGHTS], backdrop;
};

static void light_basis_free(struct light_basis *b, int n_lights)
{
    esr_image_free(&b->world);
    for (int k = 0; k < n_lights; k++)
        esr_image_free(&b->light[k]);
    esr_image_free(&b->backdrop);
}

/* The basis of test camera cam: its images share their camera rays (jitter stream cam), so their
 * coverage is the same and a frame's colour and alpha come from the same samples. */
static int light_basis_render(struct job *j, int cam, struct light_basis *b)
{
    const struct esr_camera *camera = &j->plan->test_cams[cam];
    const uint64_t jitter = (uint64_t)cam;
    float emission[ESR_SYNTH_MAX_LIGHTS][3];
    memset(emission, 0, sizeof emission);
    ESR_TRY(render_image(j, camera, (const float(*)[3])emission, 1, 0, &jitter, &b->world));
    if (j->opt->backdrop)
        ESR_TRY(render_image(j, camera, (const float(*)[3])emission, 0, 1, &jitter, &b->backdrop));
    for (int k = 0; k < j->scene->n_lights; k++) {
        emission[k][0] = emission[k][1] = emission[k][2] = 1.0f;
        ESR_TRY(render_image(j, camera, (const float(*)[3])emission, 0, 0, &jitter, &b->light[k]));
        emission[k][0] = emission[k][1] = emission[k][2] = 0.0f;
    }
    return ESR_OK;
}

/* Frame f from its camera's basis into j->lin. */
static int light_basis_frame(struct job *j, const struct light_basis *b, const struct esr_synth_frame *f)
{
    ESR_TRY(esr_image_alloc(&j->lin, b->world.width, b->world.height, 4));
    struct esr_synth_trace_params whole; /* the frame rendered whole: which lights are lit */
    esr_synth_trace_setup(j->scene, (const float(*)[3])f->emission, &whole);
    const float backdrop_gain = esr_synth_trace_any_lit(&whole) ? ESR_SYNTH_BACKDROP_LIT_GAIN : 1.0f;
    const size_t n = (size_t)b->world.width * (size_t)b->world.height;
    for (size_t i = 0; i < n; i++) {
        float *dst = j->lin.data + 4 * i;
        memcpy(dst, b->world.data + 4 * i, 4 * sizeof(float));
        for (int k = 0; k < j->scene->n_lights; k++)
            for (int c = 0; c < 3; c++)
                dst[c] += f->emission[k][c] * b->light[k].data[4 * i + c];
        if (b->backdrop.data) {
            for (int c = 0; c < 3; c++)
                dst[c] += backdrop_gain * b->backdrop.data[4 * i + c];
            dst[3] = 1.0f; /* opaque, as a photograph */
        }
    }
    return ESR_OK;
}

/* phases[] after train */
static const enum esr_phase_id *const test_phases = phases + 1;
#define N_TEST_PHASES (N_PHASES - 1)

/* The test phases camera by camera: the ground-truth maps and the light basis once per camera,
 * then every frame of that camera in every test phase. */
static int render_test(struct job *j)
{
    const int n_lights = j->scene->n_lights;
    int total = 0, done = 0, rc = ESR_OK;
    long images = 0;
    for (int p = 0; p < N_TEST_PHASES; p++)
        total += j->plan->n_frames[test_phases[p]];
    const double t0 = now_s();
    for (int cam = 0; cam < j->plan->n_test_cams && rc == ESR_OK; cam++) {
        const struct esr_camera *camera = &j->plan->test_cams[cam];
        struct esr_synth_gt gt;
        struct light_basis b;
        memset(&gt, 0, sizeof gt);
        memset(&b, 0, sizeof b);
        rc = esr_synth_render_gt(j->scene, camera, &gt);
        if (rc == ESR_OK)
            rc = write_gt_maps(j, cam, &gt);
        if (rc == ESR_OK)
            rc = light_basis_render(j, cam, &b);
        images += 1 + n_lights; /* the backdrop's image traces camera rays only */
        for (int p = 0; p < N_TEST_PHASES && rc == ESR_OK; p++) {
            const enum esr_phase_id ph = test_phases[p];
            for (int i = 0; i < j->plan->n_frames[ph] && rc == ESR_OK; i++) {
                const struct esr_synth_frame *f = &j->plan->frames[ph][i];
                if (f->cam != cam)
                    continue;
                rc = light_basis_frame(j, &b, f);
                if (rc == ESR_OK)
                    rc = write_frame_image(j, ph, f);
                if (rc == ESR_OK)
                    rc = write_frame_masks(j, ph, f, gt.prim);
                esr_image_free(&j->lin);
                report(j, "test", ++done, total, images, t0);
            }
        }
        light_basis_free(&b, n_lights);
        esr_synth_gt_free(&gt);
    }
    return rc;
}

static int write_all(struct job *j, const struct esr_synth_settings *set)
{
    ESR_TRY(make_layout(j->root));
    ESR_TRY(render_train(j));
    ESR_TRY(render_test(j));
    /* the train photos' EXIF exposure in the frames too, as an import records it */
    struct esr_exif_exposure *exif = NULL;
    if (j->photos && j->opt->photo.exif) {
        const int n = j->plan->n_frames[ESR_PHASE_TRAIN];
        exif = malloc((size_t)n * sizeof *exif);
        if (!exif)
            return ESR_FAIL("out of memory for the photos' exposures");
        for (int i = 0; i < n; i++)
            esr_photo_exif(&j->photos[i], &exif[i]);
    }
    int status = ESR_OK;
    for (int i = 0; i < N_PHASES && status == ESR_OK; i++)
        status = esr_synth_json_transforms(j->root, j->scene, j->plan, phases[i],
                                           phases[i] == ESR_PHASE_TRAIN ? esr_synth_train_ext(&j->opt->photo) : "",
                                           phases[i] == ESR_PHASE_TRAIN ? exif : NULL);
    free(exif);
    ESR_TRY(status);
    ESR_TRY(esr_synth_json_scene(j->root, j->scene, j->plan, set));
    if (j->photos)
        ESR_TRY(esr_synth_json_photos(j->root, j->plan, &j->opt->photo, j->photos));
    struct esr_mesh mesh;
    ESR_TRY(esr_synth_scene_mesh(j->scene, MESH_SEGMENTS, &mesh));
    char path[PATH_LEN];
    snprintf(path, sizeof path, "%s/gt/mesh.ply", j->root);
    int rc = esr_ply_write(path, &mesh);
    esr_mesh_free(&mesh);
    return rc;
}

static int check_range(const char *what, int v, int lo, int hi)
{
    if (v < lo || v > hi)
        return ESR_FAIL("%s %d is out of range %d..%d", what, v, lo, hi);
    return ESR_OK;
}

int esr_synth_write_dataset(const char *out_dir, const struct esr_synth_options *opt)
{
    struct esr_synth_scene scene;
    ESR_TRY(esr_synth_scene_get(opt->scene, &scene));
    struct esr_synth_settings set;
    set.res = opt->res ? opt->res : scene.res;
    set.spp = opt->spp ? opt->spp : scene.spp;
    set.n_train = opt->n_train ? opt->n_train : scene.n_train;
    set.n_test = opt->n_test ? opt->n_test : scene.n_test;
    set.seed = (unsigned long long)opt->seed;
    ESR_TRY(check_range("resolution", set.res, ESR_SYNTH_RES_MIN, ESR_SYNTH_RES_MAX));
    ESR_TRY(check_range("samples per pixel", set.spp, ESR_SYNTH_SPP_MIN, ESR_SYNTH_SPP_MAX));
    ESR_TRY(check_range("train views per condition", set.n_train, 1, 500));
    ESR_TRY(check_range("test cameras", set.n_test, 1, 500));
    ESR_TRY(esr_photo_check(&opt->photo));

    struct esr_synth_plan plan;
    ESR_TRY(esr_synth_plan_make(&scene, set.res, set.n_train, set.n_test, opt->seed, &plan));
    char staging[PATH_LEN];
    struct job j;
    memset(&j, 0, sizeof j);
    j.root = staging;
    j.scene = &scene;
    j.plan = &plan;
    j.opt = opt;
    j.res = set.res;
    j.spp = set.spp;
    struct esr_photo_truth *photos = NULL;
    if (esr_photo_active(&opt->photo)) {
        photos = calloc((size_t)plan.n_frames[ESR_PHASE_TRAIN], sizeof *photos);
        if (!photos) {
            esr_synth_plan_free(&plan);
            return ESR_FAIL("out of memory for the photos' truth");
        }
        esr_photo_plan(&opt->photo, &plan, scene.n_lights, opt->seed, photos);
        j.photos = photos;
    }
    int rc = esr_staging_begin(out_dir, opt->force, staging, sizeof staging);
    if (rc == ESR_OK) {
        rc = esr_image_alloc(&j.png, set.res, set.res, 4);
        if (rc == ESR_OK)
            rc = esr_image_alloc(&j.mask, set.res, set.res, 1);
        if (rc == ESR_OK)
            rc = write_all(&j, &set);
        if (rc == ESR_OK)
            rc = esr_staging_commit(staging, out_dir);
        if (rc != ESR_OK)
            esr_remove_tree(staging); /* keeps the first (real) error message */
    }
    esr_image_free(&j.png);
    esr_image_free(&j.mask);
    free(photos);
    esr_synth_plan_free(&plan);
    return rc;
}
