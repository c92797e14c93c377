/* Growable float work buffers: the "free them all, allocate them all at a new size" step that
 * workspaces growing to a high-water mark share. */
#ifndef ESR_CORE_BUFFERS_H
#define ESR_CORE_BUFFERS_H

#include <stddef.h>

/* Frees each of the n buffers *bufs[i] and allocates it again with `count` floats. On failure
 * every buffer is NULL and ESR_ERR is returned with a message naming `what`. */
int esr_floats_realloc(float **const *bufs, size_t n, size_t count, const char *what);

#endif
