/* The lights' colour from their own silhouettes (see lights.h, esr_lights_balance). */
#include "train/lights/lights.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/colour.h"
#include "core/error.h"
#include "train/rays.h"
#include "volume/ray.h"

/* rays rendered per call (the candidates are gathered this many at a time) */
#define BALANCE_CHUNK 65536
/* a light's box is its labelled lattice points' grown by this many voxels */
#define BALANCE_BOX_VOX 2.0f
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

/* Renders the n rays (o3/d3) lights on: the linear radiance (lin3, lights showing their
 * lights-off radiance plus their emitted radiance at the lights' current scales) and the
 * composited emitted radiance of the samples on lights (emitted3); either may be NULL. */
static int render_on(const struct esr_model *m, const float *o3, const float *d3, size_t n,
                     float *lin3, float *emitted3)
{
    const struct esr_render_out out = {
        .linear = lin3,
        .emitted_lights = emitted3,
        .lights_emitted_only = 1,
    };
    return n ? esr_model_render_rays(m, o3, d3, n, 1, &out) : ESR_OK;
}

/* Each light's box (min xyz, max xyz): its labelled lattice points', grown by BALANCE_BOX_VOX
 * voxels (a sample takes the label of its cell's nearest labelled corner). */
static void light_boxes(const struct esr_lights *L, float box[ESR_MAX_LIGHTS][6])
{
    const struct esr_grid *g = &L->grid;
    for (int k = 0; k < ESR_MAX_LIGHTS; k++)
        for (int a = 0; a < 3; a++)
            box[k][a] = INFINITY, box[k][3 + a] = -INFINITY;
    for (int z = 0; z < g->nz; z++)
        for (int y = 0; y < g->ny; y++)
            for (int x = 0; x < g->nx; x++) {
                const int id = ESR_LIGHT_LABEL_ID(L->label[esr_grid_index(g, x, y, z)]) - 1;
                if (id < 0 || id >= ESR_MAX_LIGHTS)
                    continue;
                float p[3];
                esr_grid_voxel_pos(g, x, y, z, p);
                for (int a = 0; a < 3; a++) {
                    box[id][a] = fminf(box[id][a], p[a]);
                    box[id][3 + a] = fmaxf(box[id][3 + a], p[a]);
                }
            }
    for (int k = 0; k < ESR_MAX_LIGHTS; k++)
        for (int a = 0; a < 3; a++) {
            const float h = BALANCE_BOX_VOX * esr_grid_voxel_size(g, a);
            box[k][a] -= h, box[k][3 + a] += h;
        }
}

/* Sums of light k's silhouette rows: g.(photo - rest) and g.g per channel, and their count. */
struct silhouette_sums {
    double gy[3], gg[3];
    long rows;
};

/* A batch of light k's candidate rays (lights-on rays, photo sRGB): its field composited at
 * scale 1 (g) and the render with it dark, the other lights at their scales (rest); the
 * unclipped rows the field reaches add g.(photo - rest) and g.g to the sums. g3, rest3
 * [rays->n * 3] scratch. */
static int silhouette_batch(struct esr_model *m, int k, const float scales[][3],
                            const struct esr_ray_set *rays, float *g3, float *rest3,
                            struct silhouette_sums *sum)
{
    const float *o3 = rays->orig3, *d3 = rays->dir3, *rgb3 = rays->rgb3;
    const size_t n = rays->n;
    struct esr_lights *L = &m->lights;
    for (int a = 0; a < L->n; a++)
        for (int c = 0; c < 3; c++)
            L->light[a].scale[c] = a == k ? 1.0f : 0.0f;
    ESR_TRY(render_on(m, o3, d3, n, NULL, g3));
    for (int a = 0; a < L->n; a++)
        for (int c = 0; c < 3; c++)
            L->light[a].scale[c] = a == k ? 0.0f : scales[a][c];
    ESR_TRY(render_on(m, o3, d3, n, rest3, NULL));
    for (size_t r = 0; r < n; r++) {
        const float *g = g3 + r * 3;
        if (fmaxf(g[0], fmaxf(g[1], g[2])) < BALANCE_MIN_FIELD)
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
            sum->gy[c] += (double)g[c] * (double)(y[c] - rest3[r * 3 + (size_t)c]);
            sum->gg[c] += (double)g[c] * (double)g[c];
        }
        sum->rows++;
    }
    return ESR_OK;
}

