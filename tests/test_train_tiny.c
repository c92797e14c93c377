/* Training end to end on a tiny path-traced dataset (`esr synth --res 24`): the three stages
 * reach a fixed held-out PSNR, write their files, resume after an interruption to bitwise the
 * same parameters, survive an injected NaN (reload + halved lr) and stop after repeated ones
 * with the checkpoint intact; corrupt checkpoints are refused with a clear message. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cjson/cJSON.h>

#include "core/colour.h"
#include "core/error.h"
#include "io/file.h"
#include "io/image.h"
#include "io/json_file.h"
#include "test_support.h"
#include "model/material_fields.h"
#include "model/model.h"
#include "eval/evaluate.h"
#include "eval/quick_eval.h"
#include "eval/select.h"
#include "edit/editor.h"
#include "edit/finetune.h"
#include "io/dataset.h"
#include "io/dir.h"
#include "render/view.h"
#include "train/trainer.h"

static char data_dir[4096];

static int group_setup(void **state)
{
    test_setup_tmpdir(state);
    snprintf(data_dir, sizeof data_dir, "%s/data", test_tmpdir);
    char args[4300], out[4096];
    snprintf(args, sizeof args, "synth --res 24 --spp 4 --train 16 --test 3 %s", data_dir);
    return test_run_esr(args, out, sizeof out) == 0 ? 0 : -1;
}

static void tiny_config(struct esr_train_config *c)
{
    esr_config_defaults(c, ESR_PRESET_FAST);
    c->threads = 1; /* deterministic speed on a loaded machine; results do not depend on it */
    c->batch_rays = 512;
    c->log_every = 20;
    c->save_every = 20;
    c->alphamask.res = 24;
    c->alphamask.iters = 150;
    c->coarse.res = 24;
    c->coarse.iters = 300;
    c->coarse.lr_grid = 2e-2f;
    c->coarse.feat_channels = 6;
    c->coarse.mlp_width = 32;
    c->coarse.s_div = 1.0f;
    c->fine.res = 32;
    c->fine.iters = 300;
    c->fine.mlp_width = 32;
    c->fine.mlp_depth = 2;
    c->fine.s_div = 1.0f;
    c->tone_width = 16;
    c->lts.res = 32;
    c->lts.iters = 60;
    c->pdra.res = 32;
    c->pdra.iters = 40;
    c->lts_points = 64;
    c->lts_dirs = 16;
    c->field_width = 16;
}

struct log_capture {
    char text[16384];
    size_t len;
    int stages_done; /* ESR_TRAIN_STAGE_DONE events with a positive time */
};

static void capture(void *user, const struct esr_train_progress *p)
{
    struct log_capture *lc = user;
    if (p->event == ESR_TRAIN_STAGE_DONE && p->seconds > 0.0 && p->iter == p->iters)
        lc->stages_done++;
    if (p->event == ESR_TRAIN_MESSAGE && lc->len < sizeof lc->text - 1)
        lc->len += (size_t)snprintf(lc->text + lc->len, sizeof lc->text - lc->len, "%s\n",
                                    p->message);
}

/* RUN/ckpt_<stage>.bin loads and holds step `step` (-1: any) and the finished flag `done` (-1:
 * either). */
static void assert_checkpoint(const char *run, const char *stage, long step, int done)
{
    char path[4400];
    snprintf(path, sizeof path, "%s/ckpt_%s.bin", run, stage);
    struct esr_model m;
    if (esr_model_load(&m, path) != ESR_OK)
        fail_msg("%s", esr_error_message());
    if (step >= 0)
        assert_int_equal(m.step, step);
    if (done >= 0)
        assert_int_equal(m.stage_done, done);
    esr_model_free(&m);
}

static void opts_for(struct esr_train_opts *o, const char *run, enum esr_stage until,
                     struct log_capture *lc)
{
    memset(o, 0, sizeof(*o));
    o->data_dir = data_dir;
    o->run_dir = run;
    o->until = until;
    o->nan_test_iter = -1;
    tiny_config(&o->cfg);
    if (lc) {
        lc->len = 0;
        lc->stages_done = 0;
        lc->text[0] = '\0';
        o->report = capture;
        o->user = lc;
    }
}

static void test_tiny_reaches_psnr(void **state)
{
    (void)state;
    char run[4200], path[4300];
    snprintf(run, sizeof run, "%s/runs/full", test_tmpdir); /* runs/ does not exist yet */
    struct esr_train_opts o;
    struct log_capture lc;
    opts_for(&o, run, ESR_STAGE_LTS, &lc);
    if (esr_train_run(&o) != ESR_OK)
        fail_msg("%s", esr_error_message());
    assert_int_equal(lc.stages_done, ESR_STAGE_LTS + 1);
    const char *files[] = {"config.json", "train_log.jsonl", "ckpt_alphamask.bin",
                           "ckpt_coarse.bin", "ckpt_fine.bin", "ckpt_lts.bin"};
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        snprintf(path, sizeof path, "%s/%s", run, files[i]);
        assert_true(esr_file_exists(path));
    }
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

/* Parameters of two checkpoints are bitwise equal. */
static void assert_same_model(const char *a, const char *b)
{
    struct esr_model ma, mb;
    assert_int_equal(esr_model_load(&ma, a), 0);
    assert_int_equal(esr_model_load(&mb, b), 0);
    assert_int_equal(ma.params.count, mb.params.count);
    assert_int_equal(ma.step, mb.step);
    assert_memory_equal(ma.params.w, mb.params.w, ma.params.count * sizeof(float));
    assert_memory_equal(ma.adam.v, mb.adam.v, ma.params.count * sizeof(float));
    esr_model_free(&ma);
    esr_model_free(&mb);
}

/* The run folders of a straight run and of one that is stopped and resumed. */
static void run_dir_pair(char straight[4200], char cut[4200], const char *test)
{
    snprintf(straight, 4200, "%s/straight_%s", test_tmpdir, test);
    snprintf(cut, 4200, "%s/cut_%s", test_tmpdir, test);
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

/* A run stopped at a stage's end (--until fine) and resumed trains the later stages exactly as
 * a run that never stopped: the in-memory model carries nothing into them that its checkpoint
 * does not (the fine model's inv-s was one step behind: lts renders it for the environment map's
 * starting level, so every lts parameter came out a few ulp off). */
static void test_resume_at_stage_boundary_is_exact(void **state)
{
    (void)state;
    char straight[4200], cut[4200], pa[4300], pb[4300];
    run_dir_pair(straight, cut, "boundary");
    struct esr_train_opts o;
    opts_for(&o, straight, ESR_STAGE_PDRA, NULL);
    assert_int_equal(esr_train_run(&o), 0);
    opts_for(&o, cut, ESR_STAGE_FINE, NULL);
    assert_int_equal(esr_train_run(&o), 0);
    opts_for(&o, cut, ESR_STAGE_PDRA, NULL);
    o.resume = 1;
    assert_int_equal(esr_train_run(&o), 0);
    const char *stages[] = {"lts", "pdra"};
    for (int i = 0; i < 2; i++) {
        snprintf(pa, sizeof pa, "%s/ckpt_%s.bin", straight, stages[i]);
        snprintf(pb, sizeof pb, "%s/ckpt_%s.bin", cut, stages[i]);
        assert_same_model(pa, pb);
    }
}

/* Killed inside lts and again inside pdra (the last checkpoints at lts step 20 and pdra step 20
 * of 60 and 40, saved every 20) and resumed each time: both stages end exactly as in the straight
 * run of test_resume_at_stage_boundary_is_exact. The LTS normals are a smoothed copy of the SDF,
 * refreshed every 50 steps; a resumed stage computes them from the checkpoint's SDF, so the
 * straight run must refresh them where it saves a checkpoint too (before, a run resumed at lts
 * step 20 used step-20 normals where the straight run used step 0's until step 50). */
static void test_resume_inside_lts_and_pdra_is_exact(void **state)
{
    (void)state;
    char straight[4200], cut[4200], pa[4300], pb[4300], cmd[16384];
    run_dir_pair(straight, cut, "boundary"); /* the straight run trained to pdra */
    snprintf(cut, sizeof cut, "%s/cut_inside", test_tmpdir);
    const char *from_straight[] = {"config.json", "ckpt_alphamask.bin", "ckpt_coarse.bin",
                                   "ckpt_fine.bin"};
    for (int i = 0; i < 4; i++) {
        snprintf(cmd, sizeof cmd, "mkdir -p '%s' && cp '%s/%s' '%s/'", cut, straight,
                 from_straight[i], cut);
        assert_int_equal(system(cmd), 0);
    }
    const enum esr_stage stop_in[] = {ESR_STAGE_LTS, ESR_STAGE_PDRA};
    struct esr_train_opts o;
    for (int i = 0; i < 2; i++) {
        opts_for(&o, cut, ESR_STAGE_PDRA, NULL);
        o.resume = 1;
        o.stop_test_stage = stop_in[i];
        o.stop_test_iter = 30;
        if (esr_train_run(&o) != ESR_OK)
            fail_msg("%s", esr_error_message());
        snprintf(pb, sizeof pb, "%s/ckpt_%s.bin", cut, esr_stage_name(stop_in[i]));
        struct esr_model mid;
        assert_int_equal(esr_model_load(&mid, pb), 0);
        assert_int_equal(mid.step, 20);
        assert_int_equal(mid.stage_done, 0);
        esr_model_free(&mid);
    }
    opts_for(&o, cut, ESR_STAGE_PDRA, NULL);
    o.resume = 1;
    if (esr_train_run(&o) != ESR_OK)
        fail_msg("%s", esr_error_message());
    for (int i = 0; i < 2; i++) {
        snprintf(pa, sizeof pa, "%s/ckpt_%s.bin", straight, esr_stage_name(stop_in[i]));
        snprintf(pb, sizeof pb, "%s/ckpt_%s.bin", cut, esr_stage_name(stop_in[i]));
        assert_same_model(pa, pb);
    }
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
             run, test_tmpdir, run, data_dir, data);
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
                 test_tmpdir, test_tmpdir, test_tmpdir, run);
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
             "'%s'/runs/full/run.json '%s'/", run, notds, test_tmpdir, test_tmpdir, run);
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

