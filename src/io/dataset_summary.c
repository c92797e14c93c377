#include "io/dataset_summary.h"

#include <cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "io/json_file.h"

static void summarise_phase(const struct esr_dataset *ds, const struct esr_phase *ph, struct esr_phase_summary *s)
{
    memset(s, 0, sizeof *s);
    s->present = ph->present;
    s->n_frames = ph->n_frames;
    if (ph->n_frames == 0)
        return;
    s->radius_min = INFINITY;
    s->radius_max = 0.0f;
    for (int k = 0; k < 3; k++) {
        s->centre_min[k] = INFINITY;
        s->centre_max[k] = -INFINITY;
    }
    for (int i = 0; i < ph->n_frames; i++) {
        const struct esr_frame *f = &ph->frames[i];
        s->mode_counts[esr_frame_mode(ds, f)]++;
        float r2 = 0.0f;
        for (int k = 0; k < 3; k++) {
            float c = f->camera.c2w[k][3];
            s->centre_min[k] = fminf(s->centre_min[k], c);
            s->centre_max[k] = fmaxf(s->centre_max[k], c);
            r2 += c * c;
        }
        s->radius_min = fminf(s->radius_min, sqrtf(r2));
        s->radius_max = fmaxf(s->radius_max, sqrtf(r2));
        if (f->has_exposure) {
            const int on = f->lights_on ? 1 : 0;
            const double ev = f->exposure_ev;
            s->ev_min[on] = s->n_exposure[on] ? fmin(s->ev_min[on], ev) : ev;
            s->ev_max[on] = s->n_exposure[on] ? fmax(s->ev_max[on], ev) : ev;
            s->ev_mean[on] += ev;
            s->n_exposure[on]++;
        }
    }
    for (int on = 0; on < 2; on++)
        if (s->n_exposure[on])
            s->ev_mean[on] /= s->n_exposure[on];
}

int esr_dataset_exposure_warnings(const struct esr_dataset_summary *s, esr_problem_fn say, void *user)
{
    const struct esr_phase_summary *t = &s->phases[ESR_PHASE_TRAIN];
    static const char *const set[2] = {"lights-off", "lights-on"};
    const int n = t->n_exposure[0] + t->n_exposure[1];
    if (!t->present || n == 0)
        return 0;
    char line[512];
    int said = 0;
    if (n < t->n_frames) {
        snprintf(line, sizeof line, "exposure recorded for %d of the %d training photos only: the rest are "
                 "taken as shot at the same exposure", n, t->n_frames);
        say(user, line), said++;
    }
    for (int on = 0; on < 2; on++)
        if (t->n_exposure[on] && t->ev_max[on] - t->ev_min[on] >= ESR_EXPOSURE_TOLERANCE_STOPS) {
            snprintf(line, sizeof line, "the %s photos were shot %.2f stops apart (exposure differs from "
                     "photo to photo): esr takes every photo as shot at one exposure, so their brightness "
                     "differences count as the scene's", set[on], t->ev_max[on] - t->ev_min[on]);
            say(user, line), said++;
        }
    if (t->n_exposure[0] && t->n_exposure[1]) {
        const double d = t->ev_mean[1] - t->ev_mean[0];
        if (fabs(d) >= ESR_EXPOSURE_TOLERANCE_STOPS) {
            snprintf(line, sizeof line, "the lights-on photos were shot %.2f stops %s than the lights-off ones "
                     "(automatic exposure?): the lights' strengths are read from how much brighter the "
                     "lights-on photos are, so they will come out %.2fx %s; shoot both sets at one manual "
                     "exposure", fabs(d), d < 0 ? "shorter" : "longer", pow(2.0, fabs(d)),
                     d < 0 ? "too weak" : "too strong");
            say(user, line), said++;
        }
    }
    return said;
}

void esr_dataset_summarise(const struct esr_dataset *ds, struct esr_dataset_summary *out)
{
    for (int p = 0; p < ESR_PHASE_COUNT; p++)
        summarise_phase(ds, &ds->phases[p], &out->phases[p]);
}

