/* `esr synth`'s photo-like train captures (synth/photo.h): the exposure re-centring is exact, the
 * lights-on set's exposure is what --on-exposure asks in the written images, the filmic curve is
 * monotone and invertible, the truth is in gt/photos.json and the dataset still loads. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/colour.h"
#include "core/error.h"
#include "io/dataset.h"
#include "io/dataset.h"
#include "io/dataset_summary.h"
#include "io/exif_exposure.h"
#include "io/file.h"
#include "io/image.h"
#include "synth/photo.h"
#include "test_support.h"

/* A plan of n train frames, every third lights-off, the rest lights-on with a warm light. */
static void fake_plan(struct esr_synth_plan *plan, struct esr_synth_frame *frames, int n)
{
    memset(plan, 0, sizeof *plan);
    memset(frames, 0, (size_t)n * sizeof *frames);
    for (int i = 0; i < n; i++) {
        frames[i].mode = i % 3 == 0 ? ESR_LIGHT_OFF : ESR_LIGHT_ON;
        if (frames[i].mode == ESR_LIGHT_ON) {
            frames[i].emission[0][0] = 4.0f;
            frames[i].emission[0][1] = 2.0f;
            frames[i].emission[0][2] = 1.0f;
        }
    }
    plan->n_frames[ESR_PHASE_TRAIN] = n;
    plan->frames[ESR_PHASE_TRAIN] = frames;
}

/* The truth of opt on the fake plan of n frames. */
static void plan_photos(const struct esr_photo_options *opt, int n, struct esr_synth_frame *frames,
                        struct esr_photo_truth *t)
{
    struct esr_synth_plan plan;
    fake_plan(&plan, frames, n);
    esr_photo_plan(opt, &plan, 1, 7, t);
}

static void test_recentring_is_exact(void **state)
{
    (void)state;
    enum { N = 31 };
    struct esr_synth_frame frames[N];
    struct esr_photo_truth t[N];
    const struct esr_photo_options opt = {.exposure_jitter = 1.0, .on_exposure = -1.5, .wb_jitter = 0.1};
    plan_photos(&opt, N, frames, t);
    double sum[2] = {0, 0}, spread = 0.0;
    int count[2] = {0, 0};
    for (int i = 0; i < N; i++) {
        const int on = frames[i].mode == ESR_LIGHT_ON;
        sum[on] += t[i].stops;
        count[on]++;
        spread = fmax(spread, fabs(t[i].stops - (on ? -1.5 : 0.0)));
        for (int c = 0; c < 3; c++)
            assert_true(t[i].gain[c] >= 0.9 - 1e-12 && t[i].gain[c] <= 1.1 + 1e-12);
    }
    assert_true(fabs(sum[0] / count[0]) < 1e-12);
    assert_true(fabs(sum[1] / count[1] + 1.5) < 1e-12);
    assert_true(spread > 0.3 && spread <= 2.0); /* jittered, within +-1 plus the re-centring */
}

/* --wb-follow on a warm light lowers red against blue, and keeps the gains' geometric mean. */
static void test_wb_follow_cools_a_warm_light(void **state)
{
    (void)state;
    enum { N = 6 };
    struct esr_synth_frame frames[N];
    struct esr_photo_truth t[N];
    const struct esr_photo_options opt = {.wb_follow = 1};
    plan_photos(&opt, N, frames, t);
    for (int i = 0; i < N; i++) {
        const double *g = t[i].gain;
        assert_true(fabs(g[0] * g[1] * g[2] - 1.0) < 1e-12);
        if (frames[i].mode == ESR_LIGHT_OFF)
            assert_true(g[0] == 1.0 && g[1] == 1.0 && g[2] == 1.0);
        else /* m = (4, 2, 1): w = (1/sqrt 2, 1, sqrt 2) */
            assert_true(fabs(g[0] - sqrt(0.5)) < 1e-12 && fabs(g[2] - sqrt(2.0)) < 1e-12);
    }
}

