/* The lights' strengths solved from the lights-on photos (see lights/solve.h): the rows. */
#include "train/lights/solve.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/brdf.h"
#include "core/colour.h"
#include "core/error.h"
#include "core/order.h"
#include "core/rng.h"
#include "core/simd.h"
#include "core/vec3.h"
#include "fields/grid.h"
#include "model/material_fields.h"
#include "model/render_sdf.h"
#include "train/lights/direct.h"
#include "train/lights/surface.h"
#include "train/lts.h"

/* rays rendered per batch */
#define SOLVE_CHUNK 8192
/* a ray with a surface: opacity at least this (the rest is background in the pixel) */
#define SOLVE_OPACITY 0.95f
/* points per call of the lights-off correction's light transport */
#define SOLVE_LTS_CHUNK 1024
/* the lights-off correction L_off / L^_off is clamped to [1 / this, this] */
#define SOLVE_MAX_CORRECTION 4.0f
/* a light reaches a row when its column there is at least this (linear) */
#define SOLVE_REACH 1e-3f

/* What the rows of one batch need from the render. */
struct solve_batch {
    float *o3, *d3, *lin3, *emit3, *opac, *depth, *mat5, *fopac, *fdepth, *fmat5, *x3, *nrm3;
    int32_t *ids;
};

static void batch_free(struct solve_batch *b)
{
    free(b->o3), free(b->d3), free(b->lin3), free(b->emit3), free(b->opac), free(b->depth);
    free(b->mat5), free(b->fopac), free(b->fdepth), free(b->fmat5), free(b->x3), free(b->nrm3);
    free(b->ids);
}

static int batch_alloc(struct solve_batch *b)
{
    const size_t n = SOLVE_CHUNK;
    memset(b, 0, sizeof *b);
    b->o3 = malloc(n * 3 * sizeof(float)), b->d3 = malloc(n * 3 * sizeof(float));
    b->lin3 = malloc(n * 3 * sizeof(float)), b->emit3 = malloc(n * 3 * sizeof(float));
    b->opac = malloc(n * sizeof(float)), b->depth = malloc(n * sizeof(float));
    b->mat5 = malloc(n * ESR_BRDF_CHANNELS * sizeof(float));
    b->fopac = malloc(n * sizeof(float)), b->fdepth = malloc(n * sizeof(float));
    b->fmat5 = malloc(n * ESR_BRDF_CHANNELS * sizeof(float));
    b->x3 = malloc(n * 3 * sizeof(float)), b->nrm3 = malloc(n * 3 * sizeof(float));
    b->ids = malloc(n * sizeof(int32_t));
    if (b->o3 && b->d3 && b->lin3 && b->emit3 && b->opac && b->depth && b->mat5 && b->fopac &&
        b->fdepth && b->fmat5 && b->x3 && b->nrm3 && b->ids)
        return ESR_OK;
    batch_free(b);
    return ESR_FAIL("lights: out of memory for the strength solve's rays");
}

/* Whether ray p has one surface, opaque: no silhouette against what lies behind it (the
 * direct relight's two layers, model/model.h esr_render_two_surfaces). */
static int single_surface(const struct solve_batch *b, size_t p, float voxel)
{
    float d2;
    return b->opac[p] >= SOLVE_OPACITY &&
           !esr_render_two_surfaces(b->opac[p], b->depth[p], b->fopac[p], b->fdepth[p], voxel, &d2);
}

/* The lights-on rays to solve from: want of them, one drawn at random in each of want equal
 * strata of the set's order (images, rows), or all when there are fewer. */
static size_t pick_ray(size_t n_on, size_t want, size_t i, struct esr_rng *rng)
{
    if (n_on <= want)
        return i;
    const size_t lo = i * n_on / want, hi = (i + 1) * n_on / want;
    return lo + (size_t)(esr_rng_u64(rng) % (hi > lo ? hi - lo : 1));
}

/* Builds batch b's rows (first row `row`): columns a and a2 [(row * 3 + c) * K + k] (each from
 * half of the spp light samples), targets y and kinds, each weighted by esr_image_error_scale at
 * the photo's value. */
struct solve_ctx {
    const struct esr_model *m;
    const struct esr_light_samples *ls; /* each light's samples at scale 1 */
    const struct esr_light_shadows *sh;
    int spp;
    uint64_t seed;
};

