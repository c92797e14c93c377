/* Emission and BRDF heads at arbitrary points (see material_fields.h). */
#include "model/material_fields.h"

#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/profile.h"
#include "fields/geo_feature.h"
#include "fields/grid.h"
#include "model/rows.h"

void esr_material_fields_free(struct esr_material_fields *mf)
{
    float *bufs[] = {mf->emit3, mf->brdf5, mf->x_e, mf->x_b, mf->dx_e, mf->dx_b, mf->fe,
                     mf->fb,    mf->d_fe,  mf->d_fb, mf->geo, mf->d_geo, mf->brdf5_field,
                     mf->d_brdf5_field};
    for (size_t i = 0; i < sizeof bufs / sizeof bufs[0]; i++)
        free(bufs[i]);
    esr_mlp_ctx_free(&mf->ctx_e);
    esr_mlp_ctx_free(&mf->ctx_b);
    int train = mf->train, emission_only = mf->emission_only;
    memset(mf, 0, sizeof(*mf));
    mf->train = train;
    mf->emission_only = emission_only;
}

static int grow(struct esr_material_fields *mf, const struct esr_model *m, size_t cap)
{
    const int train = mf->train, ch = mf->ch, n_in = mf->n_in, gd = mf->geo_dim;
    const size_t nb = mf->emission_only ? 0 : 1; /* BRDF rows per row */
    esr_material_fields_free(mf);
    mf->train = train;
    mf->ch = ch;
    mf->n_in = n_in;
    mf->geo_dim = gd;
    struct {
        float **p;
        size_t per_row;
    } all[] = {{&mf->emit3, 3},          {&mf->brdf5, nb * ESR_BRDF_CHANNELS},
               {&mf->x_e, n_in},         {&mf->x_b, nb * n_in},
               {&mf->dx_e, train * n_in}, {&mf->dx_b, nb * train * n_in},
               {&mf->fe, ch},            {&mf->fb, nb * ch},
               {&mf->d_fe, train * ch},  {&mf->d_fb, nb * train * ch},
               {&mf->geo, gd},           {&mf->d_geo, train * gd},
               {&mf->brdf5_field, nb * ESR_BRDF_CHANNELS},
               {&mf->d_brdf5_field, nb * train * ESR_BRDF_CHANNELS}};
    int ok = 1;
    for (size_t i = 0; i < sizeof all / sizeof all[0]; i++)
        if (all[i].per_row)
            ok &= (*all[i].p = malloc(cap * all[i].per_row * sizeof(float))) != NULL;
    int rc = ok ? ESR_OK : ESR_FAIL("material fields: out of memory for %zu rows", cap);
    const enum esr_mlp_engine engine = (enum esr_mlp_engine)m->cfg.mlp_engine;
    if (rc == ESR_OK && train)
        rc = esr_mlp_ctx_init(&mf->ctx_e, esr_model_mlp(m, ESR_COMP_EMIT_MLP), cap, engine);
    if (rc == ESR_OK && train && nb)
        rc = esr_mlp_ctx_init(&mf->ctx_b, esr_model_mlp(m, ESR_COMP_BRDF_MLP), cap, engine);
    if (rc != ESR_OK) {
        esr_material_fields_free(mf);
        return rc;
    }
    mf->cap = cap;
    return ESR_OK;
}

int esr_material_fields_init(struct esr_material_fields *mf, const struct esr_model *m, size_t cap,
                             int flags)
{
    memset(mf, 0, sizeof(*mf));
    if (!esr_model_has(m, ESR_COMP_EMIT_MLP) || !esr_model_has(m, ESR_COMP_BRDF_MLP))
        return ESR_FAIL("material fields: the %s stage has no emission/BRDF fields",
                        esr_stage_name((enum esr_stage)m->stage));
    mf->train = (flags & ESR_MATERIAL_TRAIN) != 0;
    mf->emission_only = (flags & ESR_MATERIAL_EMISSION_ONLY) != 0;
    mf->ch = esr_model_grid(m, ESR_COMP_EMO_FEAT)->channels;
    mf->n_in = esr_model_mlp(m, ESR_COMP_EMIT_MLP)->desc.n_in;
    mf->geo_dim = esr_geo_feature_dim(&m->geo);
    return grow(mf, m, cap > 0 ? cap : 1);
}

