/* Dataset loading and checking: small fixtures of both layouts written here, every kind of bad
 * input, and the lamp scene when present. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/error.h"
#include "io/dataset.h"
#include "io/dataset_summary.h"
#include "test_support.h"

#define MATRIX "[[1,0,0,0.5],[0,1,0,-0.25],[0,0,1,4],[0,0,0,1]]"
#define LIGHT(mode, inten, mask) "{\"mode\":\"" mode "\",\"intensity\":" inten ",\"color\":[0,0,1],\"mask_path\":\"" mask "\"}"
/* A transforms file of one training frame with one light (mode, intensity). */
#define ONE_LIGHT_FRAME(mode, inten)                                                                   \
    "{\"camera_angle_x\": 0.6911, \"frames\": [{\"file_path\":\"train/r_000\",\"transform_matrix\":" MATRIX \
    ",\"lights\":[" LIGHT(mode, inten, "") "]}]}"

static void write_png(const char *dir, const char *rel, int w, int h, int channels)
{
    char path[1200];
    snprintf(path, sizeof path, "%s/%s", dir, rel);
    struct esr_image img;
    assert_int_equal(esr_image_alloc(&img, w, h, channels), ESR_OK);
    for (size_t i = 0; i < esr_image_count(&img); i++)
        img.data[i] = (float)(i % 7) / 6.0f;
    assert_int_equal(esr_png_write(path, &img, 8), ESR_OK);
    esr_image_free(&img);
}

static void write_text(const char *dir, const char *rel, const char *text)
{
    char path[1200];
    snprintf(path, sizeof path, "%s/%s", dir, rel);
    assert_int_equal(test_write_file(path, text), 0);
}

static void make_dirs(const char *dir, const char *const *subs, int n)
{
    char path[1200];
    for (int i = 0; i < n; i++) {
        snprintf(path, sizeof path, "%s/%s", dir, subs[i]);
        assert_int_equal(mkdir(path, 0755), 0);
    }
}

static const char *esr_train_json = "{\"camera_angle_x\": 0.6911, \"frames\": ["
                                    "{\"file_path\":\"train/r_000\",\"transform_matrix\":" MATRIX
                                    ",\"lights\":[" LIGHT("off", "0.0", "") "]},"
                                    "{\"file_path\":\"train/r_001\",\"transform_matrix\":" MATRIX
                                    ",\"lights\":[" LIGHT("on", "1.0", "") "]}]}";

/* A one-light ESR scene of 4x4 images: train (off, on), test_nv (one frame with EXR and masks). */
static char *make_esr_fixture(const char *name)
{
    static char dir[1100];
    snprintf(dir, sizeof dir, "%s/%s", test_tmpdir, name);
    assert_int_equal(mkdir(dir, 0755), 0);
    static const char *const subs[] = {"transforms", "train", "test_nv", "test_nv/exr", "test_nv/emission", "masks"};
    make_dirs(dir, subs, 6);
    write_text(dir, "transforms/transforms_train.json", esr_train_json);
    write_text(dir, "transforms/transforms_test_nv.json",
               "{\"camera_angle_x\": 0.6911, \"frames\": [{\"file_path\":\"test_nv/c000_on\",\"transform_matrix\":" MATRIX
               ",\"lights\":[" LIGHT("on", "1.0", "masks/nv_c000_on_l0") "]}]}");
    write_text(dir, "scene.json",
               "{\"bounding_box\": {\"min\": [-1,-2,-3], \"max\": [1,2,3]}, \"lights\": [{\"index\": 0, "
               "\"name\": \"shade\", \"emitted_radiance_on\": [8, 6.4, 4.4]}]}");
    write_png(dir, "train/r_000.png", 4, 4, 4);
    write_png(dir, "train/r_001.png", 4, 4, 4);
    write_png(dir, "test_nv/c000_on.png", 4, 4, 4);
    write_png(dir, "test_nv/emission/c000_on.png", 4, 4, 1);
    write_png(dir, "masks/nv_c000_on_l0.png", 4, 4, 1);
    char path[1200];
    snprintf(path, sizeof path, "%s/test_nv/exr/c000_on.exr", dir);
    struct esr_image img;
    assert_int_equal(esr_image_alloc(&img, 4, 4, 4), ESR_OK);
    assert_int_equal(esr_exr_write(path, &img, 1), ESR_OK);
    esr_image_free(&img);
    return dir;
}

