/* esr eval RUN: render (or reuse) a phase's test views and score them against the dataset. */
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/commands.h"
#include "core/error.h"
#include "eval/edit_eval.h"
#include "eval/evaluate.h"
#include "eval/geometry.h"
#include "eval/report.h"
#include "eval/run_dir.h"
#include "io/dir.h"
#include "io/file.h"
#include "io/json_file.h"
#include "io/stale.h"
#include "render/view.h"
#include "model/model.h"

static int run_eval(int argc, char **argv);

struct eval_args {
    const char *run, *phase, *data, *frames;
    int limit, rerender;
    int spp, iters;
    enum esr_edit_method method;
    const char *edit_option; /* the first of --method, --spp, --iters given (edit phases only) */
    int argc;
    char **argv; /* for the JSON's "made_by" */
};

static int edit_option(void *args, const struct cli_option *o, const char *value);

#define AT(field) offsetof(struct eval_args, field)
static const struct cli_option eval_options[] = {
    {"RUN", .kind = CLI_ARG, .at = AT(run)},
    {"--phase", "P", "phase to evaluate (default: test_nv)", CLI_TEXT, .at = AT(phase)},
    {"--data", "DIR", "dataset directory (default: the one recorded in RUN)", CLI_TEXT,
     .at = AT(data)},
    {"--frames", "a,b,..", "only these frames, by name (e.g. c000_off,c003_on)", CLI_TEXT,
     .at = AT(frames)},
    {"--limit", "N", "only the first N (selected) frames (with either, the phase's JSON, P.json or "
     "P_METHOD.json, and its report hold only those views, replacing the earlier ones)", CLI_INT,
     .at = AT(limit), .lo = 1, .hi = 1000000,
     .bad = "--limit must be an integer in 1..1000000 (leave it out for every frame), got '%s'"},
    {"--rerender", NULL, "render every selected frame again (the edit phases relight every time)",
     CLI_FLAG, .at = AT(rerender)},
    {"--method", "M", "edit phases: direct (default), ratio (edit/relight.h) or finetune (one "
     "radiance fine-tune per distinct edit of the phase, edit/finetune.h)", CLI_CALL,
     .call = edit_option},
    {"--spp", "N", "edit phases: light samples per pixel and light (default 8; finetune: on the "
     "lights' pixels)", CLI_INT, .at = AT(spp), .lo = 1, .hi = 4096, .call = edit_option},
    {"--iters", "N", "edit phases, finetune: steps per fine-tune (default 300)", CLI_INT,
     .at = AT(iters), .lo = 1, .hi = 1000000, .call = edit_option},
    {0},
};

