/* Batch compositing over rays (see composite.h for the maths). */
#include "volume/composite.h"

#include "core/profile.h"

void esr_composite_weights(int n_rays, const size_t *ray_start, const float *alpha, float thres,
                           float *weight, float *t_last)
{
#pragma omp parallel for schedule(static)
    for (int r = 0; r < n_rays; r++) {
        size_t s0 = ray_start[r];
        t_last[r] = esr_composite_ray_weights(alpha + s0, ray_start[r + 1] - s0, thres, weight + s0);
    }
}

void esr_composite_t_last_bwd(int n_rays, const size_t *ray_start, const float *alpha, float thres,
                              const float *d_t_last, float *d_alpha)
{
#pragma omp parallel for schedule(static)
    for (int r = 0; r < n_rays; r++) {
        const float d = d_t_last[r];
        if (d == 0.0f)
            continue;
        const size_t s0 = ray_start[r], s1 = ray_start[r + 1];
        /* prod_{j != i} (1 - alpha_j) = P / (1 - alpha_i) with P the product of the non-zero
         * factors (dividing a product by one of its factors is well conditioned); a factor of
         * exactly 0 (alpha = 1) leaves only its own sample a non-zero derivative */
        double P = 1.0;
        int zeros = 0;
        for (size_t i = s0; i < s1; i++) {
            if (alpha[i] <= thres)
                continue;
            const double f = 1.0 - (double)alpha[i];
            if (f == 0.0)
                zeros++;
            else
                P *= f;
        }
        for (size_t i = s0; i < s1; i++) {
            if (alpha[i] <= thres)
                continue;
            const double f = 1.0 - (double)alpha[i];
            const double others = zeros == 0 ? P / f : (zeros == 1 && f == 0.0 ? P : 0.0);
            d_alpha[i] -= (float)(d * others);
        }
    }
}

/* Where sample i's values live. */
static size_t row_of(const struct esr_composite_args *a, size_t i)
{
    return a->value_row ? (size_t)a->value_row[i] : i;
}

static const float *bg_of(const struct esr_composite_args *a, int r)
{
    if (!a->bg)
        return 0;
    return a->bg_per_ray ? a->bg + (size_t)r * (size_t)a->channels : a->bg;
}

static void composite_fwd_run(const struct esr_composite_args *a, float *out);

void esr_composite_fwd(const struct esr_composite_args *a, float *out)
{
    esr_prof_enter(ESR_PROF_COMPOSITE);
    composite_fwd_run(a, out);
    esr_prof_exit(ESR_PROF_COMPOSITE);
}

static void composite_fwd_run(const struct esr_composite_args *a, float *out)
{
    const int C = a->channels;
#pragma omp parallel for schedule(static)
    for (int r = 0; r < a->n_rays; r++) {
        float *o = out + (size_t)r * C;
        const float *bg = bg_of(a, r);
        for (int c = 0; c < C; c++)
            o[c] = bg ? a->t_last[r] * bg[c] : 0.0f;
        for (size_t i = a->ray_start[r]; i < a->ray_start[r + 1]; i++) {
            float w = a->weight[i];
            if (!esr_composite_keep(w, a->thres))
                continue;
            const float *v = a->values + row_of(a, i) * (size_t)C;
            for (int c = 0; c < C; c++)
                o[c] += w * v[c];
        }
    }
}

void esr_composite_front(const struct esr_composite_args *a, const float *t, float min_weight,
                         float depth, float *out, float *opacity, float *t_mean)
{
    const int C = a->channels;
#pragma omp parallel for schedule(static)
    for (int r = 0; r < a->n_rays; r++) {
        float *o = out + (size_t)r * C;
        for (int c = 0; c < C; c++)
            o[c] = 0.0f;
        float sum_w = 0.0f, sum_wt = 0.0f, t_end = 0.0f;
        int started = 0;
        for (size_t i = a->ray_start[r]; i < a->ray_start[r + 1]; i++) {
            const float w = a->weight[i];
            if (!esr_composite_keep(w, a->thres) || (!started && w <= min_weight))
                continue;
            if (!started) {
                started = 1;
                t_end = t[i] + depth;
            } else if (t[i] > t_end) {
                break;
            }
            const float *v = a->values + row_of(a, i) * (size_t)C;
            for (int c = 0; c < C; c++)
                o[c] += w * v[c];
            sum_w += w;
            sum_wt += w * t[i];
        }
        opacity[r] = sum_w;
        t_mean[r] = sum_w > 0.0f ? sum_wt / sum_w : 0.0f;
    }
}

static void composite_bwd_run(const struct esr_composite_args *a, const float *d_out, float *d_alpha,
                              float *d_values);

void esr_composite_bwd(const struct esr_composite_args *a, const float *d_out, float *d_alpha,
                       float *d_values)
{
    esr_prof_enter(ESR_PROF_COMPOSITE);
    composite_bwd_run(a, d_out, d_alpha, d_values);
    esr_prof_exit(ESR_PROF_COMPOSITE);
}

static void composite_bwd_run(const struct esr_composite_args *a, const float *d_out, float *d_alpha,
                              float *d_values)
{
    const int C = a->channels;
#pragma omp parallel for schedule(static)
    for (int r = 0; r < a->n_rays; r++) {
        const float *d_o = d_out + (size_t)r * C;
        const float *bg = bg_of(a, r);
        /* dB = d_out . B_i, kept as a scalar: only its dot product with d_out is ever needed */
        float dB = 0.0f;
        if (bg)
            for (int c = 0; c < C; c++)
                dB += d_o[c] * bg[c];
        for (size_t i = a->ray_start[r + 1]; i-- > a->ray_start[r];) {
            float al = a->alpha[i];
            if (al <= a->thres)
                continue; /* dropped: no alpha, no value, B unchanged */
            float w = a->weight[i];
            int keep = esr_composite_keep(w, a->thres);
            float dv = 0.0f; /* d_out . v_i for kept samples */
            if (keep) {
                const size_t row = row_of(a, i) * (size_t)C;
                for (int c = 0; c < C; c++)
                    dv += d_o[c] * a->values[row + c];
                if (d_values)
                    for (int c = 0; c < C; c++)
                        d_values[row + c] += w * d_o[c];
            }
            if (d_alpha)
                d_alpha[i] += (w / al) * (dv - dB);
            dB = al * dv + (1.0f - al) * dB;
        }
    }
}
