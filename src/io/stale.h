/* Leftovers of a killed esr: atomic writes and staged outputs carry the writing process's id in
 * their temporary names (`<file>.tmp-<pid>-XXXXXX`, `.<dir>.partial-<pid>-XXXXXX`,
 * `.<dir>.old-<pid>-XXXXXX`), so a later run can tell a dead writer's leftovers from a live
 * one's and remove them. A process killed with SIGKILL cannot clean up after itself; without
 * this every kill during a checkpoint write would leave a checkpoint-sized file behind. */
#ifndef ESR_IO_STALE_H
#define ESR_IO_STALE_H

#include <stddef.h>

/* "<prefix><pid>-XXXXXX" for mkstemp/mkdtemp, with this process's id; fails when it does not fit. */
int esr_stale_template(char *buf, size_t n, const char *prefix);
/* Removes the entries of dir (not recursive) whose names are temporary names of processes that no
 * longer exist (a reused pid keeps its leftovers: never removes a live writer's file). *removed
 * (may be NULL) counts them. A missing dir is not an error. */
int esr_stale_sweep(const char *dir, int *removed);

#endif
