/* MSE, PSNR, HDR MSE and the emitter IoU accumulator (SSIM lives in ssim.c). */
#include "eval/metrics.h"

#include <math.h>

#include "core/colour.h"
#include "core/error.h"
#include "eval/metrics_internal.h"

int esr_metric_check_same_shape(const struct esr_image *a, const struct esr_image *b, const char *what)
{
    if (!a || !b || !a->data || !b->data)
        return ESR_FAIL("%s: missing image data", what);
    if (a->width != b->width || a->height != b->height || a->channels != b->channels)
        return ESR_FAIL("%s: image shapes differ: %dx%d with %d channels vs %dx%d with %d channels", what,
                        a->width, a->height, a->channels, b->width, b->height, b->channels);
    if (a->width <= 0 || a->height <= 0 || a->channels <= 0)
        return ESR_FAIL("%s: empty image (%dx%d, %d channels)", what, a->width, a->height, a->channels);
    return ESR_OK;
}

int esr_metric_mse(const struct esr_image *a, const struct esr_image *b, double *out)
{
    ESR_TRY(esr_metric_check_same_shape(a, b, "MSE"));
    long long n = (long long)esr_image_count(a);
    const float *pa = a->data, *pb = b->data;
    double sum = 0.0;
    /* Serial on purpose: the sum is then bit-identical for any thread count, and one pass over a
     * few million floats takes milliseconds. */
    for (long long i = 0; i < n; i++) {
        double d = (double)pa[i] - (double)pb[i];
        sum += d * d;
    }
    *out = sum / (double)n;
    return ESR_OK;
}

int esr_metric_psnr(const struct esr_image *a, const struct esr_image *b, double *out)
{
    double mse;
    ESR_TRY(esr_metric_mse(a, b, &mse));
    *out = esr_psnr_from_mse(mse);
    return ESR_OK;
}

int esr_metric_hdr_mse(const struct esr_image *pred_rgb, const struct esr_image *gt_exr, double *out)
{
    static const float white[3] = {1.0f, 1.0f, 1.0f};
    if (!gt_exr || gt_exr->channels != 4)
        return ESR_FAIL("HDR MSE: ground truth must be 4-channel premultiplied RGBA (as read from EXR), got %d "
                        "channels", gt_exr ? gt_exr->channels : 0);
    struct esr_image gt = {0};
    ESR_TRY(esr_image_composite_premultiplied(gt_exr, white, &gt));
    int status = esr_metric_mse(pred_rgb, &gt, out);
    esr_image_free(&gt);
    return status;
}

void esr_iou_init(struct esr_iou_accum *acc)
{
    acc->intersection = 0;
    acc->union_count = 0;
}

int esr_iou_add(struct esr_iou_accum *acc, const struct esr_image *pred_emission, float threshold_k,
                const struct esr_image *gt_mask, float gt_threshold)
{
    if (!pred_emission || !gt_mask || !pred_emission->data || !gt_mask->data)
        return ESR_FAIL("emitter IoU: missing image data");
    if (pred_emission->width != gt_mask->width || pred_emission->height != gt_mask->height)
        return ESR_FAIL("emitter IoU: predicted emission is %dx%d but the ground-truth mask is %dx%d",
                        pred_emission->width, pred_emission->height, gt_mask->width, gt_mask->height);
    int pc = pred_emission->channels, gc = gt_mask->channels;
    int colour = pc >= 3 ? 3 : 1;
    long long n = (long long)pred_emission->width * pred_emission->height;
    uint64_t inter = 0, uni = 0;
    for (long long i = 0; i < n; i++) {
        const float *p = pred_emission->data + i * pc;
        int pred = 0;
        for (int c = 0; c < colour; c++)
            pred |= p[c] > threshold_k;
        int gt = gt_mask->data[i * gc] > gt_threshold;
        inter += (uint64_t)(pred & gt);
        uni += (uint64_t)(pred | gt);
    }
    acc->intersection += inter;
    acc->union_count += uni;
    return ESR_OK;
}

double esr_iou_value(const struct esr_iou_accum *acc)
{
    return acc->union_count ? (double)acc->intersection / (double)acc->union_count : 1.0;
}
