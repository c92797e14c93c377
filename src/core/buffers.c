/* Growable float work buffers (see buffers.h). */
#include "core/buffers.h"

#include <stdlib.h>

#include "core/error.h"

int esr_floats_realloc(float **const *bufs, size_t n, size_t count, const char *what)
{
    int ok = 1;
    for (size_t i = 0; i < n; i++) {
        free(*bufs[i]);
        ok &= (*bufs[i] = malloc((count ? count : 1) * sizeof(float))) != NULL;
    }
    if (ok)
        return ESR_OK;
    for (size_t i = 0; i < n; i++) {
        free(*bufs[i]);
        *bufs[i] = NULL;
    }
    return ESR_FAIL("%s: out of memory for %zu floats", what, count);
}

int esr_floats_reserve(float **v, size_t *cap, size_t need, const char *what)
{
    if (need <= *cap)
        return ESR_OK;
    size_t c = *cap ? *cap : 4096;
    while (c < need)
        c *= 2;
    float *t = realloc(*v, c * sizeof(float));
    if (!t)
        return ESR_FAIL("out of memory collecting %zu %s", c, what);
    *v = t, *cap = c;
    return ESR_OK;
}
