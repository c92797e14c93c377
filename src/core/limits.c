#include "core/limits.h"

#include <stdint.h>
#include <stdio.h>

static struct esr_limits limits = {(size_t)1 << 28, 0};

const struct esr_limits *esr_limits(void) { return &limits; }

void esr_limits_set(const struct esr_limits *l) { limits = *l; }

size_t esr_limits_memory(void)
{
    if (limits.memory_bytes)
        return limits.memory_bytes;
    FILE *f = fopen("/proc/meminfo", "r");
    if (!f)
        return SIZE_MAX;
    char line[128];
    unsigned long long kib = 0;
    while (fgets(line, sizeof line, f) && sscanf(line, "MemAvailable: %llu kB", &kib) != 1)
        ;
    fclose(f);
    return kib ? (size_t)kib * 1024 : SIZE_MAX;
}
