/* A mix of the lights as JSON, the one edit `esr lightmix` writes as DIR/mix.json (the found
 * mix), its page saves, and `esr edit --mix FILE` takes:
 *     {"lights": [{"id": 0, "intensity": 0.5}, {"id": 1, "intensity": 1, "hue": 0.6,
 *                 "saturation": 1}], "exposure": 0}
 * one entry per light at most (a light left out keeps its found emission); intensity in
 * [0, ESR_LIGHT_EDIT_MAX_INTENSITY] (default 1), hue and saturation in [0, 1], given together (a
 * recolour, value kept: model/lights.h); exposure in stops (default 0), which multiplies the
 * linear view by 2^exposure. */
#ifndef ESR_EDIT_LIGHT_MIX_H
#define ESR_EDIT_LIGHT_MIX_H

#include <cjson/cJSON.h>

#include "model/lights.h"

#ifdef __cplusplus
extern "C" {
#endif

/* the exposure a mix may ask, in stops either way */
#define ESR_MIX_MAX_EXPOSURE 20.0

struct esr_light_mix {
    int n_lights;
    struct esr_light_edit edit[ESR_MAX_LIGHTS];
    double exposure; /* stops */
};

/* The found mix of n lights: every light as found, exposure 0. */
void esr_light_mix_found(struct esr_light_mix *mix, int n_lights);
/* The mix in path for a run of n_lights lights; refuses malformed JSON, an unknown light, a
 * light given twice, a value out of range or of the wrong type, naming the file and the field
 * ("mix.json: lights[1].hue: 1.5 is not a number in [0, 1]"). */
int esr_light_mix_read(const char *path, int n_lights, struct esr_light_mix *mix);
/* The same from a document already parsed (name stands for the file in messages). */
int esr_light_mix_from_json(const cJSON *root, const char *name, int n_lights,
                            struct esr_light_mix *mix);
/* The mix as JSON (NULL on out of memory): every light, hue and saturation where recoloured. */
cJSON *esr_light_mix_json(const struct esr_light_mix *mix);
/* The gain of its exposure: 2^exposure. */
float esr_light_mix_gain(const struct esr_light_mix *mix);

#ifdef __cplusplus
}
#endif
#endif
