/* The lights' table and lights.json (lights_listing.h). */
#include "cli/lights_listing.h"
#include "cli/commands.h"

#include <math.h>
#include <stdio.h>

#include "core/colour.h"
#include "io/json_file.h"
#include "train/lights/lights.h"
#include "train/lights/fit.h"

cJSON *esr_cli_lights_json(const struct esr_model *m, const char *ckpt, const long *unseen)
{
    cJSON *root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "checkpoint", ckpt);
    char fp[32]; /* the model whose lights these are, and the command that listed them */
    snprintf(fp, sizeof fp, "%016llx", (unsigned long long)esr_model_fingerprint(m));
    cJSON_AddStringToObject(root, "model_fingerprint", fp);
    cJSON_AddItemToObject(root, "made_by", cli_record("lights", 0, NULL) /* as typed; in esr demo, the name */);
    cJSON_AddNumberToObject(root, "emitter_k", m->cfg.emitter_k);
    cJSON *units = cJSON_AddObjectToObject(root, "units");
    cJSON_AddStringToObject(units, "rgb", UNITS_RGB);
    cJSON_AddStringToObject(units, "power", UNITS_POWER);
    cJSON_AddStringToObject(units, "area", UNITS_AREA);
    cJSON_AddStringToObject(root, "strength_assumption", STRENGTH_ASSUMPTION);
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
        if (l->solved) { /* what the photos say of it (train/lights/solve.h) */
            cJSON_AddNumberToObject(o, "strength_uncertainty", l->strength_err);
            cJSON_AddBoolToObject(o, "strength_lower_bound_only", l->bound_only);
            cJSON *ins = cJSON_AddArrayToObject(o, "inseparable_from");
            for (int j = 0; j < m->lights.n; j++)
                if (l->inseparable >> j & 1u)
                    cJSON_AddItemToArray(ins, cJSON_CreateNumber(j));
        }
        cJSON_AddItemToArray(arr, o);
    }
    return root;
}

/* No "-0.00" for a number that rounds to zero from below. */
static double unsigned_zero(float v, double below)
{
    return fabs((double)v) < below ? 0.0 : (double)v;
}

void esr_cli_lights_print(const struct esr_model *m, const long *unseen)
{
    const struct esr_lights *L = &m->lights;
    printf("%d light%s (emitter threshold k %.3g):\n", L->n, L->n == 1 ? "" : "s",
           (double)m->cfg.emitter_k);
    if (L->n == 0) {
        printf("  the pdra stage found no emitters (RUN/log says why); --recompute searches "
               "again\n");
        return;
    }
    printf("  id         `esr edit --light ID`; --picture FILE.png shows where each is\n"
           "  x y z      centroid, world units;  area: " UNITS_AREA "\n"
           "  R G B      emitted radiance, " UNITS_RGB "\n"
           "  H S V      of R G B: hue and saturation in [0,1] as `esr edit --color H,S` takes "
           "them, V = max(R,G,B)\n"
           "  power      " UNITS_POWER "\n"
           "  scale RGB  strength calibration per channel (1 = the emission field as trained)\n"
           "\n");
    printf("  %2s  %7s %7s %7s  %7s  %8s %8s %8s  %5s %5s %8s  %8s  %7s %7s %7s\n", "id", "x", "y",
           "z", "area", "R", "G", "B", "H", "S", "V", "power", "scale R", "scale G", "scale B");
    int borrowed = 0;
    for (int i = 0; i < L->n; i++) {
        const struct esr_light *l = &L->light[i];
        const int fitted = esr_light_strength_fitted(L, i);
        float hsv[3];
        esr_rgb_to_hsv(l->radiance, hsv);
        printf("  %2d  %7.2f %7.2f %7.2f  %7.3g  %8.3g %8.3g %8.3g  %5.3f %5.3f %8.3g  %8.3g  %7.3g "
               "%7.3g %7.3g%s\n",
               i, unsigned_zero(l->centroid[0], 0.005), unsigned_zero(l->centroid[1], 0.005),
               unsigned_zero(l->centroid[2], 0.005), (double)l->area, (double)l->radiance[0],
               (double)l->radiance[1], (double)l->radiance[2], (double)hsv[0], (double)hsv[1],
               (double)hsv[2], (double)l->power, (double)l->scale[0], (double)l->scale[1],
               (double)l->scale[2], fitted ? "" : " *");
        borrowed += !fitted;
    }
    int any_unseen = 0;
    for (int i = 0; i < L->n; i++)
        if (unseen[i]) {
            printf("  light %d: %ld of its %ld surface points unseen (no camera sees them, or "
                   "only lights-off or clipped photos)\n", i, unseen[i], L->light[i].points);
            any_unseen = 1;
        }
    if (any_unseen)
        printf("  (a light's unseen part, such as a lampshade's bottom, emits the light's mean\n"
               "  field)\n");
    if (esr_lights_balanced(L)) {
        float b[3];
        esr_lights_balance_of(L, b);
        printf("  colour from the lights' silhouettes: base colour x %.3f %.3f %.3f, environment "
               "map / the same\n", (double)b[0], (double)b[1], (double)b[2]);
    }
    int solved = 0;
    for (int i = 0; i < L->n; i++)
        solved += L->light[i].solved;
    if (solved) {
        printf("  strengths solved from the lights-on photos, statistical uncertainty (the model taken as right):");
        for (int i = 0; i < L->n; i++)
            if (L->light[i].solved)
                printf(" %d: +-%.1f%%%s", i, 100.0 * (double)L->light[i].strength_err,
                       L->light[i].bound_only ? " (a lower bound only)" : "");
        printf("\n");
        for (int i = 0; i < L->n; i++)
            for (int j = i + 1; j < L->n; j++)
                if (L->light[i].inseparable >> j & 1u)
                    printf("  lights %d and %d light the same pixels alike: the photos fix only "
                           "their sum\n", i, j);
        printf("  (%s)\n", STRENGTH_ASSUMPTION);
    }
    if (borrowed)
        printf("  * under %.0f%% of the lights' area: too small to fit from the light it casts; it\n"
               "    takes the fitted lights' area-weighted mean scale (a small lamp, or a mirror's reflection\n"
               "    of a light that the images cannot tell from one: `esr lights RUN --drop ID`\n"
               "    removes one you judge a reflection)\n",
               100.0 * ESR_LIGHTS_SMALL_SHARE);
}

