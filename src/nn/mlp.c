/* Tiled, fused MLP forward/backward on the CPU; see nn/mlp.h for layout and determinism. */
#include "nn/mlp.h"

#include "core/profile.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/profile.h"
#include "core/rng.h"
#include "nn/mlp_blas.h"
#include "nn/tile_gemm.h"

#define INFER_TILE 64 /* rows per inference tile: two ping-pong buffers stay on the stack */

static int desc_valid(const struct esr_mlp_desc *d)
{
    return d->n_in >= 1 && d->n_in <= ESR_MLP_MAX_WIDTH && d->width >= 1 &&
           d->width <= ESR_MLP_MAX_WIDTH && d->n_out >= 1 && d->n_out <= ESR_MLP_MAX_WIDTH &&
           d->n_hidden >= 0 && d->n_hidden < ESR_MLP_MAX_LAYERS &&
           (unsigned)d->hidden_act < ESR_NN_ACT_COUNT && (unsigned)d->out_act < ESR_NN_ACT_COUNT;
}

/* Fan-in / fan-out of layer l. */
static void layer_dims(const struct esr_mlp_desc *d, int l, int *fan_in, int *fan_out)
{
    *fan_in = l == 0 ? d->n_in : d->width;
    *fan_out = l == d->n_hidden ? d->n_out : d->width;
}

size_t esr_mlp_param_count(const struct esr_mlp_desc *d)
{
    if (!desc_valid(d))
        return 0;
    size_t n = 0;
    for (int l = 0; l <= d->n_hidden; l++) {
        int fi, fo;
        layer_dims(d, l, &fi, &fo);
        n += (size_t)fi * fo + fo;
    }
    return n;
}

int esr_mlp_init(struct esr_mlp *m, const struct esr_mlp_desc *d, struct esr_nn_params *p)
{
    memset(m, 0, sizeof(*m));
    if (!desc_valid(d))
        return ESR_FAIL("invalid MLP: n_in %d, width %d, n_hidden %d, n_out %d (sizes 1..%d, "
                        "hidden layers 0..%d, known activations)",
                        d->n_in, d->width, d->n_hidden, d->n_out, ESR_MLP_MAX_WIDTH,
                        ESR_MLP_MAX_LAYERS - 1);
    m->desc = *d;
    m->n_layers = d->n_hidden + 1;
    m->count = esr_mlp_param_count(d);
    ESR_TRY(esr_nn_params_take(p, m->count, &m->offset));
    size_t off = m->offset;
    for (int l = 0; l < m->n_layers; l++) {
        layer_dims(d, l, &m->fan_in[l], &m->fan_out[l]);
        m->w_off[l] = off;
        m->b_off[l] = off + (size_t)m->fan_in[l] * m->fan_out[l];
        off = m->b_off[l] + m->fan_out[l];
    }
    return ESR_OK;
}

void esr_mlp_init_weights(const struct esr_mlp *m, float *params, uint64_t seed, float last_bias)
{
    for (int l = 0; l < m->n_layers; l++) {
        int fi = m->fan_in[l], fo = m->fan_out[l];
        struct esr_rng rng = esr_rng_init(seed, (uint64_t)l);
        int last = l == m->n_layers - 1;
        /* Kaiming gain sqrt(2) keeps ReLU activations' variance; the output layer is linear. */
        float wb = sqrtf((last ? 3.0f : 6.0f) / (float)fi), bb = 1.0f / sqrtf((float)fi);
        float *w = params + m->w_off[l], *b = params + m->b_off[l];
        for (size_t i = 0; i < (size_t)fi * fo; i++)
            w[i] = wb * (2.0f * esr_rng_float(&rng) - 1.0f);
        for (int i = 0; i < fo; i++)
            b[i] = last && isfinite(last_bias) ? last_bias : bb * (2.0f * esr_rng_float(&rng) - 1.0f);
    }
}

/* Per-thread backward scratch: dZ and dH tiles. */
static size_t scratch_per_thread(void)
{
    return 2 * (size_t)ESR_MLP_TILE * ESR_MLP_MAX_WIDTH;
}

