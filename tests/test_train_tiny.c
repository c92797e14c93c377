/* Training end to end on the tiny path-traced dataset (`esr synth --res 24`, the shared tiny run
 * of tests/support/tiny_run.h): the fixture's run through lts reaches a fixed held-out PSNR and
 * writes its files (its normals, emitter mask and materials scored); runs of their own, stopped
 * inside coarse or by an interrupt, resume to bitwise the parameters of a run that never stopped;
 * --set on resume applies over the run's config (a bad one refused, the file unchanged), a
 * forgotten --resume is refused and --force starts over; a checkpoint over another scene box is
 * refused on resume. Resuming into and inside lts and pdra: test_train_resume_tiny.c. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cjson/cJSON.h>

#include "core/error.h"
#include "eval/evaluate.h"
#include "eval/quick_eval.h"
#include "eval/select.h"
#include "io/dataset.h"
#include "io/file.h"
#include "model/model.h"
#include "render/view.h"
#include "test_support.h"
#include "tiny_run.h"
#include "train/trainer.h"

/* The fixture's training (tests/support/tiny_fixture_setup.c: tiny_config through lts into
 * runs/full) finished every stage, wrote its files and reaches a fixed held-out PSNR; rendered
 * (into a copy of the run), its normals, emission, emitter mask, environment map and materials
 * are scored. */
