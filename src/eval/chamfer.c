#include "eval/chamfer.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/rng.h"
#include "core/vec3.h"

static struct esr_vec3 mesh_vertex(const struct esr_mesh *m, uint32_t i)
{
    return esr_v3(m->pos[i * 3], m->pos[i * 3 + 1], m->pos[i * 3 + 2]);
}

int esr_mesh_sample_surface(const struct esr_mesh *m, size_t n, uint64_t seed, float *pts)
{
    if (!m->n_triangles)
        return ESR_FAIL("mesh has no triangles to sample");
    double *cdf = (double *)malloc(m->n_triangles * sizeof(double));
    if (!cdf)
        return ESR_FAIL("out of memory for %zu triangle areas", m->n_triangles);
    double total = 0.0;
    for (size_t t = 0; t < m->n_triangles; t++) {
        const uint32_t *v = m->tri + t * 3;
        struct esr_vec3 a = mesh_vertex(m, v[0]);
        struct esr_vec3 e1 = esr_v3_sub(mesh_vertex(m, v[1]), a), e2 = esr_v3_sub(mesh_vertex(m, v[2]), a);
        total += 0.5 * esr_v3_length(esr_v3_cross(e1, e2));
        cdf[t] = total;
    }
    if (!(total > 0.0)) {
        free(cdf);
        return ESR_FAIL("mesh has zero surface area");
    }
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++) {
        struct esr_rng rng = esr_rng_init(seed, i);
        double target = esr_rng_float(&rng) * total;
        size_t lo = 0, hi = m->n_triangles - 1; /* first triangle whose cdf exceeds target */
        while (lo < hi) {
            size_t mid = (lo + hi) / 2;
            if (cdf[mid] > target)
                hi = mid;
            else
                lo = mid + 1;
        }
        const uint32_t *v = m->tri + lo * 3;
        float u = esr_rng_float(&rng), w = esr_rng_float(&rng);
        if (u + w > 1.0f) { /* fold the square onto the triangle */
            u = 1.0f - u;
            w = 1.0f - w;
        }
        struct esr_vec3 a = mesh_vertex(m, v[0]);
        struct esr_vec3 p = esr_v3_add(a, esr_v3_add(esr_v3_scale(esr_v3_sub(mesh_vertex(m, v[1]), a), u),
                                                      esr_v3_scale(esr_v3_sub(mesh_vertex(m, v[2]), a), w)));
        pts[i * 3] = p.x;
        pts[i * 3 + 1] = p.y;
        pts[i * 3 + 2] = p.z;
    }
    free(cdf);
    return ESR_OK;
}

/* Uniform grid over a point set, points sorted by cell (counting sort), for exact
 * nearest-neighbour queries by growing shells of cells. */
struct point_grid {
    float lo[3];
    float cell;
    int dim[3];
    size_t *start; /* [cells + 1] */
    float *pts;    /* sorted copy, [n*3] */
};

static int grid_cell_index(const struct point_grid *g, const float *p, int axis)
{
    int c = (int)((p[axis] - g->lo[axis]) / g->cell);
    return c < 0 ? 0 : c >= g->dim[axis] ? g->dim[axis] - 1 : c;
}

static size_t grid_flat(const struct point_grid *g, int x, int y, int z)
{
    return ((size_t)z * (size_t)g->dim[1] + (size_t)y) * (size_t)g->dim[0] + (size_t)x;
}

static int point_grid_build(struct point_grid *g, const float *b, size_t nb)
{
    float hi[3] = {-FLT_MAX, -FLT_MAX, -FLT_MAX};
    for (int k = 0; k < 3; k++)
        g->lo[k] = FLT_MAX;
    for (size_t i = 0; i < nb; i++)
        for (int k = 0; k < 3; k++) {
            g->lo[k] = fminf(g->lo[k], b[i * 3 + k]);
            hi[k] = fmaxf(hi[k], b[i * 3 + k]);
        }
    float extent = fmaxf(hi[0] - g->lo[0], fmaxf(hi[1] - g->lo[1], hi[2] - g->lo[2]));
    /* about 4 points per occupied cell for surface-like sets: cells ~ n^(2/3)/4 per face */
    g->cell = fmaxf(extent / fmaxf(1.0f, sqrtf((float)nb) / 2.0f), 1e-6f);
    size_t cells = 1;
    for (int k = 0; k < 3; k++) {
        g->dim[k] = (int)((hi[k] - g->lo[k]) / g->cell) + 1;
        cells *= (size_t)g->dim[k];
    }
    g->start = (size_t *)calloc(cells + 1, sizeof(size_t));
    g->pts = (float *)malloc(nb * 3 * sizeof(float));
    size_t *cell_of = (size_t *)malloc(nb * sizeof(size_t));
    if (!g->start || !g->pts || !cell_of) {
        free(cell_of);
        return ESR_FAIL("out of memory for a nearest-neighbour grid of %zu cells", cells);
    }
    for (size_t i = 0; i < nb; i++) {
        const float *p = b + i * 3;
        cell_of[i] = grid_flat(g, grid_cell_index(g, p, 0), grid_cell_index(g, p, 1), grid_cell_index(g, p, 2));
        g->start[cell_of[i] + 1]++;
    }
    for (size_t c = 0; c < cells; c++)
        g->start[c + 1] += g->start[c];
    size_t *fill = (size_t *)malloc(cells * sizeof(size_t));
    if (!fill) {
        free(cell_of);
        return ESR_FAIL("out of memory for a nearest-neighbour grid");
    }
    memcpy(fill, g->start, cells * sizeof(size_t));
    for (size_t i = 0; i < nb; i++)
        memcpy(g->pts + fill[cell_of[i]]++ * 3, b + i * 3, 3 * sizeof(float));
    free(fill);
    free(cell_of);
    return ESR_OK;
}

