#include "eval/chamfer.h"

#include <math.h>
#include <stdlib.h>

#include "core/error.h"
#include "core/rng.h"
#include "core/vec3.h"
#include "eval/kdtree.h"

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
        total += esr_mesh_triangle_area(m, t);
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

int esr_mean_nearest_distance(const float *a, size_t na, const float *b, size_t nb, double *out)
{
    if (!na || !nb)
        return ESR_FAIL("nearest-distance query on an empty point set (%zu and %zu points)", na, nb);
    struct esr_kdtree tree;
    ESR_TRY(esr_kdtree_build(&tree, b, nb));
    float *dist = malloc(na * sizeof(float));
    if (!dist) {
        esr_kdtree_free(&tree);
        return ESR_FAIL("out of memory for %zu distances", na);
    }
#pragma omp parallel for schedule(dynamic, 1024)
    for (size_t i = 0; i < na; i++)
        dist[i] = sqrtf(esr_kdtree_nearest_sq(&tree, a + i * 3));
    double sum = 0.0; /* summed in order: the same result for any thread count */
    for (size_t i = 0; i < na; i++)
        sum += dist[i];
    free(dist);
    esr_kdtree_free(&tree);
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
