/* NumPy's .npy array format (numpy/lib/format.py, versions 1.0, 2.0 and 3.0), read strictly: the
 * magic "\x93NUMPY", a version, a header that is a Python dict literal with exactly the keys
 * 'descr', 'fortran_order' and 'shape', then the raw data. esr reads only what camera files hold:
 * little-endian float64 ('<f8') or float32 ('<f4'), C order; anything else is refused naming the
 * array rather than guessed at. */
#ifndef ESR_IO_NPY_H
#define ESR_IO_NPY_H

#include <stddef.h>

#define ESR_NPY_MAX_DIMS 8

/* An array's header: element type and shape. */
struct esr_npy_header {
    int item_size;                 /* 8 ('<f8') or 4 ('<f4') */
    int ndim;                      /* 0 (a scalar) .. ESR_NPY_MAX_DIMS */
    size_t shape[ESR_NPY_MAX_DIMS];
    size_t count;                  /* product of the shape (1 for a scalar) */
    size_t data_offset;            /* bytes from the start of the file to the data */
};

/* A parsed array, its values widened to double, in C (row-major) order. */
struct esr_npy_array {
    struct esr_npy_header header;
    double *data;                  /* header.count values, owned */
};

/* Parses the header of the size bytes at bytes; name stands for the array in messages (e.g.
 * "'cameras_sphere.npz' entry 'world_mat_0'"). Fails on a bad magic or version, a header that
 * runs past the bytes, is not a dict literal of the three keys, a dtype other than '<f8' / '<f4',
 * fortran_order True, or a shape that is not a tuple of non-negative integers. */
int esr_npy_parse_header(const void *bytes, size_t size, const char *name, struct esr_npy_header *h);

/* The header and the data: the bytes after the header must be exactly count x item_size (fewer:
 * truncated; more: trailing bytes). Nothing is allocated before that is checked. */
int esr_npy_parse(const void *bytes, size_t size, const char *name, struct esr_npy_array *out);
void esr_npy_free(struct esr_npy_array *a);

#endif
