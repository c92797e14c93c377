/* Direct light of the found lights at surface points (see light_direct.h). */
#include "train/light_direct.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/brdf.h"
#include "core/error.h"
#include "core/rng.h"
#include "core/vec3.h"
#include "fields/grid.h"
#include "model/material_fields.h"
#include "volume/first_hit.h"

int esr_lights_direct(const struct esr_model *m, const struct esr_light_samples *ls, int n_lights,
                      const struct esr_light_edit *edits, const struct esr_direct_points *pts,
                      int spp, uint64_t seed, double *out, double *out_found)
{
    const size_t P = pts->n, W = (size_t)pts->n_wo, K = (size_t)n_lights;
    memset(out, 0, P * W * ESR_MAX_LIGHTS * 3 * sizeof(double));
    if (out_found)
        memset(out_found, 0, P * W * ESR_MAX_LIGHTS * 3 * sizeof(double));
    const struct esr_grid *g = esr_model_grid(m, ESR_COMP_SDF);
    const float h = esr_grid_voxel_size(g, 0);
    const size_t cap = P * K * (size_t)spp;
    if (cap == 0)
        return ESR_OK;
    /* per shadow ray: origin, direction, length, and per outgoing direction its weight (and
     * its weight for the emission as found: G, the geometry and BRDF alone, times that) */
    float *o3 = malloc(cap * 3 * sizeof(float)), *d3 = malloc(cap * 3 * sizeof(float));
    float *tmax = malloc(cap * sizeof(float)), *w3 = malloc(cap * W * 3 * sizeof(float));
    float *wf3 = out_found ? malloc(cap * W * 3 * sizeof(float)) : NULL;
    uint8_t *flags = malloc(cap);
    if (!o3 || !d3 || !tmax || !w3 || !flags || (out_found && !wf3)) {
        free(o3), free(d3), free(tmax), free(w3), free(wf3), free(flags);
        return ESR_FAIL("lights: out of memory for %zu shadow rays", cap);
    }
    /* slot (p, K, j) is fixed, so no compaction: a skipped sample gets tmax 0 and weight 0 */
#pragma omp parallel for schedule(dynamic, 16)
    for (size_t p = 0; p < P; p++) {
        const struct esr_vec3 x = esr_v3_at(pts->pos3, p), n = esr_v3_at(pts->nrm3, p);
        const struct esr_material mat = esr_material_of_row(pts->brdf5 + p * ESR_BRDF_CHANNELS, 1.0f);
        const struct esr_vec3 o = esr_v3_add(x, esr_v3_scale(n, h));
        struct esr_rng rng = esr_rng_init(seed, p);
        for (size_t k = 0; k < K; k++)
            for (int j = 0; j < spp; j++) {
                const size_t s = (p * K + k) * (size_t)spp + (size_t)j;
                memcpy(o3 + s * 3, &o, 3 * sizeof(float));
                memcpy(d3 + s * 3, &n, 3 * sizeof(float));
                tmax[s] = 0.0f;
                memset(w3 + s * W * 3, 0, W * 3 * sizeof(float));
                if (wf3)
                    memset(wf3 + s * W * 3, 0, W * 3 * sizeof(float));
                const uint32_t u = esr_rng_u32(&rng);
                if (ls[k].n == 0)
                    continue;
                const size_t q = u % (uint32_t)ls[k].n;
                const struct esr_vec3 v = esr_v3_sub(esr_v3_at(ls[k].pos3, q), o);
                const float dist = esr_v3_length(v);
                if (dist <= 1.5f * h)
                    continue;
                const struct esr_vec3 wi = esr_v3_scale(v, 1.0f / dist);
                memcpy(d3 + s * 3, &wi, 3 * sizeof(float));
                const float *found = ls[k].emit3 + q * 3;
                float e[3];
                if (edits)
                    esr_light_edit_apply(&edits[k], found, e);
                else
                    memcpy(e, found, sizeof e);
                const struct esr_vec3 ny = esr_v3_at(ls[k].nrm3, q);
                const float geo = fabsf(esr_v3_dot(ny, wi)) * ls[k].area[q] * (float)ls[k].n /
                                  ((float)spp * dist * dist);
                int any = 0;
                for (size_t w = 0; w < W; w++) {
                    const struct esr_vec3 wo = esr_v3_at(pts->wo3, p * W + w);
                    if (esr_v3_dot(n, wo) <= 0.0f)
                        continue;
                    float R[3];
                    esr_brdf_eval(&mat, n, wo, wi, R);
                    for (int c = 0; c < 3; c++) {
                        w3[(s * W + w) * 3 + c] = e[c] * R[c] * geo;
                        if (wf3)
                            wf3[(s * W + w) * 3 + c] = found[c] * R[c] * geo;
                        any |= R[c] > 0.0f;
                    }
                }
                if (any)
                    tmax[s] = dist - 1.5f * h;
            }
    }
    struct esr_first_hit_params hp;
    esr_first_hit_params_init(&hp, g);
    struct esr_first_hit_rays hr = {o3, d3, NULL, tmax, cap};
    struct esr_first_hit_out ho = {NULL, flags, NULL, NULL};
    int rc = esr_first_hit(g, esr_model_values(m, ESR_COMP_SDF), &hp, &hr, &ho);
    /* a point's sums run over its own slots in a fixed order: deterministic */
#pragma omp parallel for schedule(static)
    for (size_t p = 0; p < P; p++)
        for (size_t k = 0; rc == ESR_OK && k < K; k++)
            for (int j = 0; j < spp; j++) {
                const size_t s = (p * K + k) * (size_t)spp + (size_t)j;
                if (tmax[s] <= 0.0f || (flags[s] & ESR_FIRST_HIT_HIT))
                    continue;
                for (size_t w = 0; w < W; w++)
                    for (int c = 0; c < 3; c++) {
                        const size_t at = ((p * W + w) * ESR_MAX_LIGHTS + k) * 3 + (size_t)c;
                        out[at] += w3[(s * W + w) * 3 + c];
                        if (out_found)
                            out_found[at] += wf3[(s * W + w) * 3 + c];
                    }
            }
    free(o3), free(d3), free(tmax), free(w3), free(wf3), free(flags);
    return rc;
}
