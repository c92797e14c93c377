#include "io/file.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/error.h"
#include "io/stale.h"

int esr_file_read_all(const char *path, unsigned char **data, size_t *size)
{
    *data = NULL;
    *size = 0;
    struct stat st;
    /* before opening: opening a FIFO for reading waits for a writer, forever */
    if (stat(path, &st) == 0 && !S_ISREG(st.st_mode))
        return ESR_FAIL("'%s' is not a regular file", path);
    FILE *f = fopen(path, "rb");
    if (!f)
        return ESR_FAIL("cannot open '%s': %s", path, strerror(errno));
    if (fstat(fileno(f), &st) != 0 || !S_ISREG(st.st_mode)) {
        fclose(f);
        return ESR_FAIL("'%s' is not a regular file", path);
    }
    size_t n = (size_t)st.st_size;
    unsigned char *buf = malloc(n + 1);
    if (!buf) {
        fclose(f);
        return ESR_FAIL("out of memory reading '%s' (%zu bytes)", path, n);
    }
    size_t got = fread(buf, 1, n, f);
    int read_error = ferror(f);
    fclose(f);
    if (read_error || got != n) {
        free(buf);
        return ESR_FAIL("read error on '%s'", path);
    }
    if (n == 0) {
        free(buf);
        return ESR_FAIL("'%s' is empty", path);
    }
    buf[n] = '\0';
    *data = buf;
    *size = n;
    return ESR_OK;
}

/* Creates esr_file_write_atomic's temporary file for path: its name in tmp, its open
 * descriptor in *fd. */
static int open_temp_for(const char *path, char tmp[4096], int *fd)
{
    char prefix[4096];
    if (snprintf(prefix, sizeof prefix, "%s.tmp-", path) >= (int)sizeof prefix)
        return ESR_FAIL("path too long: '%s'", path);
    ESR_TRY(esr_stale_template(tmp, 4096, prefix));
    *fd = mkstemp(tmp);
    if (*fd < 0)
        return ESR_FAIL("cannot create a temporary file next to '%s': %s", path, strerror(errno));
    return ESR_OK;
}

int esr_file_check_writable(const char *path)
{
    char tmp[4096];
    int fd = -1;
    ESR_TRY(open_temp_for(path, tmp, &fd));
    close(fd);
    unlink(tmp);
    struct stat st;
    if (stat(path, &st) == 0 && S_ISDIR(st.st_mode))
        return ESR_FAIL("cannot write '%s': it is a directory", path);
    return ESR_OK;
}

int esr_file_write_atomic(const char *path, const void *data, size_t size)
{
    char tmp[4096];
    int fd = -1;
    ESR_TRY(open_temp_for(path, tmp, &fd));
    fchmod(fd, 0644); /* mkstemp creates 0600; outputs are meant to be shared */
    FILE *f = fdopen(fd, "wb");
    if (!f) {
        close(fd);
        unlink(tmp);
        return ESR_FAIL("cannot open temporary file for '%s': %s", path, strerror(errno));
    }
    size_t put = fwrite(data, 1, size, f);
    int write_errno = errno;
    int flushed = fflush(f) == 0 && fsync(fileno(f)) == 0;
    if (!flushed)
        write_errno = errno;
    int closed = fclose(f) == 0;
    if (!closed)
        write_errno = errno;
    if (put != size || !flushed || !closed) {
        unlink(tmp);
        return ESR_FAIL("cannot write '%s': %s", path, strerror(write_errno));
    }
    if (rename(tmp, path) != 0) {
        int e = errno;
        unlink(tmp);
        return ESR_FAIL("cannot rename temporary file to '%s': %s", path, strerror(e));
    }
    return ESR_OK;
}

int esr_file_copy(const char *src, const char *dst)
{
    unsigned char *data;
    size_t size;
    ESR_TRY(esr_file_read_all(src, &data, &size));
    int status = esr_file_write_atomic(dst, data, size);
    free(data);
    return status;
}

int esr_file_exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISREG(st.st_mode);
}
