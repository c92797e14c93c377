/* Output files named on the command line: the name says what is written (a PLY is .ply, binary
 * glTF is .glb), and a missing folder is made before any work, by every command alike (a
 * command that then fails takes back the folders it made). */
#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#include "cli/commands.h"
#include "core/error.h"
#include "io/dir.h"

int cli_ends_with(const char *path, const char *ext)
{
    const size_t n = strlen(path), e = strlen(ext);
    return n > e && !strcasecmp(path + n - e, ext);
}

void cli_parent_dir(const char *path, char *out, size_t n)
{
    snprintf(out, n, "%s", path);
    char *slash = strrchr(out, '/');
    while (slash && slash > out && slash[1] == '\0') { /* "dir/" names dir */
        *slash = '\0';
        slash = strrchr(out, '/');
    }
    if (slash)
        *(slash == out ? slash + 1 : slash) = '\0';
    else
        snprintf(out, n, ".");
}

int cli_output_file(const char *option, const char *path, const char *ext, char *made, size_t n)
{
    if (made && n)
        made[0] = '\0';
    if (!cli_ends_with(path, ext)) {
        if (!strcmp(ext, ".glb") && cli_ends_with(path, ".gltf"))
            return ESR_FAIL("%s %s: esr writes binary glTF, which viewers read from a .glb file "
                            "(a .gltf file is read as JSON): name it .glb", option, path);
        const char *dot = strrchr(path, '.'), *slash = strrchr(path, '/');
        return ESR_FAIL("%s %s: the file is written as %s: name it *%s%s%s", option, path,
                        !strcmp(ext, ".ply") ? "PLY" : !strcmp(ext, ".png") ? "PNG"
                        : !strcmp(ext, ".json") ? "JSON" : !strcmp(ext, ".glb") ? "binary glTF" : ext,
                        ext, dot && (!slash || dot > slash) ? ", not " : "",
                        dot && (!slash || dot > slash) ? dot : "");
    }
    struct stat st;
    if (stat(path, &st) == 0 && S_ISDIR(st.st_mode))
        return ESR_FAIL("%s %s is a folder: name the file to write", option, path);
    if (!strchr(path, '/'))
        return ESR_OK; /* the working directory */
    char dir[4200];
    cli_parent_dir(path, dir, sizeof dir);
    return esr_dir_create_made(dir, made, n);
}
