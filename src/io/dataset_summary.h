/* Facts about a loaded dataset (per-phase counts, camera placement) and their JSON form, shared by
 * `esr info` and the reports of other commands. */
#ifndef ESR_IO_DATASET_SUMMARY_H
#define ESR_IO_DATASET_SUMMARY_H

#include "io/dataset.h"

struct esr_phase_summary {
    int present;
    int n_frames;
    int mode_counts[ESR_LIGHT_MODE_COUNT]; /* frames per lighting mode (esr_frame_mode) */
    float centre_min[3], centre_max[3];    /* bounding box of the camera centres */
    float radius_min, radius_max;          /* camera centre distance from the origin */
    /* the recorded exposures (esr_frame.exposure_ev), per lighting: [0] lights off, [1] on */
    int n_exposure[2];
    double ev_mean[2], ev_min[2], ev_max[2];
};

struct esr_dataset_summary {
    struct esr_phase_summary phases[ESR_PHASE_COUNT];
};

/* Fills out from ds (no I/O). */
void esr_dataset_summarise(const struct esr_dataset *ds, struct esr_dataset_summary *out);

/* Exposure differences that bias what esr estimates, each said to `say` as one line for a user:
 * photos of one set shot at different exposures, the lights-on set shot at another exposure
 * than the lights-off one (the lights' strengths are read from how much brighter the lights-on
 * photos are, so a stop is a factor of two on every light), or exposures recorded for some
 * training photos only. Returns how many lines it said. Differences under
 * ESR_EXPOSURE_TOLERANCE_STOPS are ignored. */
#define ESR_EXPOSURE_TOLERANCE_STOPS 0.1
int esr_dataset_exposure_warnings(const struct esr_dataset_summary *s, esr_problem_fn say, void *user);

/* Writes the dataset facts, the summary and the given problems (may be 0) as a JSON object to
 * path (atomically). */
int esr_dataset_summary_write(const char *path, const struct esr_dataset *ds, const struct esr_dataset_summary *s,
                              const char *const *problems, int n_problems);

#endif