static void test_tiny_reaches_psnr(void **state)
{
    (void)state;
    char run[4200], path[4300];
    snprintf(run, sizeof run, "%s/runs/full", tiny_dir); /* runs/ did not exist before it */
    struct log_capture lc;
    tiny_read_log("full", &lc); /* what the fixture's training reported */
    assert_int_equal(lc.stages_done, ESR_STAGE_LTS + 1);
    const char *files[] = {"config.json", "train_log.jsonl", "ckpt_alphamask.bin",
                           "ckpt_coarse.bin", "ckpt_fine.bin", "ckpt_lts.bin"};
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        snprintf(path, sizeof path, "%s/%s", run, files[i]);
        assert_true(esr_file_exists(path));
    }
    /* the renders and the JSON below are written into the run: a copy of it */
    tiny_copy_run("runs/full", "runs/full", run, sizeof run);
    struct esr_quick_eval ev;
    if (esr_quick_eval_run(run, data_dir, &ev) != ESR_OK)
        fail_msg("%s", esr_error_message());
    double tone = 0.5 * (ev.psnr_tone[0] + ev.psnr_tone[1]);
    double lin = 0.5 * (ev.psnr_lin[0] + ev.psnr_lin[1]);
    print_message("tiny scene test_nv PSNR: tone-mapped %.2f dB, gamma(linear) %.2f dB\n", tone,
                  lin);
    assert_true(ev.views[0] > 0 && ev.views[1] > 0);
    assert_true(tone >= 18.0); /* measured 19.7 */
    assert_true(lin >= 17.5); /* measured 19.6 */

    /* the trained surface's normals against the dataset's gt/c<CCC>_normal.exr */
    struct esr_dataset ds;
    struct esr_model m;
    struct esr_eval_result res;
    int *idx, n;
    assert_int_equal(esr_dataset_load(data_dir, &ds), ESR_OK);
    assert_int_equal(esr_model_load(&m, run), ESR_OK);
    assert_int_equal(esr_select_frames(&ds.phases[ESR_PHASE_TEST_NV], "test_nv", NULL, 0, &idx, &n), ESR_OK);
    snprintf(path, sizeof path, "%s/render", run);
    if (esr_view_render_frames(&m, &ds, ESR_PHASE_TEST_NV, idx, n, path, NULL, NULL) != ESR_OK ||
        esr_eval_phase(&ds, ESR_PHASE_TEST_NV, idx, n, path, &res) != ESR_OK)
        fail_msg("%s", esr_error_message());
    print_message("tiny scene test_nv normals: mean %.2f deg, median %.2f, %.3f under 10 deg, coverage %.3f\n",
                  res.normals.mean_deg, res.normals.median_deg, res.normals.frac_good, res.normals.coverage);
    assert_int_equal(res.n_normal_views, n);
    assert_true(isfinite(res.normals.mean_deg));
    assert_true(res.normals.mean_deg < 45.0); /* measured 33.6 */
    assert_true(res.normals.coverage > 0.8);
    /* the lts model renders emission and an emitter mask, which evaluation scores */
    char render_dir[4400], emission[4600];
    snprintf(render_dir, sizeof render_dir, "%s/render", run);
    assert_int_equal(esr_view_path(emission, sizeof emission, render_dir,
                                   ds.phases[ESR_PHASE_TEST_NV].frames[idx[0]].name, "_emission.exr"),
                     ESR_OK);
    assert_true(esr_file_exists(emission));
    assert_int_equal(esr_view_path(emission, sizeof emission, render_dir,
                                   ds.phases[ESR_PHASE_TEST_NV].frames[idx[0]].name, "_basecolor.png"),
                     ESR_OK);
    assert_true(esr_file_exists(emission));
    /* and its environment map, once per render directory */
    assert_int_equal(esr_view_path(emission, sizeof emission, render_dir, "env", ".exr"), ESR_OK);
    assert_true(esr_file_exists(emission));
    assert_int_equal(res.n_emitter_views, n);
    double iou = esr_iou_value(&res.emitter);
    print_message("tiny scene emitter IoU after 60 lts iterations: %.3f\n", iou);
    assert_true(iou >= 0.0 && iou <= 1.0);
    /* the lts model's material maps against synth's gt/c<CCC>_{base_color,roughness,metallic}.exr,
     * each camera once, and the "materials" object of the JSON */
    const struct esr_materials_result *mat = &res.materials;
    const struct esr_material_stats *ms = &mat->pooled;
    assert_true(mat->has_truth);
    assert_string_equal(mat->skipped, "");
    assert_int_equal(mat->n_views, 3); /* --test 3 cameras, each lights off and on */
    print_message("tiny scene materials: base colour %.2f dB (%.2f with gains %.2f %.2f %.2f), roughness MAE "
                  "%.3f, metallic MAE %.3f; metallic pixels %ld (mean metallic %.3f), non-metallic %ld (%.3f); "
                  "coverage %.3f\n",
                  ms->base_color_psnr, ms->base_color_psnr_gain, ms->gain[0], ms->gain[1], ms->gain[2],
                  ms->roughness_mae, ms->metallic_mae, ms->metal.n, ms->metal.mean_metallic, ms->dielectric.n,
                  ms->dielectric.mean_metallic, ms->coverage);
    assert_true(ms->coverage > 0.8);
    assert_true(ms->base_color_psnr > 5.0 && ms->base_color_psnr < ESR_MATERIAL_PSNR_CAP);
    assert_true(ms->base_color_psnr_gain >= ms->base_color_psnr - 0.5); /* least squares in linear */
    assert_true(ms->roughness_mae >= 0.0 && ms->roughness_mae <= 1.0);
    assert_true(ms->metallic_mae >= 0.0 && ms->metallic_mae <= 1.0);
    assert_true(ms->metal.n + ms->dielectric.n <= ms->n && ms->dielectric.n > 0);
    snprintf(path, sizeof path, "%s/eval_test_nv.json", run);
    assert_int_equal(esr_eval_write_json(path, &ds, &res), ESR_OK);
    cJSON *json = test_read_json(path);
    const cJSON *jm = cJSON_GetObjectItem(json, "materials");
    assert_non_null(jm);
    assert_true(cJSON_IsNumber(cJSON_GetObjectItem(jm, "base_color_psnr")));
    assert_true(cJSON_IsNumber(cJSON_GetObjectItem(jm, "base_color_psnr_gain")));
    assert_true(cJSON_IsNumber(cJSON_GetObjectItem(jm, "roughness_mae")));
    assert_true(cJSON_IsObject(cJSON_GetObjectItem(jm, "metallic")));
    assert_int_equal(cJSON_GetArraySize(cJSON_GetObjectItem(jm, "per_view")), 3);
    cJSON_Delete(json);
    esr_eval_result_free(&res);
    free(idx);
    esr_model_free(&m);
    esr_dataset_free(&ds);
}

