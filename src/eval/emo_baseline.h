/* The seed's Table 3 "(*)" baseline: emitters found without the lts/pdra stages, by
 * thresholding the extra radiance the lights add, L_emo = L_on - L_off, at the threshold that
 * suits the ground truth best. It shows what the emitter stages add over the fine stage's
 * radiance split. esr computes L_emo per test camera from the rendered linear images of its
 * lights-on and lights-off frames (N.exr; frames named c<CCC>_on / c<CCC>_off, as in the
 * ESR layout's test_nv), so it needs no extra rendering. */
#ifndef ESR_EVAL_EMO_BASELINE_H
#define ESR_EVAL_EMO_BASELINE_H

#include "io/dataset.h"

struct esr_emo_baseline {
    int n_cameras;   /* cameras with both frames rendered and a ground-truth emission mask */
    double iou;      /* the best pooled IoU over every threshold */
    double k;        /* its threshold on max-channel L_emo (linear) */
};

/* Over the lights-on frames among idx[0..n) of `phase` whose lights-off partner was rendered
 * too: pooled IoU of (max_c L_emo > k) against <phase>/emission/<on name>.png, the best over
 * every k (an exact sweep of the sorted values; the seed searched steps of 0.01, until
 * 2026-11-28 esr 64 log-spaced k, which on lamp found 0.9655 where the sweep finds 0.9668).
 * n_cameras 0 (and ESR_OK) when no camera has all three files. */
int esr_emo_baseline_eval(const struct esr_dataset *ds, enum esr_phase_id phase, const int *idx,
                          int n, const char *render_dir, struct esr_emo_baseline *out);

#endif
