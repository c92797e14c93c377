/* Lights as objects: finding and calibrating them (see lights.h). */
#include "train/lights.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/brdf.h"
#include "core/colour.h"
#include "core/error.h"
#include "core/order.h"
#include "core/ridge_solve.h"
#include "core/rng.h"
#include "core/vec3.h"
#include "fields/grid.h"
#include "fields/trilerp.h"
#include "model/material_fields.h"
#include "model/trace.h"
#include "train/light_direct.h"
#include "train/lts.h"
#include "volume/first_hit.h"
#include "volume/free_space.h"

/* a surface point is outer when free space touches it this many voxels out along its normal */
#define OUTER_OFFSET 1.5f
/* camera rays stop carving free space this many voxels before their first hit */
#define CARVE_MARGIN 1.0f
/* a component smaller than this share of all emitting points (or points) is noise */
#define LIGHTS_MIN_SHARE 0.005
#define LIGHTS_MIN_POINTS 8
/* material-field evaluations per batch */
#define EVAL_CHUNK 16384
/* calibration: LTS points per call, hemisphere directions per point, area samples per point and
 * light */
#define CALIB_CHUNK 250
#define CALIB_DIRS 128
#define CALIB_LIGHT_SPP 64
/* points whose lights-on linear radiance exceeds this in a channel are clipped in the LDR images
 * (sRGB 0.9) and left out */
#define CALIB_MAX_ON 0.79f
/* camera rays traced per round of the search for calibration points, and rounds at most */
#define CALIB_RAYS 8192
#define CALIB_MAX_ROUNDS 64
/* a calibration point: a ray's strongest sample of at least this weight (a surface) ... */
#define CALIB_SURFACE_WEIGHT 0.3f
/* ... whose emission stays below this share of k (not an emitter, nor its fringe) */
#define CALIB_E_SHARE 0.25f
/* the lights-off correction of a point's base colour, L_off / L^_off, is clamped to
 * [1 / this, this] */
#define CALIB_MAX_CORRECTION 4.0
/* ridge towards scale 1, relative to each light's own normal-equation diagonal */
#define CALIB_RIDGE 1e-3
/* Huber reweighting rounds of the fit (core/ridge_solve.h) */
#define CALIB_ROBUST_ROUNDS 8
_Static_assert(ESR_MAX_LIGHTS <= ESR_RIDGE_MAX, "the calibration solves one unknown per light");

static size_t lattice_index(const struct esr_grid *g, int x, int y, int z)
{
    return ((size_t)z * (size_t)g->ny + (size_t)y) * (size_t)g->nx + (size_t)x;
}

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
                    nb[n++] = lattice_index(g, u, v, w);
            }
    return n;
}

/* Lattice points with a sign change to an axis neighbour: indices and surface positions
 * (projected along the SDF gradient by at most a voxel) and unit normals. */
