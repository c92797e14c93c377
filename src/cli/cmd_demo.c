/* esr demo: the main job end to end on the built-in default scene (or a given dataset), by
 * running the other subcommands in order: synth -> info -> train -> lights -> edit -> eval ->
 * export -> lightmix. */
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

#include "cli/commands.h"
#include "core/colour.h"
#include "io/dataset.h"
#include "model/model.h"
#include "core/error.h"
#include "io/dir.h"

static int run_demo(int argc, char **argv);

#define DEMO_MAX_SETS 32

struct demo_args {
    const char *out, *data, *preset;
    struct cli_texts sets;
};

#define AT(field) offsetof(struct demo_args, field)
static const struct cli_option demo_options[] = {
    {"--out", "DIR", "output folder (default runs/demo; created if missing)", CLI_TEXT,
     .at = AT(out)},
    {"--data", "DATA", "use this dataset instead of synthesising the default scene", CLI_TEXT,
     .at = AT(data)},
    {"--preset", "NAME", "training preset (fast, the default, paper or smoke)", CLI_TEXT,
     .at = AT(preset)},
    {"--set", "key=value", "training option override (repeatable; see `esr train --help`)",
     CLI_TEXTS, .at = AT(sets), .hi = DEMO_MAX_SETS},
    {0},
};

const struct esr_command cmd_demo = {
    .name = "demo",
    .summary = "the main job end to end: synthesise the default scene, train, evaluate, export the "
               "mesh",
    .usage =
    "usage: esr demo [--out DIR] [--data DATA] [--preset NAME] [--set key=value ...]\n"
    "\n"
    "Runs the whole pipeline and leaves everything under DIR (default runs/demo):\n"
    "  1. DIR/scene       the built-in default scene (`esr synth`), unless --data is given;\n"
    "                     an existing complete DIR/scene is reused\n"
    "  2. DIR/info.json   the dataset check and summary (`esr info`), DIR/contact_sheet.png\n"
    "  3. DIR/run         training, alphamask -> coarse -> fine -> lts -> pdra (`esr train\n"
    "                     --resume`: an interrupted demo continues where it stopped)\n"
    "  4. DIR/run/lights.json  the lights found: id, place, area, emitted radiance, and\n"
    "                     DIR/run/lights.png, where each is (`esr lights`)\n"
    "  5. DIR/run/edits   one edit per light on a test view: off, and recoloured to the hue\n"
    "                     opposite its own (H + 0.5, saturation 1)\n"
    "                     (`esr edit --method ratio`)\n"
    "  6. DIR/run/eval    PSNR/SSIM per view and lighting, emitter IoU and each light's emitted\n"
    "                     radiance against the truth, Chamfer distance to the ground-truth\n"
    "                     surface when the scene has one (`esr eval`); the test_nv renders in\n"
    "                     DIR/run/render/test_nv, the report DIR/run/report.html\n"
    "  7. DIR/mesh.ply    the reconstructed surface with normals and colours (`esr export`)\n"
    "  8. DIR/run/lightmix  an orbit of 16 views as light groups, with the LightMix page\n"
    "                     (DIR/run/lightmix/index.html: a slider per light, in a browser;\n"
    "                     `esr lightmix --orbit 16`), when the run found lights\n",
    .options = demo_options,
    .run = run_demo,
};

