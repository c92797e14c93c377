/* Memory limits (issue #13): a run refuses, before it runs out, what does not fit (core/limits.h):
 * the training rays before any image is decoded, each stage's model before it is allocated, each
 * stage's workspace before it is touched; ESR_MEMORY_LIMIT sets the budget. (A PNG/EXR header
 * that claims 100000 x 100000 pixels: test_io_image_limits.) */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <string.h>

#include "core/error.h"
#include "core/limits.h"
#include "io/file.h"
#include "test_support.h"

#if defined(__SANITIZE_ADDRESS__)
#define SANITIZED 1 /* the sanitizers replace malloc: workspaces cannot be measured */
#else
#define SANITIZED 0
#endif


static void test_parse_size(void **state)
{
    (void)state;
    const struct {
        const char *text;
        size_t bytes;
    } rows[] = {
        {"300000000", 300000000}, {"512K", 512u << 10}, {"512M", (size_t)512 << 20},
        {"2G", (size_t)2 << 30},   {"1.5G", (size_t)3 << 29}, {"1T", (size_t)1 << 40},
        {"0", 0}, {"-1M", 0}, {"12x", 0}, {"", 0}, {"G", 0}, {"1MB", 0}, {"nan", 0}, {"1e30T", 0},
    };
    for (size_t i = 0; i < sizeof rows / sizeof rows[0]; i++)
        if (esr_limits_parse_size(rows[i].text) != rows[i].bytes)
            fail_msg("'%s' -> %zu, expected %zu", rows[i].text, esr_limits_parse_size(rows[i].text),
                     rows[i].bytes);
}

/* With a budget, held + need must fit; the message names what and the figures. */
static void test_check_against_a_budget(void **state)
{
    (void)state;
    const struct esr_limits saved = *esr_limits();
    struct esr_limits l = saved;
    l.memory_bytes = 100 << 20;
    esr_limits_set(&l);
    assert_int_equal(esr_limits_check_memory(40 << 20, 60 << 20, "x"), 0);
    assert_int_not_equal(esr_limits_check_memory(40 << 20, (60 << 20) + 1, "the thing"), 0);
    assert_non_null(strstr(esr_error_message(), "the thing needs 60.0 MiB"));
    assert_non_null(strstr(esr_error_message(), "memory limit of 100.0 MiB"));
    esr_error_clear();
    assert_int_not_equal(esr_limits_check_memory(SIZE_MAX, 1, "x"), 0); /* no wrap-around */
    esr_error_clear();
    esr_limits_set(&saved);
    /* without one, the system's available memory: a petabyte does not fit */
    assert_int_not_equal(esr_limits_check_memory(0, (size_t)1 << 50, "a petabyte"), 0);
    assert_non_null(strstr(esr_error_message(), "of memory available"));
    esr_error_clear();
}

static const char *TRAIN_OPTS = "--until coarse --allow-poor --set batch_rays=512 --set alphamask.res=16 "
                                "--set alphamask.iters=100 --set coarse.res=32 --set coarse.iters=5";

/* Trains into run under ESR_MEMORY_LIMIT=limit; returns the exit status, output in out. */
static int train_limited(const char *limit, const char *run, int resume, char *out, size_t n)
{
    char shell[64], args[9000];
    snprintf(shell, sizeof shell, "ESR_MEMORY_LIMIT=%s ", limit);
    snprintf(args, sizeof args, "train %s --out %s %s %s", test_data_dir, run, resume ? "--resume" : "", TRAIN_OPTS);
    return test_run_esr_after(shell, args, out, n);
}

static void expect_refusal(int status, const char *out, const char *what)
{
    assert_int_equal(status, 1);
    if (!strstr(out, what) || !strstr(out, "memory limit"))
        fail_msg("expected a refusal naming '%s', got:\n%s", what, out);
}

/* This small run needs (measured) 0.1 MiB of rays, then 0.4 + 3.2 MiB (alphamask model and
 * workspace), then 6.6 + 15.5 MiB (coarse): each budget below stops it at the next piece. */
static void test_training_refuses_what_does_not_fit(void **state)
{
    (void)state;
    char run[4400], ckpt[4500], out[16384];
    snprintf(run, sizeof run, "%s/run_rays", test_tmpdir);
    expect_refusal(train_limited("50K", run, 0, out, sizeof out), out, "the training rays of dataset");
    snprintf(ckpt, sizeof ckpt, "%s/ckpt_alphamask.bin", run);
    assert_false(esr_file_exists(ckpt));

    snprintf(run, sizeof run, "%s/run_model", test_tmpdir);
    expect_refusal(train_limited("5M", run, 0, out, sizeof out), out, "the coarse stage's model");
    snprintf(ckpt, sizeof ckpt, "%s/ckpt_alphamask.bin", run);
    assert_true(esr_file_exists(ckpt)); /* the stage that fitted finished */
    snprintf(ckpt, sizeof ckpt, "%s/ckpt_coarse.bin", run);
    assert_false(esr_file_exists(ckpt));
    if (!SANITIZED) {
        expect_refusal(train_limited("12M", run, 1, out, sizeof out), out,
                       "the coarse stage's training workspace");
        assert_false(esr_file_exists(ckpt));
    }
    /* with room, the same run resumes and finishes */
    if (train_limited("64M", run, 1, out, sizeof out) != 0)
        fail_msg("training within 64M failed:\n%s", out);
    assert_true(esr_file_exists(ckpt));
    if (!SANITIZED && !strstr(out, "[coarse] memory: training rays"))
        fail_msg("expected the coarse stage's memory line, got:\n%s", out);
    assert_int_equal(test_run_esr_after("ESR_MEMORY_LIMIT=lots ", "info /nonexistent", out, sizeof out), 1);
    assert_non_null(strstr(out, "ESR_MEMORY_LIMIT='lots' is not a size"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_parse_size),
        cmocka_unit_test(test_check_against_a_budget),
        cmocka_unit_test(test_training_refuses_what_does_not_fit),
    };
    return cmocka_run_group_tests(tests, test_setup_small_data, test_teardown_tmpdir);
}
