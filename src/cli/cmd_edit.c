/* esr edit RUN: relight a trained scene (turn lights up, down, off, recolour them) and render it. */
#include <math.h>
#include <omp.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/commands.h"
#include "cli/edit_views.h"
#include "core/colour.h"
#include "core/error.h"
#include "core/vec3.h"
#include "edit/editor.h"
#include "edit/light_mix.h"
#include "eval/run_dir.h"
#include "io/dir.h"
#include "io/image.h"
#include "io/json_file.h"
#include "model/model.h"
#include "render/view.h"

static int run_edit(int argc, char **argv);

struct edit_args {
    int argc;
    char **argv; /* for edit.json */
    const char *run, *out, *views, *data, *frames, *mix;
    double exposure;
    int orbit, spp, n_groups, iters, has_exposure;
    enum esr_edit_method method;
    struct {
        int light; /* -1 = all */
        struct esr_light_edit e;
        int has_intensity, has_colour; /* an --intensity, a --color follows */
    } g[ESR_MAX_LIGHTS * 2];
};

static int light_group(void *args, const struct cli_option *o, const char *v);
static int group_value(void *args, const struct cli_option *o, const char *v);
static int method_value(void *args, const struct cli_option *o, const char *v);
static int exposure_given(void *args, const struct cli_option *o, const char *v);

#define AT(field) offsetof(struct edit_args, field)
/* --light, --intensity and --color make the groups (their handlers); the others are once each */
static const struct cli_option edit_options[] = {
    {"RUN", .kind = CLI_ARG, .at = AT(run)},
    {"--light", "ID|all", "starts a group: the light's id (as `esr lights RUN` lists them) or all",
     CLI_CALL, .call = light_group},
    {"--intensity", "X", "the group's light strength times X (0 = off, at most 1e6)", CLI_CALL,
     .call = group_value},
    {"--color", "H,S", "the group's hue and saturation, both in [0,1] (its value kept)", CLI_CALL,
     .call = group_value},
    {"--mix", "FILE", "the edit as a mix JSON (`esr lightmix` writes one, its page saves one): "
     "instead of --light groups and --exposure", CLI_TEXT, .at = AT(mix), .once = 1},
    {"--exposure", "STOPS", "the views' linear RGB times 2^STOPS (default 0)", CLI_DOUBLE,
     .at = AT(exposure), .lo = -ESR_MIX_MAX_EXPOSURE, .hi = ESR_MIX_MAX_EXPOSURE, .once = 1,
     .bad = "--exposure: expected stops in -20..20, got '%s'", .call = exposure_given},
    {"--method", "M", "direct (default), ratio or finetune (above)", CLI_CALL, .once = 1,
     .call = method_value},
    {"--out", "DIR", "the folder the views and edit.json are written to", CLI_TEXT, .at = AT(out),
     .once = 1},
    {"--views", "PHASE", "the cameras of a dataset phase (default: test_nv), one view per frame, "
     "named as the frame (c000_off and c000_on alike; consecutive frames of one camera are "
     "rendered once)", CLI_TEXT, .at = AT(views), .once = 1},
    {"--orbit", "N", "N cameras on a circle around the scene at the first test camera's distance "
     "and height, written orbit_000 .. orbit_<N-1>", CLI_INT, .at = AT(orbit), .lo = 1, .hi = 3600,
     .once = 1, .bad = "--orbit: expected 1..3600 views, got '%s'"},
    {"--frames", "a,b", "only these frames of the phase, by name (not with --orbit)", CLI_TEXT,
     .at = AT(frames), .once = 1},
    {"--spp", "N", "light samples per pixel and light (default 8; finetune: on lights' pixels)",
     CLI_INT, .at = AT(spp), .lo = 1, .hi = 4096, .once = 1,
     .bad = "--spp: expected 1..4096, got '%s'"},
    {"--iters", "N", "finetune: steps of the fine-tune (default 300; refused with other methods)",
     CLI_INT, .at = AT(iters), .lo = 1, .hi = 1000000, .once = 1,
     .bad = "--iters: expected 1..1000000, got '%s'"},
    {"--data", "DIR", "dataset (default: the one RUN was trained on)", CLI_TEXT, .at = AT(data),
     .once = 1},
    {0},
};

