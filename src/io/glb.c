/* Binary glTF writer (see glb.h). */
#include "io/glb.h"

#include <cjson/cJSON.h>
#include <float.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "io/file.h"

#define GLB_MAGIC 0x46546C67u /* "glTF" */
#define CHUNK_JSON 0x4E4F534Au
#define CHUNK_BIN 0x004E4942u
#define GL_FLOAT 5126
#define GL_UNSIGNED_INT 5125
#define GL_ARRAY_BUFFER 34962
#define GL_ELEMENT_ARRAY_BUFFER 34963

static cJSON *floats(const float *v, int n)
{
    cJSON *a = cJSON_CreateArray();
    for (int i = 0; i < n; i++)
        cJSON_AddItemToArray(a, cJSON_CreateNumber(v[i]));
    return a;
}

/* One buffer view + accessor pair: what add_accessor writes. */
struct accessor {
    size_t off, len;        /* the view: bytes [off, off + len) of the one buffer */
    int target;             /* the view's target (GL_ARRAY_BUFFER, GL_ELEMENT_ARRAY_BUFFER) */
    int component;          /* componentType (GL_FLOAT, GL_UNSIGNED_INT) */
    size_t count;           /* elements */
    const char *type;       /* "VEC3", "SCALAR" */
    const float *mn, *mx;   /* [3] each: the elements' bounds, or NULL: none written */
};

/* A buffer view + accessor pair as *ac describes it; returns the accessor's index. */
static int add_accessor(cJSON *views, cJSON *accessors, const struct accessor *ac)
{
    cJSON *v = cJSON_CreateObject();
    cJSON_AddNumberToObject(v, "buffer", 0);
    cJSON_AddNumberToObject(v, "byteOffset", (double)ac->off);
    cJSON_AddNumberToObject(v, "byteLength", (double)ac->len);
    cJSON_AddNumberToObject(v, "target", ac->target);
    cJSON_AddItemToArray(views, v);
    cJSON *a = cJSON_CreateObject();
    cJSON_AddNumberToObject(a, "bufferView", cJSON_GetArraySize(views) - 1);
    cJSON_AddNumberToObject(a, "componentType", ac->component);
    cJSON_AddNumberToObject(a, "count", (double)ac->count);
    cJSON_AddStringToObject(a, "type", ac->type);
    if (ac->mn) {
        cJSON_AddItemToObject(a, "min", floats(ac->mn, 3));
        cJSON_AddItemToObject(a, "max", floats(ac->mx, 3));
    }
    cJSON_AddItemToArray(accessors, a);
    return cJSON_GetArraySize(accessors) - 1;
}

static cJSON *material_json(const struct esr_glb_part *p, int *uses_strength)
{
    cJSON *m = cJSON_CreateObject();
    cJSON_AddStringToObject(m, "name", p->name);
    cJSON *pbr = cJSON_AddObjectToObject(m, "pbrMetallicRoughness");
    const float base4[4] = {p->base[0], p->base[1], p->base[2], 1.0f};
    cJSON_AddItemToObject(pbr, "baseColorFactor", floats(base4, 4));
    cJSON_AddNumberToObject(pbr, "metallicFactor", p->metallic);
    cJSON_AddNumberToObject(pbr, "roughnessFactor", p->roughness);
    if (p->emissive[0] + p->emissive[1] + p->emissive[2] > 0.0f) {
        cJSON_AddItemToObject(m, "emissiveFactor", floats(p->emissive, 3));
        if (p->emissive_strength != 1.0f) {
            cJSON *ext = cJSON_AddObjectToObject(m, "extensions");
            cJSON *st = cJSON_AddObjectToObject(ext, "KHR_materials_emissive_strength");
            cJSON_AddNumberToObject(st, "emissiveStrength", p->emissive_strength);
            *uses_strength = 1;
        }
    }
    return m;
}

