/* esr train DATA --out RUN: the geometry and radiance stages (alphamask -> coarse -> fine). */
#include <errno.h>
#include <signal.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli/commands.h"
#include "core/error.h"
#include "io/dir.h"
#include "io/file.h"
#include "eval/quick_eval.h"
#include "train/trainer.h"

static int run_train(int argc, char **argv);

struct train_args {
    const char *data, *out;
    enum esr_stage until;
    enum esr_preset preset;
    int has_preset, resume, force, eval, allow_poor;
    struct cli_texts configs, sets; /* applied in order over the preset */
};

static int preset_value(void *args, const struct cli_option *o, const char *value);
static void config_help(FILE *out);
static int stage_value(void *args, const struct cli_option *o, const char *value);

#define AT(field) offsetof(struct train_args, field)
static const struct cli_option train_options[] = {
    {"DATA", .kind = CLI_ARG, .at = AT(data)},
    {"--out", "RUN", "run directory (created if missing)", CLI_TEXT, .at = AT(out)},
    {"--until", "STAGE", "last stage to run: alphamask, coarse, fine, lts or pdra (default; fine "
     "gives the geometry and radiance without the emitters)", CLI_CALL, .call = stage_value},
    {"--resume", NULL, "continue from RUN's checkpoints with RUN's config.json (without one, with "
     "the options given now, said); --set changes options of the stages still to train and is "
     "written to it (e.g. lts and pdra again from a copy's fine checkpoint)", CLI_FLAG,
     .at = AT(resume)},
    {"--force", NULL, "start over in a RUN that holds an earlier run (not with --resume)", CLI_FLAG,
     .at = AT(force)},
    {"--preset", "NAME", "defaults: fast (CPU, default), paper (the authors' sizes) or smoke "
     "(every stage a few iterations on grids sized to the images: checks an install in seconds on "
     "a small `esr synth --res 32` dataset)", CLI_CALL, .call = preset_value},
    {"--config", "FILE.json", "options as JSON ({\"fine.iters\": 200} or {\"fine\": {\"iters\": "
     "200}}, optional \"preset\"); unknown keys or out-of-range values are refused", CLI_TEXTS,
     .at = AT(configs), .hi = CLI_TEXTS_MAX},
    {"--set", "key=value", "override one option (after --preset and --config; repeatable)",
     CLI_TEXTS, .at = AT(sets), .hi = CLI_TEXTS_MAX},
    {"--eval", NULL, "afterwards render the test_nv views with every stage's checkpoint and print "
     "PSNR (tone-mapped and gamma-corrected linear, lights off/on)", CLI_FLAG, .at = AT(eval)},
    {"--allow-poor", NULL, "exit 0 even when the run's figures say it failed (above)", CLI_FLAG,
     .at = AT(allow_poor)},
    {0},
};

const struct esr_command cmd_train = {
    .name = "train",
    .summary = "train the model: geometry, radiance, then emission and materials (alphamask .. "
               "pdra)",
    .usage =
    "usage: esr train DATA --out RUN [--until STAGE] [--resume | --force]\n"
    "                 [--preset fast|paper|smoke] [--config FILE.json] [--set key=value ...]\n"
    "                 [--eval] [--allow-poor]\n"
    "\n"
    "Runs the stages alphamask -> coarse -> fine -> lts -> pdra on DATA's train frames (lights\n"
    "off and on): geometry and radiance, then emission, BRDF and environment (lts), then the\n"
    "emitters separated from reflected light (pdra, ray groups with a rising threshold k).\n"
    "RUN receives config.json (the resolved options), log (the progress lines),\n"
    "train_log.jsonl (metrics every log_every iterations) and ckpt_<stage>.bin checkpoints,\n"
    "written atomically at the start and end of each stage and every save_every iterations.\n"
    "Ctrl-C (or SIGTERM) during training saves the checkpoint at the step reached and stops\n"
    "(before the first step, nothing in RUN has changed): --resume loses nothing; a second\n"
    "one stops at once.\n"
    "A RUN that holds anything is refused without --resume (continue it) or --force (start\n"
    "over: the earlier run's checkpoints, lights.json and train_log.jsonl are removed first;\n"
    "its log keeps its lines), so a forgotten --resume never wipes a finished run.\n"
    "A loss or gradient that turns NaN/Inf reloads the last checkpoint with half the learning\n"
    "rate; the third failure stops the run (the checkpoint stays intact).\n"
    "\n"
    "A run that finishes but whose figures say it failed ends with a warning and exit status 2:\n"
    "a last stage whose training PSNR is below the data's floor (a constant colour per lighting\n"
    "plus 3 dB), far more lights than the dataset describes or emitting regions past the\n"
    "lights' limit, non-finite values recovered from. --allow-poor (a deliberately short run)\n"
    "keeps the warning and exits 0.\n"
    "\n"
    "Exit status: 0 on success, 1 on bad arguments, data or a stopped run, 2 on a poor run.\n",
    .options = train_options,
    .help_more = config_help,
    .run = run_train,
};