const struct esr_command cmd_eval = {
    .name = "eval",
    .summary = "score a run on a test phase (PSNR, SSIM, HDR MSE per view and lighting, normal "
               "error; emitter IoU, light strengths and split; relighting on the edit phases) + "
               "HTML report",
    .usage =
    "usage: esr eval RUN [options]\n"
    "\n"
    "Renders the frames of a phase with the run's model into RUN/render/P (as `esr render`; frames\n"
    "already rendered there by the same checkpoint are reused; without a loadable model, complete\n"
    "existing renders are evaluated as they are), then compares them with the dataset:\n"
    "PSNR and SSIM of the tone-mapped and of the gamma-corrected linear output against the\n"
    "ground-truth PNG on white, and HDR MSE of the linear EXR against the ground-truth EXR on\n"
    "white. When the dataset has ground-truth normal maps (DATA/gt/c<CCC>_normal.exr, as `esr synth`\n"
    "writes), also the angular error in degrees of the rendered surface normals (N_normal.exr) over\n"
    "the pixels where the ground truth has a surface and the render's opacity is over 0.5: mean,\n"
    "median, fraction under 10 degrees, covered fraction (JSON \"normals\", per view \"normal_deg\").\n"
    "With its material maps (DATA/gt/c<CCC>_{base_color,roughness,metallic}.exr) and a model with\n"
    "a BRDF (lts stage on), the rendered N_basecolor.png, N_roughness.png, N_metallic.png over the\n"
    "same pixels: base colour PSNR of the sRGB maps, also with one least-squares gain per channel\n"
    "(in linear), roughness and metallic mean absolute error, also over the truly metallic (>= 0.9)\n"
    "and non-metallic (<= 0.1) pixels with their mean predicted metallic (JSON \"materials\").\n"
    "Writes RUN/eval/P.json (per view, mean, mean per lighting mode; \"model\": the stage, step and\n"
    "iterations of the checkpoint rendered, \"finished\": false with a warning when it stopped\n"
    "part-way), RUN/report.html\n"
    "(thumbnails, metrics, training curves from RUN/train_log.jsonl) and prints a table.\n"
    "PSNR of identical images is capped at 100 dB.\n"
    "When the dataset has a ground-truth surface (DATA/gt/mesh.ply, as `esr synth` writes), the\n"
    "model's surface is also scored by Chamfer distance (accuracy, completeness, in scene units)\n"
    "into RUN/eval/geometry.json.\n"
    "With an lts/pdra model (its emitters and lights), P.json also holds \"emitter_iou\" (the\n"
    "rendered emitter masks N_emitter.png against the dataset's light masks, pixels pooled over the\n"
    "views), \"emitter_iou_emo_threshold\" (the baseline that thresholds the model's L_on - L_off\n"
    "at its best k on the same masks: an oracle threshold, what the emitter stages add is the\n"
    "difference), \"emitter_radiance\" (per dataset light with known radiance, the mean rendered\n"
    "emission over its mask against the truth: \"error_pct\" = |found - true| / |true| in RGB,\n"
    "\"ratio\" = |found| / |true|; a light too small for the eroded mask is scored on its whole\n"
    "mask, \"eroded\": false; \"power\": its rendered emission's luminance summed over its pixels),\n"
    "\"emitter_strength\" (\"shared_scale\": geometric mean over the lights of found / true\n"
    "luminance, \"worst_relative\": the largest |ratio / shared_scale - 1|, \"lights_found\",\n"
    "\"lights_true\"; eval/emitter_strength.h) and \"light_split\" (per dataset light the esr\n"
    "light of best IoU).\n"
    "Edit phases (test_nvi, test_nvc, test_nvic) relight each frame as its lights[] say with\n"
    "--method (edit/relight.h; dataset lights mapped to esr's by the frames' per-light masks) into\n"
    "RUN/render/P_METHOD, and write RUN/eval/P_METHOD.json (PSNR, SSIM per view, mean, mean per\n"
    "edit asked; the light split) and RUN/report_P_METHOD.html (original, edit, ground truth side\n"
    "by side).\n",
    .options = eval_options,
    .run = run_eval,
    .view_loop = 1,
};

/* --method, --spp and --iters apply to the edit phases only: the first given is named when the
 * phase is another; --method's value is read here. */
static int edit_option(void *args, const struct cli_option *o, const char *value)
{
    struct eval_args *a = args;
    a->edit_option = a->edit_option ? a->edit_option : o->name;
    if (strcmp(o->name, "--method") || !esr_edit_method_from_name(value, &a->method))
        return 0;
    return cli_fail(&cmd_eval, "--method: expected direct, ratio or finetune, got '%s'", value);
}

static void show_progress(void *user, const struct esr_view_progress *p)
{
    (void)user;
    fprintf(stderr, "  rendered %-16s %4d / %-4d  %.2f s\n", p->name, p->done, p->total, p->seconds);
}

static void show_edit_progress(void *user, const struct esr_edit_eval_progress *p)
{
    (void)user;
    fprintf(stderr, "  %-20s %3d / %-3d  %.2f dB%s\n", p->name, p->done, p->total, p->psnr,
            p->finetuned ? " (after a fine-tune)" : "");
}

/* The checkpoint the views are rendered with: an unfinished one is scored, and said to be. */
struct model_state {
    int present, stage, done;
    long step, iters;
};

