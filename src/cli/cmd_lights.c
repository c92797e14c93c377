/* esr lights RUN: the lights the run found (ids, place, size, colour as `esr edit` takes it,
 * strength) as a table; on request, or when --recompute or --drop changes them, RUN/lights.json
 * and a picture of where each light is. */
#include <signal.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli/commands.h"
#include "cli/lights_listing.h"
#include "core/error.h"
#include "eval/run_dir.h"
#include "io/dataset.h"
#include "io/dir.h"
#include "io/file.h"
#include "io/image.h"
#include "io/json_file.h"
#include "model/model.h"
#include "render/lights_picture.h"
#include "train/lights/lights.h"
#include "train/rays.h"

static int run_lights(int argc, char **argv);

#define LIGHTS_MAX_SETS 16
struct lights_args {
    const char *run, *data, *drop, *json, *picture;
    int again;
    struct cli_texts set; /* --set key=value: the lights' options */
};

static int lights_set(void *args, const struct cli_option *o, const char *value);

#define AT(field) offsetof(struct lights_args, field)
static const struct cli_option lights_options[] = {
    {"RUN", .kind = CLI_ARG, .at = AT(run)},
    {"--recompute", NULL, "find and calibrate the lights again and store them in the checkpoint (a "
     "run whose pdra stage found none keeps none unless asked)", CLI_FLAG, .at = AT(again)},
    {"--drop", "IDS", "remove these lights (ids as listed now; a reflection you judge no light, "
     "such as a mirror's view of a lamp: it then follows the lights it reflects in relights "
     "instead of glowing on), calibrate the others again without them and store the result in the "
     "checkpoint; --recompute brings them back", CLI_TEXT, .at = AT(drop)},
    {"--json", "FILE.json", "write the lights as JSON to FILE.json (as RUN/lights.json, above)",
     CLI_TEXT, .at = AT(json)},
    {"--picture", "FILE.png", "write where each light is: the lights-on training photo that shows "
     "the most lights' centroids, enlarged to at least 256 pixels wide, each light's id in a black "
     "box beside a cross at its centroid (occlusion not tested: a light behind an object is marked "
     "where it would be seen)", CLI_TEXT, .at = AT(picture)},
    {"--set", "key=value", "with --recompute or --drop: one of the lights' options, every "
     "training option named lights_... and emitter_k (`esr train --help` lists and says each), "
     "kept in the checkpoint", CLI_TEXTS, .at = AT(set), .hi = LIGHTS_MAX_SETS, .call = lights_set},
    {"--data", "DIR", "the dataset whose training images --recompute and --drop read (lights-off "
     "to calibrate, lights-on for the colour) and --picture shows (default: the one RUN was "
     "trained on)", CLI_TEXT, .at = AT(data)},
    {0},
};

const struct esr_command cmd_lights = {
    .name = "lights",
    .summary = "list the lights a run found (id, place, area, colour as `esr edit` takes it, "
               "power) and where they are",
    .usage =
    "usage: esr lights RUN [--recompute | --drop ID[,ID...]] [--set key=value ...]\n"
    "                  [--json FILE.json] [--picture FILE.png] [--data DIR]\n"
    "\n"
    "Reads the lights stored in RUN's pdra checkpoint (found and calibrated when the pdra stage\n"
    "ended: the emitting surface split into connected lights, each light's strength fixed by the\n"
    "light it casts on the rest of the scene) and prints them: id (what `esr edit --light` takes),\n"
    "centroid and area, emitted radiance R G B with its H S V (H and S as `esr edit --color H,S`\n"
    "takes them), power and the strength calibration. Units: positions in the dataset's world\n"
    "units; radiance linear RGB on the photos' scale (a pixel's sRGB value made linear: 1 is white\n"
    "in a photo; the strength is calibrated from the light the lights cast in the lights-off\n"
    "photos); power = luminance(R G B) x pi x area (a Lambertian emitter, one side), in radiance\n"
    "units x world units^2. Listing writes nothing unless asked (--json, --picture);\n"
    "--recompute and --drop, which change the lights, write the checkpoint, RUN/lights.json and\n"
    "RUN/lights.png together, each aside first and then renamed: an error or an interruption\n"
    "(Ctrl-C, SIGTERM) before they are all written leaves the three as they were.\n"
    "\n"
    "lights.json:\n"
    "  {\"lights\": [{\"id\", \"centroid\", \"area\", \"points\", \"unseen_points\" (of its surface\n"
    "               points, those whose emission no photo shows: no camera sees them, or only\n"
    "               lights-off or clipped photos do), \"rgb\" (emitted radiance, linear), \"hsv\" (of\n"
    "               rgb: H, S in [0,1], V = max(rgb), linear), \"power\", \"field_rgb\",\n"
    "               \"strength_scale\", \"calibration_points\",\n"
    "               \"strength_fitted\" (false: too small to fit, the fitted lights' area-weighted mean scale),\n"
    "               solved from the lights-on photos (lights_solve 1): \"strength_uncertainty\"\n"
    "               (relative statistical standard error), \"strength_lower_bound_only\" (no\n"
    "               unclipped pixel shows its light), \"inseparable_from\" (ids of lights only the\n"
    "               sum with which the photos fix)}...],\n"
    "   \"strength_assumption\" (the one scale the strengths share with the environment map and\n"
    "   the base colour),\n"
    "   \"emitter_k\", \"checkpoint\", \"units\", \"colour_balance\" (the base colour's factor per\n"
    "   channel, the environment map's divisor, set from the lights' silhouettes in the lights-on\n"
    "   photos; 1 1 1: none)}\n",
    .options = lights_options,
    .run = run_lights,
};

