/* Adam and its sparse (masked) variant over flat ranges; see nn/adam.h for the choices. */
#include "nn/adam.h"

#include <math.h>
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

/* The per-entry update; `sparse` is constant per call so the branch is hoisted. */
ESR_HOT static void adam_range(float *ESR_RESTRICT w, const float *ESR_RESTRICT g,
                               float *ESR_RESTRICT m, float *ESR_RESTRICT v, size_t n, float b1,
                               float b2, float step, float inv_sqrt_bc2, float eps, int sparse)
{
    for (size_t i = 0; i < n; i++) {
        float gi = g[i];
        if (sparse && gi == 0.0f)
            continue;
        float mi = b1 * m[i] + (1.0f - b1) * gi;
        float vi = b2 * v[i] + (1.0f - b2) * gi * gi;
        m[i] = mi;
        v[i] = vi;
        w[i] -= step * mi / (sqrtf(vi) * inv_sqrt_bc2 + eps);
    }
}

void esr_adam_step(const struct esr_adam_hp *hp, long t, struct esr_adam *a, float *w,
                   const float *g, size_t offset, size_t n)
{
    if (t < 1)
        t = 1;
    double bc1 = 1.0 - pow(hp->beta1, (double)t);
    double bc2 = 1.0 - pow(hp->beta2, (double)t);
    float step = (float)(hp->lr / bc1);
    float inv_sqrt_bc2 = (float)(1.0 / sqrt(bc2));
    const size_t chunk = 1 << 14;
    size_t n_chunks = (n + chunk - 1) / chunk;
#pragma omp parallel for schedule(static) if (n_chunks > 1)
    for (size_t c = 0; c < n_chunks; c++) {
        size_t b = offset + c * chunk, len = c + 1 < n_chunks ? chunk : n - c * chunk;
        adam_range(w + b, g + b, a->m + b, a->v + b, len, hp->beta1, hp->beta2, step,
                   inv_sqrt_bc2, hp->eps, hp->sparse);
    }
}
