/* Relighting by direct illumination (see relight.h). */
#include "edit/relight.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/brdf.h"
#include "core/colour.h"
#include "core/error.h"
#include "core/rng.h"
#include "core/vec3.h"
#include "fields/grid.h"
#include "model/material_fields.h"
#include "model/render_sdf.h"
#include "volume/first_hit.h"

/* a camera ray whose opacity is below this has no surface (the ratio method's mean) */
#define SURFACE_OPACITY 0.5f
/* a pixel sees two surfaces (layers) as esr_render_two_surfaces says (model/model.h); a layer
 * of opacity below LIT_OPACITY gets no direct light */
#define LIT_OPACITY 0.02f
/* the direct light's denoiser: window radius (pixels), depth scale (voxels), normal power, and
 * the smallest base colour the light is divided by */
#define DENOISE_R 2
#define DENOISE_DEPTH_VOX 2.0f
#define DENOISE_NPOW 8
#define DENOISE_MIN_ALBEDO 0.05f
/* ratio method: the share of the view's mean direct light added to each pixel's (edit/relight.h) */
#define RATIO_FLOOR 0.1

int esr_relight_init(struct esr_relight *r, const struct esr_model *m, int spp,
                     enum esr_relight_mode mode)
{
    memset(r, 0, sizeof(*r));
    r->mode = mode;
    if (m->lights.n == 0)
        return ESR_FAIL("relight: the model has no lights: its pdra stage found no emitters (the "
                        "run's log says why), so there is nothing to relight");
    if (spp < 1)
        return ESR_FAIL("relight: %d light samples per pixel (need at least 1)", spp);
    r->spp = spp;
    ESR_TRY(esr_light_shadows_init(&r->shadows, m));
    int rc0 = esr_model_normal_sdf(m, &r->normal_sdf);
    if (rc0 != ESR_OK) {
        esr_relight_free(r);
        return rc0;
    }
    for (int k = 0; k < m->lights.n; k++) {
        int rc = esr_light_samples_get(m, k, &r->samples[k]);
        if (rc != ESR_OK) {
            esr_relight_free(r);
            return rc;
        }
        r->n_lights = k + 1;
    }
    return ESR_OK;
}

void esr_relight_free(struct esr_relight *r)
{
    for (int k = 0; k < r->n_lights; k++)
        esr_light_samples_free(&r->samples[k]);
    esr_light_shadows_free(&r->shadows);
    free(r->normal_sdf);
    memset(r, 0, sizeof(*r));
}

/* Per-pixel buffers of one view. A pixel is lit as up to two layers, layer i = 2 p + l: where
 * its ray sees two surfaces (an object's silhouette), each is lit at its own point with its own
 * normal and BRDF (a single point at the expected depth lies in the air between them, and its
 * light came out dark); else layer 0 is the whole ray and layer 1 is empty. */
struct view_buf {
    float *o3, *d3, *lin3, *on3, *opac, *depth, *mat5, *emit3; /* on3: not in direct */
    float *front_opac, *front_depth, *front_mat5;               /* the ray's first surface */
    float *l_opac, *l_depth, *l_mat5, *l_nrm3;                  /* per layer [2n] */
    int32_t *ids;
    float *each3, *value_each3; /* esr_relight_layers only: each light's emission [K * n*3] */
};

static void view_buf_free(struct view_buf *b)
{
    free(b->o3), free(b->d3), free(b->lin3), free(b->on3), free(b->opac), free(b->depth);
    free(b->mat5), free(b->emit3), free(b->ids);
    free(b->front_opac), free(b->front_depth), free(b->front_mat5);
    free(b->l_opac), free(b->l_depth), free(b->l_mat5), free(b->l_nrm3);
    free(b->each3), free(b->value_each3);
}

