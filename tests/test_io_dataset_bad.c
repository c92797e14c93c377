/* Bad datasets, one row each: a small valid ESR-layout dataset (two 4x4 RGBA train frames) with
 * one thing broken, and where the problem must show (loading, or the file check of `esr info`)
 * with the message it must give; or that the variation is accepted (16-bit PNGs). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/error.h"
#include "io/dataset.h"
#include "test_support.h"

#define MATRIX "[[1,0,0,0.5],[0,1,0,-0.25],[0,0,1,4],[0,0,0,1]]"
#define LIGHT(mode, mask) "{\"mode\":\"" mode "\",\"intensity\":1,\"color\":[0,0,1],\"mask_path\":\"" mask "\"}"
#define FRAME(path, matrix, mask) "{\"file_path\":\"" path "\",\"transform_matrix\":" matrix ",\"lights\":[" LIGHT("on", mask) "]}"
#define TRANSFORMS(angle, frames) "{\"camera_angle_x\": " angle ", \"frames\": [" frames "]}"
#define GOOD_FRAMES FRAME("train/r_000", MATRIX, "") "," FRAME("train/r_001", MATRIX, "")

enum where { AT_LOAD, AT_CHECK, ACCEPTED };

struct row {
    const char *name;
    const char *train_json; /* transforms_train.json; NULL: the good one */
    void (*setup)(const char *dir); /* further changes; NULL: none */
    enum where where;
    const char *file, *what; /* the message names file and says what */
};

static void write_png(const char *dir, const char *rel, int w, int h, int channels, int bits)
{
    char path[1200];
    snprintf(path, sizeof path, "%s/%s", dir, rel);
    struct esr_image img;
    assert_int_equal(esr_image_alloc(&img, w, h, channels), ESR_OK);
    for (size_t i = 0; i < esr_image_count(&img); i++)
        img.data[i] = (float)(i % 5) / 4.0f;
    assert_int_equal(esr_png_write(path, &img, bits), ESR_OK);
    esr_image_free(&img);
}

static void write_text(const char *dir, const char *rel, const char *text)
{
    char path[1200];
    snprintf(path, sizeof path, "%s/%s", dir, rel);
    assert_int_equal(test_write_file(path, text), 0);
}

static void wider_second(const char *dir) { write_png(dir, "train/r_001.png", 6, 4, 4, 8); }
static void sixteen_bit(const char *dir) { write_png(dir, "train/r_001.png", 4, 4, 4, 16); }
static void grey(const char *dir) { write_png(dir, "train/r_001.png", 4, 4, 1, 8); }
static void grey_alpha(const char *dir) { write_png(dir, "train/r_001.png", 4, 4, 2, 8); }

static void link_to_itself(const char *dir, const char *rel)
{
    char path[1200];
    snprintf(path, sizeof path, "%s/%s", dir, rel);
    assert_int_equal(unlink(path), 0);
    const char *base = strrchr(rel, '/') + 1;
    assert_int_equal(symlink(base, path), 0);
}

static void loop_first(const char *dir) { link_to_itself(dir, "train/r_000.png"); }
static void loop_second(const char *dir) { link_to_itself(dir, "train/r_001.png"); }

static void empty_test_phase(const char *dir)
{
    write_text(dir, "transforms/transforms_test_nv.json", TRANSFORMS("0.6911", ""));
}

