/* A full disk and an output that cannot be written lose nothing (issue #13): the command fails
 * with a clear message and exit status 1, the previous checkpoint stays as it was, and no
 * half-written output or temporary file is left. The disk is "full" through the file-size limit
 * (ulimit -f, with SIGXFSZ ignored so a write fails with EFBIG instead of killing the process). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "io/file.h"
#include "test_support.h"

static char data_dir[4200];

/* Runs esr with args under a file-size limit of blocks x 512 bytes (0: none), output into out. */
static int run_limited(int blocks, const char *args, char *out, size_t n)
{
    char shell[64] = "";
    if (blocks > 0) /* SIGXFSZ ignored (inherited through exec): writes fail with EFBIG */
        snprintf(shell, sizeof shell, "trap '' XFSZ; ulimit -f %d; ", blocks);
    return test_run_esr_after(shell, args, out, n);
}

static int group_setup(void **state)
{
    if (test_setup_tmpdir(state))
        return -1;
    snprintf(data_dir, sizeof data_dir, "%s/data", test_tmpdir);
    return test_synth_small(data_dir) == 0 ? 0 : -1;
}

/* esr synth into a disk that fills up: exit 1 naming the file and EFBIG, nothing left behind. */
static void test_synth_on_full_disk(void **state)
{
    (void)state;
    char dir[4400], args[8800], out[8192];
    snprintf(dir, sizeof dir, "%s/synth_full", test_tmpdir);
    snprintf(args, sizeof args, "synth --res 16 --spp 1 --train 2 --test 1 %s", dir);
    assert_int_equal(run_limited(8, args, out, sizeof out), 1);
    if (!strstr(out, "File too large") || !strstr(out, "cannot write"))
        fail_msg("expected a write error naming EFBIG, got:\n%s", out);
    assert_false(esr_file_exists(dir));
    assert_int_equal(test_count_names(test_tmpdir, "synth_full"), 0); /* no staging folder left */
}

/* A training whose next checkpoint does not fit: exit 1, the previous checkpoint byte for byte
 * as it was, no new checkpoint and no temporary file. */
static void test_train_checkpoint_on_full_disk(void **state)
{
    (void)state;
    char run[4400], args[9000], out[8192], ckpt[4500];
    snprintf(run, sizeof run, "%s/run", test_tmpdir);
    const char *opts = "--set batch_rays=512 --set alphamask.iters=100 --set alphamask.res=16 "
                       "--set coarse.iters=10 --set coarse.res=16";
    snprintf(args, sizeof args, "train %s --out %s --until alphamask %s", data_dir, run, opts);
    if (run_limited(0, args, out, sizeof out) != 0)
        fail_msg("training the alphamask stage failed:\n%s", out);
    snprintf(ckpt, sizeof ckpt, "%s/ckpt_alphamask.bin", run);
    unsigned char *before, *after;
    size_t n_before, n_after;
    assert_int_equal(esr_file_read_all(ckpt, &before, &n_before), 0);
    snprintf(args, sizeof args, "train %s --out %s --resume --until coarse %s", data_dir, run, opts);
    assert_int_equal(run_limited(64, args, out, sizeof out), 1); /* 32 KiB: no checkpoint fits */
    if (!strstr(out, "File too large") || !strstr(out, "ckpt_"))
        fail_msg("expected a checkpoint write error naming EFBIG, got:\n%s", out);
    assert_int_equal(esr_file_read_all(ckpt, &after, &n_after), 0);
    assert_int_equal(n_after, n_before);
    assert_memory_equal(after, before, n_before);
    free(before);
    free(after);
    snprintf(ckpt, sizeof ckpt, "%s/ckpt_coarse.bin", run);
    assert_false(esr_file_exists(ckpt));
    assert_int_equal(test_count_names(run, ".tmp-"), 0);
}

/* Output into a folder that cannot be created (its parent is a regular file; a read-only folder
 * is no test as root, which writes anyway): exit 1 naming the path, nothing written. */
static void test_unwritable_output(void **state)
{
    (void)state;
    char file[4400], dir[4500], args[9200], out[8192];
    snprintf(file, sizeof file, "%s/plain_file", test_tmpdir);
    assert_int_equal(test_write_file(file, "not a folder\n"), 0);
    snprintf(dir, sizeof dir, "%s/sub", file);
    snprintf(args, sizeof args, "synth --res 16 --spp 1 --train 2 --test 1 %s", dir);
    assert_int_equal(run_limited(0, args, out, sizeof out), 1);
    if (!strstr(out, "plain_file"))
        fail_msg("expected the path in the message, got:\n%s", out);
    snprintf(args, sizeof args, "train %s --out %s --until alphamask --set alphamask.iters=5",
             data_dir, dir);
    assert_int_equal(run_limited(0, args, out, sizeof out), 1);
    if (!strstr(out, "plain_file"))
        fail_msg("expected the path in the message, got:\n%s", out);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_synth_on_full_disk),
        cmocka_unit_test(test_train_checkpoint_on_full_disk),
        cmocka_unit_test(test_unwritable_output),
    };
    return cmocka_run_group_tests(tests, group_setup, test_teardown_tmpdir);
}
