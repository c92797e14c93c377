/* Trace layer 2: the stage's head at arbitrary points (see point_fields.h). */
#include "model/point_fields.h"

#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/profile.h"
#include "fields/geo_feature.h"
#include "fields/grid.h"
#include "nn/activation.h"
#include "model/rows.h"
#include "nn/encoding.h"

/* Row widths of the stage's head. */
static void set_dims(struct esr_point_fields *pf, const struct esr_model *m)
{
    pf->ch_a = pf->ch_b = pf->n_in_a = pf->n_in_b = pf->n_tone_in = pf->geo_dim = 0;
    switch (pf->head) {
    case ESR_HEAD_RGB_GRID:
        pf->ch_a = esr_model_grid(m, ESR_COMP_RGB_GRID)->channels;
        break;
    case ESR_HEAD_COLOUR_MLP:
        pf->ch_a = esr_model_grid(m, ESR_COMP_COLOUR_FEAT)->channels;
        pf->n_in_a = esr_model_mlp(m, ESR_COMP_COLOUR_MLP)->desc.n_in;
        break;
    case ESR_HEAD_RADIANCE:
        pf->ch_a = pf->ch_b = esr_model_grid(m, ESR_COMP_OFF_FEAT)->channels;
        pf->n_in_a = pf->n_in_b = esr_model_mlp(m, ESR_COMP_OFF_MLP)->desc.n_in;
        pf->n_tone_in = esr_model_mlp(m, ESR_COMP_TONE_MLP)->desc.n_in;
        pf->geo_dim = esr_geo_feature_dim(&m->geo);
        break;
    }
}

struct buf {
    void **p;
    size_t per_row; /* floats (or 32-bit ints) per row; 0 = not needed by this head */
};

/* The buffer table of a workspace (one place for allocation and freeing). */
static size_t buffers(struct esr_point_fields *pf, struct buf *b)
{
    const size_t na = (size_t)pf->n_in_a, nb = (size_t)pf->n_in_b, nt = (size_t)pf->n_tone_in;
    const size_t g = (size_t)pf->geo_dim, ca = (size_t)pf->ch_a, cb = (size_t)pf->ch_b;
    const size_t lin = pf->head == ESR_HEAD_RADIANCE ? 3 : 0;
    struct buf all[] = {
        {(void **)&pf->tone3, 3},    {(void **)&pf->lin3, lin},     {(void **)&pf->order, 1},
        {(void **)&pf->pos3, 3},     {(void **)&pf->dir3, 3},       {(void **)&pf->x_a, na},
        {(void **)&pf->x_b, nb},     {(void **)&pf->dx_a, na},      {(void **)&pf->dx_b, nb},
        {(void **)&pf->y_a3, 3},     {(void **)&pf->y_b3, lin},     {(void **)&pf->sum3, lin},
        {(void **)&pf->tone_in, nt}, {(void **)&pf->out3, 3},       {(void **)&pf->d_y_a3, 3},
        {(void **)&pf->d_y_b3, lin}, {(void **)&pf->d_sum3, lin},   {(void **)&pf->d_tone_in, nt},
        {(void **)&pf->d_out3, 3},   {(void **)&pf->geo, g},        {(void **)&pf->d_geo, g},
        {(void **)&pf->fa, ca},      {(void **)&pf->fb, cb},        {(void **)&pf->d_fa, ca},
        {(void **)&pf->d_fb, cb},
    };
    const size_t n = sizeof all / sizeof all[0];
    if (b)
        memcpy(b, all, sizeof all);
    return n;
}

#define MAX_BUFS 32

static void free_rows(struct esr_point_fields *pf)
{
    struct buf b[MAX_BUFS];
    size_t nb = buffers(pf, b);
    for (size_t i = 0; i < nb; i++) {
        free(*b[i].p);
        *b[i].p = NULL;
    }
    esr_mlp_ctx_free(&pf->ctx_a);
    esr_mlp_ctx_free(&pf->ctx_b);
    esr_mlp_ctx_free(&pf->ctx_tone);
    pf->cap = 0;
}