/* The layers of every pixel from the totals and the first surface (see struct view_buf). */
static void split_layers(struct view_buf *b, size_t n, float voxel)
{
    for (size_t p = 0; p < n; p++) {
        const size_t i0 = 2 * p, i1 = i0 + 1;
        const float a = b->opac[p], a1 = b->front_opac[p], a2 = a - a1, d1 = b->front_depth[p];
        float d2;
        const int two = esr_render_two_surfaces(a, b->depth[p], a1, d1, voxel, &d2);
        b->l_opac[i0] = two ? a1 : a;
        b->l_depth[i0] = two ? d1 : b->depth[p];
        b->l_opac[i1] = two ? a2 : 0.0f;
        b->l_depth[i1] = two ? d2 : b->depth[p];
        for (int c = 0; c < ESR_BRDF_CHANNELS; c++) {
            const float m = b->mat5[p * ESR_BRDF_CHANNELS + c], m1 = b->front_mat5[p * ESR_BRDF_CHANNELS + c];
            b->l_mat5[i0 * ESR_BRDF_CHANNELS + c] = two ? m1 : m;
            b->l_mat5[i1 * ESR_BRDF_CHANNELS + c] = two ? m - m1 : 0.0f;
        }
    }
}

/* Whether layer i gets the direct light: a surface, and in the model mode on a pixel that sees a
 * light. */
static int lit_layer(const struct esr_relight *r, const struct view_buf *b, size_t i)
{
    return b->l_opac[i] > LIT_OPACITY && (r->mode != ESR_RELIGHT_MODEL || b->ids[i / 2] >= 0);
}

/* What the direct light pass adds up: term t of light k adds w * (the light's direct light at
 * its found emission, or with value set: at unit colour times each sample's value V) into output
 * out. An edit is one output (and the ratio method's found light a second: edit/relight.h), the
 * layers two per light; a light without terms takes no samples. */
struct direct_term {
    int out, value;
    float w[3];
};
#define MAX_OUTPUTS (2 * ESR_MAX_LIGHTS)
struct direct_plan {
    int n_terms[ESR_MAX_LIGHTS];
    struct direct_term term[ESR_MAX_LIGHTS][2];
    int n_out;
    float *out[MAX_OUTPUTS]; /* [2n * 3] per layer, zeroed by the caller */
};

static void plan_add(struct direct_plan *pl, int k, int out, int value, const float w[3])
{
    struct direct_term *t = &pl->term[k][pl->n_terms[k]++];
    t->out = out;
    t->value = value;
    memcpy(t->w, w, sizeof t->w);
}

/* The stream of light k's samples at layer i: its own, so that a light's light does not depend on
 * which other lights an edit turns off (nor on the other layer's), and a mix of the layers
 * (esr_relight_layers) equals the edit. */
static struct esr_rng light_stream(uint64_t seed, size_t i, int k)
{
    return esr_rng_init(seed, (uint64_t)i * ESR_MAX_LIGHTS + (uint64_t)k);
}

/* The direct light at every lit layer (lit_layer) into the plan's outputs: spp area samples per
 * light, each with its shadow ray traced on the spot; returns how many shadow rays were traced.
 * A light's samples at a layer draw from their own stream (light_stream) and add in a fixed
 * order, so the result does not depend on the schedule; nothing is allocated (a view's shadow
 * rays (~200k for lamp's 160x160 at 8 per light) kept in arrays cost more in page faults than in
 * marching). */
ESR_HOT static size_t layers_direct_light(const struct esr_relight *r, const struct view_buf *b,
                                          size_t n_px, uint64_t seed, const struct direct_plan *pl)
{
    size_t traced = 0;
#pragma omp parallel for schedule(dynamic, 16) reduction(+ : traced)
    for (size_t p = 0; p < n_px; p++) {
        for (size_t i = 2 * p; i < 2 * p + 2; i++) {
            const float a = b->l_opac[i];
            struct esr_vec3 n = esr_v3_at(b->l_nrm3, i);
            if (!lit_layer(r, b, i) || esr_v3_length(n) < 1e-6f)
                continue;
            n = esr_v3_normalize(n);
            const struct esr_vec3 d = esr_v3_at(b->d3, p);
            const struct esr_vec3 x = esr_v3_add(esr_v3_at(b->o3, p), esr_v3_scale(d, b->l_depth[i]));
            const struct esr_vec3 wo = esr_v3_scale(d, -1.0f);
            const struct esr_material mat = esr_material_of_row(b->l_mat5 + i * ESR_BRDF_CHANNELS, a);
            for (int k = 0; k < r->n_lights; k++) {
                if (!pl->n_terms[k] || r->samples[k].n == 0 || !(r->samples[k].max_emit > 0.0f))
                    continue;
                int value = 0;
                for (int t = 0; t < pl->n_terms[k]; t++)
                    value |= pl->term[k][t].value;
                struct esr_rng rng = light_stream(seed, i, k);
                float found[1][3] = {{0, 0, 0}}, val[1][3] = {{0, 0, 0}};
                const struct esr_direct_point_query q = {
                    &r->shadows, &r->samples[k], NULL, r->spp, &mat, x, n, &wo, 1, a};
                traced += esr_light_direct_point(&q, &rng, found, NULL, value ? val : NULL);
                for (int t = 0; t < pl->n_terms[k]; t++) {
                    const struct direct_term *tm = &pl->term[k][t];
                    const float *src = tm->value ? val[0] : found[0];
                    for (int c = 0; c < 3; c++)
                        pl->out[tm->out][i * 3 + c] += tm->w[c] * src[c];
                }
            }
        }
    }
    return traced;
}

