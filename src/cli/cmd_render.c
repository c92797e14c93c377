/* esr render RUN: render the test views of a phase with the trained model. */
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/commands.h"
#include "core/error.h"
#include "eval/run_dir.h"
#include "io/staging.h"
#include "render/view.h"
#include "model/model.h"

static int run_render(int argc, char **argv);

struct render_args {
    const char *run, *phase, *out, *frames, *data;
    int limit;
};

#define AT(field) offsetof(struct render_args, field)
static const struct cli_option render_options[] = {
    {"RUN", .kind = CLI_ARG, .at = AT(run)},
    {"--phase", "P", "phase to render (default: test_nv)", CLI_TEXT, .at = AT(phase)},
    {"--out", "DIR", "output directory (default: RUN/render/P; not inside the dataset, unless "
     "inside RUN)", CLI_TEXT, .at = AT(out)},
    {"--frames", "a,b,..", "only these frames, by name (e.g. c000_off,c003_on)", CLI_TEXT,
     .at = AT(frames)},
    {"--limit", "N", "only the first N (selected) frames", CLI_INT, .at = AT(limit), .lo = 1,
     .hi = 1000000,
     .bad = "--limit must be an integer in 1..1000000 (leave it out for every frame), got '%s'"},
    {"--data", "DIR", "dataset directory (default: the one recorded in RUN)", CLI_TEXT,
     .at = AT(data)},
    {0},
};

const struct esr_command cmd_render = {
    .name = "render",
    .summary = "render a phase's test views with a trained model (PNG, linear, EXR, normal, depth)",
    .usage =
    "usage: esr render RUN [options]\n"
    "\n"
    "Renders every frame of a dataset phase with the model in run directory RUN (its most advanced\n"
    "checkpoint) from the frame's camera, with the frame's lighting (off or on), and writes per\n"
    "frame N, at the dataset's image size:\n"
    "  N.png         tone-mapped RGB composited on white\n"
    "  N_linear.png  linear RGB on white through the sRGB curve (clipped to [0,1])\n"
    "  N.exr         linear RGB on white (float)\n"
    "  N_normal.png  world-space normal mapped to [0,1], white background\n"
    "  N_depth.png   depth, 0 = nearest .. 1 = farthest surface pixel, white background\n"
    "  N_depth.exr   depth in world units\n"
    "  N_normal.exr  the composited normal (RGB, not normalised) and opacity (A)\n"
    "and for a model of the lts or pdra stage (linear values as EXR, PNG through the sRGB curve):\n"
    "  N_emission.exr/.png  emitted radiance (pdra: the found lights' only, at their strength;\n"
    "                       the PNG over the brightest light's largest channel above 1)\n"
    "  N_emitter.png        emitter mask, 0 or 255 (the mask emitter IoU is scored on)\n"
    "  N_lights.png         with lights found: 0 off the lights, else 1 + the light's id (`esr\n"
    "                       lights RUN`); stretch its contrast to see it\n"
    "  N_emo.exr/.png       lights-on views: the emission's effect, on - off\n"
    "  N_basecolor.png, N_roughness.png, N_metallic.png  the reconstructed BRDF\n"
    "  env.exr/.png         the environment map, equirectangular, once per folder\n"
    "and render.json, the record of which frames are current for the checkpoint.\n"
    "Light-edit phases (test_nvi, test_nvc, test_nvic): `esr eval RUN --phase P` relights and\n"
    "scores them; `esr edit` relights the scene as you choose.\n",
    .options = render_options,
    .run = run_render,
    .view_loop = 1,
};

static void show_progress(void *user, const struct esr_view_progress *p)
{
    (void)user;
    fprintf(stderr, "  %-16s %4d / %-4d  %.2f s\n", p->name, p->done, p->total, p->seconds);
}

static int render_selected(const char *run, const struct esr_run_selection *sel, const char *out_dir)
{
    struct esr_model model;
    if (esr_model_load(&model, run) != ESR_OK)
        return ESR_ERR;
    fprintf(stderr, "rendering %d frame(s) of %s with the %s model (step %ld) into %s\n", sel->n,
            esr_phase_name(sel->phase), esr_stage_name((enum esr_stage)model.stage), model.step, out_dir);
    int status = esr_view_render_frames(&model, &sel->ds, sel->phase, sel->idx, sel->n, out_dir, show_progress,
                                        NULL);
    esr_model_free(&model);
    return status;
}

static int run_render(int argc, char **argv)
{
    struct render_args a = {NULL, "test_nv", NULL, NULL, NULL, 0};
    const int parsed = cli_parse(&cmd_render, argc, argv, &a);
    if (parsed != CLI_PARSED)
        return parsed == CLI_HELPED ? 0 : 1;
    const char *run = a.run, *phase = a.phase, *out = a.out, *frames = a.frames, *data = a.data;
    const int limit = a.limit;
    if (!run)
        return cli_fail(&cmd_render, "missing RUN directory");
    char out_dir[ESR_PATH_MAX];
    if (snprintf(out_dir, sizeof out_dir, "%s/render/%s", run, phase) >= (int)sizeof out_dir)
        return cli_fail(&cmd_render, "run path '%s' is too long", run);
    struct esr_run_selection sel;
    int status = esr_run_select(run, data, phase, frames, limit, &sel);
    const char *const dataset[1] = {sel.ds.root}, *const what[1] = {"the dataset"};
    if (status == ESR_OK && out) /* renders would replace its photos */
        status = esr_output_check_outside(out, dataset, what, 1, run);
    if (status == ESR_OK)
        status = render_selected(run, &sel, out ? out : out_dir);
    char record[ESR_PATH_MAX + 16]; /* render.json says which command made the folder */
    snprintf(record, sizeof record, "%s/render.json", out ? out : out_dir);
    if (status == ESR_OK)
        status = cli_record_into(record, "render", argc, argv);
    const int sel_n = sel.n;
    esr_run_selection_free(&sel);
    if (status != ESR_OK)
        return cli_fail_lib(&cmd_render);
    fprintf(stderr, "wrote %d view(s) of %s and render.json to %s\n", sel_n, phase, out ? out : out_dir);
    return 0;
}
