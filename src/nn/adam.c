/* Adam and its sparse (masked) variant over flat ranges; see nn/adam.h for the choices. */
#include "nn/adam.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/simd.h"

int esr_adam_init(struct esr_adam *a, size_t count)
{
    memset(a, 0, sizeof(*a));
    return esr_adam_resize(a, count);
}

void esr_adam_free(struct esr_adam *a)
{
    free(a->m);
    free(a->v);
    memset(a, 0, sizeof(*a));
}

int esr_adam_resize(struct esr_adam *a, size_t count)
{
    if (count <= a->count && a->m)
        return ESR_OK;
    float *m = calloc(count ? count : 1, sizeof(float));
    float *v = calloc(count ? count : 1, sizeof(float));
    if (!m || !v) {
        free(m);
        free(v);
        return ESR_FAIL("out of memory for Adam moments of %zu parameters", count);
    }
    if (a->count) {
        memcpy(m, a->m, a->count * sizeof(float));
        memcpy(v, a->v, a->count * sizeof(float));
    }
    free(a->m);
    free(a->v);
    a->m = m;
    a->v = v;
    a->count = count;
    return ESR_OK;
}

/* One step's coefficients, the same for every entry of a range. */
struct adam_coef {
    float b1, b2;       /* the moments' decay (beta1, beta2) */
    float step;         /* lr / (1 - b1^t): the first moment's bias correction folded in */
    float inv_sqrt_bc2; /* 1 / sqrt(1 - b2^t): the second moment's */
    float eps;
    int sparse;         /* 1: an entry whose gradient is exactly zero is left alone */
};

/* The per-entry update of entry i (the scalar form, for the tail of a range). */
static inline void adam_entry(float *ESR_RESTRICT w, const float *ESR_RESTRICT g,
                              float *ESR_RESTRICT m, float *ESR_RESTRICT v, size_t i,
                              const struct adam_coef *k)
{
    const float b1 = k->b1, b2 = k->b2, step = k->step, inv_sqrt_bc2 = k->inv_sqrt_bc2, eps = k->eps;
    const int sparse = k->sparse;
    float gi = g[i];
    if (sparse && gi == 0.0f)
        return;
    float mi = b1 * m[i] + (1.0f - b1) * gi;
    float vi = b2 * v[i] + (1.0f - b2) * gi * gi;
    m[i] = mi;
    v[i] = vi;
    w[i] -= step * mi / (sqrtf(vi) * inv_sqrt_bc2 + eps);
}

/* The update in blocks of 8 entries, branch-free inside a block so it vectorises (sqrt and divide
 * 8 lanes at a time; adam.c is compiled without errno so sqrtf is the instruction): a sparse
 * entry with a zero gradient computes its update and keeps its old values, which leaves it as
 * untouched as skipping it, and a block whose 8 gradients are all zero (most of a grid away from
 * the batch's rays) is skipped after reading only its gradients. */
ESR_HOT static void adam_range(float *ESR_RESTRICT w, const float *ESR_RESTRICT g,
                               float *ESR_RESTRICT m, float *ESR_RESTRICT v, size_t n,
                               const struct adam_coef *k)
{
    const float b1 = k->b1, b2 = k->b2, step = k->step, inv_sqrt_bc2 = k->inv_sqrt_bc2, eps = k->eps;
    const int sparse = k->sparse;
    size_t i = 0;
    for (; i + 8 <= n; i += 8) {
        if (sparse) {
            uint32_t any = 0; /* +0 and -0 alike, as gi == 0 */
            for (int j = 0; j < 8; j++) {
                uint32_t bits;
                memcpy(&bits, g + i + j, sizeof bits);
                any |= bits & 0x7fffffffu;
            }
            if (!any)
                continue;
        }
        for (int j = 0; j < 8; j++) {
            const float gi = g[i + j], m0 = m[i + j], v0 = v[i + j], w0 = w[i + j];
            const float mi = b1 * m0 + (1.0f - b1) * gi;
            const float vi = b2 * v0 + (1.0f - b2) * gi * gi;
            const float wi = w0 - step * mi / (sqrtf(vi) * inv_sqrt_bc2 + eps);
            const int keep = sparse && gi == 0.0f;
            m[i + j] = keep ? m0 : mi;
            v[i + j] = keep ? v0 : vi;
            w[i + j] = keep ? w0 : wi;
        }
    }
    for (; i < n; i++)
        adam_entry(w, g, m, v, i, k);
}

void esr_adam_step(const struct esr_adam_hp *hp, long t, struct esr_adam *a, float *w,
                   const float *g, size_t offset, size_t n)
{
    if (t < 1)
        t = 1;
    double bc1 = 1.0 - pow(hp->beta1, (double)t);
    double bc2 = 1.0 - pow(hp->beta2, (double)t);
    const struct adam_coef k = {hp->beta1, hp->beta2, (float)(hp->lr / bc1), (float)(1.0 / sqrt(bc2)),
                                hp->eps, hp->sparse};
    const size_t chunk = 1 << 14;
    size_t n_chunks = (n + chunk - 1) / chunk;
#pragma omp parallel for schedule(static) if (n_chunks > 1)
    for (size_t c = 0; c < n_chunks; c++) {
        size_t b = offset + c * chunk, len = c + 1 < n_chunks ? chunk : n - c * chunk;
        adam_range(w + b, g + b, a->m + b, a->v + b, len, &k);
    }
}