static void config_help(FILE *out)
{
    fprintf(out, "configuration options (--set key=value, --config FILE.json):\n");
    esr_config_print_help(out);
}

/* --preset: checked where it stands (the defaults every other option applies to). */
static int preset_value(void *args, const struct cli_option *o, const char *value)
{
    struct train_args *a = args;
    (void)o;
    if (esr_preset_from_name(value, &a->preset) != ESR_OK)
        return cli_fail_lib(&cmd_train);
    a->has_preset = 1;
    return 0;
}

static int stage_value(void *args, const struct cli_option *o, const char *value)
{
    struct train_args *a = args;
    (void)o;
    return esr_stage_from_name(value, &a->until) != ESR_OK ? cli_fail_lib(&cmd_train) : 0;
}

struct progress_sink {
    const char *log_path; /* RUN/log, opened at the first line: the trainer creates RUN only
                             once the dataset has passed its checks */
    FILE *log;
    int log_failed;
    int tty;
    int last_was_progress;
};

static void fmt_eta(double s, char *out, size_t n)
{
    long t = (long)(s + 0.5);
    if (t >= 3600)
        snprintf(out, n, "%ldh%02ldm", t / 3600, t / 60 % 60);
    else
        snprintf(out, n, "%ldm%02lds", t / 60, t % 60);
}

static void on_progress(void *user, const struct esr_train_progress *p)
{
    struct progress_sink *s = user;
    char line[1024];
    if (p->event == ESR_TRAIN_STAGE_DONE)
        return; /* the trainer's own message says it */
    if (p->event == ESR_TRAIN_MESSAGE) {
        const char *tag = esr_stage_name(p->stage);
        snprintf(line, sizeof line, "[%s] %s", tag ? tag : "setup", p->message);
    } else {
        char eta[32];
        fmt_eta(p->eta_s, eta, sizeof eta);
        snprintf(line, sizeof line,
                 "[%s] iter %ld/%ld  loss %.5f  psnr %.2f dB  %.0f rays/s  %.1f/%.1f samples/ray  "
                 "ETA %s",
                 esr_stage_name(p->stage), p->iter, p->iters, p->loss, p->psnr, p->rays_per_s,
                 p->kept_per_ray, p->samples_per_ray, eta);
        if (p->has_lts) {
            size_t len = strlen(line);
            snprintf(line + len, sizeof line - len,
                     "  lts off %.4f emo %.4f  %.0f secondary/s (%.0f%% hit)", p->lts_mse_off,
                     p->lts_mse_emo, p->secondary_per_s, 100.0 * p->hit_frac);
        }
        if (p->has_groups) {
            size_t len = strlen(line);
            snprintf(line + len, sizeof line - len, "  k %.3f  %.1f%% uncertain", p->k,
                     100.0 * p->uncertain_frac);
        }
    }
    if (!s->log && !s->log_failed && !(s->log = fopen(s->log_path, "a")))
        s->log_failed = 1; /* the terminal still gets the line */
    if (s->log) {
        fprintf(s->log, "%s\n", line);
        fflush(s->log);
    }
    if (s->tty && p->event == ESR_TRAIN_PROGRESS) {
        fprintf(stderr, "\r%-120s", line);
        s->last_was_progress = 1;
    } else {
        fprintf(stderr, "%s%s\n", s->tty && s->last_was_progress ? "\n" : "", line);
        s->last_was_progress = 0;
    }
    fflush(stderr);
}

