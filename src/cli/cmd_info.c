/* esr info DATA_DIR: what a dataset holds, and every problem with its files. */
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/commands.h"
#include "core/error.h"
#include "eval/contact_sheet.h"
#include "io/dataset.h"
#include "io/dataset_summary.h"

static int run_info(int argc, char **argv);

struct info_args {
    const char *dir, *json, *sheet;
};

#define AT(field) offsetof(struct info_args, field)
static const struct cli_option info_options[] = {
    {"DATA_DIR", .kind = CLI_ARG, .at = AT(dir)},
    {"--json", "FILE", "also write the summary and the problems as JSON (atomically)", CLI_TEXT,
     .at = AT(json)},
    {"--contact-sheet", "FILE.png", "write a grid of thumbnails: train lights off, train lights "
     "on, test views (composited on white)", CLI_TEXT, .at = AT(sheet)},
    {0},
};

const struct esr_command cmd_info = {
    .name = "info",
    .summary = "describe a dataset and check its files",
    .usage =
    "usage: esr info DATA_DIR [--json FILE] [--contact-sheet FILE.png]\n"
    "\n"
    "Loads DATA_DIR (ESR layout: transforms/transforms_<phase>.json, or NeRF-synthetic:\n"
    "transforms_{train,val,test}.json) and prints its layout, image size, focal length, number\n"
    "of lights, per phase the frame count and the count per lighting mode, the bounding box of\n"
    "the camera centres and their distance from the origin, and the scene box. Then decodes every\n"
    "image, EXR and mask the dataset refers to and lists every problem found. Where the frames\n"
    "record their exposure (EXIF, written by `esr import colmap`), prints its range per lighting\n"
    "and warns when photos of one set, or the two sets, were shot at different exposures.\n"
    "Exit status: 0 when the dataset is valid, 1 when it cannot be loaded or has problems.\n",
    .options = info_options,
    .run = run_info,
};

struct problem_list {
    char **items;
    int count, capacity;
};

static void collect_problem(void *user, const char *message)
{
    struct problem_list *list = user;
    if (list->count == list->capacity) {
        int cap = list->capacity ? list->capacity * 2 : 16;
        char **grown = realloc(list->items, (size_t)cap * sizeof *grown);
        if (!grown)
            return; /* the count printed below stays right; only the text is lost */
        list->items = grown;
        list->capacity = cap;
    }
    list->items[list->count++] = strdup(message);
}

/* A line of esr_dataset_exposure_warnings after the prefix in user. */
static void print_warning(void *user, const char *line)
{
    printf("%s%s\n", (const char *)user, line);
}

static void print_summary(const struct esr_dataset *ds, const struct esr_dataset_summary *s)
{
    printf("dataset   %s\n", ds->root);
    printf("layout    %s\n", ds->layout == ESR_LAYOUT_ESR ? "esr" : "nerf-synthetic");
    printf("images    %d x %d\n", ds->width, ds->height);
    printf("focal     %.2f px (camera_angle_x %.6f rad)\n", (double)ds->focal, (double)ds->camera_angle_x);
    printf("lights    %d\n", ds->n_lights);
    printf("scene box [%.3g, %.3g, %.3g] .. [%.3g, %.3g, %.3g] (%s)\n", (double)ds->bbox_min[0],
           (double)ds->bbox_min[1], (double)ds->bbox_min[2], (double)ds->bbox_max[0], (double)ds->bbox_max[1],
           (double)ds->bbox_max[2],
           esr_dataset_bbox_source(ds));
    printf("\n%-10s %6s  %-34s %-40s %s\n", "phase", "frames", "lighting", "camera centres min .. max",
           "distance");
    for (int p = 0; p < ESR_PHASE_COUNT; p++) {
        const struct esr_phase_summary *ps = &s->phases[p];
        if (!ps->present)
            continue;
        char modes[128] = "", *at = modes;
        for (int m = 0; m < ESR_LIGHT_MODE_COUNT; m++)
            if (ps->mode_counts[m])
                at += snprintf(at, sizeof modes - (size_t)(at - modes), "%s%s %d", at == modes ? "" : ", ",
                               esr_light_mode_name((enum esr_light_mode)m), ps->mode_counts[m]);
        char centres[96];
        snprintf(centres, sizeof centres, "[%.2f, %.2f, %.2f] .. [%.2f, %.2f, %.2f]", (double)ps->centre_min[0],
                 (double)ps->centre_min[1], (double)ps->centre_min[2], (double)ps->centre_max[0],
                 (double)ps->centre_max[1], (double)ps->centre_max[2]);
        printf("%-10s %6d  %-34s %-40s %.3f .. %.3f\n", esr_phase_name((enum esr_phase_id)p), ps->n_frames, modes,
               centres, (double)ps->radius_min, (double)ps->radius_max);
    }
    const struct esr_phase_summary *t = &s->phases[ESR_PHASE_TRAIN];
    static const char *const set[2] = {"lights off", "lights on"};
    if (t->n_exposure[0] || t->n_exposure[1])
        printf("\n");
    for (int on = 0; on < 2; on++)
        if (t->n_exposure[on])
            printf("exposure  %-10s %d photos, log2(time x ISO / f-number^2) %.2f .. %.2f, mean %.2f\n", set[on],
                   t->n_exposure[on], t->ev_min[on], t->ev_max[on], t->ev_mean[on]);
    esr_dataset_exposure_warnings(s, print_warning, "warning: ");
}