static void test_filmic_is_monotone_and_invertible(void **state)
{
    (void)state;
    double prev = -1.0, max_err = 0.0;
    assert_true(esr_photo_filmic(0.0) == 0.0);
    assert_true(fabs(esr_photo_filmic(1.0) - 1.0) < 1e-6);
    for (int i = 0; i <= 4096; i++) {
        const double x = i / 4096.0, y = esr_photo_filmic(x);
        assert_true(y > prev);
        prev = y;
        max_err = fmax(max_err, fabs(esr_photo_filmic_inverse(y) - x));
    }
    assert_true(max_err < 1e-5);
    /* S-shaped against sRGB: darker in the shadows, brighter in the highlights */
    assert_true(esr_photo_filmic(0.05) < esr_srgb_from_linear(0.05f));
    assert_true(esr_photo_filmic(0.6) > esr_srgb_from_linear(0.6f));
}

/* tmp/plain and tmp/photo: the default scene at res with 2 + 2 train views, seed 3, the second
 * with the extra options photo. */
static void synth_pair(const char *tmp, int res, const char *photo)
{
    char args[1024], out[8192];
    snprintf(args, sizeof args, "synth --res %d --spp 2 --train 2 --test 1 --seed 3 %s/plain", res, tmp);
    assert_int_equal(test_run_esr(args, out, sizeof out), 0);
    snprintf(args, sizeof args, "synth --res %d --spp 2 --train 2 --test 1 --seed 3 %s %s/photo", res, photo, tmp);
    assert_int_equal(test_run_esr(args, out, sizeof out), 0);
}

/* Mean linear value of the pixels of a train image that are opaque and unclipped (no channel at
 * 255) in the plain render. */
static double mean_linear(const char *path, const struct esr_image *plain)
{
    struct esr_image img;
    assert_int_equal(esr_image_read(path, &img), 0);
    double sum = 0.0;
    long n = 0;
    for (size_t i = 0; i < (size_t)img.width * (size_t)img.height; i++) {
        const float *p = plain->data + 4 * i;
        if (p[3] < 1.0f || fmaxf(p[0], fmaxf(p[1], p[2])) > 254.5f / 255.0f)
            continue;
        for (int c = 0; c < 3; c++)
            sum += esr_linear_from_srgb(img.data[(size_t)img.channels * i + (size_t)c]);
        n++;
    }
    esr_image_free(&img);
    assert_true(n > 20);
    return sum / (double)n;
}

/* The same seed with and without --on-exposure -1: every lights-on image's opaque pixels halve
 * (to 8-bit rounding), every lights-off one's stay; gt/photos.json holds the truth and the
 * dataset loads. */
static void test_on_exposure_in_the_images(void **state)
{
    (void)state;
    char *tmp = test_make_tmpdir(), path[1024];
    synth_pair(tmp, 24, "--on-exposure -1");

    snprintf(path, sizeof path, "%s/photo/gt/photos.json", tmp);
    cJSON *truth = test_read_json(path);
    assert_non_null(truth);
    const cJSON *frames = cJSON_GetObjectItem(truth, "frames");
    assert_int_equal(cJSON_GetArraySize(frames), 4);
    snprintf(path, sizeof path, "%s/photo", tmp);
    struct esr_dataset ds;
    assert_int_equal(esr_dataset_load(path, &ds), 0);
    esr_dataset_free(&ds);

    const cJSON *fr;
    int n_on = 0;
    cJSON_ArrayForEach(fr, frames)
    {
        const char *file = cJSON_GetObjectItem(fr, "file_path")->valuestring;
        const int on = !strcmp(cJSON_GetObjectItem(fr, "mode")->valuestring, "on");
        const double stops = cJSON_GetObjectItem(fr, "exposure_stops")->valuedouble;
        assert_true(stops == (on ? -1.0 : 0.0));
        struct esr_image plain;
        snprintf(path, sizeof path, "%s/plain/%s.png", tmp, file);
        assert_int_equal(esr_png_read(path, &plain), 0);
        const double base = mean_linear(path, &plain);
        snprintf(path, sizeof path, "%s/photo/%s.png", tmp, file);
        const double ratio = mean_linear(path, &plain) / base;
        esr_image_free(&plain);
        assert_true(fabs(ratio - (on ? 0.5 : 1.0)) < 0.02 * (on ? 0.5 : 1.0));
        n_on += on;
    }
    assert_int_equal(n_on, 2);
    cJSON_Delete(truth);
    test_rmtree(tmp);
    free(tmp);
}

/* --jpeg: train frames are train/<name>.jpg in the transforms, decode at the dataset's size as
 * opaque RGB, and the dataset loads; test frames stay PNG renders. */
