/* One flat float buffer holds every parameter of a model, with a gradient buffer of the same
 * size beside it. Components (MLPs, grids, ...) keep *offsets* into it, never pointers, so the
 * buffer may grow while a model is being assembled; the optimiser is then one loop over ranges
 * and a checkpoint is the configuration plus this buffer. */
#ifndef ESR_NN_PARAMS_H
#define ESR_NN_PARAMS_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Every range handed out starts on a 64-byte boundary (16 floats) so kernels can use aligned
 * vector loads and ranges never share a cache line between threads. */
#define ESR_NN_PARAM_ALIGN 16

struct esr_nn_params {
    float *w;        /* parameters, `count` used of `capacity` (64-byte aligned) */
    float *g;        /* gradients, same layout as w */
    size_t count;    /* floats handed out so far (including alignment padding) */
    size_t capacity; /* floats allocated */
    int count_only;  /* 1: take() hands out offsets and allocates nothing (memory estimates) */
};

/* Empty store; `reserve` floats are allocated up front (0 allowed). Free with esr_nn_params_free. */
int esr_nn_params_init(struct esr_nn_params *p, size_t reserve);
void esr_nn_params_free(struct esr_nn_params *p);
/* Hands out `n` zero-initialised floats (w and g) and returns their offset; grows the buffer
 * (pointers w/g may change, offsets stay valid). */
int esr_nn_params_take(struct esr_nn_params *p, size_t n, size_t *offset);
/* Sets the gradients of [offset, offset+n) to zero (parallel). */
void esr_nn_params_zero_grad(struct esr_nn_params *p, size_t offset, size_t n);

#ifdef __cplusplus
}
#endif
#endif