static void test_corrupt_checkpoints_are_refused(void **state)
{
    (void)state;
    char src[4300], bad[4300];
    snprintf(src, sizeof src, "%s/runs/full/ckpt_coarse.bin", test_tmpdir);
    unsigned char *data;
    size_t size;
    assert_int_equal(esr_file_read_all(src, &data, &size), 0);
    snprintf(bad, sizeof bad, "%s/truncated.bin", test_tmpdir);
    assert_int_equal(esr_file_write_atomic(bad, data, size / 2), 0);
    struct esr_model m;
    esr_error_clear();
    assert_int_equal(esr_model_load(&m, bad), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "truncated"));
    esr_error_clear();
    data[0] = 'X';
    snprintf(bad, sizeof bad, "%s/magic.bin", test_tmpdir);
    assert_int_equal(esr_file_write_atomic(bad, data, size), 0);
    assert_int_equal(esr_model_load(&m, bad), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "not an esr checkpoint"));
    esr_error_clear();
    free(data);
    assert_int_equal(esr_model_load(&m, test_tmpdir), ESR_ERR); /* no checkpoint in it */
    assert_non_null(strstr(esr_error_message(), "no checkpoint"));
    esr_error_clear();
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
                     test_tmpdir, run);
            assert_int_equal(system(cmd), 0);
        }
        if (k == 1) { /* the geometry from the full run; no lights-off images: a fresh run */
            snprintf(cmd, sizeof cmd,
                     "mkdir -p '%s' && cp '%s'/runs/full/ckpt_alphamask.bin "
                     "'%s'/runs/full/ckpt_coarse.bin '%s'/runs/full/ckpt_fine.bin '%s'/",
                     run, test_tmpdir, test_tmpdir, test_tmpdir, run);
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

/* The pdra stage, continuing the full run's lts checkpoint, ends by finding the lights and
 * storing them in its checkpoint; `esr lights` lists them and writes them to --json. */
/* dst: a copy of run's config.json, run.json and ckpt_pdra.bin, the checkpoint changed by
 * `change`. */
static void copy_run_changed(const char *run, const char *dst, void (*change)(struct esr_model *))
{
    char cmd[24576];
    snprintf(cmd, sizeof cmd, "mkdir -p '%s' && cp '%s'/config.json '%s'/run.json '%s'/", dst, run,
             run, dst);
    assert_int_equal(system(cmd), 0);
    struct esr_model m;
    snprintf(cmd, sizeof cmd, "%s/ckpt_pdra.bin", run);
    assert_int_equal(esr_model_load(&m, cmd), ESR_OK);
    change(&m);
    snprintf(cmd, sizeof cmd, "%s/ckpt_pdra.bin", dst);
    assert_int_equal(esr_model_save(&m, cmd), ESR_OK);
    esr_model_free(&m);
}

static void make_unfinished(struct esr_model *m)
{
    m->stage_done = 0;
    m->step = 20;
}

static void remove_lights(struct esr_model *m)
{
    esr_lights_free(&m->lights);
}

/* `esr edit` of every light on run fails saying `message`, and out_dir is not created. */
static void expect_edit_refused(const char *run, const char *out_dir, const char *message)
{
    char cmd[16384], out[8192];
    snprintf(cmd, sizeof cmd, "edit %s --light all --intensity 0 --out %s --orbit 1", run, out_dir);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
    if (!strstr(out, message))
        fail_msg("esr %s: expected '%s' in:\n%s", cmd, message, out);
    assert_false(esr_file_exists(out_dir));
}

static void test_pdra_finds_lights(void **state)
{
    (void)state;
    char run[4300], cmd[24000], out[8192];
    snprintf(run, sizeof run, "%s/run_pdra", test_tmpdir);
    snprintf(cmd, sizeof cmd, "mkdir -p '%s' && cp '%s'/runs/full/ckpt_*.bin '%s'/", run, test_tmpdir,
             run);
    assert_int_equal(system(cmd), 0);
    struct esr_train_opts o;
    struct log_capture lc;
    opts_for(&o, run, ESR_STAGE_PDRA, &lc);
    o.resume = 1;
    if (esr_train_run(&o) != ESR_OK)
        fail_msg("%s", esr_error_message());
    print_message("%s", strstr(lc.text, "lights found") ? strstr(lc.text, "lights found") : lc.text);
    assert_non_null(strstr(lc.text, "lights found: "));
    /* checkpoints but no config.json: --resume says it resumes them with the options given */
    assert_non_null(strstr(lc.text, "has no config.json: its checkpoints (ckpt_alphamask.bin"));
    assert_non_null(strstr(lc.text, "are resumed with the options given now"));
    struct esr_model m;
    snprintf(cmd, sizeof cmd, "%s/ckpt_pdra.bin", run);
    assert_int_equal(esr_model_load(&m, cmd), ESR_OK);
    assert_true(m.lights.n >= 0 && m.lights.n <= ESR_MAX_LIGHTS);
    for (int i = 0; i < m.lights.n; i++) {
        const struct esr_light *l = &m.lights.light[i];
        assert_true(l->points > 0 && l->area > 0.0f);
        for (int c = 0; c < 3; c++)
            assert_true(isfinite(l->scale[c]) && l->scale[c] >= 0.0f);
    }
    snprintf(cmd, sizeof cmd, "lights %s --data /nonexistent", run);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
    assert_non_null(strstr(out, "--data is read only with --recompute"));
    snprintf(cmd, sizeof cmd, "lights %s --json %s/lights.json", run, run); /* listing alone writes nothing */
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 0);
    snprintf(cmd, sizeof cmd, "%d light", m.lights.n);
    assert_non_null(strstr(out, cmd));
    snprintf(cmd, sizeof cmd, "%s/lights.json", run);
    unsigned char *text;
    size_t size;
    assert_int_equal(esr_file_read_all(cmd, &text, &size), ESR_OK);
    cJSON *root = cJSON_ParseWithLength((const char *)text, size);
    free(text);
    assert_non_null(root);
    assert_int_equal(cJSON_GetArraySize(cJSON_GetObjectItem(root, "lights")), m.lights.n);
    long unseen[ESR_MAX_LIGHTS];
    esr_lights_unseen_points(&m.lights, unseen);
    for (int i = 0; i < m.lights.n; i++) { /* whether its strength was fitted; its unseen part */
        const cJSON *lt = cJSON_GetArrayItem(cJSON_GetObjectItem(root, "lights"), i);
        const cJSON *f = cJSON_GetObjectItem(lt, "strength_fitted");
        assert_true(cJSON_IsBool(f));
        assert_int_equal(cJSON_IsTrue(f), esr_light_strength_fitted(&m.lights, i));
        const cJSON *u = cJSON_GetObjectItem(lt, "unseen_points");
        assert_true(cJSON_IsNumber(u));
        assert_true(u->valuedouble == (double)unseen[i] && unseen[i] <= m.lights.light[i].points);
    }
    cJSON_Delete(root);

    /* the relightable glTF: one node per light, and valid for the Khronos validator */
    char glb[4400];
    snprintf(glb, sizeof glb, "%s/scene.glb", test_tmpdir);
    snprintf(cmd, sizeof cmd, "export %s --gltf %s", run, glb);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 0);
    snprintf(cmd, sizeof cmd, "%d light node(s)", m.lights.n);
    assert_non_null(strstr(out, cmd));
    /* at a coarse --res a light may get no triangle: then it is said, and not counted */
    snprintf(cmd, sizeof cmd, "export %s --gltf %s --res 8", run, glb);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 0);
    int nodes = -1, unsaid = 0;
    const char *said = strstr(out, "the surface and ");
    assert_non_null(said);
    assert_int_equal(sscanf(said, "the surface and %d light node(s)", &nodes), 1);
    for (const char *w = out; (w = strstr(w, "has no triangle at this resolution")); w++)
        unsaid++;
    print_message("glTF at --res 8: %d light node(s), %d without\n", nodes, unsaid);
    assert_int_equal(nodes + unsaid, m.lights.n);
    snprintf(cmd, sizeof cmd, "export %s --gltf %s", run, glb); /* the full one, validated below */
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 0);
    if (esr_file_exists(ESR_GLTF_VALIDATOR "/package.json")) {
        snprintf(cmd, sizeof cmd, "node '%s/validate_gltf.js' '%s' '%s' 2>&1", ESR_TEST_SUPPORT_DIR,
                 ESR_GLTF_VALIDATOR, glb);
        FILE *pipe = popen(cmd, "r");
        assert_non_null(pipe);
        size_t got = fread(out, 1, sizeof out - 1, pipe);
        out[got] = '\0';
        const int status = pclose(pipe);
        print_message("%s", out);
        assert_int_equal(status, 0);
        assert_non_null(strstr(out, " 0 errors"));
    } else {
        print_message("SKIPPED the glTF validation: %s is not installed (make test-tools)\n",
                      ESR_GLTF_VALIDATOR);
    }

    /* esr edit refuses bad edits with a clear message and writes nothing */
    static const struct {
        const char *args, *message;
    } bad[] = {
        {"--light 15 --intensity 0", "no light 15"},
        {"--light all --intensity -1", "--intensity: expected a number >= 0 and at most"},
        {"--light all --intensity nan", "--intensity: expected a number >= 0 and at most"},
        {"--light all --intensity 0x10", "--intensity: expected a number >= 0 and at most"},
        {"--light all --intensity ' 1'", "--intensity: expected a number >= 0 and at most"},
        {"--light +0 --intensity 2", "--light: expected a light id"},
        {"--light 0 --color 1.5,0.2", "--color: expected H,S with both in [0,1]"},
        {"--light 0 --method relit", "--method: expected direct, ratio or finetune"},
        {"--light 0 --method finetune --iters 0", "--iters: expected 1..1000000"},
        {"--light 0 --intensity 2 --iters 5", "--iters is read only with --method finetune"},
        {"--light 0 --intensity 2 --frames c000_on", "--frames and --orbit exclude each other"},
        {"--light 0 --intensity 2 --spp 2 --spp 3", "--spp given twice"},
        {"--light 0 --intensity 2 --intensity 3", "--intensity given twice after one --light"},
        {"--intensity 2", "--intensity before any --light"},
        {"--light all --intensity 1e40", "--intensity: expected a number >= 0 and at most"},
        {"--light 0 --intensity 2 --light 1", "--light 1 has no --intensity or --color"},
    };
    char edit_out[4400];
    snprintf(edit_out, sizeof edit_out, "%s/edit_bad", test_tmpdir);
    /* a run whose pdra stage never ran (the full run stops after lts) */
    snprintf(cmd, sizeof cmd, "edit %s/runs/full --light 0 --intensity 0 --out %s --orbit 1",
             test_tmpdir, edit_out);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
    assert_non_null(strstr(out, "has no pdra checkpoint"));
    assert_false(esr_file_exists(edit_out));
    snprintf(cmd, sizeof cmd, "lights %s/runs/full", test_tmpdir);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
    assert_non_null(strstr(out, "has no pdra checkpoint"));
    /* a pdra stage stopped before its end (its periodic checkpoint) */
    char unfinished[4400];
    snprintf(unfinished, sizeof unfinished, "%s/run_pdra_unfinished", test_tmpdir);
    copy_run_changed(run, unfinished, make_unfinished);
    expect_edit_refused(unfinished, edit_out, "the pdra stage has not finished (step 20)");
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        snprintf(cmd, sizeof cmd, "edit %s %s --out %s --orbit 1", run, bad[i].args, edit_out);
        assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
        if (!strstr(out, bad[i].message))
            fail_msg("esr %s: expected '%s' in:\n%s", cmd, bad[i].message, out);
        assert_false(esr_file_exists(edit_out));
    }

    /* lights too dim for the threshold: the pdra stage ends with none and says so (decided over
     * the whole surface the cameras see, not over the last batch's rays) */
    char dim_run[4400];
    snprintf(dim_run, sizeof dim_run, "%s/run_dim", test_tmpdir);
    snprintf(cmd, sizeof cmd, "mkdir -p '%s' && cp '%s'/runs/full/ckpt_*.bin '%s'/", dim_run,
             test_tmpdir, dim_run);
    assert_int_equal(system(cmd), 0);
    opts_for(&o, dim_run, ESR_STAGE_PDRA, &lc);
    o.resume = 1;
    o.cfg.pdra_k0 = o.cfg.pdra_k_end = 1e3f; /* far above any emission the field learned */
    if (esr_train_run(&o) != ESR_OK)
        fail_msg("%s", esr_error_message());
    assert_non_null(strstr(lc.text, "no emitters found: no surface point"));
    assert_null(strstr(lc.text, "lights found"));
    snprintf(cmd, sizeof cmd, "%s/ckpt_pdra.bin", dim_run);
    struct esr_model dim;
    assert_int_equal(esr_model_load(&dim, cmd), ESR_OK);
    assert_int_equal(dim.lights.n, 0);
    assert_true(dim.stage_done);
    esr_model_free(&dim);

    /* a run whose pdra stage found no emitters: `esr lights` keeps none and says so (it used to
     * search again whenever the set was empty, inventing lights), and edits are refused */
    char none_run[4400];
    snprintf(none_run, sizeof none_run, "%s/run_no_lights", test_tmpdir);
    copy_run_changed(run, none_run, remove_lights);
    struct esr_model none;
    snprintf(cmd, sizeof cmd, "lights %s", none_run);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 0);
    assert_non_null(strstr(out, "0 lights"));
    assert_non_null(strstr(out, "found no emitters"));
    snprintf(cmd, sizeof cmd, "%s/ckpt_pdra.bin", none_run);
    assert_int_equal(esr_model_load(&none, cmd), ESR_OK);
    assert_int_equal(none.lights.n, 0);
    esr_model_free(&none);
    expect_edit_refused(none_run, edit_out, "no lights");

    if (m.lights.n > 0) {
        /* a phase's off and on frames of one camera: one render, written under both names */
        char views_out[4400], a_png[4500], b_png[4500];
        snprintf(views_out, sizeof views_out, "%s/edit_views", test_tmpdir);
        snprintf(cmd, sizeof cmd, "edit %s --light 0 --intensity 0 --views test_nv --out %s", run,
                 views_out);
        if (test_run_esr(cmd, out, sizeof out) != 0)
            fail_msg("esr %s: %s", cmd, out);
        assert_non_null(strstr(out, "(the previous frame's camera: its view)"));
        snprintf(a_png, sizeof a_png, "%s/c000_off.exr", views_out);
        snprintf(b_png, sizeof b_png, "%s/c000_on.exr", views_out);
        assert_true(test_files_equal(a_png, b_png));
        /* groups add up; two that set one thing for one light are refused */
        snprintf(cmd, sizeof cmd, "edit %s --light all --intensity 0 --light 0 --intensity 2 --out "
                 "%s --orbit 1", run, edit_out);
        assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
        assert_non_null(strstr(out, "light 0 gets its --intensity from two groups (--light all "
                                    "and --light 0)"));
        assert_false(esr_file_exists(edit_out));
        /* an output folder inside the dataset or the run's renders would replace their files */
        const char *inside[2] = {data_dir, run};
        for (int k = 0; k < 2; k++) {
            snprintf(cmd, sizeof cmd, "edit %s --light 0 --intensity 2 --out %s/%s --orbit 1", run,
                     inside[k], k ? "render/test_nv" : "test_nv");
            assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
            if (!strstr(out, k ? "lies inside the run's render folder" : "lies inside the dataset"))
                fail_msg("esr %s: %s", cmd, out);
        }
        /* a view that cannot be written: the views written before it are removed */
        char blocked[4400];
        snprintf(blocked, sizeof blocked, "%s/edit_blocked/orbit_001.png", test_tmpdir);
        assert_int_equal(esr_dir_create(blocked), ESR_OK);
        snprintf(cmd, sizeof cmd, "edit %s --light all --color 0.6,1 --light 0 --intensity 2 --out "
                 "%s/edit_blocked --orbit 3", run, test_tmpdir);
        assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
        assert_non_null(strstr(out, "orbit_001.png"));
        const char *gone[3] = {"orbit_000.exr", "orbit_000.png", "orbit_001.exr"};
        for (int k = 0; k < 3; k++) {
            snprintf(cmd, sizeof cmd, "%s/edit_blocked/%s", test_tmpdir, gone[k]);
            assert_false(esr_file_exists(cmd));
        }
        /* an output folder that cannot be created */
        snprintf(cmd, sizeof cmd, "edit %s --light all --intensity 0 --out /proc/esr_cannot --orbit 1",
                 run);
        assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
        assert_non_null(strstr(out, "/proc/esr_cannot"));
        /* every light off, and doubled: the direct part is linear in the intensity */
        char off_dir[4400], one_dir[4400], two_dir[4400];
        const char *dirs[3] = {off_dir, one_dir, two_dir}, *gain[3] = {"0", "1", "2"};
        snprintf(off_dir, sizeof off_dir, "%s/edit_off", test_tmpdir);
        snprintf(one_dir, sizeof one_dir, "%s/edit_one", test_tmpdir);
        snprintf(two_dir, sizeof two_dir, "%s/edit_two", test_tmpdir);
        struct esr_image img[3];
        for (int k = 0; k < 3; k++) {
            snprintf(cmd, sizeof cmd, "edit %s --light all --intensity %s --out %s --orbit 2",
                     run, gain[k], dirs[k]);
            assert_int_equal(test_run_esr(cmd, out, sizeof out), 0);
            snprintf(cmd, sizeof cmd, "%s/orbit_001.exr", dirs[k]);
            assert_int_equal(esr_exr_read(cmd, &img[k]), ESR_OK);
        }
        double worst = 0.0;
        for (size_t p = 0; p < (size_t)img[0].width * img[0].height; p++)
            for (int c = 0; c < 3; c++) {
                const float base = img[0].data[p * 4 + c], a = img[1].data[p * 4 + c] - base,
                            b = img[2].data[p * 4 + c] - base;
                assert_true(a >= -1e-6f); /* lights only add light */
                worst = fmax(worst, fabs(b - 2.0 * a));
            }
        print_message("edit: intensity 2 adds twice what intensity 1 adds (worst %.2g)\n", worst);
        assert_true(worst < 1e-4);
        for (int k = 0; k < 3; k++)
            esr_image_free(&img[k]);
    } else {
        snprintf(cmd, sizeof cmd, "edit %s --light all --intensity 0 --out %s --orbit 1", run, edit_out);
        assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
        assert_non_null(strstr(out, "no lights"));
    }
    esr_model_free(&m);
}

