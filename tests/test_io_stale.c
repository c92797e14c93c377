/* A killed writer's leftovers (io/stale.h): temporary files and staging folders whose writer is
 * dead are removed, a live writer's and every other file are kept, and atomic writes and staging
 * use names the sweep recognises. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "core/error.h"
#include "io/dir.h"
#include "io/file.h"
#include "io/stale.h"
#include "io/staging.h"
#include "test_support.h"

static void put(const char *dir, const char *name)
{
    char path[8192];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    assert_int_equal(test_write_file(path, "x"), 0);
}

static int has(const char *dir, const char *name)
{
    char path[8192];
    struct stat st;
    snprintf(path, sizeof path, "%s/%s", dir, name);
    return lstat(path, &st) == 0;
}

static void test_sweep_removes_only_dead_writers_leftovers(void **state)
{
    (void)state;
    char dir[4300], name[256], sub[4700], keep[8][256];
    snprintf(dir, sizeof dir, "%s/sweep", test_tmpdir);
    assert_int_equal(esr_dir_create(dir), 0);
    const long dead = test_dead_pid(), live = (long)getppid(), self = (long)getpid();
    assert_true(dead > 0);
    int k = 0;
    /* kept: live writers, and names that only look similar */
    snprintf(keep[k++], 256, "ckpt_fine.bin.tmp-%ld-a1B2c3", live);
    snprintf(keep[k++], 256, "ckpt_fine.bin.tmp-%ld-a1B2c3", self);
    snprintf(keep[k++], 256, "notes.tmp-%ld-abc", dead);      /* not 6 characters */
    snprintf(keep[k++], 256, "notes.tmp-x%ld-abcdef", dead);  /* no pid */
    snprintf(keep[k++], 256, "data.partial-%ld-abcdef", dead); /* a staging folder is hidden */
    snprintf(keep[k++], 256, "ckpt_fine.bin");
    for (int i = 0; i < k; i++)
        put(dir, keep[i]);
    /* removed: a dead writer's temporary file and staging folders (with contents) */
    snprintf(name, sizeof name, "ckpt_fine.bin.tmp-%ld-Zz9yX8", dead);
    put(dir, name);
    const char *tags[] = {"partial", "old"};
    for (int t = 0; t < 2; t++) {
        snprintf(sub, sizeof sub, "%s/.data.%s-%ld-abcdef/train", dir, tags[t], dead);
        assert_int_equal(esr_dir_create(sub), 0);
        put(sub, "r_0.png");
    }
    int removed = -1;
    assert_int_equal(esr_stale_sweep(dir, &removed), 0);
    assert_int_equal(removed, 3);
    assert_false(has(dir, name));
    for (int i = 0; i < k; i++)
        if (!has(dir, keep[i]))
            fail_msg("%s was removed", keep[i]);
    assert_int_equal(test_count_names(dir, ".data."), 0); /* both staging folders */
    /* a missing folder is nothing to sweep */
    snprintf(sub, sizeof sub, "%s/absent", dir);
    assert_int_equal(esr_stale_sweep(sub, &removed), 0);
    assert_int_equal(removed, 0);
}

/* The writers' own temporary names are ones the sweep recognises (checked through a child that
 * stages an output and dies before committing it). */
static void test_killed_staging_is_swept_by_the_next_run(void **state)
{
    (void)state;
    char out[4400], staging[4600], parent[4300];
    snprintf(parent, sizeof parent, "%s/staged", test_tmpdir);
    snprintf(out, sizeof out, "%s/data", parent);
    const pid_t p = fork();
    if (p == 0) {
        if (esr_staging_begin(out, 0, staging, sizeof staging) != 0)
            _exit(1);
        _exit(0); /* as if killed: the staging folder stays */
    }
    int status;
    assert_int_equal(waitpid(p, &status, 0), p);
    assert_true(WIFEXITED(status) && WEXITSTATUS(status) == 0);
    assert_int_equal(test_count_names(parent, ".partial-"), 1);
    assert_int_equal(esr_staging_begin(out, 0, staging, sizeof staging), 0);
    assert_int_equal(test_count_names(parent, ".partial-"), 1); /* only this process's */
    assert_int_equal(esr_remove_tree(staging), 0);
    assert_int_equal(esr_dir_prepare_output(parent), 0);
}

/* An output-folder case: a path below the test's root, and whether the check accepts it. */
struct out_case {
    const char *out;
    int ok;
};

/* Runs check(root/out, ctx) on every case: accepted or refused as the case says, a refusal's
 * message holding `refusal`; `against` names the folder in a failure. */
