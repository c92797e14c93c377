/* Angular error of rendered surface normals against ground-truth normal maps.
 *
 * Ground truth: datasets written by `esr synth` hold, per test camera CCC, the map
 * DATA/gt/c<CCC>_normal.exr: the world-space outward unit normal of the surface hit by the ray
 * through the pixel centre, (0,0,0) on background (scene.json "ground_truth"). A test frame is
 * mapped to its camera by its name, c<CCC>_<condition> (FORMAT.md's test-frame names); frames
 * named otherwise, and datasets without the map, have no ground truth.
 *
 * Prediction: the rendered N_normal.exr (render/view.h): RGB = the composited world-space
 * normal sum_i w_i n_i (not normalised), A = opacity.
 *
 * A pixel is scored when the ground truth has a surface there (nonzero normal) and the prediction
 * is opaque (opacity > ESR_NORMAL_MIN_OPACITY, nonzero composited normal); its error is the angle
 * between the normalised composited normal and the ground-truth normal, in degrees. */
#ifndef ESR_EVAL_NORMALS_H
#define ESR_EVAL_NORMALS_H

#include <stddef.h>

#include "io/dataset.h"
#include "io/image.h"

#define ESR_NORMAL_MIN_OPACITY 0.5f
#define ESR_NORMAL_GOOD_DEG 10.0 /* "good" pixels: error below this many degrees */

/* Angle between a and b in degrees, in [0, 180]; both are normalised first (any nonzero length
 * works). NAN when either has zero length or a non-finite component. */
double esr_normal_angle_deg(const float a[3], const float b[3]);

/* Path of the ground-truth normal map of frame f ("<root>/gt/c<CCC>_normal.exr"). Returns 1 and
 * fills out when the frame's name has the form c<digits>_... and that file exists, else 0. */
int esr_normal_gt_path(const struct esr_dataset *ds, const struct esr_frame *f, char *out, size_t n);

/* Angular errors of a set of pixels (grown by esr_normal_errors_add). */
struct esr_normal_errors {
    float *deg;   /* errors of the scored pixels, in degrees */
    size_t n, cap;
    long n_gt;    /* pixels where the ground truth has a surface (scored or not) */
};

/* Appends the errors of the scored pixels of pred (4 channels: composited normal, opacity) against
 * gt (3 or 4 channels; only RGB is read) and adds gt's surface pixels to e->n_gt. Fails when the
 * sizes differ or pred lacks its opacity channel. */
int esr_normal_errors_add(struct esr_normal_errors *e, const struct esr_image *pred, const struct esr_image *gt);
void esr_normal_errors_free(struct esr_normal_errors *e);

struct esr_normal_stats {
    long n_gt, n;        /* ground-truth surface pixels, scored pixels */
    double mean_deg;     /* mean error of the scored pixels (NAN when none) */
    double median_deg;
    double frac_good;    /* fraction of scored pixels under ESR_NORMAL_GOOD_DEG */
    double coverage;     /* n / n_gt (NAN when n_gt = 0) */
};

/* Statistics of the n errors deg[0..n) of a set with n_gt ground-truth surface pixels (sorts deg
 * in place). */
struct esr_normal_stats esr_normal_stats_of(float *deg, size_t n, long n_gt);

#endif
