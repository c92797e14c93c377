/* Activation names for configuration files and checkpoints. */
#include "nn/activation.h"

#include <string.h>

#include "core/error.h"

static const char *const act_names[] = {"none", "relu", "sigmoid", "softplus", "trunc_exp"};
_Static_assert(sizeof(act_names) / sizeof(act_names[0]) == ESR_NN_ACT_COUNT, "act name table");

const char *esr_nn_act_name(enum esr_nn_act act)
{
    return (unsigned)act < ESR_NN_ACT_COUNT ? act_names[act] : NULL;
}

int esr_nn_act_from_name(const char *name, enum esr_nn_act *out)
{
    for (int i = 0; i < ESR_NN_ACT_COUNT; i++)
        if (strcmp(name, act_names[i]) == 0) {
            *out = (enum esr_nn_act)i;
            return ESR_OK;
        }
    return ESR_FAIL("unknown activation '%s' (none, relu, sigmoid, softplus, trunc_exp)", name);
}
