/* The LTS incident-radiance estimators compared on one trained checkpoint for `esr bench`
 * (issue: every shortcut measured against the faithful estimator on the same scene).
 *
 * Points: P surface points (the strongest kept sample of evenly spaced pixels of a test view
 * that reach a surface), outgoing direction = the camera's. Reference: the faithful estimator
 * (volume-rendered L_i, uniform directions) averaged over REF_CALLS independent calls of 256
 * directions. Each estimator runs `repeats` calls with fresh directions on the same points:
 *   bias = RMS over points and channels of (mean estimate - reference)
 *   sd   = RMS over points and channels of the per-call standard deviation
 *   noise = the bias that the two means' standard errors alone would show
 * both relative to the RMS of the reference, for L^_off and L^_emo; the time of one LTS loss
 * call (forward and backward, P points) and its secondary rays per second. */
#ifndef ESR_EVAL_BENCH_LTS_H
#define ESR_EVAL_BENCH_LTS_H

#define ESR_BENCH_LTS_MAX_ROWS 4

struct esr_bench_lts_row {
    char name[32];
    int estimator, dirs;
    double ms_per_call, secondary_per_s, hit_frac;
    double bias_off, bias_emo, sd_off, sd_emo; /* relative to the reference RMS */
    double noise_off, noise_emo; /* the bias that noise alone would read (both means' standard
                                    errors), same units: a bias near it is no bias */
};

struct esr_bench_lts_result {
    char stage[16];
    int points, repeats, ref_dirs;
    double ref_rms_off, ref_rms_emo;
    int n_rows;
    struct esr_bench_lts_row rows[ESR_BENCH_LTS_MAX_ROWS];
};

/* Runs the comparison on checkpoint ckpt (an lts or pdra stage) of dataset data_dir. */
int esr_bench_lts(const char *ckpt, const char *data_dir, int repeats,
                  struct esr_bench_lts_result *r);

#endif