static void expect_out_cases(const char *root, const struct out_case *cases, size_t n,
                             int (*check)(const char *out, const void *ctx), const void *ctx,
                             const char *against, const char *refusal)
{
    for (size_t i = 0; i < n; i++) {
        char out[8600];
        snprintf(out, sizeof out, "%s/%s", root, cases[i].out);
        esr_error_clear();
        const int rc = check(out, ctx);
        if ((rc == ESR_OK) != cases[i].ok)
            fail_msg("'%s' against '%s': %s", out, against, rc == ESR_OK ? "accepted" : esr_error_message());
        if (rc != ESR_OK)
            assert_non_null(strstr(esr_error_message(), refusal));
    }
    esr_error_clear();
}

static int check_apart(const char *out, const void *ctx)
{
    return esr_staging_check_apart(out, (const char *const *)ctx, 2);
}

/* An output folder must stay apart from the inputs it is made from: the same folder, one
 * containing an input, or an existing folder of the input's own inside it, also through a
 * symbolic link or `..`, are refused; a new folder inside an input, an earlier import's output
 * there, and a sibling that only shares a name prefix are fine. */
static void test_output_apart_from_inputs(void **state)
{
    (void)state;
    char root[4200], in[4300], link[4300], cmd[32768];
    snprintf(root, sizeof root, "%s/apart", test_tmpdir);
    snprintf(in, sizeof in, "%s/photos", root);
    snprintf(link, sizeof link, "%s/alias", root);
    /* photos/off holds a photo; photos/done an earlier import (import.json) */
    snprintf(cmd, sizeof cmd, "mkdir -p '%s/off' '%s/done' && touch '%s/off/a.png' "
             "'%s/done/import.json' && ln -s '%s' '%s'", in, in, in, in, in, link);
    assert_int_equal(system(cmd), 0);
    const char *const inputs[] = {NULL, in};
    static const struct out_case cases[] = {
        {"photos", 0},         {"photos/", 0},     {"photos/off", 0},  {"", 0},
        {"alias", 0},          {"alias/off", 0},   {"photos/../photos", 0},
        {"new/../photos", 0},  {"new/./x/../../photos/off", 0},
        {"photos/new/sub", 1}, {"photos/done", 1}, {"photos2", 1},     {"data", 1},
        {"data/new/sub", 1},   {"photo", 1},       {"new/../photos2", 1},
    };
    expect_out_cases(root, cases, sizeof cases / sizeof cases[0], check_apart, inputs, in,
                     "would delete the input");
}

/* The dataset folder and the run inside it that esr_output_check_outside is given. */
struct outside_args {
    const char *data, *run;
};

static int check_outside(const char *out, const void *ctx)
{
    const struct outside_args *a = ctx;
    const char *const what = "the dataset";
    return esr_output_check_outside(out, &a->data, &what, 1, a->run);
}

/* esr_output_check_outside: refused in or under a listed folder however the path is spelled
 * ('..' through folders that do not exist yet, links), fine beside it and inside the allowed
 * folder (a run kept inside its dataset). */
static void test_output_outside(void **state)
{
    (void)state;
    char root[4200], data[4300], run[4400], cmd[32768];
    snprintf(root, sizeof root, "%s/outside", test_tmpdir);
    snprintf(data, sizeof data, "%s/data", root);
    snprintf(run, sizeof run, "%s/run", data);
    snprintf(cmd, sizeof cmd, "mkdir -p '%s/test_nv' '%s' && ln -s '%s' '%s/alias'", data, run, data,
             root);
    assert_int_equal(system(cmd), 0);
    const struct outside_args args = {data, run};
    static const struct out_case cases[] = {
        {"data", 0},           {"data/test_nv", 0},         {"data/new/sub", 0},
        {"alias/test_nv", 0},  {"new/../data/test_nv", 0},  {"data/run/../test_nv", 0},
        {"data/run", 1},       {"data/run/edits/x", 1},     {"alias/run/new", 1},
        {"data2", 1},          {"new/../data2", 1},         {"edits", 1},
    };
    expect_out_cases(root, cases, sizeof cases / sizeof cases[0], check_outside, &args, data,
                     "the dataset");
}

/* esr_file_check_writable: fine for a new file in a folder that exists, refused for a missing
 * folder and for a directory, and leaves nothing behind either way. */
