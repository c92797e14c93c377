/* Lights of a model: labels and calibration lookups (see lights.h). */
#include "model/lights.h"

#include "core/colour.h"
#include "core/error.h"
#include "core/hash.h"
#include "fields/trilerp.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void esr_lights_free(struct esr_lights *L)
{
    free(L->label);
    memset(L, 0, sizeof(*L));
}

void esr_lights_balance_of(const struct esr_lights *L, float b[3])
{
    for (int c = 0; c < 3; c++)
        b[c] = L->n > 0 && L->balance[c] > 0.0f ? L->balance[c] : 1.0f;
}

int esr_lights_balanced(const struct esr_lights *L)
{
    float b[3];
    esr_lights_balance_of(L, b);
    return b[0] != 1.0f || b[1] != 1.0f || b[2] != 1.0f;
}

void esr_lights_balance_env(const struct esr_lights *L, float *rgb3, size_t n)
{
    if (!esr_lights_balanced(L))
        return;
    float b[3];
    esr_lights_balance_of(L, b);
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++)
            rgb3[i * 3 + (size_t)c] /= b[c];
}

void esr_light_update_radiance(struct esr_light *l)
{
    for (int c = 0; c < 3; c++)
        l->radiance[c] = l->scale[c] * l->field_rgb[c];
    l->power = esr_luminance(l->radiance) * (float)M_PI * l->area;
}

uint64_t esr_lights_fingerprint(const struct esr_lights *L)
{
    uint64_t h = esr_hash_bytes(ESR_HASH_INIT, &L->n, sizeof L->n);
    for (int i = 0; i < L->n; i++) { /* field by field: no struct padding in the hash */
        const struct esr_light *l = &L->light[i];
        const long points = l->points;
        h = esr_hash_bytes(h, l->centroid, sizeof l->centroid);
        h = esr_hash_bytes(h, &l->area, sizeof l->area);
        h = esr_hash_bytes(h, &points, sizeof points);
        h = esr_hash_bytes(h, l->field_rgb, sizeof l->field_rgb);
        h = esr_hash_bytes(h, l->scale, sizeof l->scale);
    }
    if (L->n > 0 && L->label)
        h = esr_hash_bytes(h, L->label, esr_grid_voxels(&L->grid));
    if (esr_lights_balanced(L)) /* unbalanced lights hash as before the balance existed */
        h = esr_hash_bytes(h, L->balance, sizeof L->balance);
    return h;
}

int esr_lights_drop(struct esr_lights *L, int id)
{
    if (L->n == 0)
        return ESR_FAIL("light %d: the run has no lights", id);
    if (id < 0 || id >= L->n)
        return ESR_FAIL("light %d: the run has %d light%s (ids 0 to %d)", id, L->n, L->n == 1 ? "" : "s",
                        L->n - 1);
    const size_t N = esr_grid_voxels(&L->grid);
    for (size_t i = 0; i < N; i++) {
        const int k = ESR_LIGHT_LABEL_ID(L->label[i]) - 1;
        if (k == id)
            L->label[i] = 0;
        else if (k > id) /* its id + 1 becomes id: one less, the unseen flag kept */
            L->label[i] = (uint8_t)((L->label[i] & (ESR_LIGHT_UNSEEN | ESR_LIGHT_UNDECIDED)) | (uint8_t)k);
    }
    memmove(&L->light[id], &L->light[id + 1], (size_t)(L->n - id - 1) * sizeof L->light[0]);
    memmove(&L->edit[id], &L->edit[id + 1], (size_t)(L->n - id - 1) * sizeof L->edit[0]);
    memmove(&L->rim[id], &L->rim[id + 1], (size_t)(L->n - id - 1) * sizeof L->rim[0]);
    if (--L->n == 0)
        esr_lights_free(L);
    return ESR_OK;
}

void esr_lights_unseen_points(const struct esr_lights *L, long unseen[ESR_MAX_LIGHTS])
{
    memset(unseen, 0, ESR_MAX_LIGHTS * sizeof(long));
    if (L->n == 0 || !L->label)
        return;
    const size_t N = esr_grid_voxels(&L->grid);
    for (size_t i = 0; i < N; i++) {
        const int id = ESR_LIGHT_LABEL_ID(L->label[i]) - 1;
        if ((L->label[i] & ESR_LIGHT_UNSEEN) && id >= 0 && id < L->n)
            unseen[id]++;
    }
}