ESR_HOT static void batch_rows(const struct solve_ctx *ctx, const struct solve_batch *b,
                               const float *rgb3, size_t nb, size_t row,
                               const struct esr_solve_rows *rows)
{
    const struct esr_model *m = ctx->m;
    const struct esr_light_samples *ls = ctx->ls;
    const struct esr_light_shadows *sh = ctx->sh;
    const int spp = ctx->spp;
    const uint64_t seed = ctx->seed;
    float *a = rows->a, *a2 = rows->a2, *y = rows->y;
    uint8_t *kind = rows->kind;
    const int K = m->lights.n, seen_exact = m->cfg.lights_solve_seen;
#pragma omp parallel for schedule(dynamic, 16)
    for (size_t p = 0; p < nb; p++) {
        const size_t i = row + p;
        uint8_t *ki = kind + i * 3;
        memset(ki, 0, 3);
        struct esr_vec3 n = esr_v3_at(b->nrm3, p);
        if (!single_surface(b, p, sh->voxel) || esr_v3_length(n) < 1e-6f)
            continue;
        n = esr_v3_normalize(n);
        const float op = b->opac[p];
        const struct esr_vec3 x = esr_v3_at(b->x3, p), wo = esr_v3_scale(esr_v3_at(b->d3, p), -1.0f);
        const struct esr_material mat = esr_material_of_row(b->mat5 + p * ESR_BRDF_CHANNELS, op);
        /* two independent halves of the samples (esr_lights_solve_fit says why) */
        struct esr_rng rng = esr_rng_init(seed, i), rng2 = esr_rng_init(~seed, i);
        float col[ESR_MAX_LIGHTS][3], col2[ESR_MAX_LIGHTS][3];
        memset(col, 0, sizeof col);
        memset(col2, 0, sizeof col2);
        const int half = spp > 1 ? spp / 2 : 1;
        for (int k = 0; k < K; k++) {
            if (ls[k].n == 0 || ls[k].max_emit <= 0.0f)
                continue;
            const struct esr_direct_point_query q = {sh, &ls[k], NULL, half, &mat, x, n, &wo, 1, op};
            (void)esr_light_direct_point(&q, &rng, &col[k], NULL, NULL);
            (void)esr_light_direct_point(&q, &rng2, &col2[k], NULL, NULL);
        }
        const int id = b->ids[p];
        const int on_light = id >= 0 && id < K;
        if (on_light) /* the light as the pixel sees it (at scale 1) */
            for (int c = 0; c < 3; c++) {
                col[id][c] += b->emit3[p * 3 + c];
                col2[id][c] += b->emit3[p * 3 + c];
            }
        for (int c = 0; c < 3; c++) {
            const float photo = rgb3[p * 3 + c], lin = esr_linear_from_srgb(photo);
            const int exact = lin < ESR_SOLVE_EXACT && (!on_light || seen_exact),
                      bound = lin >= ESR_SOLVE_CLIPPED;
            int finite = isfinite(b->lin3[p * 3 + c]);
            for (int k = 0; k < K; k++)
                finite &= isfinite(col[k][c]) && isfinite(col2[k][c]);
            if ((!exact && !bound) || !finite) /* a NaN in the model's render is no evidence */
                continue;
            const float w = esr_image_error_scale(exact ? lin : 1.0f);
            ki[c] = exact ? 1 : 2;
            y[i * 3 + (size_t)c] = w * ((exact ? lin : 1.0f) - b->lin3[p * 3 + c]);
            for (int k = 0; k < K; k++) {
                a[(i * 3 + (size_t)c) * (size_t)K + (size_t)k] = w * col[k][c];
                a2[(i * 3 + (size_t)c) * (size_t)K + (size_t)k] = w * col2[k][c];
            }
        }
    }
}

/* The lights-off correction of each surface ray of batch b: r = L_off / L^_off per channel, the
 * lights-off radiance field over the model's own estimate of it from its BRDF and what reaches
 * the point (the LTS, first hit, `dirs` directions), clamped (1 where there is no surface). Base
 * colour next to a light absorbs some of the light its clipped photos show; the lights-off photos
 * did not see that light, so where the estimate exceeds the field the base colour is too high by
 * as much, and the light it reflects with it. */
