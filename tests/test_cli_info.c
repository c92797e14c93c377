/* `esr info`: summary, problems and exit status, JSON and contact sheet outputs. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "core/error.h"
#include "io/file.h"
#include "io/image.h"
#include "test_support.h"

static char out[1 << 16];

static void test_usage_errors(void **state)
{
    (void)state;
    assert_int_equal(test_run_esr("info", out, sizeof out), 1);
    assert_non_null(strstr(out, "missing DATA_DIR"));
    assert_int_equal(test_run_esr("info --help", out, sizeof out), 0);
    assert_non_null(strstr(out, "--contact-sheet"));
    assert_int_equal(test_run_esr("info /nonexistent-dataset", out, sizeof out), 1);
    assert_non_null(strstr(out, "/nonexistent-dataset"));
}

/* A NeRF-synthetic dataset with one broken image: info prints it and exits 1. */
static void test_problem_exit(void **state)
{
    (void)state;
    char dir[1100], path[1300], args[3000];
    snprintf(dir, sizeof dir, "%s/ds", test_tmpdir);
    assert_int_equal(mkdir(dir, 0755), 0);
    snprintf(path, sizeof path, "%s/transforms_train.json", dir);
    assert_int_equal(test_write_file(path, "{\"camera_angle_x\": 0.5, \"frames\": ["
                                           "{\"file_path\": \"a\", \"transform_matrix\": "
                                           "[[1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]},"
                                           "{\"file_path\": \"b\", \"transform_matrix\": "
                                           "[[1,0,0,0],[0,1,0,0],[0,0,1,3],[0,0,0,1]]}]}"),
                     0);
    struct esr_image img;
    assert_int_equal(esr_image_alloc(&img, 8, 8, 4), ESR_OK);
    snprintf(path, sizeof path, "%s/a.png", dir);
    assert_int_equal(esr_png_write(path, &img, 8), ESR_OK);
    esr_image_free(&img);
    snprintf(path, sizeof path, "%s/b.png", dir);
    assert_int_equal(test_write_file(path, "broken"), 0);
    snprintf(args, sizeof args, "info '%s' --json '%s/info.json'", dir, test_tmpdir);
    assert_int_equal(test_run_esr(args, out, sizeof out), 1);
    assert_non_null(strstr(out, "nerf-synthetic"));
    assert_non_null(strstr(out, "1 problem"));
    assert_non_null(strstr(out, "b.png"));
    snprintf(path, sizeof path, "%s/info.json", test_tmpdir);
    unsigned char *json;
    size_t size;
    assert_int_equal(esr_file_read_all(path, &json, &size), ESR_OK);
    assert_non_null(strstr((char *)json, "\"problems\""));
    assert_non_null(strstr((char *)json, "b.png"));
    free(json);
}

static void test_lamp(void **state)
{
    (void)state;
    const char *scene = test_shared_scene("lamp");
    if (!scene)
        skip();
    char args[3000], path[1200];
    snprintf(args, sizeof args, "info '%s' --contact-sheet '%s/sheet.png'", scene, test_tmpdir);
    int rc = test_run_esr(args, out, sizeof out);
    if (rc != 0)
        fail_msg("esr info exited %d:\n%s", rc, out);
    static const char *const expected[] = {"images    160 x 160", "lights    2", "focal     222.23 px",
                                           "off 100, on 100", "off 25, on 25", "i_change 75", "c_change 50",
                                           "ic_change 50", "no problems"};
    for (size_t i = 0; i < sizeof expected / sizeof expected[0]; i++)
        if (!strstr(out, expected[i]))
            fail_msg("'%s' missing from:\n%s", expected[i], out);
    snprintf(path, sizeof path, "%s/sheet.png", test_tmpdir);
    struct esr_image sheet;
    assert_int_equal(esr_png_read(path, &sheet), ESR_OK);
    assert_int_equal(sheet.channels, 3);
    assert_int_equal(sheet.width, 8 * (96 + 4) + 4);
    esr_image_free(&sheet);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_usage_errors),
        cmocka_unit_test(test_problem_exit),
        cmocka_unit_test(test_lamp),
    };
    return cmocka_run_group_tests(tests, test_setup_tmpdir, test_teardown_tmpdir);
}
