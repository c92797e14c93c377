/* Colour heads of the three stages (see trace_heads.h). */
#include "model/trace_heads.h"

#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "fields/geo_feature.h"
#include "fields/grid.h"
#include "nn/activation.h"
#include "nn/encoding.h"

void esr_trace_heads_dims(struct esr_trace *t, const struct esr_model *m)
{
    t->ch_a = t->ch_b = t->n_in_a = t->n_in_b = t->n_tone_in = t->geo_dim = 0;
    if (m->stage == ESR_STAGE_ALPHAMASK) {
        t->ch_a = m->feat.channels;
    } else if (m->stage == ESR_STAGE_COARSE) {
        t->ch_a = m->feat.channels;
        t->n_in_a = m->colour.desc.n_in;
    } else {
        t->ch_a = t->ch_b = m->feat_off_g.channels;
        t->n_in_a = t->n_in_b = m->rad_off.desc.n_in;
        t->n_tone_in = m->tone.desc.n_in;
        t->geo_dim = esr_geo_feature_dim(&m->geo);
    }
}

void esr_trace_heads_free(struct esr_trace *t)
{
    void **bufs[] = {(void **)&t->kidx, (void **)&t->kpos3,   (void **)&t->kdir3,
                     (void **)&t->x_a,  (void **)&t->x_b,     (void **)&t->dx_a,
                     (void **)&t->dx_b, (void **)&t->y_a3,    (void **)&t->y_b3,
                     (void **)&t->lin3, (void **)&t->tone_in, (void **)&t->tone3,
                     (void **)&t->d_y_a3, (void **)&t->d_y_b3, (void **)&t->d_lin3,
                     (void **)&t->d_tone_in, (void **)&t->d_tone3, (void **)&t->geo,
                     (void **)&t->d_geo, (void **)&t->fa, (void **)&t->fb,
                     (void **)&t->d_fa, (void **)&t->d_fb};
    for (size_t i = 0; i < sizeof bufs / sizeof bufs[0]; i++) {
        free(*bufs[i]);
        *bufs[i] = NULL;
    }
    esr_mlp_ctx_free(&t->ctx_a);
    esr_mlp_ctx_free(&t->ctx_b);
    esr_mlp_ctx_free(&t->ctx_tone);
    t->cap_kept = 0;
}

int esr_trace_heads_grow(struct esr_trace *t, const struct esr_model *m, size_t cap)
{
    esr_trace_heads_free(t);
    struct {
        void **p;
        size_t per_row; /* floats (or u32) per kept row; 0 = not needed */
    } bufs[] = {
        {(void **)&t->kidx, 1},           {(void **)&t->kpos3, 3},
        {(void **)&t->kdir3, 3},          {(void **)&t->x_a, (size_t)t->n_in_a},
        {(void **)&t->x_b, (size_t)t->n_in_b}, {(void **)&t->dx_a, (size_t)t->n_in_a},
        {(void **)&t->dx_b, (size_t)t->n_in_b}, {(void **)&t->y_a3, 3},
        {(void **)&t->y_b3, 3},           {(void **)&t->lin3, 3},
        {(void **)&t->tone_in, (size_t)t->n_tone_in}, {(void **)&t->tone3, 3},
        {(void **)&t->d_y_a3, 3},         {(void **)&t->d_y_b3, 3},
        {(void **)&t->d_lin3, 3},         {(void **)&t->d_tone_in, (size_t)t->n_tone_in},
        {(void **)&t->d_tone3, 3},        {(void **)&t->geo, (size_t)t->geo_dim},
        {(void **)&t->d_geo, (size_t)t->geo_dim}, {(void **)&t->fa, (size_t)t->ch_a},
        {(void **)&t->fb, (size_t)t->ch_b}, {(void **)&t->d_fa, (size_t)t->ch_a},
        {(void **)&t->d_fb, (size_t)t->ch_b},
    };
    int ok = 1;
    for (size_t i = 0; i < sizeof bufs / sizeof bufs[0]; i++)
        if (bufs[i].per_row)
            ok &= (*bufs[i].p = malloc(cap * bufs[i].per_row * sizeof(float))) != NULL;
    if (!ok) {
        esr_trace_heads_free(t);
        return ESR_FAIL("trace: out of memory for %zu kept samples", cap);
    }
    int rc = ESR_OK;
    const enum esr_mlp_engine engine = (enum esr_mlp_engine)m->cfg.mlp_engine;
    if (t->train && m->stage == ESR_STAGE_COARSE)
        rc = esr_mlp_ctx_init(&t->ctx_a, &m->colour, cap, engine);
    if (t->train && m->stage == ESR_STAGE_FINE) {
        rc = esr_mlp_ctx_init(&t->ctx_a, &m->rad_off, cap, engine);
        if (rc == ESR_OK)
            rc = esr_mlp_ctx_init(&t->ctx_b, &m->rad_emo, cap, engine);
        if (rc == ESR_OK)
            rc = esr_mlp_ctx_init(&t->ctx_tone, &m->tone, cap, engine);
    }
    if (rc != ESR_OK) {
        esr_trace_heads_free(t);
        return rc;
    }
    t->cap_kept = cap;
    return ESR_OK;
}

