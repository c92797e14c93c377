/* The lights' colour from their own silhouettes (see lights.h, esr_lights_balance). */
#include "train/lights.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/colour.h"
#include "core/error.h"

/* rays per render call */
#define BALANCE_CHUNK 65536
/* a silhouette pixel: the light's composited field (scale 1) reaches this in some channel ... */
#define BALANCE_MIN_FIELD 0.01f
/* ... and the photo is below this in every channel (linear; sRGB 0.9, the calibration's clip) */
#define BALANCE_MAX_ON 0.79f
/* a light votes with at least this many silhouette pixels */
#define BALANCE_MIN_ROWS 50
/* the balance found is clamped to [1 / this, this] per channel */
#define BALANCE_MAX 2.0f

int esr_lights_balance_solve(int n, const float sil[][3], const float scale[][3], const long rows[],
                             float b[3])
{
    double acc[3] = {0.0, 0.0, 0.0}, weight = 0.0;
    int used = 0;
    for (int k = 0; k < n; k++) {
        int ok = rows[k] >= BALANCE_MIN_ROWS;
        for (int c = 0; c < 3 && ok; c++)
            ok = sil[k][c] > 0.0f && scale[k][c] > 0.0f && isfinite(sil[k][c]) &&
                 isfinite(scale[k][c]);
        if (!ok)
            continue;
        double q[3], mean = 0.0;
        for (int c = 0; c < 3; c++) { /* the calibration's colour over the silhouette's */
            q[c] = log((double)scale[k][c] / (double)sil[k][c]);
            mean += q[c] / 3.0;
        }
        for (int c = 0; c < 3; c++)
            acc[c] += (double)rows[k] * (q[c] - mean);
        weight += (double)rows[k];
        used++;
    }
    for (int c = 0; c < 3; c++) {
        const float v = used ? (float)exp(acc[c] / weight) : 1.0f;
        b[c] = fminf(fmaxf(v, 1.0f / BALANCE_MAX), BALANCE_MAX);
    }
    return used;
}

/* Renders the n rays (o3/d3) lights on in chunks: the linear radiance (lin3, lights showing their
 * lights-off radiance plus their emitted radiance at the lights' current scales) and the
 * composited emitted radiance of the samples on lights (emitted3); either may be NULL. */
static int render_on(const struct esr_model *m, const float *o3, const float *d3, size_t n,
                     float *lin3, float *emitted3)
{
    for (size_t i0 = 0; i0 < n; i0 += BALANCE_CHUNK) {
        const size_t c = n - i0 < BALANCE_CHUNK ? n - i0 : BALANCE_CHUNK;
        const struct esr_render_out out = {
            .linear = lin3 ? lin3 + i0 * 3 : NULL,
            .emitted_lights = emitted3 ? emitted3 + i0 * 3 : NULL,
            .lights_emitted_only = 1,
        };
        ESR_TRY(esr_model_render_rays(m, o3 + i0 * 3, d3 + i0 * 3, c, 1, &out));
    }
    return ESR_OK;
}

/* Light k's silhouette pixels among the candidate rays (o3/d3/rgb3 [n*3], the photo sRGB): its
 * field composited at scale 1 (g) and the rest of the render with it dark, the other lights at
 * their scales (rest); least squares per channel of photo - rest = s g. */
static int silhouette_scale(struct esr_model *m, int k, const float scales[][3], const float *o3,
                            const float *d3, const float *rgb3, size_t n, float *g, float *rest,
                            float sil[3], long *rows)
{
    struct esr_lights *L = &m->lights;
    for (int a = 0; a < L->n; a++)
        for (int c = 0; c < 3; c++)
            L->light[a].scale[c] = a == k ? 1.0f : 0.0f;
    ESR_TRY(render_on(m, o3, d3, n, NULL, g));
    for (int a = 0; a < L->n; a++)
        for (int c = 0; c < 3; c++)
            L->light[a].scale[c] = a == k ? 0.0f : scales[a][c];
    ESR_TRY(render_on(m, o3, d3, n, rest, NULL));
    double gy[3] = {0.0, 0.0, 0.0}, gg[3] = {0.0, 0.0, 0.0};
    *rows = 0;
    for (size_t r = 0; r < n; r++) {
        const float *gr = g + r * 3;
        if (fmaxf(gr[0], fmaxf(gr[1], gr[2])) < BALANCE_MIN_FIELD)
            continue;
        float y[3];
        int clipped = 0;
        for (int c = 0; c < 3; c++) {
            y[c] = esr_linear_from_srgb(rgb3[r * 3 + (size_t)c]);
            clipped |= y[c] >= BALANCE_MAX_ON;
        }
        if (clipped) /* says only "at least this bright" */
            continue;
        for (int c = 0; c < 3; c++) {
            gy[c] += (double)gr[c] * (double)(y[c] - rest[r * 3 + (size_t)c]);
            gg[c] += (double)gr[c] * (double)gr[c];
        }
        (*rows)++;
    }
    for (int c = 0; c < 3; c++)
        sil[c] = gg[c] > 0.0 ? (float)(gy[c] / gg[c]) : 0.0f;
    return ESR_OK;
}

