/* Radiance fine-tuning's loss (edit/finetune.h) on the LTS stage's points: it replaces the LTS
 * loss (train/lts.h, esr_lts_loss_hook) while an edit is fine-tuned. For each point p and both
 * outgoing directions, the points' L_emo' goes towards
 *     sg(L_emo (D' + K L_emo' + f') / (D + K L_emo + f))   (per channel, held at most 16)
 * D, D': the lights' direct light at p as found and edited (the caller's, one set of samples);
 * f, f': 5% of the step's mean D and D' (the ratio relight's mean term: light that reaches x by
 * ways the direct light misses follows the scene's average change; +0.4 dB on lamp test_nvc);
 * K L: the reflection of the incident L_emo over hits not on a light; L_emo: the trained model on
 * the same rows. The trained L_emo is not exactly a fixed point of the reconstructed transport
 * (calibration, BRDF, normals): fine-tuning towards the plain estimate first drifts to that
 * transport's own solution (lamp, an edit that changes nothing: 19.6 dB against the model's own
 * render), and keeping the unexplained rest as an added residual keeps it in the old colour
 * (lamp test_nvc 26.0 dB: a warm floor under a red lamp). As a ratio, an edit that changes
 * nothing is a fixed point and all of L_emo follows the lights. The target is fixed each step (a
 * fixed-point iteration); only the points' L_emo rows get a gradient; points on a light are left
 * out (their L_emo is the saturated emitter, and the editor renders lights from their emission).
 * Each channel's squared error is weighted by esr_image_error_scale squared at the target's
 * lights-on radiance (L_off + target): edits are judged as images, and a recolour to a saturated
 * hue takes channels near 0 (a faint colour haze on the floor in a linear MSE). */
#ifndef ESR_EDIT_FINETUNE_LOSS_H
#define ESR_EDIT_FINETUNE_LOSS_H

#include <stddef.h>
#include <stdint.h>

#include "model/lights.h"
#include "model/model.h"
#include "model/point_fields.h"
#include "train/lts.h"

#ifdef __cplusplus
extern "C" {
#endif

struct esr_finetune_loss {
    const struct esr_light_edit *edit; /* one per light of the model, while an edit is tuned */
    const struct esr_model *ref;       /* the trained model (weights before fine-tuning) */
    size_t P, M;                       /* points, directions per point the buffers hold */
    /* [P*2*3] D' and D per point and outgoing direction: the caller fills them each step, from
     * the LTS's points, before esr_finetune_loss_run */
    float *direct3, *found3;
    float edit_floor[3], found_floor[3]; /* the step's floors f' and f */
    uint8_t *on_light;                 /* [P*M] the direction's first hit is on a light */
    struct esr_point_fields pf_ref;    /* the trained model's rows */
    int has_pf_ref;
};

/* Buffers for `points` points with `dirs` incident directions each (the LTS's sizes). */
int esr_finetune_loss_init(struct esr_finetune_loss *fl, const struct esr_model *ref, int points,
                           int dirs);
void esr_finetune_loss_free(struct esr_finetune_loss *fl);

/* The loss on the step's P points of l (after their rows q are rendered into l->pf): adds its
 * gradient into l->d_lin3 (the L_emo rows) and its weighted squared error into *se_emo; the
 * mean is over points x 2 outgoing directions x 3 channels, as the LTS loss's. */
int esr_finetune_loss_run(struct esr_finetune_loss *fl, struct esr_lts *l,
                          const struct esr_model *m, const float *sdf,
                          const struct esr_point_query *q, size_t P, double *se_emo);

#ifdef __cplusplus
}
#endif
#endif