static int batch_correction(struct esr_model *m, struct esr_lts *l, const struct solve_batch *b,
                            size_t nb, float voxel, uint64_t seed, float *r3)
{
    const float *sdf = esr_model_values(m, ESR_COMP_SDF);
    float *pos = malloc(SOLVE_LTS_CHUNK * 3 * sizeof(float)), *dir = malloc(SOLVE_LTS_CHUNK * 3 * sizeof(float));
    size_t *which = malloc(SOLVE_LTS_CHUNK * sizeof(size_t));
    int rc = pos && dir && which ? ESR_OK : ESR_FAIL("lights: out of memory for the lights-off correction");
    for (size_t p = 0; p < nb * 3; p++)
        r3[p] = 1.0f;
    for (size_t p0 = 0; rc == ESR_OK && p0 < nb;) {
        size_t P = 0;
        for (; p0 < nb && P < SOLVE_LTS_CHUNK; p0++)
            if (single_surface(b, p0, voxel)) {
                memcpy(pos + P * 3, b->x3 + p0 * 3, 3 * sizeof(float));
                memcpy(dir + P * 3, b->d3 + p0 * 3, 3 * sizeof(float));
                which[P++] = p0;
            }
        if (P == 0)
            continue;
        struct esr_march pts; /* the points as a kept list: the LTS takes each once */
        memset(&pts, 0, sizeof pts);
        pts.n_kept = P;
        pts.kpos3 = pos;
        pts.kdir3 = dir;
        struct esr_lts_stats st;
        const struct esr_lts_batch lb = {&pts, NULL, seed + p0};
        rc = esr_lts_run(l, m, sdf, NULL, NULL, &lb, &st);
        for (size_t q = 0; rc == ESR_OK && q < P; q++)
            for (int c = 0; c < 3; c++) {
                const float off = l->pf.lin3[(q * 4) * 3 + (size_t)c], hat = l->hat3[(q * 2) * 6 + (size_t)c];
                const float v = hat > 1e-6f && isfinite(hat) ? off / hat : 1.0f;
                r3[which[q] * 3 + (size_t)c] =
                    fminf(fmaxf(v, 1.0f / SOLVE_MAX_CORRECTION), SOLVE_MAX_CORRECTION);
            }
    }
    free(pos), free(dir), free(which);
    return rc;
}

/* Renders the rays of batch b (nb of them, lights off, every light's field at scale 1) and the
 * surface points' normals. */
static int batch_render(const struct esr_model *m, const float *normal_sdf, struct solve_batch *b,
                        size_t nb)
{
    const struct esr_render_out o = {.linear = b->lin3, .depth = b->depth, .opacity = b->opac,
                                     .emitted_lights = b->emit3, .material = b->mat5,
                                     .light_id = b->ids, .front_opacity = b->fopac,
                                     .front_depth = b->fdepth, .front_material = b->fmat5};
    ESR_TRY(esr_model_render_rays(m, b->o3, b->d3, nb, 0, &o));
    for (size_t p = 0; p < nb; p++)
        for (int c = 0; c < 3; c++)
            b->x3[p * 3 + c] = b->o3[p * 3 + c] + b->d3[p * 3 + c] * b->depth[p];
    esr_grid_sample_dpoint(esr_model_grid(m, ESR_COMP_SDF), normal_sdf, 0, b->x3, nb, b->nrm3);
    return ESR_OK;
}

/* Multiplies the light columns of the rows that see no light (ids [n]) by their lights-off
 * correction (rr [n*3]) over its median per channel (written to median): the base colour's error
 * from place to place, not the one scale the photos cannot fix. */
static void correct_rows(int K, size_t n, const uint8_t *kind, const float *rr, const int32_t *ids,
                         float *a, float *a2, float median[3])
{
    double *v = malloc((n ? n : 1) * sizeof(double));
    for (int c = 0; c < 3; c++) {
        size_t m = 0;
        for (size_t i = 0; v && i < n; i++)
            if (kind[i * 3 + (size_t)c] && ids[i] < 0)
                v[m++] = rr[i * 3 + (size_t)c];
        median[c] = m && v ? (float)esr_median_doubles(v, m) : 1.0f;
        for (size_t i = 0; i < n; i++) {
            if (ids[i] >= 0 || !kind[i * 3 + (size_t)c])
                continue;
            const float f = rr[i * 3 + (size_t)c] / median[c];
            for (int k = 0; k < K; k++) {
                a[(i * 3 + (size_t)c) * (size_t)K + (size_t)k] *= f;
                a2[(i * 3 + (size_t)c) * (size_t)K + (size_t)k] *= f;
            }
        }
    }
    free(v);
}