int esr_lights_balance(struct esr_model *m, const float *orig3, const float *dir3,
                       const float *rgb3, size_t n, struct esr_lights_balance_info *info)
{
    struct esr_lights *L = &m->lights;
    memset(info, 0, sizeof(*info));
    for (int c = 0; c < 3; c++)
        info->applied[c] = 1.0f;
    if (L->n == 0 || n == 0 || L->edited)
        return ESR_OK;
    float scales[ESR_MAX_LIGHTS][3];
    for (int a = 0; a < L->n; a++)
        memcpy(scales[a], L->light[a].scale, sizeof scales[a]);
    /* the candidates: rays that any light's field reaches */
    float *g = malloc(BALANCE_CHUNK * 3 * sizeof(float));
    size_t *pick = NULL, np = 0, cap = 0;
    int rc = g ? ESR_OK : ESR_FAIL("lights: out of memory for the colour balance");
    for (int a = 0; a < L->n; a++)
        for (int c = 0; c < 3; c++)
            L->light[a].scale[c] = 1.0f;
    for (size_t i0 = 0; rc == ESR_OK && i0 < n; i0 += BALANCE_CHUNK) {
        const size_t c = n - i0 < BALANCE_CHUNK ? n - i0 : BALANCE_CHUNK;
        rc = render_on(m, orig3 + i0 * 3, dir3 + i0 * 3, c, NULL, g);
        for (size_t r = 0; rc == ESR_OK && r < c; r++) {
            if (fmaxf(g[r * 3], fmaxf(g[r * 3 + 1], g[r * 3 + 2])) < BALANCE_MIN_FIELD)
                continue;
            if (np == cap) {
                size_t *t = realloc(pick, (cap ? 2 * cap : 4096) * sizeof(size_t));
                if (!t) {
                    rc = ESR_FAIL("lights: out of memory for the colour balance");
                    break;
                }
                pick = t;
                cap = cap ? 2 * cap : 4096;
            }
            pick[np++] = i0 + r;
        }
    }
    free(g);
    float *o = malloc((np ? np : 1) * 3 * sizeof(float)), *d = malloc((np ? np : 1) * 3 * sizeof(float));
    float *y = malloc((np ? np : 1) * 3 * sizeof(float)), *gk = malloc((np ? np : 1) * 3 * sizeof(float));
    float *rest = malloc((np ? np : 1) * 3 * sizeof(float));
    if (rc == ESR_OK && !(o && d && y && gk && rest))
        rc = ESR_FAIL("lights: out of memory for the colour balance");
    for (size_t i = 0; rc == ESR_OK && i < np; i++) {
        memcpy(o + i * 3, orig3 + pick[i] * 3, 3 * sizeof(float));
        memcpy(d + i * 3, dir3 + pick[i] * 3, 3 * sizeof(float));
        memcpy(y + i * 3, rgb3 + pick[i] * 3, 3 * sizeof(float));
    }
    free(pick);
    /* lights too small to fit borrowed their scale: no colour of their own to compare */
    for (int k = 0; rc == ESR_OK && k < L->n; k++)
        if (esr_light_strength_fitted(L, k))
            rc = silhouette_scale(m, k, (const float(*)[3])scales, o, d, y, np, gk, rest,
                                  info->silhouette[k], &info->rows[k]);
    free(o), free(d), free(y), free(gk), free(rest);
    for (int a = 0; a < L->n; a++)
        memcpy(L->light[a].scale, scales[a], sizeof scales[a]);
    if (rc != ESR_OK)
        return rc;
    info->used = esr_lights_balance_solve(L->n, (const float(*)[3])info->silhouette,
                                          (const float(*)[3])scales, info->rows, info->applied);
    if (info->used == 0)
        return ESR_OK;
    float b[3];
    esr_lights_balance_of(L, b);
    for (int c = 0; c < 3; c++) {
        L->balance[c] = b[c] * info->applied[c];
        for (int a = 0; a < L->n; a++)
            L->light[a].scale[c] /= info->applied[c];
    }
    for (int a = 0; a < L->n; a++)
        esr_light_update_radiance(&L->light[a]);
    return ESR_OK;
}

void esr_lights_balance_text(const struct esr_model *m, const struct esr_lights_balance_info *info,
                             char *out, size_t size)
{
    const struct esr_lights *L = &m->lights;
    if (info->used == 0) {
        snprintf(out, size, "colour balance: none (no light shows %d unclipped silhouette pixels; "
                            "the lights keep the colour the environment map's start gives them)",
                 BALANCE_MIN_ROWS);
        return;
    }
    float b[3];
    esr_lights_balance_of(L, b);
    int at = snprintf(out, size, "colour balance from the lights' silhouettes: x %.3f %.3f %.3f "
                                 "(base colour; the lights and the environment map over it; this "
                                 "pass %.3f %.3f %.3f; pixels",
                      (double)b[0], (double)b[1], (double)b[2], (double)info->applied[0],
                      (double)info->applied[1], (double)info->applied[2]);
    for (int k = 0; k < L->n && at > 0 && (size_t)at < size; k++)
        if (info->rows[k] > 0)
            at += snprintf(out + at, size - (size_t)at, " light %d: %ld", k, info->rows[k]);
    if (at > 0 && (size_t)at < size)
        snprintf(out + at, size - (size_t)at, ")");
}
