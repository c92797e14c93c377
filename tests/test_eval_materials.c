/* Material maps scored against the truth (eval/materials.h): the scores of small hand-made maps
 * against values computed here (the sRGB curve written out again from IEC 61966-2-1, the gain's
 * closed form), which pixels count and into which metallic set, empty sets as null, and, on a
 * 16x16 fixture dataset, the files: esr_eval_phase's "materials", its JSON, the terminal lines,
 * the report's section and truth images, a missing or mis-sized map. */
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
#include <sys/stat.h>

#include "core/error.h"
#include "eval/evaluate.h"
#include "eval/materials.h"
#include "eval/report.h"
#include "eval/select.h"
#include "io/dataset.h"
#include "io/file.h"
#include "io/image.h"
#include "test_support.h"

/* IEC 61966-2-1, in double: the values the scores are checked against. */
static double srgb_encode(double x)
{
    return x <= 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1.0 / 2.4) - 0.055;
}

static double srgb_decode(double v)
{
    return v <= 0.04045 ? v / 12.92 : pow((v + 0.055) / 1.055, 2.4);
}

static void expect_near(double got, double want, double tol, const char *what)
{
    if (!(fabs(got - want) <= tol))
        fail_msg("%s: got %.9g, expected %.9g", what, got, want);
}

/* ---- in-memory maps ---- */

/* One pixel: the render's surface values (before compositing on white), its opacity, the truth
 * and whether the truth has a surface there. */
struct pixel {
    float base[3], rough, metal, a;
    float t_base[3], t_rough, t_metal;
    int surface;
};

/* Maps of one row of pixels as the files give them: the render composited on white (base
 * 3 channels, grey 1), opacity as N_normal.exr's alpha (4 channels), truth 4 channels (RGBA, as
 * esr_exr_read returns them). */
struct maps {
    struct esr_image p[4], t[4];
    struct esr_material_maps pred, truth;
};

static void maps_make(struct maps *m, const struct pixel *px, int n)
{
    static const int pch[4] = {3, 1, 1, 4};
    for (int k = 0; k < 4; k++) {
        assert_int_equal(esr_image_alloc(&m->p[k], n, 1, pch[k]), ESR_OK);
        assert_int_equal(esr_image_alloc(&m->t[k], n, 1, 4), ESR_OK);
    }
    for (int i = 0; i < n; i++) {
        const struct pixel *q = &px[i];
        const float bg = 1.0f - q->a;
        for (int c = 0; c < 3; c++)
            m->p[0].data[3 * i + c] = q->a * q->base[c] + bg;
        m->p[1].data[i] = q->a * q->rough + bg;
        m->p[2].data[i] = q->a * q->metal + bg;
        float *o = m->p[3].data + 4 * i;
        o[0] = o[1] = 0.0f;
        o[2] = q->a; /* composited normal (0, 0, a): unused here */
        o[3] = q->a;
        for (int c = 0; c < 4; c++) {
            m->t[0].data[4 * i + c] = c < 3 ? q->t_base[c] : 1.0f;
            m->t[1].data[4 * i + c] = c < 3 ? q->t_rough : 1.0f;
            m->t[2].data[4 * i + c] = c < 3 ? q->t_metal : 1.0f;
            m->t[3].data[4 * i + c] = c == 3 ? 1.0f : c == 2 && q->surface ? 1.0f : 0.0f;
        }
    }
    m->pred = (struct esr_material_maps){&m->p[0], &m->p[1], &m->p[2], &m->p[3]};
    m->truth = (struct esr_material_maps){&m->t[0], &m->t[1], &m->t[2], &m->t[3]};
}

static void maps_free(struct maps *m)
{
    for (int k = 0; k < 4; k++) {
        esr_image_free(&m->p[k]);
        esr_image_free(&m->t[k]);
    }
}

/* Both passes over one view: stats with its own gains. */
static struct esr_material_stats score(const struct pixel *px, int n)
{
    struct maps m;
    struct esr_material_sums s;
    double gain[3];
    memset(&s, 0, sizeof s);
    maps_make(&m, px, n);
    assert_int_equal(esr_material_add(&s, &m.pred, &m.truth), ESR_OK);
    esr_material_gains(&s, gain);
    assert_int_equal(esr_material_add_gained(&s, &m.pred, &m.truth, gain), ESR_OK);
    maps_free(&m);
    return esr_material_stats_of(&s, gain);
}