int esr_mlp_ctx_init(struct esr_mlp_ctx *c, const struct esr_mlp *m, size_t max_rows,
                     enum esr_mlp_engine engine)
{
    memset(c, 0, sizeof(*c));
    if ((unsigned)engine >= ESR_MLP_ENGINE_COUNT)
        return ESR_FAIL("unknown MLP engine %d", (int)engine);
    c->engine = engine;
    c->max_rows = max_rows;
    c->n_threads = omp_get_max_threads();
    const size_t rows = max_rows ? max_rows : 1;
    size_t n_act = (size_t)m->desc.n_hidden * m->desc.width * rows;
    c->act = malloc(n_act ? n_act * sizeof(float) : sizeof(float));
    int ok = c->act != NULL;
    if (engine == ESR_MLP_ENGINE_FUSED) {
        ok &= (c->slices = malloc((size_t)ESR_MLP_GRAD_SLICES * m->count * sizeof(float))) != NULL;
        ok &= (c->wt = malloc(m->count * sizeof(float))) != NULL;
        ok &= (c->scratch = malloc((size_t)c->n_threads * scratch_per_thread() * sizeof(float))) != NULL;
    } else {
        ok &= (c->grad_rows = malloc(2 * rows * ESR_MLP_MAX_WIDTH * sizeof(float))) != NULL;
        ok &= (c->ones = malloc(rows * sizeof(float))) != NULL;
        for (size_t r = 0; ok && r < rows; r++)
            c->ones[r] = 1.0f;
    }
    if (!ok) {
        esr_mlp_ctx_free(c);
        return ESR_FAIL("out of memory for an MLP workspace of %zu rows", max_rows);
    }
    return ESR_OK;
}

void esr_mlp_ctx_free(struct esr_mlp_ctx *c)
{
    free(c->act);
    free(c->slices);
    free(c->wt);
    free(c->scratch);
    free(c->grad_rows);
    free(c->ones);
    memset(c, 0, sizeof(*c));
}

/* Runs layer l on `rows` rows: y = act(x W_l + b_l). */
static void layer_fwd(const struct esr_mlp *m, const float *params, int l, const float *x, int ldx,
                      float *y, int ldy, int rows)
{
    const struct esr_gemm_tile t = {
        .a = x, .b = params + m->w_off[l], .c = y, .bias = params + m->b_off[l],
        .m = rows, .n = m->fan_out[l], .k = m->fan_in[l],
        .lda = ldx, .ldb = m->fan_out[l], .ldc = ldy,
        .act = l == m->n_layers - 1 ? m->desc.out_act : m->desc.hidden_act,
    };
    esr_gemm_tile(&t);
}

/* Hidden activations of layer l for row r in the training workspace. */
static float *act_row(const struct esr_mlp *m, struct esr_mlp_ctx *c, int l, size_t r)
{
    return c->act + ((size_t)l * c->max_rows + r) * m->desc.width;
}

/* All layers on one tile of `rows` rows starting at input row x; layer l < L-1 writes its
 * activations to hid[l] (rows `width` apart), the last layer writes out. */
static void tile_fwd(const struct esr_mlp *m, const float *params, const float *x, int rows,
                     float *const *hid, float *out)
{
    int ldx = m->desc.n_in;
    for (int l = 0; l < m->n_layers - 1; l++) {
        layer_fwd(m, params, l, x, ldx, hid[l], m->desc.width, rows);
        x = hid[l];
        ldx = m->desc.width;
    }
    layer_fwd(m, params, m->n_layers - 1, x, ldx, out, m->desc.n_out, rows);
}

/* multiply-adds of one row through every layer, times 2: a forward's flops per row */
static double flops_per_row(const struct esr_mlp *m)
{
    double f = 0.0;
    for (int l = 0; l < m->n_layers; l++)
        f += 2.0 * m->fan_in[l] * m->fan_out[l];
    return f;
}

static int mlp_fwd_run(const struct esr_mlp *m, const float *params, struct esr_mlp_ctx *c,
                       const float *in, float *out, size_t n);

int esr_mlp_fwd(const struct esr_mlp *m, const float *params, struct esr_mlp_ctx *c,
                const float *in, float *out, size_t n)
{
    esr_prof_enter(ESR_PROF_MLP_FWD);
    const int rc = mlp_fwd_run(m, params, c, in, out, n);
    esr_prof_work(ESR_PROF_MLP_FWD, flops_per_row(m) * (double)n, 0.0);
    esr_prof_exit(ESR_PROF_MLP_FWD);
    return rc;
}

static int mlp_fwd_run(const struct esr_mlp *m, const float *params, struct esr_mlp_ctx *c,
                       const float *in, float *out, size_t n)
{
    if (n > c->max_rows)
        return ESR_FAIL("MLP forward of %zu rows exceeds the workspace's %zu", n, c->max_rows);
    c->in = in;
    c->out = out;
    c->rows = n;
    if (c->engine != ESR_MLP_ENGINE_FUSED) {
        esr_mlp_blas_fwd(m, params, c, in, out, n);
        return ESR_OK;
    }
    size_t n_tiles = (n + ESR_MLP_TILE - 1) / ESR_MLP_TILE;
    /* Rows are independent, so dynamic scheduling (robust when a core is shared) cannot change
     * any result. */
#pragma omp parallel for schedule(dynamic, 2) num_threads(c->n_threads) if (n_tiles > 1)
    for (size_t t = 0; t < n_tiles; t++) {
        size_t r0 = t * ESR_MLP_TILE;
        float *hid[ESR_MLP_MAX_LAYERS];
        for (int l = 0; l < m->n_layers - 1; l++)
            hid[l] = act_row(m, c, l, r0);
        tile_fwd(m, params, in + r0 * m->desc.n_in,
                 (int)(n - r0 < ESR_MLP_TILE ? n - r0 : ESR_MLP_TILE), hid,
                 out + r0 * m->desc.n_out);
    }
    return ESR_OK;
}

