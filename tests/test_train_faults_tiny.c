/* Training's faults and odd input on the tiny dataset (tests/support/tiny_run.h): injected NaNs
 * are recovered (reload + halved lr, in alphamask, lts and pdra; killed after a recovery and
 * resumed, bitwise the recovered run) and repeated ones stop with the checkpoint intact; a bad
 * dataset writes nothing; an empty mask cache is refused; the emitter stages on one lighting only
 * (no lights-off images refused before any stage trains, no lights-on images: E 0 and pdra
 * skipped), and the geometry stages on lights-on photos only. Runs of their own, from the shared
 * run's checkpoints where they continue it. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cjson/cJSON.h>

#include "core/error.h"
#include "io/file.h"
#include "io/json_file.h"
#include "model/material_fields.h"
#include "model/model.h"
#include "test_support.h"
#include "tiny_run.h"
#include "train/trainer.h"

static void test_nan_is_recovered_then_stops(void **state)
{
    (void)state;
    char run[4200];
    struct log_capture lc;
    struct esr_train_opts o;
    snprintf(run, sizeof run, "%s/nan1", test_tmpdir);
    opts_for(&o, run, ESR_STAGE_COARSE, &lc);
    o.nan_test_iter = 30;
    o.nan_test_times = 1;
    if (esr_train_run(&o) != ESR_OK)
        fail_msg("%s", esr_error_message());
    assert_non_null(strstr(lc.text, "non-finite loss or gradient at alphamask iteration 30"));
    assert_non_null(strstr(lc.text, "learning rate halved"));
    /* a gradient that is always poisoned: three failures, then a clear stop */
    snprintf(run, sizeof run, "%s/nan3", test_tmpdir);
    opts_for(&o, run, ESR_STAGE_COARSE, &lc);
    o.nan_test_iter = 30;
    o.nan_test_times = 100;
    esr_error_clear();
    assert_int_equal(esr_train_run(&o), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "stage alphamask at iteration 30"));
    assert_non_null(strstr(esr_error_message(), "is intact"));
    esr_error_clear();
    assert_checkpoint(run, "alphamask", 20, -1);
}

/* A non-finite gradient inside lts (before the stage's first checkpoint after its start) and
 * inside pdra (after one): reloaded, learning rate halved, and the run ends with lights found. */