/* Only the lights' own options change here. */
static int lights_set(void *args, const struct cli_option *o, const char *value)
{
    (void)args;
    if (strncmp(value, "lights_", 7) && strncmp(value, "emitter_k=", 10))
        return cli_fail(&cmd_lights, "%s %s: only the lights' options (lights_..., emitter_k) "
                        "change here; the others are the training's", o->name, value);
    return 0;
}

/* Finds (find) and calibrates the lights of m from the training rays of ds, loaded from DATA
 * (the lights-off ones calibrate, the lights-on ones balance their colour): the trainer's
 * esr_lights_estimate, with its lines on the terminal. */
static int find_and_calibrate(struct esr_model *m, const struct esr_dataset *ds, const char *data,
                              int find)
{
    struct esr_ray_set rs;
    memset(&rs, 0, sizeof rs);
    int rc = esr_ray_set_build(&rs, ds, ESR_PHASE_TRAIN);
    if (rc == ESR_OK && rs.n_off == 0)
        rc = ESR_FAIL("dataset %s: no lights-off training images to calibrate with", data);
    const struct esr_lights_estimate_opts eo = {find, 1, 1, (uint64_t)m->cfg.seed};
    struct esr_lights_report rep;
    if (rc == ESR_OK)
        rc = esr_lights_estimate(m, &rs, &eo, &rep);
    for (int i = 0; rc == ESR_OK && i < rep.n; i++)
        if (strncmp(rep.line[i], "  light ", 8)) /* the table below says each light */
            fprintf(stderr, "esr lights: %s%s\n", rep.warning[i] ? "warning: " : "", rep.line[i]);
    esr_ray_set_free(&rs);
    return rc;
}

/* Removes the lights whose ids (as listed before) the comma-separated list names. */
static int drop_lights(struct esr_model *m, const char *list)
{
    if (m->lights.n == 0)
        return ESR_FAIL("--drop: the run has no lights");
    int drop[ESR_MAX_LIGHTS] = {0}, dropping = 0;
    if (!*list)
        return ESR_FAIL("--drop: expected light ids from 0 to %d, separated by commas", m->lights.n - 1);
    for (const char *at = list; *at;) {
        char *end;
        const long id = strtol(at, &end, 10);
        if (end == at || (*end && *end != ',') || id < 0 || id >= m->lights.n)
            return ESR_FAIL("--drop %s: expected light ids from 0 to %d, separated by commas", list,
                            m->lights.n - 1);
        dropping += !drop[id];
        drop[id] = 1;
        at = *end ? end + 1 : end;
    }
    if (dropping == m->lights.n) /* with none, renders fall back to the raw field everywhere */
        return ESR_FAIL("--drop %s would leave no lights (keep at least one; --recompute finds them "
                        "again)", list);
    for (int id = m->lights.n - 1; id >= 0; id--) /* highest first: the others keep their ids */
        if (drop[id]) {
            ESR_TRY(esr_lights_drop(&m->lights, id));
            fprintf(stderr, "esr lights: dropped light %d\n", id);
        }
    return ESR_OK;
}

