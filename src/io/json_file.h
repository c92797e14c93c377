/* JSON documents written to disk: the one way esr writes its JSON outputs (metrics, configs,
 * summaries, records), so every one is atomic, newline-terminated and reports a full disk. */
#ifndef ESR_IO_JSON_FILE_H
#define ESR_IO_JSON_FILE_H

#include <cjson/cJSON.h>

/* Prints root (formatted) followed by a newline to path with esr_file_write_atomic. Takes
 * ownership: root is deleted in every case. A NULL root (a failed cJSON allocation upstream)
 * is reported as out of memory. */
int esr_json_write_atomic(const char *path, cJSON *root);

#endif
