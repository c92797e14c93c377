/* Indexed triangle mesh storage. */
#include "core/mesh.h"

#include <stdlib.h>
#include <string.h>

#include "core/error.h"

int esr_mesh_alloc_colours(struct esr_mesh *m)
{
    free(m->colour);
    m->colour = (float *)calloc(m->n_vertices ? m->n_vertices * 3 : 1, sizeof(float));
    if (!m->colour)
        return ESR_FAIL("mesh: out of memory for %zu vertex colours", m->n_vertices);
    return ESR_OK;
}

void esr_mesh_free(struct esr_mesh *m)
{
    free(m->pos);
    free(m->normal);
    free(m->colour);
    free(m->tri);
    memset(m, 0, sizeof(*m));
}
