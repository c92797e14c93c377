/* Batch form of the rendering loss (see render_loss.h). */
#include "train/render_loss.h"

void esr_render_loss_batch(const float *tone3, const float *lin3, const float *target3, size_t n,
                           float lambda_tau, float *d_tone3, float *d_lin3,
                           struct esr_render_loss_result *res)
{
    double loss = 0.0, mt = 0.0, ml = 0.0;
    const size_t m = n * 3;
    const float inv = m ? 1.0f / (float)m : 0.0f;
#pragma omp parallel for schedule(static) reduction(+ : loss, mt, ml)
    for (size_t i = 0; i < m; i++) {
        float c = tone3[i], l = lin3[i], t = target3[i];
        loss += esr_render_loss_fwd(c, l, t, lambda_tau);
        float ct = c < 0.0f ? 0.0f : (c > 1.0f ? 1.0f : c);
        float g = esr_srgb_from_linear(esr_render_loss_lin_clamp(l, t)) - t;
        mt += (double)(ct - t) * (ct - t);
        ml += (double)g * g;
        float dt, dl;
        esr_render_loss_bwd(c, l, t, lambda_tau, &dt, &dl);
        if (d_tone3)
            d_tone3[i] = dt * inv;
        if (d_lin3)
            d_lin3[i] = dl * inv;
    }
    res->loss = m ? loss / (double)m : 0.0;
    res->mse_tone = m ? mt / (double)m : 0.0;
    res->mse_lin = m ? ml / (double)m : 0.0;
}
