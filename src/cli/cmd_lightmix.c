/* esr lightmix RUN: a trained scene's views as light groups, one layer per light, for mixing the
 * lights after rendering (a compositor, or `esr edit --mix`). */
#include <omp.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/commands.h"
#include "cli/edit_views.h"
#include "cli/lightmix_page.h"
#include "cli/lights_listing.h"
#include "core/error.h"
#include "edit/editor.h"
#include "edit/light_mix.h"
#include "edit/relight.h"
#include "io/dir.h"
#include "io/image.h"
#include "io/json_file.h"
#include "model/model.h"
#include "render/view.h"

static int run_lightmix(int argc, char **argv);

struct lightmix_args {
    int argc;
    char **argv; /* for lightmix.json */
    const char *run, *out, *views, *data, *frames;
    int orbit, spp, size;
    enum esr_edit_method method;
};

static int method_value(void *args, const struct cli_option *o, const char *v);

#define AT(field) offsetof(struct lightmix_args, field)
static const struct cli_option lightmix_options[] = {
    {"RUN", .kind = CLI_ARG, .at = AT(run)},
    {"--out", "DIR", "the folder the layers, mix.json, lightmix.json and the page are written to",
     CLI_TEXT, .at = AT(out), .once = 1},
    {"--views", "PHASE", "the cameras of a dataset phase (default: test_nv), one view per frame, "
     "named as the frame (consecutive frames of one camera are rendered once)", CLI_TEXT,
     .at = AT(views), .once = 1},
    {"--frames", "a,b", "only these frames of the phase, by name (not with --orbit)", CLI_TEXT,
     .at = AT(frames), .once = 1},
    {"--orbit", "N", "N cameras on a circle around the scene at the first test camera's distance "
     "and height, written orbit_000 .. orbit_<N-1>", CLI_INT, .at = AT(orbit), .lo = 1, .hi = 3600,
     .once = 1, .bad = "--orbit: expected 1..3600 views, got '%s'"},
    {"--size", "W", "the views' width in pixels, the height to scale (default: the cameras')",
     CLI_INT, .at = AT(size), .lo = 8, .hi = 8192, .once = 1,
     .bad = "--size: expected a width of 8..8192 pixels, got '%s'"},
    {"--method", "M", "direct (default) or ratio, as `esr edit` renders them", CLI_CALL, .once = 1,
     .call = method_value},
    {"--spp", "N", "light samples per pixel and light (default 8)", CLI_INT, .at = AT(spp), .lo = 1,
     .hi = 4096, .once = 1, .bad = "--spp: expected 1..4096, got '%s'"},
    {"--data", "DIR", "dataset (default: the one RUN was trained on)", CLI_TEXT, .at = AT(data),
     .once = 1},
    {0},
};

const struct esr_command cmd_lightmix = {
    .name = "lightmix",
    .summary = "a trained scene's views as light groups: one EXR layer per light, mixed after "
               "rendering as `esr edit` would render the mix",
    .usage =
    "usage: esr lightmix RUN --out DIR [--views PHASE [--frames a,b] | --orbit N] [--size W]\n"
    "                    [--method direct|ratio] [--spp N] [--data DIR]\n"
    "\n"
    "Renders each view once as light groups and writes DIR/N.exr: one multi-layer OpenEXR (one\n"
    "part, 32-bit float) with the layers\n"
    "  off              the lights-off view (linear RGB on white)\n"
    "  light_K          light K (as `esr lights RUN` lists them) at its found emission: the light\n"
    "                   it casts and its own emission where the camera sees it\n"
    "  light_K_value    light K at unit colour times each emitting point's value V (max R,G,B):\n"
    "                   what a recolour multiplies\n"
    "each with R, G, B. off plus every light_K is the unedited view; any edit `esr edit` takes\n"
    "(--method direct or ratio, the same --spp) is off + sum over K of w_K x light_K, or with a\n"
    "recolour of light K to hue H, saturation S w_K x light_K_value, w_K its intensity times\n"
    "the colour (H, S, 1) in RGB, all times 2^exposure: equal to the edit's view to float\n"
    "rounding. Also writes DIR/mix.json (the found mix, as `esr edit --mix` takes it) and\n"
    "DIR/lightmix.json (the command, the model's fingerprint, the lights as `esr lights` lists\n"
    "them, the views and layers), and the LightMix page, DIR/index.html: open it in a browser\n"
    "(from the folder, no server or network; WebGL2) for a slider per light (0 to 10x), hue and\n"
    "saturation, exposure, the mix as an `esr edit` command line and as JSON to save or load;\n"
    "index.html#view=N&mix=JSON gives a view and a mix, &still=1 the image alone (DIR/N.js and\n"
    "DIR/lightmix.js hold what it shows). With --size the views are not the cameras' size that\n"
    "`esr edit` renders. DIR may not lie in RUN's render or eval folders, nor in the dataset\n"
    "unless inside RUN; it is replaced whole once everything is written.\n",
    .options = lightmix_options,
    .run = run_lightmix,
    .view_loop = 1,
};

