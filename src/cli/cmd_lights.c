/* esr lights RUN: the lights the run found (ids, place, size, colour, strength) as a table and
 * RUN/lights.json. */
#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/commands.h"
#include "core/colour.h"
#include "core/error.h"
#include "eval/run_dir.h"
#include "io/dataset.h"
#include "io/json_file.h"
#include "model/model.h"
#include "train/lights.h"
#include "train/lights_fit.h"
#include "train/rays.h"

static int run_lights(int argc, char **argv);

const struct esr_command cmd_lights = {
    "lights",
    "list the lights a run found (id, centroid, area, colour, emitted radiance and power)",
    "usage: esr lights RUN [--recompute | --drop ID[,ID...]] [--data DIR]\n"
    "\n"
    "Reads the lights stored in RUN's pdra checkpoint (found and calibrated when the pdra stage\n"
    "ended: the emitting surface split into connected lights, each light's strength fixed by the\n"
    "light it casts on the rest of the scene), prints them and writes RUN/lights.json:\n"
    "  {\"lights\": [{\"id\", \"centroid\", \"area\", \"points\", \"unseen_points\" (of its surface\n"
    "               points, those whose emission no photo shows: no camera sees them, or only\n"
    "               lights-off or clipped photos do), \"rgb\" (emitted radiance, linear), \"hsv\" (of\n"
    "               rgb: H, S in [0,1], V unbounded, linear), \"power\", \"field_rgb\",\n"
    "               \"strength_scale\", \"calibration_points\",\n"
    "               \"strength_fitted\" (false: too small to fit, the fitted lights' area-weighted mean scale)}...],\n"
    "   \"emitter_k\", \"checkpoint\", \"colour_balance\" (the base colour's factor per channel, the\n"
    "   environment map's divisor, set from the lights' silhouettes in the lights-on photos;\n"
    "   1 1 1: none)}\n"
    "\n"
    "options:\n"
    "  --recompute   find and calibrate the lights again and store them in the checkpoint (a\n"
    "                run whose pdra stage found none keeps none unless asked)\n"
    "  --drop IDS    remove these lights (ids as listed now; a reflection you judge no light,\n"
    "                such as a mirror's view of a lamp: it then follows the lights it reflects\n"
    "                in relights instead of glowing on), calibrate the others again without\n"
    "                them and store the result in the checkpoint; --recompute brings them back\n"
    "  --data DIR    with --recompute or --drop: the dataset whose training images they read\n"
    "                (lights-off to calibrate, lights-on for the colour; default: the one RUN\n"
    "                was trained on)\n"
    "  -h, --help    this text\n",
    run_lights,
    0, /* view_loop */
};

/* Finds (find) and calibrates the lights of m from DATA's training rays (the lights-off ones
 * calibrate, the lights-on ones balance their colour). */
