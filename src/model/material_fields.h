/* The inverse-rendering heads at arbitrary points (lts stage on): emission E(x) and the BRDF
 * parameters, forward and backward. Both MLPs read what the radiance MLPs read minus the view
 * direction (METHOD.md "Stages 4-5 in detail"):
 *   E(x):    [emo feature grid | PE(x) | geometry feature] -> softplus, linear HDR RGB; the emo
 *            grid is shared with the L_emo radiance MLP
 *   BRDF(x): [BRDF feature grid | PE(x) | geometry feature] -> sigmoid -> base colour (3, linear),
 *            roughness, metallic (core/brdf.h)
 * The LTS loss calls it on its surface points; rendering calls it on kept samples (emission
 * maps, material maps). A model whose lights carry a colour balance (model/lights.h) reports the
 * base colour times it (and its backward passes the gradient through that factor). */
#ifndef ESR_MODEL_MATERIAL_FIELDS_H
#define ESR_MODEL_MATERIAL_FIELDS_H

#include <stddef.h>

#include "core/brdf.h"
#include "model/model.h"
#include "nn/mlp.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Channels of a BRDF row: base colour r, g, b, roughness, metallic. */
#define ESR_BRDF_CHANNELS 5

/* The material of a BRDF row, each channel divided by `cover` (1 for a point's own row; the
 * opacity for a row composited along a ray). */
static inline struct esr_material esr_material_of_row(const float *row, float cover)
{
    struct esr_material mat;
    for (int c = 0; c < 3; c++)
        mat.base[c] = row[c] / cover;
    mat.roughness = row[3] / cover;
    mat.metallic = row[4] / cover;
    return mat;
}

struct esr_material_fields {
    int train;            /* 1: keep the MLP contexts for backward */
    int emission_only;    /* 1: E only (brdf5 not computed) */
    size_t cap, n;
    const float *pos3;    /* the last forward's points (the caller keeps them alive) */
    float *emit3;         /* [cap * 3] E(x), linear HDR */
    float *brdf5;         /* [cap * 5] base colour, roughness, metallic in (0, 1) */
    /* internal */
    float *x_e, *x_b, *dx_e, *dx_b, *fe, *fb, *d_fe, *d_fb, *geo, *d_geo;
    float *brdf5_field, *d_brdf5_field; /* [cap * 5] the field's output before the colour
                                           balance, and its gradient (balanced models only) */
    int ch, n_in, geo_dim;
    struct esr_mlp_ctx ctx_e, ctx_b;
};

/* flags: ESR_MATERIAL_EMISSION_ONLY skips the BRDF head (pdra's suppression, emission maps). */
#define ESR_MATERIAL_TRAIN 1
#define ESR_MATERIAL_EMISSION_ONLY 2
int esr_material_fields_init(struct esr_material_fields *mf, const struct esr_model *m, size_t cap,
                             int flags);
void esr_material_fields_free(struct esr_material_fields *mf);

/* E and BRDF at n points (pos3 [n*3] must stay alive until the backward); `sdf` is the SDF the
 * geometry feature reads. Fills mf->emit3 and mf->brdf5. */
int esr_material_fields_fwd(struct esr_material_fields *mf, const struct esr_model *m,
                            const float *sdf, const float *pos3, size_t n);
/* Backward of the last forward from d loss/d emit3 and d loss/d brdf5 (either may be NULL: no
 * gradient; d_brdf5 must be NULL when emission-only): ADDS parameter gradients into grads and the
 * geometry feature's into g_sdf. */
int esr_material_fields_bwd(struct esr_material_fields *mf, const struct esr_model *m,
                            float *g_sdf, float *grads, const float *d_emit3,
                            const float *d_brdf5);

#ifdef __cplusplus
}
#endif
#endif