static int surface_points(const struct esr_model *m, uint32_t **idx_out, float **pos_out,
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
                const size_t i = lattice_index(g, x, y, z);
                const int in = f[i] <= 0.0f;
                const int nb[6][3] = {{x - 1, y, z}, {x + 1, y, z}, {x, y - 1, z},
                                      {x, y + 1, z}, {x, y, z - 1}, {x, y, z + 1}};
                int edge = 0;
                for (int k = 0; k < 6 && !edge; k++) {
                    const int *q = nb[k];
                    if (q[0] < 0 || q[1] < 0 || q[2] < 0 || q[0] >= g->nx || q[1] >= g->ny ||
                        q[2] >= g->nz)
                        continue;
                    edge = (f[lattice_index(g, q[0], q[1], q[2])] <= 0.0f) != in;
                }
                if (!edge)
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
static float point_area(float h, const float *nrm)
{
    const float mx = fmaxf(fabsf(nrm[0]), fmaxf(fabsf(nrm[1]), fabsf(nrm[2])));
    return 0.5f * h * h / fmaxf(mx, 0.577f);
}

/* E at n points, in chunks. */
static int emission_at(const struct esr_model *m, const float *pos3, size_t n, float *emit3)
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

static float max3(const float *v)
{
    return fmaxf(v[0], fmaxf(v[1], v[2]));
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
    ESR_TRY(surface_points(m, &idx, &pos, &nrm, &n));
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
        rc = emission_at(m, pos, n, emit);
    if (rc == ESR_OK)
        rc = esr_free_space_carve(g, esr_model_values(m, ESR_COMP_SDF), orig3, dir3, n_rays,
                                  CARVE_MARGIN, free_mask);
    long emitting = 0;
    for (size_t i = 0; rc == ESR_OK && i < n; i++) {
        float out[3];
        for (int a = 0; a < 3; a++)
            out[a] = pos[i * 3 + a] + OUTER_OFFSET * h * nrm[i * 3 + a];
        outer[i] = (uint8_t)esr_free_space_at(g, free_mask, out);
        if (max3(emit + i * 3) > k && outer[i]) {
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
            acc[id][6] += point_area(h, nrm + i * 3);
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
                acc[id][6] += point_area(h, nrm + i * 3);
            }
        for (int j = 0; j < kept; j++) {
            struct esr_light *l = &L->light[j];
            const double np = (double)(l->points > 0 ? l->points : 1);
            for (int a = 0; a < 3; a++)
                l->centroid[a] = (float)(acc[j][a] / np);
            l->area = (float)acc[j][6];
            l->power = esr_luminance(l->radiance) * (float)M_PI * l->area;
        }
    }
    free(idx), free(pos), free(nrm), free(emit), free(flag), free(free_mask), free(comp), free(queue);
    free(seen), free(outer);
    free(sizes), free(id_of);
    if (rc != ESR_OK)
        esr_lights_free(L);
    return rc;
}

/* Calibration points: the strongest sample (weight >= CALIB_SURFACE_WEIGHT) of random rays,
 * kept when it lies on no light and its E is well below k. */
static int calib_points(const struct esr_model *m, const float *orig3, const float *dir3, size_t n,
                        int want, uint64_t seed, float *pos3, float *dir_out3, int *got)
{
    const float *sdf = esr_model_values(m, ESR_COMP_SDF);
    const float k = m->cfg.emitter_k;
    struct esr_trace t;
    struct esr_material_fields mf;
    ESR_TRY(esr_trace_init(&t, m, CALIB_RAYS, 0));
    int rc = esr_material_fields_init(&mf, m, CALIB_RAYS, ESR_MATERIAL_EMISSION_ONLY);
    float *o = malloc(CALIB_RAYS * 3 * sizeof(float)), *d = malloc(CALIB_RAYS * 3 * sizeof(float));
    float *cand = malloc(CALIB_RAYS * 6 * sizeof(float));
    uint8_t *on = calloc(CALIB_RAYS, 1);
    if (rc == ESR_OK && (!o || !d || !cand || !on))
        rc = ESR_FAIL("lights: out of memory for the calibration rays");
    *got = 0;
    /* rounds of CALIB_RAYS random rays (a fixed stride would alias with the image width) */
    struct esr_rng rng = esr_rng_init(seed, 0x11ad5);
    for (int round = 0; rc == ESR_OK && *got < want && round < CALIB_MAX_ROUNDS; round++) {
        const int nr = CALIB_RAYS;
        for (int i = 0; i < nr; i++) {
            const size_t r = (size_t)(esr_rng_u64(&rng) % n);
            memcpy(o + i * 3, orig3 + r * 3, 3 * sizeof(float));
            memcpy(d + i * 3, dir3 + r * 3, 3 * sizeof(float));
        }
        rc = esr_trace_fwd(&t, m, sdf, o, d, on, nr, seed);
        const struct esr_march *mc = &t.march;
        int nc = 0;
        for (int r = 0; rc == ESR_OK && r < nr; r++) {
            size_t best = 0;
            const float wmax = esr_march_strongest_kept(mc, r, &best);
            if (wmax < CALIB_SURFACE_WEIGHT || esr_lights_id_at(&m->lights, mc->kpos3 + best * 3) >= 0)
                continue;
            memcpy(cand + nc * 6, mc->kpos3 + best * 3, 3 * sizeof(float));
            memcpy(cand + nc * 6 + 3, mc->kdir3 + best * 3, 3 * sizeof(float));
            nc++;
        }
        for (int c = 0; c < nc; c++) /* positions contiguous for the E query */
            memcpy(o + c * 3, cand + c * 6, 3 * sizeof(float));
        if (rc == ESR_OK && nc > 0)
            rc = esr_material_fields_fwd(&mf, m, sdf, o, (size_t)nc);
        for (int c = 0; rc == ESR_OK && c < nc && *got < want; c++) {
            if (max3(mf.emit3 + c * 3) >= CALIB_E_SHARE * k)
                continue;
            memcpy(pos3 + *got * 3, cand + c * 6, 3 * sizeof(float));
            memcpy(dir_out3 + *got * 3, cand + c * 6 + 3, 3 * sizeof(float));
            (*got)++;
        }
    }
    free(o), free(d), free(cand), free(on);
    esr_material_fields_free(&mf);
    esr_trace_free(&t);
    return rc;
}

/* Point p of an LTS call: its normal, camera direction and material; 0 when the camera sees it
 * from behind (nothing to estimate). */
static int point_frame(const struct esr_lts *l, size_t p, struct esr_vec3 *n, struct esr_vec3 *wo,
                       struct esr_material *mat)
{
    *n = esr_v3_at(l->nrm3, p);
    *wo = esr_v3_at(l->wo3, 2 * p); /* the camera direction */
    *mat = esr_material_of_row(l->mf.brdf5 + p * ESR_BRDF_CHANNELS, 1.0f);
    return esr_v3_dot(*n, *wo) > 0.0f;
}

/* Calibration rows, one per point and channel: L_emo - r B ~ sum_K s_K r A_K, both sides times
 * esr_image_error_scale at the point's lights-on radiance, r the lights-off correction of the
 * point's base colour over its median (train/lights.h says why). Kept apart until the medians
 * are known. */
struct calib_rows {
    size_t n, cap;  /* points */
    double *a;      /* [cap * 3 * K] weighted A: point p, channel c at (p * 3 + c) * K */
    double *emo;    /* [cap * 3] weighted L_emo */
    double *b;      /* [cap * 3] weighted B */
    double *r;      /* [cap * 3] L_off / L^_off */
};

/* Adds one LTS call's points as rows: A from esr_lights_direct, B from the hemisphere directions
 * (the other surfaces' emo radiance, and the lights' own reflected part L_emo - E where a
 * direction hits one). */
static void accumulate(const struct esr_model *m, const struct esr_lts *l, size_t P,
                       const float *hit_emit3, const double *Aall, struct calib_rows *rows,
                       double *seen)
{
    const int K = m->lights.n;
    const size_t M = (size_t)l->M;
    for (size_t p = 0; p < P && rows->n < rows->cap; p++) {
        struct esr_vec3 n, wo;
        struct esr_material mat;
        if (!point_frame(l, p, &n, &wo, &mat))
            continue;
        /* a point the on images show clipped says only "at least this bright" */
        const float *L_on = l->pf.lin3 + (p * 4 + 1) * 3;
        if (fmaxf(L_on[0], fmaxf(L_on[1], L_on[2])) > CALIB_MAX_ON)
            continue;
        const double *A = Aall + p * 2 * ESR_MAX_LIGHTS * 3; /* the camera direction's */
        double B[3] = {0, 0, 0};
        for (size_t j = 0; j < M; j++) {
            const size_t i = p * M + j;
            if (l->hit_row[i] < 0)
                continue;
            float R[3];
            const float *wi = l->wi3 + i * 3;
            esr_brdf_eval(&mat, n, wo, esr_v3(wi[0], wi[1], wi[2]), R);
            const int on_light = esr_lights_id_at(&m->lights, l->hit_pos3 + i * 3) >= 0;
            for (int c = 0; c < 3; c++) {
                const double w = (double)R[c] * l->wt[i], li = l->li_emo3[i * 3 + c];
                B[c] += (on_light ? li - hit_emit3[i * 3 + c] : li) * w;
            }
        }
        /* L_emo at the point for the camera direction: on row minus off row */
        const float *lin = l->pf.lin3;
        for (int c = 0; c < 3; c++) {
            const size_t row = rows->n * 3 + (size_t)c;
            const double w = esr_image_error_scale(L_on[c]); /* row weight: judged as images */
            const double off = lin[(p * 4) * 3 + c], hat_off = l->hat3[(p * 2) * 6 + c];
            rows->emo[row] = w * ((double)lin[(p * 4 + 1) * 3 + c] - off);
            rows->b[row] = w * B[c];
            rows->r[row] = hat_off > 1e-6 ? fmin(fmax(off / hat_off, 1.0 / CALIB_MAX_CORRECTION),
                                                 CALIB_MAX_CORRECTION)
                                          : 1.0;
            for (int a = 0; a < K; a++)
                rows->a[row * (size_t)K + (size_t)a] = w * A[a * 3 + c];
        }
        rows->n++;
        for (int a = 0; a < K; a++)
            seen[a] += A[a * 3] + A[a * 3 + 1] + A[a * 3 + 2] > 0.0;
    }
}

int esr_lights_calibrate(struct esr_model *m, const float *orig3, const float *dir3, size_t n,
                         int want, uint64_t seed)
{
    const int K = m->lights.n;
    if (K == 0 || want <= 0)
        return ESR_OK;
    if (n == 0)
        return ESR_FAIL("lights: no lights-off rays to calibrate the lights' strength with");
    struct esr_light keep[ESR_MAX_LIGHTS]; /* put back if the calibration fails */
    memcpy(keep, m->lights.light, sizeof keep);
    /* solved from the field itself: the light samples below carry E at scale 1 */
    for (int a = 0; a < K; a++)
        for (int c = 0; c < 3; c++)
            m->lights.light[a].scale[c] = 1.0f;
    struct esr_light_samples ls[ESR_MAX_LIGHTS];
    memset(ls, 0, sizeof ls);
    double *Abuf = malloc((size_t)CALIB_CHUNK * 2 * ESR_MAX_LIGHTS * 3 * sizeof(double));
    float *pos = malloc((size_t)want * 3 * sizeof(float)), *dir = malloc((size_t)want * 3 * sizeof(float));
    struct calib_rows rows = {0, (size_t)want, malloc((size_t)want * 3 * K * sizeof(double)),
                              malloc((size_t)want * 3 * sizeof(double)),
                              malloc((size_t)want * 3 * sizeof(double)),
                              malloc((size_t)want * 3 * sizeof(double))};
    double *ca = malloc((size_t)want * K * sizeof(double)), *cy = malloc((size_t)want * sizeof(double));
    double seen[ESR_MAX_LIGHTS] = {0};
    int got = 0;
    int rc = pos && dir && rows.a && rows.emo && rows.b && rows.r && ca && cy && Abuf
                 ? ESR_OK
                 : ESR_FAIL("lights: out of memory for the calibration");
    for (int a = 0; rc == ESR_OK && a < K; a++)
        rc = esr_light_samples_get(m, a, &ls[a]);
    if (rc == ESR_OK)
        rc = calib_points(m, orig3, dir3, n, want, seed, pos, dir, &got);
    /* the LTS machinery at these points: its own sizes, first hit; restored below */
    const struct esr_train_config keep_cfg = m->cfg;
    const long keep_step = m->step;
    m->cfg.lts_points = CALIB_CHUNK;
    m->cfg.lts_dirs = CALIB_DIRS;
    m->cfg.lts_estimator = ESR_LTS_FIRST_HIT;
    m->step = 1; /* off the normal SDF's refresh period: computed once */
    struct esr_lts l;
    memset(&l, 0, sizeof l);
    if (rc == ESR_OK)
        rc = esr_lts_init(&l, m);
    struct esr_material_fields mf;
    memset(&mf, 0, sizeof mf);
    if (rc == ESR_OK)
        rc = esr_material_fields_init(&mf, m, (size_t)CALIB_CHUNK * CALIB_DIRS,
                                      ESR_MATERIAL_EMISSION_ONLY);
    const float *sdf = esr_model_values(m, ESR_COMP_SDF);
    struct esr_light_shadows shadows;
    memset(&shadows, 0, sizeof shadows);
    if (rc == ESR_OK)
        rc = esr_light_shadows_init(&shadows, m);
    for (int p0 = 0; rc == ESR_OK && p0 < got; p0 += CALIB_CHUNK) {
        const size_t P = (size_t)(got - p0 < CALIB_CHUNK ? got - p0 : CALIB_CHUNK);
        struct esr_march pts; /* the points as a kept list: the LTS takes each once */
        memset(&pts, 0, sizeof pts);
        pts.n_kept = P;
        pts.kpos3 = pos + (size_t)p0 * 3;
        pts.kdir3 = dir + (size_t)p0 * 3;
        struct esr_lts_stats st;
        rc = esr_lts_run(&l, m, sdf, NULL, NULL, &pts, NULL, seed + (uint64_t)p0, &st);
        if (rc == ESR_OK)
            rc = esr_material_fields_fwd(&mf, m, sdf, l.hit_pos3, P * CALIB_DIRS);
        /* A_K: the samples carry the field's E (scales 1), the scale is what is solved for */
        const struct esr_direct_points dp = {P, l.pos3, l.nrm3, l.mf.brdf5, l.wo3, 2};
        if (rc == ESR_OK)
            rc = esr_lights_direct(&shadows, ls, K, NULL, &dp, CALIB_LIGHT_SPP,
                                   seed ^ (uint64_t)(p0 + 1) * 0x9e3779b97f4a7c15ULL, Abuf, NULL);
        if (rc == ESR_OK)
            accumulate(m, &l, P, mf.emit3, Abuf, &rows, seen);
    }
    esr_material_fields_free(&mf);
    esr_lts_free(&l);
    esr_light_shadows_free(&shadows);
    m->cfg = keep_cfg;
    m->step = keep_step;
    int fit[ESR_MAX_LIGHTS];
    const int nf = esr_lights_fitted(&m->lights, fit);
    for (int c = 0; rc == ESR_OK && c < 3; c++) {
        for (size_t p = 0; p < rows.n; p++) /* the median correction (cy as scratch) */
            cy[p] = rows.r[p * 3 + (size_t)c];
        const double median = rows.n ? esr_median_doubles(cy, rows.n) : 1.0;
        for (size_t p = 0; p < rows.n; p++) { /* channel c's rows of the fitted lights */
            const size_t row = p * 3 + (size_t)c;
            const double r = rows.r[row] / median;
            cy[p] = rows.emo[row] - r * rows.b[row];
            for (int f = 0; f < nf; f++)
                ca[p * (size_t)nf + (size_t)f] = r * rows.a[row * (size_t)K + (size_t)fit[f]];
        }
        double s[ESR_MAX_LIGHTS];
        if (esr_ridge_fit_robust(nf, rows.n, ca, cy, CALIB_RIDGE, CALIB_ROBUST_ROUNDS, s) != 0)
            rc = ESR_FAIL("lights: out of memory for the calibration");
        for (int f = 0; rc == ESR_OK && f < nf; f++)
            m->lights.light[fit[f]].scale[c] = (float)s[f];
        if (rc == ESR_OK)
            esr_lights_share_scale(&m->lights, c);
    }
    for (int a = 0; rc == ESR_OK && a < K; a++) {
        struct esr_light *lt = &m->lights.light[a];
        for (int c = 0; c < 3; c++)
            lt->radiance[c] = lt->scale[c] * lt->field_rgb[c];
        lt->power = esr_luminance(lt->radiance) * (float)M_PI * lt->area;
        lt->calib_points = (float)seen[a];
    }
    for (int a = 0; a < K; a++)
        esr_light_samples_free(&ls[a]);
    free(pos), free(dir), free(rows.a), free(rows.emo), free(rows.b), free(rows.r), free(ca), free(cy);
    free(Abuf);
    if (rc != ESR_OK)
        memcpy(m->lights.light, keep, sizeof keep);
    return rc;
}

static int is_fitted(const struct esr_lights *L, int a, double total_area)
{
    return L->light[a].area >= ESR_LIGHTS_SMALL_SHARE * total_area;
}

static double lights_area(const struct esr_lights *L)
{
    double total = 0.0;
    for (int a = 0; a < L->n; a++)
        total += L->light[a].area;
    return total;
}

int esr_lights_fitted(const struct esr_lights *L, int *fit)
{
    const double total = lights_area(L);
    int nf = 0;
    for (int a = 0; a < L->n; a++)
        if (is_fitted(L, a, total))
            fit[nf++] = a;
    return nf;
}

int esr_light_strength_fitted(const struct esr_lights *L, int id)
{
    return id >= 0 && id < L->n && is_fitted(L, id, lights_area(L));
}

void esr_lights_share_scale(struct esr_lights *L, int c)
{
    const double total = lights_area(L);
    double mean = 0.0, area = 0.0;
    for (int a = 0; a < L->n; a++)
        if (is_fitted(L, a, total)) {
            mean += (double)L->light[a].scale[c] * L->light[a].area;
            area += L->light[a].area;
        }
    for (int a = 0; a < L->n; a++)
        if (!is_fitted(L, a, total))
            L->light[a].scale[c] = (float)(area > 0.0 ? mean / area : 1.0);
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
    memset(out, 0, sizeof(*out));
    const struct esr_lights *L = &m->lights;
    if (id < 0 || id >= L->n)
        return ESR_FAIL("lights: no light %d (the model has %d)", id, L->n);
    uint32_t *idx = NULL;
    float *pos = NULL, *nrm = NULL;
    size_t n = 0;
    ESR_TRY(surface_points(m, &idx, &pos, &nrm, &n));
    size_t k = 0;
    uint8_t *unseen = malloc(n ? n : 1);
    for (size_t i = 0; unseen && i < n; i++) /* the light's points, compacted in place */
        if (ESR_LIGHT_LABEL_ID(L->label[idx[i]]) == id + 1) {
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
        rc = emission_at(m, pos, k, out->emit3);
    const float h = esr_grid_voxel_size(esr_model_grid(m, ESR_COMP_SDF), 0);
    for (size_t i = 0; rc == ESR_OK && i < k; i++) {
        if (unseen[i]) /* its field learned only the light it casts, which clipped images understate */
            memcpy(out->emit3 + i * 3, L->light[id].field_rgb, 3 * sizeof(float));
        for (int c = 0; c < 3; c++)
            out->emit3[i * 3 + c] *= L->light[id].scale[c];
        out->area[i] = point_area(h, nrm + i * 3);
        out->total_area += out->area[i];
        for (int c = 0; c < 3; c++)
            out->max_emit = fmaxf(out->max_emit, out->emit3[i * 3 + c]);
    }
    free(unseen);
    if (rc != ESR_OK)
        esr_light_samples_free(out);
    return rc;
}
