/* Flat parameter store: growth keeps offsets valid by copying into a larger aligned buffer. */
#include "nn/params.h"

#include <stdlib.h>
#include <string.h>

#include "core/error.h"

static size_t round_up(size_t n, size_t a) { return (n + a - 1) / a * a; }

/* 64-byte aligned, zeroed floats; NULL on failure. */
static float *alloc_floats(size_t n)
{
    size_t bytes = round_up(n ? n : 1, ESR_NN_PARAM_ALIGN) * sizeof(float);
    float *x = aligned_alloc(64, bytes);
    if (x)
        memset(x, 0, bytes);
    return x;
}

/* Reallocates w and g to hold `capacity` floats, keeping the first `count`. */
static int params_grow(struct esr_nn_params *p, size_t capacity)
{
    float *w = alloc_floats(capacity), *g = alloc_floats(capacity);
    if (!w || !g) {
        free(w);
        free(g);
        return ESR_FAIL("out of memory for %zu parameters", capacity);
    }
    if (p->count) {
        memcpy(w, p->w, p->count * sizeof(float));
        memcpy(g, p->g, p->count * sizeof(float));
    }
    free(p->w);
    free(p->g);
    p->w = w;
    p->g = g;
    p->capacity = capacity;
    return ESR_OK;
}

int esr_nn_params_init(struct esr_nn_params *p, size_t reserve)
{
    memset(p, 0, sizeof(*p));
    return params_grow(p, round_up(reserve, ESR_NN_PARAM_ALIGN));
}

void esr_nn_params_free(struct esr_nn_params *p)
{
    free(p->w);
    free(p->g);
    memset(p, 0, sizeof(*p));
}

int esr_nn_params_take(struct esr_nn_params *p, size_t n, size_t *offset)
{
    size_t start = round_up(p->count, ESR_NN_PARAM_ALIGN);
    size_t end = start + n;
    if (end < start)
        return ESR_FAIL("parameter count overflow (%zu + %zu)", start, n);
    if (end > p->capacity && !p->count_only) {
        size_t cap = p->capacity * 2 > end ? p->capacity * 2 : end;
        ESR_TRY(params_grow(p, round_up(cap, ESR_NN_PARAM_ALIGN)));
    }
    p->count = end;
    *offset = start;
    return ESR_OK;
}

void esr_nn_params_zero_grad(struct esr_nn_params *p, size_t offset, size_t n)
{
    float *g = p->g + offset;
    const size_t chunk = 1 << 16;
    size_t n_chunks = (n + chunk - 1) / chunk;
#pragma omp parallel for schedule(static) if (n_chunks > 1)
    for (size_t c = 0; c < n_chunks; c++) {
        size_t b = c * chunk, e = b + chunk < n ? b + chunk : n;
        memset(g + b, 0, (e - b) * sizeof(float));
    }
}
