/* Lights as objects: which surfaces emit, split into lights, grown over their unseen parts (see
 * lights.h). */
#include "train/lights/lights.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/colour.h"
#include "core/error.h"
#include "fields/grid.h"
#include "model/render_sdf.h"
#include "train/lights/seen.h"
#include "train/lights/surface.h"
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

/* a lights-on pixel whose every channel reaches this (sRGB) is clipped: it shows an emitter, or
 * light too strong to read, and says nothing on whether the surface it sees emits (nor does a
 * masked photo's background, composited on white, which counts the same) */
#define SEEN_CLIPPED 0.99f

/* Whether ray r of rs sees clearly: a lights-on ray whose photo is not clipped. */
static int sees_clearly(const struct esr_ray_set *rs, size_t r)
{
    const float *c = rs->rgb3 + r * 3;
    return r >= rs->n_off && fminf(c[0], fminf(c[1], c[2])) < SEEN_CLIPPED;
}

/* Marks the lattice points the training views see (train/lights/seen.h): in seen[] by any ray,
 * in seen_clearly[] by the rays that see clearly. One march serves both. */
static int mark_seen(const struct esr_model *m, const float *sdf, const struct esr_ray_set *rs,
                     uint8_t *seen, uint8_t *seen_clearly)
{
    const struct esr_grid *g = esr_model_grid(m, ESR_COMP_SDF);
    const size_t N = esr_grid_voxels(g);
    float *area = calloc(N, sizeof(float)), *area_clearly = calloc(N, sizeof(float));
    int rc = area && area_clearly ? ESR_OK : ESR_FAIL("lights: out of memory for the seen surface");
    if (rc == ESR_OK)
        rc = esr_seen_area(g, sdf, rs, sees_clearly, area, area_clearly);
    if (rc == ESR_OK) {
        const float h = esr_grid_voxel_size(g, 0), need = m->cfg.lights_seen_area * h * h;
        esr_seen_marks(g, area, need, seen);
        esr_seen_marks(g, area_clearly, need, seen_clearly);
    }
    free(area), free(area_clearly);
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

/* Labels the undecided rim of each light: the flagged points (outer surface that only
 * lights-off or clipped pixels see) one lattice point from it, with the light's id,
 * ESR_LIGHT_UNSEEN and ESR_LIGHT_UNDECIDED (the calibration decides whether each light's rim
 * emits, esr_lights_settle). One point deep: without the limit the rims of both scenes grow by
 * only 5-10% (lamp's lampshade 276 -> 302 points), and a rim of floor beside a light could run
 * on across the floor. */
static void mark_undecided(const struct esr_grid *g, const uint8_t *flag, uint8_t *label)
{
    const size_t N = esr_grid_voxels(g);
    for (size_t i = 0; i < N; i++) {
        if (!flag[i] || label[i])
            continue;
        size_t nb[26];
        const int nn = neighbours26(g, i, nb);
        for (int q = 0; q < nn; q++)
            if (label[nb[q]] && !(label[nb[q]] & ESR_LIGHT_UNDECIDED)) {
                label[i] = (uint8_t)(ESR_LIGHT_LABEL_ID(label[nb[q]]) | ESR_LIGHT_UNSEEN |
                                     ESR_LIGHT_UNDECIDED);
                break;
            }
    }
}

/* Each light's points, centroid, area and power from its labels over the n surface points
 * (lattice indices idx, positions pos, normals nrm), on a lattice of spacing h. */
static void measure(struct esr_lights *L, float h, const uint32_t *idx, const float *pos,
                    const float *nrm, size_t n)
{
    double acc[ESR_MAX_LIGHTS][4]; /* centroid 3, area */
    memset(acc, 0, sizeof acc);
    for (int j = 0; j < L->n; j++)
        L->light[j].points = 0;
    for (size_t i = 0; i < n; i++) {
        const int id = ESR_LIGHT_LABEL_ID(L->label[idx[i]]) - 1;
        if (id < 0 || id >= L->n)
            continue;
        L->light[id].points++;
        for (int a = 0; a < 3; a++)
            acc[id][a] += pos[i * 3 + a];
        acc[id][3] += esr_light_point_area(h, nrm + i * 3);
    }
    for (int j = 0; j < L->n; j++) {
        struct esr_light *l = &L->light[j];
        const double np = (double)(l->points > 0 ? l->points : 1);
        for (int a = 0; a < 3; a++)
            l->centroid[a] = (float)(acc[j][a] / np);
        l->area = (float)acc[j][3];
        esr_light_update_radiance(l);
    }
}

int esr_lights_settle(struct esr_model *m, const int emits[ESR_MAX_LIGHTS])
{
    struct esr_lights *L = &m->lights;
    if (L->n == 0)
        return ESR_OK;
    const size_t N = esr_grid_voxels(&L->grid);
    size_t undecided = 0;
    for (size_t i = 0; i < N; i++) {
        if (!(L->label[i] & ESR_LIGHT_UNDECIDED))
            continue;
        const int id = ESR_LIGHT_LABEL_ID(L->label[i]) - 1;
        L->label[i] = id >= 0 && id < L->n && emits[id] ? (uint8_t)(L->label[i] & ~ESR_LIGHT_UNDECIDED) : 0;
        undecided++;
    }
    if (undecided == 0) /* the lights are as measured */
        return ESR_OK;
    uint32_t *idx = NULL;
    float *pos = NULL, *nrm = NULL;
    size_t n = 0;
    ESR_TRY(esr_light_surface_points(m, &idx, &pos, &nrm, &n));
    measure(L, esr_grid_voxel_size(esr_model_grid(m, ESR_COMP_SDF), 0), idx, pos, nrm, n);
    free(idx), free(pos), free(nrm);
    return ESR_OK;
}

int esr_lights_find(struct esr_model *m, const struct esr_ray_set *rs)
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
    uint8_t *seen_clearly = calloc(N, 1);
    uint8_t *outer = malloc(n ? n : 1);
    int32_t *comp = malloc(N * sizeof(int32_t));
    uint32_t *queue = malloc(N * sizeof(uint32_t));
    emit = malloc((n ? n : 1) * 3 * sizeof(float));
    long *sizes = NULL;
    int nc = 0;
    int rc = flag && free_mask && seen && seen_clearly && outer && comp && queue && emit
                 ? ESR_OK
                 : ESR_FAIL("lights: out of memory");
    float *hit_sdf = NULL; /* what the cameras' rays first hit: no surface where renders skip */
    if (rc == ESR_OK)
        rc = esr_model_first_hit_sdf(m, &hit_sdf);
    if (rc == ESR_OK)
        rc = esr_light_emission_at(m, pos, n, emit);
    if (rc == ESR_OK)
        rc = esr_free_space_carve(g, hit_sdf, rs->orig3, rs->dir3, rs->n, CARVE_MARGIN, free_mask);
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
        double acc[ESR_MAX_LIGHTS][3]; /* E */
        long emitting_points[ESR_MAX_LIGHTS] = {0};
        memset(acc, 0, sizeof acc);
        for (size_t i = 0; i < n; i++) {
            const int c = comp[idx[i]];
            const int id = c < 0 ? -1 : id_of[c];
            if (id < 0)
                continue;
            L->label[idx[i]] = (uint8_t)(id + 1);
            emitting_points[id]++;
            for (int a = 0; a < 3; a++)
                acc[id][a] += emit[i * 3 + a];
        }
        for (int j = 0; j < kept; j++) { /* E: the mean over the part the field learned */
            struct esr_light *l = &L->light[j];
            const double np = (double)(emitting_points[j] > 0 ? emitting_points[j] : 1);
            for (int a = 0; a < 3; a++) {
                l->field_rgb[a] = (float)(acc[j][a] / np);
                l->scale[a] = 1.0f;
            }
        }
        /* the lights' unseen parts: outer surface points no camera sees (flag reused) */
        memset(flag, 0, N);
        rc = mark_seen(m, hit_sdf, rs, seen, seen_clearly);
        for (size_t i = 0; rc == ESR_OK && i < n; i++)
            if (!seen[idx[i]] && outer[i])
                flag[idx[i]] = 1;
        if (rc == ESR_OK)
            grow_unseen(g, flag, L->label, queue);
        /* the undecided rims: outer points next to a light that only lights-off or clipped
         * pixels see */
        for (size_t i = 0; rc == ESR_OK && i < n; i++)
            flag[idx[i]] = !seen_clearly[idx[i]] && outer[i] && !L->label[idx[i]];
        if (rc == ESR_OK)
            mark_undecided(g, flag, L->label);
    }
    if (rc == ESR_OK && kept > 0)
        measure(L, h, idx, pos, nrm, n);
    free(idx), free(pos), free(nrm), free(emit), free(flag), free(free_mask), free(comp), free(queue);
    free(seen), free(seen_clearly), free(outer), free(hit_sdf);
    free(sizes), free(id_of);
    if (rc != ESR_OK)
        esr_lights_free(L);
    else
        L->n_left_out = left_out;
    return rc;
}