/* Truth base colour 0 or 1 (the same in sRGB), so that every error is exact. */
static const struct pixel masked[] = {
    /* scored, opaque: base exact; roughness off by 0.2; metallic 0.2 on a dielectric (truth 0) */
    {{1, 0, 1}, 0.5f, 0.2f, 1.0f, {1, 0, 1}, 0.3f, 0.0f, 1},
    /* scored: base 0.5 against 1 (squared error 3 x 0.25); metallic 0.6 on a metal (truth 1) */
    {{0.5f, 0.5f, 0.5f}, 0.4f, 0.6f, 1.0f, {1, 1, 1}, 0.4f, 1.0f, 1},
    /* surface, opacity exactly 0.5: not scored (as the normals), but a truth surface pixel */
    {{0, 0, 0}, 0, 0, 0.5f, {1, 1, 1}, 1, 1, 1},
    /* background in the truth: ignored whatever the render says */
    {{0, 0, 0}, 1, 1, 1.0f, {0, 0, 0}, 0, 0, 0},
    /* scored at opacity 0.8: the white is taken off again (stored base 0.2, roughness 1, metallic
     * 0.6); truth metallic 0.5 is in neither set */
    {{0, 0, 0}, 1.0f, 0.5f, 0.8f, {0, 0, 0}, 0.5f, 0.5f, 1},
    /* truth metallic exactly 0.9 is metallic; exact render */
    {{1, 1, 1}, 0.2f, 0.9f, 1.0f, {1, 1, 1}, 0.2f, 0.9f, 1},
    /* truth metallic exactly 0.1 is non-metallic; metallic 0.3 against it */
    {{0, 0, 0}, 0.7f, 0.3f, 1.0f, {0, 0, 0}, 0.7f, 0.1f, 1},
};
#define N_MASKED ((int)(sizeof masked / sizeof masked[0]))

static void test_masking_and_split(void **state)
{
    (void)state;
    struct esr_material_stats s = score(masked, N_MASKED);
    assert_int_equal(s.n_gt, 6);
    assert_int_equal(s.n, 5);
    expect_near(s.coverage, 5.0 / 6.0, 1e-12, "coverage");
    /* squared error 0.75 over 5 pixels x 3 channels: MSE 0.05, PSNR 10 log10(20) */
    expect_near(s.base_color_psnr, 10.0 * log10(20.0), 1e-5, "base colour PSNR");
    /* roughness errors 0.2, 0, 0.5, 0, 0 */
    expect_near(s.roughness_mae, 0.7 / 5.0, 1e-6, "roughness MAE");
    /* metallic errors 0.2, 0.4, 0, 0, 0.2 */
    expect_near(s.metallic_mae, 0.8 / 5.0, 1e-6, "metallic MAE");
    /* metallic set: pixels 1 and 5 */
    assert_int_equal(s.metal.n, 2);
    expect_near(s.metal.metallic_mae, 0.2, 1e-6, "metallic set's metallic MAE");
    expect_near(s.metal.roughness_mae, 0.0, 1e-6, "metallic set's roughness MAE");
    expect_near(s.metal.mean_metallic, 0.75, 1e-6, "metallic set's mean metallic");
    /* non-metallic set: pixels 0 and 6 */
    assert_int_equal(s.dielectric.n, 2);
    expect_near(s.dielectric.metallic_mae, 0.2, 1e-6, "non-metallic set's metallic MAE");
    expect_near(s.dielectric.roughness_mae, 0.1, 1e-6, "non-metallic set's roughness MAE");
    expect_near(s.dielectric.mean_metallic, 0.25, 1e-6, "non-metallic set's mean metallic");
}

/* g_c = sum t r / sum r r (r the render's linear value) over the pixels; PSNR after the gain
 * against the value computed here. */
