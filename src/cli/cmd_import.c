/* esr import colmap: a COLMAP-posed photo capture into a dataset in the ESR layout. */
#include <stddef.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "cli/commands.h"
#include "core/error.h"
#include "io/dataset.h"
#include "io/dataset_summary.h"
#include "import/colmap_import.h"
#include "import/dtu_import.h"

static int run_import(int argc, char **argv);

#define DEFAULT_SIZE 400

struct import_args {
    struct cli_texts positional; /* colmap MODEL_DIR IMAGES, or dtu SCAN */
    const char *out, *align_to, *masks;
    int size; /* 0: not given (DEFAULT_SIZE) */
    int force;
};

#define AT(field) offsetof(struct import_args, field)
static const struct cli_option import_options[] = {
    {"SOURCE", .kind = CLI_ARGS, .at = AT(positional), .hi = 3},
    {"--out", "DATA", "output dataset folder (absent or empty unless --force)", CLI_TEXT,
     .at = AT(out)},
    {"--size", "N", "longer side of the written images in pixels, 8..16384 (default: 400)", CLI_INT,
     .at = AT(size), .lo = 8, .hi = 16384},
    {"--align-to", "TRUE_DATA", "align to and compare with true cameras (above)", CLI_TEXT,
     .at = AT(align_to)},
    {"--masks", "MASKS", "colmap: foreground masks (above)", CLI_TEXT, .at = AT(masks)},
    {"--force", NULL, "replace a non-empty DATA", CLI_FLAG, .at = AT(force)},
    {0},
};

const struct esr_command cmd_import = {
    .name = "import",
    .summary = "turn a COLMAP-posed photo capture or a DTU scan into a dataset (ESR layout)",
    .usage =
    "usage: esr import colmap MODEL_DIR IMAGES --out DATA [--size N | --align-to TRUE_DATA]\n"
    "                         [--masks MASKS] [--force]\n"
    "       esr import dtu SCAN --out DATA [--size N] [--force]\n"
    "\n"
    "colmap: photos with the lights off in IMAGES/off/, with the lights on in IMAGES/on/\n"
    "(JPEG or PNG, any names), all posed in one COLMAP sparse model MODEL_DIR (text: cameras.txt,\n"
    "images.txt, points3D.txt; or binary: the same names with .bin), its image names relative to\n"
    "IMAGES (\"off/x.jpg\"). Camera models: SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV.\n"
    "\n"
    "Writes DATA in the ESR layout: transforms/transforms_train.json (one light, mode \"off\" or\n"
    "\"on\" from the photo's folder), train/<stem>_off.png and train/<stem>_on.png, import.json\n"
    "(where the COLMAP world went). Every photo is undistorted into one centred pinhole shared by\n"
    "all frames (the field of view every camera covers; an off-centre principal point or fx != fy\n"
    "is resampled away) and area-filtered to the output size. The scene is centred on the median\n"
    "sparse point, scaled so 90% of the points lie within radius 1 (cameras no further than 4)\n"
    "and turned so the cameras' mean image-up is +Z. EXIF orientation is ignored, as COLMAP does.\n"
    "Without masks the photos are opaque and training learns their background (fields/background).\n"
    "--masks MASKS: foreground masks laid out as COLMAP reads them (--ImageReader.mask_path):\n"
    "MASKS/off/x.jpg.png for the photo off/x.jpg (or MASKS/off/x.png), one per registered photo,\n"
    "its size, > 127 = foreground; undistorted with the photo into the PNG's alpha (training then\n"
    "composites on white and ignores the background, as for DTU).\n"
    "\n"
    "dtu: a DTU scan as NeuS/IDR distribute it: SCAN/cameras_sphere.npz (world_mat_<n>, scale_mat_<n>),\n"
    "SCAN/image/<n>.png (000000.png, ...) and optionally SCAN/mask/<n>.png (> 127 = foreground). Every\n"
    "photo becomes a lights-off frame train/<n>_off.png, resampled into one centred pinhole like the\n"
    "COLMAP import; with masks the PNGs are RGBA, the mask as alpha (composited on white in training).\n"
    "The normalised frame's unit sphere becomes esr's (scale 1; less if the cameras' median distance\n"
    "exceeds 4), turned so the cameras' mean image-up is +Z; import.json records the mapping.\n"
    "\n"
    "DATA is written to a hidden sibling folder and renamed at the end.\n"
    "\n"
    "--align-to TRUE_DATA checks COLMAP against known cameras (a synthetic capture: TRUE_DATA is\n"
    "the dataset whose train images the photos are, named alike: off/r_003.png <-> train/r_003):\n"
    "the COLMAP cameras are aligned to the true ones by a similarity on the camera centres, which\n"
    "also places the scene, so DATA lives in TRUE_DATA's world; the photos are written in\n"
    "TRUE_DATA's pinhole (size, camera_angle_x) and its test_nv phase is copied in, so runs on both\n"
    "are scored on the same test views. Prints and records in import.json (\"alignment\") the\n"
    "median and largest rotation error (degrees) and camera-centre error (absolute and in units\n"
    "of the scene radius: half the largest side of scene.json's tight box, else 1).\n",
    .options = import_options,
    .run = run_import,
};

