/* The ctest fixture tiny_run (test `tiny_fixture_setup`, FIXTURES_SETUP): makes the tiny run
 * that the *_tiny tests share, once per ctest invocation, in tiny_dir (tiny_run.h says what it
 * holds):
 * the dataset (`esr synth --res 24`), the tiny_config training through lts into runs/full, and
 * runs/full's checkpoints resumed through pdra in run_pdra, with what each training reported.
 * What they must reach is checked by the tests that read them (test_train_tiny.c:
 * test_tiny_reaches_psnr, test_train_lights_tiny.c: test_pdra_finds_lights). An earlier fixture
 * is removed first; `complete` is written last. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "io/dir.h"
#include "io/file.h"
#include "test_support.h"
#include "tiny_run.h"

/* The marker that a folder is a tiny-run fixture, which set-up may remove. */
#define TINY_MARKER ".esr-tiny-fixture"

static void tiny_make(void **state)
{
    (void)state;
    char path[4400], cmd[16384], out[4096];
    assert_int_equal(tiny_locate(), 0);
    /* a folder that is not an earlier fixture is not removed */
    snprintf(path, sizeof path, "%s/" TINY_MARKER, tiny_dir);
    if (esr_file_exists(tiny_dir) && !esr_file_exists(path)) {
        snprintf(cmd, sizeof cmd, "rmdir '%s' 2>/dev/null", tiny_dir); /* empty: fine */
        if (system(cmd) != 0)
            fail_msg("%s exists and is not a tiny-run fixture (no %s): not removed", tiny_dir,
                     TINY_MARKER);
    }
    snprintf(cmd, sizeof cmd, "rm -rf '%s' && mkdir -p '%s' && touch '%s'", tiny_dir, tiny_dir,
             path);
    assert_int_equal(system(cmd), 0);

    /* the dataset (the group set-up of the tests before they shared one run) */
    char args[4300];
    snprintf(args, sizeof args, "synth --res 24 --spp 4 --train 16 --test 3 %s", data_dir);
    if (test_run_esr(args, out, sizeof out) != 0)
        fail_msg("esr %s:\n%s", args, out);

    /* the three geometry stages and lts (test_tiny_reaches_psnr checks them) */
    char run[4200];
    snprintf(run, sizeof run, "%s/runs/full", tiny_dir); /* runs/ does not exist yet */
    struct esr_train_opts o;
    struct log_capture lc;
    opts_for(&o, run, ESR_STAGE_LTS, &lc);
    if (esr_train_run(&o) != ESR_OK)
        fail_msg("%s", esr_error_message());
    snprintf(path, sizeof path, "%s/log_full.txt", tiny_dir);
    assert_int_equal(tiny_write_log(path, &lc), 0);

    /* pdra, continuing runs/full's checkpoints (test_pdra_finds_lights checks it) */
    snprintf(run, sizeof run, "%s/run_pdra", tiny_dir);
    snprintf(cmd, sizeof cmd, "mkdir -p '%s' && cp '%s'/runs/full/ckpt_*.bin '%s'/", run, tiny_dir,
             run);
    assert_int_equal(system(cmd), 0);
    opts_for(&o, run, ESR_STAGE_PDRA, &lc);
    o.resume = 1;
    if (esr_train_run(&o) != ESR_OK)
        fail_msg("%s", esr_error_message());
    snprintf(path, sizeof path, "%s/log_pdra.txt", tiny_dir);
    assert_int_equal(tiny_write_log(path, &lc), 0);

    snprintf(path, sizeof path, "%s/complete", tiny_dir);
    assert_int_equal(test_write_file(path, "the tiny run fixture: data, runs/full, run_pdra\n"), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(tiny_make),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