/* Training forward (keeps the context) or inference, on n rows. */
static int mlp_run(const struct esr_trace *t, const struct esr_mlp *mlp, const float *w,
                   struct esr_mlp_ctx *ctx, const float *in, float *out, size_t n)
{
    if (n == 0)
        return ESR_OK;
    if (t->train)
        return esr_mlp_fwd(mlp, w, ctx, in, out, n);
    esr_mlp_infer(mlp, w, in, out, n);
    return ESR_OK;
}

static int mlp_back(const struct esr_mlp *mlp, const float *w, float *grads, struct esr_mlp_ctx *ctx,
                    const float *d_out, float *d_in, size_t n)
{
    if (n == 0)
        return ESR_OK;
    return esr_mlp_bwd(mlp, w, grads, ctx, d_out, d_in, ESR_NN_GRAD_OVERWRITE);
}

/* dst[k*3+c] = src[kidx[k]*3+c] (gather) or the reverse (scatter). */
static void gather3(const struct esr_trace *t, const float *per_sample, float *rows)
{
    const size_t nk = t->n_kept;
#pragma omp parallel for schedule(static)
    for (size_t k = 0; k < nk; k++)
        for (int c = 0; c < 3; c++)
            rows[k * 3 + c] = per_sample[(size_t)t->kidx[k] * 3 + c];
}

static void scatter3(const struct esr_trace *t, const float *rows, float *per_sample)
{
    const size_t nk = t->n_kept;
#pragma omp parallel for schedule(static)
    for (size_t k = 0; k < nk; k++)
        for (int c = 0; c < 3; c++)
            per_sample[(size_t)t->kidx[k] * 3 + c] = rows[k * 3 + c];
}

/* Copies `cols` columns between row-major arrays of different strides. */
static void copy_cols(const float *src, size_t src_stride, float *dst, size_t dst_stride, size_t n,
                      int cols)
{
#pragma omp parallel for schedule(static)
    for (size_t k = 0; k < n; k++)
        memcpy(dst + k * dst_stride, src + k * src_stride, (size_t)cols * sizeof(float));
}

static void pe_into(const struct esr_pe *pe, const float *in, size_t n, float *out, size_t stride)
{
    struct esr_pe_rows rows;
    rows.n = n;
    rows.in_stride = 3;
    rows.out_stride = stride;
    esr_pe_fwd(pe, &rows, in, out);
}

/* ---- alphamask: sigmoid colour grid ---- */

static int alphamask_fwd(struct esr_trace *t, const struct esr_model *m)
{
    const size_t nk = t->n_kept, nk_off = t->n_kept_off;
    esr_grid_sample_fwd(&m->feat, m->params.w + m->feat_off, t->kpos3, nk, t->fa);
#pragma omp parallel for schedule(static)
    for (size_t k = 0; k < nk; k++)
        for (int c = 0; c < 3; c++)
            t->y_a3[k * 3 + c] = esr_nn_sigmoid_fwd(t->fa[k * 6 + (k >= nk_off ? 3 : 0) + c]);
    scatter3(t, t->y_a3, t->val_tone3);
    return ESR_OK;
}

