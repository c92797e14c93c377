/* Dense-kernel benchmark; see nn/bench.h. Every engine of nn/mlp.h runs the same network through
 * the same API; the library engines (nn/mlp_blas.c) run it the way a framework would. */
#include "nn/bench.h"

#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/rng.h"
#include "nn/mlp.h"

/* OpenBLAS's pthread build exports this; its header does not always declare it. */
void openblas_set_num_threads(int n);

struct bench_case {
    int n;
    struct esr_mlp_desc d;
};

#define RELU ESR_NN_ACT_RELU
#define LINEAR ESR_NN_ACT_NONE
static const struct bench_case bench_cases[] = {
    {16384, {64, 64, 0, 64, RELU, LINEAR}},  {65536, {64, 64, 0, 64, RELU, LINEAR}},
    {65536, {39, 64, 0, 64, RELU, LINEAR}},  {65536, {64, 64, 0, 3, RELU, LINEAR}},
    {65536, {192, 192, 0, 192, RELU, LINEAR}}, /* fine-stage hidden layer */
    {65536, {39, 64, 2, 3, RELU, LINEAR}},   /* coarse-stage colour MLP */
    {16384, {90, 192, 3, 3, RELU, LINEAR}},  /* fine-stage radiance MLP */
};

/* Indexed by enum esr_mlp_engine. */
static const char *const kernel_names[ESR_MLP_ENGINE_COUNT] = {"esr", "onednn", "openblas"};

struct bench_env {
    enum esr_mlp_engine engine;
    const struct bench_case *bc;
    struct esr_mlp mlp;
    struct esr_nn_params p;
    struct esr_mlp_ctx ctx;
    float *x, *y, *dy, *dx;
};

static void run_pass(struct bench_env *e, int bwd)
{
    if (!bwd)
        esr_mlp_fwd(&e->mlp, e->p.w, &e->ctx, e->x, e->y, (size_t)e->bc->n);
    else
        esr_mlp_bwd(&e->mlp, e->p.w, e->p.g, &e->ctx, e->dy, e->dx, ESR_NN_GRAD_OVERWRITE);
}

static float *alloc_filled(size_t count, uint64_t stream)
{
    float *p = malloc((count ? count : 1) * sizeof(float));
    struct esr_rng rng = esr_rng_init(7, stream);
    for (size_t i = 0; p && i < count; i++)
        p[i] = esr_rng_float(&rng) - 0.5f;
    return p;
}

static void env_free(struct bench_env *e)
{
    esr_mlp_ctx_free(&e->ctx);
    esr_nn_params_free(&e->p);
    free(e->x);
    free(e->y);
    free(e->dy);
    free(e->dx);
}

/* Weights, inputs, output gradients and the engine's workspace for one case. */
static int env_init(struct bench_env *e, enum esr_mlp_engine k, const struct bench_case *bc)
{
    memset(e, 0, sizeof(*e));
    e->engine = k;
    e->bc = bc;
    const size_t n = (size_t)bc->n;
    ESR_TRY(esr_nn_params_init(&e->p, 0));
    ESR_TRY(esr_mlp_init(&e->mlp, &bc->d, &e->p));
    esr_mlp_init_weights(&e->mlp, e->p.w, 1, 0.0f);
    ESR_TRY(esr_mlp_ctx_init(&e->ctx, &e->mlp, n, k));
    e->x = alloc_filled(n * bc->d.n_in, 1);
    e->dx = alloc_filled(n * bc->d.n_in, 2);
    e->y = alloc_filled(n * bc->d.n_out, 3);
    e->dy = alloc_filled(n * bc->d.n_out, 4);
    if (!e->x || !e->dx || !e->y || !e->dy)
        return ESR_FAIL("out of memory for the nn benchmark (%d rows)", bc->n);
    return ESR_OK;
}

static double pass_flops(const struct bench_env *e, int bwd)
{
    double f = 0.0;
    for (int l = 0; l < e->mlp.n_layers; l++)
        f += 2.0 * e->bc->n * e->mlp.fan_in[l] * e->mlp.fan_out[l];
    return bwd ? 2.0 * f : f;
}

/* Best of reps after a warm-up of at least 50 ms (page faults, library dispatch, thread start-up
 * and clock ramp-up otherwise land in the first kernel's figures). */
static void time_pass(struct bench_env *e, int bwd, int reps, struct esr_nn_bench_row *row)
{
    double w0 = omp_get_wtime();
    do
        run_pass(e, bwd);
    while (omp_get_wtime() - w0 < 0.05);
    double best = 1e30;
    for (int r = 0; r < reps; r++) {
        double t0 = omp_get_wtime();
        run_pass(e, bwd);
        double t = omp_get_wtime() - t0;
        best = t < best ? t : best;
    }
    snprintf(row->kernel, sizeof(row->kernel), "%s", kernel_names[e->engine]);
    snprintf(row->pass, sizeof(row->pass), "%s", bwd ? "bwd" : "fwd");
    row->n = e->bc->n;
    row->n_in = e->bc->d.n_in;
    row->width = e->bc->d.width;
    row->n_hidden = e->bc->d.n_hidden;
    row->n_out = e->bc->d.n_out;
    row->ms = best * 1e3;
    row->gflops = pass_flops(e, bwd) / best * 1e-9;
}

/* Forward then backward (which needs the forward's state) of one kernel on one case. */
static int bench_case_run(enum esr_mlp_engine k, const struct bench_case *bc, int reps,
                          struct esr_nn_bench_result *res)
{
    struct bench_env e;
    int rc = env_init(&e, k, bc);
    for (int bwd = 0; bwd < 2 && rc == ESR_OK; bwd++)
        if (res->n_rows < ESR_NN_BENCH_MAX_ROWS)
            time_pass(&e, bwd, reps, &res->rows[res->n_rows++]);
    env_free(&e);
    return rc;
}

int esr_nn_bench(int reps, struct esr_nn_bench_result *res)
{
    memset(res, 0, sizeof(*res));
    res->threads = omp_get_max_threads();
    /* Kernel by kernel, OpenBLAS last: its pthread workers spin after each call and would steal
     * the cores from whatever ran next. Its thread count goes back to 1 afterwards, the setting
     * for calls made inside OpenMP regions. */
    int rc = ESR_OK;
    for (int k = 0; k < ESR_MLP_ENGINE_COUNT && rc == ESR_OK; k++) {
        if (k == ESR_MLP_ENGINE_OPENBLAS)
            openblas_set_num_threads(res->threads);
        for (size_t i = 0; i < sizeof(bench_cases) / sizeof(bench_cases[0]) && rc == ESR_OK; i++)
            rc = bench_case_run((enum esr_mlp_engine)k, &bench_cases[i], reps < 1 ? 1 : reps, res);
    }
    openblas_set_num_threads(1);
    return rc;
}
