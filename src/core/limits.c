#include "core/limits.h"

#include <malloc.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"

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

/* "1.234 GiB" or "56.7 MiB" */
static const char *human(size_t bytes, char *buf, size_t n)
{
    if (bytes >= (size_t)1 << 30)
        snprintf(buf, n, "%.3f GiB", (double)bytes / (double)(1u << 30));
    else
        snprintf(buf, n, "%.1f MiB", (double)bytes / (double)(1u << 20));
    return buf;
}

int esr_limits_check_memory(size_t held, size_t need, const char *what)
{
    char a[32], b[32], c[32];
    if (limits.memory_bytes) {
        if (need <= limits.memory_bytes && held <= limits.memory_bytes - need)
            return ESR_OK;
        return ESR_FAIL("%s needs %s; with the %s already held that is more than the memory limit "
                        "of %s",
                        what, human(need, a, sizeof a), human(held, b, sizeof b),
                        human(limits.memory_bytes, c, sizeof c));
    }
    const size_t have = esr_limits_memory();
    if (need <= have)
        return ESR_OK;
    return ESR_FAIL("%s needs %s, more than the %s of memory available", what, human(need, a, sizeof a),
                    human(have, b, sizeof b));
}

size_t esr_limits_parse_size(const char *text)
{
    char *end;
    const double v = strtod(text, &end);
    double unit = 1.0;
    const char *suffixes = "KMGT", *at = *end ? strchr(suffixes, *end) : NULL;
    if (at) {
        unit = pow(1024.0, (double)(at - suffixes + 1));
        end++;
    }
    if (end == text || *end != '\0' || !isfinite(v) || v <= 0.0 || v * unit >= 0x1p63)
        return 0;
    const double bytes = floor(v * unit);
    return bytes >= 1.0 ? (size_t)bytes : 0;
}

size_t esr_heap_in_use(void)
{
    const struct mallinfo2 mi = mallinfo2();
    return mi.uordblks + mi.hblkhd;
}