/* A joint bilateral filter on the direct light (a few light samples per pixel leave speckle):
 * each lit layer averages the lit layers of a (2 DENOISE_R + 1)^2 window of pixels (both layers
 * of each, so the far side of a silhouette takes its light from the surface it continues),
 * weighted by depth (DENOISE_DEPTH_VOX voxels) and normal agreement (cos^DENOISE_NPOW), on the
 * light per unit opacity divided by the base colour so the texture is not blurred, then
 * multiplied back. Reads n_in per-layer lights in[j] (layers_direct_light; divided by the base
 * colour in place: they are not read afterwards) and writes each pixel's sum of its layers into
 * out[j] [n * 3]. The weights depend on the view alone, so the filter is linear in its input:
 * the lights filtered one by one add up to their sum filtered. */
static int denoise_direct(const struct esr_relight *r, const struct view_buf *b, int w, int h,
                          int n_in, float *const *in, float *const *out)
{
    const float vox = r->shadows.voxel;
    const size_t n = (size_t)w * (size_t)h;
    float *nrm = malloc(2 * n * 3 * sizeof(float)), *albedo = malloc(2 * n * 3 * sizeof(float));
    if (!nrm || !albedo) {
        free(nrm), free(albedo);
        return ESR_FAIL("relight: out of memory for the denoiser");
    }
    float *const *demod = in;
    for (size_t i = 0; i < 2 * n; i++) {
        const float a = b->l_opac[i] > 1e-4f ? b->l_opac[i] : 1e-4f;
        float len = 0.0f;
        for (int c = 0; c < 3; c++) {
            albedo[i * 3 + c] = fmaxf(b->l_mat5[i * ESR_BRDF_CHANNELS + c] / a, DENOISE_MIN_ALBEDO);
            for (int j = 0; j < n_in; j++)
                demod[j][i * 3 + c] /= a * albedo[i * 3 + c];
            len += b->l_nrm3[i * 3 + c] * b->l_nrm3[i * 3 + c];
        }
        len = len > 1e-12f ? 1.0f / sqrtf(len) : 0.0f;
        for (int c = 0; c < 3; c++)
            nrm[i * 3 + c] = b->l_nrm3[i * 3 + c] * len;
    }
    const float inv2s2 = 1.0f / (2.0f * (DENOISE_DEPTH_VOX * vox) * (DENOISE_DEPTH_VOX * vox));
#pragma omp parallel for schedule(static)
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            const size_t p = (size_t)y * (size_t)w + (size_t)x;
            for (int j = 0; j < n_in; j++)
                for (int c = 0; c < 3; c++)
                    out[j][p * 3 + c] = 0.0f;
            for (size_t i = 2 * p; i < 2 * p + 2; i++) {
                if (!lit_layer(r, b, i))
                    continue;
                double sum[MAX_OUTPUTS][3] = {{0}}, wsum = 0.0;
                for (int dy = -DENOISE_R; dy <= DENOISE_R; dy++)
                    for (int dx = -DENOISE_R; dx <= DENOISE_R; dx++) {
                        const int u = x + dx, v = y + dy;
                        if (u < 0 || v < 0 || u >= w || v >= h)
                            continue;
                        const size_t q = (size_t)v * (size_t)w + (size_t)u;
                        for (size_t k = 2 * q; k < 2 * q + 2; k++) {
                            if (!lit_layer(r, b, k))
                                continue;
                            const float dd = b->l_depth[k] - b->l_depth[i];
                            const float cn = nrm[i * 3] * nrm[k * 3] + nrm[i * 3 + 1] * nrm[k * 3 + 1] +
                                             nrm[i * 3 + 2] * nrm[k * 3 + 2];
                            if (cn <= 0.0f)
                                continue;
                            float wn = cn;
                            for (int e = 1; e < DENOISE_NPOW; e++)
                                wn *= cn;
                            const double wq = (double)wn * exp(-(double)(dd * dd * inv2s2));
                            for (int j = 0; j < n_in; j++)
                                for (int c = 0; c < 3; c++)
                                    sum[j][c] += wq * demod[j][k * 3 + c];
                            wsum += wq;
                        }
                    }
                if (wsum <= 0.0)
                    continue; /* its normal is unset (its own weight would be 1) */
                for (int j = 0; j < n_in; j++)
                    for (int c = 0; c < 3; c++)
                        out[j][p * 3 + c] +=
                            (float)(sum[j][c] / wsum) * b->l_opac[i] * albedo[i * 3 + c];
            }
        }
    free(nrm), free(albedo);
    return ESR_OK;
}