const struct esr_command cmd_edit = {
    .name = "edit",
    .summary = "relight a trained scene: each light's intensity and colour, rendered from test or "
               "orbit views",
    .usage =
    "usage: esr edit RUN --light ID|all [--intensity X] [--color H,S] [--light ...]...\n"
    "                [--exposure STOPS] [--method direct|ratio|finetune] --out DIR\n"
    "                [--views PHASE | --orbit N] [--frames a,b] [--spp N] [--iters N] [--data DIR]\n"
    "       esr edit RUN --mix FILE [--method ...] --out DIR ...\n"
    "\n"
    "Edits the lights `esr lights RUN` lists (ids from 0) and renders the scene. Each --light\n"
    "starts a group; the --intensity and --color after it apply to that light (or to every light\n"
    "with `all`); lights not named stay as found. --intensity X multiplies the light's strength\n"
    "(0 = off, at most 1e6); --color H,S (both in [0,1]) replaces its hue and saturation, keeping\n"
    "its value (seed eqs. 10-15). Each --light needs one or both.\n"
    "Groups add up: `--light all --color 0.6,1 --light 0 --intensity 2` recolours every light and\n"
    "doubles light 0; two groups that set the same thing for one light are refused.\n"
    "--mix FILE gives the same edit as JSON, {\"lights\": [{\"id\": 0, \"intensity\": 0.5},\n"
    "{\"id\": 1, \"hue\": 0.6, \"saturation\": 1}], \"exposure\": 0} (a light left out stays as\n"
    "found; `esr lightmix` writes one and its page saves them).\n"
    "Writes per view DIR/N.png (linear through the sRGB curve, clipped) and DIR/N.exr (linear\n"
    "RGB on white); DIR may not lie in RUN's render or eval folders, nor in the dataset unless\n"
    "inside RUN. The views are written aside and replace DIR only once all are complete, with\n"
    "DIR/edit.json (the command, the model's fingerprint, each light's edit, the views): an\n"
    "error or Ctrl-C leaves DIR as it was. A DIR that holds other files than an earlier edit's\n"
    "is refused.\n"
    "\n"
    "methods:\n"
    "  direct     (default) the lights-off radiance plus the direct light of every light at its\n"
    "             edited strength and colour: area samples over each light's surface, shadow rays\n"
    "             against the SDF, the reconstructed BRDF (edit/relight.h); any colour works\n"
    "  ratio      the model's own lights-on radiance, its reflected light scaled per pixel and\n"
    "             channel by the edited over the found direct light (the same samples and\n"
    "             shadow rays as direct): light after bounces included, the lights' absolute\n"
    "             strength cancels; as fast as direct\n"
    "  finetune   the paper's radiance fine-tuning (edit/finetune.h): L_emo trained towards the\n"
    "             light transport with the edited emission (about 25 s per edit on 2 cores),\n"
    "             then the fine-tuned lights-on radiance rendered: interreflections included\n"
    "             (where a pixel sees a light, the lights' direct light as in direct)\n",
    .options = edit_options,
    .run = run_edit,
    .view_loop = 1,
};

/* "H,S" in [0,1] each (each as cli_parse_double reads numbers). */
static int parse_hs(const char *text, float *h, float *s)
{
    const char *comma = strchr(text, ',');
    char first[64];
    double a, b;
    if (!comma || (size_t)(comma - text) >= sizeof first)
        return -1;
    memcpy(first, text, (size_t)(comma - text));
    first[comma - text] = '\0';
    if (cli_parse_double(first, 0.0, 1.0, &a) || cli_parse_double(comma + 1, 0.0, 1.0, &b))
        return -1;
    *h = (float)a;
    *s = (float)b;
    return 0;
}

/* --light ID|all: a new group (the run's own range of ids is checked once its lights are
 * loaded). */
static int light_group(void *args, const struct cli_option *o, const char *v)
{
    struct edit_args *a = args;
    if (a->n_groups == (int)(sizeof a->g / sizeof a->g[0]))
        return cli_fail(&cmd_edit, "too many %s groups", o->name);
    int id = -1;
    if (strcmp(v, "all") && cli_parse_int(v, 0, 1000000, &id))
        return cli_fail(&cmd_edit, "--light: expected a light id (0, 1, ...) or 'all', got '%s'",
                        v);
    a->g[a->n_groups].light = id;
    a->g[a->n_groups].e.intensity = 1.0f;
    a->n_groups++;
    return 0;
}

