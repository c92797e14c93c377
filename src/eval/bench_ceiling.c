/* The machine's SGEMM and memory ceilings (see bench_ceiling.h). */
#include "eval/bench_ceiling.h"

#include <omp.h>
#include <oneapi/dnnl/dnnl.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"

/* best GFLOP/s of `reps` row-major m x n x k products */
static double sgemm_best(int m, int n, int k, int reps, const float *a, const float *b, float *c)
{
    double best = 0.0;
    for (int r = 0; r < reps; r++) {
        const double t0 = omp_get_wtime();
        dnnl_sgemm('N', 'N', m, n, k, 1.0f, a, k, b, n, 0.0f, c, n);
        const double dt = omp_get_wtime() - t0;
        if (dt > 0.0 && 2.0 * m * n * k / dt / 1e9 > best)
            best = 2.0 * m * n * k / dt / 1e9;
    }
    return best;
}

int esr_bench_ceiling_measure(struct esr_bench_ceiling *c)
{
    memset(c, 0, sizeof *c);
    const size_t big = 1024, rows = 65536, w = 64, copy = (size_t)64 << 20; /* floats: 256 MiB */
    float *a = malloc(rows * w * sizeof(float)), *b = malloc(big * big * sizeof(float));
    float *o = malloc(rows * w * sizeof(float));
    float *src = malloc(copy * sizeof(float)), *dst = malloc(copy * sizeof(float));
    int rc = a && b && o && src && dst ? ESR_OK : ESR_FAIL("bench: out of memory for the ceilings");
    if (rc == ESR_OK) {
        for (size_t i = 0; i < rows * w; i++)
            a[i] = (float)(i % 7) * 0.1f;
        for (size_t i = 0; i < big * big; i++)
            b[i] = (float)(i % 5) * 0.1f;
        /* the 1024-cube product reads a as 1024 x 1024 (rows * w >= big * big) */
        c->sgemm_gflops = sgemm_best((int)big, (int)big, (int)big, 4, a, b, o);
        c->sgemm_mlp_gflops = sgemm_best((int)rows, (int)w, (int)w, 8, a, b, o);
#pragma omp parallel for schedule(static)
        for (size_t i = 0; i < copy; i++)
            src[i] = (float)i, dst[i] = 0.0f; /* touched first by the threads that copy them */
        double best = 0.0;
        for (int r = 0; r < 4; r++) {
            const double t0 = omp_get_wtime();
#pragma omp parallel for schedule(static)
            for (size_t i = 0; i < copy; i++)
                dst[i] = src[i];
            const double dt = omp_get_wtime() - t0;
            if (dt > 0.0 && 2.0 * copy * sizeof(float) / dt / 1e9 > best)
                best = 2.0 * copy * sizeof(float) / dt / 1e9;
        }
        c->copy_gbs = best;
    }
    free(a), free(b), free(o), free(src), free(dst);
    return rc;
}