/* RATIO_FLOOR times the mean of x [n*3] over the view's surface pixels that see no light. */
static void floor_mean(const struct view_buf *b, const float *x, size_t n, double mean[3])
{
    size_t surface = 0;
    mean[0] = mean[1] = mean[2] = 0.0;
    for (size_t p = 0; p < n; p++)
        if (b->opac[p] > SURFACE_OPACITY && b->ids[p] < 0) {
            surface++;
            for (int c = 0; c < 3; c++)
                mean[c] += x[p * 3 + c];
        }
    for (int c = 0; c < 3; c++)
        mean[c] = RATIO_FLOOR * mean[c] / (double)(surface ? surface : 1);
}

/* The ratio method (edit/relight.h) adds to out at the pixels that see no light the trained
 * lights-on radiance's reflected light L_on - L_off - emitted (the emission a pixel on a light's
 * edge composites is not reflected light), per channel times
 *     (num + f mean num) / (found + f mean found)
 * num: the direct light of the edit (or of one light's layer), found: the direct light with the
 * emission as found (same samples and shadow rays); the means over the view's surface pixels
 * that see no light, f = RATIO_FLOOR, so that where no light reaches directly (shadow, light
 * after bounces only) the view's overall change applies. At a pixel that sees a light it adds
 * num, as direct. Linear in num: the layers' ratios add up to the edit's. */
static void transfer_ratio(const struct view_buf *b, const float *num, const float *found,
                           size_t n, float *out)
{
    const float *on = b->on3;
    double mean_n[3], mean_f[3];
    floor_mean(b, num, n, mean_n);
    floor_mean(b, found, n, mean_f);
    for (int c = 0; c < 3; c++)
        mean_f[c] += 1e-12;
    for (size_t p = 0; p < n; p++) {
        if (b->ids[p] >= 0) { /* a light: its edited emission and the direct light, as direct */
            for (int c = 0; c < 3; c++)
                out[p * 3 + c] += num[p * 3 + c];
            continue;
        }
        for (int c = 0; c < 3; c++) {
            const double ratio = (num[p * 3 + c] + mean_n[c]) / (found[p * 3 + c] + mean_f[c]);
            out[p * 3 + c] +=
                (float)(ratio * (on[p * 3 + c] - b->lin3[p * 3 + c] - b->emit3[p * 3 + c]));
        }
    }
}

/* The view of cam rendered into b (allocated; view_buf_free frees it even on failure): rays,
 * lights-off radiance (and lights-on but in direct), the lights' composited emission under edits
 * (NULL: as found), each light's too when each (esr_relight_layers), materials, the two layers
 * of every pixel and their normals from the smoothed SDF. */
