/* The colour heads of struct esr_trace (internal to src/train): what runs on the kept samples
 * of a batch in each stage.
 *   alphamask: direct colour grid, sigmoid (off RGB in channels 0-2, on RGB in 3-5)
 *   coarse:    colour MLP on [feature grid | PE(dir) | lights flag], sigmoid
 *   fine:      off / emo radiance MLPs on [feature grid | PE(x) | geometry feature | PE(dir)],
 *              L = L_off (+ L_emo on on-rays), tone-mapper on PE(L); the off branch of on-rays
 *              runs in inference mode (stop-gradient, METHOD.md stage 3). */
#ifndef ESR_MODEL_TRACE_HEADS_H
#define ESR_MODEL_TRACE_HEADS_H

#include "model/trace.h"

/* Sets the head's row widths in t from m's stage. */
void esr_trace_heads_dims(struct esr_trace *t, const struct esr_model *m);
/* (Re)allocates the kept-sample buffers (and MLP workspaces when t->train) for cap rows. */
int esr_trace_heads_grow(struct esr_trace *t, const struct esr_model *m, size_t cap);
void esr_trace_heads_free(struct esr_trace *t);
/* Evaluates the head on the kept samples; writes val_tone3 (and val_lin3 in fine) at kidx. */
int esr_trace_heads_fwd(struct esr_trace *t, const struct esr_model *m, const float *sdf);
/* From d_val_tone3 / d_val_lin3 at kidx: parameter gradients into grads, SDF gradients (fine
 * geometry feature) into g_sdf. */
int esr_trace_heads_bwd(struct esr_trace *t, const struct esr_model *m, const float *sdf,
                        float *g_sdf, float *grads);

#endif
