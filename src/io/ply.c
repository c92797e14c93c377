/* Binary little-endian PLY writer for struct esr_mesh. */
#include "io/ply.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "io/file.h"

static unsigned char *put(unsigned char *p, const void *src, size_t n)
{
    /* the formats are little-endian and so is every supported host (x86-64, CUDA hosts) */
    memcpy(p, src, n);
    return p + n;
}

static unsigned char to_byte(float v)
{
    v = v < 0.0f ? 0.0f : v > 1.0f ? 1.0f : v;
    return (unsigned char)(v * 255.0f + 0.5f);
}

int esr_ply_write(const char *path, const struct esr_mesh *m)
{
    char header[512];
    int hn = snprintf(header, sizeof(header),
                      "ply\nformat binary_little_endian 1.0\ncomment written by esr\n"
                      "element vertex %zu\nproperty float x\nproperty float y\nproperty float z\n"
                      "property float nx\nproperty float ny\nproperty float nz\n%s"
                      "element face %zu\nproperty list uchar uint vertex_indices\nend_header\n",
                      m->n_vertices,
                      m->colour ? "property uchar red\nproperty uchar green\nproperty uchar blue\n" : "",
                      m->n_triangles);
    size_t vbytes = 24 + (m->colour ? 3 : 0);
    size_t size = (size_t)hn + m->n_vertices * vbytes + m->n_triangles * 13;
    unsigned char *buf = (unsigned char *)malloc(size);
    if (!buf)
        return ESR_FAIL("%s: out of memory for a %zu-byte PLY file", path, size);
    unsigned char *p = put(buf, header, (size_t)hn);
    for (size_t i = 0; i < m->n_vertices; i++) {
        p = put(p, m->pos + i * 3, 12);
        p = put(p, m->normal + i * 3, 12);
        if (m->colour)
            for (int c = 0; c < 3; c++)
                *p++ = to_byte(m->colour[i * 3 + c]);
    }
    for (size_t i = 0; i < m->n_triangles; i++) {
        *p++ = 3;
        p = put(p, m->tri + i * 3, 12);
    }
    int rc = esr_file_write_atomic(path, buf, size);
    free(buf);
    return rc;
}