static void show_progress(void *user, int done, int total)
{
    const int tty = *(const int *)user;
    if (!tty && done != total)
        return;
    fprintf(stderr, "%sresampling photos %4d / %-4d%s", tty ? "\r" : "", done, total, done == total ? "\n" : "");
    fflush(stderr);
}

static void print_dtu_result(const struct esr_dtu_import_opts *o, const struct esr_dtu_import_result *r)
{
    printf("wrote %s from DTU scan %s\n", o->out_dir, o->scan_dir);
    printf("frames    %d (lights off)%s\n", r->n_frames, r->masks ? ", masks as alpha" : ", no masks");
    printf("images    %d x %d from %d x %d, focal %.2f px (camera_angle_x %.6f rad)\n", r->width, r->height,
           r->source_width, r->source_height, r->focal, r->camera_angle_x);
    printf("scene     unit sphere x %.4g\n", r->frame.scale);
    printf("cameras   %.2f .. %.2f from the origin\n", r->cam_dist_min, r->cam_dist_max);
}

/* A line of esr_dataset_exposure_warnings, as the import's other warnings are printed. */
static void print_warning(void *user, const char *line)
{
    (void)user;
    printf("warning   %s\n", line);
}

static void print_result(const struct esr_colmap_import_opts *o, const struct esr_colmap_import_result *r)
{
    printf("wrote %s from COLMAP %s model %s\n", o->out_dir, r->format, o->model_dir);
    printf("frames    %d (lights off %d, on %d)%s\n", r->n_frames, r->n_off, r->n_on,
           o->masks_dir ? ", masks as alpha" : "");
    printf("images    %d x %d, focal %.2f px (camera_angle_x %.6f rad)\n", r->width, r->height, r->focal,
           r->camera_angle_x);
    printf("scene     centre (%.4g, %.4g, %.4g), scale %.4g (from the %s)\n", r->frame.centre[0], r->frame.centre[1],
           r->frame.centre[2], r->frame.scale, r->frame.from_points ? "sparse points" : "camera centres");
    printf("cameras   %.2f .. %.2f from the origin\n", r->cam_dist_min, r->cam_dist_max);
    if (r->aligned) {
        const struct esr_colmap_alignment *a = &r->alignment;
        printf("aligned   to %s: %d of %d true train frames registered; scale %.6g\n", o->align_to, a->n_matched,
               a->n_true, a->colmap_to_true.scale);
        printf("rotation  error median %.4f deg, max %.4f deg\n", a->rot_median_deg, a->rot_max_deg);
        printf("position  error median %.5f, max %.5f (x scene radius %.4g: %.5f, %.5f)\n", a->pos_median,
               a->pos_max, a->scene_radius, a->pos_median_rel, a->pos_max_rel);
        printf("inliers   %d of %d within %.3g of their true centre: rotation median %.4f, max %.4f deg; "
               "position median %.5f, max %.5f\n", a->n_inliers, a->n_matched, a->inlier_threshold,
               a->rot_median_inliers_deg, a->rot_max_inliers_deg, a->pos_median_inliers, a->pos_max_inliers);
        printf("test      %d test_nv views copied\n", r->n_test_views);
        if (r->view_coverage < 0.999)
            printf("warning   the COLMAP cameras cover %.1f%% of the true field of view; the outermost pixels "
                   "repeat the photos' edges\n", 100.0 * r->view_coverage);
    }
    if (!r->n_on || !r->n_off)
        printf("warning   no lights-%s photos: the emitter stages need both\n", r->n_on ? "off" : "on");
    printf("exposure  EXIF exposure recorded for %d of %d photos\n", r->n_exposure, r->n_frames);
    if (r->n_exposure_bad)
        printf("warning   %d photo%s EXIF exposure left out as absurd (the first: %s)\n", r->n_exposure_bad,
               r->n_exposure_bad == 1 ? "'s" : "s'", r->exposure_bad);
    struct esr_dataset ds; /* what the frames' exposures say, as `esr info` says it */
    if (r->n_exposure && esr_dataset_load(o->out_dir, &ds) == ESR_OK) {
        struct esr_dataset_summary sum;
        esr_dataset_summarise(&ds, &sum);
        esr_dataset_exposure_warnings(&sum, print_warning, NULL);
        esr_dataset_free(&ds);
    } else {
        esr_error_clear();
    }
}