static void test_gain_closed_form(void **state)
{
    (void)state;
    /* R: r = 1 against t = 0.5 and 0.25: g = 0.375; G: r = r0 = decode(0.5) and 1 against 0.2
     * both: g = 0.2 (r0 + 1) / (r0^2 + 1); B: the render is black: gain 1 */
    const float t0[3] = {0.5f, 0.2f, 0.3f}, t1[3] = {0.25f, 0.2f, 0.6f};
    const struct pixel px[2] = {
        {{1, 0.5f, 0}, 0.5f, 0, 1.0f, {t0[0], t0[1], t0[2]}, 0.5f, 0, 1},
        {{1, 1, 0}, 0.5f, 0, 1.0f, {t1[0], t1[1], t1[2]}, 0.5f, 0, 1},
    };
    const double p[2][3] = {{1, 0.5, 0}, {1, 1, 0}};
    const double r0 = srgb_decode(0.5);
    const double g[3] = {0.375, (0.2 * r0 + 0.2) / (r0 * r0 + 1.0), 1.0};
    struct esr_material_stats s = score(px, 2);
    for (int c = 0; c < 3; c++)
        expect_near(s.gain[c], g[c], 1e-6, "gain");
    double se = 0.0, se_gain = 0.0;
    const float *t[2] = {t0, t1};
    for (int i = 0; i < 2; i++)
        for (int c = 0; c < 3; c++) {
            const double ts = srgb_encode(t[i][c]);
            se += (p[i][c] - ts) * (p[i][c] - ts);
            const double gp = fmin(1.0, g[c] * srgb_decode(p[i][c]));
            se_gain += (srgb_encode(gp) - ts) * (srgb_encode(gp) - ts);
        }
    expect_near(s.base_color_psnr, 10.0 * log10(6.0 / se), 1e-4, "PSNR");
    expect_near(s.base_color_psnr_gain, 10.0 * log10(6.0 / se_gain), 1e-4, "PSNR with gains");
    assert_true(s.base_color_psnr_gain > s.base_color_psnr);

    /* a render off by one scale per channel is exact after the gains: PSNR capped */
    const struct pixel scaled[2] = {
        {{0.5f, 0.6f, 0.7f}, 0, 0, 1.0f,
         {(float)(0.5 * srgb_decode(0.5)), (float)(0.8 * srgb_decode(0.6)), (float)(0.4 * srgb_decode(0.7))}, 0, 0, 1},
        {{0.6f, 0.7f, 0.5f}, 0, 0, 1.0f,
         {(float)(0.5 * srgb_decode(0.6)), (float)(0.8 * srgb_decode(0.7)), (float)(0.4 * srgb_decode(0.5))}, 0, 0, 1},
    };
    s = score(scaled, 2);
    expect_near(s.gain[0], 0.5, 1e-5, "gain R");
    expect_near(s.gain[1], 0.8, 1e-5, "gain G");
    expect_near(s.gain[2], 0.4, 1e-5, "gain B");
    assert_true(s.base_color_psnr < 20.0);
    assert_true(s.base_color_psnr_gain > 60.0);
}

/* Two views pooled: one gain for both (their own would make each exact). */
static void test_gains_pooled_over_views(void **state)
{
    (void)state;
    const struct pixel a = {{1, 1, 1}, 0, 0, 1.0f, {0.5f, 0.5f, 0.5f}, 0, 0, 1};
    const struct pixel b = {{1, 1, 1}, 0, 0, 1.0f, {0.25f, 0.25f, 0.25f}, 0, 0, 1};
    struct maps ma, mb;
    struct esr_material_sums sa, sb, pooled;
    memset(&sa, 0, sizeof sa);
    memset(&sb, 0, sizeof sb);
    memset(&pooled, 0, sizeof pooled);
    maps_make(&ma, &a, 1);
    maps_make(&mb, &b, 1);
    assert_int_equal(esr_material_add(&sa, &ma.pred, &ma.truth), ESR_OK);
    assert_int_equal(esr_material_add(&sb, &mb.pred, &mb.truth), ESR_OK);
    esr_material_sums_merge(&pooled, &sa);
    esr_material_sums_merge(&pooled, &sb);
    double gain[3];
    esr_material_gains(&pooled, gain);
    expect_near(gain[1], 0.375, 1e-9, "pooled gain");
    assert_int_equal(esr_material_add_gained(&sa, &ma.pred, &ma.truth, gain), ESR_OK);
    struct esr_material_stats s = esr_material_stats_of(&sa, gain);
    const double d = srgb_encode(0.375) - srgb_encode(0.5);
    expect_near(s.base_color_psnr_gain, -10.0 * log10(d * d), 1e-4, "view a's PSNR with the pooled gain");
    maps_free(&ma);
    maps_free(&mb);
}

