/* Fixed path-tracing workload for `esr bench`. */
#include <string.h>
#include <time.h>

#include "core/error.h"
#include "synth/plan.h"
#include "synth/synth.h"
#include "synth/trace.h"

#define BENCH_RES 64
#define BENCH_SPP 16
#define BENCH_VIEWS 4

int esr_synth_bench(struct esr_synth_bench_result *out)
{
    memset(out, 0, sizeof *out);
    struct esr_synth_scene scene;
    ESR_TRY(esr_synth_scene_get("default", &scene));
    struct esr_synth_plan plan;
    ESR_TRY(esr_synth_plan_make(&scene, BENCH_RES, BENCH_VIEWS, 1, 1, &plan));
    /* The "on" half of the train views: every light lit, the costliest condition. */
    const struct esr_synth_frame *frames = plan.frames[ESR_PHASE_TRAIN] + BENCH_VIEWS;
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    int rc = ESR_OK;
    for (int v = 0; v < BENCH_VIEWS && rc == ESR_OK; v++) {
        struct esr_synth_trace_params params;
        struct esr_image img;
        esr_synth_trace_setup(&scene, (const float(*)[3])frames[v].emission, &params);
        rc = esr_synth_render(&params, &plan.train_cams[frames[v].cam], BENCH_SPP, 1, (uint64_t)v, &img);
        esr_image_free(&img);
    }
    clock_gettime(CLOCK_MONOTONIC, &t1);
    esr_synth_plan_free(&plan);
    ESR_TRY(rc);
    out->seconds = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
    out->samples = (long long)BENCH_VIEWS * BENCH_RES * BENCH_RES * BENCH_SPP;
    out->samples_per_s = (double)out->samples / out->seconds;
    out->pixels_per_s = (double)BENCH_VIEWS * BENCH_RES * BENCH_RES / out->seconds;
    return ESR_OK;
}