static int find_and_calibrate(struct esr_model *m, const char *data, int find)
{
    struct esr_dataset ds;
    ESR_TRY(esr_dataset_load(data, &ds));
    struct esr_ray_set rs;
    memset(&rs, 0, sizeof rs);
    int rc = esr_ray_set_build(&rs, &ds, ESR_PHASE_TRAIN);
    esr_dataset_free(&ds);
    if (rc == ESR_OK && rs.n_off == 0)
        rc = ESR_FAIL("dataset %s: no lights-off training images to calibrate with", data);
    if (rc == ESR_OK && find)
        rc = esr_lights_find(m, &rs);
    if (rc == ESR_OK && find && m->lights.n_left_out > 0)
        fprintf(stderr, "esr lights: " ESR_LIGHTS_LEFT_OUT_FMT "\n", m->lights.n_left_out, ESR_MAX_LIGHTS);
    if (rc == ESR_OK && m->lights.n > 0)
        rc = esr_lights_calibrate(m, rs.orig3, rs.dir3, rs.n_off, m->cfg.lights_calib_points,
                                  (uint64_t)m->cfg.seed, 1);
    for (int i = 0; rc == ESR_OK && i < m->lights.n; i++) {
        char line[320];
        if (esr_lights_rim_text(&m->lights, i, line, sizeof line))
            fprintf(stderr, "esr lights: %s\n", line);
    }
    if (rc == ESR_OK && esr_lights_uncalibrated(&m->lights))
        fprintf(stderr, "esr lights: warning: " ESR_LIGHTS_UNCALIBRATED_TEXT "\n");
    struct esr_lights_balance_info bal;
    if (rc == ESR_OK && m->lights.n > 0)
        rc = esr_lights_balance(m, &rs, &bal);
    if (rc == ESR_OK && m->lights.n > 0) {
        char line[256];
        esr_lights_balance_text(m, &bal, line, sizeof line);
        fprintf(stderr, "esr lights: %s\n", line);
    }
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

static cJSON *lights_json(const struct esr_model *m, const char *ckpt, const long *unseen)
{
    cJSON *root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "checkpoint", ckpt);
    cJSON_AddNumberToObject(root, "emitter_k", m->cfg.emitter_k);
    float balance[3];
    esr_lights_balance_of(&m->lights, balance);
    cJSON_AddItemToObject(root, "colour_balance", esr_json_float_array(balance, 3));
    cJSON *arr = cJSON_AddArrayToObject(root, "lights");
    for (int i = 0; i < m->lights.n; i++) {
        const struct esr_light *l = &m->lights.light[i];
        float hsv[3];
        esr_rgb_to_hsv(l->radiance, hsv);
        cJSON *o = cJSON_CreateObject();
        cJSON_AddNumberToObject(o, "id", i);
        cJSON_AddItemToObject(o, "centroid", esr_json_float_array(l->centroid, 3));
        cJSON_AddNumberToObject(o, "area", l->area);
        cJSON_AddNumberToObject(o, "points", (double)l->points);
        cJSON_AddNumberToObject(o, "unseen_points", (double)unseen[i]);
        cJSON_AddItemToObject(o, "rgb", esr_json_float_array(l->radiance, 3));
        cJSON_AddItemToObject(o, "hsv", esr_json_float_array(hsv, 3));
        cJSON_AddNumberToObject(o, "power", l->power);
        cJSON_AddItemToObject(o, "field_rgb", esr_json_float_array(l->field_rgb, 3));
        cJSON_AddItemToObject(o, "strength_scale", esr_json_float_array(l->scale, 3));
        cJSON_AddNumberToObject(o, "calibration_points", l->calib_points);
        cJSON_AddBoolToObject(o, "strength_fitted", esr_light_strength_fitted(&m->lights, i));
        cJSON_AddItemToArray(arr, o);
    }
    return root;
}

