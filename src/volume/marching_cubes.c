/* Marching cubes with a case table generated at run time from the cube's face contours.
 *
 * Corner c of a cell has offset (c & 1, c >> 1 & 1, c >> 2 & 1); edge e = 4a + j runs along
 * axis a from the corner whose other two coordinates are the bits of j. A corner is "inside"
 * when its value is below the level. On each cube face, walked counter-clockwise as seen from
 * outside the cube, the contour leaves the inside region at "A" crossings and enters it at "B"
 * crossings; every A is joined to the crossing just before it, which cuts off each inside corner
 * (this also resolves ambiguous faces, and the two cells sharing a face decide it identically, so
 * the mesh has no cracks). The directed face segments chain into closed loops around the cube.
 * A loop is fanned from a point whose chords all pass through the cube's interior (a chord lying
 * in a face would coincide with the neighbouring cell's triangles); when no such point exists,
 * as in some ambiguous configurations, it is fanned from an extra vertex at its centroid. For
 * non-ambiguous cells this reproduces Lorensen & Cline's 1987 cases (as tabulated by Bourke). */
#include "volume/marching_cubes.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "fields/trilerp.h"

#define MC_MAX_LOOPS 4 /* e.g. four isolated inside corners */

/* The contour loops of one corner configuration: loop l has len[l] edge ids in pts (loops stored
 * one after another) and is fanned from its point apex[l], or from a new vertex at its centroid
 * when apex[l] < 0 (no apex whose chords all avoid the cube's faces exists). */
struct mc_case {
    signed char n_loops;
    signed char len[MC_MAX_LOOPS];
    signed char apex[MC_MAX_LOOPS];
    signed char pts[12];
};

struct mc_table {
    struct mc_case cases[256];
};

static int edge_between(int c0, int c1)
{
    int diff = c0 ^ c1, a = diff == 1 ? 0 : diff == 2 ? 1 : 2;
    int lo = c0 < c1 ? c0 : c1;
    int j = 0, bit = 0;
    for (int b = 0; b < 3; b++)
        if (b != a)
            j |= ((lo >> b) & 1) << bit++;
    return 4 * a + j;
}

/* Bit mask of the two cube faces (2 * axis + side) that contain edge e. */
static int edge_faces(int e)
{
    int a = e / 4, j = e % 4, mask = 0, bit = 0;
    for (int b = 0; b < 3; b++)
        if (b != a)
            mask |= 1 << (2 * b + ((j >> bit++) & 1));
    return mask;
}