struct problems {
    int count;
    char text[8][1024];
};

static void collect(void *user, const char *message)
{
    struct problems *p = user;
    if (p->count < 8)
        snprintf(p->text[p->count], sizeof p->text[0], "%s", message);
    p->count++;
}

static void test_esr_fixture_loads(void **state)
{
    (void)state;
    const char *dir = make_esr_fixture("good");
    struct esr_dataset ds;
    assert_int_equal(esr_dataset_load(dir, &ds), ESR_OK);
    assert_int_equal(ds.layout, ESR_LAYOUT_ESR);
    assert_int_equal(ds.width, 4);
    assert_int_equal(ds.n_lights, 1);
    assert_int_equal(ds.bbox_from_scene, 1);
    /* [-1,-2,-3]..[1,2,3] is widened to the cube of its longest side (the model's voxels are
     * cubes: light areas and shadow-ray offsets are measured in them) */
    assert_int_equal(ds.bbox_made_cubic, 1);
    for (int k = 0; k < 3; k++) {
        assert_float_equal(ds.bbox_min[k], -3.0f, 0.0);
        assert_float_equal(ds.bbox_max[k], 3.0f, 0.0);
    }
    assert_int_equal(ds.n_true_lights, 1); /* scene.json's ground truth for evaluation */
    assert_string_equal(ds.true_lights[0].name, "shade");
    assert_float_equal(ds.true_lights[0].radiance[1], 6.4f, 0.0);
    assert_float_equal(ds.focal, 2.0 / tan(0.5 * 0.6911), 1e-4);
    assert_int_equal(ds.phases[ESR_PHASE_TRAIN].n_frames, 2);
    assert_int_equal(ds.phases[ESR_PHASE_TEST_NV].n_frames, 1);
    assert_int_equal(ds.phases[ESR_PHASE_TEST_NVI].present, 0);
    const struct esr_frame *f = &ds.phases[ESR_PHASE_TEST_NV].frames[0];
    assert_string_equal(f->name, "c000_on");
    assert_int_equal(f->lights_on, 1);
    assert_int_equal(ds.phases[ESR_PHASE_TRAIN].frames[0].lights_on, 0);
    assert_float_equal(f->camera.c2w[1][3], -0.25f, 0.0);
    char path[2200], expect[2200];
    esr_frame_exr_path(&ds, f, path, sizeof path);
    snprintf(expect, sizeof expect, "%s/test_nv/exr/c000_on.exr", dir);
    assert_string_equal(path, expect);
    esr_frame_light_mask_path(&ds, f, 0, path, sizeof path);
    snprintf(expect, sizeof expect, "%s/masks/nv_c000_on_l0.png", dir);
    assert_string_equal(path, expect);
    struct problems probs = {0};
    assert_int_equal(esr_dataset_check(&ds, collect, &probs), 0);
    /* Loading composites on white: c = rgb * a + (1 - a). */
    struct esr_image rgb, alpha, raw;
    assert_int_equal(esr_frame_load_rgb(&ds, f, &rgb, &alpha), ESR_OK);
    esr_frame_image_path(&ds, f, path, sizeof path);
    assert_int_equal(esr_png_read(path, &raw), ESR_OK);
    for (int p = 0; p < 16; p++) {
        float a = raw.data[p * 4 + 3];
        assert_float_equal(alpha.data[p], a, 0.0);
        for (int k = 0; k < 3; k++)
            assert_float_equal(rgb.data[p * 3 + k], raw.data[p * 4 + k] * a + (1.0f - a), 1e-6);
    }
    esr_image_free(&rgb);
    esr_image_free(&alpha);
    esr_image_free(&raw);
    struct esr_dataset_summary s;
    esr_dataset_summarise(&ds, &s);
    assert_int_equal(s.phases[ESR_PHASE_TRAIN].mode_counts[ESR_LIGHT_OFF], 1);
    assert_int_equal(s.phases[ESR_PHASE_TRAIN].mode_counts[ESR_LIGHT_ON], 1);
    assert_float_equal(s.phases[ESR_PHASE_TRAIN].radius_max, sqrt(0.25 + 0.0625 + 16.0), 1e-5);
    esr_dataset_free(&ds);
}