static int view_prepare(const struct esr_relight *r, const struct esr_model *m,
                        const struct esr_light_edit *edits, const struct esr_camera *cam, int each,
                        struct view_buf *b)
{
    memset(b, 0, sizeof *b);
    const size_t n = (size_t)cam->width * (size_t)cam->height, K = (size_t)m->lights.n;
    const int with_on = r->mode != ESR_RELIGHT_DIRECT;
    b->o3 = malloc(n * 3 * sizeof(float));
    b->d3 = malloc(n * 3 * sizeof(float));
    b->lin3 = malloc(n * 3 * sizeof(float));
    b->on3 = with_on ? malloc(n * 3 * sizeof(float)) : NULL;
    b->opac = malloc(n * sizeof(float));
    b->depth = malloc(n * sizeof(float));
    b->mat5 = malloc(n * ESR_BRDF_CHANNELS * sizeof(float));
    b->emit3 = malloc(n * 3 * sizeof(float));
    b->ids = malloc(n * sizeof(int32_t));
    b->front_opac = malloc(n * sizeof(float));
    b->front_depth = malloc(n * sizeof(float));
    b->front_mat5 = malloc(n * ESR_BRDF_CHANNELS * sizeof(float));
    b->l_opac = malloc(2 * n * sizeof(float));
    b->l_depth = malloc(2 * n * sizeof(float));
    b->l_mat5 = malloc(2 * n * ESR_BRDF_CHANNELS * sizeof(float));
    b->l_nrm3 = malloc(2 * n * 3 * sizeof(float));
    b->each3 = each ? malloc(K * n * 3 * sizeof(float)) : NULL;
    b->value_each3 = each ? malloc(K * n * 3 * sizeof(float)) : NULL;
    if (!(b->o3 && b->d3 && b->lin3 && (b->on3 || !with_on) && b->opac && b->depth && b->mat5 &&
          b->emit3 && b->ids && b->front_opac && b->front_depth && b->front_mat5 && b->l_opac &&
          b->l_depth && b->l_mat5 && b->l_nrm3 && (!each || (b->each3 && b->value_each3))))
        return ESR_FAIL("relight: out of memory for a %dx%d view", cam->width, cam->height);
    /* m with the edit in place: each sample on a light composites its light's edited emission,
     * so a pixel on a light's edge shows the edited light in proportion (model/lights.h) */
    struct esr_model *edited = malloc(sizeof *edited);
    if (!edited)
        return ESR_FAIL("relight: out of memory");
    *edited = *m;
    edited->lights.edited = edits != NULL;
    if (edits)
        memcpy(edited->lights.edit, edits, K * sizeof *edits);
    esr_camera_pixel_rays(cam, b->o3, b->d3);
    struct esr_render_out o = {.linear = b->lin3, .depth = b->depth, .opacity = b->opac,
                               .emitted_lights = b->emit3, .material = b->mat5, .light_id = b->ids,
                               .linear_other = b->on3, .front_opacity = b->front_opac,
                               .front_depth = b->front_depth, .front_material = b->front_mat5,
                               .emitted_each_light = b->each3,
                               .emitted_value_each_light = b->value_each3,
                               .lights_emitted_only = r->mode == ESR_RELIGHT_MODEL};
    int rc = esr_model_render_rays(edited, b->o3, b->d3, n, 0, &o);
    free(edited);
    ESR_TRY(rc);
    /* the layers' surface points, and their normals from the smoothed SDF */
    split_layers(b, n, r->shadows.voxel);
    float *x3 = b->l_nrm3; /* the points first, overwritten by their normals */
    for (size_t i = 0; i < 2 * n; i++)
        for (int a = 0; a < 3; a++)
            x3[i * 3 + a] = b->o3[i / 2 * 3 + a] + b->d3[i / 2 * 3 + a] * b->l_depth[i];
    const struct esr_grid *g = esr_model_grid(m, ESR_COMP_SDF);
    float *tmp = malloc(2 * n * 3 * sizeof(float));
    if (!tmp)
        return ESR_FAIL("relight: out of memory for %zu normals", 2 * n);
    esr_grid_sample_dpoint(g, r->normal_sdf ? r->normal_sdf : esr_model_values(m, ESR_COMP_SDF), 0,
                           x3, 2 * n, tmp);
    memcpy(b->l_nrm3, tmp, 2 * n * 3 * sizeof(float));
    free(tmp);
    return ESR_OK;
}

