/* Inference rendering of a model (esr_model_render_rays), the SDF view the renderer sees, and the
 * SDF as marches for the first hit must see it. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/colour.h"
#include "core/error.h"
#include "fields/sdf.h"
#include "model/material_fields.h"
#include "model/render_sdf.h"
#include "model/trace.h"
#include "volume/composite.h"

#define RENDER_CHUNK 4096

int esr_model_view_sdf(const struct esr_model *m, const float *raw, float *out, float *scratch)
{
    const struct esr_grid *g = esr_model_grid(m, ESR_COMP_SDF);
    size_t n = esr_grid_count(g);
    if (!esr_stage_info((enum esr_stage)m->stage)->smoothed_sdf || m->cfg.smooth_ksize <= 1) {
        memcpy(out, raw, n * sizeof(float));
        return ESR_OK;
    }
    return esr_grid_smooth_fwd(g, raw, out, scratch, m->cfg.smooth_ksize,
                               m->cfg.smooth_sigma);
}

int esr_model_normal_sdf(const struct esr_model *m, float **out)
{
    *out = NULL;
    if (!esr_model_has(m, ESR_COMP_SDF) || m->cfg.normal_ksize <= 1)
        return ESR_OK;
    const struct esr_grid *g = esr_model_grid(m, ESR_COMP_SDF);
    size_t n = esr_grid_count(g);
    float *smooth = malloc(n * sizeof(float)), *scratch = malloc(n * sizeof(float));
    int rc = smooth && scratch ? esr_grid_smooth_fwd(g, esr_model_values(m, ESR_COMP_SDF), smooth,
                                                     scratch, m->cfg.normal_ksize,
                                                     m->cfg.normal_sigma)
                               : ESR_FAIL("normals: out of memory for the smoothed SDF");
    free(scratch);
    if (rc != ESR_OK)
        free(smooth);
    else
        *out = smooth;
    return rc;
}

/* The lattice indices of point i's 6 axis neighbours inside the grid; returns their count (below
 * 6 on the grid's edge). */
static int neighbours6(const struct esr_grid *g, size_t i, size_t nb[6])
{
    const int x = (int)(i % (size_t)g->nx), y = (int)(i / (size_t)g->nx % (size_t)g->ny),
              z = (int)(i / ((size_t)g->nx * (size_t)g->ny));
    const int q[6][3] = {{x - 1, y, z}, {x + 1, y, z}, {x, y - 1, z},
                         {x, y + 1, z}, {x, y, z - 1}, {x, y, z + 1}};
    int n = 0;
    for (int k = 0; k < 6; k++)
        if (q[k][0] >= 0 && q[k][1] >= 0 && q[k][2] >= 0 && q[k][0] < g->nx && q[k][1] < g->ny &&
            q[k][2] < g->nz)
            nb[n++] = esr_grid_index(g, q[k][0], q[k][1], q[k][2]);
    return n;
}

/* Whether skipped lattice point i borders space outside: the grid's edge, or a rendered
 * neighbour with the SDF above 0 (its skipped region is empty space, not a solid's inside). */
static int touches_outside(const struct esr_grid *g, const float *sdf, const uint8_t *skipped,
                           size_t i)
{
    size_t nb[6];
    const int n = neighbours6(g, i, nb);
    for (int k = 0; k < n; k++)
        if (skipped[nb[k]] == ESR_SDF_RENDERED && sdf[nb[k]] > 0.0f)
            return 1;
    return n < 6;
}

