/* Direct light of the found lights at surface points (see lights/direct.h). */
#include "train/lights/direct.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/brdf.h"
#include "core/error.h"
#include "core/rng.h"
#include "core/simd.h"
#include "core/vec3.h"
#include "fields/grid.h"
#include "model/material_fields.h"
#include "model/render_sdf.h"
#include "volume/first_hit.h"

int esr_light_shadows_init(struct esr_light_shadows *s, const struct esr_model *m)
{
    memset(s, 0, sizeof(*s));
    const struct esr_grid *g = esr_model_grid(m, ESR_COMP_SDF);
    s->voxel = esr_grid_voxel_size(g, 0);
    ESR_TRY(esr_model_first_hit_sdf(m, &s->sdf));
    const int rc = esr_first_hit_shadow_setup(&s->grid, &s->params, g, s->sdf);
    if (rc != ESR_OK)
        esr_light_shadows_free(s);
    return rc;
}

void esr_light_shadows_free(struct esr_light_shadows *s)
{
    esr_first_hit_grid_free(&s->grid);
    free(s->sdf);
    s->sdf = NULL;
}

/* Shadow rays start this many voxels off the surface along its normal and stop this many short
 * of the light's sample (its own surface). */
#define SHADOW_OFFSET_VOX 1.0f
#define SHADOW_STOP_VOX 1.5f

ESR_HOT size_t esr_light_direct_point(const struct esr_direct_point_query *query,
                                      struct esr_rng *rng, float (*edited)[3], float (*found)[3],
                                      float (*value)[3])
{
    const struct esr_light_shadows *sh = query->sh;
    const struct esr_light_samples *ls = query->ls;
    const struct esr_light_edit *edit = query->edit;
    const int spp = query->spp, n_wo = query->n_wo;
    const struct esr_material *mat = query->mat;
    const struct esr_vec3 x = query->x, n = query->n, *wo = query->wo;
    const float scale = query->scale;
    const float h = sh->voxel;
    const struct esr_vec3 o = esr_v3_add(x, esr_v3_scale(n, SHADOW_OFFSET_VOX * h));
    const float o3[3] = {o.x, o.y, o.z};
    size_t traced = 0;
    for (int j = 0; j < spp && ls->n > 0; j++) {
        size_t q = (size_t)(((double)j + esr_rng_float(rng)) * (double)ls->n / spp);
        if (q >= ls->n)
            q = ls->n - 1;
        /* direction and distance from x itself: the offset start o is only where the shadow
         * ray begins (measured from o, a light a few voxels above x came out too bright: 2.25x
         * at 3 voxels, 1.19x at 12) */
        const struct esr_vec3 v = esr_v3_sub(esr_v3_at(ls->pos3, q), x);
        const float dist = esr_v3_length(v);
        if (dist <= (SHADOW_OFFSET_VOX + SHADOW_STOP_VOX) * h)
            continue;
        const struct esr_vec3 wi = esr_v3_scale(v, 1.0f / dist);
        float R[ESR_DIRECT_MAX_WO][3];
        int any = 0;
        for (int w = 0; w < n_wo; w++) {
            for (int c = 0; c < 3; c++)
                R[w][c] = 0.0f;
            if (esr_v3_dot(n, wo[w]) <= 0.0f)
                continue;
            esr_brdf_eval(mat, n, wo[w], wi, R[w]);
            any |= R[w][0] + R[w][1] + R[w][2] > 0.0f;
        }
        if (!any)
            continue; /* below the surface for every wo */
        const struct esr_vec3 end = esr_v3_add(x, esr_v3_scale(wi, dist - SHADOW_STOP_VOX * h));
        const float end3[3] = {end.x, end.y, end.z};
        traced++;
        if (esr_first_hit_segment_blocked(&sh->grid, &sh->params, o3, end3))
            continue; /* occluded */
        const float g = fabsf(esr_v3_dot(esr_v3_at(ls->nrm3, q), wi)) * ls->area[q] *
                        (float)ls->n / ((float)spp * dist * dist);
        const float *e_found = ls->emit3 + q * 3;
        float e[3];
        if (edit)
            esr_light_edit_apply(edit, e_found, e);
        else
            memcpy(e, e_found, sizeof e);
        const float val = value ? esr_light_value(e_found) : 0.0f;
        for (int w = 0; w < n_wo; w++)
            for (int c = 0; c < 3; c++) {
                edited[w][c] += scale * e[c] * R[w][c] * g;
                if (found)
                    found[w][c] += scale * e_found[c] * R[w][c] * g;
                if (value)
                    value[w][c] += scale * val * R[w][c] * g;
            }
    }
    return traced;
}

ESR_HOT int esr_lights_direct(const struct esr_direct_lights *L, const struct esr_direct_points *pts,
                              uint64_t seed, double *out, double *out_found)
{
    const struct esr_light_shadows *sh = L->sh;
    const struct esr_light_samples *ls = L->ls;
    const struct esr_light_edit *edits = L->edits;
    const int n_lights = L->n, spp = L->spp;
    if (pts->n_wo < 1 || pts->n_wo > ESR_DIRECT_MAX_WO)
        return ESR_FAIL("lights: %d outgoing directions per point (1 to %d)", pts->n_wo,
                        ESR_DIRECT_MAX_WO);
    if (n_lights < 0 || n_lights > ESR_MAX_LIGHTS)
        return ESR_FAIL("lights: %d lights (0 to %d)", n_lights, ESR_MAX_LIGHTS);
    const size_t P = pts->n, W = (size_t)pts->n_wo, K = (size_t)n_lights;
    memset(out, 0, P * W * ESR_MAX_LIGHTS * 3 * sizeof(double));
    if (out_found)
        memset(out_found, 0, P * W * ESR_MAX_LIGHTS * 3 * sizeof(double));
    if (P * K * (size_t)spp == 0)
        return ESR_OK;
    /* each shadow ray is traced where its sample is drawn; a point's sums run over its own
     * samples in a fixed order from its own stream: deterministic, nothing allocated */
#pragma omp parallel for schedule(dynamic, 16)
    for (size_t p = 0; p < P; p++) {
        const struct esr_material mat = esr_material_of_row(pts->brdf5 + p * ESR_BRDF_CHANNELS, 1.0f);
        struct esr_vec3 wo[ESR_DIRECT_MAX_WO];
        for (size_t w = 0; w < W; w++)
            wo[w] = esr_v3_at(pts->wo3, p * W + w);
        struct esr_rng rng = esr_rng_init(seed, p);
        for (size_t k = 0; k < K; k++) {
            float d[ESR_DIRECT_MAX_WO][3] = {{0}}, d_found[ESR_DIRECT_MAX_WO][3] = {{0}};
            const struct esr_direct_point_query q = {
                sh, &ls[k], edits ? &edits[k] : NULL, spp, &mat, esr_v3_at(pts->pos3, p),
                esr_v3_at(pts->nrm3, p), wo, (int)W, 1.0f};
            (void)esr_light_direct_point(&q, &rng, d, out_found ? d_found : NULL, NULL);
            for (size_t w = 0; w < W; w++)
                for (int c = 0; c < 3; c++) {
                    const size_t at = ((p * W + w) * ESR_MAX_LIGHTS + k) * 3 + (size_t)c;
                    out[at] = d[w][c];
                    if (out_found)
                        out_found[at] = d_found[w][c];
                }
        }
    }
    return ESR_OK;
}
