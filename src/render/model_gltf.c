/* The trained scene as a relightable glTF asset (see model_gltf.h). */
#include "render/model_gltf.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/colour.h"
#include "core/error.h"
#include "io/glb.h"
#include "model/material_fields.h"
#include "render/model_mesh.h"

#define CHUNK 16384

/* Base colour per vertex (into mesh->colour) and the mean roughness and metallic. */
static int vertex_materials(const struct esr_model *m, struct esr_mesh *mesh, float *rough,
                            float *metal)
{
    struct esr_material_fields mf;
    ESR_TRY(esr_material_fields_init(&mf, m, CHUNK, 0));
    const float *sdf = esr_model_values(m, ESR_COMP_SDF);
    double r = 0.0, mt = 0.0;
    int rc = ESR_OK;
    for (size_t i0 = 0; i0 < mesh->n_vertices && rc == ESR_OK; i0 += CHUNK) {
        const size_t n = mesh->n_vertices - i0 < CHUNK ? mesh->n_vertices - i0 : CHUNK;
        rc = esr_material_fields_fwd(&mf, m, sdf, mesh->pos + i0 * 3, n);
        for (size_t i = 0; rc == ESR_OK && i < n; i++) {
            const float *b = mf.brdf5 + i * ESR_BRDF_CHANNELS;
            for (int c = 0; c < 3; c++) /* glTF colours lie in [0, 1]; a colour balance
                                           (model/lights.h) can lift a base colour past 1 */
                mesh->colour[(i0 + i) * 3 + c] = esr_clamp01(b[c]);
            r += b[3];
            mt += b[4];
        }
    }
    esr_material_fields_free(&mf);
    *rough = (float)(r / (double)(mesh->n_vertices ? mesh->n_vertices : 1));
    *metal = (float)(mt / (double)(mesh->n_vertices ? mesh->n_vertices : 1));
    return rc;
}

int esr_model_gltf_write(const struct esr_model *m, int res, const char *path, int *light_nodes)
{
    *light_nodes = 0;
    const int has_fields = esr_model_has(m, ESR_COMP_BRDF_MLP);
    struct esr_mesh mesh;
    ESR_TRY(esr_model_mesh(m, res, !has_fields, &mesh));
    float rough = 0.5f, metal = 0.0f;
    int rc = ESR_OK;
    if (has_fields) {
        rc = esr_mesh_alloc_colours(&mesh);
        if (rc == ESR_OK)
            rc = vertex_materials(m, &mesh, &rough, &metal);
    }
    const int n_lights = m->lights.n;
    /* triangles by light: part 0 the surface, part k + 1 light k */
    uint32_t *tri[ESR_MAX_LIGHTS + 1];
    size_t cnt[ESR_MAX_LIGHTS + 1];
    memset(tri, 0, sizeof tri);
    memset(cnt, 0, sizeof cnt);
    for (int k = 0; rc == ESR_OK && k <= n_lights; k++)
        if (!(tri[k] = malloc((mesh.n_triangles ? mesh.n_triangles : 1) * 3 * sizeof(uint32_t))))
            rc = ESR_FAIL("gltf: out of memory for %zu triangles", mesh.n_triangles);
    for (size_t t = 0; rc == ESR_OK && t < mesh.n_triangles; t++) {
        float c[3] = {0, 0, 0};
        for (int v = 0; v < 3; v++)
            for (int a = 0; a < 3; a++)
                c[a] += mesh.pos[(size_t)mesh.tri[t * 3 + v] * 3 + a] / 3.0f;
        const int part = esr_lights_id_at(&m->lights, c) + 1;
        memcpy(tri[part] + cnt[part] * 3, mesh.tri + t * 3, 3 * sizeof(uint32_t));
        cnt[part]++;
    }
    struct esr_glb_part parts[ESR_MAX_LIGHTS + 1];
    char names[ESR_MAX_LIGHTS + 1][32];
    for (int k = 0; rc == ESR_OK && k <= n_lights; k++) {
        struct esr_glb_part *p = &parts[k];
        memset(p, 0, sizeof *p);
        if (k == 0)
            snprintf(names[k], sizeof names[k], "surface");
        else
            snprintf(names[k], sizeof names[k], "light_%d", k - 1);
        p->name = names[k];
        p->tri = tri[k];
        p->n_triangles = cnt[k];
        p->base[0] = p->base[1] = p->base[2] = 1.0f; /* x COLOR_0, the base colour */
        p->metallic = metal;
        p->roughness = rough;
        p->emissive_strength = 1.0f;
        if (k > 0) {
            const float *L = m->lights.light[k - 1].radiance;
            const float mx = fmaxf(L[0], fmaxf(L[1], L[2]));
            if (mx > 0.0f) {
                for (int c = 0; c < 3; c++)
                    p->emissive[c] = L[c] / mx;
                p->emissive_strength = mx;
            }
        }
    }
    /* glTF is +Y up: the scene's +Z (up) becomes +Y, its +Y becomes -Z */
    for (size_t i = 0; rc == ESR_OK && i < mesh.n_vertices; i++) {
        float *vs[2] = {mesh.pos + i * 3, mesh.normal + i * 3};
        for (int k = 0; k < 2; k++) {
            const float y = vs[k][1], z = vs[k][2];
            vs[k][1] = z;
            vs[k][2] = -y;
        }
    }
    if (rc == ESR_OK)
        rc = esr_glb_write(path, &mesh, parts, n_lights + 1);
    for (int k = 1; rc == ESR_OK && k <= n_lights; k++) /* a part without triangles has no node */
        *light_nodes |= (cnt[k] > 0) << (k - 1);
    for (int k = 0; k <= n_lights; k++)
        free(tri[k]);
    esr_mesh_free(&mesh);
    return rc;
}
