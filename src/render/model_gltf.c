/* The trained scene as a relightable glTF asset (see model_gltf.h). */
#include "render/model_gltf.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/colour.h"
#include "core/error.h"
#include "core/kmeans.h"
#include "io/glb.h"
#include "model/material_fields.h"
#include "render/model_mesh.h"

#define CHUNK 16384

/* Base colour per vertex (into mesh->colour), roughness and metallic per vertex (rough[],
 * metal[]). */
static int vertex_materials(const struct esr_model *m, struct esr_mesh *mesh, float *rough,
                            float *metal)
{
    struct esr_material_fields mf;
    ESR_TRY(esr_material_fields_init(&mf, m, CHUNK, 0));
    const float *sdf = esr_model_values(m, ESR_COMP_SDF);
    int rc = ESR_OK;
    for (size_t i0 = 0; i0 < mesh->n_vertices && rc == ESR_OK; i0 += CHUNK) {
        const size_t n = mesh->n_vertices - i0 < CHUNK ? mesh->n_vertices - i0 : CHUNK;
        rc = esr_material_fields_fwd(&mf, m, sdf, mesh->pos + i0 * 3, n);
        for (size_t i = 0; rc == ESR_OK && i < n; i++) {
            const float *b = mf.brdf5 + i * ESR_BRDF_CHANNELS;
            for (int c = 0; c < 3; c++) /* glTF colours lie in [0, 1]; a colour balance
                                           (model/lights.h) can lift a base colour past 1 */
                mesh->colour[(i0 + i) * 3 + c] = esr_clamp01(b[c]);
            rough[i0 + i] = esr_clamp01(b[3]);
            metal[i0 + i] = esr_clamp01(b[4]);
        }
    }
    esr_material_fields_free(&mf);
    return rc;
}

/* The triangles' materials: rm[t * 2] roughness, rm[t * 2 + 1] metallic, the mean of their
 * vertices'. */
static void triangle_materials(const struct esr_mesh *mesh, const float *rough,
                               const float *metal, float *rm)
{
    for (size_t t = 0; t < mesh->n_triangles; t++) {
        float r = 0.0f, mt = 0.0f;
        for (int v = 0; v < 3; v++) {
            r += rough[mesh->tri[t * 3 + v]] / 3.0f;
            mt += metal[mesh->tri[t * 3 + v]] / 3.0f;
        }
        rm[t * 2] = r, rm[t * 2 + 1] = mt;
    }
}

/* Splits the n surface triangles (indices sel, their materials rm by triangle) into at most
 * max_k materials, area-weighted: cluster[i] for sel[i], centres into out. */
static int cluster_surface(const struct esr_mesh *mesh, const uint32_t *sel, size_t n,
                           const float *rm, int max_k, int32_t *cluster,
                           struct esr_gltf_summary *out)
{
    float *x = malloc((n ? n : 1) * 2 * sizeof(float)), *w = malloc((n ? n : 1) * sizeof(float));
    int rc = x && w ? ESR_OK : ESR_FAIL("gltf: out of memory for %zu triangles' materials", n);
    double total = 0.0;
    for (size_t i = 0; rc == ESR_OK && i < n; i++) {
        x[i * 2] = rm[(size_t)sel[i] * 2], x[i * 2 + 1] = rm[(size_t)sel[i] * 2 + 1];
        w[i] = esr_mesh_triangle_area(mesh, sel[i]);
        total += w[i];
    }
    float centres[ESR_KMEANS_MAX_K * 2];
    double area[ESR_KMEANS_MAX_K];
    const struct esr_kmeans_params kp = {.x = x, .w = w, .n = n, .dim = 2, .k_max = max_k,
                                         .min_separation = ESR_GLTF_MATERIAL_SEPARATION,
                                         .min_share = ESR_GLTF_MATERIAL_MIN_SHARE, .iters = 30};
    if (rc == ESR_OK)
        rc = esr_kmeans(&kp, centres, cluster, area, &out->n_materials);
    for (int j = 0; rc == ESR_OK && j < out->n_materials; j++) {
        out->roughness[j] = centres[j * 2], out->metallic[j] = centres[j * 2 + 1];
        out->share[j] = total > 0.0 ? (float)(area[j] / total) : 1.0f / (float)out->n_materials;
    }
    free(x), free(w);
    return rc;
}

