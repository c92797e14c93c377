/* The MLP through a library sgemm (oneDNN or OpenBLAS): one full-batch GEMM per layer and
 * product, bias and activation in separate element-wise passes, the way a framework runs it. Layouts as in nn/mlp.h: rows of a batch are contiguous, W_l is
 * [fan_in][fan_out] row-major, so every product is a plain row-major GEMM. */
#include "nn/mlp_blas.h"

#include <cblas.h>
#include <oneapi/dnnl/dnnl.h>

#include "nn/activation.h"

/* Row-major C = op(A) op(B) + beta C through the workspace's library; ta/tb 'N' or 'T'.
 * Exempt from the eight-argument rule: it keeps the BLAS sgemm signature it wraps. */
static void sgemm(const struct esr_mlp_ctx *ctx, char ta, char tb, size_t m, int n, size_t k, const float *a,
                  int lda, const float *b, int ldb, float beta, float *c, int ldc)
{
    if (ctx->engine == ESR_MLP_ENGINE_ONEDNN) {
        dnnl_sgemm(ta, tb, (dnnl_dim_t)m, n, (dnnl_dim_t)k, 1.0f, a, lda, b, ldb, beta, c, ldc);
        return;
    }
    cblas_sgemm(CblasRowMajor, ta == 'T' ? CblasTrans : CblasNoTrans, tb == 'T' ? CblasTrans : CblasNoTrans,
                (blasint)m, n, (blasint)k, 1.0f, a, lda, b, ldb, beta, c, ldc);
}

/* y = act(y + b) over n rows of width w; the activation is switched outside the loops. */
static void bias_act(float *y, const float *b, size_t n, int w, enum esr_nn_act act)
{
#pragma omp parallel for schedule(static)
    for (size_t r = 0; r < n; r++) {
        float *row = y + r * w;
        if (act == ESR_NN_ACT_RELU)
            for (int j = 0; j < w; j++)
                row[j] = esr_nn_relu_fwd(row[j] + b[j]);
        else
            for (int j = 0; j < w; j++)
                row[j] = esr_nn_act_fwd(act, row[j] + b[j]);
    }
}

/* g = act'(y) * dy over count values (act' from the activation's output). */
static void act_grad(enum esr_nn_act act, const float *y, const float *dy, float *g, size_t count)
{
    if (act == ESR_NN_ACT_RELU) {
#pragma omp parallel for schedule(static)
        for (size_t i = 0; i < count; i++)
            g[i] = esr_nn_relu_bwd(y[i], dy[i]);
    } else {
#pragma omp parallel for schedule(static)
        for (size_t i = 0; i < count; i++)
            g[i] = esr_nn_act_bwd(act, y[i], dy[i]);
    }
}

static float *hidden(const struct esr_mlp *m, const struct esr_mlp_ctx *c, int l)
{
    return c->act + (size_t)l * c->max_rows * m->desc.width;
}

void esr_mlp_blas_fwd(const struct esr_mlp *m, const float *params, struct esr_mlp_ctx *c, const float *in,
                        float *out, size_t n)
{
    if (n == 0)
        return;
    const float *x = in;
    for (int l = 0; l < m->n_layers; l++) {
        int fi = m->fan_in[l], fo = m->fan_out[l], last = l == m->n_layers - 1;
        float *y = last ? out : hidden(m, c, l);
        sgemm(c, 'N', 'N', n, fo, (size_t)fi, x, fi, params + m->w_off[l], fo, 0.0f, y, fo);
        bias_act(y, params + m->b_off[l], n, fo, last ? m->desc.out_act : m->desc.hidden_act);
        x = y;
    }
}

void esr_mlp_blas_bwd(const struct esr_mlp *m, const float *params, float *grads, struct esr_mlp_ctx *c,
                        const float *d_out, float *d_in, enum esr_nn_grad_mode mode)
{
    const size_t n = c->rows;
    if (n == 0)
        return;
    float *buf[2] = {c->grad_rows, c->grad_rows + c->max_rows * ESR_MLP_MAX_WIDTH};
    /* g: d loss / d pre-activation of the current layer */
    const float *g = d_out;
    if (m->desc.out_act != ESR_NN_ACT_NONE) {
        act_grad(m->desc.out_act, c->out, d_out, buf[0], n * (size_t)m->desc.n_out);
        g = buf[0];
    }
    for (int l = m->n_layers - 1; l >= 0; l--) {
        int fi = m->fan_in[l], fo = m->fan_out[l];
        const float *x = l == 0 ? c->in : hidden(m, c, l - 1);
        /* db += 1^T G and dW += X^T G, accumulated into the gradient buffer */
        sgemm(c, 'N', 'N', 1, fo, n, c->ones, (int)n, g, fo, 1.0f, grads + m->b_off[l], fo);
        sgemm(c, 'T', 'N', (size_t)fi, fo, n, x, fi, g, fo, 1.0f, grads + m->w_off[l], fo);
        const float *w = params + m->w_off[l];
        if (l > 0) {
            float *dh = buf[(m->n_layers - l) & 1]; /* never the buffer g points into */
            sgemm(c, 'N', 'T', n, fi, (size_t)fo, g, fo, w, fo, 0.0f, dh, fi);
            act_grad(m->desc.hidden_act, x, dh, dh, n * (size_t)fi);
            g = dh;
        } else if (mode != ESR_NN_GRAD_IGNORE) {
            sgemm(c, 'N', 'T', n, fi, (size_t)fo, g, fo, w, fo, mode == ESR_NN_GRAD_ACCUMULATE ? 1.0f : 0.0f, d_in, fi);
        }
    }
}
