/* Throughput of the dense kernels behind the MLPs, own fused kernel against the GEMMs of oneDNN
 * and OpenBLAS, on the shapes the training stages use. `esr bench` prints and stores this. */
#ifndef ESR_NN_BENCH_H
#define ESR_NN_BENCH_H

#ifdef __cplusplus
extern "C" {
#endif

#define ESR_NN_BENCH_MAX_ROWS 64

struct esr_nn_bench_row {
    char kernel[16]; /* "esr", "onednn", "openblas" */
    char pass[8];    /* "fwd" (Y = X W + b, act) or "bwd" (dW = X^T dY and dX = dY W^T) */
    int n, k, m;     /* rows, fan_in, fan_out */
    double ms;       /* best time of one call */
    double gflops;   /* 2 n k m (fwd) or 4 n k m (bwd) over ms */
};

struct esr_nn_bench_result {
    int n_rows;
    struct esr_nn_bench_row rows[ESR_NN_BENCH_MAX_ROWS];
    int threads; /* OpenMP threads used */
};

/* Runs every kernel on every shape (16384x64x64 and the real layer shapes at n = 65536), best
 * of `reps` (>= 1) timed calls after one warm-up. ESR_ERR on allocation failure. */
int esr_nn_bench(int reps, struct esr_nn_bench_result *res);

#ifdef __cplusplus
}
#endif
#endif
