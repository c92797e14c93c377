/* What `esr lights` prints and writes of a model's lights: the table (one header per number,
 * the units stated, H S V beside R G B as `esr edit --color H,S` takes them) and lights.json. */
#ifndef ESR_CLI_LIGHTS_LISTING_H
#define ESR_CLI_LIGHTS_LISTING_H

#include <cjson/cJSON.h>

#include "model/model.h"

/* What the lights' numbers are measured in (the table's header and lights.json's "units"). */
#define UNITS_RGB "linear RGB on the photos' scale (a pixel's sRGB value made linear: 1 = white)"
#define UNITS_POWER "luminance(rgb) x pi x area (Lambertian, one side): radiance x world units^2"
#define UNITS_AREA "world units^2"
/* The one thing the photos cannot fix about the strengths, said with them. */
#define STRENGTH_ASSUMPTION                                                                       \
    "the photos fix the lights' strengths only up to one scale they share with the environment " \
    "map and the base colour (a brighter map over a darker floor gives the same photos); esr "   \
    "takes the base colour the lights-off photos give with the map started from their mean "     \
    "(a scene that averages grey)"

/* Prints m's lights to stdout; unseen[id]: each light's surface points no photo shows. */
void esr_cli_lights_print(const struct esr_model *m, const long *unseen);
/* m's lights as lights.json's object (`esr lights --help` lists its keys); ckpt names the
 * checkpoint they are stored in. NULL when out of memory. */
cJSON *esr_cli_lights_json(const struct esr_model *m, const char *ckpt, const long *unseen);

#endif
