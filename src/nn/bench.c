/* Dense-kernel benchmark; see nn/bench.h. The library baselines run the network the way a
 * framework would: one full-batch GEMM per layer and product, plus separate element-wise passes
 * for bias, activation and their gradients. */
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

enum bench_kernel { KERNEL_ESR, KERNEL_ONEDNN, KERNEL_OPENBLAS, KERNEL_COUNT };
static const char *const kernel_names[KERNEL_COUNT] = {"esr", "onednn", "openblas"};

/* Row-major C = A op B (+ beta C) through one library; ta/tb 'N' or 'T'. */
static void lib_gemm(enum bench_kernel k, char ta, char tb, int m, int n, int kk, const float *a,
                     int lda, const float *b, int ldb, float beta, float *c, int ldc)
{
    if (k == KERNEL_ONEDNN) {
        dnnl_sgemm(ta, tb, m, n, kk, 1.0f, a, lda, b, ldb, beta, c, ldc);
        return;
    }
    cblas_sgemm(CblasRowMajor, ta == 'T' ? CblasTrans : CblasNoTrans,
                tb == 'T' ? CblasTrans : CblasNoTrans, m, n, kk, 1.0f, a, lda, b, ldb, beta, c,
                ldc);
}

struct bench_env {
    enum bench_kernel kernel;
    const struct bench_case *bc;
    struct esr_mlp mlp;
    struct esr_nn_params p;
    struct esr_mlp_ctx ctx;
    float *x, *y, *dy, *dx;
    float *h[ESR_MLP_MAX_LAYERS]; /* library path: outputs of every layer, full batch */
    float *dh[2];                 /* library path: ping-pong gradient buffers */
    float *ones;                  /* library path: n ones for the bias-gradient GEMM */
};

/* y = act(y + b) over n rows of width w (the library path's separate epilogue pass); the
 * activation is switched outside the loops so they vectorise. */
static void bias_act_pass(float *y, const float *b, size_t n, int w, enum esr_nn_act act)
{
#pragma omp parallel for schedule(static)
    for (size_t r = 0; r < n; r++) {
        float *row = y + r * w;
        if (act == ESR_NN_ACT_RELU)
            for (int j = 0; j < w; j++)
                row[j] = esr_nn_relu_fwd(row[j] + b[j]);
        else
            for (int j = 0; j < w; j++)
                row[j] = esr_nn_act_fwd(act, row[j] + b[j]);
    }
}

/* g = relu'(h) * g over count values. */
static void relu_mask_pass(float *g, const float *h, size_t count)
{
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < count; i++)
        g[i] = esr_nn_relu_bwd(h[i], g[i]);
}

static void lib_fwd(const struct bench_env *e)
{
    const struct esr_mlp *m = &e->mlp;
    const float *x = e->x;
    for (int l = 0; l < m->n_layers; l++) {
        int fi = m->fan_in[l], fo = m->fan_out[l];
        lib_gemm(e->kernel, 'N', 'N', e->bc->n, fo, fi, x, fi, e->p.w + m->w_off[l], fo, 0.0f,
                 e->h[l], fo);
        bias_act_pass(e->h[l], e->p.w + m->b_off[l], (size_t)e->bc->n, fo,
                      l == m->n_layers - 1 ? m->desc.out_act : m->desc.hidden_act);
        x = e->h[l];
    }
}