static const struct row rows[] = {
    {"nan_matrix", TRANSFORMS("0.6911", FRAME("train/r_000", "[[NaN,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]", "")),
     NULL, AT_LOAD, "transforms_train.json", "malformed JSON"},
    {"inf_matrix", TRANSFORMS("0.6911", FRAME("train/r_000", "[[1,0,0,1e999],[0,1,0,0],[0,0,1,4],[0,0,0,1]]", "")),
     NULL, AT_LOAD, "transforms_train.json', frame 0", "non-finite"},
    {"scaled_matrix", TRANSFORMS("0.6911", FRAME("train/r_000", "[[2,0,0,0],[0,2,0,0],[0,0,2,4],[0,0,0,1]]", "")),
     NULL, AT_LOAD, "transforms_train.json', frame 0", "not a rigid camera"},
    {"sheared_matrix",
     TRANSFORMS("0.6911", FRAME("train/r_000", "[[1,0.5,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]", "")), NULL, AT_LOAD,
     "transforms_train.json', frame 0", "not a rigid camera"},
    {"mirrored_matrix",
     TRANSFORMS("0.6911", FRAME("train/r_000", "[[1,0,0,0],[0,1,0,0],[0,0,-1,4],[0,0,0,1]]", "")), NULL, AT_LOAD,
     "transforms_train.json', frame 0", "not a rigid camera"},
    {"degenerate_matrix",
     TRANSFORMS("0.6911", FRAME("train/r_000", "[[1,0,0,0],[1,0,0,0],[0,0,1,4],[0,0,0,1]]", "")), NULL, AT_LOAD,
     "transforms_train.json', frame 0", "degenerate"},
    {"zero_fov", TRANSFORMS("0", GOOD_FRAMES), NULL, AT_LOAD, "transforms_train.json",
     "'camera_angle_x' = 0 is not a field of view"},
    {"negative_fov", TRANSFORMS("-0.5", GOOD_FRAMES), NULL, AT_LOAD, "transforms_train.json",
     "'camera_angle_x' = -0.5 is not a field of view"},
    {"mixed_sizes", NULL, wider_second, AT_CHECK, "train/r_001.png", "is 6x4, the dataset's images are 4x4"},
    {"sixteen_bit_png", NULL, sixteen_bit, ACCEPTED, NULL, NULL},
    {"grey_png", NULL, grey, AT_CHECK, "train/r_001.png", "is not an RGB(A) image (1 channels)"},
    {"grey_alpha_png", NULL, grey_alpha, AT_CHECK, "train/r_001.png", "is not an RGB(A) image (2 channels)"},
    {"duplicate_frames", TRANSFORMS("0.6911", GOOD_FRAMES "," FRAME("train/r_000", MATRIX, "")), NULL, AT_LOAD,
     "transforms_train.json', frame 2", "repeats frame 0 ('file_path' 'train/r_000')"},
    {"escaping_path", TRANSFORMS("0.6911", FRAME("../../etc/passwd", MATRIX, "")), NULL, AT_LOAD,
     "transforms_train.json', frame 0", "'file_path' = '../../etc/passwd' leaves the dataset folder"},
    {"escaping_inner_path", TRANSFORMS("0.6911", FRAME("train/../../../etc/passwd", MATRIX, "")), NULL, AT_LOAD,
     "transforms_train.json', frame 0", "leaves the dataset folder"},
    {"absolute_path", TRANSFORMS("0.6911", FRAME("/etc/passwd", MATRIX, "")), NULL, AT_LOAD,
     "transforms_train.json', frame 0", "'file_path' = '/etc/passwd' leaves the dataset folder"},
    {"escaping_mask", TRANSFORMS("0.6911", FRAME("train/r_000", MATRIX, "../masks/x")), NULL, AT_LOAD,
     "transforms_train.json', frame 0", "'mask_path' = '../masks/x' leaves the dataset folder"},
    {"symlink_loop_first", NULL, loop_first, AT_CHECK, "train/r_000.png", "Too many levels of symbolic links"},
    {"symlink_loop", NULL, loop_second, AT_CHECK, "train/r_001.png", "Too many levels of symbolic links"},
    {"empty_train_phase", TRANSFORMS("0.6911", ""), NULL, AT_LOAD, "transforms_train.json",
     "'frames' must be a non-empty array"},
    {"empty_test_phase", NULL, empty_test_phase, AT_LOAD, "transforms_test_nv.json",
     "'frames' must be a non-empty array"},
    {"empty_file", "", NULL, AT_LOAD, "transforms_train.json", "is empty"},
};

static const char *make_dataset(const struct row *r)
{
    static char dir[1100];
    snprintf(dir, sizeof dir, "%s/%s", test_tmpdir, r->name);
    assert_int_equal(mkdir(dir, 0755), 0);
    char path[1200];
    snprintf(path, sizeof path, "%s/transforms", dir);
    assert_int_equal(mkdir(path, 0755), 0);
    snprintf(path, sizeof path, "%s/train", dir);
    assert_int_equal(mkdir(path, 0755), 0);
    write_text(dir, "transforms/transforms_train.json", r->train_json ? r->train_json : TRANSFORMS("0.6911", GOOD_FRAMES));
    write_png(dir, "train/r_000.png", 4, 4, 4, 8);
    write_png(dir, "train/r_001.png", 4, 4, 4, 8);
    if (r->setup)
        r->setup(dir);
    return dir;
}

static void problem(void *user, const char *message)
{
    const struct row *r = *(const struct row **)user;
    if (strstr(message, r->file) && strstr(message, r->what))
        *(const struct row **)user = NULL; /* found */
}

static void check_row(const struct row *r)
{
    const char *dir = make_dataset(r);
    struct esr_dataset ds;
    esr_error_clear();
    int loaded = esr_dataset_load(dir, &ds);
    if (r->where == AT_LOAD) {
        const char *msg = esr_error_message();
        if (loaded == ESR_OK || !strstr(msg, r->file) || !strstr(msg, r->what))
            fail_msg("%s: loading should fail naming '%s' and saying '%s'; got '%s'", r->name, r->file, r->what,
                     loaded == ESR_OK ? "(loaded)" : msg);
        esr_error_clear();
        return;
    }
    if (loaded != ESR_OK)
        fail_msg("%s: should load, got '%s'", r->name, esr_error_message());
    const struct row *pending = r;
    int n = esr_dataset_check(&ds, problem, &pending);
    if (r->where == ACCEPTED) {
        assert_int_equal(n, 0);
        const struct esr_phase *ph = &ds.phases[ESR_PHASE_TRAIN];
        for (int i = 0; i < ph->n_frames; i++) {
            struct esr_image rgb;
            assert_int_equal(esr_frame_load_rgb(&ds, &ph->frames[i], &rgb, NULL), ESR_OK);
            esr_image_free(&rgb);
        }
    } else if (pending) {
        fail_msg("%s: the check should report '%s' saying '%s' (%d problems)", r->name, r->file, r->what, n);
    }
    esr_dataset_free(&ds);
}

static void test_bad_datasets(void **state)
{
    (void)state;
    for (size_t i = 0; i < sizeof rows / sizeof rows[0]; i++)
        check_row(&rows[i]);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_bad_datasets)};
    return cmocka_run_group_tests(tests, test_setup_tmpdir, test_teardown_tmpdir);
}
