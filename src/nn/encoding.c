/* Positional encoding, forward and backward, parallel over rows. */
#include "nn/encoding.h"

/* The frequencies double, so each sine and cosine pair follows from the last by the double-angle
 * formulas (sin 2a = 2 sin a cos a, cos 2a = (cos a - sin a)(cos a + sin a)): one libm call per
 * scalar instead of 2F. The error grows about twofold per octave: ~1e-6 at the fifth, far below
 * what the MLPs resolve. */
ESR_INLINE void pe_double(float *s, float *c)
{
    const float s2 = 2.0f * *s * *c;
    *c = (*c - *s) * (*c + *s);
    *s = s2;
}

/* PE of one scalar into its 1 + 2F slots, `step` floats apart. */
ESR_INLINE void pe_scalar_fwd(float x, int n_freqs, float *out, int step)
{
    out[0] = x;
    float s = sinf(x), c = cosf(x);
    for (int k = 0; k < n_freqs; k++, pe_double(&s, &c)) {
        out[(1 + 2 * k) * step] = s;
        out[(2 + 2 * k) * step] = c;
    }
}

/* d loss/dx of one scalar from the d_out slots of its encoding. */
ESR_INLINE float pe_scalar_bwd(float x, int n_freqs, const float *d_out, int step)
{
    float d = d_out[0], f = 1.0f, s = sinf(x), c = cosf(x);
    for (int k = 0; k < n_freqs; k++, f *= 2.0f, pe_double(&s, &c))
        d += f * (c * d_out[(1 + 2 * k) * step] - s * d_out[(2 + 2 * k) * step]);
    return d;
}

void esr_pe_fwd(const struct esr_pe *pe, const struct esr_pe_rows *rows, const float *in,
                float *out)
{
    const int nd = pe->n_dims, nf = pe->n_freqs;
#pragma omp parallel for schedule(static) if (rows->n > 4096)
    for (size_t r = 0; r < rows->n; r++)
        for (int d = 0; d < nd; d++)
            pe_scalar_fwd(in[r * rows->in_stride + d], nf, out + r * rows->out_stride + d, nd);
}

void esr_pe_bwd(const struct esr_pe *pe, const struct esr_pe_rows *rows, const float *in,
                const float *d_out, float *d_in, enum esr_nn_grad_mode mode)
{
    if (mode == ESR_NN_GRAD_IGNORE)
        return;
    const int nd = pe->n_dims, nf = pe->n_freqs;
#pragma omp parallel for schedule(static) if (rows->n > 4096)
    for (size_t r = 0; r < rows->n; r++)
        for (int d = 0; d < nd; d++) {
            float g = pe_scalar_bwd(in[r * rows->in_stride + d], nf,
                                    d_out + r * rows->out_stride + d, nd);
            float *dst = d_in + r * rows->in_stride + d;
            *dst = mode == ESR_NN_GRAD_ACCUMULATE ? *dst + g : g;
        }
}
