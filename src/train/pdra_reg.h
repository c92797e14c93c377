/* The pdra stage's regularisers (METHOD.md "Loss terms"), on the batch's kept samples x:
 *   emission smoothness  w_es mean |E(x) - E(x + N(0, s_es^2))|      (per channel, L1; on a
 *                        quarter of the kept samples, a different quarter each step)
 *   normal smoothness    w_ns mean |grad f(x) - grad f(x + N(0, s_ns^2))|  (per axis, L1; f the
 *                        SDF, the raw trilinear gradient)
 *   entropy              w_ent mean_r H(T_r), H(T) = -T ln T - (1 - T) ln(1 - T), T_r the ray's
 *                        final transmittance (pushes every ray to fully hit or fully miss)
 * The offsets are in voxels of the SDF grid: the authors' N(0, 1e-3) and N(0, 0.01) on their
 * [-1, 1] box of 160 voxels are 0.08 and 0.8 voxels. Each term's gradient is exact (the jitter
 * is a constant of the step, drawn from its seed). */
#ifndef ESR_TRAIN_PDRA_REG_H
#define ESR_TRAIN_PDRA_REG_H

#include <stddef.h>
#include <stdint.h>

#include "model/material_fields.h"
#include "model/model.h"
#include "volume/march.h"

#ifdef __cplusplus
extern "C" {
#endif

#define ESR_PDRA_ES_SIGMA_VOX 0.08f
#define ESR_PDRA_NS_SIGMA_VOX 0.8f

struct esr_pdra_reg {
    struct esr_material_fields mf; /* E at the jittered points */
    size_t cap;
    float *jit3, *d_jit3, *g0, *g1, *d_g;  /* [cap * 3] */
    double es_loss, ns_loss, ent_loss;     /* the last step's */
};

int esr_pdra_reg_init(struct esr_pdra_reg *r, const struct esr_model *m, size_t cap);
void esr_pdra_reg_free(struct esr_pdra_reg *r);

/* The batch the smoothness terms are taken on. */
struct esr_pdra_reg_batch {
    const struct esr_march *mc; /* the primary batch's last forward: the terms' points are its
                                   kept rows */
    const float *emit3;         /* [mc->n_kept * 3] E at the kept rows (the caller's forward) */
    float *d_emit3;             /* [mc->n_kept * 3] the kept rows' E gradient, ADDED into */
    uint64_t seed;              /* the step's jitter and emission-smoothness rows */
};

/* Emission smoothness at b's kept rows: its gradient is ADDED into b->d_emit3 and the jittered
 * points' into grads / g_sdf. Normal smoothness: ADDED into g_sdf. Either term is skipped at
 * weight 0. */
int esr_pdra_reg_smooth(struct esr_pdra_reg *r, const struct esr_model *m, const float *sdf,
                        float *g_sdf, float *grads, const struct esr_pdra_reg_batch *b);

/* Entropy of the final transmittances t_last[n]: returns the loss (w_ent mean H) and writes
 * d_t_last[n] (its gradient). */
double esr_pdra_reg_entropy(float w_ent, const float *t_last, int n, float *d_t_last);

#ifdef __cplusplus
}
#endif
#endif