static double now_s(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* Runs one subcommand with the given arguments (argv[0] = its name), announcing the step. */
static int step(int number, const struct esr_command *cmd, int argc, char **argv)
{
    fprintf(stderr, "\n== demo step %d: esr", number);
    for (int i = 0; i < argc; i++)
        fprintf(stderr, " %s", argv[i]);
    fprintf(stderr, "\n");
    fflush(stderr);
    int rc = cmd->run(argc, argv);
    fflush(stdout);
    return rc;
}

/* One edit per light of the run that emits (off, and recoloured to the hue opposite its own, so
 * that the change shows whatever the light's colour: a fixed blue left a blue light as it was;
 * the ratio method) on the
 * first lights-on test_nv view, into RUN/edits/light<K>_off and RUN/edits/light<K>_recoloured
 * (the report shows them). */
static int demo_edits(const char *run, const char *data)
{
    char ckpt[4200];
    snprintf(ckpt, sizeof ckpt, "%s/ckpt_pdra.bin", run);
    struct esr_model m;
    struct esr_dataset ds;
    if (esr_model_load(&m, ckpt) != ESR_OK)
        return cli_fail(&cmd_demo, "%s", esr_error_message());
    const int n = m.lights.n;
    int lit[ESR_MAX_LIGHTS]; /* a light calibrated to nothing (a highlight) is not worth an edit */
    char colour[ESR_MAX_LIGHTS][32];
    for (int k = 0; k < n; k++) {
        const float *rad = m.lights.light[k].radiance;
        lit[k] = rad[0] > 0.0f || rad[1] > 0.0f || rad[2] > 0.0f;
        float hsv[3];
        esr_rgb_to_hsv(rad, hsv);
        snprintf(colour[k], sizeof colour[k], "%.3f,1", fmod((double)hsv[0] + 0.5, 1.0));
    }
    esr_model_free(&m);
    if (esr_dataset_load(data, &ds) != ESR_OK)
        return cli_fail(&cmd_demo, "%s", esr_error_message());
    const struct esr_phase *ph = &ds.phases[ESR_PHASE_TEST_NV];
    char view[ESR_NAME_MAX] = "";
    for (int i = 0; i < ph->n_frames && !view[0]; i++)
        if (ph->frames[i].lights_on)
            snprintf(view, sizeof view, "%s", ph->frames[i].name);
    esr_dataset_free(&ds);
    for (int k = 0; k < n && view[0]; k++) {
        if (!lit[k])
            continue;
        char id[16], out_off[4300], out_col[4300];
        snprintf(id, sizeof id, "%d", k);
        snprintf(out_off, sizeof out_off, "%s/edits/light%d_off", run, k);
        snprintf(out_col, sizeof out_col, "%s/edits/light%d_recoloured", run, k);
        char *off[] = {"edit", (char *)run, "--light", id, "--intensity", "0", "--out", out_off,
                       "--frames", view, "--data", (char *)data, "--method", "ratio"};
        char *col[] = {"edit", (char *)run, "--light", id, "--color", colour[k], "--out", out_col,
                       "--frames", view, "--data", (char *)data, "--method", "ratio"};
        if (step(5, &cmd_edit, 14, off) || step(5, &cmd_edit, 14, col))
            return 1;
    }
    return 0;
}

/* How many lights the run's pdra model found (0 when it cannot be read). */
static int lights_found(const char *run)
{
    char ckpt[4200];
    snprintf(ckpt, sizeof ckpt, "%s/ckpt_pdra.bin", run);
    struct esr_model m;
    if (esr_model_load(&m, ckpt) != ESR_OK) {
        esr_error_clear();
        return 0;
    }
    const int n = m.lights.n;
    esr_model_free(&m);
    return n;
}

static int is_file(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISREG(st.st_mode);
}

static int run_demo(int argc, char **argv)
{
    struct demo_args a = {"runs/demo", NULL, "fast", {{NULL}, 0}};
    const int parsed = cli_parse(&cmd_demo, argc, argv, &a);
    if (parsed != CLI_PARSED)
        return parsed == CLI_HELPED ? 0 : 1;
    char scene[4096], run[4096], info[4096], sheet[4096], mesh[4096], probe[4200];
    snprintf(scene, sizeof scene, "%s/scene", a.out);
    snprintf(run, sizeof run, "%s/run", a.out);
    snprintf(info, sizeof info, "%s/info.json", a.out);
    snprintf(sheet, sizeof sheet, "%s/contact_sheet.png", a.out);
    snprintf(mesh, sizeof mesh, "%s/mesh.ply", a.out);
    if (strlen(a.out) > 3000)
        return cli_fail(&cmd_demo, "output path too long");
    if (esr_dir_create(a.out) != ESR_OK)
        return cli_fail(&cmd_demo, "%s", esr_error_message());
    double t0 = now_s();

    const char *data = a.data ? a.data : scene;
    /* esr synth renames its finished output into place, so scene.json marks a complete scene */
    snprintf(probe, sizeof probe, "%s/scene.json", scene);
    if (!a.data && !is_file(probe)) {
        char *synth[] = {"synth", "--force", scene};
        if (step(1, &cmd_synth, 3, synth))
            return 1;
    } else {
        fprintf(stderr, "== demo step 1: using the dataset in %s\n", data);
    }

    char *info_argv[] = {"info", (char *)data, "--json", info, "--contact-sheet", sheet};
    if (step(2, &cmd_info, 6, info_argv))
        return 1;

    char *train[8 + 2 * DEMO_MAX_SETS];
    int n = 0;
    train[n++] = "train";
    train[n++] = (char *)data;
    train[n++] = "--out";
    train[n++] = run;
    train[n++] = "--resume";
    train[n++] = "--preset";
    train[n++] = (char *)a.preset;
    for (int i = 0; i < a.sets.n; i++) {
        train[n++] = "--set";
        train[n++] = (char *)a.sets.v[i];
    }
    double t_train = now_s();
    if (step(3, &cmd_train, n, train))
        return 1;
    t_train = now_s() - t_train;

    snprintf(probe, sizeof probe, "%s/ckpt_pdra.bin", run);
    char lights_json[4300], lights_png[4300];
    snprintf(lights_json, sizeof lights_json, "%s/lights.json", run);
    snprintf(lights_png, sizeof lights_png, "%s/lights.png", run);
    char *lights[] = {"lights", run, "--json", lights_json, "--picture", lights_png};
    if (is_file(probe) && step(4, &cmd_lights, 6, lights))
        return 1;

    if (is_file(probe) && demo_edits(run, data))
        return 1;

    char *eval[] = {"eval", run, "--data", (char *)data};
    if (step(6, &cmd_eval, 4, eval))
        return 1;

    char *export[] = {"export", run, "--mesh", mesh};
    if (step(7, &cmd_export, 4, export))
        return 1;

    char lightmix[4300];
    snprintf(lightmix, sizeof lightmix, "%s/lightmix", run);
    char *mix[] = {"lightmix", run, "--orbit", "16", "--data", (char *)data, "--out", lightmix};
    const int mixed = is_file(probe) && lights_found(run) > 0;
    if (mixed && step(8, &cmd_lightmix, 8, mix))
        return 1;

    printf("\ndemo finished in %.1f min (training %.1f min). Results in %s:\n", (now_s() - t0) / 60.0,
           t_train / 60.0, a.out);
    printf("  %s/report.html            open in a browser: renders, metrics, training curves\n", run);
    printf("  %s/eval/test_nv.json      PSNR / SSIM per view and lighting mode, emitter IoU, "
           "emitted radiance per light\n", run);
    printf("  %s/lights.json            the lights found (id, centroid, area, colour, strength)\n", run);
    printf("  %s/lights.png             where each light is: its id on a training photo\n", run);
    snprintf(probe, sizeof probe, "%s/eval/geometry.json", run);
    if (is_file(probe))
        printf("  %s   Chamfer distance to the ground-truth surface\n", probe);
    printf("  %s/render/test_nv         rendered test views (PNG, linear PNG, EXR, normals, depth, "
           "emission, emitter masks, materials, the emission's effect)\n", run);
    printf("  %s                   reconstructed surface (PLY)\n", mesh);
    if (mixed)
        printf("  %s/index.html  open in a browser: the LightMix page, a slider per light (an orbit "
               "of 16 views as light groups, one EXR each)\n", lightmix);
    printf("  %s  %s\n", info, sheet);
    return 0;
}
