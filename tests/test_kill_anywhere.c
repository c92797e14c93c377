/* Kill anywhere (issue #13): esr train, esr synth and esr eval are killed with SIGKILL at random
 * moments (during their atomic writes included), started again each time, and what they finally
 * leave must be byte for byte what an uninterrupted run leaves:
 * - train resumes (--resume) from its last checkpoint: the final checkpoints are identical;
 * - synth stages its whole output and renames it at the end: after every kill the output is
 *   either absent or complete and identical, and a rerun produces it;
 * - eval renders what is missing and rewrites its JSON and report: the rerun's renders, JSON and
 *   report are identical.
 * Every temporary file or staging folder a kill leaves is removed by the next run (io/stale.h). */
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
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <cjson/cJSON.h>

#include "core/rng.h"
#include "io/file.h"
#include "test_support.h"

/* under the sanitizers (3-5x slower per run) half as many kills: the release build lands 20 */
#if defined(__SANITIZE_ADDRESS__)
#define MIN_KILLS 10
#else
#define MIN_KILLS 20
#endif
#define MAX_ARGS 40

static const char *const TRAIN_SET[] = {
    "--until", "coarse", "--set", "threads=1", "--set", "batch_rays=512", "--set", "save_every=10",
    "--set", "alphamask.res=16", "--set", "alphamask.iters=100", "--set", "coarse.res=16",
    "--set", "coarse.iters=100", "--set", "coarse.mlp_width=32", "--set", "coarse.feat_channels=6"};
#define N_TRAIN_SET (sizeof TRAIN_SET / sizeof TRAIN_SET[0])


/* A command line: esr's arguments, NULL-terminated. */
struct command {
    const char *argv[MAX_ARGS];
    int n;
};

static void add(struct command *c, const char *arg)
{
    assert_true(c->n < MAX_ARGS - 1);
    c->argv[c->n++] = arg;
    c->argv[c->n] = NULL;
}

/* Starts esr with c's arguments, its output to /dev/null. */
static pid_t start(const struct command *c)
{
    const pid_t pid = fork();
    if (pid != 0)
        return pid;
    const char *argv[MAX_ARGS + 1];
    argv[0] = ESR_BINARY;
    memcpy(argv + 1, c->argv, (size_t)(c->n + 1) * sizeof *argv);
    if (!freopen("/dev/null", "w", stdout) || !freopen("/dev/null", "w", stderr))
        _exit(127);
    execv(ESR_BINARY, (char *const *)argv);
    _exit(127);
}

/* Runs c to the end; returns the wall time in microseconds, failing the test unless it exits 0. */
static double run_whole(const struct command *c)
{
    struct timespec t0, t1;
    int status;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    const pid_t pid = start(c);
    assert_true(pid > 0);
    assert_int_equal(waitpid(pid, &status, 0), pid);
    if (!(WIFEXITED(status) && WEXITSTATUS(status) == 0))
        fail_msg("esr %s ... failed uninterrupted (status %d)", c->argv[0], status);
    clock_gettime(CLOCK_MONOTONIC, &t1);
    return 1e6 * (double)(t1.tv_sec - t0.tv_sec) + 1e-3 * (double)(t1.tv_nsec - t0.tv_nsec);
}

/* One job to kill: how to (re)start it, when it is done without running again, and the check
 * after each kill. */
struct job {
    void (*command)(struct job *j, struct command *c);
    int (*finished)(struct job *j);     /* may be NULL: never before a run */
    void (*after_kill)(struct job *j);  /* may be NULL */
    const char *dir;                    /* the output being killed into */
    const char *ref;                    /* the uninterrupted run's output */
    int temps;                          /* leftovers counted after kills (evidence) */
    int last_exit_clean;                /* the episode ended with a run that exited 0 */
};

/* Restarts j and kills it at random moments (between 1/20 and 1.2 of a whole run, short ones
 * likelier: a restarted run may have less left to do, so any round may finish) until a run
 * finishes; returns the number of kills that landed. The window widens by half every 10 rounds
 * without an end, in case restarts run slower than the measured run (a busy machine). */