static void model_state_of(const struct esr_model *m, struct model_state *st)
{
    st->present = 1;
    st->stage = m->stage;
    st->done = m->stage_done;
    st->step = m->step;
    st->iters = esr_stage_options(&m->cfg, (enum esr_stage)m->stage)->iters;
}

/* Said after the scores, where it is read: the model stopped part-way. */
static void warn_model_state(const char *run, const struct model_state *st)
{
    if (st->present && !st->done)
        fprintf(stderr, "warning   %s: the %s stage stopped at step %ld of %ld; these are the scores of "
                        "an unfinished model (esr train --resume finishes it)%s\n",
                run, esr_stage_name((enum esr_stage)st->stage), st->step, st->iters,
                st->stage == ESR_STAGE_PDRA ? "; its lights are the mid-stage estimate" : "");
}

/* The rendering model's state into the scores' JSON ("model"). */
static int record_model_state(const struct model_state *st, const char *json)
{
    if (!st->present)
        return ESR_OK;
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "stage", esr_stage_name((enum esr_stage)st->stage));
    cJSON_AddNumberToObject(o, "step", (double)st->step);
    cJSON_AddNumberToObject(o, "iters", (double)st->iters);
    cJSON_AddBoolToObject(o, "finished", st->done);
    return cli_json_set(json, "model", o);
}

/* Renders the selected frames that are missing or stale in render_dir. Without a loadable model
 * the existing renders are used when complete (st->present 0). */
static int ensure_renders(const struct eval_args *a, const struct esr_run_selection *sel, const char *render_dir,
                          struct model_state *st)
{
    const struct esr_phase *ph = &sel->ds.phases[sel->phase];
    struct esr_model model;
    memset(st, 0, sizeof *st);
    if (esr_model_load(&model, a->run) != ESR_OK) {
        for (int i = 0; i < sel->n; i++)
            if (!esr_view_outputs_exist(render_dir, ph->frames[sel->idx[i]].name))
                return ESR_ERR; /* the load error explains why they cannot be rendered */
        fprintf(stderr, "note: no loadable model (%s); evaluating the existing renders in %s\n",
                esr_error_message(), render_dir);
        esr_error_clear();
        return ESR_OK;
    }
    int *todo = malloc((size_t)sel->n * sizeof *todo), n_todo = 0;
    uint8_t *current = malloc((size_t)sel->n);
    if (!todo || !current) {
        free(todo), free(current);
        esr_model_free(&model);
        return ESR_FAIL("out of memory");
    }
    model_state_of(&model, st);
    esr_view_current(render_dir, &model, &sel->ds, sel->phase, sel->idx, sel->n, current);
    for (int i = 0; i < sel->n; i++)
        if (a->rerender || !current[i])
            todo[n_todo++] = sel->idx[i];
    free(current);
    int status = ESR_OK;
    if (n_todo > 0) {
        fprintf(stderr, "rendering %d of %d frame(s) with the %s model (step %ld) into %s\n", n_todo, sel->n,
                esr_stage_name((enum esr_stage)model.stage), model.step, render_dir);
        status = esr_view_render_frames(&model, &sel->ds, sel->phase, todo, n_todo, render_dir, show_progress,
                                        NULL);
    }
    free(todo);
    esr_model_free(&model);
    return status;
}

/* A 10-wide table cell: "-" for a missing (NAN) value; `general` picks %g over %.2f. */
static void print_cell(double v, int general)
{
    if (isnan(v))
        printf(" %10s", "-");
    else if (general)
        printf(" %10.4g", v);
    else
        printf(" %10.2f", v);
}

/* One table row of the scores s (a view's: n 1); `normal` (mean normal error, degrees) is a
 * column only when with_normals. */
static void print_row(const char *name, const char *mode, const struct esr_eval_mean *s, int with_normals,
                      double normal)
{
    printf("%-16s %-9s %4d %8.2f %7.4f %8.2f %7.4f", name, mode, s->n, s->psnr, s->ssim, s->psnr_linear,
           s->ssim_linear);
    print_cell(s->hdr_mse, 1);
    if (with_normals)
        print_cell(normal, 0);
    printf("\n");
}