/* Lights-on (on 1) or lights-off linear render of cam into lin [w*h*3], and the light each
 * pixel sees (-1: none) into ids when not NULL. */
static void render_linear(const struct esr_model *m, const struct esr_camera *cam, int on, float *lin,
                          int32_t *ids)
{
    const size_t n = (size_t)cam->width * (size_t)cam->height;
    float *o = malloc(n * 3 * sizeof(float)), *d = malloc(n * 3 * sizeof(float));
    assert_non_null(o);
    assert_non_null(d);
    esr_camera_pixel_rays(cam, o, d);
    struct esr_render_out r = {.linear = lin, .light_id = ids};
    assert_int_equal(esr_model_render_rays(m, o, d, n, on, &r), ESR_OK);
    free(o);
    free(d);
}

/* Mean |a - b| over the pixels that see no light (what fine-tuning is responsible for: the
 * editor renders the lights themselves from their emission). */
static double mean_abs_diff_off_lights(const float *a, const float *b, const int32_t *ids, size_t px)
{
    double s = 0.0;
    size_t k = 0;
    for (size_t p = 0; p < px; p++)
        if (ids[p] < 0) {
            for (int c = 0; c < 3; c++)
                s += fabs((double)a[p * 3 + c] - b[p * 3 + c]);
            k += 3;
        }
    return k ? s / (double)k : 0.0;
}

