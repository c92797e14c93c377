/* Evaluation of a rendered directory against a dataset phase (eval/evaluate.h), its JSON, frame
 * selection, the HTML report and training curves, on a hand-made 16x16 fixture dataset whose
 * PSNR / HDR MSE values (and, with ground-truth normal maps added, normal errors) are known in
 * closed form. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <sys/stat.h>

#include "core/error.h"
#include "eval/curve.h"
#include "eval/evaluate.h"
#include "eval/report.h"
#include "eval/select.h"
#include "io/dataset.h"
#include "io/file.h"
#include "io/image.h"
#include "test_support.h"

#define RES 16
static char ds_dir[1100], render_dir[1100];
static const char *const identity =
    "[[1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]";

/* Ground-truth code value of pixel (x,y) channel c: multiples of 4/255 up to 124/255, so a
 * rendered offset of 51/255 stays in [0,1] and survives 8-bit storage exactly. */
static float gt_value(int x, int y, int c)
{
    return (float)(((x + 2 * y + 3 * c) % 32) * 4) / 255.0f;
}

static void write_png_fn(const char *path, int w, int h, int channels, float offset)
{
    struct esr_image img;
    assert_int_equal(esr_image_alloc(&img, w, h, channels), ESR_OK);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int c = 0; c < channels; c++)
                img.data[(y * w + x) * channels + c] = c == 3 ? 1.0f : gt_value(x, y, c) + offset;
    assert_int_equal(esr_png_write(path, &img, 8), ESR_OK);
    esr_image_free(&img);
}

/* An EXR filled with one RGBA (channels = 4) or RGB (3) value. */
static void write_exr_const(const char *path, int channels, float rgb, float a)
{
    struct esr_image img;
    assert_int_equal(esr_image_alloc(&img, RES, RES, channels), ESR_OK);
    for (size_t i = 0; i < esr_image_count(&img); i++)
        img.data[i] = (channels == 4 && i % 4 == 3) ? a : rgb;
    assert_int_equal(esr_exr_write(path, &img, channels == 4), ESR_OK);
    esr_image_free(&img);
}

static void path_in(char *out, size_t n, const char *dir, const char *rel)
{
    snprintf(out, n, "%s/%s", dir, rel);
}

static const char *frame_json(const char *file, const char *mode, int intensity, char *buf, size_t n)
{
    snprintf(buf, n,
             "{\"file_path\": \"%s\", \"transform_matrix\": %s, \"lights\": [{\"mode\": \"%s\", "
             "\"mask_path\": \"\", \"color\": [0,0,1], \"intensity\": %d}]}",
             file, identity, mode, intensity);
    return buf;
}

/* ESR layout: one train frame, test_nv = c000_off, c000_on with PNGs and EXRs. GT EXRs:
 * off = rgb 0.25 premultiplied with alpha 0.5 (0.75 on white), on = rgb 2.0, alpha 1. */
static void make_fixture(void)
{
    char path[1300], f1[512], f2[512], text[1400];
    snprintf(ds_dir, sizeof ds_dir, "%s/ds", test_tmpdir);
    static const char *const dirs[] = {"", "/transforms", "/train", "/test_nv", "/test_nv/exr"};
    for (size_t i = 0; i < sizeof dirs / sizeof dirs[0]; i++) {
        snprintf(path, sizeof path, "%s%s", ds_dir, dirs[i]);
        assert_int_equal(mkdir(path, 0755), 0);
    }
    path_in(path, sizeof path, ds_dir, "transforms/transforms_train.json");
    snprintf(text, sizeof text, "{\"camera_angle_x\": 0.7, \"frames\": [%s]}",
             frame_json("train/r_000", "off", 0, f1, sizeof f1));
    assert_int_equal(test_write_file(path, text), 0);
    path_in(path, sizeof path, ds_dir, "transforms/transforms_test_nv.json");
    snprintf(text, sizeof text, "{\"camera_angle_x\": 0.7, \"frames\": [%s, %s]}",
             frame_json("test_nv/c000_off", "off", 0, f1, sizeof f1),
             frame_json("test_nv/c000_on", "on", 1, f2, sizeof f2));
    assert_int_equal(test_write_file(path, text), 0);
    static const char *const pngs[] = {"train/r_000.png", "test_nv/c000_off.png", "test_nv/c000_on.png"};
    for (size_t i = 0; i < 3; i++) {
        path_in(path, sizeof path, ds_dir, pngs[i]);
        write_png_fn(path, RES, RES, 4, 0.0f);
    }
    path_in(path, sizeof path, ds_dir, "test_nv/exr/c000_off.exr");
    write_exr_const(path, 4, 0.25f, 0.5f);
    path_in(path, sizeof path, ds_dir, "test_nv/exr/c000_on.exr");
    write_exr_const(path, 4, 2.0f, 1.0f);
}

/* Rendered files: c000_off identical to the ground truth (EXR 0.75 on white, no alpha);
 * c000_on tone-mapped off by +51/255, linear identical, EXR 2.5 (HDR MSE 0.25). */