static void test_nerf_synthetic_fixture(void **state)
{
    (void)state;
    char dir[1100];
    snprintf(dir, sizeof dir, "%s/nerf", test_tmpdir);
    assert_int_equal(mkdir(dir, 0755), 0);
    static const char *const subs[] = {"train", "val", "test"};
    make_dirs(dir, subs, 3);
    static const char *const phases[] = {"train", "val", "test"};
    for (int i = 0; i < 3; i++) {
        char rel[64], json[512];
        snprintf(rel, sizeof rel, "transforms_%s.json", phases[i]);
        snprintf(json, sizeof json,
                 "{\"camera_angle_x\": 0.5, \"frames\": [{\"file_path\": \"./%s/r_0\", \"rotation\": 0.1,"
                 " \"transform_matrix\": " MATRIX "}]}",
                 phases[i]);
        write_text(dir, rel, json);
        snprintf(rel, sizeof rel, "%s/r_0.png", phases[i]);
        write_png(dir, rel, 6, 6, 4);
    }
    struct esr_dataset ds;
    assert_int_equal(esr_dataset_load(dir, &ds), ESR_OK);
    assert_int_equal(ds.layout, ESR_LAYOUT_NERF_SYNTHETIC);
    assert_int_equal(ds.n_lights, 0);
    assert_int_equal(ds.width, 6);
    assert_int_equal(ds.bbox_from_scene, 0);
    assert_int_equal(ds.phases[ESR_PHASE_VAL].n_frames, 1);
    assert_int_equal(ds.phases[ESR_PHASE_TEST_NV].n_frames, 1);
    assert_int_equal(esr_frame_mode(&ds, &ds.phases[ESR_PHASE_TRAIN].frames[0]), ESR_LIGHT_OFF);
    struct problems probs = {0};
    assert_int_equal(esr_dataset_check(&ds, collect, &probs), 0);
    esr_dataset_free(&ds);
}

/* Loading must fail with a message naming `file` (relative to dir) and containing `what`. */
static void expect_load_error(const char *dir, const char *file, const char *what)
{
    struct esr_dataset ds;
    esr_error_clear();
    assert_int_equal(esr_dataset_load(dir, &ds), ESR_ERR);
    const char *msg = esr_error_message();
    if (!strstr(msg, file) || !strstr(msg, what))
        fail_msg("message '%s' should name '%s' and say '%s'", msg, file, what);
    esr_error_clear();
}

