/* What `esr render` and `esr eval` need from a run directory: the dataset it was trained on and
 * the frames of a phase to work on. */
#ifndef ESR_EVAL_RUN_DIR_H
#define ESR_EVAL_RUN_DIR_H

#include <stddef.h>

#include "io/dataset.h"

/* The dataset directory of run `run`: `override` when non-NULL, else the string member "data"
 * (or "data_dir", "dataset") of RUN/run.json or RUN/config.json, first found. Fails naming the
 * run and the files looked at when none is recorded (then --data must be given). */
int esr_run_data_dir(const char *run, const char *override, char *out, size_t n);
/* The first of "data", "data_dir", "dataset" that the JSON object in text (size bytes, no NUL
 * needed) has as a non-empty string shorter than n, copied to out: 1, else 0 (out untouched). */
int esr_run_data_key(const char *text, size_t size, char *out, size_t n);

/* A loaded dataset, a phase of it and the selected frames of that phase. */
struct esr_run_selection {
    struct esr_dataset ds;
    enum esr_phase_id phase;
    int *idx; /* frame indices into ds.phases[phase].frames */
    int n;
};

/* Checks that `run` is a directory, loads the dataset (esr_run_data_dir), parses the phase name
 * and selects frames (esr_select_frames with `frames` and `limit`). Each failure names its
 * cause: missing run directory, unknown phase (listing the valid names), phase absent from the
 * dataset, unknown frame. Free with esr_run_selection_free (also after an error). */
int esr_run_select(const char *run, const char *data_override, const char *phase, const char *frames, int limit,
                   struct esr_run_selection *sel);
void esr_run_selection_free(struct esr_run_selection *sel);

#endif