/* (Re)allocates every row buffer (and the MLP workspaces when training) for cap rows. */
static int grow(struct esr_point_fields *pf, const struct esr_model *m, size_t cap)
{
    free_rows(pf);
    struct buf b[MAX_BUFS];
    size_t nb = buffers(pf, b);
    int ok = 1;
    for (size_t i = 0; i < nb; i++)
        if (b[i].per_row)
            ok &= (*b[i].p = malloc(cap * b[i].per_row * sizeof(float))) != NULL;
    int rc = ok ? ESR_OK : ESR_FAIL("point fields: out of memory for %zu rows", cap);
    const enum esr_mlp_engine engine = (enum esr_mlp_engine)m->cfg.mlp_engine;
    if (rc == ESR_OK && pf->train && pf->head == ESR_HEAD_COLOUR_MLP)
        rc = esr_mlp_ctx_init(&pf->ctx_a, esr_model_mlp(m, ESR_COMP_COLOUR_MLP), cap, engine);
    if (rc == ESR_OK && pf->train && pf->head == ESR_HEAD_RADIANCE) {
        rc = esr_mlp_ctx_init(&pf->ctx_a, esr_model_mlp(m, ESR_COMP_OFF_MLP), cap, engine);
        if (rc == ESR_OK)
            rc = esr_mlp_ctx_init(&pf->ctx_b, esr_model_mlp(m, ESR_COMP_EMO_MLP), cap, engine);
        if (rc == ESR_OK)
            rc = esr_mlp_ctx_init(&pf->ctx_tone, esr_model_mlp(m, ESR_COMP_TONE_MLP), cap, engine);
    }
    if (rc != ESR_OK) {
        free_rows(pf);
        return rc;
    }
    pf->cap = cap;
    return ESR_OK;
}

int esr_point_fields_init(struct esr_point_fields *pf, const struct esr_model *m, size_t cap,
                          int train)
{
    memset(pf, 0, sizeof(*pf));
    pf->train = train;
    pf->head = esr_stage_info((enum esr_stage)m->stage)->head;
    set_dims(pf, m);
    return grow(pf, m, cap > 0 ? cap : 1);
}

void esr_point_fields_free(struct esr_point_fields *pf)
{
    free_rows(pf);
    memset(pf, 0, sizeof(*pf));
}

/* ---- shared row helpers ---- */

