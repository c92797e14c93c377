/* The command line as a newcomer meets it, on a copy of the shared tiny run's pdra run
 * (tests/support/tiny_run.h): a slip or an interruption destroys nothing (a forgotten --resume,
 * a damaged checkpoint and the advice that recovers it, an edit, eval or export stopped by a
 * signal, an edit into an earlier edit's folder), output names say what is written, a run that
 * finished poorly says so, and one option grammar with suggestions for typos. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cjson/cJSON.h>

#include "core/error.h"
#include "io/file.h"
#include "test_support.h"
#include "tiny_run.h"

/* The "model" entry of an eval's JSON: 1 finished, 0 not, -1 missing. */
static int model_finished(const char *json)
{
    cJSON *root = test_read_json(json);
    assert_non_null(root);
    const cJSON *m = cJSON_GetObjectItemCaseSensitive(root, "model");
    const cJSON *f = cJSON_GetObjectItemCaseSensitive(m, "finished");
    const cJSON *st = cJSON_GetObjectItemCaseSensitive(m, "stage");
    const int r = !cJSON_IsBool(f) ? -1 : cJSON_IsTrue(f);
    if (r >= 0)
        assert_string_equal(cJSON_GetStringValue(st), "pdra");
    cJSON_Delete(root);
    return r;
}

/* A slip or an interruption destroys nothing (issue: the command line as a newcomer meets it):
 * a forgotten --resume, a damaged checkpoint, an edit, eval or export stopped by a signal, an
 * edit into an earlier edit's folder, output names that do not say what is written, a run that
 * finished poorly. */
