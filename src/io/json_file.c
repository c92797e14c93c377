#include "io/json_file.h"

#include <math.h>
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

cJSON *esr_json_float_array(const float *v, int n)
{
    cJSON *a = cJSON_CreateArray();
    for (int i = 0; a && i < n; i++)
        cJSON_AddItemToArray(a, cJSON_CreateNumber((double)v[i]));
    return a;
}

void esr_json_add_number_or_null(cJSON *obj, const char *name, double value)
{
    if (isfinite(value))
        cJSON_AddNumberToObject(obj, name, value);
    else
        cJSON_AddNullToObject(obj, name);
}

cJSON *esr_json_parse_whole(const char *text, size_t size, const char *name)
{
    const char *end = NULL;
    cJSON *root = cJSON_ParseWithLengthOpts(text, size, &end, 0);
    const char *bad = NULL;
    if (!root) {
        const char *at = cJSON_GetErrorPtr();
        bad = at && at >= text && at <= text + size ? at : NULL;
    }
    /* what follows the value: white space only (a second object or stray text is no part of it) */
    for (const char *c = end; root && !bad && c && c < text + size; c++)
        if (*c != ' ' && *c != '\t' && *c != '\n' && *c != '\r' && *c != '\0')
            bad = c;
    if (root && !bad)
        return root;
    cJSON_Delete(root);
    if (!bad) {
        ESR_FAIL("%s: malformed JSON", name);
        return NULL;
    }
    /* where an editor shows it: line and column, both from 1 (a column counts bytes) */
    long line = 1, col = 1;
    for (const char *c = text; c < bad; c++, col++)
        if (*c == '\n')
            line++, col = 0;
    ESR_FAIL("%s:%ld:%ld: malformed JSON (line %ld, column %ld)", name, line, col, line, col);
    return NULL;
}