static void test_nan_in_emitter_stages_is_recovered(void **state)
{
    (void)state;
    char run[4300], cmd[9000];
    const struct {
        enum esr_stage stage;
        long iter;
    } at[] = {{ESR_STAGE_LTS, 5}, {ESR_STAGE_PDRA, 25}};
    for (int i = 0; i < 2; i++) {
        const char *name = esr_stage_name(at[i].stage);
        snprintf(run, sizeof run, "%s/nan_%s", test_tmpdir, name);
        snprintf(cmd, sizeof cmd, "mkdir -p '%s' && cp '%s'/runs/full/ckpt_alphamask.bin "
                 "'%s'/runs/full/ckpt_coarse.bin '%s'/runs/full/ckpt_fine.bin '%s'/", run,
                 tiny_dir, tiny_dir, tiny_dir, run);
        assert_int_equal(system(cmd), 0);
        struct esr_train_opts o;
        struct log_capture lc;
        opts_for(&o, run, ESR_STAGE_PDRA, &lc);
        o.resume = 1;
        o.nan_test_iter = at[i].iter;
        o.nan_test_times = 1;
        o.nan_test_stage = at[i].stage;
        if (esr_train_run(&o) != ESR_OK)
            fail_msg("%s", esr_error_message());
        snprintf(cmd, sizeof cmd, "non-finite loss or gradient at %s iteration %ld: reloaded",
                 name, at[i].iter);
        if (!strstr(lc.text, cmd))
            fail_msg("expected '%s' in:\n%s", cmd, lc.text);
        assert_non_null(strstr(lc.text, "learning rate halved"));
        assert_non_null(strstr(lc.text, "lights found"));
    }
    /* killed after the recovery (pdra step 35 of 40; the last checkpoint is the one at step 20
     * that the recovery reloaded) and resumed: the recovery saved the halved learning rate in that
     * checkpoint, so pdra ends as in the run above */
    char straight[4300], pa[4400], pb[4400], cp[16384];
    snprintf(straight, sizeof straight, "%s/nan_pdra", test_tmpdir);
    snprintf(run, sizeof run, "%s/nan_pdra_cut", test_tmpdir);
    const char *copy[] = {"config.json", "ckpt_alphamask.bin", "ckpt_coarse.bin", "ckpt_fine.bin",
                          "ckpt_lts.bin"};
    for (int i = 0; i < 5; i++) {
        snprintf(cp, sizeof cp, "mkdir -p '%s' && cp '%s/%s' '%s/'", run, straight, copy[i], run);
        assert_int_equal(system(cp), 0);
    }
    struct esr_train_opts o;
    opts_for(&o, run, ESR_STAGE_PDRA, NULL);
    o.resume = 1;
    o.nan_test_iter = 25;
    o.nan_test_times = 1;
    o.nan_test_stage = ESR_STAGE_PDRA;
    o.stop_test_stage = ESR_STAGE_PDRA;
    o.stop_test_iter = 35;
    if (esr_train_run(&o) != ESR_OK)
        fail_msg("%s", esr_error_message());
    opts_for(&o, run, ESR_STAGE_PDRA, NULL);
    o.resume = 1;
    if (esr_train_run(&o) != ESR_OK)
        fail_msg("%s", esr_error_message());
    snprintf(pa, sizeof pa, "%s/ckpt_pdra.bin", straight);
    snprintf(pb, sizeof pb, "%s/ckpt_pdra.bin", run);
    assert_same_model(pa, pb);
}

/* A bad dataset is refused before anything is written: a new RUN folder is not created, and an
 * existing run's config.json and run.json stay byte for byte (a failed `esr train` used to
 * rewrite them first, pointing the run at the bad data). */
static void test_bad_dataset_writes_nothing(void **state)
{
    (void)state;
    char run[4300], fresh[4300], notds[4300], cmd[16384], out[4096];
    snprintf(run, sizeof run, "%s/existing_run", test_tmpdir);
    snprintf(fresh, sizeof fresh, "%s/never_created", test_tmpdir);
    snprintf(notds, sizeof notds, "%s/not_a_dataset", test_tmpdir);
    snprintf(cmd, sizeof cmd, "mkdir -p '%s' '%s' && cp '%s'/runs/full/config.json "
             "'%s'/runs/full/run.json '%s'/", run, notds, tiny_dir, tiny_dir, run);
    assert_int_equal(system(cmd), 0);
    const char *files[] = {"config.json", "run.json"};
    unsigned char *before[2];
    size_t n_before[2];
    for (int i = 0; i < 2; i++) {
        snprintf(cmd, sizeof cmd, "%s/%s", run, files[i]);
        assert_int_equal(esr_file_read_all(cmd, &before[i], &n_before[i]), ESR_OK);
    }
    snprintf(cmd, sizeof cmd, "train '%s' --out '%s' --set seed=7", notds, run);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
    assert_non_null(strstr(out, "is not a dataset"));
    for (int i = 0; i < 2; i++) {
        unsigned char *after;
        size_t n_after;
        snprintf(cmd, sizeof cmd, "%s/%s", run, files[i]);
        assert_int_equal(esr_file_read_all(cmd, &after, &n_after), ESR_OK);
        assert_int_equal(n_after, n_before[i]);
        assert_memory_equal(after, before[i], n_after);
        free(after);
        free(before[i]);
    }
    snprintf(cmd, sizeof cmd, "%s/log", run);
    assert_false(esr_file_exists(cmd));
    snprintf(cmd, sizeof cmd, "train '%s' --out '%s'", notds, fresh);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
    assert_false(esr_file_exists(fresh));
}

