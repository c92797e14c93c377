#include "io/json_file.h"

#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "io/file.h"

int esr_json_write_atomic(const char *path, cJSON *root)
{
    char *text = root ? cJSON_Print(root) : NULL;
    cJSON_Delete(root);
    if (!text)
        return ESR_FAIL("out of memory writing '%s'", path);
    size_t len = strlen(text);
    char *line = realloc(text, len + 2);
    if (!line) {
        free(text);
        return ESR_FAIL("out of memory writing '%s'", path);
    }
    line[len] = '\n';
    line[len + 1] = '\0';
    int status = esr_file_write_atomic(path, line, len + 1);
    free(line);
    return status;
}
