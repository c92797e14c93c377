/* mkdir -p (saying what it made, so a failed command can take it back), output folders cleared
 * of a killed run's leftovers, and the lock a training holds on its run folder. */
#include "io/dir.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/error.h"
#include "io/dataset.h"
#include "io/stale.h"

/* Makes one folder; *made = 1 when this call created it. */
static int make_one(const char *path, int *made)
{
    struct stat st;
    *made = 0;
    if (mkdir(path, 0777) == 0) {
        *made = 1;
        return ESR_OK;
    }
    int err = errno;
    if (err == EEXIST && stat(path, &st) == 0 && S_ISDIR(st.st_mode))
        return ESR_OK;
    return ESR_FAIL("cannot create directory '%s': %s", path,
                    err == EEXIST ? "a file of that name exists" : strerror(err));
}

/* 1 when some component of path is "..": its folders cannot be told apart by their text. */
static int has_dotdot(const char *path)
{
    for (const char *c = path; *c;) {
        const size_t w = strcspn(c, "/");
        if (w == 2 && c[0] == '.' && c[1] == '.')
            return 1;
        c += w;
        while (*c == '/')
            c++;
    }
    return 0;
}

int esr_dir_create_made(const char *path, char *made, size_t made_size)
{
    char buf[ESR_PATH_MAX];
    size_t len = strlen(path);
    if (made && made_size)
        made[0] = '\0';
    if (len == 0 || len >= sizeof buf)
        return ESR_FAIL("cannot create directory '%s': empty or too long path", path);
    /* what was made is tracked only where the text names each folder once (no ".."), and in
     * full: a path with ".." or a record cut short would take back folders that were there */
    const int track = made && made_size > len && !has_dotdot(path);
    memcpy(buf, path, len + 1);
    /* Every prefix ending before a '/' is a parent; the leading '/' of an absolute path is not. */
    for (size_t i = 1; i <= len; i++) {
        if (i < len && (buf[i] != '/' || buf[i - 1] == '/'))
            continue;
        buf[i] = '\0';
        int created = 0;
        int status = make_one(buf, &created);
        if (status == ESR_OK && created && track && !made[0])
            memcpy(made, buf, i + 1);
        if (i < len)
            buf[i] = '/';
        ESR_TRY(status);
    }
    return ESR_OK;
}

int esr_dir_create(const char *path)
{
    return esr_dir_create_made(path, NULL, 0);
}

void esr_dir_remove_made(const char *path, const char *made)
{
    const size_t top = made ? strlen(made) : 0;
    if (top == 0 || strncmp(path, made, top) != 0 || (path[top] && path[top] != '/'))
        return;
    char buf[ESR_PATH_MAX];
    snprintf(buf, sizeof buf, "%s", path);
    /* from the innermost folder outwards, up to and including `made`: one that does not exist
     * (a failure before it was made) is passed over; one that is not empty stops the walk (its
     * parents are not empty either) */
    for (;;) {
        size_t len = strlen(buf);
        while (len > top && buf[len - 1] == '/')
            buf[--len] = '\0';
        if (rmdir(buf) != 0 && errno != ENOENT)
            return;
        if (len <= top)
            return;
        char *slash = strrchr(buf, '/');
        if (!slash || (size_t)(slash - buf) < top)
            return;
        *slash = '\0';
    }
}

int esr_dir_prepare_output_made(const char *path, char *made, size_t made_size)
{
    ESR_TRY(esr_dir_create_made(path, made, made_size));
    if (access(path, W_OK | X_OK) != 0)
        return ESR_FAIL("cannot write into the output folder %s: %s", path, strerror(errno));
    return esr_stale_sweep(path, NULL);
}

int esr_dir_prepare_output(const char *path)
{
    return esr_dir_prepare_output_made(path, NULL, 0);
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

int esr_dir_lock(const char *dir, const char *what, int *fd_out)
{
    char path[ESR_PATH_MAX];
    *fd_out = -1;
    if (snprintf(path, sizeof path, "%s/.esr.lock", dir) >= (int)sizeof path)
        return ESR_FAIL("path too long: '%s'", dir);
    /* read-only is all flock needs (a lock file left read-only by another user still locks) */
    const int fd = open(path, O_RDONLY | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0)
        return ESR_OK; /* a folder that cannot hold it: unlocked; its writes will say why */
    if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
        const int e = errno;
        close(fd);
        if (e == EWOULDBLOCK)
            return ESR_FAIL("%s is in use by another esr %s (two would overwrite each other's "
                            "checkpoints); wait for it or use another folder", dir, what);
        return ESR_OK; /* a file system without flock (some network mounts): unlocked */
    }
    *fd_out = fd;
    return ESR_OK;
}

void esr_dir_unlock(int fd)
{
    if (fd >= 0)
        close(fd); /* releases the lock */
}

int esr_dir_list_entries(const char *dir, char *names, size_t n)
{
    if (names && n)
        names[0] = '\0';
    DIR *d = opendir(dir);
    if (!d)
        return 0;
    int count = 0;
    for (struct dirent *e; (e = readdir(d));) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, "..") || !strcmp(e->d_name, ".esr.lock"))
            continue;
        count++;
        if (names && n) {
            const size_t len = strlen(names);
            if (count <= 6 && len + strlen(e->d_name) + 8 < n)
                snprintf(names + len, n - len, "%s%s", len ? ", " : "", e->d_name);
            else if (count == 7 && len + 6 < n)
                snprintf(names + len, n - len, ", ...");
        }
    }
    closedir(d);
    return count;
}