static void print_table(const struct esr_eval_result *res)
{
    int nrm = res->n_normal_views > 0;
    printf("%-16s %-9s %4s %8s %7s %8s %7s %10s", "view", "lighting", "n", "PSNR", "SSIM", "PSNR-lin", "SSIM-lin",
           "HDR-MSE");
    if (nrm)
        printf(" %10s", "normal-deg");
    printf("\n");
    for (int i = 0; i < res->n_views; i++) {
        const struct esr_eval_view *v = &res->views[i];
        const struct esr_eval_mean one = {1, v->psnr, v->ssim, v->psnr_linear, v->ssim_linear, v->hdr_mse};
        print_row(v->name, esr_light_mode_name(v->mode), &one, nrm, v->has_normal_gt ? v->normal.mean_deg : NAN);
    }
    for (int mode = 0; mode < ESR_LIGHT_MODE_COUNT; mode++) {
        const struct esr_eval_mean *m = &res->by_mode[mode];
        if (m->n > 0)
            print_row("mean", esr_light_mode_name((enum esr_light_mode)mode), m, nrm, NAN);
    }
    const struct esr_eval_mean *m = &res->all;
    print_row("mean", "all", m, nrm, res->normals.mean_deg);
}

/* The pooled normal error, or a note that the dataset has no ground-truth normal maps. */
static void print_normals(const struct esr_eval_result *res)
{
    const struct esr_normal_stats *s = &res->normals;
    if (res->n_normal_views == 0) {
        fprintf(stderr, "note: no ground-truth normal maps (DATA/gt/c<CCC>_normal.exr) for these views; normal "
                        "error not scored\n");
        return;
    }
    printf("normals vs gt (%d views, pixels pooled): mean %.2f deg, median %.2f deg, %.1f%% under %.0f deg, "
           "coverage %.1f%% (%ld of %ld surface pixels at opacity > %.1f)\n",
           res->n_normal_views, s->mean_deg, s->median_deg, 100.0 * s->frac_good, ESR_NORMAL_GOOD_DEG,
           100.0 * s->coverage, s->n, s->n_gt, (double)ESR_NORMAL_MIN_OPACITY);
}

/* The pooled emitter IoU and the thresholded-L_emo baseline, when there is something to score. */
static void print_emitters(const struct esr_eval_result *res)
{
    if (res->n_emitter_views > 0)
        printf("emitters vs gt (%d views, pixels pooled): IoU %.3f\n", res->n_emitter_views,
               esr_iou_value(&res->emitter));
    if (res->emo_baseline.n_cameras > 0)
        printf("baseline, L_emo = L_on - L_off thresholded at its best k (%.3g, %d cameras): IoU "
               "%.3f\n",
               res->emo_baseline.k, res->emo_baseline.n_cameras, res->emo_baseline.iou);
    for (int k = 0; k < res->radiance.n; k++) {
        const struct esr_emitter_radiance *r = &res->radiance.lights[k];
        printf("light %d (%s): emitted radiance %.3g %.3g %.3g vs true %.3g %.3g %.3g: %.1f%% off, "
               "%.0f%% of its strength (%ld pixels)\n",
               r->light, r->name, r->mean[0], r->mean[1], r->mean[2], r->truth[0], r->truth[1],
               r->truth[2], r->error_pct, 100.0 * r->ratio, r->pixels);
    }
    esr_emitter_strength_print(stdout, &res->radiance, &res->strength);
    for (int k = 0; k < res->split.n; k++) {
        const struct esr_light_split_row *r = &res->split.rows[k];
        printf("light %d (%s) is esr light %d: IoU %.3f (%d views pooled)\n", r->light, r->name,
               r->esr_light, r->iou, res->split.views);
    }
}

/* Paths under RUN: render/P, eval/, eval/P.json, eval/P_gt, report.html, train_log.jsonl. */
struct eval_paths {
    char render[ESR_PATH_MAX], eval[ESR_PATH_MAX], json[ESR_PATH_MAX], gt[ESR_PATH_MAX];
    char report[ESR_PATH_MAX], log[ESR_PATH_MAX], render_href[ESR_PATH_MAX], gt_href[ESR_PATH_MAX];
};

