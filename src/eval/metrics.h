/* Image-quality and emitter-identification metrics used by the evaluation (METHOD.md,
 * "Emitter identification and metrics"). All functions work on in-memory images and never touch
 * files; values are read as stored (the caller composites and tone-maps beforehand). */
#ifndef ESR_EVAL_METRICS_H
#define ESR_EVAL_METRICS_H

#include <stdint.h>

#include "io/image.h"

/* Mean of (a-b)^2 over every pixel and channel, accumulated in double. a and b must have the same
 * width, height and channel count (else ESR_ERR naming both shapes). */
int esr_metric_mse(const struct esr_image *a, const struct esr_image *b, double *out);

/* PSNR of a against b (peak 1.0, meant for images in [0,1]); same shape rules as esr_metric_mse. */
int esr_metric_psnr(const struct esr_image *a, const struct esr_image *b, double *out);

/* SSIM, the variant the NeRF literature reports (JAXNeRF / mip-NeRF `compute_ssim`): 11x11
 * Gaussian window with sigma 1.5 applied as two separable 1-D passes with 'valid' borders (the
 * map is (W-10) x (H-10)), K1 = 0.01, K2 = 0.03, max_val = 1, variances clipped at 0 and the
 * covariance clipped to +-sqrt(var_a var_b); every channel is treated as its own grey image and the
 * result is the mean of the map over pixels and channels. Needs width, height >= 11. */
int esr_metric_ssim(const struct esr_image *a, const struct esr_image *b, double *out);

/* HDR MSE (METHOD.md): prediction `pred_rgb` (3-channel linear RGB, already composited on white)
 * against a ground-truth EXR image `gt_exr` as esr_exr_read returns it (4-channel premultiplied
 * RGBA), which is composited on white here before the MSE. */
int esr_metric_hdr_mse(const struct esr_image *pred_rgb, const struct esr_image *gt_exr, double *out);

/* Emitter-mask IoU accumulated over many views: sum of intersections / sum of unions. */
struct esr_iou_accum {
    uint64_t intersection; /* pixels that are emitters in both prediction and ground truth */
    uint64_t union_count;  /* pixels that are emitters in either */
};

void esr_iou_init(struct esr_iou_accum *acc);
/* Adds one view. A predicted pixel is an emitter when any colour channel of `pred_emission`
 * (volume-rendered E, linear; channels 1..4, colour = first 3 when >= 3 else the first) exceeds
 * `threshold_k` (the current PDRA k); a ground-truth pixel is an emitter when channel 0 of
 * `gt_mask` (test_nv/emission PNGs) exceeds `gt_threshold` (0.5 in METHOD.md). Sizes must match. */
int esr_iou_add(struct esr_iou_accum *acc, const struct esr_image *pred_emission, float threshold_k,
                const struct esr_image *gt_mask, float gt_threshold);
/* sum(intersection) / sum(union); 1.0 when the union is empty (no emitter predicted or present in
 * any view counts as perfect agreement). */
double esr_iou_value(const struct esr_iou_accum *acc);

#endif
