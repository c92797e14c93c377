/* JSON documents on disk: the one way esr writes its JSON outputs (metrics, configs, summaries,
 * records), so every one is atomic, newline-terminated and reports a full disk; and the reading
 * of a whole document that a user wrote (a dataset's transforms, a config). */
#ifndef ESR_IO_JSON_FILE_H
#define ESR_IO_JSON_FILE_H

#include <cjson/cJSON.h>

/* Prints root (formatted) followed by a newline to path with esr_file_write_atomic. Takes
 * ownership: root is deleted in every case. A NULL root (a failed cJSON allocation upstream)
 * is reported as out of memory. */
int esr_json_write_atomic(const char *path, cJSON *root);

/* The document of text[0..size) (no NUL needed), which must be one JSON value with nothing but
 * white space (or NUL bytes) after it; NULL when it is malformed or something follows, with the
 * error "NAME:LINE:COLUMN: malformed JSON (line L, column C)" where the parser stopped (both from 1),
 * or "NAME: malformed JSON" when it does not say. */
cJSON *esr_json_parse_whole(const char *text, size_t size, const char *name);

/* A JSON array of the n floats v (NULL on out of memory). */
cJSON *esr_json_float_array(const float *v, int n);
/* obj[name] = value, or null when value is NaN or infinite (JSON has neither). */
void esr_json_add_number_or_null(cJSON *obj, const char *name, double value);

#endif