static void make_renders(void)
{
    char path[1300];
    snprintf(render_dir, sizeof render_dir, "%s/render", test_tmpdir);
    mkdir(render_dir, 0755);
    path_in(path, sizeof path, render_dir, "c000_off.png");
    write_png_fn(path, RES, RES, 3, 0.0f);
    path_in(path, sizeof path, render_dir, "c000_off_linear.png");
    write_png_fn(path, RES, RES, 4, 0.0f); /* RGBA with alpha 1 is accepted too */
    path_in(path, sizeof path, render_dir, "c000_off.exr");
    write_exr_const(path, 3, 0.75f, 1.0f);
    path_in(path, sizeof path, render_dir, "c000_on.png");
    write_png_fn(path, RES, RES, 3, 51.0f / 255.0f);
    path_in(path, sizeof path, render_dir, "c000_on_linear.png");
    write_png_fn(path, RES, RES, 3, 0.0f);
    path_in(path, sizeof path, render_dir, "c000_on.exr");
    write_exr_const(path, 3, 2.5f, 1.0f);
}

static int setup(void **state)
{
    if (test_setup_tmpdir(state))
        return -1;
    make_fixture();
    make_renders();
    return 0;
}

/* Moves dir/rel to the temporary directory's "aside" file (restore with the swapped pair). */
static void move_aside(const char *dir, const char *rel, char *path, char *moved, size_t n)
{
    path_in(path, n, dir, rel);
    path_in(moved, n, test_tmpdir, "aside");
    assert_int_equal(rename(path, moved), 0);
}

static void load_all(struct esr_dataset *ds, int **idx, int *n)
{
    assert_int_equal(esr_dataset_load(ds_dir, ds), ESR_OK);
    assert_int_equal(esr_select_frames(&ds->phases[ESR_PHASE_TEST_NV], "test_nv", NULL, 0, idx, n), ESR_OK);
    assert_int_equal(*n, 2);
}

static void test_known_values(void **state)
{
    (void)state;
    struct esr_dataset ds;
    struct esr_eval_result res;
    int *idx, n;
    load_all(&ds, &idx, &n);
    assert_int_equal(esr_eval_phase(&ds, ESR_PHASE_TEST_NV, idx, n, render_dir, &res), ESR_OK);
    assert_int_equal(res.n_views, 2);
    const struct esr_eval_view *off = &res.views[0], *on = &res.views[1];
    assert_string_equal(off->name, "c000_off");
    assert_int_equal(off->mode, ESR_LIGHT_OFF);
    assert_int_equal(on->mode, ESR_LIGHT_ON);
    /* identical images: PSNR capped, SSIM 1, HDR MSE 0 (alpha 0.5 composited on white) */
    assert_true(off->psnr == ESR_EVAL_PSNR_CAP && off->psnr_linear == ESR_EVAL_PSNR_CAP);
    assert_true(fabs(off->ssim - 1.0) < 1e-6 && fabs(off->ssim_linear - 1.0) < 1e-6);
    assert_true(fabs(off->hdr_mse) < 1e-12);
    /* offset 51/255 = 0.2 on every value: MSE 0.04, PSNR -10 log10(0.04) */
    double expect = -10.0 * log10(0.04);
    assert_true(fabs(on->psnr - expect) < 1e-4);
    assert_true(on->ssim < 0.999);
    assert_true(on->psnr_linear == ESR_EVAL_PSNR_CAP);
    assert_true(fabs(on->hdr_mse - 0.25) < 1e-6);
    /* means: overall and per lighting mode */
    assert_int_equal(res.all.n, 2);
    assert_true(fabs(res.all.psnr - 0.5 * (ESR_EVAL_PSNR_CAP + expect)) < 1e-4);
    assert_true(fabs(res.all.hdr_mse - 0.125) < 1e-6);
    assert_int_equal(res.by_mode[ESR_LIGHT_OFF].n, 1);
    assert_int_equal(res.by_mode[ESR_LIGHT_ON].n, 1);
    assert_true(fabs(res.by_mode[ESR_LIGHT_ON].psnr - expect) < 1e-4);
    assert_int_equal(res.by_mode[ESR_LIGHT_I_CHANGE].n, 0);
    esr_eval_result_free(&res);
    free(idx);
    esr_dataset_free(&ds);
}