static int alphamask_bwd(struct esr_trace *t, const struct esr_model *m, float *grads)
{
    const size_t nk = t->n_kept, nk_off = t->n_kept_off;
    gather3(t, t->d_val_tone3, t->d_y_a3);
#pragma omp parallel for schedule(static)
    for (size_t k = 0; k < nk; k++) {
        int half = k >= nk_off ? 3 : 0;
        for (int c = 0; c < 6; c++)
            t->d_fa[k * 6 + c] = 0.0f;
        for (int c = 0; c < 3; c++)
            t->d_fa[k * 6 + half + c] = esr_nn_sigmoid_bwd(t->y_a3[k * 3 + c], t->d_y_a3[k * 3 + c]);
    }
    esr_grid_sample_bwd(&m->feat, t->kpos3, nk, t->d_fa, grads + m->feat_off);
    return ESR_OK;
}

/* ---- coarse: colour MLP ---- */

static int coarse_fwd(struct esr_trace *t, const struct esr_model *m)
{
    const size_t nk = t->n_kept, nk_off = t->n_kept_off, ni = (size_t)t->n_in_a;
    const int C = t->ch_a;
    esr_grid_sample_fwd(&m->feat, m->params.w + m->feat_off, t->kpos3, nk, t->fa);
    copy_cols(t->fa, (size_t)C, t->x_a, ni, nk, C);
    pe_into(&m->pe_dir, t->kdir3, nk, t->x_a + C, ni);
#pragma omp parallel for schedule(static)
    for (size_t k = 0; k < nk; k++)
        t->x_a[k * ni + ni - 1] = k >= nk_off ? 1.0f : 0.0f;
    ESR_TRY(mlp_run(t, &m->colour, m->params.w, &t->ctx_a, t->x_a, t->y_a3, nk));
    scatter3(t, t->y_a3, t->val_tone3);
    return ESR_OK;
}

static int coarse_bwd(struct esr_trace *t, const struct esr_model *m, float *grads)
{
    const size_t nk = t->n_kept;
    const int C = t->ch_a;
    gather3(t, t->d_val_tone3, t->d_y_a3);
    ESR_TRY(mlp_back(&m->colour, m->params.w, grads, &t->ctx_a, t->d_y_a3, t->dx_a, nk));
    copy_cols(t->dx_a, (size_t)t->n_in_a, t->d_fa, (size_t)C, nk, C);
    esr_grid_sample_bwd(&m->feat, t->kpos3, nk, t->d_fa, grads + m->feat_off);
    return ESR_OK;
}

/* ---- fine: off / emo radiance MLPs + tone-mapper ---- */

static int fine_fwd(struct esr_trace *t, const struct esr_model *m, const float *sdf)
{
    const size_t nk = t->n_kept, nk_off = t->n_kept_off, n_on = nk - nk_off, ni = (size_t)t->n_in_a;
    const int C = t->ch_a, pp = esr_pe_out_dims(&m->pe_pos);
    const float *w = m->params.w;
    esr_grid_sample_fwd(&m->feat_off_g, w + m->feat_off_off, t->kpos3, nk, t->fa);
    esr_grid_sample_fwd(&m->feat_emo_g, w + m->feat_emo_off, t->kpos3 + nk_off * 3, n_on, t->fb);
    ESR_TRY(esr_geo_feature_fwd(&m->sdf, sdf, &m->geo, t->kpos3, nk, t->geo));
    copy_cols(t->fa, (size_t)C, t->x_a, ni, nk, C);
    pe_into(&m->pe_pos, t->kpos3, nk, t->x_a + C, ni);
    copy_cols(t->geo, (size_t)t->geo_dim, t->x_a + C + pp, ni, nk, t->geo_dim);
    pe_into(&m->pe_dir, t->kdir3, nk, t->x_a + C + pp + t->geo_dim, ni);
    /* emo rows: own features, the shared columns of the same samples */
    copy_cols(t->fb, (size_t)C, t->x_b, ni, n_on, C);
    copy_cols(t->x_a + nk_off * ni + C, ni, t->x_b + C, ni, n_on, (int)ni - C);
    ESR_TRY(mlp_run(t, &m->rad_off, w, &t->ctx_a, t->x_a, t->y_a3, nk_off));
    /* stop-gradient: the off branch of on-rays needs no backward state */
    esr_mlp_infer(&m->rad_off, w, t->x_a + nk_off * ni, t->y_a3 + nk_off * 3, n_on);
    ESR_TRY(mlp_run(t, &m->rad_emo, w, &t->ctx_b, t->x_b, t->y_b3, n_on));
#pragma omp parallel for schedule(static)
    for (size_t k = 0; k < nk; k++)
        for (int c = 0; c < 3; c++)
            t->lin3[k * 3 + c] = t->y_a3[k * 3 + c] + (k >= nk_off ? t->y_b3[(k - nk_off) * 3 + c] : 0.0f);
    pe_into(&m->pe_tone, t->lin3, nk, t->tone_in, (size_t)t->n_tone_in);
    ESR_TRY(mlp_run(t, &m->tone, w, &t->ctx_tone, t->tone_in, t->tone3, nk));
    scatter3(t, t->tone3, t->val_tone3);
    scatter3(t, t->lin3, t->val_lin3);
    return ESR_OK;
}