/* The pdra run (it finds the tiny scene's lights, see above) seen from the first test_nv
 * camera: its model and dataset, and the lights-on render (with the light each pixel sees) and
 * the lights-off render of that view. */
struct pdra_view {
    struct esr_model m;
    struct esr_dataset ds;
    const struct esr_camera *cam;
    size_t px;
    float *on, *off;
    int32_t *ids;
};

static void pdra_view_open(struct pdra_view *v)
{
    char path[4400];
    snprintf(path, sizeof path, "%s/run_pdra/ckpt_pdra.bin", test_tmpdir);
    assert_int_equal(esr_model_load(&v->m, path), ESR_OK);
    assert_true(v->m.lights.n > 0);
    assert_int_equal(esr_dataset_load(data_dir, &v->ds), ESR_OK);
    v->cam = &v->ds.phases[ESR_PHASE_TEST_NV].frames[0].camera;
    v->px = (size_t)v->cam->width * (size_t)v->cam->height;
    v->on = malloc(v->px * 3 * sizeof(float));
    v->off = malloc(v->px * 3 * sizeof(float));
    v->ids = malloc(v->px * sizeof(int32_t));
    assert_non_null(v->on);
    assert_non_null(v->off);
    assert_non_null(v->ids);
    render_linear(&v->m, v->cam, 1, v->on, v->ids);
    render_linear(&v->m, v->cam, 0, v->off, NULL);
}

static void pdra_view_close(struct pdra_view *v)
{
    esr_dataset_free(&v->ds);
    free(v->on), free(v->off), free(v->ids);
    esr_model_free(&v->m);
}

/* Radiance fine-tuning (edit/finetune.h) on the pdra run: where no light is seen, an edit that
 * changes nothing leaves the lights-on render as it was (the trained model's residual is kept)
 * and every light off brings it most of the way to the lights-off render; restoring gives the
 * trained model back bit for bit. */
/* `esr demo` after its training (the run of test_pdra_finds_lights in place, so the training
 * step resumes finished stages): its later steps, lights, one edit per light, eval and export,
 * run end to end with the arguments it gives them. The demo's own scene takes ten minutes to
 * train, so only this half of it can be tested here (a --data it passed to `esr lights` was
 * refused once, and nothing but a full demo noticed). */
static void test_demo_steps_after_training(void **state)
{
    (void)state;
    char demo[4300], cmd[24576];
    static char out[1 << 18];
    snprintf(demo, sizeof demo, "%s/demo", test_tmpdir);
    snprintf(cmd, sizeof cmd, "mkdir -p '%s/run' && cp '%s'/run_pdra/config.json "
             "'%s'/run_pdra/run.json '%s'/run_pdra/ckpt_*.bin '%s/run/'", demo, test_tmpdir,
             test_tmpdir, test_tmpdir, demo);
    assert_int_equal(system(cmd), 0);
    snprintf(cmd, sizeof cmd, "demo --out '%s' --data '%s'", demo, data_dir);
    const int rc = test_run_esr(cmd, out, sizeof out);
    if (rc != 0)
        fail_msg("esr %s: exit %d:\n%s", cmd, rc, out);
    assert_non_null(strstr(out, "demo finished"));
    const char *made[] = {"run/lights.json", "run/lights.png", "run/eval/test_nv.json",
                          "run/report.html", "mesh.ply", "info.json"};
    for (size_t i = 0; i < sizeof made / sizeof made[0]; i++) {
        snprintf(cmd, sizeof cmd, "%s/%s", demo, made[i]);
        if (!esr_file_exists(cmd))
            fail_msg("esr demo did not write %s", cmd);
    }
    /* each light recoloured to the hue opposite its own (a fixed 0.6 left a blue light blue) */
    struct esr_model m;
    snprintf(cmd, sizeof cmd, "%s/run/ckpt_pdra.bin", demo);
    assert_int_equal(esr_model_load(&m, cmd), ESR_OK);
    int recoloured = 0;
    for (int k = 0; k < m.lights.n; k++) {
        const float *rgb = m.lights.light[k].radiance;
        if (!(rgb[0] > 0.0f || rgb[1] > 0.0f || rgb[2] > 0.0f))
            continue;
        float hsv[3];
        esr_rgb_to_hsv(rgb, hsv);
        snprintf(cmd, sizeof cmd, "--light %d --color %.3f,1 ", k, fmod((double)hsv[0] + 0.5, 1.0));
        if (!strstr(out, cmd))
            fail_msg("esr demo: no '%s' (light %d's hue %.3f) in its output", cmd, k, (double)hsv[0]);
        recoloured++;
    }
    esr_model_free(&m);
    assert_true(recoloured > 0);
    /* light 0 off and recoloured, as PNG and EXR */
    snprintf(cmd, sizeof cmd, "ls '%s'/run/edits/light0_off/*.png '%s'/run/edits/light0_off/*.exr "
             "'%s'/run/edits/light0_recoloured/*.png > /dev/null 2>&1", demo, demo, demo);
    assert_int_equal(system(cmd), 0);
}

