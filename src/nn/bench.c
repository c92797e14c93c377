/* Dense-kernel benchmark: own tiled MLP layer (bias and activation included) against plain
 * GEMM calls of oneDNN and OpenBLAS (which do less work: no bias, no activation). */
#include "nn/bench.h"

#include <cblas.h>
#include <oneapi/dnnl/dnnl.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/rng.h"
#include "nn/mlp.h"

/* OpenBLAS's pthread build exports this; its header does not always declare it. */
void openblas_set_num_threads(int n);

struct bench_shape {
    int n, k, m;
};

static const struct bench_shape bench_shapes[] = {
    {16384, 64, 64}, {65536, 64, 64}, {65536, 39, 64}, {65536, 64, 3}, {65536, 192, 192},
};

struct bench_bufs {
    float *x, *y, *dy, *dx, *w, *dw;
};

static void fill(float *p, size_t n, uint64_t stream)
{
    struct esr_rng rng = esr_rng_init(7, stream);
    for (size_t i = 0; i < n; i++)
        p[i] = esr_rng_float(&rng) - 0.5f;
}

static int bufs_alloc(struct bench_bufs *b, const struct bench_shape *s)
{
    size_t nk = (size_t)s->n * s->k, nm = (size_t)s->n * s->m, km = (size_t)s->k * s->m;
    b->x = malloc(nk * sizeof(float));
    b->dx = malloc(nk * sizeof(float));
    b->y = malloc(nm * sizeof(float));
    b->dy = malloc(nm * sizeof(float));
    b->w = malloc(km * sizeof(float));
    b->dw = malloc(km * sizeof(float));
    if (!b->x || !b->dx || !b->y || !b->dy || !b->w || !b->dw)
        return ESR_FAIL("out of memory for the nn benchmark (%d x %d x %d)", s->n, s->k, s->m);
    fill(b->x, nk, 1);
    fill(b->dy, nm, 2);
    fill(b->w, km, 3);
    return ESR_OK;
}

static void bufs_free(struct bench_bufs *b)
{
    free(b->x);
    free(b->dx);
    free(b->y);
    free(b->dy);
    free(b->w);
    free(b->dw);
}

enum bench_op { OP_ESR_FWD, OP_ESR_BWD, OP_DNNL_FWD, OP_DNNL_BWD, OP_BLAS_FWD, OP_BLAS_BWD };

struct bench_env {
    const struct bench_shape *s;
    struct bench_bufs *b;
    struct esr_mlp *mlp;
    struct esr_nn_params *p;
    struct esr_mlp_ctx *ctx;
};

static void run_op(enum bench_op op, const struct bench_env *e)
{
    const struct bench_shape *s = e->s;
    struct bench_bufs *b = e->b;
    switch (op) {
    case OP_ESR_FWD:
        esr_mlp_fwd(e->mlp, e->p->w, e->ctx, b->x, b->y, (size_t)s->n);
        break;
    case OP_ESR_BWD:
        esr_mlp_bwd(e->mlp, e->p->w, e->p->g, e->ctx, b->dy, b->dx, ESR_NN_GRAD_OVERWRITE);
        break;
    case OP_DNNL_FWD:
        dnnl_sgemm('N', 'N', s->n, s->m, s->k, 1.0f, b->x, s->k, b->w, s->m, 0.0f, b->y, s->m);
        break;
    case OP_DNNL_BWD:
        dnnl_sgemm('T', 'N', s->k, s->m, s->n, 1.0f, b->x, s->k, b->dy, s->m, 1.0f, b->dw, s->m);
        dnnl_sgemm('N', 'T', s->n, s->k, s->m, 1.0f, b->dy, s->m, b->w, s->m, 0.0f, b->dx, s->k);
        break;
    case OP_BLAS_FWD:
        cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, s->n, s->m, s->k, 1.0f, b->x, s->k,
                    b->w, s->m, 0.0f, b->y, s->m);
        break;
    case OP_BLAS_BWD:
        cblas_sgemm(CblasRowMajor, CblasTrans, CblasNoTrans, s->k, s->m, s->n, 1.0f, b->x, s->k,
                    b->dy, s->m, 1.0f, b->dw, s->m);
        cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasTrans, s->n, s->k, s->m, 1.0f, b->dy, s->m,
                    b->w, s->m, 0.0f, b->dx, s->k);
        break;
    }
}

