#include "test_support.h"

#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cjson/cJSON.h>

#include "io/file.h"

const char *test_shared_scene(const char *name)
{
    static char path[1024];
    struct stat st;
    snprintf(path, sizeof path, "%s/%s", ESR_SHARED_SCENES, name);
    if (stat(path, &st) == 0 && S_ISDIR(st.st_mode))
        return path;
    return NULL;
}

char *test_make_tmpdir(void)
{
    char templ[] = "/tmp/esr-test-XXXXXX";
    char *dir = mkdtemp(templ);
    return dir ? strdup(dir) : NULL;
}

void test_rmtree(const char *dir)
{
    if (!dir || strncmp(dir, "/tmp/esr-test-", 14) != 0)
        return; /* refuse to remove anything we did not create */
    char cmd[1200];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    if (system(cmd) != 0)
        fprintf(stderr, "warning: could not remove %s\n", dir);
}

char *test_tmpdir;

int test_setup_tmpdir(void **state)
{
    (void)state;
    test_tmpdir = test_make_tmpdir();
    return test_tmpdir ? 0 : -1;
}

int test_teardown_tmpdir(void **state)
{
    (void)state;
    test_rmtree(test_tmpdir);
    free(test_tmpdir);
    test_tmpdir = NULL;
    return 0;
}

int test_run_esr(const char *args, char *out, size_t n)
{
    return test_run_esr_after("", args, out, n);
}

int test_run_esr_after(const char *shell, const char *args, char *out, size_t n)
{
    char cmd[12288];
    snprintf(cmd, sizeof cmd, "%s'%s' %s 2>&1", shell, ESR_BINARY, args);
    FILE *p = popen(cmd, "r");
    if (!p)
        return -1;
    size_t used = fread(out, 1, n - 1, p);
    out[used] = '\0';
    char sink[4096];
    while (fread(sink, 1, sizeof sink, p) > 0) {
    }
    int status = pclose(p);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

int test_synth_small(const char *dir)
{
    char args[4400], out[8192];
    snprintf(args, sizeof args, "synth --res 16 --spp 1 --train 4 --test 1 %s", dir);
    return test_run_esr(args, out, sizeof out);
}

char test_data_dir[4200];

int test_setup_small_data(void **state)
{
    if (test_setup_tmpdir(state))
        return -1;
    snprintf(test_data_dir, sizeof test_data_dir, "%s/data", test_tmpdir);
    return test_synth_small(test_data_dir) == 0 ? 0 : -1;
}

int test_files_equal(const char *a, const char *b)
{
    unsigned char *x = NULL, *y = NULL;
    size_t nx = 0, ny = 0;
    const int read = esr_file_read_all(a, &x, &nx) == 0 && esr_file_read_all(b, &y, &ny) == 0;
    const int same = read && nx == ny && memcmp(x, y, nx) == 0;
    free(x);
    free(y);
    return same;
}

int test_count_names(const char *dir, const char *part)
{
    DIR *d = opendir(dir);
    if (!d)
        return 0;
    int n = 0;
    for (struct dirent *e; (e = readdir(d));)
        n += strstr(e->d_name, part) != NULL;
    closedir(d);
    return n;
}

void test_rotation_to_quaternion(const double r[3][3], double q[4])
{
    double tr = r[0][0] + r[1][1] + r[2][2];
    if (tr > 0) {
        double s = 2.0 * sqrt(1.0 + tr);
        q[0] = s / 4, q[1] = (r[2][1] - r[1][2]) / s, q[2] = (r[0][2] - r[2][0]) / s, q[3] = (r[1][0] - r[0][1]) / s;
    } else if (r[0][0] > r[1][1] && r[0][0] > r[2][2]) {
        double s = 2.0 * sqrt(1.0 + r[0][0] - r[1][1] - r[2][2]);
        q[0] = (r[2][1] - r[1][2]) / s, q[1] = s / 4, q[2] = (r[0][1] + r[1][0]) / s, q[3] = (r[0][2] + r[2][0]) / s;
    } else if (r[1][1] > r[2][2]) {
        double s = 2.0 * sqrt(1.0 + r[1][1] - r[0][0] - r[2][2]);
        q[0] = (r[0][2] - r[2][0]) / s, q[1] = (r[0][1] + r[1][0]) / s, q[2] = s / 4, q[3] = (r[1][2] + r[2][1]) / s;
    } else {
        double s = 2.0 * sqrt(1.0 + r[2][2] - r[0][0] - r[1][1]);
        q[0] = (r[1][0] - r[0][1]) / s, q[1] = (r[0][2] + r[2][0]) / s, q[2] = (r[1][2] + r[2][1]) / s, q[3] = s / 4;
    }
}

int test_write_file(const char *path, const char *text)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return -1;
    size_t len = strlen(text);
    int ok = fwrite(text, 1, len, f) == len;
    return (fclose(f) == 0 && ok) ? 0 : -1;
}

cJSON *test_read_json(const char *path)
{
    unsigned char *text;
    size_t size;
    if (esr_file_read_all(path, &text, &size) != 0)
        return NULL;
    cJSON *root = cJSON_ParseWithLength((const char *)text, size);
    free(text);
    return root;
}

long test_dead_pid(void)
{
    const pid_t p = fork();
    if (p == 0)
        _exit(0);
    if (p < 0 || waitpid(p, NULL, 0) != p)
        return -1;
    return (long)p;
}

long test_spawn_esr(const char *args, const char *log)
{
    char cmd[12288];
    snprintf(cmd, sizeof cmd, "exec '%s' %s > '%s' 2>&1", ESR_BINARY, args, log);
    const pid_t pid = fork();
    if (pid == 0) {
        execl("/bin/sh", "sh", "-c", cmd, (char *)NULL);
        _exit(127);
    }
    return pid;
}

int test_wait_esr(long pid)
{
    int status;
    if (waitpid((pid_t)pid, &status, 0) != (pid_t)pid)
        return -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : WIFSIGNALED(status) ? 128 + WTERMSIG(status) : -1;
}

int test_wait_for_text(const char *path, const char *text, int timeout_ms)
{
    for (int waited = 0; waited <= timeout_ms; waited += 5) {
        unsigned char *data = NULL;
        size_t size = 0;
        if (esr_file_read_all(path, &data, &size) == 0) {
            char *t = realloc(data, size + 1);
            if (t) {
                t[size] = '\0';
                const int found = strstr(t, text) != NULL;
                free(t);
                if (found)
                    return 1;
            } else {
                free(data);
            }
        }
        usleep(5000);
    }
    return 0;
}