/* No metallic pixel, no scored pixel at all: means over nothing are NAN (null in JSON). */
static void test_empty_sets(void **state)
{
    (void)state;
    const struct pixel px[2] = {
        {{0.5f, 0.5f, 0.5f}, 0.5f, 0.5f, 1.0f, {1, 1, 1}, 0.5f, 0.0f, 1},
        {{0.5f, 0.5f, 0.5f}, 0.5f, 0.5f, 0.2f, {1, 1, 1}, 0.5f, 1.0f, 1}, /* not opaque */
    };
    struct esr_material_stats s = score(px, 2);
    assert_int_equal(s.n, 1);
    assert_int_equal(s.dielectric.n, 1);
    assert_int_equal(s.metal.n, 0);
    assert_true(isnan(s.metal.mean_metallic) && isnan(s.metal.roughness_mae) && isnan(s.metal.metallic_mae));
    expect_near(s.dielectric.mean_metallic, 0.5, 1e-6, "mean metallic");
    s = score(px + 1, 1);
    assert_int_equal(s.n_gt, 1);
    assert_int_equal(s.n, 0);
    assert_true(isnan(s.base_color_psnr) && isnan(s.base_color_psnr_gain) && isnan(s.roughness_mae));
    expect_near(s.coverage, 0.0, 0.0, "coverage");
    for (int c = 0; c < 3; c++)
        expect_near(s.gain[c], 1.0, 0.0, "gain of no pixel");
    /* the same through the JSON */
    struct esr_materials_result r;
    memset(&r, 0, sizeof r);
    r.has_truth = 1;
    r.pooled = s;
    cJSON *o = esr_materials_json(&r);
    assert_non_null(o);
    assert_true(cJSON_IsNull(cJSON_GetObjectItem(o, "base_color_psnr")));
    assert_true(cJSON_IsNull(cJSON_GetObjectItem(cJSON_GetObjectItem(o, "metallic"), "mean_metallic")));
    assert_int_equal(cJSON_GetObjectItem(cJSON_GetObjectItem(o, "metallic"), "pixels")->valueint, 0);
    cJSON_Delete(o);
    /* nothing without truth */
    r.has_truth = 0;
    assert_null(esr_materials_json(&r));
}

static void test_bad_maps(void **state)
{
    (void)state;
    struct maps m;
    struct esr_material_sums s;
    memset(&s, 0, sizeof s);
    maps_make(&m, masked, N_MASKED);
    struct esr_image small = {0};
    assert_int_equal(esr_image_alloc(&small, 2, 1, 4), ESR_OK);
    struct esr_material_maps truth = m.truth;
    truth.roughness = &small;
    assert_int_equal(esr_material_add(&s, &m.pred, &truth), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "ground-truth roughness map is 2x1"));
    esr_error_clear();
    struct esr_material_maps pred = m.pred;
    pred.base = m.pred.roughness; /* grey as colour */
    assert_int_equal(esr_material_add(&s, &pred, &m.truth), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "1 channel(s)"));
    assert_int_equal(s.n_gt, 0);
    esr_error_clear();
    esr_image_free(&small);
    maps_free(&m);
}

/* ---- files: a 16x16 dataset with one camera, c000_off and c000_on ---- */

#define RES 16
static char ds_dir[1100], render_dir[1100];

static void path_in(char *out, size_t n, const char *dir, const char *rel)
{
    snprintf(out, n, "%s/%s", dir, rel);
}

/* A w x h image with `channels` channels, each pixel from fn(x, y, c). */
static void write_image(const char *path, int w, int h, int channels, float (*fn)(int, int, int))
{
    struct esr_image img;
    assert_int_equal(esr_image_alloc(&img, w, h, channels), ESR_OK);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int c = 0; c < channels; c++)
                img.data[(y * w + x) * channels + c] = fn(x, y, c);
    if (esr_image_is_exr(path))
        assert_int_equal(esr_exr_write(path, &img, 0), ESR_OK);
    else
        assert_int_equal(esr_png_write(path, &img, 8), ESR_OK);
    esr_image_free(&img);
}

/* Truth: row 0 is background; the left half non-metallic (0), the right half metallic (1);
 * base colour decode(0.4) (0.4 once encoded), roughness 0.5. */
static float t_normal(int x, int y, int c) { (void)x; return y > 0 && c == 2 ? 1.0f : 0.0f; }
static float t_base(int x, int y, int c) { (void)x; (void)c; return y > 0 ? (float)srgb_decode(0.4) : 0.0f; }
static float t_rough(int x, int y, int c) { (void)x; (void)c; return y > 0 ? 0.5f : 0.0f; }
static float t_metal(int x, int y, int c) { (void)c; return y > 0 && x >= RES / 2 ? 1.0f : 0.0f; }
/* Render (8-bit exact values): base 0.6 (153/255), roughness 0.6, metallic 0.2 (51/255), opaque
 * but for column 0 (opacity 0.25: not scored) */