static void test_check_writable(void **state)
{
    (void)state;
    char dir[4200], path[4300], cmd[9000];
    snprintf(dir, sizeof dir, "%s/writable", test_tmpdir);
    snprintf(cmd, sizeof cmd, "mkdir -p '%s/sub'", dir);
    assert_int_equal(system(cmd), 0);
    snprintf(path, sizeof path, "%s/out.json", dir);
    assert_int_equal(esr_file_check_writable(path), ESR_OK);
    snprintf(path, sizeof path, "%s/missing/out.json", dir);
    assert_int_equal(esr_file_check_writable(path), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "missing/out.json"));
    esr_error_clear();
    snprintf(path, sizeof path, "%s/sub", dir);
    assert_int_equal(esr_file_check_writable(path), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "is a directory"));
    esr_error_clear();
    snprintf(cmd, sizeof cmd, "test \"$(ls -A '%s')\" = sub", dir); /* nothing but sub/ */
    assert_int_equal(system(cmd), 0);
}

/* esr_dir_create_made names the outermost folder it made, and esr_dir_remove_made takes back
 * exactly those folders while they are empty: a failed command leaves no folder it made, and
 * never one that was there before or that holds a file. */
static void test_dir_remove_made(void **state)
{
    (void)state;
    char base[4200], path[4400], made[4400], want[4400];
    snprintf(base, sizeof base, "%s/made", test_tmpdir);
    assert_int_equal(esr_dir_create(base), ESR_OK);
    snprintf(path, sizeof path, "%s/a/b/c/", base);
    assert_int_equal(esr_dir_create_made(path, made, sizeof made), ESR_OK);
    snprintf(want, sizeof want, "%s/a", base);
    assert_string_equal(made, want);
    esr_dir_remove_made(path, made);
    assert_false(has(base, "a"));
    assert_true(has(test_tmpdir, "made")); /* there before */
    /* all there: nothing made, nothing removed */
    snprintf(path, sizeof path, "%s/a/b", base);
    assert_int_equal(esr_dir_create(path), ESR_OK);
    assert_int_equal(esr_dir_create_made(path, made, sizeof made), ESR_OK);
    assert_string_equal(made, "");
    esr_dir_remove_made(path, made);
    assert_true(has(base, "a/b"));
    /* a made folder that holds a file stays, with its parents */
    snprintf(path, sizeof path, "%s/a/b/c/d", base);
    assert_int_equal(esr_dir_create_made(path, made, sizeof made), ESR_OK);
    snprintf(want, sizeof want, "%s/a/b/c", base);
    assert_string_equal(made, want);
    put(want, "kept.txt");
    esr_dir_remove_made(path, made);
    assert_false(has(base, "a/b/c/d"));
    assert_true(has(base, "a/b/c/kept.txt"));
    /* ".." in the path: its folders are not tracked (taking back "x" would remove an empty
     * folder that was there before) */
    snprintf(path, sizeof path, "%s/x", base);
    assert_int_equal(esr_dir_create(path), ESR_OK);
    snprintf(path, sizeof path, "%s/new/../x", base);
    assert_int_equal(esr_dir_create_made(path, made, sizeof made), ESR_OK);
    assert_string_equal(made, "");
    esr_dir_remove_made(path, made);
    assert_true(has(base, "x"));
    /* a walk that failed part way (the innermost folder never made) still takes back the rest */
    snprintf(path, sizeof path, "%s/p/q", base);
    assert_int_equal(esr_dir_create_made(path, made, sizeof made), ESR_OK);
    snprintf(want, sizeof want, "%s/p/q/never", base);
    esr_dir_remove_made(want, made);
    assert_false(has(base, "p"));
}

/* esr_dir_lock: one holder at a time (flock: a second open file description is refused, as a
 * second process would be), free again once released; the lock file is hidden and stays. */
static void test_dir_lock(void **state)
{
    (void)state;
    char dir[4200];
    snprintf(dir, sizeof dir, "%s/locked", test_tmpdir);
    assert_int_equal(esr_dir_create(dir), ESR_OK);
    int a = -1, b = -1;
    assert_int_equal(esr_dir_lock(dir, "train", &a), ESR_OK);
    assert_int_equal(esr_dir_lock(dir, "train", &b), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "is in use by another esr train"));
    assert_non_null(strstr(esr_error_message(), dir));
    esr_error_clear();
    assert_int_equal(b, -1);
    esr_dir_unlock(a);
    assert_int_equal(esr_dir_lock(dir, "train", &b), ESR_OK);
    esr_dir_unlock(b);
    assert_true(has(dir, ".esr.lock"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sweep_removes_only_dead_writers_leftovers),
        cmocka_unit_test(test_killed_staging_is_swept_by_the_next_run),
        cmocka_unit_test(test_output_apart_from_inputs),
        cmocka_unit_test(test_output_outside),
        cmocka_unit_test(test_check_writable),
        cmocka_unit_test(test_dir_remove_made),
        cmocka_unit_test(test_dir_lock),
    };
    return cmocka_run_group_tests(tests, test_setup_tmpdir, test_teardown_tmpdir);
}