static void test_finetune_edits(void **state)
{
    (void)state;
    struct pdra_view v;
    pdra_view_open(&v);
    struct esr_model *m = &v.m;
    const struct esr_camera *cam = v.cam;
    const size_t px = v.px, n = px * 3;
    const float *before = v.on, *off = v.off;
    const int32_t *ids = v.ids;
    float *after = malloc(n * sizeof(float));
    assert_non_null(after);

    struct esr_finetune_opts o;
    esr_finetune_default_opts(&o);
    o.iters = 100;
    o.rays = 128;
    o.points = 256;
    o.dirs = 8;
    o.light_spp = 4;
    float *moments_m = malloc(m->params.count * sizeof(float));
    float *moments_v = malloc(m->params.count * sizeof(float));
    assert_true(moments_m && moments_v);
    memcpy(moments_m, m->adam.m, m->params.count * sizeof(float));
    memcpy(moments_v, m->adam.v, m->params.count * sizeof(float));
    struct esr_finetune f;
    if (esr_finetune_init(&f, m, &v.ds, &o) != ESR_OK)
        fail_msg("%s", esr_error_message());
    struct esr_light_edit same[ESR_MAX_LIGHTS], dark[ESR_MAX_LIGHTS];
    for (int k = 0; k < ESR_MAX_LIGHTS; k++) {
        same[k] = (struct esr_light_edit){1.0f, 0, 0.0f, 0.0f};
        dark[k] = (struct esr_light_edit){0.0f, 0, 0.0f, 0.0f};
    }
    struct esr_finetune_stats st;
    assert_int_equal(esr_finetune_apply(&f, m, same, 7, &st), ESR_OK);
    assert_int_equal(st.iters, o.iters);
    render_linear(m, cam, 1, after, NULL);
    const double effect = mean_abs_diff_off_lights(before, off, ids, px);
    const double drift = mean_abs_diff_off_lights(after, before, ids, px);
    assert_int_equal(esr_finetune_apply(&f, m, dark, 7, &st), ESR_OK);
    render_linear(m, cam, 1, after, NULL);
    const double left = mean_abs_diff_off_lights(after, off, ids, px);
    print_message("finetune: lights' effect %.4f; unchanged edit drifts %.4f; all off leaves %.4f "
                  "(LTS MSE %.3g -> %.3g)\n", effect, drift, left, st.mse_first, st.mse_last);
    assert_true(effect > 0.0);
    assert_true(drift < 0.1 * effect);
    /* the light goes as the ratio of estimates decays (train/lts.h): 100 steps leave 30% of
     * the effect on this 24-pixel scene, whose lights explain little of its emo radiance (24%
     * with errors unweighted, this being a mean linear difference, which the sRGB-slope weights
     * do not favour; 36% without the ratio's mean floors, where points no direct light reaches
     * kept their light; 47% before the fine-tune's start, esr_finetune_start) */
    assert_true(left < 0.6 * effect);
    esr_finetune_restore(&f, m);
    render_linear(m, cam, 1, after, NULL);
    assert_memory_equal(after, before, n * sizeof(float));
    /* and the Adam moments the edit started afresh are the trained ones again */
    assert_memory_equal(m->adam.m, moments_m, m->params.count * sizeof(float));
    assert_memory_equal(m->adam.v, moments_v, m->params.count * sizeof(float));
    free(moments_m);
    free(moments_v);
    esr_finetune_free(&f);
    free(after);
    pdra_view_close(&v);
}

/* A render's linear_other (model.h) is the other lighting's linear render bit for bit, from
 * either side, with the lights' calibrated emission where lit. */
static void test_render_other_lighting(void **state)
{
    (void)state;
    struct pdra_view v;
    pdra_view_open(&v);
    const size_t px = v.px, n = px * 3;
    float *o = malloc(n * sizeof(float)), *d = malloc(n * sizeof(float));
    float *lin = malloc(n * sizeof(float)), *other = malloc(n * sizeof(float));
    assert_true(o && d && lin && other);
    esr_camera_pixel_rays(v.cam, o, d);
    for (int on = 0; on < 2; on++) {
        struct esr_render_out r = {.linear = lin, .linear_other = other};
        assert_int_equal(esr_model_render_rays(&v.m, o, d, px, on, &r), ESR_OK);
        assert_memory_equal(lin, on ? v.on : v.off, n * sizeof(float));
        assert_memory_equal(other, on ? v.off : v.on, n * sizeof(float));
    }
    assert_true(memcmp(v.on, v.off, n * sizeof(float)) != 0); /* the lights show */
    free(o), free(d), free(lin), free(other);
    pdra_view_close(&v);
}

/* lights_emitted_only (model.h): a lights-on render whose samples on a light show the lights-off
 * radiance plus the light's emission. Raising L_emo everywhere (the emo MLP's output bias +1:
 * L_emo = softplus, about x e where it is small) then barely moves the pixels whose strongest
 * sample is on a light, which the plain render moves with their L_emo; pixels with no sample on
 * a light render as without the flag, bit for bit. */
static void test_render_lights_emitted_only(void **state)
{
    (void)state;
    struct pdra_view v;
    pdra_view_open(&v);
    struct esr_model *m = &v.m;
    const size_t px = v.px, n = px * 3;
    float *o = malloc(n * sizeof(float)), *d = malloc(n * sizeof(float));
    float *lit = malloc(n * sizeof(float)), *plain[2], *only[2];
    assert_true(o && d && lit);
    for (int s = 0; s < 2; s++) {
        plain[s] = malloc(n * sizeof(float)), only[s] = malloc(n * sizeof(float));
        assert_true(plain[s] && only[s]);
    }
    esr_camera_pixel_rays(v.cam, o, d);
    const struct esr_mlp *mlp = esr_model_mlp(m, ESR_COMP_EMO_MLP);
    float *bias = m->params.w + mlp->b_off[mlp->n_layers - 1];
    for (int s = 0; s < 2; s++) {
        for (int c = 0; c < 3; c++)
            bias[c] += (float)s;
        struct esr_render_out r = {.linear = plain[s], .emitted_lights = lit};
        assert_int_equal(esr_model_render_rays(m, o, d, px, 1, &r), ESR_OK);
        struct esr_render_out f = {.linear = only[s], .lights_emitted_only = 1};
        assert_int_equal(esr_model_render_rays(m, o, d, px, 1, &f), ESR_OK);
    }
    size_t on_light = 0, untouched = 0;
    double moved_plain = 0.0, moved_only = 0.0;
    for (size_t p = 0; p < px; p++) {
        const int any_lit = lit[p * 3] != 0.0f || lit[p * 3 + 1] != 0.0f || lit[p * 3 + 2] != 0.0f;
        if (!any_lit) {
            assert_memory_equal(only[0] + p * 3, plain[0] + p * 3, 3 * sizeof(float));
            untouched++;
        }
        if (v.ids[p] < 0)
            continue;
        on_light++;
        moved_plain += plain[1][p * 3] - plain[0][p * 3];
        moved_only += only[1][p * 3] - only[0][p * 3];
    }
    print_message("lights_emitted_only: %zu pixels on a light: L_emo raised moves them %.3f (plain "
                  "%.3f); %zu pixels without a lit sample unchanged\n", on_light,
                  moved_only / (double)on_light, moved_plain / (double)on_light, untouched);
    assert_true(on_light > 0 && untouched > 0);
    assert_true(moved_plain / (double)on_light > 0.05);
    assert_true(moved_only < 0.25 * moved_plain);
    free(o), free(d), free(lit);
    for (int s = 0; s < 2; s++)
        free(plain[s]), free(only[s]);
    pdra_view_close(&v);
}

