/* Growable float work buffers: the "free them all, allocate them all at a new size" step that
 * workspaces growing to a high-water mark share, and lists that grow keeping what they hold. */
#ifndef ESR_CORE_BUFFERS_H
#define ESR_CORE_BUFFERS_H

#include <stddef.h>

/* Frees each of the n buffers *bufs[i] and allocates it again with `count` floats. On failure
 * every buffer is NULL and ESR_ERR is returned with a message naming `what`. */
int esr_floats_realloc(float **const *bufs, size_t n, size_t count, const char *what);

/* Grows *v, of *cap floats, to hold at least `need`, its contents kept: the capacity doubles
 * from 4096 until it does. On failure *v and *cap are as they were and ESR_ERR is returned with
 * a message naming `what`. */
int esr_floats_reserve(float **v, size_t *cap, size_t need, const char *what);

#endif
