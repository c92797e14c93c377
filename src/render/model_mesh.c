/* Mesh extraction from a model's SDF, with colours rendered along the vertex normals. */
#include "render/model_mesh.h"

#include <stdlib.h>
#include <string.h>

#include "core/colour.h"
#include "core/error.h"
#include "fields/sdf.h"
#include "model/render_sdf.h"
#include "volume/marching_cubes.h"

/* The SDF lattice as renders show it (no surface where they skip space: model/render_sdf.h)
 * resampled to res^3 over the same box (res = 0: the model's own lattice). */
static int sdf_lattice(const struct esr_model *m, int res, struct esr_grid *g, float **data)
{
    const struct esr_grid *src;
    const float *raw;
    *data = NULL;
    ESR_TRY(esr_model_sdf_grid(m, &src, &raw));
    if (res != 0 && (res < ESR_MODEL_MESH_RES_MIN || res > ESR_MODEL_MESH_RES_MAX))
        return ESR_FAIL("mesh resolution must be %d..%d (or 0 = the model's %dx%dx%d), got %d",
                        ESR_MODEL_MESH_RES_MIN, ESR_MODEL_MESH_RES_MAX, src->nx, src->ny, src->nz, res);
    float *seen;
    ESR_TRY(esr_model_first_hit_sdf(m, &seen));
    if (res == 0) {
        *g = *src;
        *data = seen;
        return ESR_OK;
    }
    int rc = esr_grid_init(g, 1, res, res, res, src->bmin, src->bmax);
    if (rc == ESR_OK) {
        *data = malloc(esr_grid_count(g) * sizeof **data);
        rc = *data ? esr_grid_resample(src, seen, g, *data)
                   : ESR_FAIL("out of memory for a %dx%dx%d SDF grid", g->nx, g->ny, g->nz);
    }
    free(seen);
    return rc;
}

/* Off-lighting linear radiance along each vertex normal (see model_mesh.h). */
static int vertex_colours(const struct esr_model *m, struct esr_mesh *mesh)
{
    const struct esr_grid *g;
    const float *unused;
    ESR_TRY(esr_model_sdf_grid(m, &g, &unused));
    float offset = 3.0f * esr_grid_voxel_size(g, 0);
    size_t n = mesh->n_vertices;
    ESR_TRY(esr_mesh_alloc_colours(mesh));
    if (n == 0)
        return ESR_OK;
    float *origins = malloc(n * 3 * sizeof *origins), *dirs = malloc(n * 3 * sizeof *dirs);
    if (!origins || !dirs) {
        free(origins);
        free(dirs);
        return ESR_FAIL("out of memory for %zu vertex rays", n);
    }
#pragma omp parallel for schedule(static)
    for (long long i = 0; i < (long long)n; i++) {
        for (int a = 0; a < 3; a++) {
            float nrm = mesh->normal[3 * i + a];
            origins[3 * i + a] = mesh->pos[3 * i + a] + offset * nrm;
            dirs[3 * i + a] = -nrm;
        }
    }
    struct esr_render_out out = {.linear = mesh->colour};
    int status = esr_model_render_rays(m, origins, dirs, n, 0, &out);
    for (size_t i = 0; status == ESR_OK && i < n * 3; i++)
        mesh->colour[i] = esr_clamp01(mesh->colour[i]);
    free(origins);
    free(dirs);
    return status;
}

int esr_model_mesh(const struct esr_model *m, int res, int colours, struct esr_mesh *out)
{
    memset(out, 0, sizeof *out);
    struct esr_grid g;
    float *sdf;
    int status = sdf_lattice(m, res, &g, &sdf);
    if (status == ESR_OK)
        status = esr_marching_cubes(&g, sdf, 0.0f, out);
    free(sdf);
    if (status == ESR_OK && colours)
        status = vertex_colours(m, out);
    if (status != ESR_OK)
        esr_mesh_free(out);
    return status;
}
