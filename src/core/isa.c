#include "core/isa.h"

#include <stdlib.h>
#include <string.h>

static int parse(const char *text)
{
    if (!text || !*text || !strcmp(text, "avx512"))
        return ESR_ISA_AVX512;
    if (!strcmp(text, "avx2"))
        return ESR_ISA_AVX2;
    if (!strcmp(text, "generic"))
        return ESR_ISA_GENERIC;
    return -1;
}

enum esr_isa esr_isa_cap(void)
{
    /* read once; a race between threads reads the same environment and stores the same value */
    static int cap = -2;
    if (cap == -2) {
        const int v = parse(getenv("ESR_MAX_ISA"));
        cap = v < 0 ? ESR_ISA_AVX512 : v;
    }
    return (enum esr_isa)cap;
}

int esr_isa_cap_valid(void) { return parse(getenv("ESR_MAX_ISA")) < 0 ? -1 : 0; }

const char *esr_isa_name(enum esr_isa isa)
{
    static const char *const names[] = {"generic", "avx2", "avx512"};
    return (unsigned)isa <= ESR_ISA_AVX512 ? names[isa] : "?";
}
