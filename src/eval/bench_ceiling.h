/* The machine's own ceilings, measured in the same run as the figures they bound (`esr bench`):
 * a part's achieved GFLOP/s or GB/s over its ceiling is the figure that carries from machine to
 * machine. */
#ifndef ESR_EVAL_BENCH_CEILING_H
#define ESR_EVAL_BENCH_CEILING_H

struct esr_bench_ceiling {
    double sgemm_gflops;     /* oneDNN sgemm, 1024 x 1024 x 1024, all threads */
    double sgemm_mlp_gflops; /* oneDNN sgemm of the MLPs' shape: 65536 rows x 64 x 64 */
    double copy_gbs;         /* a parallel copy of 256 MiB: bytes read + written per second */
};

int esr_bench_ceiling_measure(struct esr_bench_ceiling *c);

#endif
