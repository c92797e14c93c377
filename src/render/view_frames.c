/* Rendering the frames of a dataset phase into a directory, stamped with the model version. */
#include <cJSON.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "io/dir.h"
#include "io/file.h"
#include "render/view.h"
#include "io/json_file.h"

int esr_view_outputs_exist(const char *dir, const char *name)
{
    static const char *const suffixes[] = {".png", "_linear.png", ".exr", "_normal.exr"};
    char path[ESR_PATH_MAX];
    for (size_t i = 0; i < sizeof suffixes / sizeof suffixes[0]; i++)
        if (esr_view_path(path, sizeof path, dir, name, suffixes[i]) != ESR_OK || !esr_file_exists(path))
            return 0;
    return 1;
}

static int check_lighting(const struct esr_dataset *ds, const struct esr_frame *f)
{
    enum esr_light_mode mode = esr_frame_mode(ds, f);
    if (mode != ESR_LIGHT_OFF && mode != ESR_LIGHT_ON)
        return ESR_FAIL("frame %s has lighting mode '%s': rendering light edits is not supported yet (only "
                        "\"off\" and \"on\" frames, e.g. phase test_nv)",
                        f->name, esr_light_mode_name(mode));
    return ESR_OK;
}

/* dir/render.json: {"stage": "fine", "step": 1234, "lights": "<16 hex digits>",
 * "frames": ["c000_off", ...]}. */
static int stamp_path(char *path, size_t n, const char *dir)
{
    return esr_view_path(path, n, dir, "render", ".json");
}

/* The model's lights fingerprint as 16 hex digits: the same stage and step with other lights
 * (`esr lights --recompute`) is another model to a render. */
static void lights_fingerprint(const struct esr_model *m, char out[24])
{
    snprintf(out, 24, "%016llx", (unsigned long long)esr_lights_fingerprint(&m->lights));
}

cJSON *esr_view_stamp_frames(const char *text, size_t size, const char *stage, long step, const char *lights)
{
    cJSON *root = cJSON_ParseWithLength(text, size);
    const cJSON *st = cJSON_GetObjectItemCaseSensitive(root, "stage");
    const cJSON *sp = cJSON_GetObjectItemCaseSensitive(root, "step");
    const cJSON *li = cJSON_GetObjectItemCaseSensitive(root, "lights");
    const cJSON *ou = cJSON_GetObjectItemCaseSensitive(root, "outputs");
    cJSON *frames = cJSON_DetachItemFromObjectCaseSensitive(root, "frames");
    int match = cJSON_IsString(st) && cJSON_IsNumber(sp) && cJSON_IsArray(frames) && cJSON_IsString(li) &&
                !strcmp(st->valuestring, stage) && sp->valuedouble == (double)step &&
                !strcmp(li->valuestring, lights) && cJSON_IsNumber(ou) &&
                ou->valuedouble == ESR_VIEW_OUTPUTS_VERSION;
    cJSON_Delete(root);
    if (!match) {
        cJSON_Delete(frames);
        return NULL;
    }
    return frames;
}

/* The frame list of dir's stamp when the stamp names this model; NULL otherwise (no stamp, an
 * unreadable one, or one of another model: those renders are stale). */
static cJSON *current_frames(const char *dir, const struct esr_model *m)
{
    char path[ESR_PATH_MAX];
    unsigned char *text;
    size_t size;
    if (stamp_path(path, sizeof path, dir) != ESR_OK || !esr_file_exists(path))
        return NULL;
    if (esr_file_read_all(path, &text, &size) != ESR_OK) {
        esr_error_clear(); /* an unreadable stamp only means "render again" */
        return NULL;
    }
    char fp[24];
    lights_fingerprint(m, fp);
    cJSON *frames =
        esr_view_stamp_frames((const char *)text, size, esr_stage_name((enum esr_stage)m->stage), m->step, fp);
    free(text);
    return frames;
}

static int list_has(const cJSON *frames, const char *name)
{
    const cJSON *it;
    cJSON_ArrayForEach(it, frames) {
        if (cJSON_IsString(it) && !strcmp(it->valuestring, name))
            return 1;
    }
    return 0;
}

