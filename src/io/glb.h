/* Binary glTF 2.0 (.glb) of indexed triangle meshes with PBR materials: one shared vertex set
 * (positions, unit normals, linear per-vertex colours) and named parts, each its own mesh and
 * node with its own material (base colour factor x COLOR_0, metallic and roughness factors, an
 * emissive colour with KHR_materials_emissive_strength for linear HDR emission above 1). Written
 * atomically. Positions and normals are written as given: the caller puts them in glTF's frame
 * (+Y up, metres by convention). */
#ifndef ESR_IO_GLB_H
#define ESR_IO_GLB_H

#include <stddef.h>
#include <stdint.h>

#include "core/mesh.h"

struct esr_glb_part {
    const char *name;        /* node and mesh name */
    const uint32_t *tri;     /* [n_triangles * 3] indices into the shared vertices */
    size_t n_triangles;
    float base[3];           /* base colour factor (multiplies COLOR_0), linear */
    float metallic, roughness;
    float emissive[3];       /* emissive colour, linear, each <= 1 ... */
    float emissive_strength; /* ... times this (1 = none of the extension needed) */
};

/* Writes mesh (pos, normal, colour required) and its parts to path. */
int esr_glb_write(const char *path, const struct esr_mesh *mesh, const struct esr_glb_part *parts,
                  int n_parts);

#endif
