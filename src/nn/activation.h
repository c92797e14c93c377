/* Activation functions as per-element pure functions (C/C++ common subset, for a later CUDA
 * port). Every backward is written in terms of the forward *output* y, so a forward pass only has
 * to keep its outputs: relu' = [y > 0], sigmoid' = y(1-y), softplus' = sigmoid(z) = 1 - exp(-y),
 * trunc_exp' = exp(clamp(z, -15, 15)) = clamp(y, e^-15, e^15) (instant-ngp's truncated exponential). */
#ifndef ESR_NN_ACTIVATION_H
#define ESR_NN_ACTIVATION_H

#include <math.h>

#include "core/simd.h"

enum esr_nn_act {
    ESR_NN_ACT_NONE,
    ESR_NN_ACT_RELU,
    ESR_NN_ACT_SIGMOID,
    ESR_NN_ACT_SOFTPLUS, /* beta 1; linear above z = 20 like PyTorch's threshold */
    ESR_NN_ACT_TRUNC_EXP,
    ESR_NN_ACT_COUNT
};

#define ESR_NN_SOFTPLUS_THRESHOLD 20.0f
#define ESR_NN_TRUNC_EXP_CLAMP 15.0f

/* "none", "relu", ...; NULL for an invalid value. */
const char *esr_nn_act_name(enum esr_nn_act act);
/* Parses a name written by esr_nn_act_name; ESR_ERR on an unknown name. */
int esr_nn_act_from_name(const char *name, enum esr_nn_act *out);

ESR_INLINE float esr_nn_relu_fwd(float z) { return z > 0.0f ? z : 0.0f; }
ESR_INLINE float esr_nn_relu_bwd(float y, float dy) { return y > 0.0f ? dy : 0.0f; }

ESR_INLINE float esr_nn_sigmoid_fwd(float z) { return 1.0f / (1.0f + expf(-z)); }
ESR_INLINE float esr_nn_sigmoid_bwd(float y, float dy) { return dy * y * (1.0f - y); }

/* log(1 + e^z) = max(z, 0) + log1p(e^-|z|): no overflow for large z, no loss of precision for
 * very negative z. */
ESR_INLINE float esr_nn_softplus_fwd(float z)
{
    return z > ESR_NN_SOFTPLUS_THRESHOLD ? z : fmaxf(z, 0.0f) + log1pf(expf(-fabsf(z)));
}
/* sigmoid(z) recovered from y = softplus(z) as 1 - e^-y (exact identity; -expm1 keeps precision
 * when y is tiny); equals 1 in the linear region. */
ESR_INLINE float esr_nn_softplus_bwd(float y, float dy) { return dy * -expm1f(-y); }

ESR_INLINE float esr_nn_trunc_exp_fwd(float z) { return expf(z); }
ESR_INLINE float esr_nn_trunc_exp_bwd(float y, float dy)
{
    const float hi = 3269017.3724721107f;  /* e^15 */
    const float lo = 3.0590232050182579e-7f; /* e^-15 */
    return dy * (y < lo ? lo : (y > hi ? hi : y));
}

ESR_INLINE float esr_nn_act_fwd(enum esr_nn_act act, float z)
{
    switch (act) {
    case ESR_NN_ACT_RELU: return esr_nn_relu_fwd(z);
    case ESR_NN_ACT_SIGMOID: return esr_nn_sigmoid_fwd(z);
    case ESR_NN_ACT_SOFTPLUS: return esr_nn_softplus_fwd(z);
    case ESR_NN_ACT_TRUNC_EXP: return esr_nn_trunc_exp_fwd(z);
    default: return z;
    }
}
/* d loss / d z given the forward output y and d loss / d y. */
ESR_INLINE float esr_nn_act_bwd(enum esr_nn_act act, float y, float dy)
{
    switch (act) {
    case ESR_NN_ACT_RELU: return esr_nn_relu_bwd(y, dy);
    case ESR_NN_ACT_SIGMOID: return esr_nn_sigmoid_bwd(y, dy);
    case ESR_NN_ACT_SOFTPLUS: return esr_nn_softplus_bwd(y, dy);
    case ESR_NN_ACT_TRUNC_EXP: return esr_nn_trunc_exp_bwd(y, dy);
    default: return dy;
    }
}

#endif