int esr_view_is_current(const char *dir, const struct esr_model *m, const char *name)
{
    if (!esr_view_outputs_exist(dir, name))
        return 0;
    cJSON *frames = current_frames(dir, m);
    int has = frames && list_has(frames, name);
    cJSON_Delete(frames);
    return has;
}

/* Records `frames` (taken over) as rendered by m. */
static int write_stamp(const char *dir, const struct esr_model *m, cJSON *frames)
{
    char path[ESR_PATH_MAX];
    cJSON *root = cJSON_CreateObject();
    if (!root) {
        cJSON_Delete(frames);
        return ESR_FAIL("out of memory writing the render record of %s", dir);
    }
    cJSON_AddStringToObject(root, "stage", esr_stage_name((enum esr_stage)m->stage));
    cJSON_AddNumberToObject(root, "step", (double)m->step);
    char fp[24];
    lights_fingerprint(m, fp);
    cJSON_AddStringToObject(root, "lights", fp);
    cJSON_AddNumberToObject(root, "outputs", ESR_VIEW_OUTPUTS_VERSION);
    cJSON_AddItemToObject(root, "frames", frames);
    if (stamp_path(path, sizeof path, dir) != ESR_OK) {
        cJSON_Delete(root);
        return ESR_ERR;
    }
    return esr_json_write_atomic(path, root);
}

static int render_one(const struct esr_model *m, const struct esr_dataset *ds, const struct esr_frame *f,
                      const char *dir)
{
    struct esr_view_images v;
    int status = esr_view_render(m, &f->camera, esr_frame_mode(ds, f) == ESR_LIGHT_ON, &v);
    if (status == ESR_OK)
        status = esr_view_write(dir, f->name, &v);
    esr_view_images_free(&v);
    return status;
}

int esr_view_render_frames(const struct esr_model *m, const struct esr_dataset *ds, enum esr_phase_id phase,
                           const int *idx, int n, const char *dir, esr_view_progress_fn progress, void *user)
{
    if ((int)phase < 0 || phase >= ESR_PHASE_COUNT || !ds->phases[phase].present)
        return ESR_FAIL("dataset '%s' has no phase %s", ds->root, esr_phase_name(phase));
    const struct esr_phase *ph = &ds->phases[phase];
    for (int i = 0; i < n; i++) {
        if (idx[i] < 0 || idx[i] >= ph->n_frames)
            return ESR_FAIL("frame index %d out of range for phase %s", idx[i], esr_phase_name(phase));
        ESR_TRY(check_lighting(ds, &ph->frames[idx[i]]));
    }
    ESR_TRY(esr_dir_prepare_output(dir));
    char path[ESR_PATH_MAX];
    cJSON *frames = current_frames(dir, m);
    if (!frames)
        frames = cJSON_CreateArray();
    /* No record while files change, so an interrupted run leaves nothing marked current. */
    if (!frames || stamp_path(path, sizeof path, dir) != ESR_OK || (esr_file_exists(path) && remove(path) != 0)) {
        cJSON_Delete(frames);
        return ESR_FAIL("cannot reset the render record %s/render.json", dir);
    }
    int status = ESR_OK;
    for (int i = 0; i < n && status == ESR_OK; i++) {
        const struct esr_frame *f = &ph->frames[idx[i]];
        double t0 = omp_get_wtime();
        status = render_one(m, ds, f, dir);
        if (status == ESR_OK && !list_has(frames, f->name))
            cJSON_AddItemToArray(frames, cJSON_CreateString(f->name));
        if (status == ESR_OK && progress) {
            struct esr_view_progress p = {f->name, i + 1, n, omp_get_wtime() - t0};
            progress(user, &p);
        }
    }
    if (status == ESR_OK)
        status = esr_view_write_env(dir, m);
    /* Frames finished before a failure stay recorded. */
    int stamped = write_stamp(dir, m, frames);
    return status == ESR_OK ? stamped : status;
}