void esr_mlp_infer(const struct esr_mlp *m, const float *params, const float *in, float *out,
                   size_t n)
{
    size_t n_tiles = (n + INFER_TILE - 1) / INFER_TILE;
#pragma omp parallel for schedule(dynamic, 4) if (n_tiles > 1)
    for (size_t t = 0; t < n_tiles; t++) {
        float buf[2][INFER_TILE * ESR_MLP_MAX_WIDTH];
        float *hid[ESR_MLP_MAX_LAYERS];
        for (int l = 0; l < m->n_layers - 1; l++)
            hid[l] = buf[l & 1]; /* ping-pong: layer l only reads layer l-1 */
        size_t r0 = t * INFER_TILE;
        tile_fwd(m, params, in + r0 * m->desc.n_in,
                 (int)(n - r0 < INFER_TILE ? n - r0 : INFER_TILE), hid, out + r0 * m->desc.n_out);
    }
}

/* ---- backward ---- */

struct bwd_job {
    const struct esr_mlp *m;
    const float *params;
    struct esr_mlp_ctx *c;
    const float *d_out;
    float *d_in;
    enum esr_nn_grad_mode mode;
};

/* Column sums of dz [rows][n] added to db, rows in order. */
static void bias_grad(const float *dz, int rows, int n, float *db)
{
    for (int r = 0; r < rows; r++)
        for (int j = 0; j < n; j++)
            db[j] += dz[r * n + j];
}

/* dz = act'(y) * dy over n contiguous values; the activation is switched once, outside the loop,
 * so each case vectorises. */
ESR_HOT static void act_bwd_block(enum esr_nn_act act, const float *ESR_RESTRICT y,
                                  const float *ESR_RESTRICT dy, float *ESR_RESTRICT dz, int n)
{
    switch (act) {
    case ESR_NN_ACT_RELU:
        for (int i = 0; i < n; i++)
            dz[i] = esr_nn_relu_bwd(y[i], dy[i]);
        break;
    case ESR_NN_ACT_NONE:
        memcpy(dz, dy, sizeof(float) * (size_t)n);
        break;
    default:
        for (int i = 0; i < n; i++)
            dz[i] = esr_nn_act_bwd(act, y[i], dy[i]);
    }
}

/* Backward of one tile through all layers; weight gradients go to the slice buffer g (laid out
 * like the parameters, relative to m->offset). */
static void tile_bwd(const struct bwd_job *j, size_t r0, int rows, float *g, float *scratch)
{
    const struct esr_mlp *m = j->m;
    struct esr_mlp_ctx *c = j->c;
    const int w = m->desc.width, L = m->n_layers, n_out = m->desc.n_out, n_in = m->desc.n_in;
    float *dz = scratch, *dh = dz + ESR_MLP_TILE * ESR_MLP_MAX_WIDTH;
    const float *y = c->out + r0 * n_out, *dy = j->d_out + r0 * n_out;
    /* gz: d loss / d pre-activation of the current layer; a linear output reads d_out in place. */
    const float *gz = dy;
    if (m->desc.out_act != ESR_NN_ACT_NONE) {
        act_bwd_block(m->desc.out_act, y, dy, dz, rows * n_out);
        gz = dz;
    }
    for (int l = L - 1; l >= 0; l--) {
        int fi = m->fan_in[l], fo = m->fan_out[l];
        const float *x = l == 0 ? c->in + r0 * n_in : act_row(m, c, l - 1, r0);
        int ldx = l == 0 ? n_in : w;
        bias_grad(gz, rows, fo, g + (m->b_off[l] - m->offset));
        const struct esr_gemm_tile dw = { /* dW += X^T dZ */
            .a = x, .b = gz, .c = g + (m->w_off[l] - m->offset), .m = fi, .n = fo, .k = rows,
            .lda = ldx, .ldb = fo, .ldc = fo, .trans_a = 1, .accumulate = 1, .act = ESR_NN_ACT_NONE,
        };
        esr_gemm_tile(&dw);
        const float *wt = c->wt + (m->w_off[l] - m->offset);
        if (l > 0) { /* dH = dZ W^T */
            const struct esr_gemm_tile dx = {.a = gz, .b = wt, .c = dh, .m = rows, .n = fi, .k = fo,
                                             .lda = fo, .ldb = fi, .ldc = fi, .act = ESR_NN_ACT_NONE};
            esr_gemm_tile(&dx);
            /* Hidden layers are width-wide rows (ldx == fi), so the tile is one flat block. */
            act_bwd_block(m->desc.hidden_act, x, dh, dz, rows * fi);
            gz = dz;
        } else if (j->mode != ESR_NN_GRAD_IGNORE) { /* d_in (+)= dZ W^T */
            const struct esr_gemm_tile dx = {
                .a = gz, .b = wt, .c = j->d_in + r0 * n_in, .m = rows, .n = fi, .k = fo,
                .lda = fo, .ldb = fi, .ldc = n_in, .accumulate = j->mode == ESR_NN_GRAD_ACCUMULATE,
                .act = ESR_NN_ACT_NONE,
            };
            esr_gemm_tile(&dx);
        }
    }
}