/* out = in (n BRDF rows) with the base colour channels times b: the lights' colour balance on
 * the field's output, and its gradient back to it. */
static void scale_base_colour(const float *in, float *out, size_t n, const float b[3])
{
    for (size_t k = 0; k < n; k++)
        for (int c = 0; c < ESR_BRDF_CHANNELS; c++)
            out[k * ESR_BRDF_CHANNELS + (size_t)c] =
                in[k * ESR_BRDF_CHANNELS + (size_t)c] * (c < 3 ? b[c] : 1.0f);
}

static int mlp_run(const struct esr_material_fields *mf, const struct esr_mlp *mlp, const float *w,
                   struct esr_mlp_ctx *ctx, const float *in, float *out, size_t n)
{
    if (mf->train)
        return esr_mlp_fwd(mlp, w, ctx, in, out, n);
    esr_mlp_infer(mlp, w, in, out, n);
    return ESR_OK;
}

static int material_fields_fwd_run(struct esr_material_fields *mf, const struct esr_model *m,
                                   const float *sdf, const float *pos3, size_t n);

int esr_material_fields_fwd(struct esr_material_fields *mf, const struct esr_model *m,
                            const float *sdf, const float *pos3, size_t n)
{
    esr_prof_enter(ESR_PROF_FIELDS);
    const int rc = material_fields_fwd_run(mf, m, sdf, pos3, n);
    esr_prof_exit(ESR_PROF_FIELDS);
    return rc;
}

static int material_fields_fwd_run(struct esr_material_fields *mf, const struct esr_model *m,
                                   const float *sdf, const float *pos3, size_t n)
{
    if (n > mf->cap)
        ESR_TRY(grow(mf, m, n + n / 4));
    mf->n = n;
    mf->pos3 = pos3;
    if (n == 0)
        return ESR_OK;
    const size_t ni = (size_t)mf->n_in;
    const int C = mf->ch, pp = esr_pe_out_dims(&m->pe_pos);
    esr_grid_sample_fwd(esr_model_grid(m, ESR_COMP_EMO_FEAT), esr_model_values(m, ESR_COMP_EMO_FEAT),
                        pos3, n, mf->fe);
    ESR_TRY(esr_geo_feature_fwd(esr_model_grid(m, ESR_COMP_SDF), sdf, &m->geo, pos3, n, mf->geo));
    esr_rows_copy_cols(mf->fe, (size_t)C, mf->x_e, ni, n, C);
    esr_rows_pe(&m->pe_pos, pos3, n, mf->x_e + C, ni);
    esr_rows_copy_cols(mf->geo, (size_t)mf->geo_dim, mf->x_e + C + pp, ni, n, mf->geo_dim);
    const float *w = m->params.w;
    if (m->cfg.emission)
        ESR_TRY(mlp_run(mf, esr_model_mlp(m, ESR_COMP_EMIT_MLP), w, &mf->ctx_e, mf->x_e, mf->emit3, n));
    else /* a scene without lights-on images emits nothing (option emission; no backward) */
        memset(mf->emit3, 0, n * 3 * sizeof(float));
    if (mf->emission_only)
        return ESR_OK;
    /* the BRDF rows: own features, the same PE and geometry columns */
    esr_grid_sample_fwd(esr_model_grid(m, ESR_COMP_BRDF_FEAT),
                        esr_model_values(m, ESR_COMP_BRDF_FEAT), pos3, n, mf->fb);
    esr_rows_copy_cols(mf->fb, (size_t)C, mf->x_b, ni, n, C);
    esr_rows_copy_cols(mf->x_e + C, ni, mf->x_b + C, ni, n, (int)ni - C);
    if (!esr_lights_balanced(&m->lights))
        return mlp_run(mf, esr_model_mlp(m, ESR_COMP_BRDF_MLP), w, &mf->ctx_b, mf->x_b, mf->brdf5, n);
    /* the lights' colour balance (model/lights.h) on the field's output, which the MLP's backward
     * reads as it wrote it */
    ESR_TRY(mlp_run(mf, esr_model_mlp(m, ESR_COMP_BRDF_MLP), w, &mf->ctx_b, mf->x_b, mf->brdf5_field, n));
    float b[3];
    esr_lights_balance_of(&m->lights, b);
    scale_base_colour(mf->brdf5_field, mf->brdf5, n, b);
    return ESR_OK;
}