static void point_grid_free(struct point_grid *g)
{
    free(g->start);
    free(g->pts);
}

/* Exact nearest squared distance: scan shells of radius r cells until the best distance found
 * is within the distance r*cell that the unscanned cells are guaranteed to lie beyond. */
static float point_grid_nearest_sq(const struct point_grid *g, const float *q)
{
    int c[3] = {grid_cell_index(g, q, 0), grid_cell_index(g, q, 1), grid_cell_index(g, q, 2)};
    int max_r = g->dim[0] + g->dim[1] + g->dim[2];
    float best = FLT_MAX;
    for (int r = 0; r <= max_r; r++) {
        for (int z = c[2] - r; z <= c[2] + r; z++) {
            if (z < 0 || z >= g->dim[2])
                continue;
            for (int y = c[1] - r; y <= c[1] + r; y++) {
                if (y < 0 || y >= g->dim[1])
                    continue;
                int on_shell_yz = abs(z - c[2]) == r || abs(y - c[1]) == r;
                for (int x = c[0] - r; x <= c[0] + r; x += (on_shell_yz || r == 0) ? 1 : 2 * r) {
                    if (x < 0 || x >= g->dim[0])
                        continue;
                    size_t cell = grid_flat(g, x, y, z);
                    for (size_t i = g->start[cell]; i < g->start[cell + 1]; i++) {
                        const float *p = g->pts + i * 3;
                        float dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
                        best = fminf(best, dx * dx + dy * dy + dz * dz);
                    }
                }
            }
        }
        float reach = (float)r * g->cell; /* every unscanned point is farther than this */
        if (best <= reach * reach)
            break;
    }
    return best;
}

int esr_mean_nearest_distance(const float *a, size_t na, const float *b, size_t nb, double *out)
{
    if (!na || !nb)
        return ESR_FAIL("nearest-distance query on an empty point set (%zu and %zu points)", na, nb);
    struct point_grid g = {0};
    if (point_grid_build(&g, b, nb) != ESR_OK) {
        point_grid_free(&g);
        return ESR_ERR;
    }
    double sum = 0.0;
#pragma omp parallel for reduction(+ : sum) schedule(static)
    for (size_t i = 0; i < na; i++)
        sum += sqrt((double)point_grid_nearest_sq(&g, a + i * 3));
    point_grid_free(&g);
    *out = sum / (double)na;
    return ESR_OK;
}

int esr_chamfer_meshes(const struct esr_mesh *pred, const struct esr_mesh *gt, size_t n, uint64_t seed,
                       struct esr_chamfer_result *out)
{
    float *pa = (float *)malloc(n * 3 * sizeof(float));
    float *pb = (float *)malloc(n * 3 * sizeof(float));
    int rc = (pa && pb) ? ESR_OK : ESR_FAIL("out of memory for %zu surface samples", n);
    if (rc == ESR_OK)
        rc = esr_mesh_sample_surface(pred, n, seed, pa);
    if (rc == ESR_OK)
        rc = esr_mesh_sample_surface(gt, n, seed + 1, pb);
    if (rc == ESR_OK)
        rc = esr_mean_nearest_distance(pa, n, pb, n, &out->accuracy);
    if (rc == ESR_OK)
        rc = esr_mean_nearest_distance(pb, n, pa, n, &out->completeness);
    if (rc == ESR_OK) {
        out->chamfer = 0.5 * (out->accuracy + out->completeness);
        out->n_samples = n;
    }
    free(pa);
    free(pb);
    return rc;
}
