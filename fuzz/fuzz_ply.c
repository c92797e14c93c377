/* PLY reading (src/io/ply_read.c). */
#include "core/mesh.h"
#include "fuzz.h"
#include "io/ply.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fuzz_setup();
    struct esr_mesh m;
    int status = esr_ply_parse(data, size, "fuzz.ply", &m);
    if (status == ESR_OK) {
        for (size_t i = 0; i < m.n_triangles * 3; i++)
            if (m.tri[i] >= m.n_vertices)
                abort();
        esr_mesh_free(&m);
    }
    fuzz_done(status);
    return 0;
}