/* wt holds each W_l transposed to [fan_out][fan_in] for the d_in products. */
static void transpose_weights(const struct esr_mlp *m, const float *params, float *wt)
{
    for (int l = 0; l < m->n_layers; l++) {
        int fi = m->fan_in[l], fo = m->fan_out[l];
        const float *src = params + m->w_off[l];
        float *dst = wt + (m->w_off[l] - m->offset);
        for (int i = 0; i < fi; i++)
            for (int o = 0; o < fo; o++)
                dst[o * fi + i] = src[i * fo + o];
    }
}

static int mlp_bwd_run(const struct esr_mlp *m, const float *params, float *grads,
                       struct esr_mlp_ctx *c, const float *d_out, float *d_in,
                       enum esr_nn_grad_mode mode);

int esr_mlp_bwd(const struct esr_mlp *m, const float *params, float *grads, struct esr_mlp_ctx *c,
                const float *d_out, float *d_in, enum esr_nn_grad_mode mode)
{
    esr_prof_enter(ESR_PROF_MLP_BWD);
    const int rc = mlp_bwd_run(m, params, grads, c, d_out, d_in, mode);
    /* the weights' gradient and the inputs' (the activations' derivatives not counted) */
    esr_prof_work(ESR_PROF_MLP_BWD, 2.0 * flops_per_row(m) * (double)c->rows, 0.0);
    esr_prof_exit(ESR_PROF_MLP_BWD);
    return rc;
}

static int mlp_bwd_run(const struct esr_mlp *m, const float *params, float *grads,
                       struct esr_mlp_ctx *c, const float *d_out, float *d_in,
                       enum esr_nn_grad_mode mode)
{
    if (!c->in || !c->out)
        return ESR_FAIL("MLP backward without a preceding forward on this workspace");
    if (mode != ESR_NN_GRAD_IGNORE && !d_in)
        return ESR_FAIL("MLP backward asked for d_in but got no buffer");
    if (c->engine != ESR_MLP_ENGINE_FUSED) {
        esr_mlp_blas_bwd(m, params, grads, c, d_out, d_in, mode);
        return ESR_OK;
    }
    struct bwd_job job = {m, params, c, d_out, d_in, mode};
    transpose_weights(m, params, c->wt);
    const size_t n = c->rows, count = m->count;
    size_t n_tiles = (n + ESR_MLP_TILE - 1) / ESR_MLP_TILE;
    /* Slice s owns a fixed run of tiles: the partial sums, and their in-order reduction below,
     * depend on n only, never on the thread count. */
    int n_slices = n_tiles < ESR_MLP_GRAD_SLICES ? (int)n_tiles : ESR_MLP_GRAD_SLICES;
#pragma omp parallel for schedule(dynamic, 1) num_threads(c->n_threads) if (n_slices > 1)
    for (int s = 0; s < n_slices; s++) {
        float *g = c->slices + (size_t)s * count;
        float *scratch = c->scratch + (size_t)omp_get_thread_num() * scratch_per_thread();
        memset(g, 0, count * sizeof(float));
        size_t t_end = n_tiles * (size_t)(s + 1) / n_slices;
        for (size_t t = n_tiles * (size_t)s / n_slices; t < t_end; t++) {
            size_t r0 = t * ESR_MLP_TILE;
            int rows = (int)(n - r0 < ESR_MLP_TILE ? n - r0 : ESR_MLP_TILE);
            tile_bwd(&job, r0, rows, g, scratch);
        }
    }
    float *dst = grads + m->offset;
    const size_t chunk = 4096;
    size_t n_chunks = (count + chunk - 1) / chunk;
#pragma omp parallel for schedule(static) num_threads(c->n_threads) if (n_chunks > 16)
    for (size_t ch = 0; ch < n_chunks; ch++) {
        size_t b = ch * chunk, e = b + chunk < count ? b + chunk : count;
        for (int s = 0; s < n_slices; s++) {
            const float *src = c->slices + (size_t)s * count;
            for (size_t i = b; i < e; i++)
                dst[i] += src[i];
        }
    }
    return ESR_OK;
}