static void test_json(void **state)
{
    (void)state;
    struct esr_dataset ds;
    struct esr_eval_result res;
    int *idx, n;
    char path[1300];
    load_all(&ds, &idx, &n);
    assert_int_equal(esr_eval_phase(&ds, ESR_PHASE_TEST_NV, idx, n, render_dir, &res), ESR_OK);
    path_in(path, sizeof path, test_tmpdir, "eval.json");
    assert_int_equal(esr_eval_write_json(path, &ds, &res), ESR_OK);
    cJSON *root = test_read_json(path);
    assert_non_null(root);
    assert_string_equal(cJSON_GetObjectItem(root, "phase")->valuestring, "test_nv");
    assert_int_equal(cJSON_GetArraySize(cJSON_GetObjectItem(root, "views")), 2);
    const cJSON *v1 = cJSON_GetArrayItem(cJSON_GetObjectItem(root, "views"), 1);
    assert_string_equal(cJSON_GetObjectItem(v1, "name")->valuestring, "c000_on");
    assert_string_equal(cJSON_GetObjectItem(v1, "mode")->valuestring, "on");
    assert_true(fabs(cJSON_GetObjectItem(v1, "hdr_mse")->valuedouble - 0.25) < 1e-6);
    const cJSON *mean = cJSON_GetObjectItem(root, "mean");
    assert_int_equal(cJSON_GetObjectItem(mean, "n")->valueint, 2);
    static const char *const keys[] = {"psnr", "ssim", "psnr_linear", "ssim_linear", "hdr_mse"};
    for (size_t k = 0; k < 5; k++)
        assert_true(cJSON_IsNumber(cJSON_GetObjectItem(mean, keys[k])));
    const cJSON *by_mode = cJSON_GetObjectItem(root, "by_mode");
    assert_int_equal(cJSON_GetArraySize(by_mode), 2);
    assert_true(cJSON_GetObjectItem(cJSON_GetObjectItem(by_mode, "off"), "psnr")->valuedouble ==
                ESR_EVAL_PSNR_CAP);
    /* no gt/ folder: no normal error anywhere */
    assert_int_equal(res.n_normal_views, 0);
    assert_null(cJSON_GetObjectItem(root, "normals"));
    assert_null(cJSON_GetObjectItem(v1, "normal_deg"));
    cJSON_Delete(root);
    esr_eval_result_free(&res);
    free(idx);
    esr_dataset_free(&ds);
}

/* A view without a ground-truth EXR has no HDR MSE (null in JSON, left out of the mean). */
static void test_no_gt_exr(void **state)
{
    (void)state;
    struct esr_dataset ds;
    struct esr_eval_result res;
    int *idx, n;
    char path[1300], moved[1300];
    load_all(&ds, &idx, &n);
    move_aside(ds_dir, "test_nv/exr/c000_on.exr", path, moved, sizeof path);
    int status = esr_eval_phase(&ds, ESR_PHASE_TEST_NV, idx, n, render_dir, &res);
    assert_int_equal(rename(moved, path), 0);
    assert_int_equal(status, ESR_OK);
    assert_true(isnan(res.views[1].hdr_mse));
    assert_true(fabs(res.all.hdr_mse) < 1e-12); /* only the off view counts */
    assert_true(isnan(res.by_mode[ESR_LIGHT_ON].hdr_mse));
    esr_eval_result_free(&res);
    free(idx);
    esr_dataset_free(&ds);
}

/* Missing rendered file, wrong size, absent phase: ESR_ERR with a message naming the problem. */
static void test_errors(void **state)
{
    (void)state;
    struct esr_dataset ds;
    struct esr_eval_result res;
    int *idx, n;
    char path[1300], moved[1300];
    load_all(&ds, &idx, &n);
    move_aside(render_dir, "c000_on_linear.png", path, moved, sizeof path);
    esr_error_clear();
    assert_int_equal(esr_eval_phase(&ds, ESR_PHASE_TEST_NV, idx, n, render_dir, &res), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "c000_on_linear.png"));
    assert_non_null(strstr(esr_error_message(), "missing"));
    esr_eval_result_free(&res);
    /* wrong size */
    write_png_fn(path, 8, 8, 3, 0.0f);
    esr_error_clear();
    assert_int_equal(esr_eval_phase(&ds, ESR_PHASE_TEST_NV, idx, n, render_dir, &res), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "is 8x8 but the dataset's images are 16x16"));
    esr_eval_result_free(&res);
    assert_int_equal(rename(moved, path), 0);
    /* absent phase */
    esr_error_clear();
    assert_int_equal(esr_eval_phase(&ds, ESR_PHASE_TEST_NVI, idx, n, render_dir, &res), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "no phase test_nvi"));
    esr_eval_result_free(&res);
    esr_error_clear();
    free(idx);
    esr_dataset_free(&ds);
}

/* Ground-truth normals gt/c000_normal.exr: background (0,0,0) in rows y < 4, (0,0,1) below. */
static void write_gt_normals(void)
{
    char path[1300];
    struct esr_image img;
    path_in(path, sizeof path, ds_dir, "gt");
    assert_int_equal(mkdir(path, 0755), 0);
    assert_int_equal(esr_image_alloc(&img, RES, RES, 3), ESR_OK);
    for (int i = 0; i < RES * RES; i++) {
        img.data[3 * i] = img.data[3 * i + 1] = 0.0f;
        img.data[3 * i + 2] = i / RES < 4 ? 0.0f : 1.0f;
    }
    path_in(path, sizeof path, ds_dir, "gt/c000_normal.exr");
    assert_int_equal(esr_exr_write(path, &img, 0), ESR_OK);
    esr_image_free(&img);
}