int esr_model_sdf_skipped(const struct esr_model *m, uint8_t *skipped)
{
    const struct esr_grid *g = esr_model_grid(m, ESR_COMP_SDF);
    const float *sdf = esr_model_values(m, ESR_COMP_SDF);
    const size_t n = esr_grid_voxels(g);
#pragma omp parallel for schedule(static)
    for (int z = 0; z < g->nz; z++)
        for (int y = 0; y < g->ny; y++)
            for (int x = 0; x < g->nx; x++) {
                float p[3];
                esr_grid_voxel_pos(g, x, y, z, p);
                skipped[esr_grid_index(g, x, y, z)] =
                    esr_model_renders_at(m, p) ? ESR_SDF_RENDERED : ESR_SDF_SKIPPED_INSIDE;
            }
    /* the skipped regions (6-connected) that touch space outside are empty space: flood them
     * from every such point; what stays ESR_SDF_SKIPPED_INSIDE is enclosed by solid (a band
     * mask skips the inside of every thick solid) */
    uint32_t *queue = malloc(n * sizeof(uint32_t));
    if (!queue)
        return ESR_FAIL("out of memory for the space the renderer skips");
    size_t tail = 0;
    for (size_t i = 0; i < n; i++)
        if (skipped[i] == ESR_SDF_SKIPPED_INSIDE && touches_outside(g, sdf, skipped, i)) {
            skipped[i] = ESR_SDF_SKIPPED_EMPTY;
            queue[tail++] = (uint32_t)i;
        }
    for (size_t head = 0; head < tail; head++) {
        size_t nb[6];
        const int nn = neighbours6(g, queue[head], nb);
        for (int k = 0; k < nn; k++)
            if (skipped[nb[k]] == ESR_SDF_SKIPPED_INSIDE) {
                skipped[nb[k]] = ESR_SDF_SKIPPED_EMPTY;
                queue[tail++] = (uint32_t)nb[k];
            }
    }
    free(queue);
    return ESR_OK;
}

void esr_model_sdf_lift_skipped(const struct esr_model *m, const float *sdf, const uint8_t *skipped,
                                float *out)
{
    const struct esr_grid *g = esr_model_grid(m, ESR_COMP_SDF);
    const float h = esr_grid_voxel_size(g, 0);
    const size_t n = esr_grid_voxels(g);
#pragma omp parallel for simd schedule(static)
    for (size_t i = 0; i < n; i++)
        out[i] = skipped[i] == ESR_SDF_SKIPPED_EMPTY    ? fmaxf(sdf[i], h)
                 : skipped[i] == ESR_SDF_SKIPPED_INSIDE ? fminf(sdf[i], -h)
                                                        : sdf[i];
}

int esr_model_first_hit_sdf(const struct esr_model *m, float **out)
{
    const size_t n = esr_grid_voxels(esr_model_grid(m, ESR_COMP_SDF));
    float *f = malloc(n * sizeof(float));
    uint8_t *skipped = malloc(n);
    int rc = f && skipped ? ESR_OK : ESR_FAIL("out of memory for the SDF as first hits see it");
    if (rc == ESR_OK)
        rc = esr_model_sdf_skipped(m, skipped);
    if (rc == ESR_OK)
        esr_model_sdf_lift_skipped(m, esr_model_values(m, ESR_COMP_SDF), skipped, f);
    free(skipped);
    if (rc != ESR_OK)
        free(f), f = NULL;
    *out = f;
    return rc;
}

/* Per-call scratch of the emitted-radiance rows and their copy on lights only (grown to the kept
 * rows of a chunk). */
struct emit_scratch {
    float *rows;
    size_t cap;
    float *one;   /* [cap] one light's rows (esr_render_out's emitted_each_light) */
    int8_t *id;   /* [cap / 6] each row's light id, -1: none */
};

/* What material_rows composites for a chunk's rays; any pointer may be NULL. */
struct rows_out {
    float *emission3, *emitted3, *emitted_lights3, *material5;
    float *front_opacity, *front_depth, *front_material5; /* with material5 (esr_render_out) */
    float *each3, *value_each3; /* light K's at K * each_stride (esr_render_out) */
    size_t each_stride;
    float *lin3; /* the chunk's linear radiance: a lights-on render gains emitted - E */
    int lights_emitted_only; /* ... or, on lights, emitted - L_emo (esr_render_out) */
};

/* Each light's composited emitted radiance, and its value V on every channel, from the chunk's
 * emitted rows (es->rows): the rows of the other lights' samples and of
 * no light's are zero, so that the lights' sum is emitted_lights. */