static float r_base(int x, int y, int c) { (void)x; (void)y; (void)c; return 153.0f / 255.0f; }
static float r_metal(int x, int y, int c) { (void)x; (void)y; (void)c; return 51.0f / 255.0f; }
static float r_normal(int x, int y, int c) { (void)y; return c < 2 ? 0.0f : x == 0 ? 0.25f : 1.0f; }
static float r_grey(int x, int y, int c) { (void)x; (void)y; (void)c; return 0.5f; }

static void write_truth(const char *map, float (*fn)(int, int, int), int channels)
{
    char rel[64], path[1300];
    snprintf(rel, sizeof rel, "gt/c000_%s.exr", map);
    path_in(path, sizeof path, ds_dir, rel);
    write_image(path, RES, RES, channels, fn);
}

static void write_render(const char *name, const char *suffix, float (*fn)(int, int, int), int channels)
{
    char rel[64], path[1300];
    snprintf(rel, sizeof rel, "%s%s", name, suffix);
    path_in(path, sizeof path, render_dir, rel);
    write_image(path, RES, RES, channels, fn);
}

static void make_truth(void)
{
    write_truth("normal", t_normal, 3);
    write_truth("base_color", t_base, 3);
    write_truth("roughness", t_rough, 1);
    write_truth("metallic", t_metal, 1);
}

static void make_renders(void)
{
    static const char *const names[2] = {"c000_off", "c000_on"};
    for (int i = 0; i < 2; i++) {
        write_render(names[i], ".png", r_grey, 3);
        write_render(names[i], "_linear.png", r_grey, 3);
        write_render(names[i], "_normal.exr", r_normal, 4);
        write_render(names[i], "_basecolor.png", r_base, 3);
        write_render(names[i], "_roughness.png", r_base, 1);
        write_render(names[i], "_metallic.png", r_metal, 1);
    }
}

static int setup(void **state)
{
    if (test_setup_tmpdir(state))
        return -1;
    char path[1300], text[1400];
    snprintf(ds_dir, sizeof ds_dir, "%s/ds", test_tmpdir);
    snprintf(render_dir, sizeof render_dir, "%s/render", test_tmpdir);
    static const char *const dirs[] = {"", "/transforms", "/train", "/test_nv", "/gt"};
    for (size_t i = 0; i < sizeof dirs / sizeof dirs[0]; i++) {
        snprintf(path, sizeof path, "%s%s", ds_dir, dirs[i]);
        assert_int_equal(mkdir(path, 0755), 0);
    }
    assert_int_equal(mkdir(render_dir, 0755), 0);
    static const char *const frame =
        "{\"file_path\": \"%s\", \"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]], "
        "\"lights\": [{\"mode\": \"%s\", \"mask_path\": \"\", \"color\": [0,0,1], \"intensity\": %d}]}";
    char f1[512], f2[512];
    snprintf(f1, sizeof f1, frame, "train/r_000", "off", 0);
    snprintf(text, sizeof text, "{\"camera_angle_x\": 0.7, \"frames\": [%s]}", f1);
    path_in(path, sizeof path, ds_dir, "transforms/transforms_train.json");
    assert_int_equal(test_write_file(path, text), 0);
    snprintf(f1, sizeof f1, frame, "test_nv/c000_off", "off", 0);
    snprintf(f2, sizeof f2, frame, "test_nv/c000_on", "on", 1);
    snprintf(text, sizeof text, "{\"camera_angle_x\": 0.7, \"frames\": [%s, %s]}", f1, f2);
    path_in(path, sizeof path, ds_dir, "transforms/transforms_test_nv.json");
    assert_int_equal(test_write_file(path, text), 0);
    static const char *const pngs[] = {"train/r_000.png", "test_nv/c000_off.png", "test_nv/c000_on.png"};
    for (size_t i = 0; i < 3; i++) {
        path_in(path, sizeof path, ds_dir, pngs[i]);
        write_image(path, RES, RES, 3, r_grey);
    }
    make_truth();
    make_renders();
    return 0;
}

static int eval_fixture(struct esr_dataset *ds, struct esr_eval_result *res)
{
    int *idx, n;
    assert_int_equal(esr_dataset_load(ds_dir, ds), ESR_OK);
    assert_int_equal(esr_select_frames(&ds->phases[ESR_PHASE_TEST_NV], "test_nv", NULL, 0, &idx, &n), ESR_OK);
    assert_int_equal(n, 2);
    int status = esr_eval_phase(ds, ESR_PHASE_TEST_NV, idx, n, render_dir, res);
    free(idx);
    return status;
}

