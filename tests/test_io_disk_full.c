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
#include <unistd.h>

#include "io/file.h"
#include "test_support.h"

static const char *const TRAIN_OPTS = "--allow-poor --set batch_rays=512 --set alphamask.iters=100 --set alphamask.res=16 "
                                      "--set coarse.iters=10 --set coarse.res=16";

/* Runs esr with args under a file-size limit of blocks x 512 bytes (0: none), output into out. */
static int run_limited(int blocks, const char *args, char *out, size_t n)
{
    char shell[64] = "";
    if (blocks > 0) /* SIGXFSZ ignored (inherited through exec): writes fail with EFBIG */
        snprintf(shell, sizeof shell, "trap '' XFSZ; ulimit -f %d; ", blocks);
    return test_run_esr_after(shell, args, out, n);
}

/* path holds exactly the bytes `before` (n) held, read earlier; frees before. */
static void assert_unchanged(const char *path, unsigned char *before, size_t n)
{
    unsigned char *after;
    size_t n_after;
    assert_int_equal(esr_file_read_all(path, &after, &n_after), 0);
    assert_int_equal(n_after, n);
    assert_memory_equal(after, before, n);
    free(before);
    free(after);
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
    const char *opts = TRAIN_OPTS;
    snprintf(args, sizeof args, "train %s --out %s --until alphamask %s", test_data_dir, run, opts);
    if (run_limited(0, args, out, sizeof out) != 0)
        fail_msg("training the alphamask stage failed:\n%s", out);
    snprintf(ckpt, sizeof ckpt, "%s/ckpt_alphamask.bin", run);
    unsigned char *before;
    size_t n_before;
    assert_int_equal(esr_file_read_all(ckpt, &before, &n_before), 0);
    snprintf(args, sizeof args, "train %s --out %s --resume --until coarse %s", test_data_dir, run, opts);
    assert_int_equal(run_limited(64, args, out, sizeof out), 1); /* 32 KiB: no checkpoint fits */
    if (!strstr(out, "File too large") || !strstr(out, "ckpt_"))
        fail_msg("expected a checkpoint write error naming EFBIG, got:\n%s", out);
    assert_unchanged(ckpt, before, n_before);
    snprintf(ckpt, sizeof ckpt, "%s/ckpt_coarse.bin", run);
    assert_false(esr_file_exists(ckpt));
    assert_int_equal(test_count_names(run, ".tmp-"), 0);
    /* RUN/log says why the run stopped, not only the terminal */
    unsigned char *log;
    size_t n_log;
    snprintf(ckpt, sizeof ckpt, "%s/log", run);
    assert_int_equal(esr_file_read_all(ckpt, &log, &n_log), 0); /* NUL-terminated */
    if (!strstr((char *)log, "esr train: error:") || !strstr((char *)log, "File too large"))
        fail_msg("RUN/log does not say why training stopped:\n%s", (char *)log);
    free(log);
}

/* esr export of a trained run onto a full disk: exit 1 naming EFBIG, no mesh and no temporary
 * file; with room, the same export works. */
static void test_export_on_full_disk(void **state)
{
    (void)state;
    char run[4400], dir[4400], mesh[4500], args[9800], out[8192];
    snprintf(run, sizeof run, "%s/run", test_tmpdir); /* the run of the test above, to coarse */
    snprintf(args, sizeof args, "train %s --out %s --resume --until coarse %s", test_data_dir, run, TRAIN_OPTS);
    if (run_limited(0, args, out, sizeof out) != 0)
        fail_msg("training the coarse stage failed:\n%s", out);
    snprintf(dir, sizeof dir, "%s/export", test_tmpdir);
    snprintf(mesh, sizeof mesh, "%s/mesh.ply", dir);
    snprintf(args, sizeof args, "export %s --mesh %s --res 32", run, mesh);
    char mk[4500];
    snprintf(mk, sizeof mk, "mkdir -p '%s' && ", dir);
    char shell[4700];
    snprintf(shell, sizeof shell, "%strap '' XFSZ; ulimit -f 2; ", mk);
    assert_int_equal(test_run_esr_after(shell, args, out, sizeof out), 1);
    if (!strstr(out, "File too large") || !strstr(out, "mesh.ply"))
        fail_msg("expected a write error naming the mesh and EFBIG, got:\n%s", out);
    assert_false(esr_file_exists(mesh));
    assert_int_equal(test_count_names(dir, ".tmp-"), 0);
    assert_int_equal(run_limited(0, args, out, sizeof out), 0);
    assert_true(esr_file_exists(mesh));
}

