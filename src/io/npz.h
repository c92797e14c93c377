/* NumPy's .npz archives (np.savez, np.savez_compressed): a zip file with one .npy entry per array,
 * named "<key>.npy". The zip container is libzip's (stored and deflated entries); the .npy inside
 * is io/npy.h's. */
#ifndef ESR_IO_NPZ_H
#define ESR_IO_NPZ_H

#include <stddef.h>

#include "io/npy.h"

struct zip; /* libzip's archive */

struct esr_npz {
    struct zip *zip;
    char name[1024]; /* the file, for messages */
};

/* Opens path; fails naming it when it is missing or not a zip archive. */
int esr_npz_open(const char *path, struct esr_npz *z);
/* The same over size bytes in memory (not copied: they must outlive z); name stands for the
 * file in messages. */
int esr_npz_open_buffer(const void *bytes, size_t size, const char *name, struct esr_npz *z);
void esr_npz_close(struct esr_npz *z);

/* Number of entries, and entry i's name with its ".npy" cut off (NULL when it has none). */
int esr_npz_count(const struct esr_npz *z);
int esr_npz_key(const struct esr_npz *z, int i, char *key, size_t n);

/* 1 when the archive holds the array `key` ("world_mat_0" for the entry "world_mat_0.npy"). */
int esr_npz_has(const struct esr_npz *z, const char *key);

/* Reads array `key`; fails naming the file and the key when it is absent, larger than the memory
 * budget, truncated in the archive, or not a valid .npy (npy.h). */
int esr_npz_read(const struct esr_npz *z, const char *key, struct esr_npy_array *out);

/* Reads array `key` of shape exactly (rows, cols) into out[rows * cols] (row-major); any other
 * shape is refused naming the key and both shapes. */
int esr_npz_read_matrix(const struct esr_npz *z, const char *key, int rows, int cols, double *out);

#endif