static void test_bad_json(void **state)
{
    (void)state;
    static const struct {
        const char *name, *json, *what;
    } cases[] = {
        {"malformed", "{\"camera_angle_x\": 0.6911, \"frames\": [", "malformed JSON"},
        {"trailing", "{\"camera_angle_x\": 0.6911, \"frames\": []} x", "malformed JSON (line 1, column 42)"},
        {"no_matrix", "{\"camera_angle_x\": 0.6911, \"frames\": [{\"file_path\":\"train/r_000\",\"lights\":[]}]}",
         "transform_matrix"},
        {"no_angle", "{\"frames\": []}", "camera_angle_x"},
        {"bad_mode", ONE_LIGHT_FRAME("dim", "0.5"), "unknown light mode 'dim'"},
        {"negative_intensity", ONE_LIGHT_FRAME("i_change", "-1"), "intensity -1 is negative"},
        {"on_at_zero", ONE_LIGHT_FRAME("on", "0"), "mode 'on' has intensity 0"},
        {"off_but_lit", ONE_LIGHT_FRAME("off", "1"), "mode 'off' has intensity 1"},
        /* a saturation above 1 would be negative light in a colour edit */
        {"saturation_past_1",
         "{\"camera_angle_x\": 0.6911, \"frames\": [{\"file_path\":\"train/r_000\",\"transform_matrix\":" MATRIX
         ",\"lights\":[{\"mode\":\"c_change\",\"intensity\":1,\"color\":[0.5,1.5,1]}]}]}",
         "light color [0.5, 1.5, 1] is not an HSV triple in [0, 1]"},
        {"inf_matrix",
         "{\"camera_angle_x\": 0.6911, \"frames\": [{\"file_path\":\"train/r_000\",\"transform_matrix\":"
         "[[1,0,0,1e999],[0,1,0,0],[0,0,1,4],[0,0,0,1]],\"lights\":[]}]}",
         "non-finite"},
        {"degenerate",
         "{\"camera_angle_x\": 0.6911, \"frames\": [{\"file_path\":\"train/r_000\",\"transform_matrix\":"
         "[[1,0,0,0],[1,0,0,0],[0,0,1,4],[0,0,0,1]],\"lights\":[]}]}",
         "degenerate"},
        {"light_count",
         "{\"camera_angle_x\": 0.6911, \"frames\": [{\"file_path\":\"train/r_000\",\"transform_matrix\":" MATRIX
         ",\"lights\":[" LIGHT("off", "0", "") "]},{\"file_path\":\"train/r_001\",\"transform_matrix\":" MATRIX
         ",\"lights\":[" LIGHT("on", "1", "") "," LIGHT("on", "1", "") "]}]}",
         "has 2 lights but earlier frames have 1"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        const char *dir = make_esr_fixture(cases[i].name);
        write_text(dir, "transforms/transforms_train.json", cases[i].json);
        expect_load_error(dir, "transforms_train.json", cases[i].what);
    }
    const char *dir = make_esr_fixture("bad_scene_json");
    write_text(dir, "scene.json", "{\"bounding_box\": ");
    expect_load_error(dir, "scene.json", "malformed JSON");
    char empty[1100];
    snprintf(empty, sizeof empty, "%s/empty", test_tmpdir);
    assert_int_equal(mkdir(empty, 0755), 0);
    expect_load_error(empty, empty, "not a dataset");
}

/* The check must report a problem naming `file`. */
static void expect_check_problem(const char *dir, const char *file, int expected)
{
    struct esr_dataset ds;
    assert_int_equal(esr_dataset_load(dir, &ds), ESR_OK);
    struct problems probs = {0};
    assert_int_equal(esr_dataset_check(&ds, collect, &probs), expected);
    int named = 0;
    for (int i = 0; i < probs.count && i < 8; i++)
        named |= strstr(probs.text[i], file) != NULL;
    if (!named)
        fail_msg("no problem names '%s' (first: '%s')", file, probs.count ? probs.text[0] : "");
    esr_dataset_free(&ds);
}

static void test_bad_files(void **state)
{
    (void)state;
    char path[1200];
    const char *dir = make_esr_fixture("missing_image");
    snprintf(path, sizeof path, "%s/train/r_001.png", dir);
    assert_int_equal(unlink(path), 0);
    expect_check_problem(dir, "train/r_001.png", 1);

    dir = make_esr_fixture("truncated_png");
    write_text(dir, "test_nv/c000_on.png", "\x89PNG\r\n\x1a\n");
    expect_check_problem(dir, "test_nv/c000_on.png", 1);

    dir = make_esr_fixture("corrupt_exr");
    write_text(dir, "test_nv/exr/c000_on.exr", "v/1\x01 garbage, not an EXR");
    expect_check_problem(dir, "test_nv/exr/c000_on.exr", 1);

    dir = make_esr_fixture("wrong_size");
    write_png(dir, "train/r_001.png", 5, 4, 4);
    expect_check_problem(dir, "train/r_001.png' is 5x4", 1);

    /* Every problem is reported, not only the first. */
    dir = make_esr_fixture("several");
    write_png(dir, "masks/nv_c000_on_l0.png", 3, 3, 1);
    write_text(dir, "test_nv/emission/c000_on.png", "nonsense");
    snprintf(path, sizeof path, "%s/train/r_001.png", dir);
    assert_int_equal(unlink(path), 0);
    expect_check_problem(dir, "masks/nv_c000_on_l0.png", 3);

    /* An unreadable first image is one of the problems the check lists (the size comes from
     * the training images that decode); a dataset whose training images all fail to decode
     * does not load, naming the first. */
    dir = make_esr_fixture("first_missing");
    snprintf(path, sizeof path, "%s/train/r_000.png", dir);
    assert_int_equal(unlink(path), 0);
    expect_check_problem(dir, "train/r_000.png", 1);
    snprintf(path, sizeof path, "%s/train/r_001.png", dir);
    assert_int_equal(unlink(path), 0);
    expect_load_error(dir, "train/r_000.png", "cannot open");
    /* the size most training images have: an odd-sized first one is the problem, not the rest */
    dir = make_esr_fixture("first_odd_size");
    write_text(dir, "transforms/transforms_train.json",
               "{\"camera_angle_x\": 0.6911, \"frames\": ["
               "{\"file_path\":\"train/r_000\",\"transform_matrix\":" MATRIX
               ",\"lights\":[" LIGHT("off", "0.0", "") "]},"
               "{\"file_path\":\"train/r_001\",\"transform_matrix\":" MATRIX
               ",\"lights\":[" LIGHT("on", "1.0", "") "]},"
               "{\"file_path\":\"train/r_002\",\"transform_matrix\":" MATRIX
               ",\"lights\":[" LIGHT("on", "1.0", "") "]}]}");
    write_png(dir, "train/r_000.png", 7, 5, 4);
    write_png(dir, "train/r_002.png", 4, 4, 4);
    struct esr_dataset odd;
    assert_int_equal(esr_dataset_load(dir, &odd), ESR_OK);
    assert_int_equal(odd.width, 4);
    esr_dataset_free(&odd);
    expect_check_problem(dir, "train/r_000.png", 1);
}

static void test_lamp_scene(void **state)
{
    (void)state;
    const char *scene = test_shared_scene("lamp");
    if (!scene)
        skip();
    struct esr_dataset ds;
    assert_int_equal(esr_dataset_load(scene, &ds), ESR_OK);
    assert_int_equal(ds.layout, ESR_LAYOUT_ESR);
    assert_int_equal(ds.width, 160);
    assert_int_equal(ds.height, 160);
    assert_int_equal(ds.n_lights, 2);
    /* FORMAT.md's formula 0.5 W / tan(0.5 camera_angle_x); Blender 50 mm lens, 36 mm sensor. */
    assert_float_equal(ds.focal, 222.226, 0.01);
    struct esr_dataset_summary s;
    esr_dataset_summarise(&ds, &s);
    assert_int_equal(s.phases[ESR_PHASE_TRAIN].n_frames, 200);
    assert_int_equal(s.phases[ESR_PHASE_TRAIN].mode_counts[ESR_LIGHT_OFF], 100);
    assert_int_equal(s.phases[ESR_PHASE_TRAIN].mode_counts[ESR_LIGHT_ON], 100);
    assert_int_equal(s.phases[ESR_PHASE_TEST_NV].n_frames, 50);
    assert_int_equal(s.phases[ESR_PHASE_TEST_NVI].n_frames, 75);
    assert_int_equal(s.phases[ESR_PHASE_TEST_NVI].mode_counts[ESR_LIGHT_I_CHANGE], 75);
    assert_int_equal(s.phases[ESR_PHASE_TEST_NVC].n_frames, 50);
    assert_int_equal(s.phases[ESR_PHASE_TEST_NVIC].n_frames, 50);
    assert_float_equal(s.phases[ESR_PHASE_TRAIN].radius_min, 4.0f, 1e-3);
    assert_float_equal(s.phases[ESR_PHASE_TRAIN].radius_max, 4.0f, 1e-3);
    /* r_000..r_099 off, r_100..r_199 on (FORMAT.md) */
    assert_int_equal(ds.phases[ESR_PHASE_TRAIN].frames[99].lights_on, 0);
    assert_int_equal(ds.phases[ESR_PHASE_TRAIN].frames[100].lights_on, 1);
    esr_dataset_free(&ds);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_esr_fixture_loads),
        cmocka_unit_test(test_nerf_synthetic_fixture),
        cmocka_unit_test(test_bad_json),
        cmocka_unit_test(test_bad_files),
        cmocka_unit_test(test_lamp_scene),
    };
    return cmocka_run_group_tests(tests, test_setup_tmpdir, test_teardown_tmpdir);
}
