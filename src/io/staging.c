#define _XOPEN_SOURCE 700
#include "io/staging.h"

#include <dirent.h>
#include <errno.h>
#include <ftw.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/error.h"
#include "io/dir.h"
#include "io/stale.h"

static int dir_is_empty(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        return 0;
    struct dirent *e;
    int empty = 1;
    while (empty && (e = readdir(d)))
        if (strcmp(e->d_name, ".") && strcmp(e->d_name, ".."))
            empty = 0;
    closedir(d);
    return empty;
}

int esr_path_resolve(const char *path, char *out, size_t n)
{
    char abs[PATH_MAX], head[PATH_MAX], resolved[PATH_MAX], cwd[PATH_MAX];
    if (path[0] != '/' && !getcwd(cwd, sizeof cwd))
        return ESR_FAIL("cannot resolve '%s': %s", path, strerror(errno));
    const int la = path[0] == '/' ? snprintf(abs, sizeof abs, "%s", path)
                                  : snprintf(abs, sizeof abs, "%s/%s", cwd, path);
    if (la < 0 || (size_t)la >= sizeof abs)
        return ESR_FAIL("path '%s' is too long", path);
    size_t cut = (size_t)la;
    for (;;) { /* abs[0..cut) is tried; "/" always resolves */
        memcpy(head, abs, cut);
        head[cut] = '\0';
        if (realpath(cut ? head : "/", resolved))
            break;
        while (cut > 0 && abs[cut - 1] != '/')
            cut--;
        if (cut > 0)
            cut--; /* and the slash before that component */
    }
    /* the part that does not exist yet, component by component: "." dropped, ".." takes the
     * last component off (no link can hide below a folder that does not exist) */
    if (strlen(resolved) >= n)
        return ESR_FAIL("path '%s' is too long", path);
    strcpy(out, resolved);
    size_t len = strlen(out);
    for (const char *c = abs + cut; *c;) {
        while (*c == '/')
            c++;
        const size_t w = strcspn(c, "/");
        if (w == 0)
            break;
        if (w == 2 && c[0] == '.' && c[1] == '.') {
            while (len > 1 && out[len - 1] != '/')
                len--;
            if (len > 1)
                len--; /* the slash before it */
            out[len] = '\0';
        } else if (!(w == 1 && c[0] == '.')) {
            if (len + (len > 1) + w >= n)
                return ESR_FAIL("path '%s' is too long", path);
            if (len > 1)
                out[len++] = '/';
            memcpy(out + len, c, w);
            len += w;
            out[len] = '\0';
        }
        c += w;
    }
    return ESR_OK;
}

/* 1 when a is b or lies below it (path components, not string prefixes: /a/bc is not in /a/b). */
static int path_within(const char *a, const char *b)
{
    const size_t nb = strlen(b);
    if (!strcmp(b, "/"))
        return 1;
    return !strncmp(a, b, nb) && (a[nb] == '\0' || a[nb] == '/');
}

int esr_staging_check_apart(const char *out_dir, const char *const *inputs, int n)
{
    char out[PATH_MAX], in[PATH_MAX], marker[PATH_MAX + 16];
    ESR_TRY(esr_path_resolve(out_dir, out, sizeof out));
    snprintf(marker, sizeof marker, "%s/import.json", out);
    struct stat st;
    /* what --force may replace inside an input: nothing yet, or an earlier import's output */
    const int replaceable = stat(out, &st) != 0 || dir_is_empty(out) || stat(marker, &st) == 0;
    for (int i = 0; i < n; i++) {
        if (!inputs[i])
            continue;
        ESR_TRY(esr_path_resolve(inputs[i], in, sizeof in));
        const int same = !strcmp(out, in), holds_input = path_within(in, out);
        if (same || holds_input || (path_within(out, in) && !replaceable))
            return ESR_FAIL("the output folder '%s' %s the input '%s': writing it would delete "
                            "the input; choose a folder apart from the inputs", out_dir,
                            same ? "is" : holds_input ? "contains" : "is a part of", inputs[i]);
    }
    return ESR_OK;
}