/* Rendered N_normal.exr (composited normal, opacity): c000_off exactly the ground truth's
 * direction at opacity 1 everywhere (background pixels of the ground truth are ignored);
 * c000_on at 45 degrees, (0, 0.9, 0.9) at opacity 0.9, in columns x < 8 and transparent (0.3)
 * in the others. */
static void write_rendered_normals(void)
{
    char path[1300];
    struct esr_image img;
    assert_int_equal(esr_image_alloc(&img, RES, RES, 4), ESR_OK);
    for (int i = 0; i < RES * RES; i++) {
        float *p = img.data + 4 * i;
        p[0] = p[1] = 0.0f;
        p[2] = p[3] = 1.0f;
    }
    path_in(path, sizeof path, render_dir, "c000_off_normal.exr");
    assert_int_equal(esr_exr_write(path, &img, 0), ESR_OK);
    for (int i = 0; i < RES * RES; i++) {
        float *p = img.data + 4 * i, a = i % RES < 8 ? 0.9f : 0.3f;
        p[0] = 0.0f;
        p[1] = p[2] = a;
        p[3] = a;
    }
    path_in(path, sizeof path, render_dir, "c000_on_normal.exr");
    assert_int_equal(esr_exr_write(path, &img, 0), ESR_OK);
    esr_image_free(&img);
}

static void remove_normals(void)
{
    char path[1300];
    static const char *const files[] = {"gt/c000_normal.exr", "gt"};
    for (int i = 0; i < 2; i++) {
        path_in(path, sizeof path, ds_dir, files[i]);
        assert_int_equal(remove(path), 0);
    }
    path_in(path, sizeof path, render_dir, "c000_off_normal.exr");
    assert_int_equal(remove(path), 0);
    path_in(path, sizeof path, render_dir, "c000_on_normal.exr");
    assert_int_equal(remove(path), 0);
}

/* With ground-truth normals: per view and pooled angular errors with values known by
 * construction, in the result, the JSON and the report; a missing rendered normal map is an
 * error naming it. */
static void test_normals(void **state)
{
    (void)state;
    struct esr_dataset ds;
    struct esr_eval_result res;
    int *idx, n;
    char path[1300], moved[1300];
    write_gt_normals();
    write_rendered_normals();
    load_all(&ds, &idx, &n);
    assert_int_equal(esr_eval_phase(&ds, ESR_PHASE_TEST_NV, idx, n, render_dir, &res), ESR_OK);
    assert_int_equal(res.n_normal_views, 2);
    const struct esr_eval_view *off = &res.views[0], *on = &res.views[1];
    assert_true(off->has_normal_gt && on->has_normal_gt);
    assert_int_equal(off->normal.n_gt, 192);
    assert_int_equal(off->normal.n, 192);
    assert_true(off->normal.mean_deg == 0.0 && off->normal.coverage == 1.0 && off->normal.frac_good == 1.0);
    assert_int_equal(on->normal.n, 96);
    assert_true(fabs(on->normal.mean_deg - 45.0) < 1e-4 && fabs(on->normal.median_deg - 45.0) < 1e-4);
    assert_true(on->normal.frac_good == 0.0 && on->normal.coverage == 0.5);
    /* pooled over pixels: 192 at 0 degrees and 96 at 45 */
    assert_int_equal(res.normals.n, 288);
    assert_int_equal(res.normals.n_gt, 384);
    assert_true(fabs(res.normals.mean_deg - 15.0) < 1e-4);
    assert_true(res.normals.median_deg == 0.0);
    assert_true(fabs(res.normals.frac_good - 2.0 / 3.0) < 1e-12);
    assert_true(fabs(res.normals.coverage - 0.75) < 1e-12);

    path_in(path, sizeof path, test_tmpdir, "eval_normals.json");
    assert_int_equal(esr_eval_write_json(path, &ds, &res), ESR_OK);
    cJSON *root = test_read_json(path);
    assert_non_null(root);
    const cJSON *nrm = cJSON_GetObjectItem(root, "normals");
    assert_non_null(nrm);
    assert_int_equal(cJSON_GetObjectItem(nrm, "n_views")->valueint, 2);
    assert_int_equal(cJSON_GetObjectItem(nrm, "n_pixels")->valueint, 288);
    assert_int_equal(cJSON_GetObjectItem(nrm, "n_gt_pixels")->valueint, 384);
    assert_true(fabs(cJSON_GetObjectItem(nrm, "mean_deg")->valuedouble - 15.0) < 1e-4);
    assert_true(cJSON_GetObjectItem(nrm, "median_deg")->valuedouble == 0.0);
    assert_true(fabs(cJSON_GetObjectItem(nrm, "frac_good")->valuedouble - 2.0 / 3.0) < 1e-9);
    assert_true(cJSON_GetObjectItem(nrm, "good_deg")->valuedouble == 10.0);
    assert_true(fabs(cJSON_GetObjectItem(nrm, "coverage")->valuedouble - 0.75) < 1e-9);
    const cJSON *v1 = cJSON_GetArrayItem(cJSON_GetObjectItem(root, "views"), 1);
    assert_true(fabs(cJSON_GetObjectItem(v1, "normal_deg")->valuedouble - 45.0) < 1e-4);
    assert_true(cJSON_GetObjectItem(v1, "normal_coverage")->valuedouble == 0.5);
    assert_true(cJSON_IsNumber(cJSON_GetObjectItem(v1, "normal_median_deg")));
    assert_true(cJSON_IsNumber(cJSON_GetObjectItem(v1, "normal_frac_good")));
    cJSON_Delete(root);

    char gt_dir[1300], html_path[1300];
    path_in(html_path, sizeof html_path, test_tmpdir, "report_normals.html");
    path_in(gt_dir, sizeof gt_dir, test_tmpdir, "eval/test_nv_gt");
    struct esr_report_spec spec = {html_path, "run", &ds, &res, "render", gt_dir, "eval/test_nv_gt", NULL,
                                   NULL, NULL};
    assert_int_equal(esr_report_write(&spec), ESR_OK);
    unsigned char *html;
    size_t size;
    assert_int_equal(esr_file_read_all(html_path, &html, &size), ESR_OK);
    assert_non_null(strstr((char *)html, "Surface normals"));
    assert_non_null(strstr((char *)html, "<td>15.00</td>"));
    assert_non_null(strstr((char *)html, "<td>45.00</td>"));
    free(html);
    esr_eval_result_free(&res);

    /* the ground truth has normals but the render directory lacks a normal map */
    move_aside(render_dir, "c000_on_normal.exr", path, moved, sizeof path);
    esr_error_clear();
    assert_int_equal(esr_eval_phase(&ds, ESR_PHASE_TEST_NV, idx, n, render_dir, &res), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "c000_on_normal.exr"));
    assert_non_null(strstr(esr_error_message(), "missing"));
    esr_error_clear();
    esr_eval_result_free(&res);
    assert_int_equal(rename(moved, path), 0);
    remove_normals();
    free(idx);
    esr_dataset_free(&ds);
}

