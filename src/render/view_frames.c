/* Rendering the frames of a dataset phase into a directory, stamped with the model version. */
#include <cJSON.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/hash.h"
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
        return ESR_FAIL("frame %s has lighting mode '%s': esr render renders \"off\" and \"on\" frames "
                        "(phase test_nv); relight edit frames with `esr eval RUN --phase P --method "
                        "direct|ratio|finetune`, or any edit with `esr edit`",
                        f->name, esr_light_mode_name(mode));
    return ESR_OK;
}

/* dir/render.json: {"stage": "fine", "step": 1234, "model": "<16 hex digits>", "outputs": 3,
 * "frames": {"c000_off": "<16 hex digits>", ...}}: the model's fingerprint and, per frame, its
 * view's (camera and lighting). */
static int stamp_path(char *path, size_t n, const char *dir)
{
    return esr_view_path(path, n, dir, "render", ".json");
}

static void hex16(uint64_t h, char out[24])
{
    snprintf(out, 24, "%016llx", (unsigned long long)h);
}

/* The view of frame f as a render sees it: pose, size, focal, lighting. */
static void view_fingerprint(const struct esr_dataset *ds, const struct esr_frame *f, char out[24])
{
    const struct esr_camera *c = &f->camera;
    const int mode = (int)esr_frame_mode(ds, f);
    uint64_t h = esr_hash_floats(ESR_HASH_INIT, &c->c2w[0][0], 12);
    h = esr_hash_bytes(h, &c->width, sizeof c->width);
    h = esr_hash_bytes(h, &c->height, sizeof c->height);
    h = esr_hash_floats(h, &c->focal, 1);
    hex16(esr_hash_bytes(h, &mode, sizeof mode), out);
}

cJSON *esr_view_stamp_frames(const char *text, size_t size, const char *model)
{
    cJSON *root = cJSON_ParseWithLength(text, size);
    const cJSON *mo = cJSON_GetObjectItemCaseSensitive(root, "model");
    const cJSON *ou = cJSON_GetObjectItemCaseSensitive(root, "outputs");
    cJSON *frames = cJSON_DetachItemFromObjectCaseSensitive(root, "frames");
    const int match = cJSON_IsString(mo) && !strcmp(mo->valuestring, model) && cJSON_IsObject(frames) &&
                      cJSON_IsNumber(ou) && ou->valuedouble == ESR_VIEW_OUTPUTS_VERSION;
    cJSON_Delete(root);
    if (!match) {
        cJSON_Delete(frames);
        return NULL;
    }
    return frames;
}

/* The frames of dir's stamp when the stamp names this model (fingerprint fp); NULL otherwise
 * (no stamp, an unreadable one, or one of another model: those renders are stale). */
static cJSON *current_frames(const char *dir, const char *fp)
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
    cJSON *frames = esr_view_stamp_frames((const char *)text, size, fp);
    free(text);
    return frames;
}

/* 1 when the stamp's frames hold f with its view as the dataset has it now. */
static int stamped(const cJSON *frames, const struct esr_dataset *ds, const struct esr_frame *f)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(frames, f->name);
    char view[24];
    view_fingerprint(ds, f, view);
    return cJSON_IsString(v) && !strcmp(v->valuestring, view);
}

void esr_view_current(const char *dir, const struct esr_model *m, const struct esr_dataset *ds,
                      enum esr_phase_id phase, const int *idx, int n, uint8_t *current)
{
    char fp[24];
    hex16(esr_model_fingerprint(m), fp);
    cJSON *frames = current_frames(dir, fp);
    const struct esr_phase *ph = &ds->phases[phase];
    for (int i = 0; i < n; i++) {
        const struct esr_frame *f = &ph->frames[idx[i]];
        current[i] = (uint8_t)(frames && stamped(frames, ds, f) && esr_view_outputs_exist(dir, f->name));
    }
    cJSON_Delete(frames);
}

/* Records `frames` (taken over) as rendered by the model of fingerprint fp. */
static int write_stamp(const char *dir, const struct esr_model *m, const char *fp, cJSON *frames)
{
    char path[ESR_PATH_MAX];
    cJSON *root = cJSON_CreateObject();
    if (!root) {
        cJSON_Delete(frames);
        return ESR_FAIL("out of memory writing the render record of %s", dir);
    }
    cJSON_AddStringToObject(root, "stage", esr_stage_name((enum esr_stage)m->stage));
    cJSON_AddNumberToObject(root, "step", (double)m->step);
    cJSON_AddStringToObject(root, "model", fp);
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
    char path[ESR_PATH_MAX], fp[24];
    hex16(esr_model_fingerprint(m), fp);
    cJSON *frames = current_frames(dir, fp);
    if (!frames)
        frames = cJSON_CreateObject();
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
        if (status == ESR_OK) {
            char view[24];
            view_fingerprint(ds, f, view);
            cJSON_DeleteItemFromObjectCaseSensitive(frames, f->name);
            cJSON_AddStringToObject(frames, f->name, view);
        }
        if (status == ESR_OK && progress) {
            struct esr_view_progress p = {f->name, i + 1, n, omp_get_wtime() - t0};
            progress(user, &p);
        }
    }
    if (status == ESR_OK)
        status = esr_view_write_env(dir, m);
    /* Frames finished before a failure stay recorded. */
    const int recorded = write_stamp(dir, m, fp, frames);
    return status == ESR_OK ? recorded : status;
}