/* --intensity X or --color H,S: once each in the group of the --light before it. */
static int group_value(void *args, const struct cli_option *o, const char *v)
{
    struct edit_args *a = args;
    if (a->n_groups == 0)
        return cli_fail(&cmd_edit, "%s before any --light", o->name);
    struct esr_light_edit *e = &a->g[a->n_groups - 1].e;
    const int intensity = !strcmp(o->name, "--intensity");
    int *has = intensity ? &a->g[a->n_groups - 1].has_intensity : &a->g[a->n_groups - 1].has_colour;
    if (*has)
        return cli_fail(&cmd_edit, "%s given twice after one --light", o->name);
    *has = 1;
    if (!intensity) {
        if (parse_hs(v, &e->hue, &e->sat))
            return cli_fail(&cmd_edit, "--color: expected H,S with both in [0,1], got '%s'", v);
        e->recolour = 1;
        return 0;
    }
    double x;
    if (cli_parse_double(v, 0.0, ESR_LIGHT_EDIT_MAX_INTENSITY, &x))
        return cli_fail(&cmd_edit, "--intensity: expected a number >= 0 and at most %g, got '%s'",
                        ESR_LIGHT_EDIT_MAX_INTENSITY, v);
    e->intensity = (float)x;
    return 0;
}

static int method_value(void *args, const struct cli_option *o, const char *v)
{
    struct edit_args *a = args;
    if (esr_edit_method_from_name(v, &a->method))
        return cli_fail(&cmd_edit, "%s: expected direct, ratio or finetune, got '%s'", o->name, v);
    return 0;
}

static int exposure_given(void *args, const struct cli_option *o, const char *v)
{
    (void)o, (void)v;
    ((struct edit_args *)args)->has_exposure = 1;
    return 0;
}

static int parse(int argc, char **argv, struct edit_args *a)
{
    memset(a, 0, sizeof(*a));
    a->argc = argc;
    a->argv = argv;
    a->spp = 8;
    a->method = ESR_EDIT_DIRECT;
    const int rc = cli_parse(&cmd_edit, argc, argv, a);
    if (rc != CLI_PARSED)
        return rc;
    if (!a->run)
        return cli_fail(&cmd_edit, "missing RUN directory");
    if (!a->out)
        return cli_fail(&cmd_edit, "missing --out DIR");
    if (a->mix && (a->n_groups || a->has_exposure))
        return cli_fail(&cmd_edit, "--mix and %s exclude each other (the mix gives each light's "
                        "edit and the exposure)", a->n_groups ? "--light" : "--exposure");
    if (a->n_groups == 0 && !a->mix)
        return cli_fail(&cmd_edit, "nothing to edit: give at least one --light ID|all, or --mix "
                        "FILE");
    for (int i = 0; i < a->n_groups; i++)
        if (!a->g[i].has_intensity && !a->g[i].has_colour) {
            char id[16] = "all";
            if (a->g[i].light >= 0)
                snprintf(id, sizeof id, "%d", a->g[i].light);
            return cli_fail(&cmd_edit, "--light %s has no --intensity or --color after it: nothing "
                            "to change", id);
        }
    if (a->views && a->orbit)
        return cli_fail(&cmd_edit, "--views and --orbit exclude each other");
    if (a->frames && a->orbit)
        return cli_fail(&cmd_edit, "--frames and --orbit exclude each other (the orbit's views are "
                        "new cameras, not the phase's frames)");
    if (a->iters && a->method != ESR_EDIT_FINETUNE)
        return cli_fail(&cmd_edit, "--iters is read only with --method finetune");
    return 0;
}

/* The per-light edits of the groups, for a model of n lights: each group sets what it gives
 * (intensity, colour) for its lights; fails on an unknown id or on two groups setting one thing
 * for one light. */
static int edits_of(const struct edit_args *a, int n, struct esr_light_edit *edits)
{
    int by_intensity[ESR_MAX_LIGHTS], by_colour[ESR_MAX_LIGHTS]; /* the group that set it, or -1 */
    for (int k = 0; k < n; k++) {
        edits[k] = (struct esr_light_edit){1.0f, 0, 0.0f, 0.0f};
        by_intensity[k] = by_colour[k] = -1;
    }
    for (int i = 0; i < a->n_groups; i++) {
        if (a->g[i].light >= n)
            return ESR_FAIL("no light %d: the run found %d light%s (ids 0..%d; `esr lights %s`)",
                            a->g[i].light, n, n == 1 ? "" : "s", n - 1, a->run);
        for (int k = 0; k < n; k++) {
            if (a->g[i].light >= 0 && a->g[i].light != k)
                continue;
            const int *by = a->g[i].has_intensity && by_intensity[k] >= 0 ? by_intensity
                            : a->g[i].has_colour && by_colour[k] >= 0   ? by_colour
                                                                         : NULL;
            if (by) {
                char first[16] = "all", second[16] = "all";
                if (a->g[by[k]].light >= 0)
                    snprintf(first, sizeof first, "%d", a->g[by[k]].light);
                if (a->g[i].light >= 0)
                    snprintf(second, sizeof second, "%d", a->g[i].light);
                return ESR_FAIL("light %d gets its %s from two groups (--light %s and --light %s): "
                                "give it once", k, by == by_intensity ? "--intensity" : "--color",
                                first, second);
            }
            if (a->g[i].has_intensity) {
                edits[k].intensity = a->g[i].e.intensity;
                by_intensity[k] = i;
            }
            if (a->g[i].has_colour) {
                edits[k].recolour = 1;
                edits[k].hue = a->g[i].e.hue;
                edits[k].sat = a->g[i].e.sat;
                by_colour[k] = i;
            }
        }
    }
    return ESR_OK;
}

