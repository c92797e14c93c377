/* Row helpers shared by the point-field heads (internal to src/model): building MLP input rows
 * out of columns. */
#ifndef ESR_MODEL_ROWS_H
#define ESR_MODEL_ROWS_H

#include <stddef.h>
#include <string.h>

#include "nn/encoding.h"

/* Copies `cols` columns between row-major arrays of different strides. */
static inline void esr_rows_copy_cols(const float *src, size_t src_stride, float *dst,
                                      size_t dst_stride, size_t n, int cols)
{
#pragma omp parallel for schedule(static)
    for (size_t k = 0; k < n; k++)
        memcpy(dst + k * dst_stride, src + k * src_stride, (size_t)cols * sizeof(float));
}

/* PE of n 3-vectors into rows of `stride` floats. */
static inline void esr_rows_pe(const struct esr_pe *pe, const float *in, size_t n, float *out,
                               size_t stride)
{
    struct esr_pe_rows rows;
    rows.n = n;
    rows.in_stride = 3;
    rows.out_stride = stride;
    esr_pe_fwd(pe, &rows, in, out);
}

#endif
