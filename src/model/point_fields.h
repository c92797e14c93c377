/* Trace layer 2 of 3, "point fields": the model's heads evaluated at arbitrary points and
 * directions, each row with its own lighting flag, forward and backward.
 *
 * The head comes from the stage table (model/components.h):
 *   ESR_HEAD_RGB_GRID:   sigmoid colour grid (off RGB in channels 0-2, on RGB in 3-5); LDR
 *   ESR_HEAD_COLOUR_MLP: colour MLP on [feature grid | PE(dir) | lights flag], sigmoid; LDR
 *   ESR_HEAD_RADIANCE:   L_off and, on lights-on rows, L_emo: MLPs on [feature grid | PE(x) |
 *                        geometry feature | PE(dir)], softplus (linear HDR); L = L_off + L_emo;
 *                        tone-mapper m_theta on PE(L) (sigmoid). The off branch of lights-on rows
 *                        runs in inference mode: stop-gradient (METHOD.md stage 3).
 * Rows may come in any order: internally the lights-off rows go first (a stable partition) so
 * each MLP runs on one contiguous block; outputs and input gradients are in the caller's order.
 * Primary rays call it on the kept samples of layer 1; the LTS loss will call it on its own
 * points and hemisphere directions. */
#ifndef ESR_MODEL_POINT_FIELDS_H
#define ESR_MODEL_POINT_FIELDS_H

#include <stddef.h>
#include <stdint.h>

#include "model/model.h"
#include "nn/mlp.h"

#ifdef __cplusplus
extern "C" {
#endif

struct esr_point_query {
    size_t n;
    const float *pos3, *dir3;  /* [n * 3] world positions, unit directions */
    const uint8_t *lights_on;  /* [n] 1 = lights-on row, or NULL: every row lights-off */
};

struct esr_point_fields {
    int train;                 /* 1: keep the MLP contexts for backward */
    enum esr_head head;
    size_t cap;                /* rows the buffers hold */
    /* outputs of the last forward, caller row order */
    float *tone3;              /* [cap * 3] tone-mapped / LDR colour in [0,1] */
    float *lin3;               /* [cap * 3] linear HDR radiance (radiance head; else NULL) */
    /* internal: batch order = lights-off rows first */
    size_t n, n_off;
    uint32_t *order;           /* batch row j holds caller row order[j] */
    float *pos3, *dir3;        /* gathered in batch order */
    float *x_a, *x_b, *dx_a, *dx_b; /* MLP input rows: branch a (colour / off), b (emo) */
    float *y_a3, *y_b3, *sum3, *tone_in, *out3;
    float *d_y_a3, *d_y_b3, *d_sum3, *d_tone_in, *d_out3;
    float *geo, *d_geo;        /* geometry feature rows */
    float *fa, *fb, *d_fa, *d_fb; /* feature-grid rows of branches a and b */
    int ch_a, ch_b, n_in_a, n_in_b, n_tone_in, geo_dim;
    struct esr_mlp_ctx ctx_a, ctx_b, ctx_tone;
};

/* Workspace for model m's stage, growing on demand (train = 1 keeps backward state). */
int esr_point_fields_init(struct esr_point_fields *pf, const struct esr_model *m, size_t cap,
                          int train);
void esr_point_fields_free(struct esr_point_fields *pf);

/* Evaluates the stage's head on q's rows; `sdf` is the SDF the geometry feature reads (the view
 * the renderer sees). Fills pf->tone3 (and pf->lin3 for the radiance head). */
int esr_point_fields_fwd(struct esr_point_fields *pf, const struct esr_model *m, const float *sdf,
                         const struct esr_point_query *q);
/* The emo branch's part of the last forward's linear radiance, caller row order: L_on - L_off
 * for lights-on rows, 0 for lights-off rows (radiance head only). */
void esr_point_fields_emo(const struct esr_point_fields *pf, float *emo3);
/* Backward of the last forward from d loss/d tone3 and d loss/d lin3 (caller row order; lin may
 * be NULL): ADDS parameter gradients into grads (the flat gradient base) and the geometry
 * feature's SDF gradient into g_sdf. Overwrites pf's internal buffers. */
int esr_point_fields_bwd(struct esr_point_fields *pf, const struct esr_model *m, float *g_sdf,
                         float *grads, const float *d_tone3, const float *d_lin3);

#ifdef __cplusplus
}
#endif
#endif
