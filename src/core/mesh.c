/* Indexed triangle mesh storage. */
#include "core/mesh.h"

#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/vec3.h"

int esr_mesh_alloc_colours(struct esr_mesh *m)
{
    free(m->colour);
    m->colour = (float *)calloc(m->n_vertices ? m->n_vertices * 3 : 1, sizeof(float));
    if (!m->colour)
        return ESR_FAIL("mesh: out of memory for %zu vertex colours", m->n_vertices);
    return ESR_OK;
}

float esr_mesh_triangle_area(const struct esr_mesh *m, size_t t)
{
    const uint32_t *v = m->tri + t * 3;
    const struct esr_vec3 a = esr_v3_at(m->pos, v[0]);
    const struct esr_vec3 e1 = esr_v3_sub(esr_v3_at(m->pos, v[1]), a),
                          e2 = esr_v3_sub(esr_v3_at(m->pos, v[2]), a);
    return 0.5f * esr_v3_length(esr_v3_cross(e1, e2));
}

void esr_mesh_free(struct esr_mesh *m)
{
    free(m->pos);
    free(m->normal);
    free(m->colour);
    free(m->tri);
    memset(m, 0, sizeof(*m));
}