static void test_select(void **state)
{
    (void)state;
    struct esr_dataset ds;
    int *idx, n;
    load_all(&ds, &idx, &n);
    free(idx);
    const struct esr_phase *ph = &ds.phases[ESR_PHASE_TEST_NV];
    assert_int_equal(esr_select_frames(ph, "test_nv", "c000_on,c000_off", 0, &idx, &n), ESR_OK);
    assert_int_equal(n, 2);
    assert_int_equal(idx[0], 1);
    assert_int_equal(idx[1], 0);
    free(idx);
    assert_int_equal(esr_select_frames(ph, "test_nv", NULL, 1, &idx, &n), ESR_OK);
    assert_int_equal(n, 1);
    assert_int_equal(idx[0], 0);
    free(idx);
    static const char *const bad[] = {"c999", "c000_on,c000_on", ",c000_on", ""};
    static const char *const msg[] = {"no frame called 'c999'", "selected twice", "no frame called ''",
                                      "an empty list of frame names"};
    for (int i = 0; i < 4; i++) {
        esr_error_clear();
        assert_int_equal(esr_select_frames(ph, "test_nv", bad[i], 0, &idx, &n), ESR_ERR);
        assert_null(idx);
        assert_non_null(strstr(esr_error_message(), msg[i]));
    }
    esr_error_clear();
    assert_int_equal(esr_select_frames(ph, "test_nv", NULL, -1, &idx, &n), ESR_ERR);
    esr_error_clear();
    assert_int_equal(esr_select_frames(&ds.phases[ESR_PHASE_TEST_NVC], "test_nvc", NULL, 0, &idx, &n), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "no frames in phase test_nvc"));
    esr_error_clear();
    esr_dataset_free(&ds);
}

