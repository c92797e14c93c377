/* Limits checked before allocating what untrusted input asks for: the pixels an image header
 * claims and the memory a model configuration needs. One process-wide setting: the defaults
 * suit the CLI; the fuzz harnesses lower them to stay under libFuzzer's 2 GiB memory cap. */
#ifndef ESR_CORE_LIMITS_H
#define ESR_CORE_LIMITS_H

#include <stddef.h>

struct esr_limits {
    size_t image_pixels; /* most pixels (width x height) an image file may claim; default 2^28 */
    size_t memory_bytes; /* most bytes a run may hold (training rays, models, workspaces); 0
                            (default) = each allocation checked against what the system has free */
};

const struct esr_limits *esr_limits(void);
/* Not thread-safe: call once before any loading. */
void esr_limits_set(const struct esr_limits *limits);
/* The model memory budget now: memory_bytes, else MemAvailable from /proc/meminfo (SIZE_MAX
 * when the system does not say). */
size_t esr_limits_memory(void);
/* Refuses, naming `what`, an allocation of `need` bytes that does not fit: with memory_bytes set,
 * held + need must stay within it (held: what the caller already holds); else need must fit in
 * the memory the system has available now. */
int esr_limits_check_memory(size_t held, size_t need, const char *what);
/* "512M", "2G", "1.5G", "300000000" (bytes; K, M, G, T are powers of 1024) -> bytes; 0 when
 * text is not such a size. */
size_t esr_limits_parse_size(const char *text);
/* Bytes in use through malloc (glibc mallinfo2: heap in use + mmapped chunks), so a workspace's
 * size can be measured while its pages are still untouched; 0 when the allocator does not say
 * (the sanitizers replace it). */
size_t esr_heap_in_use(void);

#endif
