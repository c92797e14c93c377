/* Throughput of the dense kernels behind the MLPs on the shapes the training stages use: the
 * own tiled, fused MLP (nn/mlp.h) against the same network run layer by layer on the GEMMs of
 * oneDNN and OpenBLAS (full-batch GEMM, then a bias + activation pass). A case with n_hidden 0
 * is a single layer. `esr bench` prints and stores this. */
#ifndef ESR_NN_BENCH_H
#define ESR_NN_BENCH_H

#ifdef __cplusplus
extern "C" {
#endif

#define ESR_NN_BENCH_MAX_ROWS 64

struct esr_nn_bench_row {
    char kernel[16]; /* "esr", "onednn", "openblas" */
    char pass[8];    /* "fwd" (Y = act(X W + b) per layer) or "bwd" (dW, db and dX per layer) */
    int n;           /* rows */
    int n_in, width, n_hidden, n_out; /* network shape (ReLU hidden, linear output) */
    double ms;       /* best time of one call */
    double gflops;   /* sum over layers of 2 n fan_in fan_out (fwd), twice that (bwd), over ms */
};

struct esr_nn_bench_result {
    int n_rows;
    struct esr_nn_bench_row rows[ESR_NN_BENCH_MAX_ROWS];
    int threads; /* OpenMP threads used */
};

/* Runs every kernel on every case (16384x64x64, the real layer shapes at n = 65536, and two whole
 * MLPs), best of `reps` (>= 1) timed calls after a 50 ms warm-up. ESR_ERR on allocation failure. */
int esr_nn_bench(int reps, struct esr_nn_bench_result *res);

#ifdef __cplusplus
}
#endif
#endif