static void test_jpeg_frames_load(void **state)
{
    (void)state;
    char *tmp = test_make_tmpdir(), args[1024], out[8192], path[1024];
    snprintf(args, sizeof args, "synth --res 24 --spp 2 --train 2 --test 1 --seed 3 --jpeg 90 %s/ds", tmp);
    assert_int_equal(test_run_esr(args, out, sizeof out), 0);
    snprintf(path, sizeof path, "%s/ds", tmp);
    struct esr_dataset ds;
    assert_int_equal(esr_dataset_load(path, &ds), 0);
    int n_train = 0;
    for (int p = 0; p < ESR_PHASE_COUNT; p++)
    for (int i = 0; i < ds.phases[p].n_frames; i++) {
        const struct esr_frame *f = &ds.phases[p].frames[i];
        esr_frame_image_path(&ds, f, path, sizeof path);
        const size_t len = strlen(path);
        const int is_jpeg = len > 4 && !strcmp(path + len - 4, ".jpg");
        assert_int_equal(is_jpeg, p == ESR_PHASE_TRAIN);
        if (!is_jpeg)
            continue;
        struct esr_image img;
        assert_int_equal(esr_image_read(path, &img), 0);
        assert_int_equal(img.width, 24);
        assert_int_equal(img.channels, 3);
        esr_image_free(&img);
        n_train++;
    }
    assert_int_equal(n_train, 4);
    esr_dataset_free(&ds);
    test_rmtree(tmp);
    free(tmp);
}

static unsigned char *slurp(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    *n = (size_t)ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *b = malloc(*n);
    assert_non_null(b);
    assert_int_equal(fread(b, 1, *n, f), *n);
    fclose(f);
    return b;
}

/* A warning line kept (the last one) in user's 1024 bytes. */
static void keep_line(void *user, const char *line)
{
    snprintf(user, 1024, "%s", line);
}

/* --exif: every JPEG's ExposureTime, FNumber and ISO read back (libexif) give t * ISO / N^2
 * proportional to 2^exposure_stops of gt/photos.json, to 2%. */
static void test_exif_round_trips(void **state)
{
    (void)state;
    char *tmp = test_make_tmpdir(), args[1024], out[8192], path[1024];
    snprintf(args, sizeof args, "synth --res 16 --spp 1 --train 3 --test 1 --seed 4 --jpeg 80 --exif "
             "--exposure-jitter 1.5 --on-exposure -1 %s/ds", tmp);
    assert_int_equal(test_run_esr(args, out, sizeof out), 0);
    snprintf(path, sizeof path, "%s/ds/gt/photos.json", tmp);
    cJSON *truth = test_read_json(path);
    assert_non_null(truth);
    const struct esr_exif_exposure base = {ESR_PHOTO_EXIF_BASE_TIME_S, ESR_PHOTO_EXIF_F_NUMBER, ESR_PHOTO_EXIF_ISO};
    const cJSON *fr;
    int n = 0;
    cJSON_ArrayForEach(fr, cJSON_GetObjectItem(truth, "frames"))
    {
        snprintf(path, sizeof path, "%s/ds/%s", tmp, cJSON_GetObjectItem(fr, "file_path")->valuestring);
        size_t size;
        unsigned char *bytes = slurp(path, &size);
        struct esr_exif_exposure e;
        char why[128];
        assert_int_equal(esr_exif_exposure_read(bytes, size, &e, why, sizeof why), 1);
        free(bytes);
        const double want = exp2(cJSON_GetObjectItem(fr, "exposure_stops")->valuedouble);
        const double got = esr_exif_relative_exposure(&e) / esr_exif_relative_exposure(&base);
        assert_true(fabs(got / want - 1.0) < 0.02);
        n++;
    }
    assert_int_equal(n, 6);
    /* the frames record the same exposure (as an import does), and the two sets' mean log
     * exposures are --on-exposure apart, which `esr info` reports */
    snprintf(path, sizeof path, "%s/ds", tmp);
    struct esr_dataset ds;
    assert_int_equal(esr_dataset_load(path, &ds), ESR_OK);
    struct esr_dataset_summary sum;
    esr_dataset_summarise(&ds, &sum);
    const struct esr_phase_summary *t = &sum.phases[ESR_PHASE_TRAIN];
    assert_int_equal(t->n_exposure[0], 3);
    assert_int_equal(t->n_exposure[1], 3);
    assert_true(fabs(t->ev_mean[1] - t->ev_mean[0] + 1.0) < 0.02);
    assert_true(fabs(t->ev_mean[0] - log2(esr_exif_relative_exposure(&base))) < 0.02); /* re-centred */
    char note[1024] = "";
    assert_int_equal(esr_dataset_exposure_warnings(&sum, keep_line, note), 3); /* both sets spread, and apart */
    assert_non_null(strstr(note, "stops shorter than the lights-off ones"));
    esr_dataset_free(&ds);
    cJSON_Delete(truth);
    test_rmtree(tmp);
    free(tmp);
}