/* The view's N.exr and N.png: linear RGB, and through the sRGB curve, clipped. */
static int write_view_files(const char *dir, const char *name, const struct esr_image *lin)
{
    char path[4400];
    const size_t size = sizeof path;
    ESR_TRY(esr_view_path(path, size, dir, name, ".exr"));
    ESR_TRY(esr_exr_write(path, lin, 0));
    struct esr_image png;
    ESR_TRY(esr_image_alloc(&png, lin->width, lin->height, 3));
    for (size_t i = 0; i < esr_image_count(lin); i++)
        png.data[i] = esr_srgb_from_linear(fminf(fmaxf(lin->data[i], 0.0f), 1.0f));
    int rc = esr_view_path(path, size, dir, name, ".png");
    if (rc == ESR_OK)
        rc = esr_png_write(path, &png, 8);
    esr_image_free(&png);
    return rc;
}

/* Writes the view's N.exr and N.png, its linear RGB times gain (the exposure). */
static int write_view(const char *dir, const char *name, const struct esr_image *view, float gain)
{
    struct esr_image exposed = *view, *lin = &exposed;
    if (gain != 1.0f) {
        ESR_TRY(esr_image_alloc(&exposed, view->width, view->height, 3));
        for (size_t i = 0; i < esr_image_count(view); i++)
            exposed.data[i] = view->data[i] * gain;
    }
    const int rc = write_view_files(dir, name, lin);
    if (gain != 1.0f)
        esr_image_free(&exposed);
    return rc;
}

/* DIR/edit.json: what made the folder (command, options, build, time), the model and its lights
 * by fingerprint, each light's edit and the views. */
static int write_record(const char *dir, const struct edit_args *a, const struct esr_model *m,
                        const struct esr_light_edit *edits, double exposure,
                        char (*names)[ESR_NAME_MAX], int views)
{
    cJSON *r = cli_record("edit", a->argc, a->argv);
    char fp[32];
    snprintf(fp, sizeof fp, "%016llx", (unsigned long long)esr_model_fingerprint(m));
    cJSON_AddStringToObject(r, "run", a->run);
    cJSON_AddStringToObject(r, "model_fingerprint", fp);
    cJSON_AddStringToObject(r, "method", esr_edit_method_name(a->method));
    cJSON_AddNumberToObject(r, "spp", a->spp);
    cJSON_AddNumberToObject(r, "exposure", exposure);
    cJSON *lights = cJSON_AddArrayToObject(r, "lights");
    for (int k = 0; k < m->lights.n; k++) {
        cJSON *l = cJSON_CreateObject();
        cJSON_AddNumberToObject(l, "id", k);
        cJSON_AddNumberToObject(l, "intensity", edits[k].intensity);
        if (edits[k].recolour) {
            cJSON_AddNumberToObject(l, "hue", edits[k].hue);
            cJSON_AddNumberToObject(l, "saturation", edits[k].sat);
        }
        cJSON_AddItemToArray(lights, l);
    }
    cJSON *v = cJSON_AddArrayToObject(r, "views");
    for (int i = 0; i < views; i++)
        cJSON_AddItemToArray(v, cJSON_CreateString(names[i]));
    char path[4400];
    snprintf(path, sizeof path, "%s/edit.json", dir);
    return esr_json_write_atomic(path, r);
}

/* The edit of a run of n lights: the --mix file's, or the groups' and --exposure. */
static int edit_mix(const struct edit_args *a, int n, struct esr_light_mix *mix)
{
    if (a->mix)
        return esr_light_mix_read(a->mix, n, mix);
    esr_light_mix_found(mix, n);
    mix->exposure = a->exposure;
    return edits_of(a, n, mix->edit);
}