/* One file the command writes: its bytes are made first (kind), then written aside (cli_aside:
 * a temporary name a later esr removes if this one is killed, io/stale.h) and moved onto path
 * once every file is aside. */
enum out_kind { OUT_CKPT, OUT_JSON, OUT_PICTURE };
struct out_file {
    enum out_kind kind;
    char path[4200];
};

static int add_out(struct out_file *o, int *n, enum out_kind kind, const char *path)
{
    for (int i = 0; i < *n; i++)
        if (!strcmp(o[i].path, path))
            return ESR_OK; /* --json RUN/lights.json with --recompute: once */
    o[*n].kind = kind;
    snprintf(o[*n].path, sizeof o[*n].path, "%s", path);
    (*n)++;
    return ESR_OK;
}

/* Writes file o's bytes to `to`. */
static int write_one(const struct out_file *o, const char *to, const struct esr_model *m,
                     const char *ckpt, const long *unseen, const struct esr_image *picture)
{
    switch (o->kind) {
    case OUT_CKPT:
        return esr_model_save(m, to);
    case OUT_JSON:
        return esr_json_write_atomic(to, esr_cli_lights_json(m, ckpt, unseen));
    case OUT_PICTURE:
        return esr_png_write(to, picture, 8);
    }
    return ESR_OK;
}

/* Every file aside, then all moved onto their paths together (cli_aside_commit, signals held
 * off): an interruption before the move (the flag, cli_interrupted) leaves every path as it
 * was, one after it finds them all written. On a failure the files aside are removed. */
static int write_all(struct out_file *o, int n, const struct esr_model *m, const char *ckpt,
                     const long *unseen, const struct esr_image *picture)
{
    struct cli_aside aside = {0};
    int rc = ESR_OK;
    for (int i = 0; rc == ESR_OK && i < n; i++) {
        const char *to = cli_aside_add(&aside, o[i].path);
        rc = to ? write_one(&o[i], to, m, ckpt, unseen, picture)
                : ESR_FAIL("cannot write '%s': path too long", o[i].path);
    }
    if (rc == ESR_OK && cli_interrupted())
        rc = ESR_FAIL("interrupted: nothing written");
    if (rc != ESR_OK) {
        cli_aside_discard(&aside);
        return rc;
    }
    ESR_TRY(cli_aside_commit(&aside));
    for (int i = 0; i < n; i++)
        fprintf(stderr, "wrote %s\n", o[i].path);
    return ESR_OK;
}

/* The picture of where the lights are, and what it says (frame, lights out of view). */
static int make_picture(const struct esr_model *m, const struct esr_dataset *ds,
                        struct esr_image *out)
{
    char frame[ESR_NAME_MAX];
    int shown[ESR_MAX_LIGHTS];
    ESR_TRY(esr_lights_picture(&m->lights, ds, out, frame, sizeof frame, shown));
    fprintf(stderr, "esr lights: picture from training frame %s (%dx%d)", frame, out->width,
            out->height);
    int first = 1;
    for (int i = 0; i < m->lights.n; i++)
        if (!shown[i]) {
            fprintf(stderr, "%s%d", first ? "; out of its view: light " : ", ", i);
            first = 0;
        }
    fprintf(stderr, "\n");
    return ESR_OK;
}

