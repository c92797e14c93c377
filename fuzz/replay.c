/* Replays files through a harness without libFuzzer: every regular file of each folder named on
 * the command line is passed to LLVMFuzzerTestOneInput (in a buffer of exactly its size, so the
 * sanitizers see any over-read), as libFuzzer passes a corpus. The test suite runs this on the
 * seed corpus and on every input that ever crashed, in the normal gcc and ASan builds. */
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "fuzz.h"

/* Reads path into a new buffer of exactly its size (one byte for an empty file); NULL when it is
 * not a readable regular file. */
static uint8_t *read_file(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    struct stat st;
    uint8_t *buf = NULL;
    if (fstat(fileno(f), &st) == 0 && S_ISREG(st.st_mode)) {
        *size = (size_t)st.st_size;
        buf = malloc(*size ? *size : 1);
        if (buf && fread(buf, 1, *size, f) != *size) {
            free(buf);
            buf = NULL;
        }
    }
    fclose(f);
    return buf;
}

static int replay_dir(const char *dir, int *count)
{
    DIR *d = opendir(dir);
    if (!d) {
        fprintf(stderr, "replay: cannot open folder %s\n", dir);
        return 1;
    }
    int failed = 0;
    for (struct dirent *e; !failed && (e = readdir(d));) {
        if (e->d_name[0] == '.') /* ., .. and the .gitkeep of an empty regressions folder */
            continue;
        char path[4096];
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        size_t size = 0;
        uint8_t *data = read_file(path, &size);
        if (!data) {
            fprintf(stderr, "replay: cannot read %s\n", path);
            failed = 1;
            continue;
        }
        LLVMFuzzerTestOneInput(data, size);
        free(data);
        ++*count;
    }
    closedir(d);
    return failed;
}

int main(int argc, char **argv)
{
    int count = 0;
    for (int i = 1; i < argc; i++)
        if (replay_dir(argv[i], &count))
            return 1;
    printf("replayed %d files\n", count);
    return count > 0 ? 0 : 1;
}
