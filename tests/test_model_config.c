/* Table-driven training configuration: presets, --set parsing and bounds, JSON files (dotted and
 * nested keys, preset key, refusal of unknown keys and out-of-range values), round trip through
 * config.json, and the CLI's refusal of a bad config. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <string.h>

#include "core/error.h"
#include "test_support.h"
#include "model/config.h"

static void expect_fail(int rc, const char *needle)
{
    assert_int_equal(rc, ESR_ERR);
    if (!strstr(esr_error_message(), needle))
        fail_msg("error '%s' does not mention '%s'", esr_error_message(), needle);
    esr_error_clear();
}

static void test_presets(void **state)
{
    (void)state;
    struct esr_train_config f, p;
    esr_config_defaults(&f, ESR_PRESET_FAST);
    esr_config_defaults(&p, ESR_PRESET_PAPER);
    assert_int_equal(esr_config_validate(&f), 0);
    assert_int_equal(esr_config_validate(&p), 0);
    /* METHOD.md sizes in the paper preset */
    assert_int_equal(p.coarse.res, 96);
    assert_int_equal(p.coarse.iters, 10000);
    assert_int_equal(p.fine.res, 160);
    assert_int_equal(p.fine.iters, 20000);
    assert_int_equal(p.fine.mlp_width, 192);
    assert_float_equal(p.coarse.s_div, 50.0f, 0);
    assert_float_equal(p.fine.s_div, 100.0f, 0);
    assert_true(f.fine.iters < p.fine.iters);
    enum esr_preset e;
    assert_int_equal(esr_preset_from_name("paper", &e), 0);
    assert_int_equal(e, ESR_PRESET_PAPER);
    expect_fail(esr_preset_from_name("slow", &e), "unknown preset 'slow'");
}

static void test_set(void **state)
{
    (void)state;
    struct esr_train_config c;
    esr_config_defaults(&c, ESR_PRESET_FAST);
    assert_int_equal(esr_config_set(&c, "fine.iters=200"), 0);
    assert_int_equal(c.fine.iters, 200);
    assert_int_equal(esr_config_set(&c, "lambda_tau=0.25"), 0);
    assert_float_equal(c.lambda_tau, 0.25f, 0);
    expect_fail(esr_config_set(&c, "fine.itres=200"), "unknown option 'fine.itres'");
    expect_fail(esr_config_set(&c, "fine.iters=2.5"), "must be an integer");
    expect_fail(esr_config_set(&c, "fine.res=4"), "out of range [8, 512]");
    expect_fail(esr_config_set(&c, "batch_rays=abc"), "not a number");
    expect_fail(esr_config_set(&c, "batch_rays"), "expected key=value");
    expect_fail(esr_config_set(&c, "smooth_ksize=4"), "odd");
    assert_int_equal(c.fine.iters, 200); /* failed sets change nothing */
}

static void test_json_files(void **state)
{
    (void)state;
    char path[4200], out[4200];
    struct esr_train_config c, back;
    snprintf(path, sizeof path, "%s/cfg.json", test_tmpdir);
    assert_int_equal(test_write_file(path, "{\"preset\": \"paper\", \"fine\": {\"iters\": 300},"
                                           " \"coarse.res\": 64, \"seed\": 7}"),
                     0);
    esr_config_defaults(&c, ESR_PRESET_FAST);
    assert_int_equal(esr_config_load_json(&c, path), 0);
    assert_int_equal(c.preset, ESR_PRESET_PAPER);
    assert_int_equal(c.fine.iters, 300);
    assert_int_equal(c.coarse.res, 64);
    assert_int_equal(c.seed, 7);
    assert_int_equal(c.fine.mlp_width, 192); /* from the preset */
    /* round trip through the resolved config.json */
    snprintf(out, sizeof out, "%s/resolved.json", test_tmpdir);
    assert_int_equal(esr_config_write_json(&c, out), 0);
    esr_config_defaults(&back, ESR_PRESET_FAST);
    assert_int_equal(esr_config_load_json(&back, out), 0);
    assert_memory_equal(&c, &back, sizeof c);
    /* refusals name the file and the key */
    assert_int_equal(test_write_file(path, "{\"fine\": {\"iterz\": 3}}"), 0);
    expect_fail(esr_config_load_json(&c, path), "unknown option 'fine.iterz'");
    assert_int_equal(test_write_file(path, "{\"batch_rays\": 1e9}"), 0);
    expect_fail(esr_config_load_json(&c, path), "cfg.json: option 'batch_rays' = 1e+09 is out of range");
    assert_int_equal(test_write_file(path, "{\"batch_rays\": \"many\"}"), 0);
    expect_fail(esr_config_load_json(&c, path), "must be a number");
    assert_int_equal(test_write_file(path, "[1, 2]"), 0);
    expect_fail(esr_config_load_json(&c, path), "not a JSON object");
    assert_int_equal(test_write_file(path, "{\"preset\": \"huge\"}"), 0);
    expect_fail(esr_config_load_json(&c, path), "unknown preset 'huge'");
}

static void test_cli_refuses_bad_config(void **state)
{
    (void)state;
    char path[4200], args[8600], out[4096];
    snprintf(path, sizeof path, "%s/bad.json", test_tmpdir);
    assert_int_equal(test_write_file(path, "{\"coarse\": {\"lr_grid\": -1}}"), 0);
    snprintf(args, sizeof args, "train %s/none --out %s/run --config %s", test_tmpdir, test_tmpdir,
             path);
    assert_int_equal(test_run_esr(args, out, sizeof out), 1);
    assert_non_null(strstr(out, "option 'coarse.lr_grid' = -1 is out of range"));
    assert_int_equal(test_run_esr("train --help", out, sizeof out), 0);
    assert_non_null(strstr(out, "fine.iters"));
    assert_non_null(strstr(out, "--resume"));
    assert_int_equal(test_run_esr("train /nonexistent --out /tmp/x --set nope=1", out, sizeof out), 1);
    assert_non_null(strstr(out, "unknown option 'nope'"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_presets),
        cmocka_unit_test(test_set),
        cmocka_unit_test(test_json_files),
        cmocka_unit_test(test_cli_refuses_bad_config),
    };
    return cmocka_run_group_tests(tests, test_setup_tmpdir, test_teardown_tmpdir);
}