static int lights(const struct lights_args *a)
{
    const int change = a->again || a->drop;
    char ckpt[4200], data[4096], path[4200];
    snprintf(ckpt, sizeof ckpt, "%s/ckpt_pdra.bin", a->run);
    struct out_file out[4];
    int n_out = 0;
    if (change) {
        add_out(out, &n_out, OUT_CKPT, ckpt);
        snprintf(path, sizeof path, "%s/lights.json", a->run);
        add_out(out, &n_out, OUT_JSON, path);
        snprintf(path, sizeof path, "%s/lights.png", a->run);
        add_out(out, &n_out, OUT_PICTURE, path);
    }
    if (a->json)
        add_out(out, &n_out, OUT_JSON, a->json);
    if (a->picture)
        add_out(out, &n_out, OUT_PICTURE, a->picture);
    for (int i = 0; i < n_out; i++) /* a missing folder is found now, not after the work */
        ESR_TRY(esr_file_check_writable(out[i].path));
    int want_picture = 0;
    for (int i = 0; i < n_out; i++)
        want_picture |= out[i].kind == OUT_PICTURE;
    struct esr_model m;
    ESR_TRY(esr_model_load_finished_pdra(&m, a->run));
    int lock = -1, have_ds = 0;
    struct esr_dataset ds;
    int rc = ESR_OK;
    for (int i = 0; rc == ESR_OK && i < a->set.n; i++) /* kept in the checkpoint written */
        rc = esr_config_set(&m.cfg, a->set.v[i]);
    if (rc == ESR_OK && change) /* not beside a training of this run, nor another change of its lights */
        rc = esr_dir_lock(a->run, "lights", &lock);
    if (rc == ESR_OK && (change || want_picture))
        rc = esr_run_data_dir(a->run, a->data, data, sizeof data);
    if (rc == ESR_OK && (change || want_picture)) {
        rc = esr_dataset_load(data, &ds);
        have_ds = rc == ESR_OK;
    }
    if (rc == ESR_OK && a->drop)
        rc = drop_lights(&m, a->drop);
    if (rc == ESR_OK && change)
        rc = find_and_calibrate(&m, &ds, data, a->again);
    struct esr_image picture;
    memset(&picture, 0, sizeof picture);
    if (rc == ESR_OK && want_picture)
        rc = make_picture(&m, &ds, &picture);
    long unseen[ESR_MAX_LIGHTS]; /* each light's points whose emission no photo shows */
    if (rc == ESR_OK) {
        esr_lights_unseen_points(&m.lights, unseen);
        if (!cli_interrupted())
            esr_cli_lights_print(&m, unseen);
    }
    if (rc == ESR_OK && n_out > 0)
        rc = write_all(out, n_out, &m, ckpt, unseen, &picture);
    esr_image_free(&picture);
    if (have_ds)
        esr_dataset_free(&ds);
    esr_dir_unlock(lock);
    esr_model_free(&m);
    return rc;
}

static int run_lights(int argc, char **argv)
{
    struct lights_args a;
    memset(&a, 0, sizeof a);
    const int parsed = cli_parse(&cmd_lights, argc, argv, &a);
    if (parsed != CLI_PARSED)
        return parsed == CLI_HELPED ? 0 : 1;
    if (!a.run)
        return cli_fail(&cmd_lights, "missing RUN directory");
    if (a.data && !a.again && !a.drop && !a.picture)
        return cli_fail(&cmd_lights, "--data is read only with --recompute, --drop or --picture "
                        "(the lights are stored in RUN's pdra checkpoint)");
    if (a.set.n && !a.again && !a.drop)
        return cli_fail(&cmd_lights, "--set changes how the lights are found and calibrated: give "
                        "it with --recompute or --drop");
    if (a.again && a.drop)
        return cli_fail(&cmd_lights, "--drop names lights as listed now, which --recompute finds "
                        "anew: drop them after a --recompute");
    /* names that say what they hold: a slip such as `--json RUN/ckpt_pdra.bin` is refused, not
     * written over the checkpoint */
    if (a.picture && !cli_ends_with(a.picture, ".png"))
        return cli_fail(&cmd_lights, "--picture %s: the picture is a PNG; give a name ending in "
                        ".png", a.picture);
    if (a.json && !cli_ends_with(a.json, ".json"))
        return cli_fail(&cmd_lights, "--json %s: give a name ending in .json", a.json);
    /* a change of the lights finishes or leaves everything as it was (write_all) */
    if (a.again || a.drop)
        cli_catch_interrupt(&cmd_lights, 0);
    const int rc = lights(&a);
    const int interrupted = cli_interrupted();
    if (interrupted) {
        fprintf(stderr, "esr lights: interrupted (%s): %s\n",
                interrupted == SIGINT ? "SIGINT" : "SIGTERM",
                rc == ESR_OK ? "the lights had been written in full before it came"
                             : "the checkpoint, lights.json and lights.png are as they were");
        if (rc != ESR_OK)
            esr_error_clear();
        return 128 + interrupted;
    }
    return rc == ESR_OK ? 0 : cli_fail_lib(&cmd_lights);
}