static void test_slips_keep_earlier_outputs(void **state)
{
    (void)state;
    char run[4300], cmd[24000], out[16384], path[4500], copy[4500], log[4500];
    snprintf(run, sizeof run, "%s/run_slips", test_tmpdir);
    snprintf(cmd, sizeof cmd, "mkdir -p '%s' && cp '%s'/run_pdra/config.json '%s'/run_pdra/run.json "
             "'%s'/run_pdra/ckpt_*.bin '%s/'", run, tiny_dir, tiny_dir, tiny_dir, run);
    assert_int_equal(system(cmd), 0);
    snprintf(log, sizeof log, "%s/slips.log", test_tmpdir);

    /* 1. a finished run and a forgotten --resume: refused, every checkpoint as it was */
    snprintf(path, sizeof path, "%s/ckpt_pdra.bin", run);
    snprintf(copy, sizeof copy, "%s/ckpt_pdra.copy", test_tmpdir);
    assert_int_equal(esr_file_copy(path, copy), ESR_OK);
    snprintf(cmd, sizeof cmd, "train '%s' --out '%s'", data_dir, run);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
    if (!strstr(out, "add --resume to continue the run in it, or --force to start over"))
        fail_msg("%s", out);
    assert_true(test_files_equal(path, copy));
    snprintf(cmd, sizeof cmd, "train '%s' --out '%s' --resume --force", data_dir, run);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);

    /* 2. a damaged checkpoint: every command names the way out, and following it works */
    assert_int_equal(test_write_file(path, "esr-truncated"), 0);
    snprintf(cmd, sizeof cmd, "lights '%s'", run);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
    char advice[9000];
    snprintf(advice, sizeof advice, "To recover: rm -f %s/ckpt_pdra.bin, then `esr train DATA --out "
             "%s --resume` trains the pdra stage again", run, run);
    if (!strstr(out, advice))
        fail_msg("no recovery advice in: %s", out);
    snprintf(cmd, sizeof cmd, "rm -f '%s' && '%s' train '%s' --out '%s' --resume > '%s' 2>&1", path,
             ESR_BINARY, data_dir, run, log);
    const int retrained = system(cmd);
    assert_true(WIFEXITED(retrained) && (WEXITSTATUS(retrained) == 0 || WEXITSTATUS(retrained) == 2));
    snprintf(cmd, sizeof cmd, "lights '%s'", run);
    if (test_run_esr(cmd, out, sizeof out) != 0)
        fail_msg("after the advice: %s", out);

    /* 3a. an edit writes edit.json and says what it wrote; a second, shorter one into the same
     * folder replaces it whole (no view of the first is left) */
    char edit_dir[4400];
    snprintf(edit_dir, sizeof edit_dir, "%s/slip_edit", test_tmpdir);
    snprintf(cmd, sizeof cmd, "edit '%s' --light all --intensity=0 --orbit 4 --out '%s'", run, edit_dir);
    if (test_run_esr(cmd, out, sizeof out) != 0)
        fail_msg("%s", out);
    assert_non_null(strstr(out, "wrote 4 views to"));
    snprintf(path, sizeof path, "%s/edit.json", edit_dir);
    cJSON *rec = test_read_json(path);
    assert_non_null(rec);
    assert_true(cJSON_IsString(cJSON_GetObjectItem(rec, "command")));
    assert_non_null(strstr(cJSON_GetObjectItem(rec, "command")->valuestring, "--intensity=0"));
    assert_true(cJSON_IsString(cJSON_GetObjectItem(rec, "model_fingerprint")));
    assert_true(cJSON_IsString(cJSON_GetObjectItem(rec, "time")));
    assert_int_equal(cJSON_GetArraySize(cJSON_GetObjectItem(rec, "views")), 4);
    cJSON_Delete(rec);
    snprintf(cmd, sizeof cmd, "edit '%s' --light all --intensity 0 --orbit 2 --out '%s'", run, edit_dir);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 0);
    assert_int_equal(test_count_names(edit_dir, "orbit_"), 4); /* 2 views, .png and .exr */
    snprintf(copy, sizeof copy, "%s/edit.json.copy", test_tmpdir);
    assert_int_equal(esr_file_copy(path, copy), ESR_OK);
    /* 3b. an edit stopped by Ctrl-C: the earlier folder as it was, nothing of the new one */
    snprintf(cmd, sizeof cmd, "edit '%s' --light all --intensity 2 --orbit 400 --out '%s'", run, edit_dir);
    long pid = test_spawn_esr(cmd, log);
    assert_true(test_wait_for_text(log, "orbit_000", 60000));
    kill((pid_t)pid, SIGINT);
    assert_int_equal(test_wait_esr(pid), 128 + SIGINT);
    assert_true(test_files_equal(path, copy));
    assert_int_equal(test_count_names(edit_dir, "orbit_"), 4);
    assert_int_equal(test_count_names(test_tmpdir, ".slip_edit.partial-"), 0);
    /* 3c. an --out holding files no edit wrote is refused, the files kept */
    char foreign[4500];
    snprintf(foreign, sizeof foreign, "%s/notes.txt", edit_dir);
    assert_int_equal(test_write_file(foreign, "mine"), 0);
    snprintf(cmd, sizeof cmd, "edit '%s' --light all --intensity 0 --orbit 1 --out '%s'", run, edit_dir);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
    assert_non_null(strstr(out, "notes.txt"));
    assert_true(esr_file_exists(foreign));

    /* 3d. an eval stopped by SIGTERM while it renders, and one that fails after scoring (a
     * damaged lights checkpoint): the earlier scores and report as they were */
    snprintf(cmd, sizeof cmd, "eval '%s'", run);
    if (test_run_esr(cmd, out, sizeof out) != 0)
        fail_msg("%s", out);
    char json[4600], report[4600], json_copy[4500], report_copy[4500], eval_dir[4400];
    snprintf(eval_dir, sizeof eval_dir, "%s/eval", run);
    snprintf(json, sizeof json, "%s/test_nv.json", eval_dir);
    snprintf(report, sizeof report, "%s/report.html", run);
    snprintf(json_copy, sizeof json_copy, "%s/test_nv.json.copy", test_tmpdir);
    snprintf(report_copy, sizeof report_copy, "%s/report.html.copy", test_tmpdir);
    assert_int_equal(esr_file_copy(json, json_copy), ESR_OK);
    assert_int_equal(esr_file_copy(report, report_copy), ESR_OK);
    assert_int_equal(model_finished(json), 1);
    assert_null(strstr(out, "unfinished model"));
    /* 3c'. an unfinished checkpoint is scored and said to be, in the terminal and the JSON */
    char unfinished[4400], unfinished_json[4500];
    snprintf(unfinished, sizeof unfinished, "%s/run_unfinished", test_tmpdir);
    copy_run_changed(run, unfinished, make_unfinished);
    snprintf(cmd, sizeof cmd, "eval '%s' --limit 1", unfinished);
    if (test_run_esr(cmd, out, sizeof out) != 0)
        fail_msg("%s", out);
    assert_non_null(strstr(out, "the pdra stage stopped at step 20 of "));
    assert_non_null(strstr(out, "an unfinished model"));
    snprintf(unfinished_json, sizeof unfinished_json, "%s/eval/test_nv.json", unfinished);
    assert_int_equal(model_finished(unfinished_json), 0);
    char many[4400];
    snprintf(many, sizeof many, "%s/many_views", test_tmpdir);
    snprintf(cmd, sizeof cmd, "synth --res 24 --spp 1 --train 1 --test 30 '%s'", many);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 0);
    snprintf(cmd, sizeof cmd, "eval '%s' --data '%s' --rerender", run, many);
    pid = test_spawn_esr(cmd, log);
    assert_true(test_wait_for_text(log, "rendering ", 60000));
    kill((pid_t)pid, SIGTERM);
    assert_int_equal(test_wait_esr(pid), 128 + SIGTERM);
    assert_true(test_files_equal(json, json_copy));
    assert_true(test_files_equal(report, report_copy));
    assert_int_equal(test_count_names(eval_dir, ".tmp-"), 0);
    assert_int_equal(test_count_names(run, ".tmp-"), 0);
    snprintf(path, sizeof path, "%s/ckpt_pdra.bin", run);
    snprintf(copy, sizeof copy, "%s/ckpt_pdra.good", test_tmpdir);
    assert_int_equal(esr_file_copy(path, copy), ESR_OK);
    assert_int_equal(test_write_file(path, "esr-truncated"), 0);
    snprintf(cmd, sizeof cmd, "eval '%s' --limit 1", run);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
    assert_true(test_files_equal(json, json_copy));
    assert_true(test_files_equal(report, report_copy));
    assert_int_equal(rename(copy, path), 0);

    /* 3e. an export stopped by Ctrl-C: the earlier asset as it was, no temporary file */
    char glb[4500], glb_copy[4500];
    snprintf(glb, sizeof glb, "%s/asset/scene.glb", test_tmpdir); /* asset/ is made */
    snprintf(cmd, sizeof cmd, "export '%s' --gltf '%s' --mesh '%s/asset/scene.ply'", run, glb, test_tmpdir);
    if (test_run_esr(cmd, out, sizeof out) != 0)
        fail_msg("%s", out);
    snprintf(glb_copy, sizeof glb_copy, "%s/scene.glb.copy", test_tmpdir);
    assert_int_equal(esr_file_copy(glb, glb_copy), ESR_OK);
    snprintf(cmd, sizeof cmd, "export '%s' --gltf '%s' --mesh '%s/asset/scene.ply' --res 1024", run,
             glb, test_tmpdir);
    pid = test_spawn_esr(cmd, log);
    usleep(300000);
    kill((pid_t)pid, SIGINT);
    assert_int_equal(test_wait_esr(pid), 128 + SIGINT);
    assert_true(test_files_equal(glb, glb_copy));
    snprintf(path, sizeof path, "%s/asset", test_tmpdir);
    assert_int_equal(test_count_names(path, ".tmp-"), 0);

    /* 5. output names say what is written; a missing folder is made before any work */
    snprintf(cmd, sizeof cmd, "export '%s' --gltf '%s/asset/scene.gltf'", run, test_tmpdir);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
    assert_non_null(strstr(out, "name it .glb"));
    snprintf(cmd, sizeof cmd, "export '%s' --mesh '%s/asset/scene.txt'", run, test_tmpdir);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
    assert_non_null(strstr(out, "name it *.ply"));
    snprintf(cmd, sizeof cmd, "info '%s' --json '%s/new/dir/info.json'", data_dir, test_tmpdir);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 0);
    snprintf(path, sizeof path, "%s/new/dir/info.json", test_tmpdir);
    assert_true(esr_file_exists(path));

    /* 4. a run that finished but learned nothing says so and exits 2, unless asked for */
    char poor[4400], cfg[4500];
    snprintf(poor, sizeof poor, "%s/run_poor", test_tmpdir);
    snprintf(cfg, sizeof cfg, "%s/poor.json", test_tmpdir);
    assert_int_equal(test_write_file(cfg, "{\"alphamask\": {\"res\": 16, \"iters\": 100}, "
                                          "\"coarse\": {\"res\": 16, \"iters\": 3}}"), 0);
    snprintf(cmd, sizeof cmd, "train '%s' --out '%s' --until coarse --config '%s'", data_dir, poor, cfg);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 2);
    assert_non_null(strstr(out, "below this dataset's floor"));
    snprintf(cmd, sizeof cmd, "train '%s' --out '%s' --until coarse --config '%s' --force --allow-poor",
             data_dir, poor, cfg);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 0);
    assert_non_null(strstr(out, "esr train: warning: stage coarse ended"));

    /* 6. one option grammar: --name=value, both spellings, a typo answered with a suggestion */
    assert_int_equal(test_run_esr("edit x --orbt 4", out, sizeof out), 1);
    assert_non_null(strstr(out, "unknown option '--orbt' (did you mean --orbit?)"));
    assert_int_equal(test_run_esr("rendr x", out, sizeof out), 1);
    assert_non_null(strstr(out, "did you mean render?"));
    assert_null(strstr(out, "commands:")); /* not the whole help */
    assert_int_equal(test_run_esr("help train", out, sizeof out), 0);
    assert_non_null(strstr(out, "usage: esr train"));
    assert_int_equal(test_run_esr("--version", out, sizeof out), 0);
    assert_non_null(strstr(out, "commit "));
    assert_non_null(strstr(out, "code paths"));
    snprintf(cmd, sizeof cmd, "train '%s' --out '%s' --set fine.iter=20", data_dir, poor);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
    assert_non_null(strstr(out, "did you mean fine.iters?"));
    snprintf(cmd, sizeof cmd, "export '%s' --mesh '%s/asset/b.ply' --no-color", run, test_tmpdir);
    if (test_run_esr(cmd, out, sizeof out) != 0) /* export spells it --no-colour */
        fail_msg("%s", out);
    snprintf(cmd, sizeof cmd, "edit '%s' --light 0 --colour 0.1,1 --orbit 1 --out '%s/edit_uk'", run,
             test_tmpdir);
    if (test_run_esr(cmd, out, sizeof out) != 0) /* edit spells it --color */
        fail_msg("%s", out);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_slips_keep_earlier_outputs),
    };
    return cmocka_run_group_tests(tests, tiny_setup, test_teardown_tmpdir);
}
