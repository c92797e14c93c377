/* Mixes of the lights as JSON (see light_mix.h). */
#include "edit/light_mix.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "io/file.h"
#include "io/json_file.h"

void esr_light_mix_found(struct esr_light_mix *mix, int n_lights)
{
    memset(mix, 0, sizeof *mix);
    mix->n_lights = n_lights;
    for (int k = 0; k < ESR_MAX_LIGHTS; k++)
        mix->edit[k] = (struct esr_light_edit){1.0f, 0, 0.0f, 0.0f};
}

/* obj's number `key` in [lo, hi] into *v (absent: left as it is, *given 0); refused naming the
 * file and the field. */
static int mix_number(const cJSON *obj, const char *key, const char *name, const char *field,
                      double lo, double hi, double *v, int *given)
{
    const cJSON *it = cJSON_GetObjectItemCaseSensitive(obj, key);
    *given = it != NULL;
    if (!it)
        return ESR_OK;
    if (!cJSON_IsNumber(it))
        return ESR_FAIL("%s: %s%s%s: not a number (expected one in [%g, %g])", name, field,
                        *field ? "." : "", key, lo, hi);
    if (!(it->valuedouble >= lo && it->valuedouble <= hi))
        return ESR_FAIL("%s: %s%s%s: %g is not a number in [%g, %g]", name, field, *field ? "." : "",
                        key, it->valuedouble, lo, hi);
    *v = it->valuedouble;
    return ESR_OK;
}

/* The keys obj may hold (NULL-terminated): another is refused (a misspelt "saturaton" would
 * otherwise be dropped without a word). */
static int mix_keys(const cJSON *obj, const char *const *keys, const char *name, const char *field)
{
    for (const cJSON *it = obj->child; it; it = it->next) {
        int known = 0;
        for (int i = 0; keys[i] && !known; i++)
            known = it->string && !strcmp(it->string, keys[i]);
        if (!known)
            return ESR_FAIL("%s: %s%sunknown field '%s'", name, field, *field ? ": " : "",
                            it->string ? it->string : "?");
    }
    return ESR_OK;
}

int esr_light_mix_from_json(const cJSON *root, const char *name, int n_lights,
                            struct esr_light_mix *mix)
{
    esr_light_mix_found(mix, n_lights);
    static const char *const top_keys[] = {"lights", "exposure", NULL};
    static const char *const light_keys[] = {"id", "intensity", "hue", "saturation", NULL};
    if (!cJSON_IsObject(root))
        return ESR_FAIL("%s: a mix is a JSON object {\"lights\": [...], \"exposure\": 0}", name);
    ESR_TRY(mix_keys(root, top_keys, name, ""));
    int given;
    ESR_TRY(mix_number(root, "exposure", name, "", -ESR_MIX_MAX_EXPOSURE, ESR_MIX_MAX_EXPOSURE,
                       &mix->exposure, &given));
    const cJSON *lights = cJSON_GetObjectItemCaseSensitive(root, "lights");
    if (lights && !cJSON_IsArray(lights))
        return ESR_FAIL("%s: lights: not an array of {\"id\": N, ...}", name);
    int seen[ESR_MAX_LIGHTS] = {0}, i = 0;
    for (const cJSON *l = lights ? lights->child : NULL; l; l = l->next, i++) {
        char field[32];
        snprintf(field, sizeof field, "lights[%d]", i);
        if (!cJSON_IsObject(l))
            return ESR_FAIL("%s: %s: not an object {\"id\": N, ...}", name, field);
        ESR_TRY(mix_keys(l, light_keys, name, field));
        double id = -1.0, intensity = 1.0, hue = 0.0, sat = 0.0;
        int has_id, has_hue, has_sat;
        ESR_TRY(mix_number(l, "id", name, field, 0.0, 1e6, &id, &has_id));
        if (!has_id)
            return ESR_FAIL("%s: %s: no id (the light's, as `esr lights RUN` lists them)", name,
                            field);
        if (id != floor(id) || id >= n_lights)
            return ESR_FAIL("%s: %s.id: no light %g: the run found %d light%s (ids 0..%d)", name,
                            field, id, n_lights, n_lights == 1 ? "" : "s", n_lights - 1);
        const int k = (int)id;
        if (seen[k]++)
            return ESR_FAIL("%s: %s.id: light %d is given twice", name, field, k);
        ESR_TRY(mix_number(l, "intensity", name, field, 0.0, ESR_LIGHT_EDIT_MAX_INTENSITY,
                           &intensity, &given));
        ESR_TRY(mix_number(l, "hue", name, field, 0.0, 1.0, &hue, &has_hue));
        ESR_TRY(mix_number(l, "saturation", name, field, 0.0, 1.0, &sat, &has_sat));
        if (has_hue != has_sat)
            return ESR_FAIL("%s: %s: %s without %s (a recolour gives both)", name, field,
                            has_hue ? "hue" : "saturation", has_hue ? "saturation" : "hue");
        mix->edit[k] = (struct esr_light_edit){(float)intensity, has_hue, (float)hue, (float)sat};
    }
    return ESR_OK;
}

int esr_light_mix_read(const char *path, int n_lights, struct esr_light_mix *mix)
{
    unsigned char *text = NULL;
    size_t size = 0;
    esr_light_mix_found(mix, n_lights);
    ESR_TRY(esr_file_read_all(path, &text, &size));
    cJSON *root = esr_json_parse_whole((const char *)text, size, path);
    free(text);
    if (!root)
        return ESR_ERR; /* said, naming the file, line and column */
    const int rc = esr_light_mix_from_json(root, path, n_lights, mix);
    cJSON_Delete(root);
    return rc;
}

cJSON *esr_light_mix_json(const struct esr_light_mix *mix)
{
    cJSON *root = cJSON_CreateObject();
    cJSON *lights = root ? cJSON_AddArrayToObject(root, "lights") : NULL;
    if (!lights) {
        cJSON_Delete(root);
        return NULL;
    }
    for (int k = 0; k < mix->n_lights; k++) {
        cJSON *l = cJSON_CreateObject();
        if (!l || !cJSON_AddItemToArray(lights, l)) {
            cJSON_Delete(l);
            cJSON_Delete(root);
            return NULL;
        }
        const struct esr_light_edit *e = &mix->edit[k];
        cJSON_AddNumberToObject(l, "id", k);
        cJSON_AddNumberToObject(l, "intensity", e->intensity);
        if (e->recolour) {
            cJSON_AddNumberToObject(l, "hue", e->hue);
            cJSON_AddNumberToObject(l, "saturation", e->sat);
        }
    }
    cJSON_AddNumberToObject(root, "exposure", mix->exposure);
    return root;
}

float esr_light_mix_gain(const struct esr_light_mix *mix)
{
    return (float)exp2(mix->exposure);
}
