/* Checkpoint loading (src/model/checkpoint.c): header JSON, stored configuration, component
 * table, mask cache and light labels. */
#include "fuzz.h"
#include "model/model.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fuzz_setup();
    struct esr_model m;
    int status = esr_model_load_buffer(&m, data, size, "fuzz.bin");
    if (status == ESR_OK)
        esr_model_free(&m);
    fuzz_done(status);
    return 0;
}