/* The plan's direct light, traced per layer and denoised per pixel into den[j] [n*3] for each
 * of its outputs (each pl->out[j] [2n*3] zeroed here). */
static int direct_light(const struct esr_relight *r, const struct view_buf *b,
                        const struct esr_camera *cam, uint64_t seed, struct direct_plan *pl,
                        float *const *den, struct esr_relight_stats *stats)
{
    const size_t n = (size_t)cam->width * (size_t)cam->height;
    for (int j = 0; j < pl->n_out; j++)
        memset(pl->out[j], 0, 2 * n * 3 * sizeof(float));
    const double t0 = omp_get_wtime();
    const size_t traced = layers_direct_light(r, b, n, seed, pl);
    if (stats) {
        stats->shadow_rays = traced;
        stats->direct_seconds = omp_get_wtime() - t0;
    }
    return denoise_direct(r, b, cam->width, cam->height, pl->n_out, pl->out, den);
}

/* n_out buffers of 2n*3 (the plan's per layer) and n*3 (denoised) floats each. */
static int plan_buffers(struct direct_plan *pl, int n_out, size_t n, float **den)
{
    pl->n_out = n_out;
    for (int j = 0; j < n_out; j++) {
        pl->out[j] = malloc(2 * n * 3 * sizeof(float));
        den[j] = malloc(n * 3 * sizeof(float));
        if (!pl->out[j] || !den[j])
            return ESR_FAIL("relight: out of memory for the direct light");
    }
    return ESR_OK;
}

static void plan_buffers_free(struct direct_plan *pl, float **den)
{
    for (int j = 0; j < pl->n_out; j++)
        free(pl->out[j]), free(den[j]);
}

int esr_relight_view(const struct esr_relight *r, const struct esr_model *m,
                     const struct esr_light_edit *edits, const struct esr_camera *cam,
                     uint64_t seed, struct esr_image *out, struct esr_relight_stats *stats)
{
    memset(out, 0, sizeof(*out));
    if (stats)
        memset(stats, 0, sizeof(*stats));
    ESR_TRY(esr_light_edits_check(edits, m->lights.n));
    const size_t n = (size_t)cam->width * (size_t)cam->height;
    const int ratio = r->mode == ESR_RELIGHT_RATIO;
    struct view_buf b;
    int rc = view_prepare(r, m, edits, cam, 0, &b);
    /* the edited direct light (output 0: each light's at its edit's weights) and the ratio
     * method's found one (output 1) */
    struct direct_plan pl;
    memset(&pl, 0, sizeof pl);
    float *den[2] = {NULL, NULL};
    for (int k = 0; k < r->n_lights; k++) {
        float w[3];
        esr_light_edit_weights(&edits[k], w);
        if (edits[k].intensity > 0.0f)
            plan_add(&pl, k, 0, edits[k].recolour, w);
        if (ratio)
            plan_add(&pl, k, 1, 0, (const float[3]){1.0f, 1.0f, 1.0f});
    }
    if (rc == ESR_OK)
        rc = plan_buffers(&pl, ratio ? 2 : 1, n, den);
    if (rc == ESR_OK)
        rc = direct_light(r, &b, cam, seed, &pl, den, stats);
    if (rc == ESR_OK)
        rc = esr_image_alloc(out, cam->width, cam->height, 3);
    if (rc == ESR_OK) {
        /* the lights-off view, the edited lights where the camera sees them, the direct light */
        for (size_t i = 0; i < n * 3; i++)
            out->data[i] = b.lin3[i] + b.emit3[i];
        const float *direct = den[0];
        if (ratio)
            transfer_ratio(&b, direct, den[1], n, out->data);
        else if (r->mode == ESR_RELIGHT_MODEL)
            for (size_t p = 0; p < n; p++)
                for (int c = 0; c < 3; c++)
                    out->data[p * 3 + c] = b.ids[p] >= 0 ? out->data[p * 3 + c] + direct[p * 3 + c]
                                                         : b.on3[p * 3 + c];
        else
            for (size_t i = 0; i < n * 3; i++)
                out->data[i] += direct[i];
    }
    plan_buffers_free(&pl, den);
    view_buf_free(&b);
    if (rc != ESR_OK)
        esr_image_free(out);
    return rc;
}