/* One branch of the material fields (E's or the BRDF's): its MLP, the feature grid it reads,
 * and the workspace its backward uses. */
struct branch {
    enum esr_component mlp, feat;
    struct esr_mlp_ctx *ctx; /* the MLP's forward context */
    float *dx;               /* [n * n_in] the MLP's input-row gradients */
    float *d_f;              /* [n * ch] the feature grid's samples' gradients */
};

/* One MLP's backward and its feature grid's: input-row gradients land in br->dx. */
static int branch_bwd(struct esr_material_fields *mf, const struct esr_model *m,
                      const struct branch *br, const float *d_out, float *grads)
{
    const enum esr_component mlp = br->mlp, feat = br->feat;
    float *dx = br->dx, *d_f = br->d_f;
    const size_t n = mf->n, ni = (size_t)mf->n_in;
    ESR_TRY(esr_mlp_bwd(esr_model_mlp(m, mlp), m->params.w, grads, br->ctx, d_out, dx,
                        ESR_NN_GRAD_OVERWRITE));
    esr_rows_copy_cols(dx, ni, d_f, (size_t)mf->ch, n, mf->ch);
    esr_grid_sample_bwd(esr_model_grid(m, feat), mf->pos3, n, d_f, grads + m->part[feat].off);
    return ESR_OK;
}

static int material_fields_bwd_run(struct esr_material_fields *mf, const struct esr_model *m,
                                   float *g_sdf, float *grads, const float *d_emit3,
                                   const float *d_brdf5);

int esr_material_fields_bwd(struct esr_material_fields *mf, const struct esr_model *m,
                            float *g_sdf, float *grads, const float *d_emit3,
                            const float *d_brdf5)
{
    esr_prof_enter(ESR_PROF_FIELDS);
    const int rc = material_fields_bwd_run(mf, m, g_sdf, grads, d_emit3, d_brdf5);
    esr_prof_exit(ESR_PROF_FIELDS);
    return rc;
}

static int material_fields_bwd_run(struct esr_material_fields *mf, const struct esr_model *m,
                                   float *g_sdf, float *grads, const float *d_emit3,
                                   const float *d_brdf5)
{
    const size_t n = mf->n, ni = (size_t)mf->n_in;
    const int gcol = mf->ch + esr_pe_out_dims(&m->pe_pos), gd = mf->geo_dim;
    if (!m->cfg.emission) /* E is the constant 0 */
        d_emit3 = NULL;
    if (n == 0 || (!d_emit3 && !d_brdf5))
        return ESR_OK;
    if (!mf->train)
        return ESR_FAIL("material fields: backward of an inference forward");
    if (d_brdf5 && mf->emission_only)
        return ESR_FAIL("material fields: BRDF gradient for an emission-only workspace");
    if (d_brdf5 && esr_lights_balanced(&m->lights)) { /* through base colour = b x the field's */
        float b[3];
        esr_lights_balance_of(&m->lights, b);
        scale_base_colour(d_brdf5, mf->d_brdf5_field, n, b);
        d_brdf5 = mf->d_brdf5_field;
    }
    const struct branch emit = {ESR_COMP_EMIT_MLP, ESR_COMP_EMO_FEAT, &mf->ctx_e, mf->dx_e, mf->d_fe};
    const struct branch brdf = {ESR_COMP_BRDF_MLP, ESR_COMP_BRDF_FEAT, &mf->ctx_b, mf->dx_b, mf->d_fb};
    if (d_emit3)
        ESR_TRY(branch_bwd(mf, m, &emit, d_emit3, grads));
    if (d_brdf5)
        ESR_TRY(branch_bwd(mf, m, &brdf, d_brdf5, grads));
#pragma omp parallel for schedule(static)
    for (size_t k = 0; k < n; k++)
        for (int j = 0; j < gd; j++)
            mf->d_geo[k * (size_t)gd + (size_t)j] =
                (d_emit3 ? mf->dx_e[k * ni + (size_t)(gcol + j)] : 0.0f) +
                (d_brdf5 ? mf->dx_b[k * ni + (size_t)(gcol + j)] : 0.0f);
    return esr_geo_feature_bwd(esr_model_grid(m, ESR_COMP_SDF), &m->geo, mf->pos3, n, mf->geo,
                               mf->d_geo, g_sdf);
}