static void test_curve(void **state)
{
    (void)state;
    char path[1300];
    path_in(path, sizeof path, test_tmpdir, "log.jsonl");
    assert_int_equal(test_write_file(path, "{\"step\": 0, \"loss\": 0.5}\n\n{\"step\": 10, \"loss\": 0.25, "
                                           "\"psnr\": 12}\n{\"step\": 20, \"psnr\": 15}\n"),
                     0);
    struct esr_curve c;
    assert_int_equal(esr_curve_load_jsonl(path, "psnr", &c), ESR_OK);
    assert_int_equal(c.n, 2);
    assert_true(c.x[0] == 1.0 && c.y[0] == 12.0 && c.x[1] == 2.0 && c.y[1] == 15.0);
    esr_curve_free(&c);
    assert_int_equal(esr_curve_load_jsonl(path, "absent", &c), ESR_OK);
    assert_int_equal(c.n, 0);
    esr_curve_free(&c);
    /* stages: where each begins; a loss over orders of magnitude on a log scale */
    assert_int_equal(test_write_file(path, "{\"stage\": \"coarse\", \"loss\": 1}\n"
                                           "{\"stage\": \"coarse\", \"loss\": 0.1}\n"
                                           "{\"stage\": \"<fine>\", \"loss\": 0.01}\n"),
                     0);
    assert_int_equal(esr_curve_load_jsonl(path, "loss", &c), ESR_OK);
    assert_int_equal(c.n_stages, 2);
    assert_true(c.stage_x[0] == 0.0 && c.stage_x[1] == 2.0);
    assert_string_equal(c.stage[1], "<fine>");
    char *svg = NULL;
    size_t svg_size = 0;
    FILE *mem = open_memstream(&svg, &svg_size);
    assert_non_null(mem);
    assert_int_equal(esr_curve_write_svg(mem, &c, "loss", 300, 120), ESR_OK);
    fclose(mem);
    assert_non_null(strstr(svg, "loss (log scale)"));
    assert_non_null(strstr(svg, "&lt;fine&gt;"));
    /* on a log scale the middle value lies halfway: 1 at the top (20), 0.01 at the bottom (96) */
    assert_non_null(strstr(svg, ",58.0 "));
    free(svg);
    esr_curve_free(&c);
    assert_int_equal(test_write_file(path, "{\"loss\": 1}\nnot json\n"), 0);
    esr_error_clear();
    assert_int_equal(esr_curve_load_jsonl(path, "loss", &c), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "line 2 is not a JSON object"));
    esr_error_clear();
}

static void test_report(void **state)
{
    (void)state;
    struct esr_dataset ds;
    struct esr_eval_result res;
    int *idx, n;
    char path[1300], gt_dir[1300], log[1300], gt_copy[1400];
    load_all(&ds, &idx, &n);
    assert_int_equal(esr_eval_phase(&ds, ESR_PHASE_TEST_NV, idx, n, render_dir, &res), ESR_OK);
    path_in(path, sizeof path, test_tmpdir, "report.html");
    path_in(gt_dir, sizeof gt_dir, test_tmpdir, "eval/test_nv_gt");
    path_in(log, sizeof log, test_tmpdir, "train_log.jsonl");
    assert_int_equal(test_write_file(log, "{\"loss\": 0.5, \"psnr\": 10}\n{\"loss\": 0.3, \"psnr\": 14}\n"), 0);
    struct esr_lights lights;
    memset(&lights, 0, sizeof lights);
    lights.n = 1;
    lights.light[0].radiance[0] = 12.5f;
    lights.light[0].points = 40; /* no labels: none of them unseen */
    const struct esr_chamfer_result geometry = {0.0125, 0.0375, 0.025, 1000};
    /* an edit phase's page next to the report gets a link */
    char edit_page[1400];
    path_in(edit_page, sizeof edit_page, test_tmpdir, "report_test_nvc_ratio.html");
    assert_int_equal(test_write_file(edit_page, "<html></html>"), 0);
    struct esr_report_spec spec = {path, "run <x>", &ds, &res, "render", gt_dir, "eval/test_nv_gt", log,
                                   &lights, &geometry};
    assert_int_equal(esr_report_write(&spec), ESR_OK);
    unsigned char *html;
    size_t size;
    assert_int_equal(esr_file_read_all(path, &html, &size), ESR_OK);
    static const char *const expected[] = {"<h1>run &lt;x&gt;</h1>", "<img src=\"render/c000_on.png\"",
                                           "render/c000_on_linear.png", "render/c000_on_normal.png",
                                           "eval/test_nv_gt/c000_off.png", "<polyline", "13.98",
                                           "Lights found (1)", "<td>0 of 40</td>", "12.5, 0, 0", "</html>",
                                           "<h2>Geometry</h2>", "<td>0.02500</td><td>0.01250</td>",
                                           "<a href=\"report_test_nvc_ratio.html\">"};
    for (size_t i = 0; i < sizeof expected / sizeof expected[0]; i++)
        if (!strstr((char *)html, expected[i]))
            fail_msg("'%s' missing from the report", expected[i]);
    free(html);
    snprintf(gt_copy, sizeof gt_copy, "%s/c000_on.png", gt_dir);
    struct esr_image img;
    assert_int_equal(esr_png_read(gt_copy, &img), ESR_OK);
    assert_int_equal(img.channels, 3);
    assert_int_equal(img.width, RES);
    esr_image_free(&img);
    esr_eval_result_free(&res);
    free(idx);
    esr_dataset_free(&ds);
}

/* A grey mask: 1 where column x < cols (of RES), else 0. */
static void write_mask(const char *path, int cols)
{
    struct esr_image img;
    assert_int_equal(esr_image_alloc(&img, RES, RES, 1), ESR_OK);
    for (int y = 0; y < RES; y++)
        for (int x = 0; x < RES; x++)
            img.data[y * RES + x] = x < cols ? 1.0f : 0.0f;
    assert_int_equal(esr_png_write(path, &img, 8), ESR_OK);
    esr_image_free(&img);
}

/* Emitter IoU pooled over views, and the thresholded-L_emo baseline, by hand: the true emitters
 * are the left half, the rendered masks the left 3/4 (IoU 1/2 / 3/4 = 2/3 in each view); the
 * renders' L_emo = on - off = 2.5 - 0.75 = 1.75 everywhere, so the baseline's best threshold
 * (any k < 1.75) marks every pixel: IoU 1/2. */