/* Held-out PSNR of every stage checkpoint in the run directory. */
static int print_eval(const char *data, const char *run)
{
    printf("test_nv PSNR (dB)    tone-mapped off / on / mean    gamma(linear) off / on / mean\n");
    for (int s = 0; s < ESR_STAGE_COUNT; s++) {
        char path[4200];
        snprintf(path, sizeof path, "%s/ckpt_%s.bin", run, esr_stage_name((enum esr_stage)s));
        if (access(path, R_OK) != 0)
            continue;
        struct esr_quick_eval ev;
        if (esr_quick_eval_run(path, data, &ev) != ESR_OK)
            return ESR_ERR;
        printf("  %-10s         %6.2f %6.2f %6.2f               %6.2f %6.2f %6.2f\n",
               esr_stage_name((enum esr_stage)s), ev.psnr_tone[0], ev.psnr_tone[1],
               0.5 * (ev.psnr_tone[0] + ev.psnr_tone[1]), ev.psnr_lin[0], ev.psnr_lin[1],
               0.5 * (ev.psnr_lin[0] + ev.psnr_lin[1]));
    }
    return ESR_OK;
}

/* Ctrl-C or SIGTERM while training: the first asks the trainer to save its checkpoint at the
 * step it reached and stop (train --resume then loses nothing); a second one, of either kind,
 * kills at once. Only while esr_train_run runs (esr demo and --eval go on to other work). */
static volatile sig_atomic_t interrupted;
static struct sigaction before_int, before_term;

static void on_interrupt(int sig)
{
    static const char msg[] = "\nesr train: stopping: saving the checkpoint at this step (again "
                              "to stop at once)\n";
    (void)sig;
    const int saved_errno = errno;
    interrupted = 1;
    signal(SIGINT, SIG_DFL);
    signal(SIGTERM, SIG_DFL);
    /* `esr train | tee` on Ctrl-C: tee is gone, and a write to it must not kill the save */
    signal(SIGPIPE, SIG_IGN);
    (void)!write(2, msg, sizeof msg - 1);
    errno = saved_errno;
}

static void catch_interrupt(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_interrupt;
    sigemptyset(&sa.sa_mask);
    interrupted = 0;
    sigaction(SIGINT, &sa, &before_int);
    sigaction(SIGTERM, &sa, &before_term);
}

static void release_interrupt(void)
{
    sigaction(SIGINT, &before_int, NULL);
    sigaction(SIGTERM, &before_term, NULL);
}

/* The training's options: the preset's defaults, then each --config, then each --set, in the
 * order given. */
static int resolve_config(const struct train_args *a, struct esr_train_config *cfg)
{
    esr_config_defaults(cfg, a->preset);
    for (int i = 0; i < a->configs.n; i++)
        if (esr_config_load_json(cfg, a->configs.v[i]) != ESR_OK)
            return cli_fail_lib(&cmd_train);
    for (int i = 0; i < a->sets.n; i++)
        if (esr_config_set(cfg, a->sets.v[i]) != ESR_OK)
            return cli_fail_lib(&cmd_train);
    return 0;
}

