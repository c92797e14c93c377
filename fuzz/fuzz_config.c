/* Training configuration files (src/model/config.c). An accepted file must give a valid
 * configuration that survives the checkpoint's JSON round trip unchanged. */
#include <string.h>

#include "fuzz.h"
#include "model/config.h"

/* The configuration as the checkpoint stores it (unformatted JSON text; NULL on no memory). */
static char *config_text(const struct esr_train_config *c)
{
    cJSON *j = esr_config_to_json(c);
    char *text = j ? cJSON_PrintUnformatted(j) : NULL;
    cJSON_Delete(j);
    return text;
}

static void check_round_trip(const struct esr_train_config *c)
{
    if (esr_config_validate(c) != ESR_OK)
        abort();
    char *text = config_text(c);
    cJSON *j = text ? cJSON_Parse(text) : NULL;
    struct esr_train_config back;
    if (j && esr_config_from_json(&back, j, "round trip", NULL) != ESR_OK)
        abort();
    char *again = j ? config_text(&back) : NULL;
    if (text && again && strcmp(text, again))
        abort();
    cJSON_free(text);
    cJSON_free(again);
    cJSON_Delete(j);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fuzz_setup();
    struct esr_train_config c;
    esr_config_defaults(&c, ESR_PRESET_FAST);
    int status = esr_config_parse_json(&c, (const char *)data, size, "fuzz.json");
    if (status == ESR_OK)
        check_round_trip(&c);
    fuzz_done(status);
    return 0;
}