int esr_model_gltf_write(const struct esr_model *m, const struct esr_gltf_options *o,
                         const char *path, struct esr_gltf_summary *out)
{
    memset(out, 0, sizeof *out);
    if (o->max_materials < 1 || o->max_materials > ESR_GLTF_MAX_MATERIALS)
        return ESR_FAIL("gltf: %d materials (1..%d)", o->max_materials, ESR_GLTF_MAX_MATERIALS);
    const int has_fields = esr_model_has(m, ESR_COMP_BRDF_MLP);
    struct esr_mesh mesh;
    ESR_TRY(esr_model_mesh(m, o->res, !has_fields, &mesh));
    const size_t nv = mesh.n_vertices, nt = mesh.n_triangles;
    float *rough = malloc((nv ? nv : 1) * sizeof(float)), *metal = malloc((nv ? nv : 1) * sizeof(float));
    float *rm = malloc((nt ? nt : 1) * 2 * sizeof(float));
    int32_t *part_of = malloc((nt ? nt : 1) * sizeof(int32_t)); /* light k + 1, or 0 */
    uint32_t *surf = malloc((nt ? nt : 1) * sizeof(uint32_t));
    int32_t *cluster = malloc((nt ? nt : 1) * sizeof(int32_t));
    int rc = rough && metal && rm && part_of && surf && cluster
                 ? ESR_OK
                 : ESR_FAIL("gltf: out of memory for %zu triangles", nt);
    for (size_t i = 0; rc == ESR_OK && i < nv; i++) /* a model before lts: the defaults */
        rough[i] = 0.5f, metal[i] = 0.0f;
    if (rc == ESR_OK && has_fields) {
        rc = esr_mesh_alloc_colours(&mesh);
        if (rc == ESR_OK)
            rc = vertex_materials(m, &mesh, rough, metal);
    }
    const int n_lights = m->lights.n;
    size_t n_surf = 0;
    for (size_t t = 0; rc == ESR_OK && t < nt; t++) {
        float c[3] = {0, 0, 0};
        for (int v = 0; v < 3; v++)
            for (int a = 0; a < 3; a++)
                c[a] += mesh.pos[(size_t)mesh.tri[t * 3 + v] * 3 + a] / 3.0f;
        part_of[t] = esr_lights_id_at(&m->lights, c) + 1;
        if (part_of[t] == 0)
            surf[n_surf++] = (uint32_t)t;
    }
    if (rc == ESR_OK) {
        triangle_materials(&mesh, rough, metal, rm);
        rc = cluster_surface(&mesh, surf, n_surf, rm, o->max_materials, cluster, out);
    }
    const int n_mat = out->n_materials, n_parts = n_mat + n_lights;
    /* triangles by part: parts 0 .. n_mat - 1 the surface's materials, then light k */
    uint32_t *tri[ESR_GLTF_MAX_MATERIALS + ESR_MAX_LIGHTS];
    size_t cnt[ESR_GLTF_MAX_MATERIALS + ESR_MAX_LIGHTS];
    double lrm[ESR_MAX_LIGHTS][2]; /* each light's mean roughness and metallic */
    memset(tri, 0, sizeof tri);
    memset(cnt, 0, sizeof cnt);
    memset(lrm, 0, sizeof lrm);
    for (size_t i = 0; rc == ESR_OK && i < n_surf; i++) /* each part's size, then its triangles */
        cnt[cluster[i]]++;
    for (size_t t = 0; rc == ESR_OK && t < nt; t++)
        if (part_of[t] > 0)
            cnt[n_mat + part_of[t] - 1]++;
    for (int k = 0; rc == ESR_OK && k < n_parts; k++)
        if (!(tri[k] = malloc((cnt[k] ? cnt[k] : 1) * 3 * sizeof(uint32_t))))
            rc = ESR_FAIL("gltf: out of memory for %zu triangles", cnt[k]);
    memset(cnt, 0, sizeof cnt);
    for (size_t i = 0; rc == ESR_OK && i < n_surf; i++) {
        const int k = cluster[i];
        memcpy(tri[k] + cnt[k] * 3, mesh.tri + (size_t)surf[i] * 3, 3 * sizeof(uint32_t));
        cnt[k]++;
    }
    for (size_t t = 0; rc == ESR_OK && t < nt; t++) {
        if (part_of[t] == 0)
            continue;
        const int l = part_of[t] - 1, k = n_mat + l;
        memcpy(tri[k] + cnt[k] * 3, mesh.tri + t * 3, 3 * sizeof(uint32_t));
        cnt[k]++;
        lrm[l][0] += rm[t * 2], lrm[l][1] += rm[t * 2 + 1];
    }
    struct esr_glb_part parts[ESR_GLTF_MAX_MATERIALS + ESR_MAX_LIGHTS];
    char names[ESR_GLTF_MAX_MATERIALS + ESR_MAX_LIGHTS][32];
    int n_written = 0; /* a part without triangles is left out: a glTF mesh needs some */
    for (int k = 0; rc == ESR_OK && k < n_parts; k++) {
        if (cnt[k] == 0)
            continue;
        struct esr_glb_part *p = &parts[n_written];
        memset(p, 0, sizeof *p);
        if (k < n_mat && n_mat == 1)
            snprintf(names[n_written], sizeof names[n_written], "surface");
        else if (k < n_mat)
            snprintf(names[n_written], sizeof names[n_written], "surface_%d", k);
        else
            snprintf(names[n_written], sizeof names[n_written], "light_%d", k - n_mat);
        p->name = names[n_written];
        p->tri = tri[k];
        p->n_triangles = cnt[k];
        p->base[0] = p->base[1] = p->base[2] = 1.0f; /* x COLOR_0, the base colour */
        p->emissive_strength = 1.0f;
        if (k < n_mat) {
            p->roughness = out->roughness[k];
            p->metallic = out->metallic[k];
        } else {
            const int l = k - n_mat;
            p->roughness = (float)(lrm[l][0] / (double)cnt[k]);
            p->metallic = (float)(lrm[l][1] / (double)cnt[k]);
            const float *L = m->lights.light[l].radiance;
            const float mx = fmaxf(L[0], fmaxf(L[1], L[2]));
            if (mx > 0.0f) {
                for (int c = 0; c < 3; c++)
                    p->emissive[c] = L[c] / mx;
                p->emissive_strength = mx;
            }
            out->light_nodes |= 1 << l;
        }
        n_written++;
    }
    /* glTF is +Y up: the scene's +Z (up) becomes +Y, its +Y becomes -Z */
    for (size_t i = 0; rc == ESR_OK && i < nv; i++) {
        float *vs[2] = {mesh.pos + i * 3, mesh.normal + i * 3};
        for (int k = 0; k < 2; k++) {
            const float y = vs[k][1], z = vs[k][2];
            vs[k][1] = z;
            vs[k][2] = -y;
        }
    }
    if (rc == ESR_OK)
        rc = esr_glb_write(path, &mesh, parts, n_written);
    for (int k = 0; k < n_parts; k++)
        free(tri[k]);
    free(rough), free(metal), free(rm), free(part_of), free(surf), free(cluster);
    esr_mesh_free(&mesh);
    return rc;
}