static int method_value(void *args, const struct cli_option *o, const char *v)
{
    struct lightmix_args *a = args;
    if (esr_edit_method_from_name(v, &a->method) || a->method == ESR_EDIT_FINETUNE)
        return cli_fail(&cmd_lightmix, "%s: expected direct or ratio, got '%s'%s", o->name, v,
                        a->method == ESR_EDIT_FINETUNE ? " (a fine-tuned model's light is not "
                        "linear in the lights' emission: it has no light groups; `esr edit --mix "
                        "FILE --method finetune` renders a mix)" : "");
    return 0;
}

static int parse(int argc, char **argv, struct lightmix_args *a)
{
    memset(a, 0, sizeof(*a));
    a->argc = argc;
    a->argv = argv;
    a->spp = 8;
    a->method = ESR_EDIT_DIRECT;
    const int rc = cli_parse(&cmd_lightmix, argc, argv, a);
    if (rc != CLI_PARSED)
        return rc;
    if (!a->run)
        return cli_fail(&cmd_lightmix, "missing RUN directory");
    if (!a->out)
        return cli_fail(&cmd_lightmix, "missing --out DIR");
    if (a->views && a->orbit)
        return cli_fail(&cmd_lightmix, "--views and --orbit exclude each other");
    if (a->frames && a->orbit)
        return cli_fail(&cmd_lightmix, "--frames and --orbit exclude each other (the orbit's views "
                        "are new cameras, not the phase's frames)");
    return 0;
}

/* The layer names of n lights: off, light_K, light_K_value (names[1 + 2K], [2 + 2K]). */
#define LAYERS_MAX (1 + 2 * ESR_MAX_LIGHTS)
static void layer_names(int n, char (*names)[32], const char **ptrs)
{
    snprintf(names[0], 32, "off");
    for (int k = 0; k < n; k++) {
        snprintf(names[1 + 2 * k], 32, "light_%d", k);
        snprintf(names[2 + 2 * k], 32, "light_%d_value", k);
    }
    for (int i = 0; i < 1 + 2 * n; i++)
        ptrs[i] = names[i];
}

/* DIR/N.exr: the view's layers, 32-bit float. */
static int write_layers(const char *dir, const char *name, const struct esr_relight_layers *L)
{
    char names[LAYERS_MAX][32], path[4400];
    const char *ptrs[LAYERS_MAX];
    struct esr_image img[LAYERS_MAX];
    layer_names(L->n_lights, names, ptrs);
    img[0] = L->off;
    for (int k = 0; k < L->n_lights; k++)
        img[1 + 2 * k] = L->light[k], img[2 + 2 * k] = L->value[k];
    ESR_TRY(esr_view_path(path, sizeof path, dir, name, ".exr"));
    return esr_exr_write_layers(path, img, ptrs, 1 + 2 * L->n_lights, ESR_EXR_FLOAT, ESR_EXR_ZIP);
}

/* DIR/lightmix.json: what made the folder, the model's fingerprint, the lights as `esr lights`
 * lists them, the method, the views (each with its size) and the layers. */
