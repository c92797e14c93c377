/* esr synth: render a built-in scene into a complete dataset. */
#include <errno.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli/commands.h"
#include "synth/scene.h"
#include "synth/synth.h"

static int run_synth(int argc, char **argv);

struct synth_args {
    struct esr_synth_options opt;
    const char *out_dir;
};

static int seed_value(void *args, const struct cli_option *o, const char *value);
static int curve_value(void *args, const struct cli_option *o, const char *value);
static void list_scenes(FILE *out);

#define AT(field) offsetof(struct synth_args, field)
static const struct cli_option synth_options[] = {
    {"OUT_DIR", .kind = CLI_ARG, .at = AT(out_dir)},
    {"--scene", "NAME", "built-in scene (default: default); `--scene list` lists them", CLI_TEXT,
     .at = AT(opt.scene)},
    {"--res", "N", "image width = height in pixels, 8..2048 (default: the scene's, 100 or 160)",
     CLI_INT, .at = AT(opt.res), .lo = ESR_SYNTH_RES_MIN, .hi = ESR_SYNTH_RES_MAX},
    {"--spp", "N", "samples per pixel, 1..65536 (default: the scene's)", CLI_INT, .at = AT(opt.spp),
     .lo = ESR_SYNTH_SPP_MIN, .hi = ESR_SYNTH_SPP_MAX},
    {"--train", "N", "train views per lighting condition, 1..500 (default: the scene's, 50)",
     CLI_INT, .at = AT(opt.n_train), .lo = 1, .hi = 500},
    {"--test", "N", "test cameras, 1..500 (default: the scene's, 10)", CLI_INT,
     .at = AT(opt.n_test), .lo = 1, .hi = 500},
    {"--seed", "S", "seed of cameras and noise (default: 1)", CLI_CALL, .call = seed_value},
    {"--backdrop", NULL, "the cameras see a distant backdrop where renders are transparent: opaque "
     "images like photographs of an object in a room (esr then learns the background, "
     "fields/background.h)", CLI_FLAG, .at = AT(opt.backdrop)},
    {"--exposure-jitter", "STOPS", "train photos: each exposed by 2^u, u uniform in +-STOPS, re-centred so "
     "the lights-off set's mean is 0 (default: 0; truth in gt/photos.json)", CLI_DOUBLE,
     .at = AT(opt.photo.exposure_jitter), .lo = 0.0, .hi = 4.0},
    {"--on-exposure", "STOPS", "train photos: the lights-on set's mean exposure, -8..8 stops (default: 0)",
     CLI_DOUBLE, .at = AT(opt.photo.on_exposure), .lo = -8.0, .hi = 8.0},
    {"--wb-jitter", "F", "train photos: per-photo per-channel white-balance gains uniform in 1 +- F, 0..0.9 "
     "(default: 0)", CLI_DOUBLE, .at = AT(opt.photo.wb_jitter), .lo = 0.0, .hi = 0.9},
    {"--wb-follow", NULL, "train photos: lights-on white balance half-corrects the lights' colour "
     "(src/synth/photo.h)", CLI_FLAG, .at = AT(opt.photo.wb_follow)},
    {"--curve", "NAME", "train photos' tone curve: srgb (default) or filmic (an S-curve, src/synth/photo.h)",
     CLI_CALL, .call = curve_value},
    {"--noise", "SIGMA", "train photos: Gaussian noise of SIGMA on the exposed linear values, 0..1 "
     "(default: 0)", CLI_DOUBLE, .at = AT(opt.photo.noise), .lo = 0.0, .hi = 1.0},
    {"--jpeg", "Q", "train photos as JPEG of quality Q, 1..100 (train/<name>.jpg; default: PNG)", CLI_INT,
     .at = AT(opt.photo.jpeg_quality), .lo = 1, .hi = 100},
    {"--exif", NULL, "with --jpeg: each JPEG carries EXIF ExposureTime, FNumber and ISO of its exposure "
     "(f/4, ISO 100, (1/60 s) * 2^stops)", CLI_FLAG, .at = AT(opt.photo.exif)},
    {"--force", NULL, "replace a non-empty OUT_DIR", CLI_FLAG, .at = AT(opt.force)},
    {0},
};

