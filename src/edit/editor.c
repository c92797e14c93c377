/* The relighting methods behind one interface (see editor.h). */
#include "edit/editor.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"

const char *esr_edit_method_name(enum esr_edit_method method)
{
    return method == ESR_EDIT_FINETUNE ? "finetune" : method == ESR_EDIT_RATIO ? "ratio" : "direct";
}

int esr_edit_method_from_name(const char *name, enum esr_edit_method *out)
{
    if (!strcmp(name, "direct"))
        *out = ESR_EDIT_DIRECT;
    else if (!strcmp(name, "finetune"))
        *out = ESR_EDIT_FINETUNE;
    else if (!strcmp(name, "ratio"))
        *out = ESR_EDIT_RATIO;
    else
        return ESR_ERR;
    return ESR_OK;
}

int esr_editor_init(struct esr_editor *e, struct esr_model *m, const struct esr_dataset *ds,
                    enum esr_edit_method method, int spp, const struct esr_finetune_opts *ft)
{
    memset(e, 0, sizeof(*e));
    e->method = method;
    e->m = m;
    if (method != ESR_EDIT_FINETUNE)
        return esr_relight_init(&e->direct, m, spp, method == ESR_EDIT_RATIO);
    struct esr_finetune_opts defaults;
    esr_finetune_default_opts(&defaults);
    return esr_finetune_init(&e->ft, m, ds, ft ? ft : &defaults);
}

void esr_editor_free(struct esr_editor *e)
{
    if (e->method != ESR_EDIT_FINETUNE) {
        esr_relight_free(&e->direct);
    } else if (e->m) {
        esr_finetune_restore(&e->ft, e->m);
        esr_finetune_free(&e->ft);
    }
    memset(e, 0, sizeof(*e));
}

int esr_editor_set(struct esr_editor *e, const struct esr_light_edit *edits, uint64_t seed)
{
    const size_t bytes = (size_t)e->m->lights.n * sizeof *edits;
    if (e->method == ESR_EDIT_FINETUNE && !(e->has_edit && !memcmp(e->edits, edits, bytes))) {
        e->has_edit = 0;
        ESR_TRY(esr_finetune_apply(&e->ft, e->m, edits, seed, &e->last));
        e->finetunes++;
        e->finetune_seconds += e->last.seconds;
    }
    memcpy(e->edits, edits, bytes);
    e->has_edit = 1;
    return ESR_OK;
}

int esr_editor_view(struct esr_editor *e, const struct esr_camera *cam, uint64_t seed,
                    struct esr_image *out)
{
    if (!e->has_edit)
        return ESR_FAIL("edit: no edit set before rendering");
    if (e->method != ESR_EDIT_FINETUNE)
        return esr_relight_view(&e->direct, e->m, e->edits, cam, seed, out);
    /* the fine-tuned model's lights-on radiance; at the samples on a light, the lights-off
     * radiance plus the light's edited emission (the model's lights carry the edit): L_emo on a
     * light is the saturated emitter, which fine-tuning does not train (train/lts.c) */
    const size_t n = (size_t)cam->width * (size_t)cam->height;
    ESR_TRY(esr_image_alloc(out, cam->width, cam->height, 3));
    float *o = malloc(n * 3 * sizeof(float)), *d = malloc(n * 3 * sizeof(float));
    int rc = o && d ? ESR_OK : ESR_FAIL("edit: out of memory for a %zu-pixel view", n);
    if (rc == ESR_OK) {
        esr_camera_pixel_rays(cam, o, d);
        struct esr_render_out r = {.linear = out->data, .lights_emitted_only = 1};
        rc = esr_model_render_rays(e->m, o, d, n, 1, &r);
    }
    free(o), free(d);
    if (rc != ESR_OK)
        esr_image_free(out);
    return rc;
}
