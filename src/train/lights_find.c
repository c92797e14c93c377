/* Lights as objects: which surfaces emit, split into lights, grown over their unseen parts (see
 * lights.h). */
#include "train/lights.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/colour.h"
#include "core/error.h"
#include "fields/grid.h"
#include "fields/trilerp.h"
#include "train/light_surface.h"
#include "volume/first_hit.h"
#include "volume/free_space.h"

/* a surface point is outer when free space touches it this many voxels out along its normal */
#define OUTER_OFFSET 1.5f
/* camera rays stop carving free space this many voxels before their first hit */
#define CARVE_MARGIN 1.0f
/* a component smaller than this share of all emitting points (or points) is noise */
#define LIGHTS_MIN_SHARE 0.005
#define LIGHTS_MIN_POINTS 8

/* The lattice indices of point i's 26 neighbours inside the grid; returns their count. */
static int neighbours26(const struct esr_grid *g, size_t i, size_t nb[26])
{
    const int x = (int)(i % (size_t)g->nx), y = (int)(i / (size_t)g->nx % (size_t)g->ny),
              z = (int)(i / ((size_t)g->nx * (size_t)g->ny));
    int n = 0;
    for (int dz = -1; dz <= 1; dz++)
        for (int dy = -1; dy <= 1; dy++)
            for (int dx = -1; dx <= 1; dx++) {
                const int u = x + dx, v = y + dy, w = z + dz;
                if ((dx | dy | dz) && u >= 0 && v >= 0 && w >= 0 && u < g->nx && v < g->ny &&
                    w < g->nz)
                    nb[n++] = esr_grid_index(g, u, v, w);
            }
    return n;
}

/* 26-connected components of the flagged lattice points (comp[i] = component or -1); returns
 * the number of components, their sizes in *sizes (allocated). */
static int components(const struct esr_grid *g, const uint8_t *flag, int32_t *comp,
                      uint32_t *queue, long **sizes_out, int *n_out)
{
    const size_t N = esr_grid_voxels(g);
    int nc = 0, cap = 64;
    long *sizes = malloc((size_t)cap * sizeof(long));
    if (!sizes)
        return ESR_FAIL("lights: out of memory");
    for (size_t i = 0; i < N; i++)
        comp[i] = -1;
    for (size_t s = 0; s < N; s++) {
        if (!flag[s] || comp[s] >= 0)
            continue;
        if (nc == cap) {
            long *t = realloc(sizes, (size_t)(cap *= 2) * sizeof(long));
            if (!t) {
                free(sizes);
                return ESR_FAIL("lights: out of memory");
            }
            sizes = t;
        }
        size_t head = 0, tail = 0;
        queue[tail++] = (uint32_t)s;
        comp[s] = nc;
        while (head < tail) {
            size_t nb[26];
            const int nn = neighbours26(g, queue[head++], nb);
            for (int q = 0; q < nn; q++)
                if (flag[nb[q]] && comp[nb[q]] < 0) {
                    comp[nb[q]] = nc;
                    queue[tail++] = (uint32_t)nb[q];
                }
        }
        sizes[nc++] = (long)tail;
    }
    *sizes_out = sizes;
    *n_out = nc;
    return ESR_OK;
}

/* Marks seen[] (lattice points, zeroed by the caller) within one lattice point of some ray's
 * first SDF hit. */
static int mark_seen(const struct esr_model *m, const float *orig3, const float *dir3,
                     size_t n_rays, uint8_t *seen)
{
    const struct esr_grid *g = esr_model_grid(m, ESR_COMP_SDF);
    float *t = malloc((n_rays ? n_rays : 1) * sizeof(float));
    float *hit = malloc((n_rays ? n_rays : 1) * 3 * sizeof(float));
    int rc = t && hit ? ESR_OK : ESR_FAIL("lights: out of memory for the cameras' first hits");
    struct esr_first_hit_params fp;
    esr_first_hit_params_init(&fp, g);
    fp.refine_iters = 4; /* a lattice point is all the precision asked */
    const struct esr_first_hit_rays fr = {orig3, dir3, NULL, NULL, n_rays};
    const struct esr_first_hit_out fo = {t, NULL, hit, NULL};
    if (rc == ESR_OK)
        rc = esr_first_hit(g, esr_model_values(m, ESR_COMP_SDF), &fp, &fr, &fo);
    for (size_t r = 0; rc == ESR_OK && r < n_rays; r++) {
        if (!isfinite(t[r]))
            continue;
        const size_t at = esr_trilerp_nearest(g, hit + r * 3); /* the march is clipped to the box */
        size_t nb[26];
        const int nn = neighbours26(g, at, nb);
        seen[at] = 1;
        for (int q = 0; q < nn; q++)
            seen[nb[q]] = 1;
    }
    free(t), free(hit);
    return rc;
}