/* The DTU import with the options parsed for both sources. */
static int run_dtu(const char **positional, int n_pos, const struct esr_colmap_import_opts *common, int *tty)
{
    if (n_pos != 2)
        return cli_fail(&cmd_import, "expected exactly SCAN after 'dtu'");
    struct esr_dtu_import_opts o = {positional[1], common->out_dir, common->size, common->force, show_progress, tty};
    struct esr_dtu_import_result r;
    if (esr_dtu_import(&o, &r) != ESR_OK) {
        if (*tty)
            fprintf(stderr, "\n");
        return cli_fail_lib(&cmd_import);
    }
    print_dtu_result(&o, &r);
    return 0;
}

static int run_import(int argc, char **argv)
{
    struct import_args a;
    memset(&a, 0, sizeof a);
    const int parsed = cli_parse(&cmd_import, argc, argv, &a);
    if (parsed != CLI_PARSED)
        return parsed == CLI_HELPED ? 0 : 1;
    const char **positional = a.positional.v;
    const int n_pos = a.positional.n;
    if (n_pos < 1 || (strcmp(positional[0], "colmap") && strcmp(positional[0], "dtu")))
        return cli_fail(&cmd_import, "the first argument names the source: 'colmap' or 'dtu'");
    if (!a.out)
        return cli_fail(&cmd_import, "missing --out DATA");
    if (a.size && a.align_to)
        return cli_fail(&cmd_import, "--size and --align-to exclude each other: an aligned import takes the true "
                        "dataset's image size");
    struct esr_colmap_import_opts o;
    memset(&o, 0, sizeof o);
    o.out_dir = a.out;
    o.align_to = a.align_to;
    o.masks_dir = a.masks;
    o.size = a.size ? a.size : DEFAULT_SIZE;
    o.force = a.force;
    int tty = isatty(STDERR_FILENO);
    if (!strcmp(positional[0], "dtu")) {
        if (o.masks_dir)
            return cli_fail(&cmd_import, "--masks is for 'colmap' imports (a DTU scan's masks are "
                            "SCAN/mask/)");
        if (o.align_to)
            return cli_fail(&cmd_import, "--align-to is for 'colmap' imports (a DTU scan's "
                            "cameras are known already)");
        return run_dtu(positional, n_pos, &o, &tty);
    }
    if (n_pos < 3)
        return cli_fail(&cmd_import, "expected MODEL_DIR and IMAGES after 'colmap'");
    o.model_dir = positional[1];
    o.images_dir = positional[2];
    o.progress = show_progress;
    o.user = &tty;
    struct esr_colmap_import_result r;
    if (esr_colmap_import(&o, &r) != ESR_OK) {
        if (tty)
            fprintf(stderr, "\n");
        return cli_fail_lib(&cmd_import);
    }
    print_result(&o, &r);
    return 0;
}
