/* Tessellation of the analytic primitives into closed, outward-oriented triangle shells. */
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "synth/scene.h"

struct mesh_writer {
    struct esr_mesh *m;
    size_t nv, nt;
};

static uint32_t put_vertex(struct mesh_writer *w, struct esr_vec3 p, struct esr_vec3 n)
{
    float *pos = w->m->pos + 3 * w->nv, *nor = w->m->normal + 3 * w->nv;
    n = esr_v3_normalize(n);
    pos[0] = p.x, pos[1] = p.y, pos[2] = p.z;
    nor[0] = n.x, nor[1] = n.y, nor[2] = n.z;
    return (uint32_t)w->nv++;
}

static void put_tri(struct mesh_writer *w, uint32_t a, uint32_t b, uint32_t c)
{
    uint32_t *t = w->m->tri + 3 * w->nt++;
    t[0] = a, t[1] = b, t[2] = c;
}

/* Triangles counted as (vertices, triangles) per primitive so the arrays are allocated once. */
static void prim_counts(const struct esr_synth_prim *p, int seg, size_t *nv, size_t *nt)
{
    int rings = seg / 2;
    if (p->kind == ESR_SYNTH_SPHERE) {
        *nv = 2 + (size_t)(rings - 1) * seg;
        *nt = 2 * (size_t)seg * (rings - 1);
    } else if (p->kind == ESR_SYNTH_BOX) {
        *nv = 8;
        *nt = 12;
    } else {
        *nv = 2 + 2 * (size_t)seg;
        *nt = 4 * (size_t)seg;
    }
}

static void mesh_sphere(struct mesh_writer *w, const struct esr_synth_prim *p, int seg)
{
    int rings = seg / 2;
    float r = p->b.x;
    uint32_t north = put_vertex(w, esr_v3_add(p->a, esr_v3(0, 0, r)), esr_v3(0, 0, 1));
    uint32_t first = (uint32_t)w->nv;
    for (int i = 1; i < rings; i++) {
        float th = ESR_PI * (float)i / (float)rings;
        for (int j = 0; j < seg; j++) {
            float ph = 2.0f * ESR_PI * (float)j / (float)seg;
            struct esr_vec3 n = esr_v3(sinf(th) * cosf(ph), sinf(th) * sinf(ph), cosf(th));
            put_vertex(w, esr_v3_add(p->a, esr_v3_scale(n, r)), n);
        }
    }
    uint32_t south = put_vertex(w, esr_v3_add(p->a, esr_v3(0, 0, -r)), esr_v3(0, 0, -1));
#define V(i, j) (first + (uint32_t)(((i)-1) * seg + ((j) % seg)))
    for (int j = 0; j < seg; j++) {
        put_tri(w, north, V(1, j), V(1, j + 1));
        put_tri(w, south, V(rings - 1, j + 1), V(rings - 1, j));
        for (int i = 1; i < rings - 1; i++) {
            put_tri(w, V(i, j), V(i + 1, j), V(i + 1, j + 1));
            put_tri(w, V(i, j), V(i + 1, j + 1), V(i, j + 1));
        }
    }
#undef V
}

static void mesh_box(struct mesh_writer *w, const struct esr_synth_prim *p)
{
    /* Corner k has x from bit 0, y from bit 1, z from bit 2; faces listed counter-clockwise as
     * seen from outside. */
    static const int faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3}};
    struct esr_vec3 c = esr_v3_scale(esr_v3_add(p->a, p->b), 0.5f);
    uint32_t base = (uint32_t)w->nv;
    for (int k = 0; k < 8; k++) {
        struct esr_vec3 x = esr_v3(k & 1 ? p->b.x : p->a.x, k & 2 ? p->b.y : p->a.y, k & 4 ? p->b.z : p->a.z);
        put_vertex(w, x, esr_v3_sub(x, c));
    }
    for (int f = 0; f < 6; f++) {
        put_tri(w, base + faces[f][0], base + faces[f][1], base + faces[f][2]);
        put_tri(w, base + faces[f][0], base + faces[f][2], base + faces[f][3]);
    }
}

static void mesh_cylinder(struct mesh_writer *w, const struct esr_synth_prim *p, int seg)
{
    float r = p->b.x, h = p->b.y;
    uint32_t bottom = put_vertex(w, p->a, esr_v3(0, 0, -1));
    uint32_t top = put_vertex(w, esr_v3_add(p->a, esr_v3(0, 0, h)), esr_v3(0, 0, 1));
    uint32_t first = (uint32_t)w->nv;
    for (int j = 0; j < seg; j++) {
        float ph = 2.0f * ESR_PI * (float)j / (float)seg;
        struct esr_vec3 d = esr_v3(cosf(ph), sinf(ph), 0);
        put_vertex(w, esr_v3_add(p->a, esr_v3_scale(d, r)), esr_v3_add(d, esr_v3(0, 0, -1)));
        put_vertex(w, esr_v3_add(p->a, esr_v3(r * d.x, r * d.y, h)), esr_v3_add(d, esr_v3(0, 0, 1)));
    }
    for (int j = 0; j < seg; j++) {
        uint32_t b0 = first + 2 * (uint32_t)j, b1 = first + 2 * (uint32_t)((j + 1) % seg);
        put_tri(w, bottom, b1, b0);
        put_tri(w, top, b0 + 1, b1 + 1);
        put_tri(w, b0, b1, b1 + 1);
        put_tri(w, b0, b1 + 1, b0 + 1);
    }
}

int esr_synth_scene_mesh(const struct esr_synth_scene *s, int segments, struct esr_mesh *out)
{
    memset(out, 0, sizeof *out);
    if (segments < 8 || segments > 4096)
        return ESR_FAIL("mesh tessellation of %d segments is outside 8..4096", segments);
    size_t nv = 0, nt = 0;
    for (int i = 0; i < s->n_prims; i++) {
        size_t v, t;
        prim_counts(&s->prims[i], segments, &v, &t);
        nv += v;
        nt += t;
    }
    out->pos = malloc(nv * 3 * sizeof(float));
    out->normal = malloc(nv * 3 * sizeof(float));
    out->tri = malloc(nt * 3 * sizeof(uint32_t));
    if (!out->pos || !out->normal || !out->tri) {
        esr_mesh_free(out);
        return ESR_FAIL("out of memory for a scene mesh of %zu vertices", nv);
    }
    out->n_vertices = nv;
    out->n_triangles = nt;
    struct mesh_writer w = {out, 0, 0};
    for (int i = 0; i < s->n_prims; i++) {
        const struct esr_synth_prim *p = &s->prims[i];
        if (p->kind == ESR_SYNTH_SPHERE)
            mesh_sphere(&w, p, segments);
        else if (p->kind == ESR_SYNTH_BOX)
            mesh_box(&w, p);
        else
            mesh_cylinder(&w, p, segments);
    }
    return ESR_OK;
}