/* The fine-tune's start (edit/finetune.h) shifts only the emo MLP's output biases, by ln of the
 * lights' power ratio: 0 for an unchanged edit, ln 0.5 at half intensity, the floor ln 1e-3
 * with every light off. */
static void test_finetune_start(void **state)
{
    (void)state;
    struct pdra_view v;
    pdra_view_open(&v);
    struct esr_model *m = &v.m;
    const size_t count = m->params.count;
    float *w0 = malloc(count * sizeof(float));
    assert_non_null(w0);
    memcpy(w0, m->params.w, count * sizeof(float));
    const struct esr_mlp *mlp = esr_model_mlp(m, ESR_COMP_EMO_MLP);
    const size_t b = mlp->b_off[mlp->n_layers - 1];
    const float intensity[3] = {1.0f, 0.5f, 0.0f};
    const double want[3] = {0.0, log(0.5), log(1e-3)};
    for (int t = 0; t < 3; t++) {
        struct esr_light_edit ed[ESR_MAX_LIGHTS];
        for (int k = 0; k < ESR_MAX_LIGHTS; k++)
            ed[k] = (struct esr_light_edit){intensity[t], 0, 0.0f, 0.0f};
        memcpy(m->params.w, w0, count * sizeof(float));
        float rho[3];
        esr_finetune_start(m, ed, rho);
        for (size_t i = 0; i < count; i++) {
            const double shift = (double)m->params.w[i] - w0[i];
            if (i >= b && i < b + 3)
                assert_true(fabs(shift - want[t]) < 1e-5);
            else
                assert_true(shift == 0.0);
        }
        for (int c = 0; c < 3; c++)
            assert_true(fabs(log(rho[c]) - want[t]) < 1e-5);
    }
    memcpy(m->params.w, w0, count * sizeof(float));
    free(w0);
    pdra_view_close(&v);
}

/* The ratio method (edit/relight.h) on the pdra run: unedited it is the model's own lights-on
 * render where no light is seen; every light off leaves the lights-off render; intensity 2
 * doubles the lights' effect (the ratio of direct light is linear in the intensity). */
static void test_ratio_edits(void **state)
{
    (void)state;
    struct pdra_view v;
    pdra_view_open(&v);
    const float *on = v.on, *off = v.off;
    struct esr_editor ed;
    if (esr_editor_init(&ed, &v.m, &v.ds, ESR_EDIT_RATIO, 8, NULL) != ESR_OK)
        fail_msg("%s", esr_error_message());
    struct esr_image img[3];
    const float gain[3] = {0.0f, 1.0f, 2.0f};
    for (int g = 0; g < 3; g++) {
        struct esr_light_edit e[ESR_MAX_LIGHTS];
        for (int k = 0; k < ESR_MAX_LIGHTS; k++)
            e[k] = (struct esr_light_edit){gain[g], 0, 0.0f, 0.0f};
        assert_int_equal(esr_editor_set(&ed, e, 3), ESR_OK);
        assert_int_equal(esr_editor_view(&ed, v.cam, 3, &img[g]), ESR_OK);
    }
    double same = 0.0, dark = 0.0, lin = 0.0, effect = 0.0;
    size_t seen = 0;
    for (size_t p = 0; p < v.px; p++)
        for (int c = 0; c < 3; c++) {
            const size_t i = p * 3 + c;
            const double a = img[1].data[i] - img[0].data[i], b = img[2].data[i] - img[0].data[i];
            lin = fmax(lin, fabs(b - 2.0 * a));
            if (v.ids[p] >= 0)
                continue;
            seen += c == 0;
            same = fmax(same, fabs((double)img[1].data[i] - on[i]));
            dark = fmax(dark, fabs((double)img[0].data[i] - off[i]));
            effect = fmax(effect, fabs((double)on[i] - off[i]));
        }
    /* an edit no light can take is refused, naming the light and the value; without a recolour
     * the hue and saturation are not read */
    static const struct {
        struct esr_light_edit e;
        const char *why; /* NULL: accepted */
    } asks[] = {
        {{2e6f, 0, 0.0f, 0.0f}, "edit of light 0: intensity 2e+06 is not a number in [0, 1e+06]"},
        {{NAN, 0, 0.0f, 0.0f}, "edit of light 0: intensity nan is not a number"},
        {{-0.5f, 0, 0.0f, 0.0f}, "edit of light 0: intensity -0.5 is not a number"},
        {{1.0f, 1, 0.5f, 1.5f}, "edit of light 0: saturation 1.5 is not a number in [0, 1]"},
        {{1.0f, 1, -0.25f, 1.0f}, "edit of light 0: hue -0.25 is not a number in [0, 1]"},
        {{1.0f, 1, 0.25f, NAN}, "edit of light 0: saturation nan is not a number"},
        {{1e6f, 0, 7.0f, -3.0f}, NULL},
        {{0.0f, 1, 1.0f, 0.0f}, NULL},
    };
    for (size_t i = 0; i < sizeof asks / sizeof asks[0]; i++) {
        struct esr_light_edit e[ESR_MAX_LIGHTS];
        for (int k = 0; k < ESR_MAX_LIGHTS; k++)
            e[k] = (struct esr_light_edit){1.0f, 0, 0.0f, 0.0f};
        e[0] = asks[i].e;
        esr_error_clear();
        const int rc = esr_editor_set(&ed, e, 3);
        if (!asks[i].why) {
            assert_int_equal(rc, ESR_OK);
            continue;
        }
        assert_int_equal(rc, ESR_ERR);
        if (!strstr(esr_error_message(), asks[i].why))
            fail_msg("ask %zu: '%s' does not say '%s'", i, esr_error_message(), asks[i].why);
        struct esr_image none = {0};
        esr_error_clear();
        assert_int_equal(esr_relight_view(&ed.relight, &v.m, e, v.cam, 3, &none, NULL), ESR_ERR);
        assert_null(none.data);
    }
    esr_error_clear();
    print_message("ratio: %zu pixels see no light; lights' effect up to %.4f; unedited differs "
                  "from the lights-on render by %.2g, all off from the lights-off one by %.2g; "
                  "x2 - 2 x1 %.2g\n", seen, effect, same, dark, lin);
    assert_true(seen > 0 && effect > 0.0);
    assert_true(same < 1e-5);
    assert_true(dark < 1e-6 * (1.0 + effect));
    assert_true(lin < 1e-4 * (1.0 + effect));
    for (int g = 0; g < 3; g++)
        esr_image_free(&img[g]);
    esr_editor_free(&ed);
    pdra_view_close(&v);
}

/* A fine-tuned model's view through the editor (edit/relight.h, the model mode): where no light
 * is seen, the fine-tuned lights-on render bit for bit; where a light is seen, the lights-off
 * radiance plus the light's edited emission plus the lights' direct light, which is never
 * negative and, with light 0 off and the others x1000, lights those pixels wherever the direct
 * method does (a tiny run with one light, or its second under the floor, lights none: said). */
