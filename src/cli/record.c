/* What made an output: every output folder a command writes carries this record (edit.json,
 * render.json, the eval JSON's "made_by", run.json), so a folder found later says which
 * command, options and build wrote it, and when. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <cjson/cJSON.h>

#include "cli/commands.h"
#include "core/error.h"
#include "io/file.h"
#include "io/json_file.h"

extern const char esr_build_commit[];

cJSON *cli_record(const char *cmd_name, int argc, char **argv)
{
    cJSON *r = cJSON_CreateObject();
    char line[8192];
    int used = snprintf(line, sizeof line, "esr %s", cmd_name);
    cJSON *args = cJSON_AddArrayToObject(r, "argv");
    for (int i = 1; i < argc; i++) {
        cJSON_AddItemToArray(args, cJSON_CreateString(argv[i]));
        /* the command line as a shell takes it back: arguments with odd characters quoted */
        const int plain = argv[i][0] && strspn(argv[i], "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMN"
                                                         "OPQRSTUVWXYZ0123456789-_./,=:+@%") ==
                                            strlen(argv[i]);
        if (used >= 0 && (size_t)used < sizeof line)
            used += snprintf(line + used, sizeof line - (size_t)used, plain ? " %s" : " '%s'", argv[i]);
    }
    cJSON_AddStringToObject(r, "command", line);
    cJSON_AddStringToObject(r, "esr", ESR_VERSION);
    cJSON_AddStringToObject(r, "commit", esr_build_commit);
    char when[64];
    const time_t now = time(NULL);
    struct tm tm;
    gmtime_r(&now, &tm);
    strftime(when, sizeof when, "%Y-%m-%dT%H:%M:%SZ", &tm);
    cJSON_AddStringToObject(r, "time", when);
    return r;
}

int cli_json_set(const char *path, const char *key, struct cJSON *item)
{
    unsigned char *text;
    size_t size;
    int rc = esr_file_read_all(path, &text, &size);
    cJSON *root = rc == ESR_OK ? esr_json_parse_whole((const char *)text, size, path) : NULL;
    if (rc == ESR_OK)
        free(text);
    if (!root || !cJSON_IsObject(root)) {
        cJSON_Delete(item);
        if (root) {
            cJSON_Delete(root);
            return ESR_FAIL("%s: not a JSON object", path);
        }
        return ESR_ERR;
    }
    cJSON_DeleteItemFromObjectCaseSensitive(root, key);
    cJSON_AddItemToObject(root, key, item);
    return esr_json_write_atomic(path, root);
}

int cli_record_into(const char *path, const char *cmd_name, int argc, char **argv)
{
    return cli_json_set(path, "made_by", cli_record(cmd_name, argc, argv));
}