/* The label of a surface point: that of the nearest labelled corner of its lattice cell, or 0. */
uint8_t esr_lights_label_at(const struct esr_lights *L, const float pos[3])
{
    if (L->n == 0 || !L->label)
        return 0;
    const struct esr_grid *g = &L->grid;
    for (int a = 0; a < 3; a++) /* outside the lattice (or NaN): no light */
        if (!(pos[a] >= g->bmin[a] && pos[a] <= g->bmax[a]))
            return 0;
    struct esr_trilerp t;
    esr_trilerp_locate(g, pos, &t);
    /* the labelled corner nearest by squared distance in lattice units */
    uint8_t best = 0;
    float best_d = INFINITY;
    for (int c = 0; c < 8; c++) {
        float w;
        const size_t i = esr_trilerp_corner(&t, c, &w);
        if (!L->label[i])
            continue;
        float d = 0.0f;
        for (int a = 0; a < 3; a++) {
            const float o = (float)((c >> a) & 1);
            d += (t.f[a] - o) * (t.f[a] - o);
        }
        if (d < best_d) {
            best_d = d;
            best = L->label[i];
        }
    }
    return best;
}

int esr_lights_id_at(const struct esr_lights *L, const float pos[3])
{
    const uint8_t label = esr_lights_label_at(L, pos);
    return label ? ESR_LIGHT_LABEL_ID(label) - 1 : -1;
}

void esr_lights_scale_emission(const struct esr_lights *L, const float *pos3, size_t n, float *emit3)
{
    if (L->n == 0)
        return;
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++) {
        const uint8_t label = esr_lights_label_at(L, pos3 + i * 3);
        if (!label)
            continue;
        const int id = ESR_LIGHT_LABEL_ID(label) - 1;
        const struct esr_light *lt = &L->light[id];
        for (int c = 0; c < 3; c++) /* the unseen part emits the mean field, as its samples do */
            emit3[i * 3 + c] = (label & ESR_LIGHT_UNSEEN ? lt->field_rgb[c] : emit3[i * 3 + c]) * lt->scale[c];
        if (L->edited) {
            const float e[3] = {emit3[i * 3], emit3[i * 3 + 1], emit3[i * 3 + 2]};
            esr_light_edit_apply(&L->edit[id], e, emit3 + i * 3);
        }
    }
}

void esr_lights_keep_lit(const struct esr_lights *L, const float *pos3, size_t n, float *emit3)
{
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++)
        if (esr_lights_id_at(L, pos3 + i * 3) < 0)
            emit3[i * 3] = emit3[i * 3 + 1] = emit3[i * 3 + 2] = 0.0f;
}

const char *esr_light_edit_problem(const struct esr_light_edit *ed, char *why, size_t size)
{
    if (!(ed->intensity >= 0.0f && ed->intensity <= ESR_LIGHT_EDIT_MAX_INTENSITY))
        snprintf(why, size, "intensity %g is not a number in [0, %g]", (double)ed->intensity,
                 ESR_LIGHT_EDIT_MAX_INTENSITY);
    else if (ed->recolour && !(ed->hue >= 0.0f && ed->hue <= 1.0f))
        snprintf(why, size, "hue %g is not a number in [0, 1]", (double)ed->hue);
    else if (ed->recolour && !(ed->sat >= 0.0f && ed->sat <= 1.0f))
        snprintf(why, size, "saturation %g is not a number in [0, 1]", (double)ed->sat);
    else
        return NULL;
    return why;
}

int esr_light_edit_check(const struct esr_light_edit *ed, int id)
{
    char why[96];
    if (esr_light_edit_problem(ed, why, sizeof why))
        return ESR_FAIL("edit of light %d: %s", id, why);
    return ESR_OK;
}

int esr_light_edits_check(const struct esr_light_edit *edits, int n)
{
    for (int id = 0; id < n; id++)
        ESR_TRY(esr_light_edit_check(&edits[id], id));
    return ESR_OK;
}

void esr_light_edit_weights(const struct esr_light_edit *ed, float w[3])
{
    if (ed->recolour) { /* hsv_to_rgb(h, s, V) is V hsv_to_rgb(h, s, 1): linear in V */
        const float unit[3] = {ed->hue, ed->sat, 1.0f};
        esr_hsv_to_rgb(unit, w);
    } else {
        w[0] = w[1] = w[2] = 1.0f;
    }
    for (int c = 0; c < 3; c++)
        w[c] *= ed->intensity;
}

float esr_light_value(const float e[3])
{
    return fmaxf(e[0], fmaxf(e[1], e[2]));
}

void esr_light_edit_apply(const struct esr_light_edit *ed, const float e[3], float out[3])
{
    float w[3];
    esr_light_edit_weights(ed, w);
    const float v = esr_light_value(e);
    for (int c = 0; c < 3; c++)
        out[c] = w[c] * (ed->recolour ? v : e[c]);
}