/* Corner cycle of face (axis a, side s), counter-clockwise seen from outside. */
static void face_cycle(int a, int s, int q[4])
{
    int u = (a + 1) % 3, v = (a + 2) % 3;
    const int uv[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    for (int k = 0; k < 4; k++) {
        int kk = s ? k : 3 - k;
        q[k] = (s << a) | (uv[kk][0] << u) | (uv[kk][1] << v);
    }
}

/* A fan apex of the loop whose chords (to non-neighbouring points) all cross the cube's interior:
 * a chord lying in a face would be shared with the neighbouring cell's triangles. -1 if none. */
static int fan_apex(const signed char *loop, int m)
{
    for (int j = 0; j < m; j++) {
        int ok = 1;
        for (int k = 2; k <= m - 2 && ok; k++)
            ok = !(edge_faces(loop[j]) & edge_faces(loop[(j + k) % m]));
        if (ok)
            return j;
    }
    return -1;
}

static void build_case(int cs, struct mc_case *out)
{
    int next[12];
    for (int e = 0; e < 12; e++)
        next[e] = -1;
    for (int f = 0; f < 6; f++) {
        int q[4], xe[4], type[4], nx = 0;
        face_cycle(f / 2, f % 2, q);
        for (int k = 0; k < 4; k++) {
            int in0 = (cs >> q[k]) & 1, in1 = (cs >> q[(k + 1) % 4]) & 1;
            if (in0 != in1) {
                xe[nx] = edge_between(q[k], q[(k + 1) % 4]);
                type[nx++] = in0; /* 1: A (leaves the inside) */
            }
        }
        for (int k = 0; k < nx; k++)
            if (type[k])
                next[xe[k]] = xe[(k + nx - 1) % nx];
    }
    int used[12] = {0}, n = 0;
    out->n_loops = 0;
    for (int e0 = 0; e0 < 12; e0++) {
        if (next[e0] < 0 || used[e0])
            continue;
        if (out->n_loops == MC_MAX_LOOPS)
            break; /* unreachable: every loop has >= 3 of the 12 edges */
        int m = 0;
        for (int e = e0; e >= 0 && !used[e] && n + m < 12; e = next[e]) {
            used[e] = 1;
            out->pts[n + m++] = (signed char)e;
        }
        out->len[(int)out->n_loops] = (signed char)m;
        out->apex[(int)out->n_loops++] = (signed char)fan_apex(out->pts + n, m);
        n += m;
    }
}

static void build_table(struct mc_table *t)
{
    for (int cs = 0; cs < 256; cs++)
        build_case(cs, &t->cases[cs]);
}

struct mc_build {
    const struct esr_grid *g;
    const float *field;
    float level;
    struct esr_mesh *m;
    size_t vcap, tcap;
    int32_t *xe[2], *ye[2], *ze; /* vertex id per edge of the two planes / the layer, -1 = none */
};

static int grow(void **p, size_t *cap, size_t need, size_t elem)
{
    if (need <= *cap)
        return ESR_OK;
    size_t cap2 = *cap ? *cap * 2 : 1024;
    while (cap2 < need)
        cap2 *= 2;
    void *q = realloc(*p, cap2 * elem);
    if (!q)
        return ESR_FAIL("marching cubes: out of memory for %zu elements", cap2);
    *p = q;
    *cap = cap2;
    return ESR_OK;
}

static float value_at(const struct mc_build *b, int x, int y, int z)
{
    return b->field[((size_t)z * b->g->ny + y) * b->g->nx + x];
}

/* Appends a vertex at p; its id goes to *id. */
static int add_vertex(struct mc_build *b, const float p[3], int32_t *id)
{
    size_t vcap = b->vcap;
    if (b->m->n_vertices >= (size_t)INT32_MAX)
        return ESR_FAIL("marching cubes: more than %d vertices", INT32_MAX);
    ESR_TRY(grow((void **)&b->m->pos, &vcap, (b->m->n_vertices + 1) * 3, sizeof(float)));
    b->vcap = vcap;
    memcpy(b->m->pos + b->m->n_vertices * 3, p, 3 * sizeof(float));
    *id = (int32_t)b->m->n_vertices++;
    return ESR_OK;
}

static int add_triangle(struct mc_build *b, int32_t i0, int32_t i1, int32_t i2)
{
    size_t tcap = b->tcap;
    ESR_TRY(grow((void **)&b->m->tri, &tcap, (b->m->n_triangles + 1) * 3, sizeof(uint32_t)));
    b->tcap = tcap;
    uint32_t *t = b->m->tri + b->m->n_triangles++ * 3;
    t[0] = (uint32_t)i0;
    t[1] = (uint32_t)i1;
    t[2] = (uint32_t)i2;
    return ESR_OK;
}

/* Vertex id on lattice edge from (x,y,z) along axis a, created on first use. */
static int edge_vertex(struct mc_build *b, int x, int y, int z, int a, int iz, int32_t *id)
{
    const int nx = b->g->nx;
    int32_t *slot = a == 0   ? &b->xe[z - iz][(size_t)y * nx + x]
                    : a == 1 ? &b->ye[z - iz][(size_t)y * nx + x]
                             : &b->ze[(size_t)y * nx + x];
    if (*slot < 0) {
        float p0[3], p1[3], p[3];
        int x1 = x + (a == 0), y1 = y + (a == 1), z1 = z + (a == 2);
        float v0 = value_at(b, x, y, z), v1 = value_at(b, x1, y1, z1);
        float t = (b->level - v0) / (v1 - v0);
        esr_grid_voxel_pos(b->g, x, y, z, p0);
        esr_grid_voxel_pos(b->g, x1, y1, z1, p1);
        for (int k = 0; k < 3; k++)
            p[k] = p0[k] + t * (p1[k] - p0[k]);
        ESR_TRY(add_vertex(b, p, slot));
    }
    *id = *slot;
    return ESR_OK;
}

/* Triangulates one contour loop (vertex ids ids[0..m)) as described in struct mc_case. */
static int fan_loop(struct mc_build *b, const int32_t *ids, int m, int apex)
{
    if (apex >= 0) {
        for (int k = 1; k + 1 < m; k++)
            ESR_TRY(add_triangle(b, ids[apex], ids[(apex + k + 1) % m], ids[(apex + k) % m]));
        return ESR_OK;
    }
    float c[3] = {0.0f, 0.0f, 0.0f};
    for (int k = 0; k < m; k++)
        for (int a = 0; a < 3; a++)
            c[a] += b->m->pos[(size_t)ids[k] * 3 + a] / (float)m;
    int32_t cid;
    ESR_TRY(add_vertex(b, c, &cid));
    for (int k = 0; k < m; k++)
        ESR_TRY(add_triangle(b, cid, ids[(k + 1) % m], ids[k]));
    return ESR_OK;
}

static int polygonise_cell(struct mc_build *b, const struct mc_table *t, int x, int y, int z)
{
    int cs = 0;
    for (int c = 0; c < 8; c++)
            cs |= (value_at(b, x + (c & 1), y + ((c >> 1) & 1), z + ((c >> 2) & 1)) < b->level) << c;
    const struct mc_case *mc = &t->cases[cs];
    const signed char *pts = mc->pts;
    for (int l = 0; l < mc->n_loops; l++) {
        int32_t ids[12];
        for (int k = 0; k < mc->len[l]; k++) {
            int e = pts[k], a = e / 4, j = e % 4;
            int o[3] = {0, 0, 0}, bit = 0;
            for (int d = 0; d < 3; d++)
                if (d != a)
                    o[d] = (j >> bit++) & 1;
            ESR_TRY(edge_vertex(b, x + o[0], y + o[1], z + o[2], a, z, &ids[k]));
        }
        ESR_TRY(fan_loop(b, ids, mc->len[l], mc->apex[l]));
        pts += mc->len[l];
    }
    return ESR_OK;
}

static void reset(int32_t *p, size_t n)
{
    for (size_t i = 0; i < n; i++)
        p[i] = -1;
}

static int march_layers(struct mc_build *b, const struct mc_table *t)
{
    const struct esr_grid *g = b->g;
    const size_t plane = (size_t)g->nx * g->ny;
    reset(b->xe[0], plane);
    reset(b->ye[0], plane);
    for (int z = 0; z + 1 < g->nz; z++) {
        reset(b->xe[1], plane);
        reset(b->ye[1], plane);
        reset(b->ze, plane);
        for (int y = 0; y + 1 < g->ny; y++)
            for (int x = 0; x + 1 < g->nx; x++)
                ESR_TRY(polygonise_cell(b, t, x, y, z));
        int32_t *tmp = b->xe[0];
        b->xe[0] = b->xe[1];
        b->xe[1] = tmp;
        tmp = b->ye[0];
        b->ye[0] = b->ye[1];
        b->ye[1] = tmp;
    }
    return ESR_OK;
}

/* The vertex normals: the field's normalised trilinear gradient, unless it is zero or points
 * against the vertex's own triangles (a sheet thinner than a voxel, whose gradient at one face
 * sees the other): then the area-weighted normal of those triangles. */
static int vertex_normals(const struct esr_grid *g, const float *field, struct esr_mesh *m)
{
    m->normal = (float *)malloc((m->n_vertices ? m->n_vertices : 1) * 3 * sizeof(float));
    float *faces = (float *)calloc((m->n_vertices ? m->n_vertices : 1) * 3, sizeof(float));
    if (!m->normal || !faces) {
        free(faces);
        return ESR_FAIL("marching cubes: out of memory for %zu normals", m->n_vertices);
    }
    for (size_t t = 0; t < m->n_triangles; t++) { /* twice each triangle's area x its normal */
        const uint32_t *v = m->tri + t * 3;
        const float *a = m->pos + (size_t)v[0] * 3, *b = m->pos + (size_t)v[1] * 3,
                    *c = m->pos + (size_t)v[2] * 3;
        const float u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        const float w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        const float cr[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
                             u[0] * w[1] - u[1] * w[0]};
        for (int k = 0; k < 3; k++)
            for (int a3 = 0; a3 < 3; a3++)
                faces[(size_t)v[k] * 3 + a3] += cr[a3];
    }
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < m->n_vertices; i++) {
        struct esr_trilerp t;
        float *n = m->normal + i * 3;
        const float *fa = faces + i * 3;
        esr_trilerp_locate(g, m->pos + i * 3, &t);
        esr_trilerp_dpoint(field, 1, 0, &t, n);
        if (!(n[0] * fa[0] + n[1] * fa[1] + n[2] * fa[2] > 0.0f))
            memcpy(n, fa, 3 * sizeof(float));
        float len = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        for (int k = 0; k < 3; k++)
            n[k] = len > 0.0f ? n[k] / len : 0.0f;
    }
    free(faces);
    return ESR_OK;
}

int esr_marching_cubes(const struct esr_grid *g, const float *field, float level,
                       struct esr_mesh *out)
{
    memset(out, 0, sizeof(*out));
    if (g->channels != 1)
        return ESR_FAIL("marching cubes: grid must have 1 channel, has %d", g->channels);
    struct mc_table *t = (struct mc_table *)malloc(sizeof(*t));
    struct mc_build b;
    memset(&b, 0, sizeof(b));
    b.g = g;
    b.field = field;
    b.level = level;
    b.m = out;
    size_t plane = (size_t)g->nx * g->ny;
    int32_t *maps = (int32_t *)malloc(plane * 5 * sizeof(int32_t));
    int rc = ESR_ERR;
    if (!t || !maps) {
        ESR_FAIL("marching cubes: out of memory for a %dx%d slice", g->nx, g->ny);
    } else {
        build_table(t);
        b.xe[0] = maps;
        b.xe[1] = maps + plane;
        b.ye[0] = maps + 2 * plane;
        b.ye[1] = maps + 3 * plane;
        b.ze = maps + 4 * plane;
        rc = march_layers(&b, t);
        if (rc == ESR_OK)
            rc = vertex_normals(g, field, out);
    }
    free(t);
    free(maps);
    return rc;
}
