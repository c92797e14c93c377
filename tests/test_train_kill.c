/* Kill anywhere (issue #13): a small training is killed with SIGKILL at random moments (during
 * checkpoint writes included: they are every 10 iterations here), resumed each time with
 * --resume, and its final checkpoints must be byte for byte those of an uninterrupted run. The
 * atomic checkpoint writes (temp file + rename) and the exact resume make it so. */
#define _GNU_SOURCE /* usleep */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "core/rng.h"
#include "io/file.h"
#include "test_support.h"

#define MIN_KILLS 20

static const char *const TRAIN_SET[] = {
    "--until", "coarse", "--set", "threads=1", "--set", "batch_rays=512", "--set", "save_every=10",
    "--set", "alphamask.res=16", "--set", "alphamask.iters=100", "--set", "coarse.res=16",
    "--set", "coarse.iters=100", "--set", "coarse.mlp_width=32", "--set", "coarse.feat_channels=6"};
#define N_SET (sizeof TRAIN_SET / sizeof TRAIN_SET[0])

static char data_dir[4200];

static int group_setup(void **state)
{
    if (test_setup_tmpdir(state))
        return -1;
    snprintf(data_dir, sizeof data_dir, "%s/data", test_tmpdir);
    return test_synth_small(data_dir) == 0 ? 0 : -1;
}

/* Starts `esr train DATA --out run [--resume] ...` with its output to /dev/null. */
static pid_t start_training(const char *run, int resume)
{
    const pid_t pid = fork();
    if (pid != 0)
        return pid;
    const char *argv[N_SET + 8];
    size_t k = 0;
    argv[k++] = ESR_BINARY;
    argv[k++] = "train";
    argv[k++] = data_dir;
    argv[k++] = "--out";
    argv[k++] = run;
    if (resume)
        argv[k++] = "--resume";
    for (size_t i = 0; i < N_SET; i++)
        argv[k++] = TRAIN_SET[i];
    argv[k] = NULL;
    if (!freopen("/dev/null", "w", stdout) || !freopen("/dev/null", "w", stderr))
        _exit(127);
    execv(ESR_BINARY, (char *const *)argv);
    _exit(127);
}

static void test_killed_anywhere_resumes_exactly(void **state)
{
    (void)state;
    char ref[4300], cut[4300], a[4400], b[4400], cmd[9000];
    snprintf(ref, sizeof ref, "%s/ref", test_tmpdir);
    snprintf(cut, sizeof cut, "%s/cut", test_tmpdir);
    int status;
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    const pid_t pid = start_training(ref, 0);
    assert_true(pid > 0);
    assert_int_equal(waitpid(pid, &status, 0), pid);
    assert_true(WIFEXITED(status) && WEXITSTATUS(status) == 0);
    clock_gettime(CLOCK_MONOTONIC, &t1);
    /* kill moments scale with how long a whole run takes here (sanitizer builds are slower) */
    const double whole_us = 1e6 * (double)(t1.tv_sec - t0.tv_sec) + 1e-3 * (double)(t1.tv_nsec - t0.tv_nsec);

    struct esr_rng rng = esr_rng_init(2026, 13);
    int kills = 0, episodes = 0;
    while (kills < MIN_KILLS) { /* episodes from scratch until enough kills landed */
        snprintf(cmd, sizeof cmd, "rm -rf '%s'", cut);
        assert_int_equal(system(cmd), 0);
        episodes++;
        for (int round = 0;; round++) {
            snprintf(a, sizeof a, "%s/config.json", cut);
            const pid_t p = start_training(cut, esr_file_exists(a));
            assert_true(p > 0);
            /* a moment between 1/20 and 1.2 of a whole run, short ones likelier: a resumed run
             * has less left to do, so any round may finish, and most are cut short */
            if (round > 500)
                fail_msg("no resumed training finished in %d rounds", round);
            const double u = esr_rng_float(&rng);
            usleep((useconds_t)(whole_us * (0.05 + 1.15 * u * u)));
            const int killed = kill(p, SIGKILL) == 0;
            assert_int_equal(waitpid(p, &status, 0), p);
            if (WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL) {
                kills++;
                continue;
            }
            (void)killed; /* it finished before the signal */
            if (!(WIFEXITED(status) && WEXITSTATUS(status) == 0))
                fail_msg("a resumed training failed (status %d) after %d kills", status, kills);
            break;
        }
        static const char *const ckpts[] = {"ckpt_alphamask.bin", "ckpt_coarse.bin"};
        for (size_t i = 0; i < 2; i++) {
            snprintf(a, sizeof a, "%s/%s", ref, ckpts[i]);
            snprintf(b, sizeof b, "%s/%s", cut, ckpts[i]);
            if (!test_files_equal(a, b))
                fail_msg("%s differs from the uninterrupted run's after %d kills", b, kills);
        }
    }
    /* evidence that kills landed inside checkpoint writes: their temp files stay behind */
    const int temps = test_count_names(cut, ".tmp-");
    print_message("killed %d times in %d episodes (%d inside a checkpoint write of the last); "
                  "every final checkpoint identical\n", kills, episodes, temps);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_killed_anywhere_resumes_exactly),
    };
    return cmocka_run_group_tests(tests, group_setup, test_teardown_tmpdir);
}