static void test_resume_after_interruption_is_exact(void **state)
{
    (void)state;
    char straight[4200], cut[4200], pa[4300], pb[4300];
    run_dir_pair(straight, cut, "coarse");
    struct esr_train_opts o;
    opts_for(&o, straight, ESR_STAGE_COARSE, NULL);
    assert_int_equal(esr_train_run(&o), 0);
    /* "killed" after coarse iteration 50: the last checkpoint is from iteration 40 */
    opts_for(&o, cut, ESR_STAGE_COARSE, NULL);
    o.stop_test_iter = 50;
    o.stop_test_stage = ESR_STAGE_COARSE;
    assert_int_equal(esr_train_run(&o), 0);
    snprintf(pb, sizeof pb, "%s/ckpt_coarse.bin", cut);
    struct esr_model mid;
    assert_int_equal(esr_model_load(&mid, pb), 0);
    assert_int_equal(mid.stage, ESR_STAGE_COARSE);
    assert_int_equal(mid.step, 40);
    assert_int_equal(mid.stage_done, 0);
    /* inv-s is part of the restored state: 5 + 40 / 1 (a loaded model must render as trained) */
    assert_float_equal(mid.inv_s, 45.0f, 1e-5f);
    esr_model_free(&mid);
    opts_for(&o, cut, ESR_STAGE_COARSE, NULL);
    o.resume = 1;
    o.cfg.coarse.iters = 5; /* ignored: a resumed run uses the run's config.json */
    assert_int_equal(esr_train_run(&o), 0);
    snprintf(pa, sizeof pa, "%s/ckpt_coarse.bin", straight);
    assert_same_model(pa, pb);
}

/* A checkpoint trained over another scene box than the dataset's (a run begun before non-cubic
 * boxes were widened to cubes) is refused on resume: its grids lie over its own box. */
static void test_resume_refuses_another_box(void **state)
{
    (void)state;
    char run[4300], data[4300], cmd[24000];
    snprintf(run, sizeof run, "%s/run_box", test_tmpdir);
    snprintf(data, sizeof data, "%s/data_box", test_tmpdir);
    snprintf(cmd, sizeof cmd, "mkdir -p '%s' && cp '%s'/runs/full/ckpt_alphamask.bin '%s'/ && cp -r '%s' '%s'",
             run, tiny_dir, run, data_dir, data);
    assert_int_equal(system(cmd), 0);
    snprintf(cmd, sizeof cmd, "%s/scene.json", data);
    assert_int_equal(test_write_file(cmd, "{\"bounding_box\": {\"min\": [-1, -1, -1], \"max\": [1, 1, 2]}}"), 0);
    struct esr_train_opts o;
    struct log_capture lc;
    opts_for(&o, run, ESR_STAGE_COARSE, &lc);
    o.data_dir = data;
    o.resume = 1;
    assert_int_not_equal(esr_train_run(&o), ESR_OK);
    if (!strstr(esr_error_message(), "was trained over the scene box"))
        fail_msg("%s", esr_error_message());
    assert_non_null(strstr(lc.text, "bounding box is not a cube"));
    esr_error_clear();
}

/* --set on resume (esr_train_opts.resume_set): applied over the run's config.json for the stages
 * still to train and written back; a set that fails the cross-option check is refused with the
 * file unchanged; on the command line another --preset with --resume is refused, not ignored. */