static int lights(const char *run, const char *data_override, int again, const char *drop)
{
    char ckpt[4200], data[4096], out[4200];
    snprintf(ckpt, sizeof ckpt, "%s/ckpt_pdra.bin", run);
    struct esr_model m;
    ESR_TRY(esr_model_load_finished_pdra(&m, run));
    int rc = ESR_OK;
    if (again || drop) {
        rc = esr_run_data_dir(run, data_override, data, sizeof data);
        if (rc == ESR_OK && drop)
            rc = drop_lights(&m, drop);
        if (rc == ESR_OK)
            rc = find_and_calibrate(&m, data, again);
        if (rc == ESR_OK)
            rc = esr_model_save(&m, ckpt);
    }
    int borrowed = 0;
    if (rc == ESR_OK) {
        long unseen[ESR_MAX_LIGHTS]; /* each light's points whose emission no photo shows */
        esr_lights_unseen_points(&m.lights, unseen);
        printf("%d light%s (emitter threshold k %.3g):\n", m.lights.n, m.lights.n == 1 ? "" : "s",
               (double)m.cfg.emitter_k);
        if (m.lights.n == 0)
            printf("  the pdra stage found no emitters (RUN/log says why); --recompute searches "
                   "again\n");
        else
            printf("  id  centroid                 area    emitted radiance (linear RGB)   power    "
                   "strength scale\n");
        for (int i = 0; i < m.lights.n; i++) {
            const struct esr_light *l = &m.lights.light[i];
            const int fitted = esr_light_strength_fitted(&m.lights, i);
            double c[3]; /* no "-0.00" for a coordinate that rounds to zero from below */
            for (int a = 0; a < 3; a++)
                c[a] = fabs((double)l->centroid[a]) < 0.005 ? 0.0 : (double)l->centroid[a];
            printf("  %2d  (%6.2f %6.2f %6.2f)  %6.3f  %8.3g %8.3g %8.3g  %8.3g  %.2f %.2f %.2f%s\n",
                   i, c[0], c[1], c[2],
                   (double)l->area, (double)l->radiance[0], (double)l->radiance[1],
                   (double)l->radiance[2], (double)l->power, (double)l->scale[0],
                   (double)l->scale[1], (double)l->scale[2], fitted ? "" : " *");
            borrowed += !fitted;
        }
        int any_unseen = 0;
        for (int i = 0; i < m.lights.n; i++)
            if (unseen[i]) {
                printf("  light %d: %ld of its %ld surface points unseen (no camera sees them, or "
                       "only lights-off or clipped photos)\n", i, unseen[i], m.lights.light[i].points);
                any_unseen = 1;
            }
        if (any_unseen)
            printf("  (a light's unseen part, such as a lampshade's bottom, emits the light's mean\n"
                   "  field)\n");
        if (esr_lights_balanced(&m.lights)) {
            float b[3];
            esr_lights_balance_of(&m.lights, b);
            printf("  colour from the lights' silhouettes: base colour x %.3f %.3f %.3f, environment "
                   "map / the same\n", (double)b[0], (double)b[1], (double)b[2]);
        }
        if (borrowed)
            printf("  * under %.0f%% of the lights' area: too small to fit from the light it casts; it\n"
                   "    takes the fitted lights' area-weighted mean scale (a small lamp, or a mirror's reflection\n"
                   "    of a light that the images cannot tell from one: `esr lights RUN --drop ID`\n"
                   "    removes one you judge a reflection)\n",
                   100.0 * ESR_LIGHTS_SMALL_SHARE);
        snprintf(out, sizeof out, "%s/lights.json", run);
        rc = esr_json_write_atomic(out, lights_json(&m, ckpt, unseen));
        if (rc == ESR_OK)
            fprintf(stderr, "wrote %s\n", out);
    }
    esr_model_free(&m);
    return rc;
}

static int run_lights(int argc, char **argv)
{
    if (cli_wants_help(&cmd_lights, argc, argv))
        return 0;
    const char *run = NULL, *data = NULL, *drop = NULL;
    int again = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--recompute"))
            again = 1;
        else if (!strcmp(a, "--drop") && i + 1 < argc)
            drop = argv[++i];
        else if (!strcmp(a, "--data") && i + 1 < argc)
            data = argv[++i];
        else if (a[0] == '-' && a[1])
            return cli_fail(&cmd_lights, "unknown option or missing value: '%s'", a);
        else if (run)
            return cli_fail(&cmd_lights, "more than one RUN given ('%s', '%s')", run, a);
        else
            run = a;
    }
    if (!run)
        return cli_fail(&cmd_lights, "missing RUN directory");
    if (data && !again && !drop)
        return cli_fail(&cmd_lights, "--data is read only with --recompute or --drop (the lights are "
                        "stored in RUN's pdra checkpoint)");
    if (again && drop)
        return cli_fail(&cmd_lights, "--drop names lights as listed now, which --recompute finds "
                        "anew: drop them after a --recompute");
    return lights(run, data, again, drop) == ESR_OK ? 0 : cli_fail_lib(&cmd_lights);
}