/* Backward of lib_fwd for a linear output: per layer db, dW = X^T G, G' = relu'(H) (G W^T). */
static void lib_bwd(const struct bench_env *e)
{
    const struct esr_mlp *m = &e->mlp;
    const int n = e->bc->n;
    const float *g = e->dy;
    for (int l = m->n_layers - 1; l >= 0; l--) {
        int fi = m->fan_in[l], fo = m->fan_out[l];
        const float *x = l == 0 ? e->x : e->h[l - 1];
        /* db += 1^T G, as a GEMM with a row of ones (how frameworks reduce bias gradients) */
        lib_gemm(e->kernel, 'N', 'N', 1, fo, n, e->ones, n, g, fo, 1.0f, e->p.g + m->b_off[l], fo);
        lib_gemm(e->kernel, 'T', 'N', fi, fo, n, x, fi, g, fo, 1.0f, e->p.g + m->w_off[l], fo);
        float *dst = l == 0 ? e->dx : e->dh[l & 1];
        lib_gemm(e->kernel, 'N', 'T', n, fi, fo, g, fo, e->p.w + m->w_off[l], fo, 0.0f, dst, fi);
        if (l > 0)
            relu_mask_pass(dst, x, (size_t)n * fi);
        g = dst;
    }
}

static void run_pass(const struct bench_env *e, int bwd)
{
    if (e->kernel == KERNEL_ESR && !bwd)
        esr_mlp_fwd(&e->mlp, e->p.w, (struct esr_mlp_ctx *)&e->ctx, e->x, e->y, (size_t)e->bc->n);
    else if (e->kernel == KERNEL_ESR)
        esr_mlp_bwd(&e->mlp, e->p.w, e->p.g, (struct esr_mlp_ctx *)&e->ctx, e->dy, e->dx,
                    ESR_NN_GRAD_OVERWRITE);
    else if (!bwd)
        lib_fwd(e);
    else
        lib_bwd(e);
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
    for (int l = 0; l < ESR_MLP_MAX_LAYERS; l++)
        free(e->h[l]);
    free(e->ones);
    free(e->dh[0]);
    free(e->dh[1]);
}

/* Weights, inputs, output gradients and the kernel's workspace for one case. */
static int env_init(struct bench_env *e, enum bench_kernel k, const struct bench_case *bc)
{
    memset(e, 0, sizeof(*e));
    e->kernel = k;
    e->bc = bc;
    const size_t n = (size_t)bc->n;
    ESR_TRY(esr_nn_params_init(&e->p, 0));
    ESR_TRY(esr_mlp_init(&e->mlp, &bc->d, &e->p));
    esr_mlp_init_weights(&e->mlp, e->p.w, 1, 0.0f);
    e->x = alloc_filled(n * bc->d.n_in, 1);
    e->dx = alloc_filled(n * bc->d.n_in, 2);
    e->y = alloc_filled(n * bc->d.n_out, 3);
    e->dy = alloc_filled(n * bc->d.n_out, 4);
    int ok = e->x && e->dx && e->y && e->dy;
    if (k == KERNEL_ESR) {
        ESR_TRY(esr_mlp_ctx_init(&e->ctx, &e->mlp, n));
    } else {
        for (int l = 0; l < e->mlp.n_layers; l++)
            ok = ok && (e->h[l] = alloc_filled(n * e->mlp.fan_out[l], 5)) != NULL;
        for (int i = 0; i < 2; i++)
            ok = ok && (e->dh[i] = alloc_filled(n * ESR_MLP_MAX_WIDTH, 6)) != NULL;
        ok = ok && (e->ones = alloc_filled(n, 7)) != NULL;
        for (size_t i = 0; ok && i < n; i++)
            e->ones[i] = 1.0f;
    }
    if (!ok)
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
static void time_pass(const struct bench_env *e, int bwd, int reps, struct esr_nn_bench_row *row)
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
    snprintf(row->kernel, sizeof(row->kernel), "%s", kernel_names[e->kernel]);
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
static int bench_case_run(enum bench_kernel k, const struct bench_case *bc, int reps,
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
    for (int k = 0; k < KERNEL_COUNT && rc == ESR_OK; k++) {
        if (k == KERNEL_OPENBLAS)
            openblas_set_num_threads(res->threads);
        for (size_t i = 0; i < sizeof(bench_cases) / sizeof(bench_cases[0]) && rc == ESR_OK; i++)
            rc = bench_case_run((enum bench_kernel)k, &bench_cases[i], reps < 1 ? 1 : reps, res);
    }
    openblas_set_num_threads(1);
    return rc;
}
