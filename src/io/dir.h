/* Directory creation for command outputs (run, render and eval folders). */
#ifndef ESR_IO_DIR_H
#define ESR_IO_DIR_H

/* Creates directory `path` and any missing parents (like `mkdir -p`); an existing directory is
 * fine. Fails naming the path when a component exists but is not a directory or cannot be made. */
int esr_dir_create(const char *path);
/* An output folder about to be written: esr_dir_create, then a killed run's temporary files and
 * staging folders in it are removed (io/stale.h). */
int esr_dir_prepare_output(const char *path);
/* A run directory to read: fails naming it when it does not exist or is a file. */
int esr_dir_check_run(const char *run);

#endif
