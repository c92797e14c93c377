/* mkdir -p, and output folders cleared of a killed run's leftovers. */
#include "io/dir.h"

#include <errno.h>
#include <string.h>
#include <sys/stat.h>

#include "core/error.h"
#include "io/dataset.h"
#include "io/stale.h"

static int make_one(const char *path)
{
    struct stat st;
    if (mkdir(path, 0777) == 0)
        return ESR_OK;
    int err = errno;
    if (err == EEXIST && stat(path, &st) == 0 && S_ISDIR(st.st_mode))
        return ESR_OK;
    return ESR_FAIL("cannot create directory '%s': %s", path,
                    err == EEXIST ? "a file of that name exists" : strerror(err));
}

int esr_dir_create(const char *path)
{
    char buf[ESR_PATH_MAX];
    size_t len = strlen(path);
    if (len == 0 || len >= sizeof buf)
        return ESR_FAIL("cannot create directory '%s': empty or too long path", path);
    memcpy(buf, path, len + 1);
    /* Every prefix ending before a '/' is a parent; the leading '/' of an absolute path is not. */
    for (size_t i = 1; i < len; i++) {
        if (buf[i] != '/' || buf[i - 1] == '/')
            continue;
        buf[i] = '\0';
        int status = make_one(buf);
        buf[i] = '/';
        ESR_TRY(status);
    }
    return make_one(buf);
}

int esr_dir_prepare_output(const char *path)
{
    ESR_TRY(esr_dir_create(path));
    return esr_stale_sweep(path, NULL);
}

int esr_dir_check_run(const char *run)
{
    struct stat st;
    if (stat(run, &st) != 0)
        return ESR_FAIL("run directory '%s' does not exist", run);
    if (!S_ISDIR(st.st_mode))
        return ESR_FAIL("'%s' is not a run directory (it is a file)", run);
    return ESR_OK;
}
