/* The lights' surface: band points, their areas and emission, a light's samples (see
 * lights/surface.h). */
#include "train/lights/surface.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "fields/grid.h"
#include "model/lights.h"
#include "model/material_fields.h"
#include "model/render_sdf.h"

/* material-field evaluations per batch */
#define EVAL_CHUNK 16384

/* Lattice points with a sign change to an axis neighbour, in space the renderer does not skip:
 * indices, surface positions and unit normals. */
int esr_light_surface_points(const struct esr_model *m, uint32_t **idx_out, float **pos_out,
                             float **nrm_out, size_t *n_out)
{
    const struct esr_grid *g = esr_model_grid(m, ESR_COMP_SDF);
    const float *f = esr_model_values(m, ESR_COMP_SDF);
    size_t n = 0, cap = 1 << 16;
    uint32_t *idx = malloc(cap * sizeof(uint32_t));
    if (!idx)
        return ESR_FAIL("lights: out of memory for the surface points");
    for (int z = 0; z < g->nz; z++)
        for (int y = 0; y < g->ny; y++)
            for (int x = 0; x < g->nx; x++) {
                const size_t i = esr_grid_index(g, x, y, z);
                const int in = f[i] <= 0.0f;
                const int nb[6][3] = {{x - 1, y, z}, {x + 1, y, z}, {x, y - 1, z},
                                      {x, y + 1, z}, {x, y, z - 1}, {x, y, z + 1}};
                int edge = 0;
                for (int k = 0; k < 6 && !edge; k++) {
                    const int *q = nb[k];
                    if (q[0] < 0 || q[1] < 0 || q[2] < 0 || q[0] >= g->nx || q[1] >= g->ny ||
                        q[2] >= g->nz)
                        continue;
                    if ((f[esr_grid_index(g, q[0], q[1], q[2])] <= 0.0f) == in)
                        continue;
                    float at[3]; /* both ends where the renderer samples (model/render_sdf.h) */
                    esr_grid_voxel_pos(g, q[0], q[1], q[2], at);
                    edge = esr_model_renders_at(m, at);
                }
                if (!edge)
                    continue;
                float at[3];
                esr_grid_voxel_pos(g, x, y, z, at);
                if (!esr_model_renders_at(m, at))
                    continue;
                if (n == cap) {
                    uint32_t *t = realloc(idx, 2 * cap * sizeof(uint32_t));
                    if (!t) {
                        free(idx);
                        return ESR_FAIL("lights: out of memory for the surface points");
                    }
                    idx = t;
                    cap *= 2;
                }
                idx[n++] = (uint32_t)i;
            }
    float *pos = malloc((n ? n : 1) * 3 * sizeof(float)), *nrm = malloc((n ? n : 1) * 3 * sizeof(float));
    if (!pos || !nrm) {
        free(idx), free(pos), free(nrm);
        return ESR_FAIL("lights: out of memory for %zu surface points", n);
    }
    for (size_t k = 0; k < n; k++) {
        const size_t i = idx[k];
        const int x = (int)(i % (size_t)g->nx), y = (int)(i / (size_t)g->nx % (size_t)g->ny),
                  z = (int)(i / ((size_t)g->nx * (size_t)g->ny));
        esr_grid_voxel_pos(g, x, y, z, pos + k * 3);
    }
    esr_grid_sample_dpoint(g, f, 0, pos, n, nrm);
    const float h = esr_grid_voxel_size(g, 0);
#pragma omp parallel for schedule(static)
    for (size_t k = 0; k < n; k++) {
        float *p = pos + k * 3, *d = nrm + k * 3;
        const float g2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        if (g2 < 1e-20f) {
            d[0] = d[1] = 0.0f, d[2] = 1.0f;
            continue;
        }
        float step = -f[idx[k]] / g2; /* Newton step onto the level set, at most a voxel */
        const float len = fabsf(step) * sqrtf(g2);
        if (len > h)
            step *= h / len;
        const float inv = 1.0f / sqrtf(g2);
        for (int a = 0; a < 3; a++) {
            p[a] += step * d[a];
            d[a] *= inv;
        }
    }
    *idx_out = idx;
    *pos_out = pos;
    *nrm_out = nrm;
    *n_out = n;
    return ESR_OK;
}

/* The area a band point stands for. The band's points on each side of a plane tile it once: one
 * per lattice step along the normal's dominant axis, so each stands for h^2 / max|n_a|; both
 * sides, halved, cancel a curved surface's first-order shell growth (outside) and shrinkage
 * (inside). */