static void test_emitters(void **state)
{
    (void)state;
    char path[2700], dir[1300];
    path_in(dir, sizeof dir, ds_dir, "test_nv/emission");
    assert_int_equal(mkdir(dir, 0755), 0);
    const char *names[2] = {"c000_off", "c000_on"};
    for (int i = 0; i < 2; i++) {
        snprintf(path, sizeof path, "%s/%s.png", dir, names[i]);
        write_mask(path, RES / 2);
        snprintf(path, sizeof path, "%s/%s_emitter.png", render_dir, names[i]);
        write_mask(path, 3 * RES / 4);
    }
    struct esr_dataset ds;
    struct esr_eval_result res;
    int *idx, n;
    load_all(&ds, &idx, &n);
    assert_int_equal(esr_eval_phase(&ds, ESR_PHASE_TEST_NV, idx, n, render_dir, &res), ESR_OK);
    assert_int_equal(res.n_emitter_views, 2);
    assert_float_equal(esr_iou_value(&res.emitter), 2.0 / 3.0, 1e-9);
    assert_true(res.views[0].has_emitter && res.views[1].has_emitter);
    assert_float_equal(res.views[1].emitter_iou, 2.0 / 3.0, 1e-9);
    assert_int_equal(res.emo_baseline.n_cameras, 1);
    assert_float_equal(res.emo_baseline.iou, 0.5, 1e-9);
    assert_true(res.emo_baseline.k < 1.75); /* every k below it ties */
    esr_eval_result_free(&res);
    /* the best threshold is found wherever it lies: L_emo 0.51 on the true emitters, 0.50 beside
     * them (2% apart: the 64 log-spaced k used until 2026-11-28, 13.5% apart, have none between,
     * and scored 0.5); the cut between gives IoU 1 at k = 0.505 */
    struct esr_image on;
    assert_int_equal(esr_image_alloc(&on, RES, RES, 3), ESR_OK);
    for (int y = 0; y < RES; y++)
        for (int x = 0; x < RES; x++)
            for (int c = 0; c < 3; c++)
                on.data[(y * RES + x) * 3 + c] = 0.75f + (x < RES / 2 ? 0.51f : 0.50f);
    char on_path[2700];
    path_in(on_path, sizeof on_path, render_dir, "c000_on.exr");
    assert_int_equal(esr_exr_write(on_path, &on, 0), ESR_OK);
    esr_image_free(&on);
    assert_int_equal(esr_eval_phase(&ds, ESR_PHASE_TEST_NV, idx, n, render_dir, &res), ESR_OK);
    assert_float_equal(res.emo_baseline.iou, 1.0, 1e-9);
    assert_float_equal(res.emo_baseline.k, 0.505, 1e-4);
    esr_eval_result_free(&res);
    write_exr_const(on_path, 3, 2.5f, 1.0f);
    free(idx);
    esr_dataset_free(&ds);
    for (int i = 0; i < 2; i++) {
        snprintf(path, sizeof path, "%s/%s.png", dir, names[i]);
        assert_int_equal(remove(path), 0);
        snprintf(path, sizeof path, "%s/%s_emitter.png", render_dir, names[i]);
        assert_int_equal(remove(path), 0);
    }
    assert_int_equal(rmdir(dir), 0);
}

/* Emitted radiance per light by hand: light 0's mask is the left half; the rendered emission is
 * (3, 2, 1) there, except a border column of 100 that the mask's one-pixel erosion must leave
 * out; the truth is (4, 2, 1): error |(1, 0, 0)| / |(4, 2, 1)| = 1/sqrt(21), ratio
 * sqrt(14/21). */