static int fine_bwd(struct esr_trace *t, const struct esr_model *m, const float *sdf, float *g_sdf,
                    float *grads)
{
    const size_t nk = t->n_kept, nk_off = t->n_kept_off, n_on = nk - nk_off, ni = (size_t)t->n_in_a;
    const int C = t->ch_a, gcol = C + esr_pe_out_dims(&m->pe_pos), gd = t->geo_dim;
    const float *w = m->params.w;
    gather3(t, t->d_val_tone3, t->d_tone3);
    gather3(t, t->d_val_lin3, t->d_lin3);
    ESR_TRY(mlp_back(&m->tone, w, grads, &t->ctx_tone, t->d_tone3, t->d_tone_in, nk));
    struct esr_pe_rows rows;
    rows.n = nk;
    rows.in_stride = 3;
    rows.out_stride = (size_t)t->n_tone_in;
    esr_pe_bwd(&m->pe_tone, &rows, t->lin3, t->d_tone_in, t->d_lin3, ESR_NN_GRAD_ACCUMULATE);
    ESR_TRY(mlp_back(&m->rad_off, w, grads, &t->ctx_a, t->d_lin3, t->dx_a, nk_off));
    ESR_TRY(mlp_back(&m->rad_emo, w, grads, &t->ctx_b, t->d_lin3 + nk_off * 3, t->dx_b, n_on));
    copy_cols(t->dx_a, ni, t->d_fa, (size_t)C, nk_off, C);
    esr_grid_sample_bwd(&m->feat_off_g, t->kpos3, nk_off, t->d_fa, grads + m->feat_off_off);
    copy_cols(t->dx_b, ni, t->d_fb, (size_t)C, n_on, C);
    esr_grid_sample_bwd(&m->feat_emo_g, t->kpos3 + nk_off * 3, n_on, t->d_fb,
                        grads + m->feat_emo_off);
    /* geometry feature rows: off rows from the off branch, on rows from the emo branch */
    copy_cols(t->dx_a + gcol, ni, t->d_geo, (size_t)gd, nk_off, gd);
    copy_cols(t->dx_b + gcol, ni, t->d_geo + nk_off * (size_t)gd, (size_t)gd, n_on, gd);
    return esr_geo_feature_bwd(&m->sdf, sdf, &m->geo, t->kpos3, nk, t->d_geo, g_sdf);
}

int esr_trace_heads_fwd(struct esr_trace *t, const struct esr_model *m, const float *sdf)
{
    if (m->stage == ESR_STAGE_ALPHAMASK)
        return alphamask_fwd(t, m);
    if (m->stage == ESR_STAGE_COARSE)
        return coarse_fwd(t, m);
    return fine_fwd(t, m, sdf);
}

int esr_trace_heads_bwd(struct esr_trace *t, const struct esr_model *m, const float *sdf,
                        float *g_sdf, float *grads)
{
    if (m->stage == ESR_STAGE_ALPHAMASK)
        return alphamask_bwd(t, m, grads);
    if (m->stage == ESR_STAGE_COARSE)
        return coarse_bwd(t, m, grads);
    return fine_bwd(t, m, sdf, g_sdf, grads);
}
