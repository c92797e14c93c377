/* Throughput of the primary-ray path on the CPU, through the code training runs: trace layer 1
 * (volume/march.h: sampling with the mask cache, fused SDF value + gradient, NeuS alpha,
 * weights, the kept list), a 12-channel feature grid on the kept rows (the point-fields layer's
 * grid lookup; its MLPs are timed by the MLP section of `esr bench`), compositing, and the
 * backward pass into both grids, on a coarse-stage-sized scene (96^3 sphere SDF). */
#ifndef ESR_MODEL_BENCH_RAY_PATH_H
#define ESR_MODEL_BENCH_RAY_PATH_H

#ifdef __cplusplus
extern "C" {
#endif

enum esr_render_bench_stage {
    ESR_RENDER_BENCH_MARCH,       /* esr_march_fwd: samples, SDF value + gradient, alpha, kept list */
    ESR_RENDER_BENCH_FEATURE,     /* 12-channel feature grid at the kept rows */
    ESR_RENDER_BENCH_COMPOSITE,   /* RGB composite on white */
    ESR_RENDER_BENCH_BACKWARD,    /* composite backward, esr_march_bwd, feature-grid scatter */
    ESR_RENDER_BENCH_STAGE_COUNT
};

struct esr_render_bench_result {
    int threads;          /* OpenMP threads used */
    int n_rays;
    double samples;       /* marched samples per batch */
    double kept;          /* kept rows per batch (where heads run) */
    double ms[ESR_RENDER_BENCH_STAGE_COUNT]; /* best time of each stage */
    double fwd_points_per_s;   /* marched samples / forward time */
    double total_points_per_s; /* marched samples / (forward + backward) */
    double rays_per_s;         /* rays / (forward + backward) */
};

/* Stage name for reports ("sample", "sdf", ...); NULL for an invalid stage. */
const char *esr_render_bench_stage_name(int stage);
/* Runs the path on n_rays rays, best of reps (>= 1) after one warm-up. ESR_ERR on bad arguments
 * or allocation failure. */
int esr_render_bench(int n_rays, int reps, struct esr_render_bench_result *res);

#ifdef __cplusplus
}
#endif
#endif
