/* NumPy arrays: a bare .npy (src/io/npy.c) when the input starts with the .npy magic, else an
 * .npz archive (src/io/npz.c through libzip) whose every entry is read, and its camera arrays as
 * `esr import dtu` reads them (4x4 world_mat_0, scale_mat_0). */
#include <string.h>

#include "fuzz.h"
#include "io/npz.h"

/* An accepted array's count is its shape's product. */
static void check_array(const struct esr_npy_array *a)
{
    size_t count = 1;
    for (int i = 0; i < a->header.ndim; i++)
        count *= a->header.shape[i];
    if (count != a->header.count || (a->header.item_size != 4 && a->header.item_size != 8))
        abort();
}

static void read_archive(const uint8_t *data, size_t size)
{
    struct esr_npz z;
    int status = esr_npz_open_buffer(data, size, "fuzz.npz", &z);
    fuzz_done(status);
    if (status != ESR_OK)
        return;
    for (int i = 0; i < esr_npz_count(&z) && i < 64; i++) {
        char key[128];
        if (esr_npz_key(&z, i, key, sizeof key) != ESR_OK)
            continue;
        struct esr_npy_array a;
        status = esr_npz_read(&z, key, &a);
        if (status == ESR_OK) {
            check_array(&a);
            esr_npy_free(&a);
        }
        fuzz_done(status);
    }
    static const char *const keys[] = {"world_mat_0", "scale_mat_0"};
    for (int i = 0; i < 2; i++) {
        double m[16];
        fuzz_done(esr_npz_read_matrix(&z, keys[i], 4, 4, m));
    }
    esr_npz_close(&z);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fuzz_setup();
    if (size >= 6 && !memcmp(data, "\x93NUMPY", 6)) {
        struct esr_npy_array a;
        int status = esr_npy_parse(data, size, "fuzz.npy", &a);
        if (status == ESR_OK) {
            check_array(&a);
            esr_npy_free(&a);
        }
        fuzz_done(status);
    } else {
        read_archive(data, size);
    }
    return 0;
}