/* Writes the fit into m's lights: scales (a non-finite one, which only a NaN in the rows could
 * make, keeps the first estimate's from `first`), radiance, the rows that fixed each, the
 * relative error and which lights only the sum of is known. */
static void store(struct esr_model *m, double s[3][ESR_MAX_LIGHTS], const double *cov,
                  const struct esr_lights_solve_info *info, const struct esr_light *first)
{
    struct esr_lights *L = &m->lights;
    const int K = L->n;
    for (int k = 0; k < K; k++) {
        struct esr_light *l = &L->light[k];
        double err = 0.0;
        int used = 0;
        l->inseparable = 0;
        for (int c = 0; c < 3; c++) {
            const double *cv = cov + (size_t)c * ESR_MAX_LIGHTS * ESR_MAX_LIGHTS;
            if (!isfinite(s[c][k]) || s[c][k] < 0.0) /* never written: the first estimate stays */
                s[c][k] = first[k].scale[c];
            l->scale[c] = (float)s[c][k];
            if (s[c][k] > 0.0) {
                err += sqrt(fmax(cv[k * K + k], 0.0)) / s[c][k];
                used++;
            }
            for (int j = 0; j < K; j++) {
                const double d = cv[k * K + k] * cv[j * K + j];
                if (j != k && d > 0.0 && cv[k * K + j] / sqrt(d) < -ESR_SOLVE_INSEPARABLE)
                    l->inseparable |= 1u << j;
            }
        }
        l->strength_err = used ? (float)(err / used) : 0.0f;
        l->bound_only = info->light_rows[k] < ESR_SOLVE_MIN_ROWS;
        for (int c = 0; c < 3; c++)
            if (!(l->scale[c] * l->field_rgb[c] <= ESR_SOLVE_MAX_RADIANCE)) {
                l->scale[c] = l->field_rgb[c] > 0.0f ? ESR_SOLVE_MAX_RADIANCE / l->field_rgb[c] : 1.0f;
                l->bound_only = 1;
            }
        l->calib_points = (float)info->light_rows[k];
        l->solved = 1;
        esr_light_update_radiance(l);
    }
}

