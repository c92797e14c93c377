/* Finding and removing a dead writer's temporary files and staging folders (see stale.h). */
#define _XOPEN_SOURCE 700
#include "io/stale.h"

#include <dirent.h>
#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/error.h"
#include "io/staging.h"

int esr_stale_template(char *buf, size_t n, const char *prefix)
{
    int w = snprintf(buf, n, "%s%ld-XXXXXX", prefix, (long)getpid());
    if (w < 0 || (size_t)w >= n)
        return ESR_FAIL("path too long: '%s'", prefix);
    return ESR_OK;
}

/* The writer's pid when name ends in one of the temporary forms "<marker><pid>-XXXXXX", else 0. */
static long writer_pid(const char *name)
{
    static const char *const markers[] = {".tmp-", ".partial-", ".old-"};
    for (size_t i = 0; i < sizeof markers / sizeof markers[0]; i++) {
        const char *m = strstr(name, markers[i]), *last = NULL;
        for (; m; m = strstr(m + 1, markers[i]))
            last = m;
        if (!last)
            continue;
        const char *p = last + strlen(markers[i]);
        char *end;
        errno = 0;
        long pid = strtol(p, &end, 10);
        if (errno || end == p || pid <= 0 || *end != '-' || strlen(end + 1) != 6)
            continue;
        if (i > 0 && name[0] != '.') /* staging folders are hidden siblings */
            continue;
        return pid;
    }
    return 0;
}

static int process_alive(long pid)
{
    return pid == (long)getpid() || kill((pid_t)pid, 0) == 0 || errno == EPERM;
}

int esr_stale_sweep(const char *dir, int *removed)
{
    if (removed)
        *removed = 0;
    DIR *d = opendir(dir);
    if (!d)
        return errno == ENOENT || errno == ENOTDIR ? ESR_OK
                                                   : ESR_FAIL("cannot read directory '%s': %s", dir, strerror(errno));
    int rc = ESR_OK;
    struct dirent *e;
    while (rc == ESR_OK && (e = readdir(d))) {
        const long pid = writer_pid(e->d_name);
        if (pid == 0 || process_alive(pid))
            continue;
        char path[4096];
        if (snprintf(path, sizeof path, "%s/%s", dir, e->d_name) >= (int)sizeof path)
            continue;
        struct stat st;
        if (lstat(path, &st) != 0)
            continue; /* gone meanwhile */
        if (S_ISDIR(st.st_mode))
            rc = esr_remove_tree(path);
        else if (unlink(path) != 0 && errno != ENOENT)
            rc = ESR_FAIL("cannot remove the stale temporary file '%s': %s", path, strerror(errno));
        if (rc == ESR_OK && removed)
            (*removed)++;
    }
    closedir(d);
    return rc;
}
