/* Indexed triangle meshes (marching-cubes output, PLY export). */
#ifndef ESR_CORE_MESH_H
#define ESR_CORE_MESH_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

struct esr_mesh {
    size_t n_vertices, n_triangles;
    float *pos;       /* [n_vertices * 3] world positions */
    float *normal;    /* [n_vertices * 3] unit normals, pointing towards increasing field */
    float *colour;    /* [n_vertices * 3] linear RGB in [0,1], or NULL (see esr_mesh_alloc_colours) */
    uint32_t *tri;    /* [n_triangles * 3] vertex indices, consistently oriented */
};

/* Allocates mesh->colour (zeroed) so the caller can fill per-vertex colours. */
int esr_mesh_alloc_colours(struct esr_mesh *m);
/* The area of triangle t. */
float esr_mesh_triangle_area(const struct esr_mesh *m, size_t t);
/* Frees every array and zeroes the struct (safe on a zeroed or partly built mesh). */
void esr_mesh_free(struct esr_mesh *m);

#ifdef __cplusplus
}
#endif
#endif