/* The fixture's expected pooled scores: 15 x 16 truth surface pixels, column 0 not scored. */
static void expect_fixture_scores(const struct esr_material_stats *s)
{
    assert_int_equal(s->n_gt, 15 * 16);
    assert_int_equal(s->n, 15 * 15);
    /* 0.6 against 0.4 in sRGB: MSE 0.04 */
    expect_near(s->base_color_psnr, -10.0 * log10(0.04), 1e-4, "base colour PSNR");
    const double g = srgb_decode(0.4) / srgb_decode(0.6);
    for (int c = 0; c < 3; c++)
        expect_near(s->gain[c], g, 1e-5, "gain");
    assert_true(s->base_color_psnr_gain > 60.0); /* exact but for float rounding */
    expect_near(s->roughness_mae, 0.1, 1e-6, "roughness MAE");
    /* 0.2 against 0 on 7 scored columns, against 1 on 8 */
    expect_near(s->metallic_mae, (7 * 0.2 + 8 * 0.8) / 15.0, 1e-6, "metallic MAE");
    assert_int_equal(s->metal.n, 15 * 8);
    assert_int_equal(s->dielectric.n, 15 * 7);
    expect_near(s->metal.metallic_mae, 0.8, 1e-6, "metallic set's metallic MAE");
    expect_near(s->dielectric.metallic_mae, 0.2, 1e-6, "non-metallic set's metallic MAE");
    expect_near(s->metal.mean_metallic, 0.2, 1e-6, "metallic set's mean metallic");
    expect_near(s->dielectric.mean_metallic, 0.2, 1e-6, "non-metallic set's mean metallic");
}