/* Absurd EXIF is refused with the reason, missing EXIF is "none": neither is trusted. */
static void test_absurd_exif_is_refused(void **state)
{
    (void)state;
    struct esr_exif_exposure e = {1.0 / 100.0, 2.8, 0}, back;
    unsigned char *app1;
    size_t n;
    char why[128];
    assert_int_equal(esr_exif_exposure_payload(&e, &app1, &n), 0);
    assert_int_equal(esr_exif_exposure_read(app1, n, &back, why, sizeof why), -1);
    assert_non_null(strstr(why, "ISO 0"));
    free(app1);
    e.iso = 200;
    e.exposure_time_s = 0.0;
    assert_int_equal(esr_exif_exposure_payload(&e, &app1, &n), 0);
    assert_int_equal(esr_exif_exposure_read(app1, n, &back, why, sizeof why), -1);
    assert_non_null(strstr(why, "ExposureTime"));
    free(app1);
    static const unsigned char not_exif[] = "Exif\0\0garbage";
    assert_int_equal(esr_exif_exposure_read(not_exif, sizeof not_exif, &back, why, sizeof why), 0);
}

/* --noise 0.03: against the same seed's plain render, the linear difference on opaque
 * mid-tone pixels (where neither clipping nor 8-bit steps matter) has a spread near 0.03. */
static void test_noise_has_its_sigma(void **state)
{
    (void)state;
    char *tmp = test_make_tmpdir(), path[1024];
    synth_pair(tmp, 32, "--noise 0.03");
    double sum2 = 0.0;
    long n = 0;
    for (int k = 0; k < 4; k++) {
        struct esr_image plain, photo;
        snprintf(path, sizeof path, "%s/plain/train/r_%03d.png", tmp, k);
        assert_int_equal(esr_png_read(path, &plain), 0);
        snprintf(path, sizeof path, "%s/photo/train/r_%03d.png", tmp, k);
        assert_int_equal(esr_png_read(path, &photo), 0);
        for (size_t i = 0; i < (size_t)plain.width * (size_t)plain.height; i++)
            for (int c = 0; c < 3 && plain.data[4 * i + 3] == 1.0f; c++) {
                const double a = esr_linear_from_srgb(plain.data[4 * i + (size_t)c]);
                if (a < 0.15 || a > 0.8)
                    continue;
                const double d = esr_linear_from_srgb(photo.data[4 * i + (size_t)c]) - a;
                sum2 += d * d;
                n++;
            }
        esr_image_free(&plain);
        esr_image_free(&photo);
    }
    assert_true(n > 100);
    const double sigma = sqrt(sum2 / (double)n);
    assert_true(sigma > 0.025 && sigma < 0.035);
    test_rmtree(tmp);
    free(tmp);
}

static void test_bad_curve_fails_cleanly(void **state)
{
    (void)state;
    char *tmp = test_make_tmpdir(), args[1024], out[8192];
    snprintf(args, sizeof args, "synth --res 16 --curve gamma %s/ds", tmp);
    assert_int_not_equal(test_run_esr(args, out, sizeof out), 0);
    assert_non_null(strstr(out, "--curve must be srgb or filmic, got 'gamma'"));
    test_rmtree(tmp);
    free(tmp);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_recentring_is_exact),
        cmocka_unit_test(test_wb_follow_cools_a_warm_light),
        cmocka_unit_test(test_filmic_is_monotone_and_invertible),
        cmocka_unit_test(test_on_exposure_in_the_images),
        cmocka_unit_test(test_jpeg_frames_load),
        cmocka_unit_test(test_exif_round_trips),
        cmocka_unit_test(test_absurd_exif_is_refused),
        cmocka_unit_test(test_noise_has_its_sigma),
        cmocka_unit_test(test_bad_curve_fails_cleanly),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