static int write_record(const char *dir, const struct lightmix_args *a, const struct esr_model *m,
                        char (*views)[ESR_NAME_MAX], const int (*size)[2], int n)
{
    cJSON *r = cli_record("lightmix", a->argc, a->argv);
    char fp[32], path[4400];
    snprintf(fp, sizeof fp, "%016llx", (unsigned long long)esr_model_fingerprint(m));
    cJSON_AddStringToObject(r, "run", a->run);
    cJSON_AddStringToObject(r, "model_fingerprint", fp);
    cJSON_AddStringToObject(r, "method", esr_edit_method_name(a->method));
    cJSON_AddNumberToObject(r, "spp", a->spp);
    long unseen[ESR_MAX_LIGHTS];
    esr_lights_unseen_points(&m->lights, unseen);
    cJSON_AddItemToObject(r, "lights", esr_cli_lights_json(m, "ckpt_pdra.bin", unseen));
    char names[LAYERS_MAX][32];
    const char *ptrs[LAYERS_MAX];
    layer_names(m->lights.n, names, ptrs);
    cJSON *layers = cJSON_AddArrayToObject(r, "layers");
    for (int i = 0; i < 1 + 2 * m->lights.n; i++)
        cJSON_AddItemToArray(layers, cJSON_CreateString(ptrs[i]));
    cJSON *v = cJSON_AddArrayToObject(r, "views");
    for (int i = 0; i < n; i++) {
        cJSON *e = cJSON_CreateObject();
        cJSON_AddStringToObject(e, "name", views[i]);
        cJSON_AddNumberToObject(e, "width", size[i][0]);
        cJSON_AddNumberToObject(e, "height", size[i][1]);
        cJSON_AddItemToArray(v, e);
    }
    snprintf(path, sizeof path, "%s/lightmix.json", dir);
    return esr_json_write_atomic(path, r);
}

/* DIR/mix.json: the found mix. */
static int write_found_mix(const char *dir, int n_lights)
{
    struct esr_light_mix mix;
    char path[4400];
    esr_light_mix_found(&mix, n_lights);
    snprintf(path, sizeof path, "%s/mix.json", dir);
    return esr_json_write_atomic(path, esr_light_mix_json(&mix));
}

