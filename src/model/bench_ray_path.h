/* Throughput of the primary-ray path on the CPU: sampling with the mask cache, trilinear SDF
 * value + gradient, a 12-channel feature grid, NeuS alpha, compositing, and the backward scatter
 * into the grids, on a coarse-stage-sized scene (96^3 sphere SDF). `esr bench` reports it. */
#ifndef ESR_MODEL_BENCH_RAY_PATH_H
#define ESR_MODEL_BENCH_RAY_PATH_H

#ifdef __cplusplus
extern "C" {
#endif

enum esr_render_bench_stage {
    ESR_RENDER_BENCH_SAMPLE,      /* ray clipping + marching + mask queries */
    ESR_RENDER_BENCH_SDF,         /* SDF value and spatial gradient at every sample */
    ESR_RENDER_BENCH_FEATURE,     /* 12-channel feature grid at every sample */
    ESR_RENDER_BENCH_ALPHA,       /* section estimate + NeuS alpha + weights */
    ESR_RENDER_BENCH_COMPOSITE,   /* RGB composite on white */
    ESR_RENDER_BENCH_BACKWARD,    /* composite + alpha backward, scatter into SDF and feature grids */
    ESR_RENDER_BENCH_STAGE_COUNT
};

struct esr_render_bench_result {
    int threads;          /* OpenMP threads used */
    int n_rays;
    double samples;       /* kept samples per batch */
    double ms[ESR_RENDER_BENCH_STAGE_COUNT]; /* best time of each stage */
    double fwd_points_per_s;   /* samples / (sample + sdf + feature + alpha + composite) */
    double total_points_per_s; /* samples / (all stages) */
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