static int make_paths(const char *run, const char *phase, struct eval_paths *p)
{
    int too_long = 0;
#define EVAL_PATH(field, ...) too_long |= snprintf(p->field, sizeof p->field, __VA_ARGS__) >= (int)sizeof p->field
    EVAL_PATH(render, "%s/render/%s", run, phase);
    EVAL_PATH(eval, "%s/eval", run);
    EVAL_PATH(json, "%s/eval/%s.json", run, phase);
    EVAL_PATH(gt, "%s/eval/%s_gt", run, phase);
    EVAL_PATH(report, "%s/report.html", run);
    EVAL_PATH(log, "%s/train_log.jsonl", run);
    EVAL_PATH(render_href, "render/%s", phase);
    EVAL_PATH(gt_href, "eval/%s_gt", phase);
#undef EVAL_PATH
    return too_long ? ESR_FAIL("run path '%s' is too long", run) : ESR_OK;
}

/* Chamfer distance of the model's surface to the dataset's ground-truth mesh, when both exist
 * (*scored set then, *r the result), written to eval/geometry.json. */
static int score_geometry(const char *run, const struct esr_dataset *ds, const struct eval_paths *p,
                          struct cli_aside *aside, struct esr_chamfer_result *r, int *scored)
{
    char gt[ESR_PATH_MAX], json[ESR_PATH_MAX];
    const char *to;
    *scored = 0;
    if (!esr_geometry_gt_path(ds->root, gt, sizeof gt))
        return ESR_OK;
    struct esr_model model;
    if (esr_model_load(&model, run) != ESR_OK) {
        esr_error_clear(); /* renders-only runs have no surface to score */
        return ESR_OK;
    }
    int status = esr_geometry_score(&model, gt, r);
    esr_model_free(&model);
    if (snprintf(json, sizeof json, "%s/geometry.json", p->eval) >= (int)sizeof json ||
        !(to = cli_aside_add(aside, json)))
        return ESR_FAIL("run path '%s' is too long", run);
    if (status == ESR_OK)
        status = esr_geometry_write_json(to, gt, r);
    if (status == ESR_OK)
        printf("geometry vs %s: chamfer %.5f  (accuracy %.5f, completeness %.5f; %zu samples each)\n", gt,
               r->chamfer, r->accuracy, r->completeness, r->n_samples);
    *scored = status == ESR_OK;
    return status;
}

static int evaluate(const struct eval_args *a, const struct esr_run_selection *sel,
                    const struct eval_paths *p)
{
    struct esr_eval_result res;
    ESR_TRY(esr_eval_check_truth(&sel->ds, sel->phase, sel->idx, sel->n));
    struct model_state st;
    ESR_TRY(ensure_renders(a, sel, p->render, &st));
    int status = esr_eval_phase(&sel->ds, sel->phase, sel->idx, sel->n, p->render, &res);
    /* the lights the run found, for the report and the light count (a run without a pdra
     * checkpoint has none: the count is then the renders' light ids, eval/emitter_strength.h) */
    struct esr_model m;
    memset(&m, 0, sizeof m);
    char ckpt[ESR_PATH_MAX + 16];
    snprintf(ckpt, sizeof ckpt, "%s/ckpt_pdra.bin", a->run);
    const int has_pdra = esr_file_exists(ckpt);
    if (status == ESR_OK && has_pdra)
        status = esr_model_load(&m, ckpt);
    if (status == ESR_OK && has_pdra) {
        res.strength.lights_found = m.lights.n;
        res.strength.found_from = "model";
    }
    /* the scores, the geometry and the report are written aside and replace the earlier ones
     * together, once all three are complete */
    struct cli_aside aside = {0};
    const char *json_to = cli_aside_add(&aside, p->json), *report_to = cli_aside_add(&aside, p->report);
    if (status == ESR_OK && (!json_to || !report_to))
        status = ESR_FAIL("run path '%s' is too long", a->run);
    if (status == ESR_OK)
        status = esr_dir_prepare_output(p->eval);
    if (status == ESR_OK)
        status = esr_eval_write_json(json_to, &sel->ds, &res);
    if (status == ESR_OK)
        status = cli_record_into(json_to, "eval", a->argc, a->argv);
    if (status == ESR_OK)
        status = record_model_state(&st, json_to);
    struct esr_chamfer_result geometry; /* the surface, for the report too */
    int scored = 0;
    if (status == ESR_OK)
        status = score_geometry(a->run, &sel->ds, p, &aside, &geometry, &scored);
    if (status == ESR_OK) {
        struct esr_report_spec spec = {report_to, a->run,    &sel->ds, &res,     p->render_href,
                                       p->gt,     p->gt_href, p->log,   &m.lights,
                                       scored ? &geometry : NULL};
        status = esr_report_write(&spec);
    }
    esr_model_free(&m);
    if (status == ESR_OK)
        status = cli_aside_commit(&aside);
    else
        cli_aside_discard(&aside);
    if (status == ESR_OK) {
        print_table(&res);
        print_normals(&res);
        esr_materials_print(stdout, stderr, &res.materials);
        print_emitters(&res);
        warn_model_state(a->run, &st);
        fprintf(stderr, "wrote %s and %s\n", p->json, p->report);
    }
    esr_eval_result_free(&res);
    return status;
}

