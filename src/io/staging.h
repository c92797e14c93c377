/* Output directories that never look complete while half-written: everything goes into a hidden
 * sibling directory that is renamed onto the target at the end. */
#ifndef ESR_IO_STAGING_H
#define ESR_IO_STAGING_H

#include <stddef.h>

/* The absolute, resolved form of path, which need not exist: its longest existing prefix
 * resolved by realpath (links, `..`), the rest appended component by component ("." dropped,
 * ".." taking one off). Fails on a path too long for n bytes. */
int esr_path_resolve(const char *path, char *out, size_t n);
/* Checks that out_dir can be (re)placed: it may be absent or an empty directory; a non-empty one
 * only with force. Creates the staging directory (a sibling of out_dir) and returns its path in
 * staging (n bytes). */
int esr_staging_begin(const char *out_dir, int force, char *staging, size_t n);
/* Refuses an out_dir that is or contains one of the n input folders (NULL entries skipped), or
 * lies inside one and already holds something other than an earlier import (no import.json):
 * replacing it would delete input (`esr import ... --out IMAGES --force` did). A new or empty
 * folder inside an input (SCAN/data) is fine. Paths are compared after resolving symbolic links
 * and `..`; an out_dir that does not exist yet is resolved through its nearest existing
 * ancestor. */
int esr_staging_check_apart(const char *out_dir, const char *const *inputs, int n);
/* Refuses an out_dir that is or lies inside one of the n folders (NULL entries skipped): folders
 * whose files a command's output would replace (a dataset's images, a run's own renders whose
 * record would then describe other pixels), unless out_dir is or lies inside `allowed` (NULL:
 * none; a run kept inside its dataset). what[i] names folder i in the message. Paths are
 * resolved as in esr_staging_check_apart. */
int esr_output_check_outside(const char *out_dir, const char *const *folders,
                             const char *const *what, int n, const char *allowed);
/* Moves staging onto out_dir (replacing an existing out_dir, whose old contents are deleted). */
int esr_staging_commit(const char *staging, const char *out_dir);
/* Deletes a directory tree (no symlinks followed); used to drop a failed staging directory. */
int esr_remove_tree(const char *dir);

#endif
