/* Folders for command outputs (run, render, eval and edit folders): creation, the take-back of
 * what a failed command made, and the lock one training holds on its run folder. */
#ifndef ESR_IO_DIR_H
#define ESR_IO_DIR_H

#include <stddef.h>

/* Creates directory `path` and any missing parents (like `mkdir -p`); an existing directory is
 * fine. Fails naming the path when a component exists but is not a directory or cannot be made. */
int esr_dir_create(const char *path);
/* esr_dir_create that also says which folders it made: `made` gets the outermost folder this call
 * created ("" when all existed, and when path has a ".." component or does not fit in
 * made_size: then nothing can be taken back), for esr_dir_remove_made. */
int esr_dir_create_made(const char *path, char *made, size_t made_size);
/* Undoes esr_dir_create_made after a failed command: removes path and its parents up to and
 * including `made` while they are empty (nothing when made is ""), so a command that fails
 * leaves no folder it made. */
void esr_dir_remove_made(const char *path, const char *made);
/* An output folder about to be written: esr_dir_create, refused when this process cannot write
 * into it (permissions, a read-only mount: said before any work, not after it), then a killed
 * run's temporary files and staging folders in it are removed (io/stale.h). */
int esr_dir_prepare_output(const char *path);
/* esr_dir_prepare_output saying, as esr_dir_create_made, which folders it made. */
int esr_dir_prepare_output_made(const char *path, char *made, size_t made_size);
/* Holds dir for one writer: an exclusive lock on dir/.esr.lock (flock, released when the
 * process ends, however it ends); *fd_out keeps it until esr_dir_unlock. Fails, naming dir and
 * `what` ("train"), while another process holds it. Where no lock can be taken (the file cannot
 * be created, the file system has no flock) it goes on unlocked, *fd_out -1. */
int esr_dir_lock(const char *dir, const char *what, int *fd_out);
void esr_dir_unlock(int fd);
/* What an output folder holds, for a command that would replace it: the number of entries in
 * dir other than "." , ".." and the lock file (0 when dir does not exist), and the first few of
 * their names, comma-separated, in names (n bytes; "" when none). */
int esr_dir_list_entries(const char *dir, char *names, size_t n);
/* A run directory to read: fails naming it when it does not exist or is a file. */
int esr_dir_check_run(const char *run);

#endif
