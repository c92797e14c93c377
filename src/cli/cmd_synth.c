/* esr synth: render a built-in scene into a complete dataset. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli/commands.h"
#include "synth/scene.h"
#include "synth/synth.h"

static int run_synth(int argc, char **argv);

const struct esr_command cmd_synth = {
    "synth",
    "render a built-in scene into a complete ESR-NeRF dataset",
    "usage: esr synth [options] OUT_DIR\n"
    "\n"
    "Renders a built-in analytic scene with a path tracer into OUT_DIR in the dataset layout of\n"
    "FORMAT.md (train, test_nv, test_nvi, test_nvc, test_nvic, masks, transforms, scene.json) plus\n"
    "ground truth in OUT_DIR/gt (mesh.ply; per test camera normal, base colour, roughness,\n"
    "metallic and emission EXR maps). Written to a hidden sibling directory and renamed at the end.\n"
    "\n"
    "options:\n"
    "  --scene NAME   built-in scene (default: default); `--scene list` lists them\n"
    "  --res N        image width = height in pixels, 8..2048 (default: the scene's, 100 or 160)\n"
    "  --spp N        samples per pixel, 1..65536 (default: the scene's)\n"
    "  --train N      train views per lighting condition, 1..500 (default: the scene's, 50)\n"
    "  --test N       test cameras, 1..500 (default: the scene's, 10)\n"
    "  --seed S       seed of cameras and noise (default: 1)\n"
    "  --backdrop     the cameras see a distant backdrop where renders are transparent: opaque\n"
    "                 images like photographs of an object in a room (esr then learns the\n"
    "                 background, fields/background.h)\n"
    "  --force        replace a non-empty OUT_DIR\n"
    "  -h, --help     this text\n",
    run_synth,
    0, /* view_loop */
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

/* Parses a whole-string integer in [lo, hi]. */
static int parse_int(const char *text, long long lo, long long hi, long long *out)
{
    char *end;
    errno = 0;
    long long v = strtoll(text, &end, 10);
    if (errno || end == text || *end || v < lo || v > hi)
        return -1;
    *out = v;
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
    if (cli_wants_help(&cmd_synth, argc, argv)) {
        printf("\n");
        list_scenes(stdout);
        return 0;
    }
    struct esr_synth_options opt;
    memset(&opt, 0, sizeof opt);
    opt.scene = "default";
    opt.seed = 1;
    const char *out_dir = NULL;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        long long v;
        int has_value = i + 1 < argc;
        if (!strcmp(a, "--force")) {
            opt.force = 1;
        } else if (!strcmp(a, "--backdrop")) {
            opt.backdrop = 1;
        } else if (!strcmp(a, "--scene") && has_value) {
            opt.scene = argv[++i];
        } else if (!strcmp(a, "--res") && has_value) {
            if (parse_int(argv[++i], ESR_SYNTH_RES_MIN, ESR_SYNTH_RES_MAX, &v))
                return cli_fail(&cmd_synth, "--res must be an integer in %d..%d, got '%s'", ESR_SYNTH_RES_MIN,
                                ESR_SYNTH_RES_MAX, argv[i]);
            opt.res = (int)v;
        } else if (!strcmp(a, "--spp") && has_value) {
            if (parse_int(argv[++i], ESR_SYNTH_SPP_MIN, ESR_SYNTH_SPP_MAX, &v))
                return cli_fail(&cmd_synth, "--spp must be an integer in %d..%d, got '%s'", ESR_SYNTH_SPP_MIN,
                                ESR_SYNTH_SPP_MAX, argv[i]);
            opt.spp = (int)v;
        } else if ((!strcmp(a, "--train") || !strcmp(a, "--test")) && has_value) {
            if (parse_int(argv[++i], 1, 500, &v))
                return cli_fail(&cmd_synth, "%s must be an integer in 1..500, got '%s'", a, argv[i]);
            *(!strcmp(a, "--train") ? &opt.n_train : &opt.n_test) = (int)v;
        } else if (!strcmp(a, "--seed") && has_value) {
            if (parse_int(argv[++i], 0, 9223372036854775807LL, &v))
                return cli_fail(&cmd_synth, "--seed must be a non-negative integer, got '%s'", argv[i]);
            opt.seed = (uint64_t)v;
        } else if (a[0] == '-' && a[1]) {
            return cli_fail(&cmd_synth, "unknown option or missing value: '%s'", a);
        } else if (out_dir) {
            return cli_fail(&cmd_synth, "more than one OUT_DIR given ('%s', '%s')", out_dir, a);
        } else {
            out_dir = a;
        }
    }
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
