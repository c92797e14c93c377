/* Short training runs timed through the trainer's progress reports. */
#include "eval/bench_train.h"

#include <stdio.h>
#include <string.h>

#include "core/error.h"
#include "train/trainer.h"

/* Keeps the last progress window of every stage and its total time. */
static void on_report(void *user, const struct esr_train_progress *p)
{
    struct esr_bench_train_result *res = user;
    if ((unsigned)p->stage >= ESR_STAGE_COUNT)
        return;
    struct esr_bench_train_stage *s = &res->stages[p->stage];
    if (p->event == ESR_TRAIN_PROGRESS) {
        s->last_rays_per_s = p->rays_per_s;
        s->samples_per_ray = p->samples_per_ray;
        s->kept_per_ray = p->kept_per_ray;
        s->secondary_per_s = p->has_lts ? p->secondary_per_s : 0.0;
    } else if (p->event == ESR_TRAIN_STAGE_DONE) {
        s->iters = (int)p->iter;
        s->seconds = p->seconds;
        esr_prof_totals(&s->prof); /* the profile restarts with each stage */
        esr_prof_reset();
    }
}

int esr_bench_train(const char *data_dir, const char *run_dir, int iters, struct esr_bench_train_result *res)
{
    memset(res, 0, sizeof *res);
    if (iters != 0 && iters < 2)
        return ESR_FAIL("training benchmark needs >= 2 iterations per stage, got %d", iters);
    struct esr_train_opts o;
    memset(&o, 0, sizeof o);
    o.data_dir = data_dir;
    o.run_dir = run_dir;
    o.until = ESR_STAGE_PDRA;
    o.nan_test_iter = -1;
    esr_config_defaults(&o.cfg, ESR_PRESET_FAST);
    if (iters > 0) {
        o.cfg.alphamask.iters = o.cfg.coarse.iters = o.cfg.fine.iters = iters;
        o.cfg.lts.iters = o.cfg.pdra.iters = iters;
        o.cfg.log_every = iters / 2; /* the last window is then the second half */
    }
    o.cfg.save_every = 1000000;
    o.report = on_report;
    o.user = res;
    esr_prof_reset();
    esr_prof_enable(ESR_PROF_STEPS); /* the steps' parts; the rest of a stage apart */
    const int rc = esr_train_run(&o);
    esr_prof_enable(0);
    ESR_TRY(rc);
    for (int s = 0; s < ESR_STAGE_COUNT; s++) {
        struct esr_bench_train_stage *st = &res->stages[s];
        st->batch_rays = o.cfg.batch_rays;
        st->rays_per_s = st->seconds > 0 ? (double)st->iters * st->batch_rays / st->seconds : 0.0;
    }
    return ESR_OK;
}