static void test_emitter_radiance(void **state)
{
    (void)state;
    char path[2700];
    struct esr_dataset ds;
    int *idx, n;
    load_all(&ds, &idx, &n);
    ds.n_true_lights = 1;
    const float truth[3] = {4.0f, 2.0f, 1.0f};
    memcpy(ds.true_lights[0].radiance, truth, sizeof truth);
    snprintf(ds.true_lights[0].name, sizeof ds.true_lights[0].name, "shade");
    path_in(path, sizeof path, ds_dir, "test_nv/m0.png");
    write_mask(path, RES / 2);
    struct esr_image em;
    assert_int_equal(esr_image_alloc(&em, RES, RES, 3), ESR_OK);
    for (int y = 0; y < RES; y++)
        for (int x = 0; x < RES; x++)
            for (int c = 0; c < 3; c++)
                em.data[(y * RES + x) * 3 + c] = x == RES / 2 - 1 ? 100.0f : x < RES / 2 ? 3.0f - (float)c : 0.0f;
    for (int i = 0; i < n; i++) {
        struct esr_frame *f = &ds.phases[ESR_PHASE_TEST_NV].frames[idx[i]];
        snprintf(f->lights[0].mask_path, sizeof f->lights[0].mask_path, "test_nv/m0");
        snprintf(path, sizeof path, "%s/%s_emission.exr", render_dir, f->name);
        assert_int_equal(esr_exr_write(path, &em, 0), ESR_OK);
    }
    struct esr_emitter_radiance_result r;
    assert_int_equal(esr_emitter_radiance_eval(&ds, ESR_PHASE_TEST_NV, idx, n, render_dir, &r), ESR_OK);
    assert_int_equal(r.n, 1);
    assert_string_equal(r.lights[0].name, "shade");
    /* eroded: columns 1 .. RES/2 - 2, rows 1 .. RES - 2, in both views */
    assert_int_equal(r.lights[0].pixels, 2L * (RES / 2 - 2) * (RES - 2));
    for (int c = 0; c < 3; c++)
        assert_float_equal(r.lights[0].mean[c], 3.0 - c, 1e-6);
    assert_float_equal(r.lights[0].error_pct, 100.0 / sqrt(21.0), 1e-4);
    assert_float_equal(r.lights[0].ratio, sqrt(14.0 / 21.0), 1e-6);
    for (int i = 0; i < n; i++) {
        snprintf(path, sizeof path, "%s/%s_emission.exr", render_dir,
                 ds.phases[ESR_PHASE_TEST_NV].frames[idx[i]].name);
        assert_int_equal(remove(path), 0);
    }
    path_in(path, sizeof path, ds_dir, "test_nv/m0.png");
    assert_int_equal(remove(path), 0);
    esr_image_free(&em);
    free(idx);
    esr_dataset_free(&ds);
}

/* The light split by hand: light 0's mask is the left half (8 of 16 columns); the rendered ids
 * are esr light 1 on columns 0-5, esr light 0 on columns 6-9 and esr light 2 on columns 12-13:
 * light 0 is scored against esr light 1, IoU 6 / (8 + 6 - 6) = 0.75 (esr light 0: 2 / (8 + 4 -
 * 2) = 0.2); esr lights 0 and 1 both follow light 0's edits (both overlap it), esr light 2
 * overlaps no light and follows none. */
static void test_light_split(void **state)
{
    (void)state;
    char path[2700];
    struct esr_dataset ds;
    int *idx, n;
    load_all(&ds, &idx, &n);
    path_in(path, sizeof path, ds_dir, "test_nv/m0.png");
    write_mask(path, RES / 2);
    struct esr_image ids;
    assert_int_equal(esr_image_alloc(&ids, RES, RES, 1), ESR_OK);
    for (int y = 0; y < RES; y++)
        for (int x = 0; x < RES; x++)
            ids.data[y * RES + x] = (x < 6 ? 2.0f : x < 10 ? 1.0f : x == 12 || x == 13 ? 3.0f : 0.0f) / 255.0f;
    for (int i = 0; i < n; i++) {
        struct esr_frame *f = &ds.phases[ESR_PHASE_TEST_NV].frames[idx[i]];
        snprintf(f->lights[0].mask_path, sizeof f->lights[0].mask_path, "test_nv/m0");
        snprintf(path, sizeof path, "%s/%s_lights.png", render_dir, f->name);
        assert_int_equal(esr_png_write(path, &ids, 8), ESR_OK);
    }
    struct esr_light_split sp;
    assert_int_equal(esr_light_split_eval(&ds, ESR_PHASE_TEST_NV, idx, n, render_dir, &sp), ESR_OK);
    assert_int_equal(sp.views, 2);
    assert_int_equal(sp.n, 1);
    assert_int_equal(sp.rows[0].esr_light, 1);
    assert_float_equal(sp.rows[0].iou, 0.75, 1e-9);
    assert_float_equal(sp.mean_iou, 0.75, 1e-9);
    assert_int_equal(sp.dataset_light[0], 0);
    assert_int_equal(sp.dataset_light[1], 0);
    assert_int_equal(sp.dataset_light[2], -1);
    assert_int_equal(sp.dataset_light[3], -1);
    for (int i = 0; i < n; i++) {
        snprintf(path, sizeof path, "%s/%s_lights.png", render_dir,
                 ds.phases[ESR_PHASE_TEST_NV].frames[idx[i]].name);
        assert_int_equal(remove(path), 0);
    }
    path_in(path, sizeof path, ds_dir, "test_nv/m0.png");
    assert_int_equal(remove(path), 0);
    esr_image_free(&ids);
    free(idx);
    esr_dataset_free(&ds);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_known_values), cmocka_unit_test(test_json),   cmocka_unit_test(test_no_gt_exr),
        cmocka_unit_test(test_errors),       cmocka_unit_test(test_select), cmocka_unit_test(test_curve),
        cmocka_unit_test(test_report),       cmocka_unit_test(test_normals),
        cmocka_unit_test(test_emitters),     cmocka_unit_test(test_emitter_radiance),
        cmocka_unit_test(test_light_split),
    };
    return cmocka_run_group_tests(tests, setup, test_teardown_tmpdir);
}