static int kill_until_done(struct job *j, double whole_us, struct esr_rng *rng)
{
    int kills = 0, status;
    j->last_exit_clean = 0;
    for (int round = 0;; round++) {
        if (j->finished && j->finished(j))
            return kills;
        if (round > 100)
            fail_msg("no restarted run finished in %d rounds", round);
        if (round > 0 && round % 10 == 0)
            whole_us *= 1.5;
        struct command c = {.n = 0};
        j->command(j, &c);
        const pid_t p = start(&c);
        assert_true(p > 0);
        const double u = esr_rng_float(rng);
        usleep((useconds_t)(whole_us * (0.05 + 1.15 * u * u)));
        kill(p, SIGKILL); /* fails harmlessly when it has already exited (not yet reaped) */
        assert_int_equal(waitpid(p, &status, 0), p);
        if (WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL) {
            kills++;
            if (j->after_kill)
                j->after_kill(j);
            continue;
        }
        if (!(WIFEXITED(status) && WEXITSTATUS(status) == 0))
            fail_msg("a restarted run failed (status %d) after %d kills", status, kills);
        j->last_exit_clean = 1;
        return kills;
    }
}

/* Episodes from scratch (`reset`) until MIN_KILLS kills landed; returns the episodes. */
static int kill_episodes(struct job *j, double whole_us, void (*reset)(struct job *j),
                         void (*compare)(struct job *j), int *kills)
{
    struct esr_rng rng = esr_rng_init(2026, 13);
    int episodes = 0;
    *kills = 0;
    while (*kills < MIN_KILLS) {
        reset(j);
        episodes++;
        *kills += kill_until_done(j, whole_us, &rng);
        compare(j);
    }
    return episodes;
}

static void remove_tree(const char *dir)
{
    char cmd[9000];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    assert_int_equal(system(cmd), 0);
}

/* Temporary files (atomic writes cut short) anywhere under dir. */
static int count_temps(const char *dir)
{
    char cmd[9000];
    snprintf(cmd, sizeof cmd, "find '%s' -name '*.tmp-*' 2>/dev/null | wc -l", dir);
    FILE *f = popen(cmd, "r");
    assert_non_null(f);
    int n = 0;
    assert_int_equal(fscanf(f, "%d", &n), 1);
    pclose(f);
    return n;
}

/* Removes the record of what made an output ("made_by": the command line and the time, which
 * differ between two runs by design) from every JSON file under dir, so what is compared is
 * what was computed. */
static void strip_records(const char *dir)
{
    char cmd[9000], path[4400];
    snprintf(cmd, sizeof cmd, "find '%s' -name '*.json' 2>/dev/null", dir);
    FILE *f = popen(cmd, "r");
    assert_non_null(f);
    while (fgets(path, sizeof path, f)) {
        path[strcspn(path, "\n")] = '\0';
        cJSON *root = test_read_json(path);
        if (root && cJSON_GetObjectItemCaseSensitive(root, "made_by")) {
            cJSON_DeleteItemFromObjectCaseSensitive(root, "made_by");
            char *text = cJSON_Print(root);
            assert_non_null(text);
            assert_int_equal(test_write_file(path, text), 0);
            free(text);
        }
        cJSON_Delete(root);
    }
    pclose(f);
}

/* 1 when the files, or the trees a and b, hold the same bytes (diff from diffutils), the records
 * of what made them aside. */
static int trees_equal(const char *a, const char *b)
{
    char cmd[9000];
    strip_records(a);
    strip_records(b);
    snprintf(cmd, sizeof cmd, "diff -r -q '%s' '%s' >/dev/null 2>&1", a, b);
    return system(cmd) == 0;
}

/* ---- train ---- */

static void train_command(struct job *j, struct command *c)
{
    static char config[4400];
    add(c, "train");
    add(c, test_data_dir);
    add(c, "--out");
    add(c, j->dir);
    snprintf(config, sizeof config, "%s/config.json", j->dir);
    if (esr_file_exists(config))
        add(c, "--resume");
    for (size_t i = 0; i < N_TRAIN_SET; i++)
        add(c, TRAIN_SET[i]);
}