/* An edit phase relit by a.method, scored, with its JSON and HTML page. */
static int evaluate_edits(const struct eval_args *a, const struct esr_run_selection *sel)
{
    const char *phase = esr_phase_name(sel->phase), *method = esr_edit_method_name(a->method);
    char dir[ESR_PATH_MAX], json[ESR_PATH_MAX], html[ESR_PATH_MAX];
    char href[ESR_PATH_MAX], eval_dir[ESR_PATH_MAX];
    snprintf(dir, sizeof dir, "%s/render/%s_%s", a->run, phase, method);
    snprintf(eval_dir, sizeof eval_dir, "%s/eval", a->run);
    snprintf(json, sizeof json, "%s/eval/%s_%s.json", a->run, phase, method);
    snprintf(html, sizeof html, "%s/report_%s_%s.html", a->run, phase, method);
    snprintf(href, sizeof href, "render/%s_%s", phase, method);
    struct esr_model m;
    ESR_TRY(esr_model_load_finished_pdra(&m, a->run));
    int status = ESR_OK;
    struct esr_edit_eval res;
    memset(&res, 0, sizeof res);
    if (status == ESR_OK) {
        fprintf(stderr, "relighting %d frame(s) of %s (%s) into %s\n", sel->n, phase, method, dir);
        struct esr_finetune_opts ft;
        esr_finetune_default_opts(&ft);
        if (a->iters)
            ft.iters = a->iters;
        const struct esr_edit_eval_opts eo = {a->method, a->spp, &ft, show_edit_progress, NULL};
        status = esr_edit_eval_phase(&m, sel, dir, &eo, &res);
    }
    struct cli_aside aside = {0};
    const char *json_to = cli_aside_add(&aside, json), *html_to = cli_aside_add(&aside, html);
    if (status == ESR_OK && (!json_to || !html_to))
        status = ESR_FAIL("run path '%s' is too long", a->run);
    if (status == ESR_OK)
        status = esr_dir_prepare_output(eval_dir);
    if (status == ESR_OK)
        status = esr_edit_eval_write_json(json_to, &res);
    if (status == ESR_OK)
        status = cli_record_into(json_to, "eval", a->argc, a->argv);
    if (status == ESR_OK)
        status = esr_edit_eval_write_html(html_to, a->run, &res, href, "render/test_nv");
    if (status == ESR_OK)
        status = cli_aside_commit(&aside);
    else
        cli_aside_discard(&aside);
    if (status == ESR_OK) {
        printf("%-16s %8s %7s %8s\n", "view", "PSNR", "SSIM", "seconds");
        for (int i = 0; i < res.n; i++)
            printf("%-16s %8.2f %7.4f %8.2f\n", res.views[i].name, res.views[i].psnr,
                   res.views[i].ssim, res.views[i].seconds);
        printf("%-16s %8.2f %7.4f %8.2f  (%s, %s, %d views)\n", "mean", res.psnr, res.ssim,
               res.seconds, phase, method, res.n);
        for (int g = 0; res.n_groups > 1 && g < res.n_groups; g++)
            printf("  %-14s %8.2f %7.4f  (%d views: %s)\n", "edit mean", res.groups[g].psnr,
                   res.groups[g].ssim, res.groups[g].n, res.groups[g].edit);
        if (a->method == ESR_EDIT_FINETUNE)
            printf("%d fine-tune(s), %.1f s each\n", res.n_edits, res.finetune_seconds);
        for (int k = 0; k < res.split.n; k++)
            printf("light %d (%s) is esr light %d: IoU %.3f\n", res.split.rows[k].light,
                   res.split.rows[k].name, res.split.rows[k].esr_light, res.split.rows[k].iou);
        for (int u = 0; u < res.n_unmatched; u++)
            fprintf(stderr, "esr eval: warning: dataset light %d is edited by %d frame(s), but no "
                            "esr light follows it (none has half its pixels in its masks: the "
                            "dataset has no masks for it, or esr did not find that light): those "
                            "frames are scored without its edit\n",
                    res.unmatched[u], res.unmatched_frames[u]);
        fprintf(stderr, "wrote %s and %s\n", json, html);
    }
    esr_edit_eval_free(&res);
    esr_model_free(&m);
    return status;
}

