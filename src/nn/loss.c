/* Batched losses: one pass computes the mean and adds the scaled gradient. */
#include "nn/loss.h"

#define LOSS_PARTS 64

enum loss_kind { LOSS_MSE, LOSS_L1, LOSS_HUBER };

/* Shared loop; `kind` is a compile-time constant at each call site after inlining. */
static inline double loss_run(enum loss_kind kind, const float *pred, const float *target,
                              size_t n, float delta, float weight, float *d_pred)
{
    if (n == 0)
        return 0.0;
    /* Fixed partition into LOSS_PARTS partial sums added in order: the value does not depend on
     * the thread count. */
    double part[LOSS_PARTS] = {0};
    float gscale = weight / (float)n;
#pragma omp parallel for schedule(static) if (n > 65536)
    for (int c = 0; c < LOSS_PARTS; c++) {
        size_t b = n * (size_t)c / LOSS_PARTS, e = n * (size_t)(c + 1) / LOSS_PARTS;
        double s = 0.0;
        for (size_t i = b; i < e; i++) {
            float p = pred[i], t = target[i], v, g;
            if (kind == LOSS_MSE) {
                v = esr_mse_fwd(p, t);
                g = esr_mse_bwd(p, t);
            } else if (kind == LOSS_L1) {
                v = esr_l1_fwd(p, t);
                g = esr_l1_bwd(p, t);
            } else {
                v = esr_huber_fwd(p, t, delta);
                g = esr_huber_bwd(p, t, delta);
            }
            s += v;
            if (d_pred)
                d_pred[i] += gscale * g;
        }
        part[c] = s;
    }
    double sum = 0.0;
    for (int c = 0; c < LOSS_PARTS; c++)
        sum += part[c];
    return weight * sum / (double)n;
}

double esr_loss_mse(const float *pred, const float *target, size_t n, float weight, float *d_pred)
{
    return loss_run(LOSS_MSE, pred, target, n, 0.0f, weight, d_pred);
}

double esr_loss_l1(const float *pred, const float *target, size_t n, float weight, float *d_pred)
{
    return loss_run(LOSS_L1, pred, target, n, 0.0f, weight, d_pred);
}

double esr_loss_huber(const float *pred, const float *target, size_t n, float delta, float weight,
                      float *d_pred)
{
    return loss_run(LOSS_HUBER, pred, target, n, delta, weight, d_pred);
}
