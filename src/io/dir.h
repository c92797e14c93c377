/* Directory creation for command outputs (render folders, eval folders). */
#ifndef ESR_IO_DIR_H
#define ESR_IO_DIR_H

/* Creates directory `path` and any missing parents (like `mkdir -p`); an existing directory is
 * fine. Fails naming the path when a component exists but is not a directory or cannot be made. */
int esr_dir_create(const char *path);

#endif