float esr_light_point_area(float h, const float *nrm)
{
    const float mx = fmaxf(fabsf(nrm[0]), fmaxf(fabsf(nrm[1]), fabsf(nrm[2])));
    return 0.5f * h * h / fmaxf(mx, 0.577f);
}

/* E at n points, in chunks. */
int esr_light_emission_at(const struct esr_model *m, const float *pos3, size_t n, float *emit3)
{
    struct esr_material_fields mf;
    ESR_TRY(esr_material_fields_init(&mf, m, EVAL_CHUNK, ESR_MATERIAL_EMISSION_ONLY));
    const float *sdf = esr_model_values(m, ESR_COMP_SDF);
    int rc = ESR_OK;
    for (size_t i0 = 0; i0 < n && rc == ESR_OK; i0 += EVAL_CHUNK) {
        const size_t c = n - i0 < EVAL_CHUNK ? n - i0 : EVAL_CHUNK;
        rc = esr_material_fields_fwd(&mf, m, sdf, pos3 + i0 * 3, c);
        if (rc == ESR_OK)
            memcpy(emit3 + i0 * 3, mf.emit3, c * 3 * sizeof(float));
    }
    esr_material_fields_free(&mf);
    return rc;
}

void esr_light_samples_free(struct esr_light_samples *s)
{
    free(s->pos3);
    free(s->nrm3);
    free(s->emit3);
    free(s->area);
    memset(s, 0, sizeof(*s));
}

int esr_light_samples_get(const struct esr_model *m, int id, struct esr_light_samples *out)
{
    return esr_light_samples_part(m, id, ESR_LIGHT_PART_ALL, out);
}

/* Whether a point labelled `label` belongs to part `part` of its light. */
static int in_part(uint8_t label, enum esr_light_part part)
{
    const int undecided = (label & ESR_LIGHT_UNDECIDED) != 0;
    return part == ESR_LIGHT_PART_ALL || (part == ESR_LIGHT_PART_UNDECIDED) == undecided;
}

int esr_light_samples_part(const struct esr_model *m, int id, enum esr_light_part part,
                           struct esr_light_samples *out)
{
    memset(out, 0, sizeof(*out));
    const struct esr_lights *L = &m->lights;
    if (id < 0 || id >= L->n)
        return ESR_FAIL("lights: no light %d (the model has %d)", id, L->n);
    uint32_t *idx = NULL;
    float *pos = NULL, *nrm = NULL;
    size_t n = 0;
    ESR_TRY(esr_light_surface_points(m, &idx, &pos, &nrm, &n));
    size_t k = 0;
    uint8_t *unseen = malloc(n ? n : 1);
    for (size_t i = 0; unseen && i < n; i++) /* the light's points, compacted in place */
        if (ESR_LIGHT_LABEL_ID(L->label[idx[i]]) == id + 1 && in_part(L->label[idx[i]], part)) {
            memmove(pos + k * 3, pos + i * 3, 3 * sizeof(float));
            memmove(nrm + k * 3, nrm + i * 3, 3 * sizeof(float));
            unseen[k++] = (L->label[idx[i]] & ESR_LIGHT_UNSEEN) != 0;
        }
    free(idx);
    out->n = k;
    out->pos3 = pos;
    out->nrm3 = nrm;
    out->emit3 = malloc((k ? k : 1) * 3 * sizeof(float));
    out->area = malloc((k ? k : 1) * sizeof(float));
    int rc = out->emit3 && out->area && unseen ? ESR_OK : ESR_FAIL("lights: out of memory for samples");
    if (rc == ESR_OK)
        rc = esr_light_emission_at(m, pos, k, out->emit3);
    const float h = esr_grid_voxel_size(esr_model_grid(m, ESR_COMP_SDF), 0);
    for (size_t i = 0; rc == ESR_OK && i < k; i++) {
        if (unseen[i]) /* its field learned only the light it casts, which clipped images understate */
            memcpy(out->emit3 + i * 3, L->light[id].field_rgb, 3 * sizeof(float));
        for (int c = 0; c < 3; c++)
            out->emit3[i * 3 + c] *= L->light[id].scale[c];
        out->area[i] = esr_light_point_area(h, nrm + i * 3);
        out->total_area += out->area[i];
        for (int c = 0; c < 3; c++)
            out->max_emit = fmaxf(out->max_emit, out->emit3[i * 3 + c]);
    }
    free(unseen);
    if (rc != ESR_OK)
        esr_light_samples_free(out);
    return rc;
}
