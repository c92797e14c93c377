/* Ray groups of the pdra stage (METHOD.md stage 5, "progressive refinement with ray groups"):
 * a training ray is *certain* (not an emitter) when every channel of its composited emission E
 * is at most k, else *uncertain*. k rises from pdra_k0 to pdra_k_end over the first 3/4 of the
 * stage. Certain rays get an emission-suppression penalty pdra_supp * mean(E^2) and their LTS
 * points re-render L_emo from reflection alone (no E); uncertain points keep E (train/lts.h).
 *
 * Two choices differ from the authors' release, both for a user without per-scene tuning:
 * - k_end is derived from the data when pdra.k_end is 0: at the stage's first step, pdra.k_frac
 *   times the 99.5th percentile of the batch's composited max-channel E (the level emitters
 *   reach after lts, since they are the brightest emission in the scene), stored in the model's
 *   options (so checkpoints and resumes keep it) and logged. The authors hand-pick k's slope
 *   per scene. Every step k is also capped by pdra.k_frac times the batch's current level, so a
 *   k that overtakes the emitters (lamp with k_frac 0.6 and no cap: IoU 0.04) cannot happen.
 * - pdra.sg = 0 and pdra.progressive = 0 are the seed's two ablations.
 * - Groups are decided per batch from the current E, not kept in a per-ray table updated every
 *   200 steps: nothing to store or checkpoint, and a ray suppressed below k stays below it. */
#ifndef ESR_TRAIN_PDRA_H
#define ESR_TRAIN_PDRA_H

#include <stddef.h>
#include <stdint.h>

#include "model/material_fields.h"
#include "model/model.h"
#include "train/pdra_reg.h"
#include "volume/march.h"

#ifdef __cplusplus
extern "C" {
#endif

struct esr_pdra {
    int max_rays;
    struct esr_material_fields mf; /* E on the batch's kept rows */
    float *e_ray3;                 /* [max_rays * 3] composited E per ray */
    float *d_e_ray3;               /* its gradient */
    float *d_rows3;                /* [rows_cap * 3] per kept row */
    size_t rows_cap;
    uint8_t *certain;              /* [max_rays] */
    float *sorted;                 /* [max_rays] scratch for the emitters' level */
    struct esr_pdra_reg reg;       /* emission and normal smoothness */
    /* the last step */
    float k;
    int n_certain;
    double supp_loss;
};

int esr_pdra_init(struct esr_pdra *pd, const struct esr_model *m, int max_rays);
void esr_pdra_free(struct esr_pdra *pd);

/* k at `step` of a stage of `iters` iterations: k0 + (k_end - k0) min(1, step / (0.75 iters)). */
float esr_pdra_k(const struct esr_train_config *cfg, long step, long iters);

/* Composited E of the n rays of mc's last forward, their groups at k(m->step), the suppression
 * loss (returned in pd->supp_loss) and the smoothness terms (pd->reg, jitter from seed), their
 * gradients ADDED into grads and g_sdf (suppression through E only: the geometry's alpha gets
 * none). When m->cfg.pdra_k_end is 0 it is derived from this batch
 * and written into m->cfg; *chosen_k_end then receives it (else 0). */
int esr_pdra_step(struct esr_pdra *pd, struct esr_model *m, const float *sdf, float *g_sdf,
                  float *grads, const struct esr_march *mc, uint64_t seed, float *chosen_k_end);

#ifdef __cplusplus
}
#endif
#endif