static int edit(const struct edit_args *a)
{
    /* the run's lights first: a folder that is no finished run is named as such, not as one
     * that does not record its dataset */
    struct esr_model m;
    memset(&m, 0, sizeof m);
    int rc = esr_model_load_finished_pdra(&m, a->run);
    struct edit_views ev;
    memset(&ev, 0, sizeof ev);
    if (rc == ESR_OK)
        rc = edit_views_open(&ev, a->run, a->data, a->views, a->frames, a->orbit, 0, &m);
    struct esr_light_mix mix;
    if (rc == ESR_OK)
        rc = edit_mix(a, m.lights.n, &mix);
    const struct esr_light_edit *edits = mix.edit;
    struct esr_editor ed;
    memset(&ed, 0, sizeof ed);
    struct esr_finetune_opts ft;
    esr_finetune_default_opts(&ft);
    if (a->iters)
        ft.iters = a->iters;
    if (rc == ESR_OK)
        rc = edit_check_out(a->run, a->out, ev.sel.ds.root);
    /* the views go into a staging folder beside --out, which replaces it only once every view
     * and edit.json are written: a failed or interrupted edit leaves --out as it was */
    struct edit_output eo;
    memset(&eo, 0, sizeof eo);
    static const char *const ours[] = {"edit.json", NULL}, *const our_exts[] = {".png", ".exr", NULL};
    if (rc == ESR_OK)
        rc = edit_output_begin(&eo, a->out, ours, our_exts, "esr edit");
    if (rc == ESR_OK)
        rc = esr_editor_init(&ed, &m, &ev.sel.ds, a->method, a->spp, &ft);
    if (rc == ESR_OK && a->method == ESR_EDIT_FINETUNE)
        fprintf(stderr, "fine-tuning the lights-on radiance for the edit (%d steps)\n",
                ed.ft.o.iters);
    if (rc == ESR_OK)
        rc = esr_editor_set(&ed, edits, 0x5eedULL);
    if (rc == ESR_OK && a->method == ESR_EDIT_FINETUNE)
        fprintf(stderr, "fine-tuned in %.1f s (LTS emo MSE %.4g -> %.4g)\n", ed.last.seconds,
                ed.last.mse_first, ed.last.mse_last);
    const int views = ev.n;
    const float gain = rc == ESR_OK ? esr_light_mix_gain(&mix) : 1.0f;
    char(*names)[ESR_NAME_MAX] = rc == ESR_OK ? calloc((size_t)views, sizeof *names) : NULL;
    if (rc == ESR_OK && !names)
        rc = ESR_FAIL("out of memory for %d view names", views);
    /* the previous view: a phase's off and on frames of one camera give the same edited view
     * (the edit, not the frame, sets the lighting), so it is rendered once */
    struct esr_image prev = {0};
    struct esr_camera prev_cam;
    memset(&prev_cam, 0, sizeof prev_cam);
    for (int v = 0; rc == ESR_OK && v < views; v++) {
        if (cli_interrupted()) {
            rc = ESR_FAIL("interrupted after %d of %d views: nothing was written (%s is as it was)",
                          v, views, a->out);
            break;
        }
        char *name = names[v];
        struct esr_camera cam;
        rc = edit_views_camera(&ev, v, &cam, name);
        const double t0 = omp_get_wtime();
        const int same = prev.data && !memcmp(&cam, &prev_cam, sizeof cam);
        if (rc == ESR_OK && !same) {
            esr_image_free(&prev);
            rc = esr_editor_view(&ed, &cam, (uint64_t)v, &prev);
            prev_cam = cam;
        }
        const double secs = omp_get_wtime() - t0;
        if (rc == ESR_OK)
            rc = write_view(eo.staging, name, &prev, gain);
        if (rc == ESR_OK)
            fprintf(stderr, "  %-16s %4d / %-4d  %.2f s%s\n", name, v + 1, views, secs,
                    same ? " (the previous frame's camera: its view)" : "");
    }
    esr_image_free(&prev);
    if (rc == ESR_OK)
        rc = write_record(eo.staging, a, &m, edits, mix.exposure, names, views);
    rc = edit_output_end(&eo, rc);
    if (rc == ESR_OK) {
        fprintf(stderr, "wrote %d view%s to %s (N.png: sRGB, N.exr: linear; %s%s) and edit.json\n",
                views, views == 1 ? "" : "s", a->out, names[0], views > 1 ? " ..." : "");
    }
    free(names);
    esr_editor_free(&ed);
    esr_model_free(&m);
    edit_views_free(&ev);
    return rc;
}

static int run_edit(int argc, char **argv)
{
    struct edit_args a;
    const int rc = parse(argc, argv, &a);
    if (rc != CLI_PARSED)
        return rc == CLI_HELPED ? 0 : 1;
    cli_catch_interrupt(&cmd_edit, 0);
    if (edit(&a) == ESR_OK)
        return 0;
    cli_fail_lib(&cmd_edit);
    return cli_interrupted() ? 128 + cli_interrupted() : 1;
}