static void train_after_kill(struct job *j)
{
    j->temps += count_temps(j->dir);
}

static void train_reset(struct job *j)
{
    remove_tree(j->dir);
}

/* Fails unless each of the n names (files or folders) under j->dir holds the same bytes as under
 * j->ref, the uninterrupted `what`'s output, and unless the last run removed every temporary
 * file the kills left. */
static void assert_same_outputs(const struct job *j, const char *const *names, size_t n, const char *what)
{
    char a[4400], b[4400];
    for (size_t i = 0; i < n; i++) {
        snprintf(a, sizeof a, "%s/%s", j->ref, names[i]);
        snprintf(b, sizeof b, "%s/%s", j->dir, names[i]);
        if (!trees_equal(a, b))
            fail_msg("%s differs from the uninterrupted %s's", b, what);
    }
    assert_int_equal(count_temps(j->dir), 0);
}

static void train_compare(struct job *j)
{
    static const char *const ckpts[] = {"ckpt_alphamask.bin", "ckpt_coarse.bin"};
    assert_same_outputs(j, ckpts, sizeof ckpts / sizeof ckpts[0], "run");
}

static void test_train_killed_anywhere_resumes_exactly(void **state)
{
    (void)state;
    char ref[4300], cut[4300];
    snprintf(ref, sizeof ref, "%s/ref", test_tmpdir);
    snprintf(cut, sizeof cut, "%s/cut", test_tmpdir);
    struct job j = {.command = train_command, .after_kill = train_after_kill, .dir = ref, .ref = ref};
    struct command c = {.n = 0};
    train_command(&j, &c);
    const double whole_us = run_whole(&c); /* kill moments scale with it (sanitizers are slower) */
    j.dir = cut;
    int kills;
    const int episodes = kill_episodes(&j, whole_us, train_reset, train_compare, &kills);
    print_message("train: killed %d times in %d episodes, %d times inside a checkpoint write; "
                  "every final checkpoint identical\n", kills, episodes, j.temps);
}

/* ---- synth ---- */

static void synth_command(struct job *j, struct command *c)
{
    static const char *const args[] = {"synth", "--res", "24", "--spp", "2", "--train", "4", "--test", "1"};
    for (size_t i = 0; i < sizeof args / sizeof args[0]; i++)
        add(c, args[i]);
    add(c, j->dir);
}

/* The staged output appears whole or not at all. */
static int synth_finished(struct job *j)
{
    struct stat st;
    if (stat(j->dir, &st) != 0)
        return 0;
    if (!trees_equal(j->ref, j->dir))
        fail_msg("%s exists after a kill but is not the complete dataset", j->dir);
    return 1;
}

static void synth_after_kill(struct job *j)
{
    (void)synth_finished(j);
    j->temps += test_count_names(test_tmpdir, ".synth_cut.partial-") > 0;
}

static void synth_reset(struct job *j)
{
    remove_tree(j->dir);
}

static void synth_compare(struct job *j)
{
    if (!trees_equal(j->ref, j->dir))
        fail_msg("%s differs from the uninterrupted synth's output", j->dir);
    if (j->last_exit_clean) /* that run removed the staging folders killed ones left */
        assert_int_equal(test_count_names(test_tmpdir, ".synth_cut.partial-"), 0);
}

static void test_synth_killed_anywhere_leaves_all_or_nothing(void **state)
{
    (void)state;
    char ref[4300], cut[4300];
    snprintf(ref, sizeof ref, "%s/synth_ref", test_tmpdir);
    snprintf(cut, sizeof cut, "%s/synth_cut", test_tmpdir);
    struct job j = {.command = synth_command, .finished = synth_finished, .after_kill = synth_after_kill,
                    .dir = cut, .ref = ref};
    struct command c = {.n = 0};
    synth_command(&j, &c);
    const double whole_us = run_whole(&c); /* generated at the same path, then moved aside */
    assert_int_equal(rename(cut, ref), 0);
    int kills;
    const int episodes = kill_episodes(&j, whole_us, synth_reset, synth_compare, &kills);
    print_message("synth: killed %d times in %d episodes (%d left a staging folder, removed by the "
                  "next run); every output complete and identical or absent\n",
                  kills, episodes, j.temps);
}

