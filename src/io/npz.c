/* .npz archives through libzip (see npz.h). */
#include "io/npz.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zip.h>

#include "core/error.h"
#include "core/limits.h"
#include "io/file.h"

/* An entry larger than this is refused before it is read: camera files hold a few hundred bytes
 * per array, and a zip's declared sizes are untrusted. */
#define ENTRY_MAX ((zip_uint64_t)1 << 28)

static int open_source(zip_source_t *src, zip_error_t *err, const char *name, struct esr_npz *z)
{
    z->zip = zip_open_from_source(src, ZIP_RDONLY | ZIP_CHECKCONS, err);
    if (!z->zip) {
        int code = zip_error_code_zip(err);
        zip_source_free(src);
        const char *why = code == ZIP_ER_NOENT ? "missing" : code == ZIP_ER_NOZIP ? "not a zip archive (.npz)"
                        : zip_error_strerror(err);
        int status = ESR_FAIL("'%s' is %s%s", name, code == ZIP_ER_NOENT || code == ZIP_ER_NOZIP ? "" : "unreadable: ",
                              why);
        zip_error_fini(err);
        return status;
    }
    zip_error_fini(err);
    return ESR_OK;
}

static int set_name(struct esr_npz *z, const char *name)
{
    memset(z, 0, sizeof *z);
    if (snprintf(z->name, sizeof z->name, "%s", name) >= (int)sizeof z->name)
        return ESR_FAIL("path '%.64s...' is too long", name);
    return ESR_OK;
}

int esr_npz_open(const char *path, struct esr_npz *z)
{
    ESR_TRY(set_name(z, path));
    if (!esr_file_exists(path))
        return ESR_FAIL("'%s' is missing", path);
    zip_error_t err;
    zip_error_init(&err);
    zip_source_t *src = zip_source_file_create(path, 0, -1, &err);
    if (!src) {
        int status = ESR_FAIL("'%s' cannot be opened: %s", path, zip_error_strerror(&err));
        zip_error_fini(&err);
        return status;
    }
    return open_source(src, &err, path, z);
}

int esr_npz_open_buffer(const void *bytes, size_t size, const char *name, struct esr_npz *z)
{
    ESR_TRY(set_name(z, name));
    zip_error_t err;
    zip_error_init(&err);
    zip_source_t *src = zip_source_buffer_create(bytes, size, 0, &err);
    if (!src) {
        int status = ESR_FAIL("'%s': %s", name, zip_error_strerror(&err));
        zip_error_fini(&err);
        return status;
    }
    return open_source(src, &err, name, z);
}

void esr_npz_close(struct esr_npz *z)
{
    if (z->zip)
        zip_discard(z->zip); /* read-only: nothing to write back */
    z->zip = NULL;
}

int esr_npz_count(const struct esr_npz *z)
{
    zip_int64_t n = zip_get_num_entries(z->zip, 0);
    return n < 0 ? 0 : n > 1 << 20 ? 1 << 20 : (int)n;
}

int esr_npz_key(const struct esr_npz *z, int i, char *key, size_t n)
{
    const char *entry = zip_get_name(z->zip, (zip_uint64_t)i, ZIP_FL_ENC_RAW);
    size_t len = entry ? strlen(entry) : 0;
    if (len < 4 || strcmp(entry + len - 4, ".npy") || len - 4 >= n)
        return ESR_ERR;
    memcpy(key, entry, len - 4);
    key[len - 4] = '\0';
    return ESR_OK;
}

static zip_int64_t locate(const struct esr_npz *z, const char *key)
{
    char entry[256];
    if (snprintf(entry, sizeof entry, "%s.npy", key) >= (int)sizeof entry)
        return -1;
    return zip_name_locate(z->zip, entry, ZIP_FL_ENC_RAW);
}

int esr_npz_has(const struct esr_npz *z, const char *key)
{
    return locate(z, key) >= 0;
}

/* The whole entry `index` in a new buffer of exactly its declared size. */
static int read_entry(const struct esr_npz *z, zip_int64_t index, const char *key, unsigned char **data,
                      size_t *size)
{
    zip_stat_t st;
    if (zip_stat_index(z->zip, (zip_uint64_t)index, 0, &st) != 0 || !(st.valid & ZIP_STAT_SIZE))
        return ESR_FAIL("'%s': entry '%s.npy' cannot be read: %s", z->name, key, zip_strerror(z->zip));
    if (st.size > ENTRY_MAX || st.size > esr_limits_memory())
        return ESR_FAIL("'%s': entry '%s.npy' claims %llu bytes, more than esr reads", z->name, key,
                        (unsigned long long)st.size);
    zip_file_t *f = zip_fopen_index(z->zip, (zip_uint64_t)index, 0);
    if (!f)
        return ESR_FAIL("'%s': entry '%s.npy' cannot be opened: %s", z->name, key, zip_strerror(z->zip));
    unsigned char *buf = malloc(st.size ? (size_t)st.size : 1);
    zip_int64_t got = buf ? zip_fread(f, buf, st.size) : -1;
    int status = ESR_OK;
    if (!buf)
        status = ESR_FAIL("'%s': out of memory reading '%s.npy'", z->name, key);
    else if (got < 0)
        status = ESR_FAIL("'%s': entry '%s.npy' is corrupt: %s", z->name, key, zip_file_strerror(f));
    else if ((zip_uint64_t)got != st.size)
        status = ESR_FAIL("'%s': entry '%s.npy' is truncated (%lld of %llu bytes)", z->name, key, (long long)got,
                          (unsigned long long)st.size);
    zip_fclose(f);
    if (status != ESR_OK) {
        free(buf);
        return status;
    }
    *data = buf;
    *size = (size_t)st.size;
    return ESR_OK;
}

int esr_npz_read(const struct esr_npz *z, const char *key, struct esr_npy_array *out)
{
    memset(out, 0, sizeof *out);
    zip_int64_t index = locate(z, key);
    if (index < 0)
        return ESR_FAIL("'%s' has no array '%s'", z->name, key);
    unsigned char *data = NULL;
    size_t size = 0;
    ESR_TRY(read_entry(z, index, key, &data, &size));
    char name[1200];
    snprintf(name, sizeof name, "'%s' array '%s'", z->name, key);
    int status = esr_npy_parse(data, size, name, out);
    free(data);
    return status;
}

int esr_npz_read_matrix(const struct esr_npz *z, const char *key, int rows, int cols, double *out)
{
    struct esr_npy_array a;
    ESR_TRY(esr_npz_read(z, key, &a));
    const struct esr_npy_header *h = &a.header;
    int status = ESR_OK;
    if (h->ndim != 2 || h->shape[0] != (size_t)rows || h->shape[1] != (size_t)cols) {
        char shape[128] = "(";
        for (int i = 0; i < h->ndim; i++)
            snprintf(shape + strlen(shape), sizeof shape - strlen(shape), "%s%zu", i ? ", " : "", h->shape[i]);
        snprintf(shape + strlen(shape), sizeof shape - strlen(shape), "%s)", h->ndim == 1 ? "," : "");
        status = ESR_FAIL("'%s' array '%s' has shape %s; expected (%d, %d)", z->name, key, shape, rows, cols);
    } else {
        memcpy(out, a.data, (size_t)rows * (size_t)cols * sizeof *out);
    }
    esr_npy_free(&a);
    return status;
}