/* An alphamask stage too short to find anything stops training with a clear message instead of
 * training later stages on an empty mask cache. */
static void test_empty_mask_cache_is_refused(void **state)
{
    (void)state;
    char run[4200];
    snprintf(run, sizeof run, "%s/empty_mask", test_tmpdir);
    struct esr_train_opts o;
    opts_for(&o, run, ESR_STAGE_COARSE, NULL);
    o.cfg.alphamask.iters = 2;
    esr_error_clear();
    assert_int_equal(esr_train_run(&o), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "mask cache is empty"));
    esr_error_clear();
}

/* A copy of the tiny dataset whose training frames are only those with lighting `keep`
 * ("off" or "on"), in dst. */
static void one_lighting_dataset(const char *dst, const char *keep)
{
    char cmd[16384], path[4400];
    snprintf(cmd, sizeof cmd, "rm -rf '%s' && cp -r '%s' '%s'", dst, data_dir, dst);
    assert_int_equal(system(cmd), 0);
    snprintf(path, sizeof path, "%s/transforms/transforms_train.json", dst);
    unsigned char *text;
    size_t size;
    assert_int_equal(esr_file_read_all(path, &text, &size), 0);
    cJSON *root = cJSON_ParseWithLength((const char *)text, size);
    free(text);
    assert_non_null(root);
    cJSON *frames = cJSON_GetObjectItem(root, "frames");
    for (int i = cJSON_GetArraySize(frames) - 1; i >= 0; i--) {
        cJSON *light = cJSON_GetArrayItem(cJSON_GetObjectItem(cJSON_GetArrayItem(frames, i), "lights"), 0);
        if (strcmp(cJSON_GetStringValue(cJSON_GetObjectItem(light, "mode")), keep) != 0)
            cJSON_DeleteItemFromArray(frames, i);
    }
    assert_true(cJSON_GetArraySize(frames) > 0);
    assert_int_equal(esr_json_write_atomic(path, root), 0);
}

/* The emitter stages on a dataset with one lighting only, continuing the full run's fine
 * checkpoint: no lights-off images is refused with the reason; no lights-on images trains lts
 * (materials and environment) and skips pdra, saying so. */
