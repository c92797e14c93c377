/* The lights' calibration fit (train/lights/lights.h, esr_lights_calibrate): the rows it solves, the
 * per-channel robust fit of the lights' scales, and the choice of which lights' undecided rims
 * emit. Apart from the tracing that builds the rows, so that they can be tested on rows made up
 * for the purpose. */
#ifndef ESR_TRAIN_LIGHTS_FIT_H
#define ESR_TRAIN_LIGHTS_FIT_H

#include <stddef.h>

#include "model/lights.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ridge towards scale 1, relative to each light's own normal-equation diagonal */
#define ESR_CALIB_RIDGE 1e-3
/* Huber reweighting rounds of the fit (core/ridge_solve.h) */
#define ESR_CALIB_ROBUST_ROUNDS 8
/* a light's undecided rim changes sides when the points' mean change of Huber loss is this many
 * standard errors below 0: a choice the rows make clearly, not one noise makes */
#define ESR_CALIB_RIM_T 3.0

/* Calibration rows, one per point and channel: L_emo - r B ~ sum_K s_K r A_K, both sides times
 * esr_image_error_scale at the point's lights-on radiance, r the lights-off correction of the
 * point's base colour over its median (train/lights/lights.h says why). Kept apart until the medians
 * are known; with K lights (esr_lights.n). */
struct esr_calib_rows {
    size_t n, cap;  /* points */
    double *a;      /* [cap * 3 * K] weighted A: point p, channel c at (p * 3 + c) * K */
    double *ar;     /* [cap * 3 * K] the same from each light's undecided rim (NULL: none) */
    double *br;     /* [cap * 3 * K] weighted, the part of B that is each rim's own emission E:
                       B leaves it out (the rim's light is A's, at the light's scale, when it
                       emits) and it is added back when the rim stays dark (NULL: none) */
    double *emo;    /* [cap * 3] weighted L_emo */
    double *b;      /* [cap * 3] weighted B */
    double *r;      /* [cap * 3] L_off / L^_off */
    double median[3]; /* r's median per channel */
};

/* What the calibration fits: the lights, their rows, which of them are fitted, and scratch. */
struct esr_calib_problem {
    const struct esr_lights *L;
    const struct esr_calib_rows *rows;
    const int *fit; /* [nf] the fitted lights' ids (esr_lights_fitted) */
    int nf;
    double *ca;     /* [rows->n * nf] scratch */
    double *cy;     /* [rows->n] scratch */
};

/* Fits the fitted lights' scales to the rows of *pb, per channel, light K's undecided rim
 * counted as part of it when emits[K] (NULL: no rim counts): scale[c][f]. The residuals' scale
 * per channel (1.4826 median |residual|) goes to sigma_out (or NULL), and when sigma is given
 * each row's Huber loss at that scale to loss [n*3] (point p, channel c at p * 3 + c). Returns 0,
 * -1 when out of memory. */
int esr_calib_fit(const struct esr_calib_problem *pb, const int *emits,
                  double scale[3][ESR_MAX_LIGHTS], const double *sigma, double *sigma_out,
                  double *loss);

/* Decides which lights' undecided rims emit (emits[K]; has_rim[K]: light K has one), by the
 * light they would cast: starting from none, the rim whose light explains the rows best joins,
 * while one does so clearly: the points' paired change of Huber loss (summed over a point's
 * channels, at the residual scale of the fit without rims) is ESR_CALIB_RIM_T standard errors
 * below 0. A rim once on stays on. t_on[K]: light K's rim against the final choice, measured
 * from dark to emitting (negative: its light helps, by -t_on standard errors; with rims that
 * light the same points an emitting one can end above -ESR_CALIB_RIM_T). Returns 0, -1 when out
 * of memory. */
int esr_calib_decide_rims(const struct esr_calib_problem *pb, const int *has_rim,
                          int emits[ESR_MAX_LIGHTS], float t_on[ESR_MAX_LIGHTS]);

/* One line on what the calibration decided about light id's undecided rim (esr_lights.rim),
 * for logs and `esr lights`; returns 0 (writing "") when the light had none. */
int esr_lights_rim_text(const struct esr_lights *L, int id, char *out, size_t size);

#ifdef __cplusplus
}
#endif
#endif