static void test_eval_files(void **state)
{
    (void)state;
    struct esr_dataset ds;
    struct esr_eval_result res;
    assert_int_equal(eval_fixture(&ds, &res), ESR_OK);
    const struct esr_materials_result *m = &res.materials;
    assert_true(m->has_truth);
    assert_string_equal(m->skipped, "");
    assert_int_equal(m->n_views, 1); /* c000_off and c000_on: one camera, scored once */
    assert_string_equal(m->views[0].name, "c000_off");
    expect_fixture_scores(&m->pooled);
    expect_fixture_scores(&m->views[0].stats);

    /* the JSON */
    char path[1300];
    path_in(path, sizeof path, test_tmpdir, "eval.json");
    assert_int_equal(esr_eval_write_json(path, &ds, &res), ESR_OK);
    cJSON *root = test_read_json(path);
    const cJSON *o = cJSON_GetObjectItem(root, "materials");
    assert_non_null(o);
    assert_int_equal(cJSON_GetObjectItem(o, "n_views")->valueint, 1);
    assert_int_equal(cJSON_GetObjectItem(o, "n_pixels")->valueint, 225);
    expect_near(cJSON_GetObjectItem(o, "base_color_psnr")->valuedouble, -10.0 * log10(0.04), 1e-4, "JSON PSNR");
    assert_true(cJSON_IsNumber(cJSON_GetObjectItem(o, "base_color_psnr_gain")));
    assert_int_equal(cJSON_GetArraySize(cJSON_GetObjectItem(o, "gain")), 3);
    expect_near(cJSON_GetObjectItem(o, "roughness_mae")->valuedouble, 0.1, 1e-6, "JSON roughness MAE");
    const cJSON *metal = cJSON_GetObjectItem(o, "metallic"), *diel = cJSON_GetObjectItem(o, "non_metallic");
    assert_int_equal(cJSON_GetObjectItem(metal, "pixels")->valueint, 120);
    expect_near(cJSON_GetObjectItem(metal, "mean_metallic")->valuedouble, 0.2, 1e-6, "JSON mean metallic");
    expect_near(cJSON_GetObjectItem(diel, "metallic_mae")->valuedouble, 0.2, 1e-6, "JSON metallic MAE");
    const cJSON *pv = cJSON_GetObjectItem(o, "per_view");
    assert_int_equal(cJSON_GetArraySize(pv), 1);
    assert_string_equal(cJSON_GetObjectItem(cJSON_GetArrayItem(pv, 0), "name")->valuestring, "c000_off");
    cJSON_Delete(root);

    /* the terminal */
    char *text = NULL;
    size_t size = 0;
    FILE *out = open_memstream(&text, &size);
    esr_materials_print(out, out, m);
    fclose(out);
    static const char *const lines[] = {"materials vs gt (1 views", "225 of 240", "base colour 13.98 dB",
                                        "roughness MAE 0.100", "metallic pixels (truth metallic >= 0.9): 120",
                                        "non-metallic pixels (truth metallic <= 0.1): 105",
                                        "mean predicted metallic 0.200"};
    for (size_t i = 0; i < sizeof lines / sizeof lines[0]; i++)
        if (!strstr(text, lines[i]))
            fail_msg("'%s' missing from:\n%s", lines[i], text);
    free(text);

    /* the report: the section, the rendered maps beside the truth's, written as the render's */
    char html_path[1300], gt_dir[1100];
    path_in(html_path, sizeof html_path, test_tmpdir, "report.html");
    path_in(gt_dir, sizeof gt_dir, test_tmpdir, "eval/test_nv_gt");
    struct esr_report_spec spec = {html_path, "run", &ds, &res, "render", gt_dir, "eval/test_nv_gt", NULL,
                                   NULL, NULL};
    assert_int_equal(esr_report_write(&spec), ESR_OK);
    unsigned char *html;
    assert_int_equal(esr_file_read_all(html_path, &html, &size), ESR_OK);
    static const char *const parts[] = {"<h2>Materials</h2>", "<img src=\"render/c000_off_basecolor.png\"",
                                        "eval/test_nv_gt/c000_off_basecolor_true.png",
                                        "render/c000_off_metallic.png", "eval/test_nv_gt/c000_off_roughness_true.png",
                                        "<td>13.98</td>", "truly metallic (&gt;= 0.9)"};
    for (size_t i = 0; i < sizeof parts / sizeof parts[0]; i++)
        if (!strstr((char *)html, parts[i]))
            fail_msg("'%s' missing from the report", parts[i]);
    free(html);
    struct esr_image img;
    path_in(path, sizeof path, gt_dir, "c000_off_basecolor_true.png");
    assert_int_equal(esr_png_read(path, &img), ESR_OK);
    assert_int_equal(img.channels, 3);
    expect_near(img.data[0], 1.0, 0.0, "background white");
    expect_near(img.data[3 * RES], 0.4, 0.5 / 255.0, "true base colour, sRGB");
    esr_image_free(&img);
    path_in(path, sizeof path, gt_dir, "c000_off_metallic_true.png");
    assert_int_equal(esr_png_read(path, &img), ESR_OK);
    assert_int_equal(img.channels, 1);
    expect_near(img.data[RES], 0.0, 0.0, "true metallic, left");
    expect_near(img.data[2 * RES - 1], 1.0, 0.0, "true metallic, right");
    esr_image_free(&img);
    esr_eval_result_free(&res);
    esr_dataset_free(&ds);
}

/* Moves root/rel aside (restore with the swapped pair). */
static void move(const char *root, const char *rel, const char *aside, int back)
{
    char a[1300], b[1300];
    path_in(a, sizeof a, root, rel);
    path_in(b, sizeof b, test_tmpdir, aside);
    assert_int_equal(back ? rename(b, a) : rename(a, b), 0);
}

static void expect_skipped(const char *why)
{
    struct esr_dataset ds;
    struct esr_eval_result res;
    assert_int_equal(eval_fixture(&ds, &res), ESR_OK);
    assert_true(res.materials.has_truth);
    if (!strstr(res.materials.skipped, why))
        fail_msg("skipped for '%s', expected '%s'", res.materials.skipped, why);
    assert_int_equal(res.materials.n_views, 0);
    cJSON *o = esr_materials_json(&res.materials);
    assert_non_null(strstr(cJSON_GetObjectItem(o, "skipped")->valuestring, why));
    assert_null(cJSON_GetObjectItem(o, "base_color_psnr"));
    cJSON_Delete(o);
    esr_eval_result_free(&res);
    esr_dataset_free(&ds);
}

static void expect_error(const char *why)
{
    struct esr_dataset ds;
    struct esr_eval_result res;
    assert_int_equal(eval_fixture(&ds, &res), ESR_ERR);
    if (!strstr(esr_error_message(), why))
        fail_msg("error '%s', expected '%s'", esr_error_message(), why);
    esr_error_clear();
    esr_eval_result_free(&res);
    esr_dataset_free(&ds);
}

