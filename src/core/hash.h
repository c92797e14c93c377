/* 64-bit FNV-1a for fingerprints: what a render was made from (the model, its lights, the
 * camera), so that a changed input makes it stale. Not for security. */
#ifndef ESR_CORE_HASH_H
#define ESR_CORE_HASH_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#define ESR_HASH_INIT 0xcbf29ce484222325ULL

/* h extended by n bytes of data. */
static inline uint64_t esr_hash_bytes(uint64_t h, const void *data, size_t n)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < n; i++)
        h = (h ^ p[i]) * 0x100000001b3ULL;
    return h;
}

/* h extended by n floats, a 32-bit word per step (a model's tens of millions of parameters in
 * tens of milliseconds); the bit patterns are hashed, so -0 and 0 differ. */
static inline uint64_t esr_hash_floats(uint64_t h, const float *v, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        uint32_t w;
        memcpy(&w, v + i, sizeof w);
        h = (h ^ w) * 0x100000001b3ULL;
    }
    return h;
}

#endif
