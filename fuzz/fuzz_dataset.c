/* The dataset loader's JSON (src/io/dataset.c): each input is read as a train transforms file
 * of the ESR layout and as scene.json; an accepted transforms file then has every path of every
 * frame built, as training and evaluation build them. */
#include <stdio.h>
#include <stdlib.h>

#include "fuzz.h"
#include "io/dataset.h"

static void build_paths(const struct esr_dataset *ds)
{
    const struct esr_phase *ph = &ds->phases[ESR_PHASE_TRAIN];
    if (ph->n_frames <= 0 || !ph->frames)
        abort();
    char path[ESR_PATH_MAX * 2 + 32], partner[ESR_NAME_MAX];
    for (int i = 0; i < ph->n_frames; i++) {
        const struct esr_frame *f = &ph->frames[i];
        esr_frame_image_path(ds, f, path, sizeof path);
        esr_frame_exr_path(ds, f, path, sizeof path);
        esr_frame_emission_path(ds, f, path, sizeof path);
        for (int k = 0; k < ds->n_lights; k++)
            esr_frame_light_mask_path(ds, f, k, path, sizeof path);
        esr_frame_off_partner(f->name, partner, sizeof partner);
        (void)esr_frame_mode(ds, f);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fuzz_setup();
    struct esr_dataset *ds = calloc(1, sizeof *ds);
    if (!ds)
        return 0;
    snprintf(ds->root, sizeof ds->root, "fuzz");
    ds->layout = ESR_LAYOUT_ESR;
    ds->n_lights = -1;
    int status = esr_dataset_parse_transforms(ds, ESR_PHASE_TRAIN, (const char *)data, size, "transforms_train.json");
    if (status == ESR_OK)
        build_paths(ds);
    fuzz_done(status);
    fuzz_done(esr_dataset_parse_scene(ds, (const char *)data, size, "scene.json"));
    esr_dataset_free(ds);
    free(ds);
    return 0;
}
