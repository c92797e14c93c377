/* The learned background's lookup and its gradient (see background.h). */
#include "fields/background.h"

#include <math.h>

#include "core/colour.h"

/* The four texels around direction d and their bilinear weights. */
struct texels {
    size_t at[4];
    float w[4];
};

static struct texels lookup(const float *d, int on)
{
    const float len = sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) + 1e-20f;
    const float z = fminf(fmaxf(d[2] / len, -1.0f), 1.0f);
    const float u = atan2f(d[1], d[0]) * (0.5f / (float)M_PI) + 0.5f; /* [0, 1] */
    const float v = acosf(z) * (1.0f / (float)M_PI);                  /* [0, 1] */
    /* texel centres at (i + 1/2) / W: wrap in u, clamp in v */
    float x = u * ESR_BACKGROUND_W - 0.5f, y = v * ESR_BACKGROUND_H - 0.5f;
    y = fminf(fmaxf(y, 0.0f), (float)(ESR_BACKGROUND_H - 1));
    const float fx = floorf(x), fy = floorf(y);
    const float tx = x - fx, ty = y - fy;
    int x0 = (int)fx, y0 = (int)fy;
    int x1 = x0 + 1, y1 = y0 + 1 < ESR_BACKGROUND_H ? y0 + 1 : y0;
    x0 = (x0 % ESR_BACKGROUND_W + ESR_BACKGROUND_W) % ESR_BACKGROUND_W;
    x1 = (x1 % ESR_BACKGROUND_W + ESR_BACKGROUND_W) % ESR_BACKGROUND_W;
    const size_t layer = (size_t)(on ? 1 : 0) * ESR_BACKGROUND_H;
    struct texels t;
    t.at[0] = ((layer + (size_t)y0) * ESR_BACKGROUND_W + (size_t)x0) * 3;
    t.at[1] = ((layer + (size_t)y0) * ESR_BACKGROUND_W + (size_t)x1) * 3;
    t.at[2] = ((layer + (size_t)y1) * ESR_BACKGROUND_W + (size_t)x0) * 3;
    t.at[3] = ((layer + (size_t)y1) * ESR_BACKGROUND_W + (size_t)x1) * 3;
    t.w[0] = (1.0f - tx) * (1.0f - ty);
    t.w[1] = tx * (1.0f - ty);
    t.w[2] = (1.0f - tx) * ty;
    t.w[3] = tx * ty;
    return t;
}

/* sigmoid(bilinear logit) of channel c at the texels t */
static float colour(const float *logits, const struct texels *t, int c)
{
    float s = 0.0f;
    for (int k = 0; k < 4; k++)
        s += t->w[k] * logits[t->at[k] + (size_t)c];
    return 1.0f / (1.0f + expf(-s));
}

void esr_background_fwd(const float *logits, const float *dirs3, const uint8_t *lights_on, int n,
                        float *out3)
{
#pragma omp parallel for schedule(static)
    for (int r = 0; r < n; r++) {
        const struct texels t = lookup(dirs3 + (size_t)r * 3, lights_on[r]);
        for (int c = 0; c < 3; c++)
            out3[(size_t)r * 3 + c] = colour(logits, &t, c);
    }
}

void esr_background_fwd_linear(const float *logits, const float *dirs3, const uint8_t *lights_on, int n,
                               float *srgb3, float *lin3)
{
    esr_background_fwd(logits, dirs3, lights_on, n, srgb3);
    for (int i = 0; i < n * 3; i++)
        lin3[i] = esr_linear_from_srgb(srgb3[i]);
}

void esr_background_bwd(const float *logits, const float *dirs3, const uint8_t *lights_on, int n,
                        const float *d_out3, float *g_logits)
{
    for (int r = 0; r < n; r++) {
        const struct texels t = lookup(dirs3 + (size_t)r * 3, lights_on[r]);
        for (int c = 0; c < 3; c++) {
            const float y = colour(logits, &t, c), g = d_out3[(size_t)r * 3 + c] * y * (1.0f - y);
            for (int k = 0; k < 4; k++)
                g_logits[t.at[k] + (size_t)c] += t.w[k] * g;
        }
    }
}
