/* NeRF positional encoding: PE(x) = (x, sin(2^0 x), cos(2^0 x), ..., sin(2^(F-1) x),
 * cos(2^(F-1) x)), each group n_dims wide, in that order. Positions use 5 frequencies, view
 * directions 1. Rows are strided so the encoding can be written straight into a slice of a
 * concatenated MLP input row. */
#ifndef ESR_NN_ENCODING_H
#define ESR_NN_ENCODING_H

#include <math.h>
#include <stddef.h>

#include "core/simd.h"
#include "nn/mlp.h"

#ifdef __cplusplus
extern "C" {
#endif

#define ESR_PE_MAX_FREQS 16

struct esr_pe {
    int n_dims;  /* input dimensions per row, >= 1 */
    int n_freqs; /* F, 0..ESR_PE_MAX_FREQS */
};

/* Output features per row: n_dims * (1 + 2F). */
ESR_INLINE int esr_pe_out_dims(const struct esr_pe *pe) { return pe->n_dims * (1 + 2 * pe->n_freqs); }

/* Row strides (in floats) of the arrays one PE call reads and writes. */
struct esr_pe_rows {
    size_t n;          /* rows */
    size_t in_stride;  /* between rows of in / d_in (>= n_dims) */
    size_t out_stride; /* between rows of out / d_out (>= esr_pe_out_dims) */
};

/* out[r*out_stride + j] = PE(in[r*in_stride + ...])_j for j < esr_pe_out_dims. */
void esr_pe_fwd(const struct esr_pe *pe, const struct esr_pe_rows *rows, const float *in,
                float *out);
/* d_in (per mode) from d_out: d/dx sin(2^k x) = 2^k cos(2^k x), d/dx cos(2^k x) = -2^k sin. */
void esr_pe_bwd(const struct esr_pe *pe, const struct esr_pe_rows *rows, const float *in,
                const float *d_out, float *d_in, enum esr_nn_grad_mode mode);

#ifdef __cplusplus
}
#endif
#endif