/* ---- eval ---- */

static char eval_data[4300];
/* what `esr eval` writes into the run */
static const char *const EVAL_OUTPUTS[] = {"render", "eval", "report.html"};
#define N_EVAL_OUTPUTS (sizeof EVAL_OUTPUTS / sizeof EVAL_OUTPUTS[0])

static void eval_command(struct job *j, struct command *c)
{
    add(c, "eval");
    add(c, j->dir);
}

static void eval_after_kill(struct job *j)
{
    j->temps += count_temps(j->dir);
}

/* The trained run without its evaluation outputs, and with the temporary report a kill during
 * the report's write leaves (so that every episode checks it is removed, not only the rare one
 * whose kill lands there). */
static void eval_reset(struct job *j)
{
    char path[4400];
    for (size_t i = 0; i < N_EVAL_OUTPUTS; i++) {
        snprintf(path, sizeof path, "%s/%s", j->dir, EVAL_OUTPUTS[i]);
        remove_tree(path);
    }
    const long dead = test_dead_pid();
    assert_true(dead > 0);
    snprintf(path, sizeof path, "%s/report.html.tmp-%ld-Kq3xZ9", j->dir, dead);
    assert_int_equal(test_write_file(path, "<html>half a report"), 0);
}

static void eval_compare(struct job *j)
{
    assert_same_outputs(j, EVAL_OUTPUTS, N_EVAL_OUTPUTS, "evaluation");
}

static void test_eval_killed_anywhere_finishes_identically(void **state)
{
    (void)state;
    char run[4300], ref[4300], cmd[16384];
    /* a copy of the data without the ground-truth mesh: the Chamfer distance of a barely trained
     * model takes seconds and is no part of what is tested here */
    snprintf(eval_data, sizeof eval_data, "%s/eval_data", test_tmpdir);
    snprintf(run, sizeof run, "%s/eval_run", test_tmpdir);
    snprintf(ref, sizeof ref, "%s/eval_ref", test_tmpdir);
    snprintf(cmd, sizeof cmd, "cp -r '%s' '%s' && rm '%s/gt/mesh.ply'", test_data_dir, eval_data, eval_data);
    assert_int_equal(system(cmd), 0);
    struct command c = {.n = 0};
    const char *train[] = {"train", eval_data, "--out", run};
    for (size_t i = 0; i < 4; i++)
        add(&c, train[i]);
    for (size_t i = 0; i < N_TRAIN_SET; i++)
        add(&c, TRAIN_SET[i]);
    run_whole(&c);
    struct job j = {.command = eval_command, .after_kill = eval_after_kill, .dir = run, .ref = ref};
    c.n = 0;
    eval_command(&j, &c);
    const double whole_us = run_whole(&c); /* the reference, moved aside */
    snprintf(cmd, sizeof cmd, "mkdir '%s' && cd '%s' && mv render eval report.html '%s/'", ref, run, ref);
    assert_int_equal(system(cmd), 0);
    int kills;
    const int episodes = kill_episodes(&j, whole_us, eval_reset, eval_compare, &kills);
    print_message("eval: killed %d times in %d episodes (%d temporary files left by kills, removed "
                  "by the next run); renders, JSON and report identical\n", kills, episodes, j.temps);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_train_killed_anywhere_resumes_exactly),
        cmocka_unit_test(test_synth_killed_anywhere_leaves_all_or_nothing),
        cmocka_unit_test(test_eval_killed_anywhere_finishes_identically),
    };
    return cmocka_run_group_tests(tests, test_setup_small_data, test_teardown_tmpdir);
}