static cJSON *phase_json(const struct esr_phase_summary *s)
{
    cJSON *obj = cJSON_CreateObject();
    cJSON_AddNumberToObject(obj, "frames", s->n_frames);
    cJSON *modes = cJSON_AddObjectToObject(obj, "modes");
    for (int m = 0; m < ESR_LIGHT_MODE_COUNT; m++)
        if (s->mode_counts[m])
            cJSON_AddNumberToObject(modes, esr_light_mode_name((enum esr_light_mode)m), s->mode_counts[m]);
    cJSON_AddItemToObject(obj, "camera_centre_min", esr_json_float_array(s->centre_min, 3));
    cJSON_AddItemToObject(obj, "camera_centre_max", esr_json_float_array(s->centre_max, 3));
    cJSON_AddNumberToObject(obj, "camera_radius_min", (double)s->radius_min);
    cJSON_AddNumberToObject(obj, "camera_radius_max", (double)s->radius_max);
    static const char *const set[2] = {"lights_off", "lights_on"};
    for (int on = 0; on < 2; on++)
        if (s->n_exposure[on]) {
            char key[32];
            snprintf(key, sizeof key, "exposure_%s", set[on]);
            cJSON *e = cJSON_AddObjectToObject(obj, key);
            cJSON_AddNumberToObject(e, "photos", s->n_exposure[on]);
            cJSON_AddNumberToObject(e, "ev_mean", s->ev_mean[on]);
            cJSON_AddNumberToObject(e, "ev_min", s->ev_min[on]);
            cJSON_AddNumberToObject(e, "ev_max", s->ev_max[on]);
        }
    return obj;
}

/* Lines said to it, each ending in a newline, as one text (what fits). */
struct lines {
    char buf[1024];
    size_t len;
};

static void add_line(void *user, const char *line)
{
    struct lines *t = user;
    const int k = snprintf(t->buf + t->len, sizeof t->buf - t->len, "%s\n", line);
    t->len = k < 0 ? t->len : t->len + (size_t)k < sizeof t->buf ? t->len + (size_t)k : sizeof t->buf - 1;
}

static cJSON *summary_json(const struct esr_dataset *ds, const struct esr_dataset_summary *s,
                           const char *const *problems, int n_problems)
{
    cJSON *root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "root", ds->root);
    cJSON_AddStringToObject(root, "layout", ds->layout == ESR_LAYOUT_ESR ? "esr" : "nerf_synthetic");
    cJSON_AddNumberToObject(root, "width", ds->width);
    cJSON_AddNumberToObject(root, "height", ds->height);
    cJSON_AddNumberToObject(root, "camera_angle_x", (double)ds->camera_angle_x);
    cJSON_AddNumberToObject(root, "focal", (double)ds->focal);
    cJSON_AddNumberToObject(root, "n_lights", ds->n_lights);
    cJSON_AddItemToObject(root, "bbox_min", esr_json_float_array(ds->bbox_min, 3));
    cJSON_AddItemToObject(root, "bbox_max", esr_json_float_array(ds->bbox_max, 3));
    cJSON_AddStringToObject(root, "bbox_source", esr_dataset_bbox_source(ds));
    cJSON *phases = cJSON_AddObjectToObject(root, "phases");
    for (int p = 0; p < ESR_PHASE_COUNT; p++)
        if (s->phases[p].present)
            cJSON_AddItemToObject(phases, esr_phase_name((enum esr_phase_id)p), phase_json(&s->phases[p]));
    struct lines text = {{0}, 0};
    if (esr_dataset_exposure_warnings(s, add_line, &text))
        cJSON_AddStringToObject(root, "exposure_warnings", text.buf);
    cJSON *list = cJSON_AddArrayToObject(root, "problems");
    for (int i = 0; i < n_problems; i++)
        cJSON_AddItemToArray(list, cJSON_CreateString(problems[i]));
    return root;
}

int esr_dataset_summary_write(const char *path, const struct esr_dataset *ds, const struct esr_dataset_summary *s,
                              const char *const *problems, int n_problems)
{
    return esr_json_write_atomic(path, summary_json(ds, s, problems, n_problems));
}
