/* The library engines of the MLP workspace (ESR_MLP_ENGINE_ONEDNN / _OPENBLAS, nn/mlp.h): what
 * esr_mlp_fwd and esr_mlp_bwd run for such a workspace, layer by layer over the full batch. */
#ifndef ESR_NN_MLP_BLAS_H
#define ESR_NN_MLP_BLAS_H

#include "nn/mlp.h"

/* out[n][n_out] = mlp(in[n][n_in]), hidden activations kept in c->act. */
void esr_mlp_blas_fwd(const struct esr_mlp *m, const float *params, struct esr_mlp_ctx *c, const float *in,
                        float *out, size_t n);
/* Backward of the last forward on c, with esr_mlp_bwd's contract (checks already done). */
void esr_mlp_blas_bwd(const struct esr_mlp *m, const float *params, float *grads, struct esr_mlp_ctx *c,
                        const float *d_out, float *d_in, enum esr_nn_grad_mode mode);

#endif