static void test_finetune_view(void **state)
{
    (void)state;
    struct pdra_view v;
    pdra_view_open(&v);
    struct esr_model *m = &v.m;
    const size_t px = v.px, n = px * 3;
    struct esr_finetune_opts o;
    esr_finetune_default_opts(&o);
    o.iters = 20;
    o.rays = 128;
    o.points = 256;
    o.light_spp = 4;
    struct esr_editor ed;
    if (esr_editor_init(&ed, m, &v.ds, ESR_EDIT_FINETUNE, 8, &o) != ESR_OK)
        fail_msg("%s", esr_error_message());
    /* light 0 (the view's) off, the others x1000: the tiny scene's lights are small and far
     * apart, so at x2 the light one casts on another was 1e-5 on some runs, below what the
     * check below can tell from rounding beside the lit light's own emission */
    struct esr_light_edit e[ESR_MAX_LIGHTS];
    for (int k = 0; k < ESR_MAX_LIGHTS; k++)
        e[k] = (struct esr_light_edit){k == 0 ? 0.0f : 1000.0f, 0, 0.0f, 0.0f};
    assert_int_equal(esr_editor_set(&ed, e, 5), ESR_OK);
    struct esr_image img;
    assert_int_equal(esr_editor_view(&ed, v.cam, 3, &img), ESR_OK);
    float *o3 = malloc(n * sizeof(float)), *d3 = malloc(n * sizeof(float));
    float *on = malloc(n * sizeof(float)), *off = malloc(n * sizeof(float));
    float *lit = malloc(n * sizeof(float));
    assert_true(o3 && d3 && on && off && lit);
    esr_camera_pixel_rays(v.cam, o3, d3);
    struct esr_render_out ro = {.linear = on, .lights_emitted_only = 1};
    assert_int_equal(esr_model_render_rays(m, o3, d3, px, 1, &ro), ESR_OK);
    struct esr_render_out rf = {.linear = off, .emitted_lights = lit};
    assert_int_equal(esr_model_render_rays(m, o3, d3, px, 0, &rf), ESR_OK);
    /* the direct method on the same view and edit: the light it casts on the lights' pixels is
     * what the fine-tuned view shows there (whether any falls there is the tiny run's draw: a
     * run whose second light lies under the floor lights none) */
    struct esr_editor direct;
    struct esr_image img_direct;
    if (esr_editor_init(&direct, m, &v.ds, ESR_EDIT_DIRECT, 8, NULL) != ESR_OK)
        fail_msg("%s", esr_error_message());
    assert_int_equal(esr_editor_set(&direct, e, 5), ESR_OK);
    assert_int_equal(esr_editor_view(&direct, v.cam, 3, &img_direct), ESR_OK);
    esr_editor_free(&direct);
    size_t seen = 0, on_light = 0, lit_up = 0, direct_lit = 0;
    double most = 0.0; /* the most light a light's pixel gained, relative */
    for (size_t p = 0; p < px; p++) {
        if (v.ids[p] < 0) {
            assert_memory_equal(img.data + p * 3, on + p * 3, 3 * sizeof(float));
            seen++;
            continue;
        }
        on_light++;
        int up = 0, up_direct = 0;
        for (int c = 0; c < 3; c++) {
            const float base = off[p * 3 + c] + lit[p * 3 + c];
            up_direct |= img_direct.data[p * 3 + c] > base + 1e-4f * (1.0f + fabsf(base));
            assert_true(img.data[p * 3 + c] >= base - 1e-5f * (1.0f + fabsf(base)));
            up |= img.data[p * 3 + c] > base + 1e-4f * (1.0f + fabsf(base));
            most = fmax(most, (img.data[p * 3 + c] - base) / (1.0f + fabsf(base)));
        }
        lit_up += up;
        direct_lit += up_direct;
    }
    print_message("finetune view: %zu pixels see no light (the fine-tuned render), %zu see one, "
                  "%zu of them lit by the lights (by up to %.3g x (1 + base)); direct: %zu\n", seen,
                  on_light, lit_up, most, direct_lit);
    assert_true(seen > 0 && on_light > 0);
    assert_true(direct_lit == 0 || lit_up > 0);
    if (direct_lit == 0)
        print_message("finetune view: no light reaches another's pixels in this tiny run (%d "
                      "lights): the direct light there is not checked\n", m->lights.n);
    esr_image_free(&img_direct);
    free(o3), free(d3), free(on), free(off), free(lit);
    esr_image_free(&img);
    esr_editor_free(&ed);
    pdra_view_close(&v);
}

/* esr lights --drop: the named lights leave the checkpoint (a reflection the user judges no
 * light), the others are calibrated again; bad ids and --drop with --recompute are refused with
 * nothing changed. */
static void test_lights_drop(void **state)
{
    (void)state;
    char run[4300], cmd[24000], out[16384];
    snprintf(run, sizeof run, "%s/run_drop", test_tmpdir);
    snprintf(cmd, sizeof cmd, "mkdir -p '%s' && cp '%s'/run_pdra/config.json '%s'/run_pdra/run.json "
             "'%s'/run_pdra/ckpt_pdra.bin '%s'/", run, test_tmpdir, test_tmpdir, test_tmpdir, run);
    assert_int_equal(system(cmd), 0);
    struct esr_model m;
    snprintf(cmd, sizeof cmd, "%s/ckpt_pdra.bin", run);
    assert_int_equal(esr_model_load(&m, cmd), ESR_OK);
    const int n = m.lights.n;
    struct esr_light last = m.lights.light[n > 0 ? n - 1 : 0];
    esr_model_free(&m);
    if (n == 0)
        skip(); /* test_pdra_finds_lights prints how many the tiny run found */
    snprintf(cmd, sizeof cmd, "lights '%s' --drop %d", run, n);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
    assert_non_null(strstr(out, "expected light ids from 0 to"));
    snprintf(cmd, sizeof cmd, "lights '%s' --drop 0 --recompute", run);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
    assert_non_null(strstr(out, "drop them after a --recompute"));
    snprintf(cmd, sizeof cmd, "%s/ckpt_pdra.bin", run);
    assert_int_equal(esr_model_load(&m, cmd), ESR_OK);
    assert_int_equal(m.lights.n, n); /* refused: nothing changed */
    esr_model_free(&m);
    snprintf(cmd, sizeof cmd, "lights '%s' --drop ''", run);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
    assert_non_null(strstr(out, "expected light ids from 0 to"));
    snprintf(cmd, sizeof cmd, "lights '%s' --drop 0 --data '%s'", run, data_dir);
    if (n == 1) { /* the only light: refused, renders would fall back to the raw field */
        assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
        assert_non_null(strstr(out, "would leave no lights"));
        return;
    }
    if (test_run_esr(cmd, out, sizeof out) != 0)
        fail_msg("esr %s:\n%s", cmd, out);
    assert_non_null(strstr(out, "dropped light 0"));
    snprintf(cmd, sizeof cmd, "%s/ckpt_pdra.bin", run);
    assert_int_equal(esr_model_load(&m, cmd), ESR_OK);
    assert_int_equal(m.lights.n, n - 1);
    const struct esr_light *moved = &m.lights.light[n - 2]; /* the last light, one id down */
    assert_int_equal(moved->points, last.points);
    assert_float_equal(moved->area, last.area, 0.0f);
    for (int a = 0; a < 3; a++)
        assert_float_equal(moved->centroid[a], last.centroid[a], 0.0f);
    esr_model_free(&m);
    snprintf(cmd, sizeof cmd, "lights '%s' --drop 0 --data '%s'", run, data_dir);
    if (n == 2) { /* dropping the one light left is refused too */
        assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
        assert_non_null(strstr(out, "would leave no lights"));
    }
}

/* esr eval on an edit phase (test_nvi, direct): the scores, and what each esr light was edited
 * as (the dataset light its pixels overlap most, -1 none); without the dataset's light masks no
 * esr light can follow an edited light, and eval says so instead of scoring unedited frames
 * silently. */
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
             "'%s'/run_pdra/ckpt_*.bin '%s/'", run, test_tmpdir, test_tmpdir, test_tmpdir, run);
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