/* Light k's silhouette scale (sil) and pixel count over the lights-on rays through its box,
 * taken BALANCE_CHUNK at a time: least squares per channel of photo - rest = s g. */
static int silhouette_scale(struct esr_model *m, int k, const float scales[][3],
                            const struct esr_ray_set *rays, const float box[6], float sil[3],
                            long *rows)
{
    const float *orig3 = rays->orig3, *dir3 = rays->dir3, *rgb3 = rays->rgb3;
    const size_t n = rays->n;
    float *buf = malloc((size_t)BALANCE_CHUNK * 15 * sizeof(float));
    if (!buf)
        return ESR_FAIL("lights: out of memory for the colour balance");
    float *o3 = buf, *d3 = buf + BALANCE_CHUNK * 3, *y3 = buf + BALANCE_CHUNK * 6;
    float *g3 = buf + BALANCE_CHUNK * 9, *rest3 = buf + BALANCE_CHUNK * 12;
    struct silhouette_sums sum;
    memset(&sum, 0, sizeof sum);
    size_t got = 0;
    int rc = ESR_OK;
    for (size_t r = 0; r <= n && rc == ESR_OK; r++) {
        float t0, t1;
        if (r < n && esr_ray_box_clip(orig3 + r * 3, dir3 + r * 3, box, box + 3, 0.0f, INFINITY,
                                      &t0, &t1)) {
            memcpy(o3 + got * 3, orig3 + r * 3, 3 * sizeof(float));
            memcpy(d3 + got * 3, dir3 + r * 3, 3 * sizeof(float));
            memcpy(y3 + got * 3, rgb3 + r * 3, 3 * sizeof(float));
            got++;
        }
        if (got == BALANCE_CHUNK || (r == n && got > 0)) {
            const struct esr_ray_set batch = {.n = got, .orig3 = o3, .dir3 = d3, .rgb3 = y3};
            rc = silhouette_batch(m, k, scales, &batch, g3, rest3, &sum);
            got = 0;
        }
    }
    free(buf);
    for (int c = 0; c < 3; c++)
        sil[c] = sum.gg[c] > 0.0 ? (float)(sum.gy[c] / sum.gg[c]) : 0.0f;
    *rows = sum.rows;
    return rc;
}

int esr_lights_balance(struct esr_model *m, const struct esr_ray_set *rs,
                       struct esr_lights_balance_info *info)
{
    struct esr_lights *L = &m->lights;
    const size_t n = rs->n - rs->n_off; /* the lights-on rays follow the lights-off ones */
    const struct esr_ray_set on = {.n = n, /* n_off 0: all lights-on */
                                   .orig3 = rs->orig3 + rs->n_off * 3,
                                   .dir3 = rs->dir3 + rs->n_off * 3,
                                   .rgb3 = rs->rgb3 + rs->n_off * 3,
                                   .transparent = rs->transparent};
    memset(info, 0, sizeof(*info));
    for (int c = 0; c < 3; c++)
        info->applied[c] = 1.0f;
    if (L->n == 0 || n == 0 || L->edited)
        return ESR_OK;
    float scales[ESR_MAX_LIGHTS][3];
    for (int a = 0; a < L->n; a++)
        memcpy(scales[a], L->light[a].scale, sizeof scales[a]);
    float box[ESR_MAX_LIGHTS][6];
    light_boxes(L, box);
    int rc = ESR_OK;
    /* lights too small to fit borrowed their scale: no colour of their own to compare */
    for (int k = 0; rc == ESR_OK && k < L->n; k++)
        if (esr_light_strength_fitted(L, k))
            rc = silhouette_scale(m, k, (const float(*)[3])scales, &on, box[k],
                                  info->silhouette[k], &info->rows[k]);
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