int esr_lights_solve(struct esr_model *m, const struct esr_ray_set *rs, uint64_t seed,
                     struct esr_lights_solve_info *info)
{
    memset(info, 0, sizeof *info);
    struct esr_lights *L = &m->lights;
    const int K = L->n;
    const size_t n_on = rs->n - rs->n_off;
    if (K == 0 || n_on == 0)
        return ESR_OK;
    const double t0 = omp_get_wtime();
    info->correction[0] = info->correction[1] = info->correction[2] = 1.0f;
    const size_t want = (size_t)m->cfg.lights_solve_rays, n = n_on < want ? n_on : want;
    struct esr_light keep[ESR_MAX_LIGHTS];
    memcpy(keep, L->light, sizeof keep);
    double s[3][ESR_MAX_LIGHTS];
    for (int k = 0; k < K; k++) /* the samples carry the field at scale 1; the fit starts here */
        for (int c = 0; c < 3; c++)
            s[c][k] = L->light[k].scale[c], L->light[k].scale[c] = 1.0f;
    struct esr_light_samples ls[ESR_MAX_LIGHTS];
    memset(ls, 0, sizeof ls);
    struct esr_light_shadows sh;
    memset(&sh, 0, sizeof sh);
    struct solve_batch b;
    memset(&b, 0, sizeof b);
    float *normal_sdf = NULL, *a = malloc(n * 3 * (size_t)K * sizeof(float));
    float *a2 = malloc(n * 3 * (size_t)K * sizeof(float));
    float *y = malloc(n * 3 * sizeof(float)), *rgb = malloc(SOLVE_CHUNK * 3 * sizeof(float));
    uint8_t *kind = malloc(n * 3);
    double *cov = malloc(3 * ESR_MAX_LIGHTS * ESR_MAX_LIGHTS * sizeof(double));
    int rc = a && a2 && y && rgb && kind && cov ? ESR_OK : ESR_FAIL("lights: out of memory for the strength solve");
    for (int k = 0; rc == ESR_OK && k < K; k++)
        rc = esr_light_samples_get(m, k, &ls[k]);
    if (rc == ESR_OK)
        rc = esr_light_shadows_init(&sh, m);
    if (rc == ESR_OK)
        rc = esr_model_normal_sdf(m, &normal_sdf);
    if (rc == ESR_OK)
        rc = batch_alloc(&b);
    /* the lights-off correction's light transport (lights_solve_dirs 0: none) */
    const int dirs = m->cfg.lights_solve_dirs;
    float *rr = dirs > 0 ? malloc(n * 3 * sizeof(float)) : NULL;
    int32_t *b_ids_all = dirs > 0 ? malloc(n * sizeof(int32_t)) : NULL; /* which rows to correct */
    struct esr_lts lts;
    memset(&lts, 0, sizeof lts);
    const long keep_step = m->step;
    m->step = 1; /* off the normal SDF's refresh period: computed once; restored below */
    if (rc == ESR_OK && dirs > 0 && (!rr || !b_ids_all))
        rc = ESR_FAIL("lights: out of memory for the strength solve");
    if (rc == ESR_OK && dirs > 0)
        rc = esr_lts_init_sized(&lts, m, SOLVE_LTS_CHUNK, dirs, ESR_LTS_FIRST_HIT);
    const float *nsdf = normal_sdf ? normal_sdf : esr_model_values(m, ESR_COMP_SDF);
    struct esr_rng pick = esr_rng_init(seed, 0x501e);
    const struct solve_ctx ctx = {m, ls, &sh, m->cfg.lights_solve_spp, seed};
    const struct esr_solve_rows rows = {K, n, a, a2, y, kind};
    const float *o_on = rs->orig3 + rs->n_off * 3, *d_on = rs->dir3 + rs->n_off * 3;
    const float *c_on = rs->rgb3 + rs->n_off * 3;
    for (size_t r0 = 0; rc == ESR_OK && r0 < n; r0 += SOLVE_CHUNK) {
        const size_t nb = n - r0 < SOLVE_CHUNK ? n - r0 : SOLVE_CHUNK;
        for (size_t p = 0; p < nb; p++) {
            const size_t r = pick_ray(n_on, n, r0 + p, &pick);
            memcpy(b.o3 + p * 3, o_on + r * 3, 3 * sizeof(float));
            memcpy(b.d3 + p * 3, d_on + r * 3, 3 * sizeof(float));
            memcpy(rgb + p * 3, c_on + r * 3, 3 * sizeof(float));
        }
        rc = batch_render(m, nsdf, &b, nb);
        if (rc == ESR_OK && rr) {
            rc = batch_correction(m, &lts, &b, nb, sh.voxel, seed + r0, rr + r0 * 3);
            memcpy(b_ids_all + r0, b.ids, nb * sizeof(int32_t));
        }
        if (rc == ESR_OK)
            batch_rows(&ctx, &b, rgb, nb, r0, &rows);
    }
    if (rc == ESR_OK && rr) /* each row's correction over its median: the shape of the error */
        correct_rows(K, n, kind, rr, b_ids_all, a, a2, info->correction);
    info->rays = (long)n;
    for (size_t i = 0; rc == ESR_OK && i < n * 3; i++) {
        info->rows += kind[i] == 1;
        info->bound_rows += kind[i] == 2;
        for (int k = 0; kind[i] == 1 && k < K; k++)
            info->light_rows[k] += a[i * (size_t)K + (size_t)k] >= SOLVE_REACH;
    }
    if (rc == ESR_OK && esr_lights_solve_fit(&rows, s, cov, info->sigma) != 0)
        rc = ESR_FAIL("lights: out of memory for the strength solve");
    if (rc == ESR_OK)
        store(m, s, cov, info, keep);
    else
        memcpy(L->light, keep, sizeof keep);
    m->step = keep_step;
    esr_lts_free(&lts);
    free(rr), free(b_ids_all);
    for (int k = 0; k < K; k++)
        esr_light_samples_free(&ls[k]);
    esr_light_shadows_free(&sh);
    batch_free(&b);
    free(normal_sdf), free(a), free(a2), free(y), free(rgb), free(kind), free(cov);
    info->seconds = omp_get_wtime() - t0;
    return rc;
}