/* Grows each light over its unseen part: the outer surface points (outer[] per lattice point)
 * that no camera sees, 26-connected to the light, breadth-first from its points; they get the
 * light's label with ESR_LIGHT_UNSEEN. queue: [lattice points] scratch. */
static void grow_unseen(const struct esr_grid *g, const uint8_t *unseen_outer, uint8_t *label,
                        uint32_t *queue)
{
    const size_t N = esr_grid_voxels(g);
    size_t head = 0, tail = 0;
    for (size_t i = 0; i < N; i++)
        if (label[i])
            queue[tail++] = (uint32_t)i;
    while (head < tail) {
        const size_t i = queue[head++];
        size_t nb[26];
        const int nn = neighbours26(g, i, nb);
        for (int q = 0; q < nn; q++)
            if (unseen_outer[nb[q]] && !label[nb[q]]) {
                label[nb[q]] = (uint8_t)ESR_LIGHT_LABEL_ID(label[i]) | ESR_LIGHT_UNSEEN;
                queue[tail++] = (uint32_t)nb[q];
            }
    }
}

int esr_lights_find(struct esr_model *m, const float *orig3, const float *dir3, size_t n_rays)
{
    esr_lights_free(&m->lights);
    if (!esr_model_has(m, ESR_COMP_EMIT_MLP))
        return ESR_FAIL("lights: the %s stage has no emission field (train lts and pdra first)",
                        esr_stage_name((enum esr_stage)m->stage));
    const struct esr_grid *g = esr_model_grid(m, ESR_COMP_SDF);
    const size_t N = esr_grid_voxels(g);
    const float k = m->cfg.emitter_k, h = esr_grid_voxel_size(g, 0);
    uint32_t *idx = NULL;
    float *pos = NULL, *nrm = NULL, *emit = NULL;
    size_t n = 0;
    ESR_TRY(esr_light_surface_points(m, &idx, &pos, &nrm, &n));
    uint8_t *flag = calloc(N, 1), *free_mask = malloc(N), *seen = calloc(N, 1);
    uint8_t *outer = malloc(n ? n : 1);
    int32_t *comp = malloc(N * sizeof(int32_t));
    uint32_t *queue = malloc(N * sizeof(uint32_t));
    emit = malloc((n ? n : 1) * 3 * sizeof(float));
    long *sizes = NULL;
    int nc = 0;
    int rc = flag && free_mask && seen && outer && comp && queue && emit
                 ? ESR_OK
                 : ESR_FAIL("lights: out of memory");
    if (rc == ESR_OK)
        rc = esr_light_emission_at(m, pos, n, emit);
    if (rc == ESR_OK)
        rc = esr_free_space_carve(g, esr_model_values(m, ESR_COMP_SDF), orig3, dir3, n_rays,
                                  CARVE_MARGIN, free_mask);
    long emitting = 0;
    for (size_t i = 0; rc == ESR_OK && i < n; i++) {
        float out[3];
        for (int a = 0; a < 3; a++)
            out[a] = pos[i * 3 + a] + OUTER_OFFSET * h * nrm[i * 3 + a];
        outer[i] = (uint8_t)esr_free_space_at(g, free_mask, out);
        if (esr_max_channel(emit + i * 3) > k && outer[i]) {
            flag[idx[i]] = 1;
            emitting++;
        }
    }
    if (rc == ESR_OK)
        rc = components(g, flag, comp, queue, &sizes, &nc);
    /* the kept components, largest first: id_of[c] = light id or -1 */
    int32_t *id_of = rc == ESR_OK ? malloc((size_t)(nc ? nc : 1) * sizeof(int32_t)) : NULL;
    int kept = 0;
    if (rc == ESR_OK && !id_of)
        rc = ESR_FAIL("lights: out of memory");
    const long min_points = (long)fmax(LIGHTS_MIN_POINTS, LIGHTS_MIN_SHARE * (double)emitting);
    for (int c = 0; rc == ESR_OK && c < nc; c++)
        id_of[c] = -1;
    while (rc == ESR_OK && kept < ESR_MAX_LIGHTS) {
        int best = -1;
        for (int c = 0; c < nc; c++)
            if (id_of[c] < 0 && sizes[c] >= min_points && (best < 0 || sizes[c] > sizes[best]))
                best = c;
        if (best < 0)
            break;
        id_of[best] = kept++;
    }
    int left_out = 0;
    for (int c = 0; rc == ESR_OK && c < nc; c++)
        left_out += id_of[c] < 0 && sizes[c] >= min_points;
    struct esr_lights *L = &m->lights;
    if (rc == ESR_OK && kept > 0) {
        L->grid = *g;
        L->grid.channels = 1;
        if (!(L->label = calloc(N, 1)))
            rc = ESR_FAIL("lights: out of memory for the labels");
    }
    if (rc == ESR_OK && kept > 0) {
        L->n = kept;
        double acc[ESR_MAX_LIGHTS][7]; /* centroid 3, E 3, area */
        memset(acc, 0, sizeof acc);
        for (size_t i = 0; i < n; i++) {
            const int c = comp[idx[i]];
            const int id = c < 0 ? -1 : id_of[c];
            if (id < 0)
                continue;
            L->label[idx[i]] = (uint8_t)(id + 1);
            L->light[id].points++;
            for (int a = 0; a < 3; a++) {
                acc[id][a] += pos[i * 3 + a];
                acc[id][3 + a] += emit[i * 3 + a];
            }
            acc[id][6] += esr_light_point_area(h, nrm + i * 3);
        }
        for (int j = 0; j < kept; j++) { /* E: the mean over the part the field learned */
            struct esr_light *l = &L->light[j];
            const double np = (double)(l->points > 0 ? l->points : 1);
            for (int a = 0; a < 3; a++) {
                l->field_rgb[a] = (float)(acc[j][3 + a] / np);
                l->scale[a] = 1.0f;
                l->radiance[a] = l->field_rgb[a];
            }
        }
        /* the lights' unseen parts: outer surface points no camera sees (flag reused) */
        memset(flag, 0, N);
        rc = mark_seen(m, orig3, dir3, n_rays, seen);
        for (size_t i = 0; rc == ESR_OK && i < n; i++)
            if (!seen[idx[i]] && outer[i])
                flag[idx[i]] = 1;
        if (rc == ESR_OK)
            grow_unseen(g, flag, L->label, queue);
        for (size_t i = 0; rc == ESR_OK && i < n; i++) /* they emit: they count in the light */
            if (L->label[idx[i]] & ESR_LIGHT_UNSEEN) {
                const int id = ESR_LIGHT_LABEL_ID(L->label[idx[i]]) - 1;
                L->light[id].points++;
                for (int a = 0; a < 3; a++)
                    acc[id][a] += pos[i * 3 + a];
                acc[id][6] += esr_light_point_area(h, nrm + i * 3);
            }
        for (int j = 0; j < kept; j++) {
            struct esr_light *l = &L->light[j];
            const double np = (double)(l->points > 0 ? l->points : 1);
            for (int a = 0; a < 3; a++)
                l->centroid[a] = (float)(acc[j][a] / np);
            l->area = (float)acc[j][6];
            esr_light_update_radiance(l);
        }
    }
    free(idx), free(pos), free(nrm), free(emit), free(flag), free(free_mask), free(comp), free(queue);
    free(seen), free(outer);
    free(sizes), free(id_of);
    if (rc != ESR_OK)
        esr_lights_free(L);
    else
        L->n_left_out = left_out;
    return rc;
}
