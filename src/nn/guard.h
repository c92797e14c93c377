/* NaN/Inf guard: a training loop checks gradients (and now and then parameters) with this before
 * an optimiser step, so one bad batch is detected and skipped or rolled back instead of silently
 * poisoning every parameter. */
#ifndef ESR_NN_GUARD_H
#define ESR_NN_GUARD_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* 1 when all n values are finite, else 0. Branch-free, vectorised and parallel for large n. */
int esr_nn_all_finite(const float *x, size_t n);
/* Index of the first non-finite value, or n when there is none (for error messages). */
size_t esr_nn_first_nonfinite(const float *x, size_t n);

#ifdef __cplusplus
}
#endif
#endif
