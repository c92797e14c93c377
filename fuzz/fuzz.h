/* What every harness shares: the limits it runs under and the contract it checks on a loader's
 * answer. A harness aborts (a finding) when a loader breaks its contract, not only on a crash. */
#ifndef ESR_FUZZ_H
#define ESR_FUZZ_H

#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>

#include "core/error.h"
#include "core/limits.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* libFuzzer stops at 2 GiB of memory: images up to 4 Mpixel (64 MiB as float RGBA) and models up
 * to 256 MiB keep every accepted input well inside it, and the limits themselves get fuzzed. */
static inline void fuzz_setup(void)
{
    static const struct esr_limits limits = {(size_t)1 << 22, (size_t)256 << 20};
    esr_limits_set(&limits);
    esr_error_clear();
}

/* A refusal must say why; the message is cleared for the next input. */
static inline void fuzz_done(int status)
{
    if (status != ESR_OK && !esr_error_message()[0])
        abort();
    esr_error_clear();
}

#endif
