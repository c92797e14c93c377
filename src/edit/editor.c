/* The relighting methods behind one interface (see editor.h). */
#include "edit/editor.h"

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
    const enum esr_relight_mode mode = method == ESR_EDIT_FINETUNE ? ESR_RELIGHT_MODEL
                                       : method == ESR_EDIT_RATIO  ? ESR_RELIGHT_RATIO
                                                                   : ESR_RELIGHT_DIRECT;
    /* before any fine-tune: the lights' samples carry the emission as trained */
    ESR_TRY(esr_relight_init(&e->relight, m, spp, mode));
    if (method != ESR_EDIT_FINETUNE)
        return ESR_OK;
    struct esr_finetune_opts defaults;
    esr_finetune_default_opts(&defaults);
    int rc = esr_finetune_init(&e->ft, m, ds, ft ? ft : &defaults);
    if (rc != ESR_OK)
        esr_relight_free(&e->relight);
    return rc;
}

void esr_editor_free(struct esr_editor *e)
{
    esr_relight_free(&e->relight);
    if (e->method == ESR_EDIT_FINETUNE && e->m) {
        esr_finetune_restore(&e->ft, e->m);
        esr_finetune_free(&e->ft);
    }
    memset(e, 0, sizeof(*e));
}

int esr_editor_set(struct esr_editor *e, const struct esr_light_edit *edits, uint64_t seed)
{
    const size_t bytes = (size_t)e->m->lights.n * sizeof *edits;
    ESR_TRY(esr_light_edits_check(edits, e->m->lights.n));
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
    /* finetune: the fine-tuned model's lights-on radiance, each sample on a light as the
     * lights-off radiance plus the light's edited emission, and where a pixel sees a light the
     * edited lights' direct light (edit/relight.h, the model mode) */
    return esr_relight_view(&e->relight, e->m, e->edits, cam, seed, out, NULL);
}