static void each_light_emitted(const struct esr_march *mc, const struct esr_lights *L,
                               struct emit_scratch *es, const struct rows_out *o)
{
    const size_t nk = mc->n_kept;
    for (size_t i = 0; i < nk; i++)
        es->id[i] = (int8_t)esr_lights_id_at(L, mc->kpos3 + i * 3);
    struct esr_composite_args one;
    esr_march_composite_args(mc, es->one, 3, NULL, 0, &one);
    for (int k = 0; k < L->n; k++)
        for (int value = 0; value < 2; value++) {
            float *dst = value ? o->value_each3 : o->each3;
            if (!dst)
                continue;
            for (size_t i = 0; i < nk; i++) {
                const float *e = es->rows + i * 3;
                const float v = esr_light_value(e);
                for (int c = 0; c < 3; c++)
                    es->one[i * 3 + c] = es->id[i] != k ? 0.0f : value ? v : e[c];
            }
            esr_composite_fwd(&one, dst + (size_t)k * o->each_stride);
        }
}

/* Composited emission (3), emitted radiance (3; on lights only: emitted_lights3) and BRDF (5,
 * unless mf is emission-only) of the last trace forward's rays (no background). For a lights-on
 * render of a model with lights, lin3 gains the emitted radiance beyond E (with
 * lights_emitted_only, on lights also loses L_emo - E). */
static int material_rows(struct esr_trace *t, const struct esr_model *m, const float *sdf,
                         struct esr_material_fields *mf, struct emit_scratch *es, int lights_on,
                         const struct rows_out *o)
{
    const struct esr_march *mc = &t->march;
    const size_t nk = mc->n_kept;
    ESR_TRY(esr_material_fields_fwd(mf, m, sdf, mc->kpos3, nk));
    struct esr_composite_args a;
    if (o->emission3) {
        esr_march_composite_args(mc, mf->emit3, 3, NULL, 0, &a);
        esr_composite_fwd(&a, o->emission3);
    }
    if (o->material5 && !mf->emission_only) {
        esr_march_composite_args(mc, mf->brdf5, ESR_BRDF_CHANNELS, NULL, 0, &a);
        esr_composite_fwd(&a, o->material5);
        if (o->front_material5)
            esr_composite_front(&a, mc->smp.t, ESR_FRONT_MIN_WEIGHT,
                                ESR_FRONT_DEPTH_VOX * esr_grid_voxel_size(mc->geom.grid, 0),
                                o->front_material5, o->front_opacity, o->front_depth);
    }
    const int calibrated = m->lights.n > 0;
    if (!o->emitted3 && !o->emitted_lights3 && !o->each3 && !o->value_each3 &&
        !(calibrated && lights_on && o->lin3))
        return ESR_OK;
    if (!calibrated) {
        if (o->emitted_lights3) /* no lights: no sample is on one */
            memset(o->emitted_lights3, 0, (size_t)mc->n_rays * 3 * sizeof(float));
        if (o->emitted3 && o->emission3)
            memcpy(o->emitted3, o->emission3, (size_t)mc->n_rays * 3 * sizeof(float));
        else if (o->emitted3) {
            esr_march_composite_args(mc, mf->emit3, 3, NULL, 0, &a);
            esr_composite_fwd(&a, o->emitted3);
        }
        return ESR_OK;
    }
    if (nk * 6 > es->cap) { /* the emitted rows, and those on lights (or the rows' L_emo) */
        free(es->rows), free(es->one), free(es->id);
        es->cap = nk * 6;
        es->rows = malloc(es->cap * sizeof(float));
        es->one = malloc(es->cap * sizeof(float));
        es->id = malloc(es->cap / 6);
        if (!es->rows || !es->one || !es->id) {
            free(es->rows), free(es->one), free(es->id);
            es->rows = es->one = NULL, es->id = NULL;
            es->cap = 0;
            return ESR_FAIL("render: out of memory for %zu emission rows", nk);
        }
    }
    memcpy(es->rows, mf->emit3, nk * 3 * sizeof(float));
    esr_lights_scale_emission(&m->lights, mc->kpos3, nk, es->rows);
    esr_march_composite_args(mc, es->rows, 3, NULL, 0, &a);
    if (o->emitted3)
        esr_composite_fwd(&a, o->emitted3);
    if (o->emitted_lights3) {
        float *lit = es->rows + nk * 3;
        memcpy(lit, es->rows, nk * 3 * sizeof(float));
        esr_lights_keep_lit(&m->lights, mc->kpos3, nk, lit);
        struct esr_composite_args al;
        esr_march_composite_args(mc, lit, 3, NULL, 0, &al);
        esr_composite_fwd(&al, o->emitted_lights3);
    }
    if (o->each3 || o->value_each3)
        each_light_emitted(mc, &m->lights, es, o);
    if (lights_on && o->lin3) { /* the linear radiance's emission at the calibrated strength */
        for (size_t i = 0; i < nk * 3; i++)
            es->rows[i] -= mf->emit3[i];
        if (o->lights_emitted_only) { /* and on lights, minus L_emo - E */
            float *emo = es->rows + nk * 3; /* the rows on lights are composited by now */
            esr_point_fields_emo(&t->fields, emo);
            for (size_t i = 0; i < nk * 3; i++)
                emo[i] -= mf->emit3[i];
            esr_lights_keep_lit(&m->lights, mc->kpos3, nk, emo);
            for (size_t i = 0; i < nk * 3; i++)
                es->rows[i] -= emo[i];
        }
        float extra[3 * RENDER_CHUNK];
        esr_composite_fwd(&a, extra);
        for (int i = 0; i < mc->n_rays * 3; i++)
            o->lin3[i] += extra[i];
    }
    return ESR_OK;
}