void esr_relight_layers_free(struct esr_relight_layers *L)
{
    esr_image_free(&L->off);
    for (int k = 0; k < ESR_MAX_LIGHTS; k++)
        esr_image_free(&L->light[k]), esr_image_free(&L->value[k]);
    memset(L, 0, sizeof *L);
}

int esr_relight_layers(const struct esr_relight *r, const struct esr_model *m,
                       const struct esr_camera *cam, uint64_t seed, struct esr_relight_layers *L,
                       struct esr_relight_stats *stats)
{
    memset(L, 0, sizeof *L);
    if (stats)
        memset(stats, 0, sizeof(*stats));
    if (r->mode == ESR_RELIGHT_MODEL)
        return ESR_FAIL("relight: a fine-tuned model has no layers (its light is not linear in "
                        "the lights' emission)");
    const size_t n = (size_t)cam->width * (size_t)cam->height;
    const int K = r->n_lights;
    L->n_lights = K;
    struct view_buf b;
    int rc = view_prepare(r, m, NULL, cam, 1, &b);
    /* outputs 2k and 2k + 1: light k at its found emission and at unit colour times V */
    struct direct_plan pl;
    memset(&pl, 0, sizeof pl);
    float *den[MAX_OUTPUTS] = {NULL};
    const float one[3] = {1.0f, 1.0f, 1.0f};
    for (int k = 0; k < K; k++) {
        plan_add(&pl, k, 2 * k, 0, one);
        plan_add(&pl, k, 2 * k + 1, 1, one);
    }
    if (rc == ESR_OK)
        rc = plan_buffers(&pl, 2 * K, n, den);
    if (rc == ESR_OK)
        rc = direct_light(r, &b, cam, seed, &pl, den, stats);
    rc = rc == ESR_OK ? esr_image_alloc(&L->off, cam->width, cam->height, 3) : rc;
    for (int k = 0; k < K && rc == ESR_OK; k++)
        if ((rc = esr_image_alloc(&L->light[k], cam->width, cam->height, 3)) == ESR_OK)
            rc = esr_image_alloc(&L->value[k], cam->width, cam->height, 3);
    float *found = rc == ESR_OK && r->mode == ESR_RELIGHT_RATIO ? calloc(n * 3, sizeof(float)) : NULL;
    if (rc == ESR_OK && r->mode == ESR_RELIGHT_RATIO && !found)
        rc = ESR_FAIL("relight: out of memory for the found direct light");
    if (rc == ESR_OK) {
        memcpy(L->off.data, b.lin3, n * 3 * sizeof(float));
        for (int k = 0; found && k < K; k++) /* the ratio's denominator: every light as found */
            for (size_t i = 0; i < n * 3; i++)
                found[i] += den[2 * k][i];
        for (int k = 0; k < K; k++)
            for (int value = 0; value < 2; value++) {
                float *dst = value ? L->value[k].data : L->light[k].data;
                const float *direct = den[2 * k + value];
                memcpy(dst, (value ? b.value_each3 : b.each3) + (size_t)k * n * 3,
                       n * 3 * sizeof(float));
                if (found)
                    transfer_ratio(&b, direct, found, n, dst);
                else
                    for (size_t i = 0; i < n * 3; i++)
                        dst[i] += direct[i];
            }
    }
    free(found);
    plan_buffers_free(&pl, den);
    view_buf_free(&b);
    if (rc != ESR_OK)
        esr_relight_layers_free(L);
    return rc;
}

int esr_relight_layers_mix(const struct esr_relight_layers *L, const struct esr_light_edit *edits,
                           struct esr_image *out)
{
    memset(out, 0, sizeof *out);
    ESR_TRY(esr_light_edits_check(edits, L->n_lights));
    ESR_TRY(esr_image_alloc(out, L->off.width, L->off.height, 3));
    const size_t n3 = esr_image_count(&L->off);
    memcpy(out->data, L->off.data, n3 * sizeof(float));
    for (int k = 0; k < L->n_lights; k++) {
        float w[3];
        esr_light_edit_weights(&edits[k], w);
        const float *x = edits[k].recolour ? L->value[k].data : L->light[k].data;
        for (size_t i = 0; i < n3; i++)
            out->data[i] += w[i % 3] * x[i];
    }
    return ESR_OK;
}