/* Adds up to n frames of phase (those with the given lighting state, or any when lit < 0), spread
 * evenly over the phase; frames that fail to load leave their cell white. */
static int add_thumbnails(struct esr_contact_sheet *cs, const struct esr_dataset *ds, enum esr_phase_id phase,
                          int lit, int n)
{
    const struct esr_phase *ph = &ds->phases[phase];
    int matching = 0;
    for (int i = 0; i < ph->n_frames; i++)
        matching += lit < 0 || ph->frames[i].lights_on == lit;
    int taken = 0, seen = 0;
    for (int i = 0; i < ph->n_frames && taken < n; i++) {
        if (!(lit < 0 || ph->frames[i].lights_on == lit))
            continue;
        /* the seen-th matching frame is taken when it reaches the next evenly spaced slot */
        if ((long)seen++ * n < (long)taken * matching)
            continue;
        struct esr_image rgb;
        if (esr_frame_load_rgb(ds, &ph->frames[i], &rgb, NULL) != ESR_OK) {
            esr_error_clear();
            esr_contact_sheet_skip(cs);
        } else {
            int status = esr_contact_sheet_add(cs, &rgb);
            esr_image_free(&rgb);
            ESR_TRY(status);
        }
        taken++;
    }
    for (; taken < n; taken++)
        esr_contact_sheet_skip(cs);
    return ESR_OK;
}

static int write_contact_sheet(const struct esr_dataset *ds, const char *path)
{
    enum { COLS = 8 };
    struct esr_contact_sheet cs;
    int thumb = ds->width < 96 ? ds->width : 96;
    ESR_TRY(esr_contact_sheet_init(&cs, COLS, 3, thumb, 4));
    int status = add_thumbnails(&cs, ds, ESR_PHASE_TRAIN, 0, COLS);
    if (status == ESR_OK)
        status = add_thumbnails(&cs, ds, ESR_PHASE_TRAIN, 1, COLS);
    /* last row: two views of each test phase present (ESR), or eight test views */
    int test_phases = 0;
    for (int p = ESR_PHASE_TEST_NV; p <= ESR_PHASE_TEST_NVIC; p++)
        test_phases += ds->phases[p].present;
    for (int p = ESR_PHASE_TEST_NV; p <= ESR_PHASE_TEST_NVIC && status == ESR_OK; p++)
        if (ds->phases[p].present)
            status = add_thumbnails(&cs, ds, (enum esr_phase_id)p, -1, COLS / test_phases);
    if (status == ESR_OK)
        status = esr_png_write(path, &cs.canvas, 8);
    esr_contact_sheet_free(&cs);
    return status;
}

static int run_info(int argc, char **argv)
{
    struct info_args a = {NULL, NULL, NULL};
    const int parsed = cli_parse(&cmd_info, argc, argv, &a);
    if (parsed != CLI_PARSED)
        return parsed == CLI_HELPED ? 0 : 1;
    const char *dir = a.dir, *json_path = a.json, *sheet_path = a.sheet;
    if (!dir)
        return cli_fail(&cmd_info, "missing DATA_DIR");
    /* the outputs' names and folders before the dataset is checked (a minute on a large one) */
    if ((json_path && cli_output_file("--json", json_path, ".json", NULL, 0) != ESR_OK) ||
        (sheet_path && cli_output_file("--contact-sheet", sheet_path, ".png", NULL, 0) != ESR_OK))
        return cli_fail_lib(&cmd_info);
    struct esr_dataset ds;
    if (esr_dataset_load(dir, &ds) != ESR_OK)
        return cli_fail_lib(&cmd_info);
    struct esr_dataset_summary summary;
    esr_dataset_summarise(&ds, &summary);
    print_summary(&ds, &summary);

    struct problem_list problems = {NULL, 0, 0};
    int n = esr_dataset_check(&ds, collect_problem, &problems);
    int exit_code = 0;
    if (n < 0) {
        exit_code = cli_fail_lib(&cmd_info);
    } else if (n == 0) {
        printf("\nfiles     all images, EXRs and masks decode with the dataset's size: no problems\n");
    } else {
        printf("\n%d problem%s:\n", n, n == 1 ? "" : "s");
        for (int i = 0; i < problems.count; i++)
            printf("  %s\n", problems.items[i]);
        exit_code = 1;
    }
    if (json_path && esr_dataset_summary_write(json_path, &ds, &summary, (const char *const *)problems.items,
                                               problems.count) != ESR_OK)
        exit_code = cli_fail_lib(&cmd_info);
    if (sheet_path && write_contact_sheet(&ds, sheet_path) != ESR_OK)
        exit_code = cli_fail_lib(&cmd_info);
    for (int i = 0; i < problems.count; i++)
        free(problems.items[i]);
    free(problems.items);
    esr_dataset_free(&ds);
    return exit_code;
}
