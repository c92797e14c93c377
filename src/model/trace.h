/* One batch of rays through the model, forward and backward: the shared engine of training and
 * rendering (train/model.h). Pipeline of a coarse/fine batch:
 *   march (mask cache skips empty space) -> SDF value + gradient at every sample -> NeuS alpha
 *   from the mid-point section estimate -> weights -> keep samples with weight > 1e-4 -> only the
 *   kept samples run the feature grids, geometry feature, encodings and MLPs -> composite on
 *   white (tone-mapped LDR and linear) ; the backward pass reverses it into the flat gradient.
 * The alphamask stage replaces SDF + NeuS by DVGO density alpha and the MLP by a colour grid.
 *
 * Rays [0, n_off) of a batch are lights-off, [n_off, n) lights-on, so the kept samples of on-rays
 * form a contiguous suffix and the emo branch runs only on them. Buffers grow to the high-water
 * mark of the first batches and are then reused: the training loop allocates nothing in steady
 * state. */
#ifndef ESR_MODEL_TRACE_H
#define ESR_MODEL_TRACE_H

#include <stddef.h>
#include <stdint.h>

#include "nn/mlp.h"
#include "volume/sampler.h"
#include "model/model.h"

#ifdef __cplusplus
extern "C" {
#endif

struct esr_trace {
    int train;               /* 1: keep what backward needs (MLP contexts, jittered samples) */
    int max_rays;
    size_t cap_samples, cap_kept;
    struct esr_samples smp;
    int n_rays, n_off;       /* rays of the last forward; the first n_off are lights-off */
    float step;              /* marching step of the last forward */
    const float *dirs;       /* ray directions of the last forward (kept alive by the caller) */
    /* per sample [cap_samples] (x3 where noted) */
    float *f, *grad3, *fp, *fn, *alpha, *weight, *d_alpha, *d_f, *d_grad3;
    float *val_tone3, *val_lin3, *d_val_tone3, *d_val_lin3;
    /* kept samples [cap_kept]: kept samples of off-rays first (n_kept_off of them) */
    size_t n_kept, n_kept_off;
    uint32_t *kidx;          /* sample index of kept row k */
    float *kpos3, *kdir3;
    float *x_a, *x_b;        /* MLP input rows of branch a (colour / off) and b (emo) */
    float *dx_a, *dx_b;
    float *y_a3, *y_b3, *lin3, *tone_in, *tone3, *d_y_a3, *d_y_b3, *d_lin3, *d_tone_in, *d_tone3;
    float *geo, *d_geo;      /* geometry feature rows (fine) */
    float *fa, *fb, *d_fa, *d_fb; /* feature-grid rows of branches a and b */
    int ch_a, ch_b;          /* feature-grid channels of branches a and b */
    int n_in_a, n_in_b, n_tone_in, geo_dim;
    struct esr_mlp_ctx ctx_a, ctx_b, ctx_tone;
    /* per ray [max_rays] */
    float *t_last, *rgb3, *lin_rgb3;
};

/* Workspace for batches of up to max_rays rays of model m's current stage (train = 1 keeps
 * the backward state). */
int esr_trace_init(struct esr_trace *t, const struct esr_model *m, int max_rays, int train);
void esr_trace_free(struct esr_trace *t);

/* Forward pass of n rays (n_off of them lights-off, first) through m, with `sdf` the SDF values
 * the renderer sees (m's raw grid, or its smoothed copy in the coarse stage). Jitter uses
 * (seed, stream) when t->train. Fills t->rgb3 (tone-mapped / LDR, on white), t->lin_rgb3
 * (linear HDR on white; = rgb for coarse/alphamask) and t->t_last. */
int esr_trace_fwd(struct esr_trace *t, const struct esr_model *m, const float *sdf,
                  const float *origins, const float *dirs, int n, int n_off, uint64_t seed);
/* Backward of the last forward given d loss/d rgb and d loss/d lin (per ray x3; lin may be NULL):
 * adds into g_sdf (SDF gradient w.r.t. the values passed to forward) and into grads (the flat
 * gradient base: density, feature grids, MLPs). The off branch of on-rays is stop-gradient. */
int esr_trace_bwd(struct esr_trace *t, const struct esr_model *m, const float *sdf, float *g_sdf,
                  float *grads, const float *d_rgb3, const float *d_lin3);

/* Per-ray extras of the last forward for rendering (any may be NULL): expected distance,
 * composited SDF normal, opacity. */
void esr_trace_extras(const struct esr_trace *t, const struct esr_model *m, const float *sdf,
                      float *depth, float *normal3, float *opacity);

#ifdef __cplusplus
}
#endif
#endif
