/* Training throughput for `esr bench`: a run of every stage (alphamask .. pdra) through
 * the training driver, reporting each stage's rays per second over the whole stage and over its
 * last progress window. */
#ifndef ESR_EVAL_BENCH_TRAIN_H
#define ESR_EVAL_BENCH_TRAIN_H

#include "core/profile.h"
#include "model/model.h"

struct esr_bench_train_stage {
    int iters;              /* iterations run */
    int batch_rays;         /* rays per iteration */
    double seconds;         /* wall time of the stage (iterations and final checkpoint) */
    double rays_per_s;      /* sustained: iters * batch_rays / seconds */
    double last_rays_per_s; /* over the last progress window (after warm-up) */
    double samples_per_ray; /* marched samples per ray in that window */
    double kept_per_ray;    /* samples that reached the MLPs */
    double secondary_per_s; /* lts, pdra: secondary rays per second in that window (else 0) */
    struct esr_prof_totals prof; /* where the stage's step time went (core/profile.h) */
};

struct esr_bench_train_result {
    struct esr_bench_train_stage stages[ESR_STAGE_COUNT];
};

/* Trains data_dir from scratch into run_dir (created; existing checkpoints there are ignored)
 * with the "fast" preset and `iters` iterations per stage (0 = the preset's own, i.e. a real
 * training run; else >= 2), and records each stage's throughput. ESR_ERR with the trainer's
 * message on failure. */
int esr_bench_train(const char *data_dir, const char *run_dir, int iters, struct esr_bench_train_result *res);

#endif