static void test_edit_eval_follows_lights(void **state)
{
    (void)state;
    char run[4300], data[4300], cmd[24000], out[16384];
    snprintf(run, sizeof run, "%s/run_edit_eval", test_tmpdir);
    snprintf(data, sizeof data, "%s/data_no_masks", test_tmpdir);
    snprintf(cmd, sizeof cmd, "mkdir -p '%s' && cp '%s'/run_pdra/config.json '%s'/run_pdra/run.json "
             "'%s'/run_pdra/ckpt_*.bin '%s'/ && cp -r '%s' '%s' && rm -r '%s'/masks", run, test_tmpdir,
             test_tmpdir, test_tmpdir, run, data_dir, data, data);
    assert_int_equal(system(cmd), 0);
    struct esr_model m;
    snprintf(cmd, sizeof cmd, "%s/ckpt_pdra.bin", run);
    assert_int_equal(esr_model_load(&m, cmd), ESR_OK);
    const int n_lights = m.lights.n;
    esr_model_free(&m);
    if (n_lights == 0)
        skip(); /* edits need lights; test_pdra_finds_lights prints how many the tiny run found */
    snprintf(cmd, sizeof cmd, "eval '%s' --data '%s' --phase test_nvi --method direct", run, data_dir);
    int rc = test_run_esr(cmd, out, sizeof out);
    if (rc != 0)
        fail_msg("esr %s: exit %d:\n%s", cmd, rc, out);
    snprintf(cmd, sizeof cmd, "%s/eval/test_nvi_direct.json", run);
    cJSON *root = test_read_json(cmd);
    assert_non_null(root);
    const cJSON *sp = cJSON_GetObjectItemCaseSensitive(root, "light_split");
    const cJSON *follow = cJSON_GetObjectItemCaseSensitive(sp, "esr_lights_follow");
    assert_int_equal(cJSON_GetArraySize(follow), n_lights);
    int following = 0, followed[2] = {0, 0};
    for (int j = 0; j < n_lights; j++) {
        const int k = (int)cJSON_GetArrayItem(follow, j)->valuedouble;
        assert_true(k >= -1 && k < 2);
        following += k >= 0;
        if (k >= 0)
            followed[k] = 1;
    }
    assert_true(following > 0); /* the tiny run always finds the lampshade */
    /* the means per edit asked (the _ind frames apart), in the order the views first ask them:
     * recomputed here from the views */
    const cJSON *views = cJSON_GetObjectItemCaseSensitive(root, "views");
    const cJSON *by_edit = cJSON_GetObjectItemCaseSensitive(root, "by_edit");
    assert_int_equal(cJSON_GetArraySize(by_edit), 3); /* x0.5 both, x2 both, lampshade off */
    int grouped = 0, first_seen = 0;
    const char *edits[3];
    for (int g = 0; g < 3; g++) {
        const cJSON *grp = cJSON_GetArrayItem(by_edit, g);
        const cJSON *edit = cJSON_GetObjectItemCaseSensitive(grp, "edit");
        assert_true(cJSON_IsString(edit));
        edits[g] = edit->valuestring;
        for (int h = 0; h < g; h++)
            assert_string_not_equal(edits[h], edits[g]);
        double psnr = 0.0, ssim = 0.0;
        int count = 0, first = -1;
        for (int i = 0; i < cJSON_GetArraySize(views); i++) {
            const cJSON *v = cJSON_GetArrayItem(views, i);
            const cJSON *ve = cJSON_GetObjectItemCaseSensitive(v, "edit");
            assert_true(cJSON_IsString(ve));
            if (!strcmp(ve->valuestring, edits[g])) {
                psnr += cJSON_GetObjectItemCaseSensitive(v, "psnr")->valuedouble;
                ssim += cJSON_GetObjectItemCaseSensitive(v, "ssim")->valuedouble;
                first = first < 0 ? i : first;
                count++;
            }
        }
        assert_true(count > 0 && (g == 0 ? first == 0 : first > first_seen)); /* asked order */
        first_seen = first;
        const double n_views = cJSON_GetObjectItemCaseSensitive(grp, "n_views")->valuedouble;
        const double g_psnr = cJSON_GetObjectItemCaseSensitive(grp, "psnr")->valuedouble;
        const double g_ssim = cJSON_GetObjectItemCaseSensitive(grp, "ssim")->valuedouble;
        assert_int_equal((int)n_views, count);
        assert_true(fabs(g_psnr - psnr / count) < 1e-9 && fabs(g_ssim - ssim / count) < 1e-12);
        grouped += count;
    }
    assert_int_equal(grouped, cJSON_GetArraySize(views));
    assert_non_null(strstr(out, "edit mean"));
    snprintf(cmd, sizeof cmd, "grep -q 'Mean per edit asked' '%s'/report_test_nvi_direct.html",
             run);
    assert_int_equal(system(cmd), 0);
    /* a dataset light no esr light follows (one the tiny run did not find) is in the JSON and
     * warned about, and only such a light */
    const cJSON *unmatched = cJSON_GetObjectItemCaseSensitive(sp, "edited_lights_unmatched");
    assert_int_equal(cJSON_GetArraySize(unmatched), 2 - followed[0] - followed[1]);
    for (int k = 0; k < 2; k++) {
        char warning[96];
        snprintf(warning, sizeof warning, "warning: dataset light %d is edited", k);
        assert_true((strstr(out, warning) != NULL) == !followed[k]);
    }
    cJSON_Delete(root);
    /* the same without masks: every edited light unmatched, said */
    snprintf(cmd, sizeof cmd, "eval '%s' --data '%s' --phase test_nvi --method direct", run, data);
    rc = test_run_esr(cmd, out, sizeof out);
    if (rc != 0)
        fail_msg("esr %s: exit %d:\n%s", cmd, rc, out);
    if (!strstr(out, "warning: dataset light 0 is edited by 9 frame(s), but no esr light follows it"))
        fail_msg("esr %s said:\n%s", cmd, out);
    /* light 1 stays as it is in the _ind frames (x1): 6 of its 9 frames change it */
    if (!strstr(out, "warning: dataset light 1 is edited by 6 frame(s)"))
        fail_msg("esr %s said:\n%s", cmd, out);
    snprintf(cmd, sizeof cmd, "%s/eval/test_nvi_direct.json", run);
    root = test_read_json(cmd);
    assert_non_null(root);
    sp = cJSON_GetObjectItemCaseSensitive(root, "light_split");
    assert_int_equal(cJSON_GetArraySize(cJSON_GetObjectItemCaseSensitive(sp, "edited_lights_unmatched")), 2);
    cJSON_Delete(root);
    /* a frame asking an edit no light can take (x2e6: past esr's cap, where the radiance leaves
     * float) is refused, naming it, before anything is written */
    snprintf(data, sizeof data, "%s/data_edit_too_strong", test_tmpdir);
    snprintf(cmd, sizeof cmd, "cp -r '%s' '%s' && rm -r '%s'/render/test_nvi_direct '%s'/eval", data_dir,
             data, run, run);
    assert_int_equal(system(cmd), 0);
    snprintf(cmd, sizeof cmd, "%s/transforms/transforms_test_nvi.json", data);
    root = test_read_json(cmd);
    assert_non_null(root);
    const cJSON *frame = cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(root, "frames"), 0);
    cJSON *light = cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(frame, "lights"), 0);
    cJSON_SetNumberValue(cJSON_GetObjectItemCaseSensitive(light, "intensity"), 2e6);
    char *text = cJSON_Print(root), name[128];
    snprintf(name, sizeof name, "%s", cJSON_GetObjectItemCaseSensitive(frame, "file_path")->valuestring);
    cJSON_Delete(root);
    assert_int_equal(test_write_file(cmd, text), 0);
    free(text);
    snprintf(cmd, sizeof cmd, "eval '%s' --data '%s' --phase test_nvi --method direct", run, data);
    assert_int_not_equal(test_run_esr(cmd, out, sizeof out), 0);
    char want[256];
    snprintf(want, sizeof want, "frame %s asks dataset light 0 for an edit esr cannot make: intensity "
             "2e+06 is not a number in [0, 1e+06]", strrchr(name, '/') + 1);
    if (!strstr(out, want))
        fail_msg("esr %s said:\n%s\n(expected: %s)", cmd, out, want);
    snprintf(cmd, sizeof cmd, "%s/render/test_nvi_direct", run);
    assert_int_not_equal(access(cmd, F_OK), 0);
    snprintf(cmd, sizeof cmd, "%s/eval", run);
    assert_int_not_equal(access(cmd, F_OK), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_tiny_reaches_psnr),
        cmocka_unit_test(test_resume_after_interruption_is_exact),
        cmocka_unit_test(test_resume_at_stage_boundary_is_exact),
        cmocka_unit_test(test_resume_inside_lts_and_pdra_is_exact),
        cmocka_unit_test(test_resume_applies_set),
        cmocka_unit_test(test_resume_refuses_another_box),
        cmocka_unit_test(test_interrupt_saves_and_resumes),
        cmocka_unit_test(test_nan_is_recovered_then_stops),
        cmocka_unit_test(test_nan_in_emitter_stages_is_recovered),
        cmocka_unit_test(test_bad_dataset_writes_nothing),
        cmocka_unit_test(test_corrupt_checkpoints_are_refused),
        cmocka_unit_test(test_empty_mask_cache_is_refused),
        cmocka_unit_test(test_emitter_stages_need_both_lightings),
        cmocka_unit_test(test_geometry_from_lights_on_only),
        cmocka_unit_test(test_pdra_finds_lights),
        cmocka_unit_test(test_demo_steps_after_training),
        cmocka_unit_test(test_finetune_edits),
        cmocka_unit_test(test_finetune_start),
        cmocka_unit_test(test_finetune_view),
        cmocka_unit_test(test_render_other_lighting),
        cmocka_unit_test(test_render_lights_emitted_only),
        cmocka_unit_test(test_ratio_edits),
        cmocka_unit_test(test_edit_eval_follows_lights),
        cmocka_unit_test(test_lights_drop),
        cmocka_unit_test(test_slips_keep_earlier_outputs),
    };
    return cmocka_run_group_tests(tests, group_setup, test_teardown_tmpdir);
}