static void test_missing_and_bad_files(void **state)
{
    (void)state;
    /* a truth map missing: skipped, naming it */
    move(ds_dir, "gt/c000_metallic.exr", "aside", 0);
    expect_skipped("gt/c000_metallic.exr is missing");
    move(ds_dir, "gt/c000_metallic.exr", "aside", 1);
    /* no material maps rendered (a model before lts): skipped, saying so */
    static const char *const maps[3] = {"c000_off_basecolor.png", "c000_off_roughness.png", "c000_off_metallic.png"};
    char aside[32];
    for (int j = 0; j < 3; j++) {
        snprintf(aside, sizeof aside, "aside%d", j);
        move(render_dir, maps[j], aside, 0);
    }
    expect_skipped("no material maps (c000_off_basecolor.png)");
    /* some but not all: an error naming the missing one */
    move(render_dir, maps[0], "aside0", 1);
    move(render_dir, maps[1], "aside1", 1);
    expect_error("c000_off_metallic.png' is missing");
    move(render_dir, maps[2], "aside2", 1);
    /* a truth map of another size: an error naming it */
    write_truth("roughness", t_rough, 1);
    char path[1300];
    path_in(path, sizeof path, ds_dir, "gt/c000_roughness.exr");
    write_image(path, 8, 8, 1, t_rough);
    expect_error("c000_roughness.exr' is 8x8 but the dataset's images are 16x16");
    {   /* and before any rendering (esr eval checks the truth first) */
        struct esr_dataset ds;
        int *idx, n;
        assert_int_equal(esr_dataset_load(ds_dir, &ds), ESR_OK);
        assert_int_equal(esr_select_frames(&ds.phases[ESR_PHASE_TEST_NV], "test_nv", NULL, 0, &idx, &n), ESR_OK);
        assert_int_equal(esr_eval_check_truth(&ds, ESR_PHASE_TEST_NV, idx, n), ESR_ERR);
        assert_non_null(strstr(esr_error_message(), "c000_roughness.exr' is 8x8"));
        esr_error_clear();
        move(ds_dir, "gt/c000_roughness.exr", "aside", 0); /* missing: not an error there */
        assert_int_equal(esr_eval_check_truth(&ds, ESR_PHASE_TEST_NV, idx, n), ESR_OK);
        move(ds_dir, "gt/c000_roughness.exr", "aside", 1);
        free(idx);
        esr_dataset_free(&ds);
    }
    write_truth("roughness", t_rough, 1);
    /* a rendered map of another size */
    path_in(path, sizeof path, render_dir, "c000_off_basecolor.png");
    write_image(path, 8, 4, 3, r_base);
    expect_error("c000_off_basecolor.png' is 8x4");
    write_render("c000_off", "_basecolor.png", r_base, 3);
    /* no truth at all: no "materials" */
    move(ds_dir, "gt/c000_base_color.exr", "aside", 0);
    struct esr_dataset ds;
    struct esr_eval_result res;
    assert_int_equal(eval_fixture(&ds, &res), ESR_OK);
    assert_false(res.materials.has_truth);
    assert_null(esr_materials_json(&res.materials));
    esr_eval_result_free(&res);
    esr_dataset_free(&ds);
    move(ds_dir, "gt/c000_base_color.exr", "aside", 1);
}

static void test_gt_path(void **state)
{
    (void)state;
    char path[1300];
    assert_int_equal(esr_material_gt_path(ds_dir, "c000_on", "roughness", path, sizeof path), 1);
    assert_non_null(strstr(path, "/gt/c000_roughness.exr"));
    assert_int_equal(esr_material_gt_path(ds_dir, "c001_on", "roughness", path, sizeof path), 0);
    assert_int_equal(esr_material_gt_path(ds_dir, "r_000", "roughness", path, sizeof path), 0);
    assert_int_equal(esr_material_gt_path(ds_dir, "c_000", "roughness", path, sizeof path), 0);
    assert_int_equal(esr_material_gt_path(ds_dir, "c000", "roughness", path, sizeof path), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_masking_and_split),    cmocka_unit_test(test_gain_closed_form),
        cmocka_unit_test(test_gains_pooled_over_views), cmocka_unit_test(test_empty_sets),
        cmocka_unit_test(test_bad_maps),             cmocka_unit_test(test_eval_files),
        cmocka_unit_test(test_missing_and_bad_files), cmocka_unit_test(test_gt_path),
    };
    return cmocka_run_group_tests(tests, setup, test_teardown_tmpdir);
}
