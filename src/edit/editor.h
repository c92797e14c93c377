/* One entry point for the relighting methods: set an edit of the lights, then render views of
 * the edited scene. `direct` and `ratio` (edit/relight.h) render any edit straight away; `finetune`
 * (edit/finetune.h) fine-tunes L_emo once per distinct edit (setting the edit the model already
 * shows costs nothing) and renders the lights-on radiance of the fine-tuned model, with the
 * direct light where a pixel sees a light (edit/relight.h, the model mode). */
#ifndef ESR_EDIT_EDITOR_H
#define ESR_EDIT_EDITOR_H

#include <stdint.h>

#include "edit/finetune.h"
#include "edit/relight.h"
#include "io/camera.h"
#include "io/dataset.h"
#include "io/image.h"
#include "model/model.h"

#ifdef __cplusplus
extern "C" {
#endif

enum esr_edit_method { ESR_EDIT_DIRECT, ESR_EDIT_FINETUNE, ESR_EDIT_RATIO };

/* "direct" / "finetune" / "ratio" */
const char *esr_edit_method_name(enum esr_edit_method method);
int esr_edit_method_from_name(const char *name, enum esr_edit_method *out);

struct esr_editor {
    enum esr_edit_method method;
    struct esr_model *m;
    struct esr_relight relight;  /* renders every method's views */
    struct esr_finetune ft;
    struct esr_light_edit edits[ESR_MAX_LIGHTS]; /* the current edit */
    int has_edit;
    int finetunes;                /* fine-tunes run so far */
    double finetune_seconds;      /* their total time */
    struct esr_finetune_stats last; /* of the last fine-tune */
};

/* An editor of model m (a finished pdra model; modified in place by finetune until
 * esr_editor_free puts it back). ds: the run's dataset (finetune trains on its training
 * cameras; unused by direct and ratio). spp: light samples per pixel (direct and ratio; finetune's
 * on the pixels that see a light). ft: fine-tuning options
 * (NULL: the defaults). */
int esr_editor_init(struct esr_editor *e, struct esr_model *m, const struct esr_dataset *ds,
                    enum esr_edit_method method, int spp, const struct esr_finetune_opts *ft);
void esr_editor_free(struct esr_editor *e);

/* Sets the edit (one per light of the model); finetune fine-tunes unless it is the current one. */
int esr_editor_set(struct esr_editor *e, const struct esr_light_edit *edits, uint64_t seed);

/* The edited view of cam: linear RGB on white into *out (allocated, 3 channels). */
int esr_editor_view(struct esr_editor *e, const struct esr_camera *cam, uint64_t seed,
                    struct esr_image *out);

#ifdef __cplusplus
}
#endif
#endif
