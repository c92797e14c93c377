/* The training driver: stages alphamask -> coarse -> fine (METHOD.md 1-3), each starting from the
 * previous stage's checkpoint and writing its own (RUN/ckpt_<stage>.bin, atomic, also every
 * save_every iterations), plus RUN/config.json (resolved) and RUN/train_log.jsonl (metrics).
 * NaN/Inf in the loss or gradients: reload the stage's last checkpoint, halve the learning rate,
 * continue; after 3 failures in a run, stop with an error (the checkpoint stays intact).
 * Progress goes to a caller-supplied callback (the library never prints). */
#ifndef ESR_TRAIN_TRAINER_H
#define ESR_TRAIN_TRAINER_H

#include <signal.h>

#include "model/config.h"
#include "model/model.h"

#ifdef __cplusplus
extern "C" {
#endif

enum esr_train_event {
    ESR_TRAIN_PROGRESS,   /* periodic metrics (every log_every iterations and at stage end) */
    ESR_TRAIN_MESSAGE,    /* a line for the log (stage start/end, checkpoint, NaN recovery) */
    ESR_TRAIN_STAGE_DONE, /* a stage finished and was saved: iter = iterations run in this call,
                             seconds = their wall time (incl. the final save) */
};

struct esr_train_progress {
    enum esr_train_event event;
    enum esr_stage stage;  /* ESR_STAGE_COUNT: a message about the run, before any stage */
    long iter, iters;      /* iterations done in the stage / total */
    double loss;           /* mean loss of the last window */
    double psnr;           /* batch PSNR of the tone-mapped colour (last window) */
    double rays_per_s;     /* training rays per second over the last window */
    double eta_s;          /* remaining seconds of this stage */
    double seconds;        /* ESR_TRAIN_STAGE_DONE only */
    double samples_per_ray, kept_per_ray; /* marched / MLP-evaluated samples per ray */
    int has_lts;           /* the stage adds the light-transport loss; then: */
    double lts_mse_off, lts_mse_emo; /* its two MSE terms (last window) */
    double secondary_per_s;          /* secondary rays per second */
    double hit_frac;                 /* fraction of secondary rays that hit the surface */
    int has_groups;                  /* pdra: */
    double k;                        /* certainty threshold at the window's end */
    double uncertain_frac;           /* fraction of the batch's rays that are uncertain */
    const char *message;   /* ESR_TRAIN_MESSAGE text */
};

typedef void (*esr_train_report_fn)(void *user, const struct esr_train_progress *p);

/* How a run went, for the warning a failed run must end with (esr_train_health_problems): a
 * training can finish every iteration and still have learned nothing. */
struct esr_train_health {
    int started;               /* setup passed: RUN's config.json and run.json are this run's */
    enum esr_stage last_stage; /* the last stage this call trained or resumed */
    int trained;               /* iterations ran in this call (a run resumed as finished: 0) */
    double last_psnr;          /* the last stage's final window: batch PSNR (dB) of the colour */
    double psnr_floor;         /* what the data sets as failure: the PSNR of painting every pixel
                                  its lighting's mean training colour, plus 3 dB (a model that
                                  does not halve that constant guess's error learned nothing) */
    int nan_recoveries;        /* non-finite losses or gradients recovered from */
    int lights_found, lights_left_out; /* pdra: lights, and emitting regions past ESR_MAX_LIGHTS */
    int lights_listed;         /* lights the dataset's frames describe (0: it does not say) */
    int short_by_design;       /* the smoke preset: a few iterations, poor figures expected (only
                                  non-finite recoveries are then a problem) */
};

struct esr_train_opts {
    const char *data_dir;
    const char *run_dir;           /* created if missing */
    enum esr_stage until;          /* last stage to run */
    int resume;                    /* continue from the checkpoints in run_dir */
    int force;                     /* without resume: start over in a run_dir that holds
                                      anything (its checkpoints removed); without force such a
                                      run_dir is refused, nothing in it changed */
    struct esr_train_config cfg;   /* ignored on resume when run_dir has a config (it wins) */
    const char *const *resume_set; /* on resume with a config: "key=value" options applied over
                                      it (the CLI's --set), checked, and written back to it */
    int n_resume_set;
    esr_train_report_fn report;    /* may be NULL */
    void *user;
    long nan_test_iter;            /* test hook: poison the gradient at this iteration of every
                                      stage from nan_test_stage on (-1 = never) ... */
    int nan_test_times;            /* ... at most this many times in the run */
    enum esr_stage nan_test_stage; /* (0, alphamask: every stage) */
    const volatile sig_atomic_t *interrupt; /* or NULL: when it turns nonzero (a signal handler,
                                      the CLI's Ctrl-C) the stage saves its checkpoint at the
                                      step it reached and the run ends with ESR_ERR, saying so
                                      (before setup is done: refused with RUN unchanged; after
                                      the last stage's iterations: the run finishes) */
    long stop_test_iter;           /* test hook: return ESR_OK right after this iteration of
                                      stage stop_test_stage, without saving, as a kill -9 would
                                      leave the run (0 = never) */
    enum esr_stage stop_test_stage;
    struct esr_train_health *health; /* or NULL: filled as the run goes */
};

/* The problems that say a finished run failed, one line each into lines (at most max): a PSNR
 * below the data's floor, far more lights than the dataset describes (more than twice as many
 * and at least 3 more) or emitting regions past the lights' limit (the emission is fragmented),
 * non-finite recoveries. Returns how many. */
int esr_train_health_problems(const struct esr_train_health *h, char lines[][320], int max);

/* Runs the stages up to opts->until. ESR_ERR with a message on bad data, I/O failure or after
 * repeated NaN failures. */
int esr_train_run(const struct esr_train_opts *opts);

#ifdef __cplusplus
}
#endif
#endif
