/* Which surface the training views see (see seen.h).
 *
 * Why an area and not a count of rays: counted as seen by any single ray's hit, a 400 px capture
 * of the default scene, with 16x the rays of the 100 px one, found 235 of the lampshade's
 * underside's lattice points seen (rays grazing the model's rough rim; no camera sees that
 * side), the light lost them, and its strength came out 1.48x the 100 px one's. Each ray's hit
 * stands for the surface its pixel covers, so the sum is the same for any image size. */
#include "train/lights/seen.h"

#include <math.h>
#include <stdlib.h>

#include "core/error.h"
#include "fields/trilerp.h"
#include "volume/first_hit.h"

/* rays traced per batch */
#define SEEN_BATCH 65536

float esr_seen_footprint(const struct esr_ray_set *rs, size_t r, float t)
{
    float best = INFINITY;
    const float *o = rs->orig3 + r * 3, *d = rs->dir3 + r * 3;
    for (int s = 0; s < 2; s++) {
        if ((s == 0 && r == 0) || (s == 1 && r + 1 >= rs->n))
            continue;
        const size_t q = s == 0 ? r - 1 : r + 1;
        const float *oq = rs->orig3 + q * 3, *dq = rs->dir3 + q * 3;
        float d2 = 0.0f;
        for (int a = 0; a < 3; a++) {
            const float v = oq[a] - o[a] + t * (dq[a] - d[a]);
            d2 += v * v;
        }
        best = fminf(best, d2);
    }
    return isfinite(best) ? sqrtf(best) : 0.0f;
}

int esr_seen_area(const struct esr_grid *g, const float *sdf, const struct esr_ray_set *rs,
                  int (*clearly)(const struct esr_ray_set *rs, size_t r), float *area,
                  float *area_clearly)
{
    float *t = malloc(SEEN_BATCH * sizeof(float)), *hit = malloc(SEEN_BATCH * 3 * sizeof(float));
    int rc = t && hit ? ESR_OK : ESR_FAIL("lights: out of memory for the cameras' first hits");
    struct esr_first_hit_params fp;
    esr_first_hit_params_init(&fp, g);
    fp.refine_iters = 4; /* a lattice point is all the precision asked */
    for (size_t r0 = 0; rc == ESR_OK && r0 < rs->n; r0 += SEEN_BATCH) {
        const size_t nb = rs->n - r0 < SEEN_BATCH ? rs->n - r0 : SEEN_BATCH;
        const struct esr_first_hit_rays fr = {rs->orig3 + r0 * 3, rs->dir3 + r0 * 3, NULL, NULL, nb};
        const struct esr_first_hit_out fo = {t, NULL, hit, NULL};
        rc = esr_first_hit(g, sdf, &fp, &fr, &fo);
        for (size_t r = 0; rc == ESR_OK && r < nb; r++) { /* in ray order: the sums are reproducible */
            if (!isfinite(t[r]))
                continue;
            const float w = esr_seen_footprint(rs, r0 + r, t[r]);
            const size_t at = esr_trilerp_nearest(g, hit + r * 3); /* the march is clipped to the box */
            area[at] += w * w;
            if (area_clearly && clearly(rs, r0 + r))
                area_clearly[at] += w * w;
        }
    }
    free(t), free(hit);
    return rc;
}

void esr_seen_marks(const struct esr_grid *g, const float *area, float need, uint8_t *seen)
{
    const int nx = g->nx, ny = g->ny, nz = g->nz;
#pragma omp parallel for schedule(static)
    for (int z = 0; z < nz; z++)
        for (int y = 0; y < ny; y++)
            for (int x = 0; x < nx; x++) {
                double sum = 0.0;
                for (int c = z > 0 ? z - 1 : 0; c <= z + 1 && c < nz; c++)
                    for (int b = y > 0 ? y - 1 : 0; b <= y + 1 && b < ny; b++)
                        for (int a = x > 0 ? x - 1 : 0; a <= x + 1 && a < nx; a++)
                            sum += area[esr_grid_index(g, a, b, c)];
                seen[esr_grid_index(g, x, y, z)] = need > 0.0f ? sum >= need : sum > 0.0;
            }
}
