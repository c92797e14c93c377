/* PLY meshes. Output (binary little-endian): float x y z, float nx ny nz, and uchar red green blue
 * when the mesh has colours; faces as uchar count + uint vertex indices. Written atomically. */
#ifndef ESR_IO_PLY_H
#define ESR_IO_PLY_H

#include "core/mesh.h"

/* Writes m to path (atomic: a failed write leaves an existing file untouched). */
int esr_ply_write(const char *path, const struct esr_mesh *m);
/* Reads vertex positions and faces (polygons fan-triangulated) from an ASCII or binary
 * little-endian PLY; normals and colours are not read (left NULL). Clear error on malformed
 * files. The element order must be vertex then face. */
int esr_ply_read(const char *path, struct esr_mesh *m);
/* The same from size bytes in memory; name stands for the file in messages. */
int esr_ply_parse(const void *bytes, size_t size, const char *name, struct esr_mesh *m);

#endif