static void time_op(enum bench_op op, const struct bench_env *e, int reps,
                    struct esr_nn_bench_row *row)
{
    static const char *const kernels[] = {"esr", "esr", "onednn", "onednn", "openblas", "openblas"};
    /* Warm-up for at least 50 ms: page faults, library dispatch, thread start-up and clock
     * ramp-up otherwise land in the first kernel's figures. */
    double w0 = omp_get_wtime();
    do
        run_op(op, e);
    while (omp_get_wtime() - w0 < 0.05);
    double best = 1e30;
    for (int r = 0; r < reps; r++) {
        double t0 = omp_get_wtime();
        run_op(op, e);
        double t = omp_get_wtime() - t0;
        best = t < best ? t : best;
    }
    int bwd = op == OP_ESR_BWD || op == OP_DNNL_BWD || op == OP_BLAS_BWD;
    snprintf(row->kernel, sizeof(row->kernel), "%s", kernels[op]);
    snprintf(row->pass, sizeof(row->pass), "%s", bwd ? "bwd" : "fwd");
    row->n = e->s->n;
    row->k = e->s->k;
    row->m = e->s->m;
    row->ms = best * 1e3;
    row->gflops = (bwd ? 4.0 : 2.0) * e->s->n * e->s->k * e->s->m / best * 1e-9;
}

/* One kernel's fwd and bwd (ops fwd_op, fwd_op + 1) on one shape; a single-layer MLP (no
 * activation) holds the weights for the own kernel. */
static int bench_shape_run(const struct bench_shape *s, enum bench_op fwd_op, int reps,
                           struct esr_nn_bench_result *res)
{
    struct bench_bufs b = {0};
    struct esr_nn_params p = {0};
    struct esr_mlp mlp;
    struct esr_mlp_ctx ctx = {0};
    struct esr_mlp_desc d = {s->k, s->m, 0, s->m, ESR_NN_ACT_RELU, ESR_NN_ACT_NONE};
    int rc = bufs_alloc(&b, s);
    if (rc == ESR_OK)
        rc = esr_nn_params_init(&p, 0);
    if (rc == ESR_OK)
        rc = esr_mlp_init(&mlp, &d, &p);
    if (rc == ESR_OK)
        rc = esr_mlp_ctx_init(&ctx, &mlp, (size_t)s->n);
    if (rc == ESR_OK) {
        esr_mlp_init_weights(&mlp, p.w, 1, 0.0f);
        memset(b.dw, 0, (size_t)s->k * s->m * sizeof(float));
        struct bench_env e = {s, &b, &mlp, &p, &ctx};
        for (int op = fwd_op; op <= (int)fwd_op + 1; op++)
            if (res->n_rows < ESR_NN_BENCH_MAX_ROWS)
                time_op((enum bench_op)op, &e, reps, &res->rows[res->n_rows++]);
    }
    esr_mlp_ctx_free(&ctx);
    esr_nn_params_free(&p);
    bufs_free(&b);
    return rc;
}

int esr_nn_bench(int reps, struct esr_nn_bench_result *res)
{
    memset(res, 0, sizeof(*res));
    res->threads = omp_get_max_threads();
    /* Kernel by kernel, OpenBLAS last: its pthread workers spin after each call and would steal
     * the cores from whatever ran next. Its thread count goes back to 1 afterwards, the setting
     * for calls made inside OpenMP regions. */
    static const enum bench_op fwd_ops[] = {OP_ESR_FWD, OP_DNNL_FWD, OP_BLAS_FWD};
    int rc = ESR_OK;
    for (size_t k = 0; k < 3 && rc == ESR_OK; k++) {
        if (fwd_ops[k] == OP_BLAS_FWD)
            openblas_set_num_threads(res->threads);
        for (size_t i = 0; i < sizeof(bench_shapes) / sizeof(bench_shapes[0]) && rc == ESR_OK; i++)
            rc = bench_shape_run(&bench_shapes[i], fwd_ops[k], reps < 1 ? 1 : reps, res);
    }
    openblas_set_num_threads(1);
    return rc;
}