const struct esr_command cmd_synth = {
    .name = "synth",
    .summary = "render a built-in scene into a complete ESR-NeRF dataset",
    .usage =
    "usage: esr synth [options] OUT_DIR\n"
    "\n"
    "Renders a built-in analytic scene with a path tracer into OUT_DIR in the dataset layout of\n"
    "FORMAT.md (train, test_nv, test_nvi, test_nvc, test_nvic, masks, transforms, scene.json) plus\n"
    "ground truth in OUT_DIR/gt (mesh.ply; per test camera normal, base colour, roughness,\n"
    "metallic and emission EXR maps). Written to a hidden sibling directory and renamed at the end.\n",
    .options = synth_options,
    .help_more = list_scenes,
    .run = run_synth,
};

static void list_scenes(FILE *out)
{
    struct esr_synth_scene s;
    fprintf(out, "built-in scenes:\n");
    for (int i = 0; i < esr_synth_scene_count(); i++)
        if (esr_synth_scene_get(esr_synth_scene_name(i), &s) == 0)
            fprintf(out, "  %-8s %d light%s, %dx%d, %d spp: %s\n", s.name, s.n_lights, s.n_lights == 1 ? "" : "s",
                    s.res, s.res, s.spp, s.summary);
}

/* --seed: 64 bits, beyond cli_parse_int's int. */
static int seed_value(void *args, const struct cli_option *o, const char *value)
{
    struct synth_args *a = args;
    char *end;
    errno = 0;
    const long long v = strtoll(value, &end, 10);
    if (errno || end == value || *end || v < 0)
        return cli_fail(&cmd_synth, "%s must be a non-negative integer, got '%s'", o->name, value);
    a->opt.seed = (uint64_t)v;
    return 0;
}

/* --curve: a name of esr_photo_curve_parse. */
static int curve_value(void *args, const struct cli_option *o, const char *value)
{
    struct synth_args *a = args;
    const int curve = esr_photo_curve_parse(value);
    if (curve < 0)
        return cli_fail(&cmd_synth, "%s must be srgb or filmic, got '%s'", o->name, value);
    a->opt.photo.curve = (enum esr_photo_curve)curve;
    return 0;
}

struct progress_state {
    int tty;
};

static void show_progress(void *user, const struct esr_synth_progress *p)
{
    const struct progress_state *st = user;
    int last = p->done == p->total;
    if (!st->tty && !last)
        return;
    fprintf(stderr, "%s%-9s %4d / %-4d frames  %7.2f Msamples/s  %6.1f s%s", st->tty ? "\r" : "", p->phase, p->done,
            p->total, p->samples_per_s * 1e-6, p->elapsed_s, last ? "\n" : "");
    fflush(stderr);
}

static int run_synth(int argc, char **argv)
{
    struct synth_args a;
    memset(&a, 0, sizeof a);
    a.opt.scene = "default";
    a.opt.seed = 1;
    const int parsed = cli_parse(&cmd_synth, argc, argv, &a);
    if (parsed != CLI_PARSED)
        return parsed == CLI_HELPED ? 0 : 1;
    struct esr_synth_options opt = a.opt;
    const char *out_dir = a.out_dir;
    if (!strcmp(opt.scene, "list")) {
        list_scenes(stdout);
        return 0;
    }
    struct esr_synth_scene probe;
    if (esr_synth_scene_get(opt.scene, &probe) != 0)
        return cli_fail_lib(&cmd_synth);
    if (!out_dir)
        return cli_fail(&cmd_synth, "missing OUT_DIR");
    struct progress_state st = {isatty(STDERR_FILENO)};
    opt.progress = show_progress;
    opt.user = &st;
    if (esr_synth_write_dataset(out_dir, &opt) != 0) {
        if (st.tty)
            fprintf(stderr, "\n");
        return cli_fail_lib(&cmd_synth);
    }
    fprintf(stderr, "wrote %s (scene %s)\n", out_dir, opt.scene);
    return 0;
}
