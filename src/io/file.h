/* Whole-file reads and atomic whole-file writes shared by the image and JSON readers/writers. */
#ifndef ESR_IO_FILE_H
#define ESR_IO_FILE_H

#include <stddef.h>

/* Reads the whole file into a new malloc'ed buffer (*data, *size), with a '\0' appended after
 * the last byte so text parsers can use it directly. Fails naming the file when it is missing,
 * unreadable or empty. The caller frees *data. */
int esr_file_read_all(const char *path, unsigned char **data, size_t *size);

/* Writes size bytes to path atomically: a temporary file in the same directory is written,
 * flushed and closed (every error checked, so a full disk is reported) and then renamed over
 * path. On failure the temporary file is removed and path is left untouched. */
int esr_file_write_atomic(const char *path, const void *data, size_t size);

/* Fails, naming path and the reason, when esr_file_write_atomic could not write path (its
 * folder missing or not writable, or path a directory); writes nothing. For commands that
 * would otherwise find out only after minutes of work. */
int esr_file_check_writable(const char *path);

/* Copies the file src to dst with esr_file_write_atomic (dst never half-written). */
int esr_file_copy(const char *src, const char *dst);

/* 1 when path names an existing regular file. */
int esr_file_exists(const char *path);

#endif