/* Training forward (keeps the context) or inference, on n rows. */
static int mlp_run(const struct esr_point_fields *pf, const struct esr_mlp *mlp, const float *w,
                   struct esr_mlp_ctx *ctx, const float *in, float *out, size_t n)
{
    if (n == 0)
        return ESR_OK;
    if (pf->train)
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

/* Batch order: a stable partition of the caller's rows, lights-off first; positions and
 * directions gathered into it. */
static void partition(struct esr_point_fields *pf, const struct esr_point_query *q)
{
    size_t k = 0;
    for (int pass = 0; pass < 2; pass++) {
        for (size_t i = 0; i < q->n; i++)
            if ((q->lights_on && q->lights_on[i]) == pass)
                pf->order[k++] = (uint32_t)i;
        if (pass == 0)
            pf->n_off = k;
    }
    pf->n = q->n;
#pragma omp parallel for schedule(static)
    for (size_t j = 0; j < q->n; j++) {
        size_t i = pf->order[j];
        for (int a = 0; a < 3; a++) {
            pf->pos3[j * 3 + a] = q->pos3[i * 3 + a];
            pf->dir3[j * 3 + a] = q->dir3[i * 3 + a];
        }
    }
}

/* rows3 (batch order) -> out3 (caller order), and the reverse for gradients. */
static void to_caller(const struct esr_point_fields *pf, const float *rows3, float *out3)
{
#pragma omp parallel for schedule(static)
    for (size_t j = 0; j < pf->n; j++)
        for (int c = 0; c < 3; c++)
            out3[(size_t)pf->order[j] * 3 + c] = rows3[j * 3 + c];
}

static void from_caller(const struct esr_point_fields *pf, const float *in3, float *rows3)
{
#pragma omp parallel for schedule(static)
    for (size_t j = 0; j < pf->n; j++)
        for (int c = 0; c < 3; c++)
            rows3[j * 3 + c] = in3[(size_t)pf->order[j] * 3 + c];
}

/* ---- ESR_HEAD_RGB_GRID ---- */

static int rgb_grid_fwd(struct esr_point_fields *pf, const struct esr_model *m)
{
    const size_t n = pf->n, n_off = pf->n_off;
    esr_grid_sample_fwd(esr_model_grid(m, ESR_COMP_RGB_GRID), esr_model_values(m, ESR_COMP_RGB_GRID),
                        pf->pos3, n, pf->fa);
#pragma omp parallel for schedule(static)
    for (size_t k = 0; k < n; k++)
        for (int c = 0; c < 3; c++)
            pf->out3[k * 3 + c] = esr_nn_sigmoid_fwd(pf->fa[k * 6 + (k >= n_off ? 3 : 0) + c]);
    return ESR_OK;
}

static int rgb_grid_bwd(struct esr_point_fields *pf, const struct esr_model *m, float *grads)
{
    const size_t n = pf->n, n_off = pf->n_off;
#pragma omp parallel for schedule(static)
    for (size_t k = 0; k < n; k++) {
        int half = k >= n_off ? 3 : 0;
        for (int c = 0; c < 6; c++)
            pf->d_fa[k * 6 + c] = 0.0f;
        for (int c = 0; c < 3; c++)
            pf->d_fa[k * 6 + half + c] = esr_nn_sigmoid_bwd(pf->out3[k * 3 + c], pf->d_out3[k * 3 + c]);
    }
    esr_grid_sample_bwd(esr_model_grid(m, ESR_COMP_RGB_GRID), pf->pos3, n, pf->d_fa,
                        grads + m->part[ESR_COMP_RGB_GRID].off);
    return ESR_OK;
}

/* ---- ESR_HEAD_COLOUR_MLP ---- */

static int colour_mlp_fwd(struct esr_point_fields *pf, const struct esr_model *m)
{
    const size_t n = pf->n, n_off = pf->n_off, ni = (size_t)pf->n_in_a;
    const int C = pf->ch_a;
    esr_grid_sample_fwd(esr_model_grid(m, ESR_COMP_COLOUR_FEAT),
                        esr_model_values(m, ESR_COMP_COLOUR_FEAT), pf->pos3, n, pf->fa);
    esr_rows_copy_cols(pf->fa, (size_t)C, pf->x_a, ni, n, C);
    esr_rows_pe(&m->pe_dir, pf->dir3, n, pf->x_a + C, ni);
#pragma omp parallel for schedule(static)
    for (size_t k = 0; k < n; k++)
        pf->x_a[k * ni + ni - 1] = k >= n_off ? 1.0f : 0.0f;
    return mlp_run(pf, esr_model_mlp(m, ESR_COMP_COLOUR_MLP), m->params.w, &pf->ctx_a, pf->x_a,
                   pf->out3, n);
}

static int colour_mlp_bwd(struct esr_point_fields *pf, const struct esr_model *m, float *grads)
{
    const size_t n = pf->n;
    const int C = pf->ch_a;
    ESR_TRY(mlp_back(esr_model_mlp(m, ESR_COMP_COLOUR_MLP), m->params.w, grads, &pf->ctx_a,
                     pf->d_out3, pf->dx_a, n));
    esr_rows_copy_cols(pf->dx_a, (size_t)pf->n_in_a, pf->d_fa, (size_t)C, n, C);
    esr_grid_sample_bwd(esr_model_grid(m, ESR_COMP_COLOUR_FEAT), pf->pos3, n, pf->d_fa,
                        grads + m->part[ESR_COMP_COLOUR_FEAT].off);
    return ESR_OK;
}

/* ---- ESR_HEAD_RADIANCE ---- */

static int radiance_fwd(struct esr_point_fields *pf, const struct esr_model *m, const float *sdf)
{
    const size_t n = pf->n, n_off = pf->n_off, n_on = n - n_off, ni = (size_t)pf->n_in_a;
    const int C = pf->ch_a, pp = esr_pe_out_dims(&m->pe_pos);
    const float *w = m->params.w;
    esr_grid_sample_fwd(esr_model_grid(m, ESR_COMP_OFF_FEAT), esr_model_values(m, ESR_COMP_OFF_FEAT),
                        pf->pos3, n, pf->fa);
    esr_grid_sample_fwd(esr_model_grid(m, ESR_COMP_EMO_FEAT), esr_model_values(m, ESR_COMP_EMO_FEAT),
                        pf->pos3 + n_off * 3, n_on, pf->fb);
    ESR_TRY(esr_geo_feature_fwd(esr_model_grid(m, ESR_COMP_SDF), sdf, &m->geo, pf->pos3, n, pf->geo));
    esr_rows_copy_cols(pf->fa, (size_t)C, pf->x_a, ni, n, C);
    esr_rows_pe(&m->pe_pos, pf->pos3, n, pf->x_a + C, ni);
    esr_rows_copy_cols(pf->geo, (size_t)pf->geo_dim, pf->x_a + C + pp, ni, n, pf->geo_dim);
    esr_rows_pe(&m->pe_dir, pf->dir3, n, pf->x_a + C + pp + pf->geo_dim, ni);
    /* emo rows: own features, the shared columns of the same points */
    esr_rows_copy_cols(pf->fb, (size_t)C, pf->x_b, ni, n_on, C);
    esr_rows_copy_cols(pf->x_a + n_off * ni + C, ni, pf->x_b + C, ni, n_on, (int)ni - C);
    const struct esr_mlp *off = esr_model_mlp(m, ESR_COMP_OFF_MLP);
    ESR_TRY(mlp_run(pf, off, w, &pf->ctx_a, pf->x_a, pf->y_a3, n_off));
    /* stop-gradient: the off branch of lights-on rows needs no backward state */
    esr_mlp_infer(off, w, pf->x_a + n_off * ni, pf->y_a3 + n_off * 3, n_on);
    ESR_TRY(mlp_run(pf, esr_model_mlp(m, ESR_COMP_EMO_MLP), w, &pf->ctx_b, pf->x_b, pf->y_b3, n_on));
#pragma omp parallel for schedule(static)
    for (size_t k = 0; k < n; k++)
        for (int c = 0; c < 3; c++)
            pf->sum3[k * 3 + c] =
                pf->y_a3[k * 3 + c] + (k >= n_off ? pf->y_b3[(k - n_off) * 3 + c] : 0.0f);
    esr_rows_pe(&m->pe_tone, pf->sum3, n, pf->tone_in, (size_t)pf->n_tone_in);
    ESR_TRY(mlp_run(pf, esr_model_mlp(m, ESR_COMP_TONE_MLP), w, &pf->ctx_tone, pf->tone_in, pf->out3, n));
    to_caller(pf, pf->sum3, pf->lin3);
    return ESR_OK;
}

void esr_point_fields_emo(const struct esr_point_fields *pf, float *emo3)
{
#pragma omp parallel for schedule(static)
    for (size_t j = 0; j < pf->n; j++)
        for (int c = 0; c < 3; c++)
            emo3[(size_t)pf->order[j] * 3 + c] =
                j >= pf->n_off ? pf->y_b3[(j - pf->n_off) * 3 + c] : 0.0f;
}

static int radiance_bwd(struct esr_point_fields *pf, const struct esr_model *m, float *g_sdf,
                        float *grads)
{
    const size_t n = pf->n, n_off = pf->n_off, n_on = n - n_off, ni = (size_t)pf->n_in_a;
    const int C = pf->ch_a, gcol = C + esr_pe_out_dims(&m->pe_pos), gd = pf->geo_dim;
    const float *w = m->params.w;
    ESR_TRY(mlp_back(esr_model_mlp(m, ESR_COMP_TONE_MLP), w, grads, &pf->ctx_tone, pf->d_out3,
                     pf->d_tone_in, n));
    struct esr_pe_rows rows;
    rows.n = n;
    rows.in_stride = 3;
    rows.out_stride = (size_t)pf->n_tone_in;
    esr_pe_bwd(&m->pe_tone, &rows, pf->sum3, pf->d_tone_in, pf->d_sum3, ESR_NN_GRAD_ACCUMULATE);
    ESR_TRY(mlp_back(esr_model_mlp(m, ESR_COMP_OFF_MLP), w, grads, &pf->ctx_a, pf->d_sum3, pf->dx_a,
                     n_off));
    ESR_TRY(mlp_back(esr_model_mlp(m, ESR_COMP_EMO_MLP), w, grads, &pf->ctx_b, pf->d_sum3 + n_off * 3,
                     pf->dx_b, n_on));
    esr_rows_copy_cols(pf->dx_a, ni, pf->d_fa, (size_t)C, n_off, C);
    esr_grid_sample_bwd(esr_model_grid(m, ESR_COMP_OFF_FEAT), pf->pos3, n_off, pf->d_fa,
                        grads + m->part[ESR_COMP_OFF_FEAT].off);
    esr_rows_copy_cols(pf->dx_b, ni, pf->d_fb, (size_t)C, n_on, C);
    esr_grid_sample_bwd(esr_model_grid(m, ESR_COMP_EMO_FEAT), pf->pos3 + n_off * 3, n_on, pf->d_fb,
                        grads + m->part[ESR_COMP_EMO_FEAT].off);
    /* geometry feature rows: off rows from the off branch, on rows from the emo branch */
    esr_rows_copy_cols(pf->dx_a + gcol, ni, pf->d_geo, (size_t)gd, n_off, gd);
    esr_rows_copy_cols(pf->dx_b + gcol, ni, pf->d_geo + n_off * (size_t)gd, (size_t)gd, n_on, gd);
    return esr_geo_feature_bwd(esr_model_grid(m, ESR_COMP_SDF), &m->geo, pf->pos3, n, pf->geo,
                               pf->d_geo, g_sdf);
}

/* ---- dispatch ---- */

static int point_fields_fwd_run(struct esr_point_fields *pf, const struct esr_model *m, const float *sdf,
                                const struct esr_point_query *q);

int esr_point_fields_fwd(struct esr_point_fields *pf, const struct esr_model *m, const float *sdf,
                         const struct esr_point_query *q)
{
    esr_prof_enter(ESR_PROF_FIELDS);
    const int rc = point_fields_fwd_run(pf, m, sdf, q);
    esr_prof_exit(ESR_PROF_FIELDS);
    return rc;
}

static int point_fields_fwd_run(struct esr_point_fields *pf, const struct esr_model *m, const float *sdf,
                                const struct esr_point_query *q)
{
    if (q->n > pf->cap)
        ESR_TRY(grow(pf, m, q->n + q->n / 4));
    partition(pf, q);
    int rc = ESR_OK;
    switch (pf->head) {
    case ESR_HEAD_RGB_GRID:
        rc = rgb_grid_fwd(pf, m);
        break;
    case ESR_HEAD_COLOUR_MLP:
        rc = colour_mlp_fwd(pf, m);
        break;
    case ESR_HEAD_RADIANCE:
        rc = radiance_fwd(pf, m, sdf);
        break;
    }
    if (rc == ESR_OK)
        to_caller(pf, pf->out3, pf->tone3);
    return rc;
}

static int point_fields_bwd_run(struct esr_point_fields *pf, const struct esr_model *m, float *g_sdf,
                                float *grads, const float *d_tone3, const float *d_lin3);

int esr_point_fields_bwd(struct esr_point_fields *pf, const struct esr_model *m, float *g_sdf,
                         float *grads, const float *d_tone3, const float *d_lin3)
{
    esr_prof_enter(ESR_PROF_FIELDS);
    const int rc = point_fields_bwd_run(pf, m, g_sdf, grads, d_tone3, d_lin3);
    esr_prof_exit(ESR_PROF_FIELDS);
    return rc;
}

static int point_fields_bwd_run(struct esr_point_fields *pf, const struct esr_model *m, float *g_sdf,
                                float *grads, const float *d_tone3, const float *d_lin3)
{
    from_caller(pf, d_tone3, pf->d_out3);
    switch (pf->head) {
    case ESR_HEAD_RGB_GRID:
        return rgb_grid_bwd(pf, m, grads);
    case ESR_HEAD_COLOUR_MLP:
        return colour_mlp_bwd(pf, m, grads);
    case ESR_HEAD_RADIANCE:
        if (d_lin3)
            from_caller(pf, d_lin3, pf->d_sum3);
        else
            memset(pf->d_sum3, 0, pf->n * 3 * sizeof(float));
        return radiance_bwd(pf, m, g_sdf, grads);
    }
    return ESR_OK;
}