static void test_resume_applies_set(void **state)
{
    (void)state;
    char run[4300], cmd[9000], out[4096], cfg_path[4400];
    snprintf(run, sizeof run, "%s/resume_set", test_tmpdir);
    /* from the straight run of test_resume_after_interruption_is_exact */
    snprintf(cmd, sizeof cmd, "mkdir -p '%s' && cp '%s'/straight_coarse/config.json '%s'/straight_coarse/ckpt_alphamask.bin '%s'/",
             run, test_tmpdir, test_tmpdir, run);
    assert_int_equal(system(cmd), 0);
    snprintf(cfg_path, sizeof cfg_path, "%s/config.json", run);
    struct esr_train_opts o;
    struct log_capture lc;
    const char *sets[] = {"coarse.iters=7"};
    opts_for(&o, run, ESR_STAGE_COARSE, &lc);
    o.resume = 1;
    o.resume_set = sets;
    o.n_resume_set = 1;
    if (esr_train_run(&o) != ESR_OK)
        fail_msg("%s", esr_error_message());
    assert_non_null(strstr(lc.text, "resume: coarse.iters=7"));
    assert_null(strstr(lc.text, "earlier stages were trained on")); /* no record yet */
    struct esr_train_config c;
    esr_config_defaults(&c, ESR_PRESET_FAST);
    assert_int_equal(esr_config_load_json(&c, cfg_path), ESR_OK);
    assert_int_equal(c.coarse.iters, 7);
    assert_checkpoint(run, "coarse", 7, 1);
    /* resumed on another dataset than the run's record names (a folder that exists): said; a
     * recorded folder that is gone is data that moved: nothing to say */
    char record[4400], other[4600];
    snprintf(record, sizeof record, "%s/run.json", run);
    snprintf(other, sizeof other, "{\"data\": \"%s\"}", test_tmpdir);
    assert_int_equal(test_write_file(record, other), 0);
    opts_for(&o, run, ESR_STAGE_COARSE, &lc);
    o.resume = 1;
    assert_int_equal(esr_train_run(&o), ESR_OK);
    snprintf(other, sizeof other, "earlier stages were trained on %s;", test_tmpdir);
    assert_non_null(strstr(lc.text, other));
    assert_int_equal(test_write_file(record, "{\"data\": \"/elsewhere/moved_away\"}"), 0);
    opts_for(&o, run, ESR_STAGE_COARSE, &lc);
    o.resume = 1;
    assert_int_equal(esr_train_run(&o), ESR_OK);
    assert_null(strstr(lc.text, "earlier stages were trained on"));
    const char *bad[] = {"lts_split=1"}; /* without lobe directions */
    opts_for(&o, run, ESR_STAGE_COARSE, NULL);
    o.resume = 1;
    o.resume_set = bad;
    o.n_resume_set = 1;
    assert_int_equal(esr_train_run(&o), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "lts_split 1 needs"));
    esr_error_clear();
    esr_config_defaults(&c, ESR_PRESET_FAST);
    assert_int_equal(esr_config_load_json(&c, cfg_path), ESR_OK);
    assert_int_equal(c.lts_split, 0);
    assert_int_equal(c.coarse.iters, 7);
    snprintf(cmd, sizeof cmd, "train '%s' --out '%s' --resume --preset paper --until coarse", data_dir, run);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
    assert_non_null(strstr(out, "another --preset or a --config would not apply"));
    /* an option of a finished stage: said to change nothing */
    const char *late[] = {"coarse.iters=9"};
    opts_for(&o, run, ESR_STAGE_COARSE, &lc);
    o.resume = 1;
    o.resume_set = late;
    o.n_resume_set = 1;
    assert_int_equal(esr_train_run(&o), ESR_OK);
    assert_non_null(strstr(lc.text, "coarse.iters=9 changes nothing: stage coarse is finished"));
    /* the run's own preset again, as esr demo names it: accepted (the stage is done: no work) */
    snprintf(cmd, sizeof cmd, "train '%s' --out '%s' --resume --preset fast --until coarse", data_dir, run);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 0);
    /* trained again without --resume, only to alphamask: the earlier run's coarse checkpoint
     * goes (it used to stay, and be resumed, rendered and evaluated as this run's) */
    opts_for(&o, run, ESR_STAGE_ALPHAMASK, &lc);
    /* a forgotten --resume is refused, the run left as it was; --force starts over */
    assert_int_equal(esr_train_run(&o), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "add --resume to continue the run in it, or --force"));
    esr_error_clear();
    snprintf(cmd, sizeof cmd, "%s/ckpt_coarse.bin", run);
    assert_true(esr_file_exists(cmd));
    opts_for(&o, run, ESR_STAGE_ALPHAMASK, &lc);
    o.force = 1;
    if (esr_train_run(&o) != ESR_OK)
        fail_msg("%s", esr_error_message());
    assert_non_null(strstr(lc.text, "starting over: removed the earlier run's checkpoints"));
    assert_non_null(strstr(lc.text, "ckpt_alphamask.bin, ckpt_coarse.bin"));
    snprintf(cmd, sizeof cmd, "%s/ckpt_coarse.bin", run);
    assert_false(esr_file_exists(cmd));
    snprintf(cmd, sizeof cmd, "%s/ckpt_alphamask.bin", run);
    assert_true(esr_file_exists(cmd));
    /* its metrics start afresh: no coarse line from the earlier run */
    unsigned char *jl;
    size_t n_jl;
    snprintf(cmd, sizeof cmd, "%s/train_log.jsonl", run);
    assert_int_equal(esr_file_read_all(cmd, &jl, &n_jl), ESR_OK); /* NUL-terminated */
    assert_null(strstr((char *)jl, "\"coarse\""));
    assert_non_null(strstr((char *)jl, "\"alphamask\""));
    free(jl);
}