/* Runs esr as an unprivileged user (root writes into read-only folders anyway): setpriv from
 * util-linux drops to nobody. Returns -2 when that is not possible here (then the caller skips). */
static int run_unprivileged(const char *args, char *out, size_t n)
{
    if (geteuid() != 0)
        return test_run_esr_after("", args, out, n);
    if (system("command -v setpriv >/dev/null 2>&1") != 0)
        return -2;
    return test_run_esr_after("setpriv --reuid=65534 --regid=65534 --clear-groups ", args, out, n);
}

/* Outputs into read-only folders: a new run, a resumed run whose folder became read-only, an
 * export: exit 1 naming the path and the permission, the earlier checkpoint intact. */
static void test_read_only_folders(void **state)
{
    (void)state;
    char ro[4300], run[4400], args[9800], out[8192], ckpt[4500], cmd[32768];
    unsigned char *before;
    size_t n_before;
    snprintf(ro, sizeof ro, "%s/read_only", test_tmpdir);
    snprintf(run, sizeof run, "%s/run", ro);
    /* readable by everyone, writable by nobody but root: the test's folder, the data, a run */
    snprintf(cmd, sizeof cmd, "chmod 755 '%s' && mkdir -p '%s' && cp -r '%s/run/.' '%s/' && "
             "chmod -R a+rX '%s' '%s' && chmod -R a-w '%s'", test_tmpdir, run, test_tmpdir, run,
             test_data_dir, ro, ro);
    assert_int_equal(system(cmd), 0);
    snprintf(args, sizeof args, "train %s --out %s/new_run --until alphamask --set alphamask.iters=5", test_data_dir, ro);
    int rc = run_unprivileged(args, out, sizeof out);
    if (rc == -2) {
        print_message("skipped: running as root and setpriv is missing, so no folder is read-only\n");
        return;
    }
    assert_int_equal(rc, 1);
    if (!strstr(out, "new_run") || !strstr(out, "Permission denied"))
        fail_msg("expected the folder and EACCES in the message, got:\n%s", out);

    snprintf(ckpt, sizeof ckpt, "%s/ckpt_coarse.bin", run);
    assert_int_equal(esr_file_read_all(ckpt, &before, &n_before), 0);
    snprintf(args, sizeof args, "train %s --out %s --resume --until fine %s", test_data_dir, run, TRAIN_OPTS);
    assert_int_equal(run_unprivileged(args, out, sizeof out), 1);
    if (!strstr(out, "Permission denied"))
        fail_msg("expected EACCES in the message, got:\n%s", out);
    assert_unchanged(ckpt, before, n_before);

    snprintf(args, sizeof args, "export %s --mesh %s/mesh.ply --res 16", run, ro);
    assert_int_equal(run_unprivileged(args, out, sizeof out), 1);
    if (!strstr(out, "mesh.ply") || !strstr(out, "Permission denied"))
        fail_msg("expected the mesh path and EACCES in the message, got:\n%s", out);
    assert_int_equal(test_count_names(ro, "mesh"), 0);

    /* an output folder that exists but cannot be written is refused before the work */
    snprintf(args, sizeof args, "render %s --out %s --limit 1", run, ro);
    assert_int_equal(run_unprivileged(args, out, sizeof out), 1);
    if (!strstr(out, "cannot write into the output folder") || !strstr(out, "Permission denied"))
        fail_msg("expected the folder refused with EACCES, got:\n%s", out);
    assert_int_equal(test_count_names(ro, ".png"), 0);
    snprintf(cmd, sizeof cmd, "chmod -R u+w '%s'", ro); /* so the teardown can remove it */
    assert_int_equal(system(cmd), 0);
}

/* Output into a folder that cannot be created (its parent is a regular file): exit 1 naming the
 * path, nothing written. */
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
             test_data_dir, dir);
    assert_int_equal(run_limited(0, args, out, sizeof out), 1);
    if (!strstr(out, "plain_file"))
        fail_msg("expected the path in the message, got:\n%s", out);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_synth_on_full_disk),
        cmocka_unit_test(test_train_checkpoint_on_full_disk),
        cmocka_unit_test(test_export_on_full_disk),
        cmocka_unit_test(test_read_only_folders),
        cmocka_unit_test(test_unwritable_output),
    };
    return cmocka_run_group_tests(tests, test_setup_small_data, test_teardown_tmpdir);
}
