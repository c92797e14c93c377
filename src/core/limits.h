/* Limits checked before allocating what untrusted input asks for: the pixels an image header
 * claims and the memory a model configuration needs. One process-wide setting: the defaults
 * suit the CLI; the fuzz harnesses lower them to stay under libFuzzer's 2 GiB memory cap. */
#ifndef ESR_CORE_LIMITS_H
#define ESR_CORE_LIMITS_H

#include <stddef.h>

struct esr_limits {
    size_t image_pixels; /* most pixels (width x height) an image file may claim; default 2^28 */
    size_t memory_bytes; /* most bytes a model may take; 0 (default) = what the system has free */
};

const struct esr_limits *esr_limits(void);
/* Not thread-safe: call once before any loading. */
void esr_limits_set(const struct esr_limits *limits);
/* The model memory budget now: memory_bytes, else MemAvailable from /proc/meminfo (SIZE_MAX
 * when the system does not say). */
size_t esr_limits_memory(void);

#endif