int esr_output_check_outside(const char *out_dir, const char *const *folders,
                             const char *const *what, int n, const char *allowed)
{
    char out[PATH_MAX], in[PATH_MAX];
    ESR_TRY(esr_path_resolve(out_dir, out, sizeof out));
    if (allowed) {
        ESR_TRY(esr_path_resolve(allowed, in, sizeof in));
        if (path_within(out, in))
            return ESR_OK;
    }
    for (int i = 0; i < n; i++) {
        if (!folders[i])
            continue;
        ESR_TRY(esr_path_resolve(folders[i], in, sizeof in));
        if (path_within(out, in))
            return ESR_FAIL("the output folder '%s' %s %s '%s': writing there would replace its "
                            "files; choose a folder outside it", out_dir,
                            strcmp(out, in) ? "lies inside" : "is", what[i], folders[i]);
    }
    return ESR_OK;
}

/* "<parent>/.<base>.<tag>-<pid>-XXXXXX" for out_dir (trailing slashes ignored). */
static int sibling_template(const char *out_dir, const char *tag, char *buf, size_t n)
{
    size_t len = strlen(out_dir);
    while (len > 1 && out_dir[len - 1] == '/')
        len--;
    size_t slash = len;
    while (slash > 0 && out_dir[slash - 1] != '/')
        slash--;
    char prefix[4096];
    int w = snprintf(prefix, sizeof prefix, "%.*s.%.*s.%s-", (int)slash, out_dir, (int)(len - slash),
                     out_dir + slash, tag);
    if (w < 0 || (size_t)w >= sizeof prefix)
        return ESR_FAIL("output path '%s' is too long", out_dir);
    return esr_stale_template(buf, n, prefix);
}

/* The staging folder is a sibling of the output, so the output's parent must exist first; a
 * killed run's staging folders there are removed. */
static int make_parent(const char *path)
{
    char parent[4096];
    size_t slash = strlen(path);
    while (slash > 0 && path[slash - 1] != '/')
        slash--;
    if (slash == 0) /* relative to the working directory */
        return esr_stale_sweep(".", NULL);
    if (slash == 1) /* directly under / */
        return ESR_OK;
    if (slash >= sizeof parent)
        return ESR_FAIL("output path '%s' is too long", path);
    memcpy(parent, path, slash - 1);
    parent[slash - 1] = '\0';
    ESR_TRY(esr_dir_create(parent));
    return esr_stale_sweep(parent, NULL);
}

int esr_staging_begin(const char *out_dir, int force, char *staging, size_t n)
{
    struct stat st;
    if (stat(out_dir, &st) == 0) {
        if (!S_ISDIR(st.st_mode))
            return ESR_FAIL("output '%s' exists and is not a directory", out_dir);
        if (!force && !dir_is_empty(out_dir))
            return ESR_FAIL("output directory '%s' exists and is not empty (use --force to replace it)", out_dir);
    } else if (errno != ENOENT) {
        return ESR_FAIL("cannot inspect output '%s': %s", out_dir, strerror(errno));
    }
    ESR_TRY(sibling_template(out_dir, "partial", staging, n));
    ESR_TRY(make_parent(staging));
    if (!mkdtemp(staging))
        return ESR_FAIL("cannot create staging directory '%s': %s", staging, strerror(errno));
    return ESR_OK;
}

int esr_staging_commit(const char *staging, const char *out_dir)
{
    /* rename() replaces an empty directory; a non-empty one is first moved aside. */
    if (rename(staging, out_dir) == 0)
        return ESR_OK;
    if (errno != ENOTEMPTY && errno != EEXIST)
        return ESR_FAIL("cannot move '%s' to '%s': %s", staging, out_dir, strerror(errno));
    char old[4096];
    ESR_TRY(sibling_template(out_dir, "old", old, sizeof old));
    if (!mkdtemp(old))
        return ESR_FAIL("cannot create '%s' to replace '%s': %s", old, out_dir, strerror(errno));
    if (rename(out_dir, old) != 0) {
        rmdir(old);
        return ESR_FAIL("cannot move the old '%s' aside: %s", out_dir, strerror(errno));
    }
    if (rename(staging, out_dir) != 0) {
        int err = errno;
        rename(old, out_dir); /* put the old dataset back */
        return ESR_FAIL("cannot move '%s' to '%s': %s", staging, out_dir, strerror(err));
    }
    return esr_remove_tree(old);
}

static int remove_entry(const char *path, const struct stat *st, int flag, struct FTW *ftw)
{
    (void)st, (void)flag, (void)ftw;
    return remove(path) == 0 ? 0 : -1;
}

int esr_remove_tree(const char *dir)
{
    if (nftw(dir, remove_entry, 16, FTW_DEPTH | FTW_PHYS) != 0)
        return ESR_FAIL("cannot remove '%s': %s", dir, strerror(errno));
    return ESR_OK;
}
