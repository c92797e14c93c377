/* Fully-connected network (tiny-cuda-nn style): n_in -> [width, act]^n_hidden -> n_out, out_act.
 * Parameters live in the model's flat buffer (nn/params.h); the MLP keeps only offsets.
 *
 * Parameter layout, per layer l (n_hidden + 1 layers), consecutive from `offset`:
 *   W_l as [fan_in][fan_out] row-major (input-major, i.e. the transpose of PyTorch's weight, so
 *   the batched product's inner loop runs over contiguous outputs), then b_l[fan_out].
 *
 * Batched rows: inputs [n][n_in] and outputs [n][n_out], row-major, contiguous.
 * The forward pass is tiled (ESR_MLP_TILE rows through all layers while they are in cache),
 * OpenMP-parallel over tiles; backward accumulates weight gradients into a fixed number of
 * row-slices reduced in a fixed order, so results are bitwise identical for any thread count.
 * Training can instead run through oneDNN or OpenBLAS (enum esr_mlp_engine, nn/mlp_blas.c). */
#ifndef ESR_NN_MLP_H
#define ESR_NN_MLP_H

#include <stddef.h>
#include <stdint.h>

#include "nn/activation.h"
#include "nn/params.h"

#ifdef __cplusplus
extern "C" {
#endif

#define ESR_MLP_MAX_WIDTH 256 /* widest layer (in, hidden or out) */
#define ESR_MLP_MAX_LAYERS 16 /* matmuls = n_hidden + 1 */
#define ESR_MLP_TILE 128      /* rows per tile */
#define ESR_MLP_GRAD_SLICES 16 /* fixed weight-gradient partial sums (determinism) */

struct esr_mlp_desc {
    int n_in;                 /* input features, 1..ESR_MLP_MAX_WIDTH */
    int width;                /* hidden width, 1..ESR_MLP_MAX_WIDTH */
    int n_hidden;             /* hidden layers, 0..ESR_MLP_MAX_LAYERS-1 (0 = one linear layer) */
    int n_out;                /* outputs, 1..ESR_MLP_MAX_WIDTH */
    enum esr_nn_act hidden_act; /* usually ESR_NN_ACT_RELU */
    enum esr_nn_act out_act;  /* none / sigmoid / softplus / trunc_exp */
};

struct esr_mlp {
    struct esr_mlp_desc desc;
    int n_layers;                          /* n_hidden + 1 */
    int fan_in[ESR_MLP_MAX_LAYERS];
    int fan_out[ESR_MLP_MAX_LAYERS];
    size_t w_off[ESR_MLP_MAX_LAYERS];      /* absolute offset of W_l in the flat buffer */
    size_t b_off[ESR_MLP_MAX_LAYERS];      /* absolute offset of b_l */
    size_t offset;                         /* first parameter */
    size_t count;                          /* parameters (W and b of all layers) */
};

/* Which d_in the backward pass produces (tiny-cuda-nn's GradientMode). */
enum esr_nn_grad_mode {
    ESR_NN_GRAD_IGNORE,     /* d_in not computed (may be NULL) */
    ESR_NN_GRAD_OVERWRITE,  /* d_in = d loss / d in */
    ESR_NN_GRAD_ACCUMULATE  /* d_in += d loss / d in */
};

/* Which kernels a training workspace runs. FUSED: esr's tiled kernel, every layer of a 128-row
 * tile while it is in cache, bitwise identical results for any thread count. ONEDNN / OPENBLAS:
 * one full-batch library sgemm per layer and product with separate bias/activation passes
 * (nn/mlp_blas.c); oneDNN is the fastest on every training shape `esr bench` measures on an
 * AVX-512 machine, but library sums may be ordered differently for another thread count.
 * Inference (esr_mlp_infer) always runs the fused kernel. */
enum esr_mlp_engine { ESR_MLP_ENGINE_FUSED, ESR_MLP_ENGINE_ONEDNN, ESR_MLP_ENGINE_OPENBLAS, ESR_MLP_ENGINE_COUNT };

/* Caller-owned workspace for training: the hidden activations of one forward call and the
 * backward scratch, sized once for max_rows so the training loop allocates nothing. */
struct esr_mlp_ctx {
    size_t max_rows;
    float *act;        /* hidden activations, per layer [max_rows][width] */
    float *slices;     /* ESR_MLP_GRAD_SLICES x count partial weight gradients */
    float *wt;         /* weights transposed to [fan_out][fan_in] for d_in, count floats */
    float *scratch;    /* per-thread tile scratch */
    float *grad_rows;  /* library engines: two [max_rows][widest layer] gradient buffers */
    float *ones;       /* library engines: max_rows ones (bias gradients as a GEMM) */
    enum esr_mlp_engine engine;
    int n_threads;     /* threads the scratch was sized for */
    const float *in;   /* forward input kept for backward (caller keeps it alive) */
    const float *out;  /* forward output kept for backward (caller keeps it alive) */
    size_t rows;       /* rows of the last forward */
};

/* Number of parameters (floats) for a descriptor; 0 when the descriptor is invalid. */
size_t esr_mlp_param_count(const struct esr_mlp_desc *d);
/* Validates d, takes the parameters from p and fills m (weights zero until init_weights). */
int esr_mlp_init(struct esr_mlp *m, const struct esr_mlp_desc *d, struct esr_nn_params *p);
/* Kaiming-uniform weights (U(-sqrt(6/fan_in), +) for ReLU-fed layers, sqrt(3/fan_in) for the
 * output layer), biases U(-1/sqrt(fan_in), +) like PyTorch, the last layer's bias set to
 * last_bias (e.g. 0) when finite. Deterministic in seed. `params` is the flat buffer base. */
void esr_mlp_init_weights(const struct esr_mlp *m, float *params, uint64_t seed, float last_bias);

/* Allocates a training workspace for up to max_rows rows per forward call, run by engine. */
int esr_mlp_ctx_init(struct esr_mlp_ctx *c, const struct esr_mlp *m, size_t max_rows,
                     enum esr_mlp_engine engine);
void esr_mlp_ctx_free(struct esr_mlp_ctx *c);

/* Training forward: out[n][n_out] = mlp(in[n][n_in]), keeping what backward needs in c
 * (including the in/out pointers: both must stay unchanged until esr_mlp_bwd).
 * ESR_ERR when n > c->max_rows. `params` is the flat buffer base. */
int esr_mlp_fwd(const struct esr_mlp *m, const float *params, struct esr_mlp_ctx *c,
                const float *in, float *out, size_t n);
/* Backward of the last esr_mlp_fwd on c: adds d loss/d params into grads (flat gradient base)
 * and writes d_in[n][n_in] per mode. d_out is [n][n_out]. */
int esr_mlp_bwd(const struct esr_mlp *m, const float *params, float *grads, struct esr_mlp_ctx *c,
                const float *d_out, float *d_in, enum esr_nn_grad_mode mode);
/* Inference forward: no workspace, nothing kept; any n. */
void esr_mlp_infer(const struct esr_mlp *m, const float *params, const float *in, float *out,
                   size_t n);

#ifdef __cplusplus
}
#endif
#endif