static void test_emitter_stages_need_both_lightings(void **state)
{
    (void)state;
    char data[4300], run[4300], cmd[24000];
    struct esr_train_opts o;
    struct log_capture lc;
    const char *keep[2] = {"on", "off"};
    for (int k = 0; k < 2; k++) {
        snprintf(data, sizeof data, "%s/data_%s", test_tmpdir, keep[k]);
        snprintf(run, sizeof run, "%s/run_%s", test_tmpdir, keep[k]);
        one_lighting_dataset(data, keep[k]);
        if (k == 0) { /* an earlier run in RUN: a refused run must leave it as it was */
            snprintf(cmd, sizeof cmd, "mkdir -p '%s' && cp '%s'/runs/full/ckpt_fine.bin '%s'/", run,
                     tiny_dir, run);
            assert_int_equal(system(cmd), 0);
        }
        if (k == 1) { /* the geometry from the full run; no lights-off images: a fresh run */
            snprintf(cmd, sizeof cmd,
                     "mkdir -p '%s' && cp '%s'/runs/full/ckpt_alphamask.bin "
                     "'%s'/runs/full/ckpt_coarse.bin '%s'/runs/full/ckpt_fine.bin '%s'/",
                     run, tiny_dir, tiny_dir, tiny_dir, run);
            assert_int_equal(system(cmd), 0);
        }
        opts_for(&o, run, ESR_STAGE_PDRA, &lc);
        o.data_dir = data;
        o.resume = k == 1;
        esr_error_clear();
        int rc = esr_train_run(&o);
        if (k == 1) /* checkpoints without a config.json: resumed with these options, said */
            assert_non_null(strstr(lc.text, "has no config.json: its checkpoints (ckpt_alphamask.bin, "
                                            "ckpt_coarse.bin, ckpt_fine.bin) are resumed"));
        if (k == 0) { /* refused before any stage trains */
            assert_int_equal(rc, ESR_ERR);
            assert_non_null(strstr(esr_error_message(), "needs lights-off training images"));
            snprintf(cmd, sizeof cmd, "%s/ckpt_alphamask.bin", run);
            assert_false(esr_file_exists(cmd));
            snprintf(cmd, sizeof cmd, "%s/ckpt_fine.bin", run);
            assert_true(esr_file_exists(cmd));
        } else {
            if (rc != ESR_OK)
                fail_msg("%s", esr_error_message());
            assert_non_null(strstr(lc.text, "stage lts trains materials and the environment only"));
            assert_non_null(strstr(lc.text, "stage pdra skipped"));
            snprintf(cmd, sizeof cmd, "%s/ckpt_pdra.bin", run);
            assert_false(esr_file_exists(cmd));
            /* nothing tells emission from reflection: the lts model emits nothing */
            snprintf(cmd, sizeof cmd, "%s/ckpt_lts.bin", run);
            struct esr_model m;
            assert_int_equal(esr_model_load(&m, cmd), ESR_OK);
            assert_int_equal(m.cfg.emission, 0);
            struct esr_material_fields mf;
            assert_int_equal(esr_material_fields_init(&mf, &m, 64, 0), ESR_OK);
            float pos[64 * 3];
            for (int i = 0; i < 64 * 3; i++)
                pos[i] = 0.6f * ((float)((i * 37) % 101) / 50.0f - 1.0f);
            assert_int_equal(esr_material_fields_fwd(&mf, &m, esr_model_values(&m, ESR_COMP_SDF),
                                                     pos, 64), ESR_OK);
            double sum_e = 0.0, sum_b = 0.0;
            for (int i = 0; i < 64 * 3; i++)
                sum_e += fabsf(mf.emit3[i]);
            for (int i = 0; i < 64 * ESR_BRDF_CHANNELS; i++)
                sum_b += fabsf(mf.brdf5[i]);
            assert_true(sum_e == 0.0);
            assert_true(sum_b > 0.0); /* the materials are there */
            esr_material_fields_free(&mf);
            esr_model_free(&m);
        }
        esr_error_clear();
    }
}

/* Lights-on photos only: the geometry stages, which by default shape the surface from the
 * lights-off photos (geom_on 0), take it from the lights-on ones and say so; without that the
 * alphamask stage learns no occupancy and the run stops on an empty mask cache. */
static void test_geometry_from_lights_on_only(void **state)
{
    (void)state;
    char data[4300], run[4300];
    snprintf(data, sizeof data, "%s/data_on_only", test_tmpdir);
    snprintf(run, sizeof run, "%s/run_on_only", test_tmpdir);
    one_lighting_dataset(data, "on");
    struct esr_train_opts o;
    struct log_capture lc;
    opts_for(&o, run, ESR_STAGE_ALPHAMASK, &lc);
    o.data_dir = data;
    assert_true(o.cfg.alphamask.geom_on == 0.0f);
    esr_error_clear();
    if (esr_train_run(&o) != ESR_OK)
        fail_msg("%s", esr_error_message());
    assert_non_null(strstr(lc.text, "no lights-off training images: stage alphamask shapes the "
                                    "surface from the lights-on ones"));
    assert_non_null(strstr(lc.text, "mask cache: "));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_nan_is_recovered_then_stops),
        cmocka_unit_test(test_nan_in_emitter_stages_is_recovered),
        cmocka_unit_test(test_bad_dataset_writes_nothing),
        cmocka_unit_test(test_empty_mask_cache_is_refused),
        cmocka_unit_test(test_emitter_stages_need_both_lightings),
        cmocka_unit_test(test_geometry_from_lights_on_only),
    };
    return cmocka_run_group_tests(tests, tiny_setup, test_teardown_tmpdir);
}
