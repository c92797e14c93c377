/* Direct light of the found lights at surface points (see light_direct.h). */
#include "train/light_direct.h"

#include <math.h>
#include <string.h>

#include "core/brdf.h"
#include "core/error.h"
#include "core/rng.h"
#include "core/simd.h"
#include "core/vec3.h"
#include "fields/grid.h"
#include "model/material_fields.h"
#include "volume/first_hit.h"

int esr_light_shadows_init(struct esr_light_shadows *s, const struct esr_model *m)
{
    const struct esr_grid *g = esr_model_grid(m, ESR_COMP_SDF);
    s->voxel = esr_grid_voxel_size(g, 0);
    return esr_first_hit_shadow_setup(&s->grid, &s->params, g, esr_model_values(m, ESR_COMP_SDF));
}

ESR_HOT int esr_lights_direct(const struct esr_light_shadows *sh, const struct esr_light_samples *ls,
                              int n_lights, const struct esr_light_edit *edits,
                              const struct esr_direct_points *pts, int spp, uint64_t seed,
                              double *out, double *out_found)
{
    const size_t P = pts->n, W = (size_t)pts->n_wo, K = (size_t)n_lights;
    memset(out, 0, P * W * ESR_MAX_LIGHTS * 3 * sizeof(double));
    if (out_found)
        memset(out_found, 0, P * W * ESR_MAX_LIGHTS * 3 * sizeof(double));
    if (pts->n_wo < 1 || pts->n_wo > ESR_DIRECT_MAX_WO)
        return ESR_FAIL("lights: %d outgoing directions per point (1 to %d)", pts->n_wo,
                        ESR_DIRECT_MAX_WO);
    const float h = sh->voxel;
    if (P * K * (size_t)spp == 0)
        return ESR_OK;
    /* each shadow ray is traced where its sample is drawn; a point's sums run over its own
     * samples in a fixed order from its own stream: deterministic, nothing allocated */
#pragma omp parallel for schedule(dynamic, 16)
    for (size_t p = 0; p < P; p++) {
        const struct esr_vec3 x = esr_v3_at(pts->pos3, p), n = esr_v3_at(pts->nrm3, p);
        const struct esr_material mat = esr_material_of_row(pts->brdf5 + p * ESR_BRDF_CHANNELS, 1.0f);
        const struct esr_vec3 o = esr_v3_add(x, esr_v3_scale(n, h));
        const float o3[3] = {o.x, o.y, o.z};
        struct esr_rng rng = esr_rng_init(seed, p);
        for (size_t k = 0; k < K; k++)
            for (int j = 0; j < spp; j++) {
                const uint32_t u = esr_rng_u32(&rng);
                if (ls[k].n == 0)
                    continue;
                const size_t q = u % (uint32_t)ls[k].n;
                const struct esr_vec3 v = esr_v3_sub(esr_v3_at(ls[k].pos3, q), o);
                const float dist = esr_v3_length(v);
                if (dist <= 1.5f * h)
                    continue;
                const struct esr_vec3 wi = esr_v3_scale(v, 1.0f / dist);
                const float *found = ls[k].emit3 + q * 3;
                float e[3];
                if (edits)
                    esr_light_edit_apply(&edits[k], found, e);
                else
                    memcpy(e, found, sizeof e);
                const struct esr_vec3 ny = esr_v3_at(ls[k].nrm3, q);
                const float geo = fabsf(esr_v3_dot(ny, wi)) * ls[k].area[q] * (float)ls[k].n /
                                  ((float)spp * dist * dist);
                float R[ESR_DIRECT_MAX_WO][3];
                int any = 0;
                for (size_t w = 0; w < W; w++) {
                    const struct esr_vec3 wo = esr_v3_at(pts->wo3, p * W + w);
                    for (int c = 0; c < 3; c++)
                        R[w][c] = 0.0f;
                    if (esr_v3_dot(n, wo) <= 0.0f)
                        continue;
                    esr_brdf_eval(&mat, n, wo, wi, R[w]);
                    any |= R[w][0] > 0.0f || R[w][1] > 0.0f || R[w][2] > 0.0f;
                }
                const struct esr_vec3 end = esr_v3_add(o, esr_v3_scale(wi, dist - 1.5f * h));
                const float end3[3] = {end.x, end.y, end.z};
                if (!any || esr_first_hit_segment_blocked(&sh->grid, &sh->params, o3, end3))
                    continue;
                for (size_t w = 0; w < W; w++)
                    for (int c = 0; c < 3; c++) {
                        const size_t at = ((p * W + w) * ESR_MAX_LIGHTS + k) * 3 + (size_t)c;
                        out[at] += e[c] * R[w][c] * geo;
                        if (out_found)
                            out_found[at] += found[c] * R[w][c] * geo;
                    }
            }
    }
    return ESR_OK;
}
