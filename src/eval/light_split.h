/* esr's split of the emitters into lights, scored against the dataset's per-light masks (the
 * masks are used here only, never by training): per view the rendered N_lights.png (code value
 * id + 1 on the emitter mask) and each light K's mask (the frame's lights[K].mask_path), pixels
 * pooled over the views; dataset light K is scored against the esr light of best IoU with it,
 * and each esr light takes the edits of the dataset light it overlaps most. */
#ifndef ESR_EVAL_LIGHT_SPLIT_H
#define ESR_EVAL_LIGHT_SPLIT_H

#include "io/dataset.h"
#include "model/lights.h"

struct esr_light_split_row {
    int light;             /* dataset light K */
    char name[64];         /* its name in scene.json ("" when not listed) */
    int esr_light;         /* best-matching esr light id, -1 when no esr light overlaps it */
    double iou;            /* pooled IoU of that pair */
    long true_pixels;
};

struct esr_light_split {
    int views;             /* views with N_lights.png and at least one light mask */
    int n;                 /* dataset lights scored */
    struct esr_light_split_row rows[ESR_MAX_TRUE_LIGHTS];
    double mean_iou;
    /* per esr light j: the dataset light whose masks hold at least half of its pixels, -1 when
     * none does (a light the dataset does not have, such as a reflection kept as emission, even
     * if a few of its pixels touch a mask's edge). Edits follow it, so a dataset light that esr
     * found in two pieces is edited in both. (Masks of different lights do not overlap, so at
     * most one holds more than half; two holding half each: the lower id.) */
    int dataset_light[ESR_MAX_LIGHTS];
};

/* Scores the frames idx[0..n) of `phase` rendered in render_dir; views = 0 when none has both. */
int esr_light_split_eval(const struct esr_dataset *ds, enum esr_phase_id phase, const int *idx,
                         int n, const char *render_dir, struct esr_light_split *out);

#endif