static int run_train(int argc, char **argv)
{
    struct train_args a;
    memset(&a, 0, sizeof a);
    a.until = ESR_STAGE_PDRA;
    a.preset = ESR_PRESET_FAST;
    const int parsed = cli_parse(&cmd_train, argc, argv, &a);
    if (parsed != CLI_PARSED)
        return parsed == CLI_HELPED ? 0 : 1;
    struct esr_train_opts o;
    memset(&o, 0, sizeof o);
    o.until = a.until;
    o.nan_test_iter = -1;
    o.run_dir = a.out;
    o.resume = a.resume;
    o.force = a.force;
    if (resolve_config(&a, &o.cfg))
        return 1;
    const char *data = a.data, *config = a.configs.n ? a.configs.v[0] : NULL;
    const enum esr_preset preset = a.preset;
    const int do_eval = a.eval, has_preset = a.has_preset, allow_poor = a.allow_poor;
    if (!data)
        return cli_fail(&cmd_train, "missing DATA directory");
    if (!o.run_dir)
        return cli_fail(&cmd_train, "missing --out RUN");
    o.data_dir = data;
    if (o.resume && o.force)
        return cli_fail(&cmd_train, "--resume continues the run in %s and --force starts it over: "
                        "give one", o.run_dir);
    if (o.resume) {
        char cfg_path[4200];
        snprintf(cfg_path, sizeof cfg_path, "%s/config.json", o.run_dir);
        if (esr_file_exists(cfg_path)) {
            struct esr_train_config stored;
            esr_config_defaults(&stored, ESR_PRESET_FAST);
            if (esr_config_load_json(&stored, cfg_path) != ESR_OK)
                return cli_fail_lib(&cmd_train);
            /* the same preset again is harmless (esr demo always names one) */
            if (config || (has_preset && stored.preset != (int)preset))
                return cli_fail(&cmd_train, "--resume continues with %s (preset %s): another "
                                "--preset or a --config would not apply; change single options "
                                "with --set", cfg_path, esr_preset_name((enum esr_preset)stored.preset));
        }
        o.resume_set = a.sets.v;
        o.n_resume_set = a.sets.n;
    }
    char log_path[4200];
    snprintf(log_path, sizeof log_path, "%s/log", o.run_dir);
    struct progress_sink sink = {log_path, NULL, 0, isatty(2), 0};
    o.report = on_progress;
    struct esr_train_health health;
    memset(&health, 0, sizeof health);
    o.health = &health;
    catch_interrupt();
    o.interrupt = &interrupted;
    o.user = &sink;
    int rc = esr_train_run(&o);
    release_interrupt();
    if (sink.tty && sink.last_was_progress)
        fprintf(stderr, "\n");
    char record[4200]; /* run.json says which command made the run (the trainer wrote it) */
    snprintf(record, sizeof record, "%s/run.json", o.run_dir);
    if (health.started && cli_record_into(record, "train", argc, argv) != ESR_OK && rc == ESR_OK)
        rc = ESR_ERR;
    if (rc != ESR_OK && sink.log) /* the log a run leaves says why it stopped (a full disk...) */
        fprintf(sink.log, "esr train: error: %s\n", esr_error_message());
    if (sink.log)
        fclose(sink.log);
    if (rc != ESR_OK)
        return cli_fail_lib(&cmd_train);
    if (do_eval && print_eval(data, o.run_dir) != ESR_OK)
        return cli_fail_lib(&cmd_train);
    char problems[4][320];
    const int n_problems = esr_train_health_problems(&health, problems, 4);
    FILE *log = n_problems ? fopen(log_path, "a") : NULL; /* RUN/log says it too */
    for (int i = 0; i < n_problems; i++) {
        fprintf(stderr, "esr train: warning: %s\n", problems[i]);
        if (log)
            fprintf(log, "esr train: warning: %s\n", problems[i]);
    }
    if (log)
        fclose(log);
    if (n_problems && !allow_poor)
        fprintf(stderr, "esr train: the run finished, but its figures say it failed (exit status "
                        "2; --allow-poor accepts it)\n");
    return n_problems && !allow_poor ? 2 : 0;
}