int esr_glb_write(const char *path, const struct esr_mesh *mesh, const struct esr_glb_part *parts,
                  int n_parts)
{
    if (!mesh->pos || !mesh->normal || !mesh->colour || mesh->n_vertices == 0)
        return ESR_FAIL("glb %s: the mesh needs positions, normals and colours", path);
    const size_t nv = mesh->n_vertices, vbytes = nv * 3 * sizeof(float);
    size_t bin_len = 3 * vbytes;
    for (int i = 0; i < n_parts; i++)
        bin_len += parts[i].n_triangles * 3 * sizeof(uint32_t);
    unsigned char *bin = malloc(bin_len + 4);
    if (!bin)
        return ESR_FAIL("glb %s: out of memory for %zu bytes", path, bin_len);
    float mn[3] = {FLT_MAX, FLT_MAX, FLT_MAX}, mx[3] = {-FLT_MAX, -FLT_MAX, -FLT_MAX};
    for (size_t i = 0; i < nv; i++)
        for (int a = 0; a < 3; a++) {
            mn[a] = mesh->pos[i * 3 + a] < mn[a] ? mesh->pos[i * 3 + a] : mn[a];
            mx[a] = mesh->pos[i * 3 + a] > mx[a] ? mesh->pos[i * 3 + a] : mx[a];
        }
    memcpy(bin, mesh->pos, vbytes);
    memcpy(bin + vbytes, mesh->normal, vbytes);
    memcpy(bin + 2 * vbytes, mesh->colour, vbytes);
    cJSON *root = cJSON_CreateObject();
    cJSON *asset = cJSON_AddObjectToObject(root, "asset");
    cJSON_AddStringToObject(asset, "version", "2.0");
    cJSON_AddStringToObject(asset, "generator", "esr export --gltf");
    cJSON *views = cJSON_AddArrayToObject(root, "bufferViews");
    cJSON *accessors = cJSON_AddArrayToObject(root, "accessors");
    const struct accessor pos = {0, vbytes, GL_ARRAY_BUFFER, GL_FLOAT, nv, "VEC3", mn, mx};
    const struct accessor nrm = {vbytes, vbytes, GL_ARRAY_BUFFER, GL_FLOAT, nv, "VEC3", NULL, NULL};
    const struct accessor col = {2 * vbytes, vbytes, GL_ARRAY_BUFFER, GL_FLOAT, nv, "VEC3", NULL, NULL};
    const int a_pos = add_accessor(views, accessors, &pos);
    const int a_nrm = add_accessor(views, accessors, &nrm);
    const int a_col = add_accessor(views, accessors, &col);
    cJSON *meshes = cJSON_AddArrayToObject(root, "meshes");
    cJSON *materials = cJSON_AddArrayToObject(root, "materials");
    cJSON *nodes = cJSON_AddArrayToObject(root, "nodes");
    cJSON *scene_nodes = cJSON_CreateArray();
    size_t off = 3 * vbytes;
    int uses_strength = 0;
    for (int i = 0; i < n_parts; i++) {
        const struct esr_glb_part *p = &parts[i];
        if (p->n_triangles == 0)
            continue;
        const size_t ib = p->n_triangles * 3 * sizeof(uint32_t);
        memcpy(bin + off, p->tri, ib);
        const struct accessor idx = {off, ib, GL_ELEMENT_ARRAY_BUFFER, GL_UNSIGNED_INT,
                                     p->n_triangles * 3, "SCALAR", NULL, NULL};
        const int a_idx = add_accessor(views, accessors, &idx);
        off += ib;
        cJSON_AddItemToArray(materials, material_json(p, &uses_strength));
        cJSON *mesh_j = cJSON_CreateObject();
        cJSON_AddStringToObject(mesh_j, "name", p->name);
        cJSON *prims = cJSON_AddArrayToObject(mesh_j, "primitives");
        cJSON *prim = cJSON_CreateObject();
        cJSON *attr = cJSON_AddObjectToObject(prim, "attributes");
        cJSON_AddNumberToObject(attr, "POSITION", a_pos);
        cJSON_AddNumberToObject(attr, "NORMAL", a_nrm);
        cJSON_AddNumberToObject(attr, "COLOR_0", a_col);
        cJSON_AddNumberToObject(prim, "indices", a_idx);
        cJSON_AddNumberToObject(prim, "material", cJSON_GetArraySize(materials) - 1);
        cJSON_AddNumberToObject(prim, "mode", 4);
        cJSON_AddItemToArray(prims, prim);
        cJSON_AddItemToArray(meshes, mesh_j);
        cJSON *node = cJSON_CreateObject();
        cJSON_AddStringToObject(node, "name", p->name);
        cJSON_AddNumberToObject(node, "mesh", cJSON_GetArraySize(meshes) - 1);
        cJSON_AddItemToArray(nodes, node);
        cJSON_AddItemToArray(scene_nodes, cJSON_CreateNumber(cJSON_GetArraySize(nodes) - 1));
    }
    cJSON *scenes = cJSON_AddArrayToObject(root, "scenes");
    cJSON *scene = cJSON_CreateObject();
    cJSON_AddItemToObject(scene, "nodes", scene_nodes);
    cJSON_AddItemToArray(scenes, scene);
    cJSON_AddNumberToObject(root, "scene", 0);
    if (uses_strength) {
        cJSON *used = cJSON_AddArrayToObject(root, "extensionsUsed");
        cJSON_AddItemToArray(used, cJSON_CreateString("KHR_materials_emissive_strength"));
    }
    cJSON *buffers = cJSON_AddArrayToObject(root, "buffers");
    cJSON *buf = cJSON_CreateObject();
    cJSON_AddNumberToObject(buf, "byteLength", (double)off);
    cJSON_AddItemToArray(buffers, buf);
    char *json = cJSON_PrintUnformatted(root);
    cJSON_Delete(root);
    if (!json) {
        free(bin);
        return ESR_FAIL("glb %s: out of memory for the JSON chunk", path);
    }
    /* chunks padded to 4 bytes: JSON with spaces, BIN with zeros */
    const size_t jlen = strlen(json), jpad = (jlen + 3) & ~(size_t)3, bpad = (off + 3) & ~(size_t)3;
    const size_t total = 12 + 8 + jpad + 8 + bpad;
    if (total > UINT32_MAX) { /* the header's lengths are 32-bit */
        free(json);
        free(bin);
        return ESR_FAIL("glb %s: %zu bytes, past the format's 4 GiB (export at a lower --res)",
                        path, total);
    }
    unsigned char *out = malloc(total);
    int rc = out ? ESR_OK : ESR_FAIL("glb %s: out of memory for %zu bytes", path, total);
    if (rc == ESR_OK) {
        uint32_t h[3] = {GLB_MAGIC, 2, (uint32_t)total}, cj[2] = {(uint32_t)jpad, CHUNK_JSON},
                 cb[2] = {(uint32_t)bpad, CHUNK_BIN};
        unsigned char *p = out;
        memcpy(p, h, 12), p += 12;
        memcpy(p, cj, 8), p += 8;
        memcpy(p, json, jlen), memset(p + jlen, ' ', jpad - jlen), p += jpad;
        memcpy(p, cb, 8), p += 8;
        memcpy(p, bin, off), memset(p + off, 0, bpad - off);
        rc = esr_file_write_atomic(path, out, total);
    }
    free(out);
    free(json);
    free(bin);
    return rc;
}