/* Per ray the light at its strongest kept sample, or -1. */
static void light_ids(const struct esr_march *mc, const struct esr_lights *L, int32_t *ids)
{
#pragma omp parallel for schedule(static)
    for (int r = 0; r < mc->n_rays; r++) {
        size_t best = 0;
        ids[r] = esr_march_strongest_kept(mc, r, &best) > 0.0f
                     ? esr_lights_id_at(L, mc->kpos3 + best * 3)
                     : -1;
    }
}

/* The last shading's linear radiance of n rays (the LDR heads': their colour decoded). */
static void copy_linear(const struct esr_trace *t, float *dst, size_t n)
{
    for (size_t i = 0; i < n * 3; i++)
        dst[i] = t->fields.lin3 ? t->lin_rgb3[i] : esr_linear_from_srgb(t->rgb3[i]);
}

static void copy_out(float *dst, const float *src, size_t off, size_t n)
{
    if (dst)
        memcpy(dst + off, src, n * sizeof(float));
}

int esr_model_render_rays(const struct esr_model *m, const float *origins, const float *dirs,
                          size_t n, int lights_on, const struct esr_render_out *out)
{
    const float *sdf = NULL;
    float *view = NULL, *scratch = NULL;
    if (esr_model_has(m, ESR_COMP_SDF)) {
        size_t ns = esr_grid_count(esr_model_grid(m, ESR_COMP_SDF));
        view = malloc(ns * sizeof(float));
        scratch = malloc(ns * sizeof(float));
        if (!view || !scratch) {
            free(view);
            free(scratch);
            return ESR_FAIL("render: out of memory for the SDF view");
        }
        int rc = esr_model_view_sdf(m, esr_model_values(m, ESR_COMP_SDF), view, scratch);
        free(scratch);
        if (rc != ESR_OK) {
            free(view);
            return rc;
        }
        sdf = view;
    }
    float *normal_sdf = NULL;
    int rc = out->normal ? esr_model_normal_sdf(m, &normal_sdf) : ESR_OK;
    if (rc != ESR_OK) {
        free(view);
        return rc;
    }
    struct esr_trace t;
    int chunk = n < RENDER_CHUNK ? (int)(n ? n : 1) : RENDER_CHUNK;
    rc = esr_trace_init(&t, m, chunk, 0);
    float *depth = NULL, *normal = NULL, *opac = NULL;
    uint8_t *flags = NULL, *flags_other = NULL;
    struct esr_material_fields mf;
    const int fields = (out->emission || out->emitted || out->emitted_lights || out->material ||
                        out->emitted_each_light || out->emitted_value_each_light ||
                        (((lights_on && out->linear) || out->linear_other) && m->lights.n > 0)) &&
                       esr_model_has(m, ESR_COMP_EMIT_MLP);
    struct emit_scratch es = {NULL, 0, NULL, NULL};
    memset(&mf, 0, sizeof mf);
    if (rc == ESR_OK && fields)
        rc = esr_material_fields_init(&mf, m, (size_t)chunk * 8,
                                      out->material ? 0 : ESR_MATERIAL_EMISSION_ONLY);
    if (rc == ESR_OK) {
        flags = malloc((size_t)chunk);
        flags_other = out->linear_other ? malloc((size_t)chunk) : NULL;
        depth = malloc((size_t)chunk * sizeof(float));
        normal = malloc((size_t)chunk * 3 * sizeof(float));
        opac = malloc((size_t)chunk * sizeof(float));
        if (!depth || !normal || !opac || !flags || (out->linear_other && !flags_other))
            rc = ESR_FAIL("render: out of memory");
        else {
            memset(flags, lights_on ? 1 : 0, (size_t)chunk);
            if (flags_other)
                memset(flags_other, lights_on ? 0 : 1, (size_t)chunk);
        }
    }
    for (size_t r0 = 0; rc == ESR_OK && r0 < n; r0 += (size_t)chunk) {
        int c = (int)(n - r0 < (size_t)chunk ? n - r0 : (size_t)chunk);
        rc = esr_trace_fwd(&t, m, sdf, origins + r0 * 3, dirs + r0 * 3, flags, c, 0);
        if (rc != ESR_OK)
            break;
        esr_trace_extras(&t, normal_sdf, depth, normal, opac);
        copy_out(out->rgb, t.rgb3, r0 * 3, (size_t)c * 3);
        copy_out(out->depth, depth, r0, (size_t)c);
        copy_out(out->normal, normal, r0 * 3, (size_t)c * 3);
        copy_out(out->opacity, opac, r0, (size_t)c);
        if (out->linear)
            copy_linear(&t, out->linear + r0 * 3, (size_t)c);
        if (out->light_id)
            light_ids(&t.march, &m->lights, out->light_id + r0);
        if (fields) {
            const struct rows_out ro = {
                out->emission ? out->emission + r0 * 3 : NULL,
                out->emitted ? out->emitted + r0 * 3 : NULL,
                out->emitted_lights ? out->emitted_lights + r0 * 3 : NULL,
                out->material ? out->material + r0 * ESR_BRDF_CHANNELS : NULL,
                out->front_material ? out->front_opacity + r0 : NULL,
                out->front_material ? out->front_depth + r0 : NULL,
                out->front_material ? out->front_material + r0 * ESR_BRDF_CHANNELS : NULL,
                out->emitted_each_light ? out->emitted_each_light + r0 * 3 : NULL,
                out->emitted_value_each_light ? out->emitted_value_each_light + r0 * 3 : NULL,
                n * 3, out->linear ? out->linear + r0 * 3 : NULL, out->lights_emitted_only};
            rc = material_rows(&t, m, sdf, &mf, &es, lights_on, &ro);
            if (rc != ESR_OK)
                break;
        }
        if (out->linear_other) { /* the same march shaded with the other lighting */
            rc = esr_trace_shade(&t, m, sdf, flags_other);
            if (rc != ESR_OK)
                break;
            copy_linear(&t, out->linear_other + r0 * 3, (size_t)c);
            if (fields) {
                const struct rows_out ro = {.lin3 = out->linear_other + r0 * 3,
                                            .lights_emitted_only = out->lights_emitted_only};
                rc = material_rows(&t, m, sdf, &mf, &es, !lights_on, &ro);
            }
        }
    }
    free(es.rows), free(es.one), free(es.id);
    free(depth);
    free(normal);
    free(opac);
    free(flags);
    free(flags_other);
    esr_trace_free(&t);
    esr_material_fields_free(&mf);
    free(view);
    free(normal_sdf);
    return rc;
}