static int run_eval(int argc, char **argv)
{
    struct eval_args a = {NULL, "test_nv", NULL, NULL, 0, 0, 8, 0, ESR_EDIT_DIRECT, NULL, argc, argv};
    const int parsed = cli_parse(&cmd_eval, argc, argv, &a);
    if (parsed != CLI_PARSED)
        return parsed == CLI_HELPED ? 0 : 1;
    if (!a.run)
        return cli_fail(&cmd_eval, "missing RUN directory");
    if (a.iters && a.method != ESR_EDIT_FINETUNE)
        return cli_fail(&cmd_eval, "--iters is read only with --method finetune");
    /* Ctrl-C: the aside files go, the earlier results stay (the renders made so far are kept:
     * each is complete and recorded, and the next eval reuses them) */
    cli_catch_interrupt(&cmd_eval, 1);
    struct eval_paths paths;
    struct esr_run_selection sel;
    memset(&sel, 0, sizeof sel);
    int status = make_paths(a.run, a.phase, &paths);
    if (status == ESR_OK)
        status = esr_run_select(a.run, a.data, a.phase, a.frames, a.limit, &sel);
    /* the reports are written into RUN itself: a killed evaluation's temporary report goes here */
    if (status == ESR_OK)
        status = esr_stale_sweep(a.run, NULL);
    const int edit_phase = status == ESR_OK && (sel.phase == ESR_PHASE_TEST_NVI ||
                                                sel.phase == ESR_PHASE_TEST_NVC ||
                                                sel.phase == ESR_PHASE_TEST_NVIC);
    if (status == ESR_OK && sel.ds.n_lights > ESR_MAX_TRUE_LIGHTS)
        fprintf(stderr, "esr eval: warning: the dataset has %d lights; evaluation maps and scores the "
                        "first %d (light split, emitted radiance, edits), the others' edits are not "
                        "applied\n", sel.ds.n_lights, ESR_MAX_TRUE_LIGHTS);
    if (status == ESR_OK && !edit_phase && a.edit_option)
        status = ESR_FAIL("%s applies to the edit phases (test_nvi, test_nvc, test_nvic), not to "
                          "%s", a.edit_option, a.phase);
    if (status == ESR_OK && edit_phase)
        status = evaluate_edits(&a, &sel);
    else if (status == ESR_OK)
        status = evaluate(&a, &sel, &paths);
    esr_run_selection_free(&sel);
    return status == ESR_OK ? 0 : cli_fail_lib(&cmd_eval);
}