static int lightmix(const struct lightmix_args *a)
{
    struct esr_model m;
    memset(&m, 0, sizeof m);
    int rc = esr_model_load_finished_pdra(&m, a->run);
    if (rc == ESR_OK && m.lights.n == 0)
        rc = ESR_FAIL("%s found no lights (its pdra stage found no emitters; the run's log says "
                      "why): nothing to mix", a->run);
    struct edit_views ev;
    memset(&ev, 0, sizeof ev);
    if (rc == ESR_OK)
        rc = edit_views_open(&ev, a->run, a->data, a->views, a->frames, a->orbit, a->size, &m);
    if (rc == ESR_OK)
        rc = edit_check_out(a->run, a->out, ev.sel.ds.root);
    struct edit_output eo;
    memset(&eo, 0, sizeof eo);
    static const char *const ours[] = {"mix.json", "lightmix.json", "index.html", NULL};
    static const char *const our_exts[] = {".exr", ".js", NULL};
    if (rc == ESR_OK)
        rc = edit_output_begin(&eo, a->out, ours, our_exts, "esr lightmix");
    struct esr_relight r;
    memset(&r, 0, sizeof r);
    if (rc == ESR_OK)
        rc = esr_relight_init(&r, &m, a->spp,
                              a->method == ESR_EDIT_RATIO ? ESR_RELIGHT_RATIO : ESR_RELIGHT_DIRECT);
    const int views = ev.n;
    char(*names)[ESR_NAME_MAX] = rc == ESR_OK ? calloc((size_t)views, sizeof *names) : NULL;
    int(*size)[2] = rc == ESR_OK ? calloc((size_t)views, sizeof *size) : NULL;
    int *data_of = rc == ESR_OK ? calloc((size_t)views, sizeof *data_of) : NULL;
    if (rc == ESR_OK && (!names || !size || !data_of))
        rc = ESR_FAIL("out of memory for %d view names", views);
    if (rc == ESR_OK)
        fprintf(stderr, "rendering %d view%s as %d light groups (%s, %d samples per pixel and "
                "light)\n", views, views == 1 ? "" : "s", m.lights.n,
                esr_edit_method_name(a->method), a->spp);
    /* the previous view's layers: a phase's off and on frames of one camera give the same layers
     * (esr edit renders them once too, with the first frame's seed) */
    struct esr_relight_layers prev;
    memset(&prev, 0, sizeof prev);
    struct esr_camera prev_cam;
    memset(&prev_cam, 0, sizeof prev_cam);
    const double t_all = omp_get_wtime();
    for (int v = 0; rc == ESR_OK && v < views; v++) {
        if (cli_interrupted()) {
            rc = ESR_FAIL("interrupted after %d of %d views: nothing was written (%s is as it was)",
                          v, views, a->out);
            break;
        }
        struct esr_camera cam;
        rc = edit_views_camera(&ev, v, &cam, names[v]);
        const double t0 = omp_get_wtime();
        const int same = prev.n_lights && !memcmp(&cam, &prev_cam, sizeof cam);
        if (rc == ESR_OK && !same) {
            esr_relight_layers_free(&prev);
            rc = esr_relight_layers(&r, &m, &cam, (uint64_t)v, &prev, NULL);
            prev_cam = cam;
        }
        const double secs = omp_get_wtime() - t0;
        size[v][0] = cam.width, size[v][1] = cam.height;
        data_of[v] = same ? data_of[v - 1] : v; /* the page loads the layers once */
        if (rc == ESR_OK)
            rc = write_layers(eo.staging, names[v], &prev);
        if (rc == ESR_OK && !same)
            rc = lightmix_page_view(eo.staging, names[v], &prev);
        if (rc == ESR_OK)
            fprintf(stderr, "  %-16s %4d / %-4d  %.2f s%s\n", names[v], v + 1, views, secs,
                    same ? " (the previous frame's camera: its layers)" : "");
    }
    esr_relight_layers_free(&prev);
    if (rc == ESR_OK)
        rc = write_found_mix(eo.staging, m.lights.n);
    const struct lightmix_page page = {a->run, esr_edit_method_name(a->method),
                                       a->orbit ? NULL : a->views ? a->views : "test_nv", a->spp,
                                       a->orbit, a->size, views, (const char(*)[ESR_NAME_MAX])names,
                                       (const int(*)[2])size, data_of};
    if (rc == ESR_OK)
        rc = lightmix_page_write(eo.staging, &page, &m);
    if (rc == ESR_OK)
        rc = write_record(eo.staging, a, &m, names, (const int(*)[2])size, views);
    rc = edit_output_end(&eo, rc);
    if (rc == ESR_OK) {
        fprintf(stderr, "wrote %d view%s light groups to %s in %.1f s (N.exr: layers off, light_0 "
                "... light_%d and their _value layers; %s%s), mix.json, lightmix.json and the page: "
                "open %s/index.html in a browser\n", views,
                views == 1 ? "'s" : "s'", a->out, omp_get_wtime() - t_all, m.lights.n - 1, names[0],
                views > 1 ? " ..." : "", a->out);
    }
    free(names);
    free(size);
    free(data_of);
    esr_relight_free(&r);
    esr_model_free(&m);
    edit_views_free(&ev);
    return rc;
}

static int run_lightmix(int argc, char **argv)
{
    struct lightmix_args a;
    const int rc = parse(argc, argv, &a);
    if (rc != CLI_PARSED)
        return rc == CLI_HELPED ? 0 : 1;
    cli_catch_interrupt(&cmd_lightmix, 0);
    if (lightmix(&a) == ESR_OK)
        return 0;
    cli_fail_lib(&cmd_lightmix);
    return cli_interrupted() ? 128 + cli_interrupted() : 1;
}