/* An interrupt (the CLI's Ctrl-C handler sets the flag): raised while training, the stage saves
 * its checkpoint at the step it reached, the run ends saying so, and --resume finishes it;
 * raised before training began, the run is refused with RUN as it was. */
static volatile sig_atomic_t interrupt_flag;

static void interrupt_at_first_step(void *user, const struct esr_train_progress *p)
{
    (void)user;
    if (p->event == ESR_TRAIN_MESSAGE && strstr(p->message, "stage alphamask: iterations"))
        interrupt_flag = 1; /* as a Ctrl-C during the first step would */
}

static void test_interrupt_saves_and_resumes(void **state)
{
    (void)state;
    char run[4300], path[4400];
    snprintf(run, sizeof run, "%s/interrupted", test_tmpdir);
    struct esr_train_opts o;
    opts_for(&o, run, ESR_STAGE_COARSE, NULL);
    o.report = interrupt_at_first_step;
    o.interrupt = &interrupt_flag;
    interrupt_flag = 0;
    assert_int_equal(esr_train_run(&o), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "interrupted at alphamask iteration 1"));
    esr_error_clear();
    assert_checkpoint(run, "alphamask", 1, 0);
    snprintf(path, sizeof path, "%s/ckpt_alphamask.bin", run);
    /* raised before training began (a fresh start would remove this checkpoint): refused */
    opts_for(&o, run, ESR_STAGE_COARSE, NULL);
    o.interrupt = &interrupt_flag;
    o.force = 1;
    assert_int_equal(esr_train_run(&o), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "interrupted before training began"));
    esr_error_clear();
    assert_true(esr_file_exists(path));
    interrupt_flag = 0;
    opts_for(&o, run, ESR_STAGE_COARSE, NULL);
    o.resume = 1;
    o.interrupt = &interrupt_flag;
    if (esr_train_run(&o) != ESR_OK)
        fail_msg("%s", esr_error_message());
    assert_checkpoint(run, "coarse", -1, 1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_tiny_reaches_psnr),
        cmocka_unit_test(test_resume_after_interruption_is_exact),
        cmocka_unit_test(test_resume_applies_set),
        cmocka_unit_test(test_resume_refuses_another_box),
        cmocka_unit_test(test_interrupt_saves_and_resumes),
    };
    return cmocka_run_group_tests(tests, tiny_setup, test_teardown_tmpdir);
}
