/* Helpers shared by the cmocka test programs. */
#ifndef ESR_TEST_SUPPORT_H
#define ESR_TEST_SUPPORT_H

#include <stddef.h>

/* Path of ../shared/scenes/<name> when present, else NULL (tests then skip the real-scene part). */
const char *test_shared_scene(const char *name);
/* A fresh empty temporary directory (removed by test_rmtree). Returns a static-lifetime copy. */
char *test_make_tmpdir(void);
void test_rmtree(const char *dir);
/* cmocka group setup/teardown that create and remove a temporary directory, test_tmpdir. */
extern char *test_tmpdir;
int test_setup_tmpdir(void **state);
int test_teardown_tmpdir(void **state);
/* Runs the esr binary with the given argument string through the shell; captures stdout+stderr
 * into `out` (truncated to n). Returns the exit code. */
int test_run_esr(const char *args, char *out, size_t n);
/* The same after shell commands `shell` (for example limits: "ulimit -f 8; "), in one sh -c. */
int test_run_esr_after(const char *shell, const char *args, char *out, size_t n);
/* Starts `esr args` in the background, its output to the file log; returns its process id. */
long test_spawn_esr(const char *args, const char *log);
/* Waits for it: its exit status, or 128 + the signal that ended it. */
int test_wait_esr(long pid);
/* 1 once the file path holds text (polled every 5 ms), 0 after timeout_ms. */
int test_wait_for_text(const char *path, const char *text, int timeout_ms);
/* esr synth of a small scene into dir (16 px, 1 sample, 4 + 4 training views, 1 test camera,
 * a second or two): the data of tests that train briefly. Returns esr's exit code. */
int test_synth_small(const char *dir);
/* cmocka group setup: test_tmpdir with test_synth_small's scene in test_data_dir (its "data"). */
extern char test_data_dir[];
int test_setup_small_data(void **state);
/* 1 when files a and b both read and are equal byte for byte. */
int test_files_equal(const char *a, const char *b);
/* How many entries of dir have `part` in their name (0 when dir cannot be read). */
int test_count_names(const char *dir, const char *part);
/* Unit quaternion (w, x, y, z) of a rotation matrix (Shepperd's method): COLMAP poses for tests. */
void test_rotation_to_quaternion(const double r[3][3], double q[4]);
/* Writes `text` to path; returns 0 on success. */
int test_write_file(const char *path, const char *text);
/* The id of a process that has exited and been reaped (for a dead writer's leftovers), -1 when
 * fork fails. */
long test_dead_pid(void);
/* The JSON document in path, or NULL when it cannot be read or parsed; cJSON_Delete it. */
struct cJSON *test_read_json(const char *path);

#endif
