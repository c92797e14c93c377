/* Run directory look-ups shared by the render and eval commands. */
#include "eval/run_dir.h"

#include <cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "eval/select.h"
#include "io/dir.h"
#include "io/file.h"

/* The dataset path recorded in a run file's parsed JSON (root may be NULL); 1 when found. */
static int data_key_in(const cJSON *root, char *out, size_t n)
{
    static const char *const keys[] = {"data", "data_dir", "dataset"};
    for (size_t k = 0; k < sizeof keys / sizeof keys[0]; k++) {
        const cJSON *v = cJSON_GetObjectItemCaseSensitive(root, keys[k]);
        if (cJSON_IsString(v) && v->valuestring[0] && strlen(v->valuestring) < n) {
            snprintf(out, n, "%s", v->valuestring);
            return 1;
        }
    }
    return 0;
}

int esr_run_data_key(const char *text, size_t size, char *out, size_t n)
{
    cJSON *root = cJSON_ParseWithLength(text, size);
    const int found = data_key_in(root, out, n);
    cJSON_Delete(root);
    return found;
}

/* The dataset path in `file`: 1 when found; 0 when the file is absent, unreadable or has no
 * such key; -1 when it exists but is not JSON (a damaged file, which the caller names). */
static int data_key_of(const char *file, char *out, size_t n)
{
    unsigned char *text;
    size_t size;
    if (!esr_file_exists(file))
        return 0;
    if (esr_file_read_all(file, &text, &size) != ESR_OK)
        return 0;
    cJSON *root = cJSON_ParseWithLength((const char *)text, size);
    free(text);
    const int found = root ? data_key_in(root, out, n) : -1;
    cJSON_Delete(root);
    return found;
}

int esr_run_data_dir(const char *run, const char *override, char *out, size_t n)
{
    if (override) {
        if (strlen(override) >= n)
            return ESR_FAIL("dataset path '%s' is too long", override);
        snprintf(out, n, "%s", override);
        return ESR_OK;
    }
    static const char *const files[] = {"run.json", "config.json"};
    char path[ESR_PATH_MAX], damaged[ESR_PATH_MAX] = "";
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        snprintf(path, sizeof path, "%s/%s", run, files[i]);
        const int found = data_key_of(path, out, n);
        if (found > 0) {
            esr_error_clear(); /* a file without the key is not an error */
            return ESR_OK;
        }
        if (found < 0 && i == 0) /* run.json: the file esr train writes for this */
            snprintf(damaged, sizeof damaged, "%s", path);
    }
    esr_error_clear();
    if (damaged[0])
        return ESR_FAIL("%s is not valid JSON (a damaged file: `esr train DATA --out %s "
                        "--resume` writes it again); give --data DIR", damaged, run);
    return ESR_FAIL("run '%s' does not record its dataset (no \"data\" in %s/run.json or %s/config.json); give "
                    "--data DIR",
                    run, run, run);
}

static int parse_phase(const char *name, enum esr_phase_id *out)
{
    if (esr_phase_from_name(name, out) == ESR_OK)
        return ESR_OK;
    esr_error_clear();
    char names[256] = "";
    for (int p = 0; p < ESR_PHASE_COUNT; p++) {
        size_t used = strlen(names);
        snprintf(names + used, sizeof names - used, "%s%s", p ? ", " : "", esr_phase_name((enum esr_phase_id)p));
    }
    return ESR_FAIL("unknown phase '%s' (phases: %s)", name, names);
}

int esr_run_select(const char *run, const char *data_override, const char *phase, const char *frames, int limit,
                   struct esr_run_selection *sel)
{
    memset(sel, 0, sizeof *sel);
    ESR_TRY(esr_dir_check_run(run));
    ESR_TRY(parse_phase(phase, &sel->phase));
    char data[ESR_PATH_MAX];
    ESR_TRY(esr_run_data_dir(run, data_override, data, sizeof data));
    ESR_TRY(esr_dataset_load(data, &sel->ds));
    if (!sel->ds.phases[sel->phase].present) {
        const char *file = esr_phase_file_name(&sel->ds, sel->phase);
        if (!file) /* a phase this dataset layout cannot hold */
            return ESR_FAIL("dataset '%s' has no phase %s (its layout has none)", data, phase);
        return ESR_FAIL("dataset '%s' has no phase %s (no %s)", data, phase, file);
    }
    return esr_select_frames(&sel->ds.phases[sel->phase], phase, frames, limit, &sel->idx, &sel->n);
}

void esr_run_selection_free(struct esr_run_selection *sel)
{
    esr_dataset_free(&sel->ds);
    free(sel->idx);
    memset(sel, 0, sizeof *sel);
}
