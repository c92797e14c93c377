/* Learning-rate schedules as small pure functions of the step; they return the factor or rate
 * for step `step` (0-based) so the training loop stays free of schedule state. */
#ifndef ESR_NN_SCHEDULE_H
#define ESR_NN_SCHEDULE_H

#include <math.h>

#include "core/simd.h"

/* Exponential decay reaching `final_factor` at step `total` (DVGO's lrate_decay: multiply by
 * final_factor^(1/total) every step): final_factor^(step/total). */
ESR_INLINE float esr_lr_exp_factor(long step, long total, float final_factor)
{
    if (total <= 0)
        return 1.0f;
    return powf(final_factor, (float)step / (float)total);
}

/* Linear warm-up from 0 over `warmup` steps (NeuS/Voxurf): step/warmup, then 1. */
ESR_INLINE float esr_lr_warmup_factor(long step, long warmup)
{
    if (warmup <= 0 || step >= warmup)
        return 1.0f;
    return step > 0 ? (float)step / (float)warmup : 0.0f;
}

/* Voxurf's cosine schedule: warm-up, then cosine from 1 down to alpha at step `total`.
 * Past total it stays at alpha. */
ESR_INLINE float esr_lr_cosine_factor(long step, long total, long warmup, float alpha)
{
    if (step < warmup)
        return esr_lr_warmup_factor(step, warmup);
    if (total <= warmup || step >= total)
        return alpha;
    double progress = (double)(step - warmup) / (double)(total - warmup);
    return (float)((cos(3.14159265358979323846 * progress) + 1.0) * 0.5 * (1.0 - alpha) + alpha);
}

#endif
