/* Output directories that never look complete while half-written: everything goes into a hidden
 * sibling directory that is renamed onto the target at the end. */
#ifndef ESR_IO_STAGING_H
#define ESR_IO_STAGING_H

#include <stddef.h>

/* Checks that out_dir can be (re)placed: it may be absent or an empty directory; a non-empty one
 * only with force. Creates the staging directory (a sibling of out_dir) and returns its path in
 * staging (n bytes). */
int esr_staging_begin(const char *out_dir, int force, char *staging, size_t n);
/* Moves staging onto out_dir (replacing an existing out_dir, whose old contents are deleted). */
int esr_staging_commit(const char *staging, const char *out_dir);
/* Deletes a directory tree (no symlinks followed); used to drop a failed staging directory. */
int esr_remove_tree(const char *dir);

#endif
