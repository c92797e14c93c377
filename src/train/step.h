/* One training step's loss and gradient, the path the trainer runs every iteration and the
 * finite-difference tests check: the SDF the stage renders (raw, or Gaussian-smoothed in the
 * coarse stage), the trace forward (march -> point fields -> composite), the two-term rendering
 * loss, the trace backward and the smoothing's adjoint; in the lts stage the light-transport
 * loss on the batch's kept samples (train/lts.h) is added. Regularisers and the optimiser are the
 * trainer's (train/trainer.c). */
#ifndef ESR_TRAIN_STEP_H
#define ESR_TRAIN_STEP_H

#include <stdint.h>

#include "model/model.h"
#include "model/trace.h"
#include "train/lts.h"
#include "train/pdra.h"
#include "train/render_loss.h"

#ifdef __cplusplus
extern "C" {
#endif

struct esr_train_step {
    int max_rays;
    struct esr_trace tr;
    /* the batch, filled by the caller: [max_rays * 3] each, lights_on [max_rays] */
    float *orig3, *dir3, *tgt3;
    uint8_t *lights_on;
    float *d_rgb3, *d_lin3;                 /* loss gradients per ray */
    float *d_t_last;                        /* [max_rays] entropy gradient (pdra) */
    double ent_loss;                        /* pdra's entropy term of the last step */
    float *sdf_view, *g_sdf_view, *scratch; /* smoothed-SDF stages: the view and its gradient */
    float *grad_tv_work;                    /* smoothed-gradient TV work space (when enabled) */
    int has_lts;                            /* the stage adds the LTS loss */
    struct esr_lts lts;
    struct esr_lts_stats lts_stats;         /* of the last step */
    int has_pdra;                           /* the stage has ray groups */
    struct esr_pdra pdra;
    float pdra_chosen_k_end;                /* > 0 on the step that derived k_end */
};

/* Buffers for batches of up to max_rays rays of m's stage. */
int esr_train_step_init(struct esr_train_step *st, const struct esr_model *m, int max_rays);
void esr_train_step_free(struct esr_train_step *st);

/* Loss of the n rays in st's batch and, in m->params.g (zeroed first), its gradient with
 * respect to every parameter of m. `seed` drives the sample jitter. */
int esr_train_step_run(struct esr_train_step *st, struct esr_model *m, int n, uint64_t seed,
                       struct esr_render_loss_result *out);

#ifdef __cplusplus
}
#endif
#endif
