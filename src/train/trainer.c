/* The stage loop (see trainer.h). */
#include "train/trainer.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <omp.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/colour.h"
#include "core/error.h"
#include "core/profile.h"
#include "core/limits.h"
#include "core/rng.h"
#include "fields/env_sg.h"
#include "fields/sdf.h"
#include "io/dataset.h"
#include "io/dataset_summary.h"
#include "io/dir.h"
#include "io/file.h"
#include "io/json_file.h"
#include "nn/adam.h"
#include "nn/guard.h"
#include "nn/schedule.h"
#include "train/env_init.h"
#include "train/lights/lights.h"
#include "train/lights/fit.h"
#include "train/rays.h"
#include "train/render_loss.h"
#include "train/step.h"

#define MAX_NAN_FAILURES 3

struct run {
    const struct esr_train_opts *o;
    struct esr_train_config cfg;
    struct esr_ray_set rays;
    float scene_min[3], scene_max[3];
    int nan_failures;
    int nan_injected;
    int stopped; /* the stop_test_iter hook fired */
    struct esr_train_health health;
    int lock_fd; /* RUN held for this run (io/dir.h esr_dir_lock), -1 before */
    char log_path[4096];
};

struct window {
    double t0, loss, mse, samples, kept;
    double lts_off, lts_emo, secondary, hits, uncertain;
    float k;
    long iters;
};

/* Hands one event to the caller's progress callback, if any. */
static void emit(const struct run *r, const struct esr_train_progress *p)
{
    if (r->o->report)
        r->o->report(r->o->user, p);
}

static void say(struct run *r, enum esr_stage s, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
static void say(struct run *r, enum esr_stage s, const char *fmt, ...)
{
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    struct esr_train_progress p = {.event = ESR_TRAIN_MESSAGE, .stage = s, .message = msg};
    emit(r, &p);
}

/* A warning of the dataset's (esr_problem_fn) in the run's log. */
static void say_warning(void *user, const char *line)
{
    say(user, ESR_STAGE_COUNT, "warning: %s", line);
}

static void ckpt_path(const struct run *r, enum esr_stage s, char *out, size_t n)
{
    snprintf(out, n, "%s/ckpt_%s.bin", r->o->run_dir, esr_stage_name(s));
}

/* The stage option a component's learning rate comes from (component table: lr class). */
static float component_lr(const struct esr_stage_config *sc, enum esr_component c)
{
    switch (esr_component_info(c)->lr) {
    case ESR_LR_GRID:
        return sc->lr_grid;
    case ESR_LR_FEAT:
        return sc->lr_feat;
    case ESR_LR_MLP:
        break;
    }
    return sc->lr_mlp;
}

/* One Adam step over every component the stage trains, each with its learning rate; grids
 * take sparse Adam with beta2 0.99 (DVGO/Voxurf), MLPs dense Adam with 0.999. */
static void adam_all(struct esr_model *m, enum esr_stage s, float lr_scale, long t)
{
    const struct esr_stage_config *sc = esr_stage_options(&m->cfg, s);
    const uint32_t trained = esr_stage_info(s)->trained;
    for (int c = 0; c < ESR_COMP_COUNT; c++) {
        if (!(trained & ESR_BIT(c)) || !esr_model_has(m, (enum esr_component)c))
            continue;
        const int grid = esr_component_info((enum esr_component)c)->kind == ESR_KIND_GRID;
        struct esr_adam_hp hp;
        hp.lr = component_lr(sc, (enum esr_component)c) * lr_scale;
        hp.beta1 = 0.9f;
        hp.beta2 = grid ? 0.99f : 0.999f;
        hp.eps = 1e-8f;
        hp.sparse = grid;
        esr_adam_step(&hp, t, &m->adam, m->params.w, m->params.g, m->part[c].off, m->part[c].count);
        /* nominal traffic: w, g, m, v read, w, m, v written (a sparse step skips rows) */
        esr_prof_work(ESR_PROF_ADAM, 0.0, 7.0 * sizeof(float) * (double)m->part[c].count);
    }
}

/* Learning-rate factor at step it, by the stage's decay: exponential or cosine. */
static float lr_factor(const struct esr_stage_config *sc, enum esr_stage s, long it)
{
    if (esr_stage_info(s)->decay == ESR_DECAY_COSINE)
        return esr_lr_cosine_factor(it, sc->iters, 0, sc->lr_final);
    return esr_lr_exp_factor(it, sc->iters, sc->lr_final);
}

/* Total-variation regularisers of the stage's grids (component table: TV class), every
 * tv_every iterations with the weight scaled by it: gradients added, loss added to *total. */
static int add_tv(struct esr_model *m, const struct esr_train_step *b, enum esr_stage s, long it,
                  double *total)
{
    const struct esr_stage_config *sc = esr_stage_options(&m->cfg, s);
    const int every = m->cfg.tv_every;
    if (it % every != 0)
        return ESR_OK;
    for (int c = 0; c < ESR_COMP_COUNT; c++) {
        const enum esr_tv_class tv = esr_component_info((enum esr_component)c)->tv;
        const float weight = tv == ESR_TV_SDF ? sc->tv_sdf : tv == ESR_TV_FEAT ? sc->tv_feat : 0.0f;
        if (weight <= 0.0f || !esr_model_has(m, (enum esr_component)c))
            continue;
        double l = 0.0;
        ESR_TRY(esr_grid_tv_add_grad(esr_model_grid(m, (enum esr_component)c),
                                     esr_model_values(m, (enum esr_component)c), weight * (float)every,
                                     m->params.g + m->part[c].off, &l));
        *total += l;
    }
    if (b->grad_tv_work) {
        /* on the raw SDF, smoothed with the coarse stage's kernel (Voxurf's smooth_grad_tv) */
        double l = 0.0;
        int ksize = m->cfg.smooth_ksize > 1 ? m->cfg.smooth_ksize : 1;
        ESR_TRY(esr_sdf_grad_tv_add_grad(esr_model_grid(m, ESR_COMP_SDF),
                                         esr_model_values(m, ESR_COMP_SDF),
                                         sc->tv_sdf_grad * (float)every, ksize, m->cfg.smooth_sigma,
                                         b->grad_tv_work, m->params.g + m->part[ESR_COMP_SDF].off, &l));
        *total += l;
    }
    return ESR_OK;
}

static void append_jsonl(struct run *r, const char *line)
{
    FILE *f = fopen(r->log_path, "a");
    if (!f)
        return; /* metrics log is best effort; checkpoints carry the state */
    fprintf(f, "%s\n", line);
    fclose(f);
}

static void report_stage_done(struct run *r, enum esr_stage s, long run_now, long iters, double secs)
{
    struct esr_train_progress p = {
        .event = ESR_TRAIN_STAGE_DONE, .stage = s, .iter = run_now, .iters = iters, .seconds = secs};
    emit(r, &p);
}

static void report_window(struct run *r, const struct esr_model *m, enum esr_stage s,
                          struct window *w, long it, long iters, int B)
{
    double now = omp_get_wtime(), dt = now - w->t0;
    if (w->iters == 0)
        return;
    struct esr_train_progress p = {.event = ESR_TRAIN_PROGRESS, .stage = s, .iter = it, .iters = iters};
    p.loss = w->loss / (double)w->iters;
    double mse = w->mse / (double)w->iters;
    p.psnr = esr_psnr_from_mse(mse > 1e-12 ? mse : 1e-12);
    p.rays_per_s = dt > 0 ? (double)w->iters * B / dt : 0.0;
    p.eta_s = dt > 0 ? dt / (double)w->iters * (double)(iters - it) : 0.0;
    p.samples_per_ray = w->samples / ((double)w->iters * B);
    p.kept_per_ray = w->kept / ((double)w->iters * B);
    char line[768], extra[256] = "";
    if (esr_stage_info(s)->ray_groups) {
        p.has_groups = 1;
        p.k = w->k;
        p.uncertain_frac = w->uncertain / ((double)w->iters * B);
    }
    if (esr_stage_info(s)->lts_loss) {
        p.has_lts = 1;
        p.lts_mse_off = w->lts_off / (double)w->iters;
        p.lts_mse_emo = w->lts_emo / (double)w->iters;
        p.secondary_per_s = dt > 0 ? w->secondary / dt : 0.0;
        p.hit_frac = w->secondary > 0 ? w->hits / w->secondary : 0.0;
        snprintf(extra, sizeof extra,
                 ",\"lts_mse_off\":%.6g,\"lts_mse_emo\":%.6g,\"secondary_per_s\":%.0f,"
                 "\"hit_frac\":%.3f,\"k\":%.4g,\"uncertain_frac\":%.4f",
                 p.lts_mse_off, p.lts_mse_emo, p.secondary_per_s, p.hit_frac, p.k,
                 p.uncertain_frac);
    }
    snprintf(line, sizeof line,
             "{\"stage\":\"%s\",\"iter\":%ld,\"loss\":%.6g,\"psnr\":%.3f,\"rays_per_s\":%.0f,"
             "\"samples_per_ray\":%.2f,\"kept_per_ray\":%.2f,\"inv_s\":%.2f%s}",
             esr_stage_name(s), it, p.loss, p.psnr, p.rays_per_s, p.samples_per_ray,
             p.kept_per_ray, (double)m->inv_s, extra);
    append_jsonl(r, line);
    emit(r, &p);
    r->health.last_psnr = p.psnr;
    memset(w, 0, sizeof(*w));
    w->t0 = now;
}

static int save(struct run *r, const struct esr_model *m, enum esr_stage s)
{
    char path[4200];
    ckpt_path(r, s, path, sizeof path);
    return esr_model_save(m, path);
}

/* A checkpoint inside a stage: the next step recomputes the LTS normals from the model's SDF,
 * as a run resumed from this checkpoint computes them first. Inside pdra after pdra.lights_at
 * it holds, as its lights, the lights the transport sees (a run resumed from it hands them back
 * to the transport: resume_transport_lights). */
static int save_in_stage(struct run *r, const struct esr_model *m, enum esr_stage s,
                         struct esr_train_step *b)
{
    if (!b->has_lts)
        return save(r, m, s);
    esr_lts_refresh_normals(&b->lts);
    struct esr_model with_lights = *m; /* a shallow view: saving only reads it */
    with_lights.lights = b->lts.lights;
    return save(r, &with_lights, s);
}

/* Whether stage s's light transport can be handed the lights (esr_lts_set_lights): the stage
 * that finds them, with the first-hit estimator. */
static int transport_takes_lights(enum esr_stage s, const struct esr_train_step *b)
{
    return esr_stage_info(s)->finds_lights && b->has_lts && b->lts.estimator == ESR_LTS_FIRST_HIT;
}

/* The step after which pdra's light transport sees the lights at their calibrated strength
 * (pdra.lights_at); 0: never (another stage, the option 0, the volume estimator). */
static long transport_lights_step(const struct esr_model *m, enum esr_stage s,
                                  const struct esr_stage_config *sc, const struct esr_train_step *b)
{
    if (!transport_takes_lights(s, b) || !(m->cfg.pdra_lights_at > 0.0f))
        return 0;
    const long at = lroundf(m->cfg.pdra_lights_at * (float)sc->iters);
    return at < 1 ? 1 : at;
}

/* pdra.lights_at: the lights, found and calibrated as at the stage's end but with the BRDF as it
 * stands (no lights-off correction: the strengths it explains the light with), handed to the
 * light transport; the model itself stays without lights until the stage ends. */
static int transport_lights(struct run *r, struct esr_model *m, struct esr_train_step *b,
                            enum esr_stage s)
{
    const struct esr_lights_estimate_opts eo = {1, 0, 0, (uint64_t)r->cfg.seed};
    struct esr_lights_report rep;
    int rc = esr_lights_estimate(m, &r->rays, &eo, &rep);
    if (rc == ESR_OK && m->lights.n == 0)
        say(r, s, "light transport from iteration %ld: no light yet, so its secondary rays keep "
                  "seeing the radiance fields", m->step);
    for (int i = 0; rc == ESR_OK && i < m->lights.n; i++) {
        const float *L = m->lights.light[i].radiance;
        say(r, s, "light transport from iteration %ld: light %d (of %d) seen at its calibrated "
                  "radiance %.3g %.3g %.3g", m->step, i, m->lights.n, (double)L[0], (double)L[1],
            (double)L[2]);
    }
    if (rc == ESR_OK)
        rc = esr_lts_set_lights(&b->lts, m, &m->lights); /* takes them over */
    esr_lights_free(&m->lights);
    return rc;
}

/* A pdra checkpoint saved after pdra.lights_at holds the lights its transport saw
 * (save_in_stage): they go back to the transport, as the run that saved it had them. */
static int resume_transport_lights(struct esr_model *m, struct esr_train_step *b, enum esr_stage s)
{
    if (m->stage_done || !esr_stage_info(s)->finds_lights || m->lights.n == 0)
        return ESR_OK;
    if (!transport_takes_lights(s, b)) {
        esr_lights_free(&m->lights);
        return ESR_OK;
    }
    return esr_lts_set_lights(&b->lts, m, &m->lights);
}

/* Reloads the stage's last checkpoint into m (same layout) after a NaN. */
static int recover(struct run *r, struct esr_model *m, enum esr_stage s, long it,
                   struct esr_train_step *b)
{
    char path[4200];
    ckpt_path(r, s, path, sizeof path);
    r->nan_failures++;
    if (r->nan_failures >= MAX_NAN_FAILURES)
        return ESR_FAIL("train: non-finite loss or gradient in stage %s at iteration %ld, "
                        "failure %d of %d: stopping; the last good checkpoint %s is intact",
                        esr_stage_name(s), it, r->nan_failures, MAX_NAN_FAILURES, path);
    struct esr_model good;
    ESR_TRY(esr_model_load(&good, path));
    memcpy(m->params.w, good.params.w, m->params.count * sizeof(float));
    memcpy(m->adam.m, good.adam.m, m->params.count * sizeof(float));
    memcpy(m->adam.v, good.adam.v, m->params.count * sizeof(float));
    m->step = good.step;
    m->inv_s = good.inv_s;
    if (transport_takes_lights(s, b)) {
        /* the transport's lights, as the checkpoint saved them (none before pdra.lights_at) */
        int rc = esr_lts_set_lights(&b->lts, m, &good.lights);
        if (rc != ESR_OK) {
            esr_model_free(&good);
            return rc;
        }
    }
    esr_model_free(&good);
    m->lr_scale *= 0.5f;
    say(r, s, "non-finite loss or gradient at %s iteration %ld: reloaded %s (iteration %ld), "
              "learning rate halved (x%g), continuing",
        esr_stage_name(s), it, path, m->step, (double)m->lr_scale);
    /* the checkpoint now says at which rate its step goes on: a run killed before the next
     * checkpoint resumes from it as this one continues (normals from the reloaded SDF) */
    return save_in_stage(r, m, s, b);
}

/* Forward + loss + backward + regularisers for iteration it; returns the loss in *loss. */
static int iterate(struct run *r, struct esr_model *m, struct esr_train_step *b, enum esr_stage s,
                   long it, struct window *w, double *loss)
{
    const int B = r->cfg.batch_rays;
    uint64_t seed = esr_mix64((uint64_t)r->cfg.seed * 0x100000001b3ULL + (uint64_t)s);
    esr_ray_set_draw(&r->rays, seed, it, B, b->orig3, b->dir3, b->tgt3, b->lights_on);
    struct esr_render_loss_result lr;
    ESR_TRY(esr_train_step_run(b, m, B, esr_mix64(seed + (uint64_t)it), &lr));
    *loss = lr.loss;
    esr_prof_enter(ESR_PROF_REG);
    const int rc_tv = add_tv(m, b, s, it, loss);
    esr_prof_exit(ESR_PROF_REG);
    ESR_TRY(rc_tv);
    w->loss += *loss;
    w->mse += lr.mse_tone;
    w->samples += (double)b->tr.march.smp.count;
    w->kept += (double)b->tr.march.n_kept;
    if (b->has_lts) {
        w->lts_off += b->lts_stats.mse_off;
        w->lts_emo += b->lts_stats.mse_emo;
        w->secondary += (double)b->lts_stats.secondary;
        w->hits += (double)b->lts_stats.hits;
    }
    if (b->has_pdra) {
        w->uncertain += (double)(B - b->pdra.n_certain);
        w->k = b->pdra.k;
        if (b->pdra_chosen_k_end > 0.0f)
            say(r, s, "k_end %.4g derived from the data: %.2f x the emitters' level (99.5th "
                      "percentile of composited E in the first batch); k rises from %.3g, capped "
                      "each step at %.2f x the batch's current level (emitters whose E drifts down "
                      "stay above it)",
                (double)b->pdra_chosen_k_end, (double)m->cfg.pdra_k_frac, (double)m->cfg.pdra_k0,
                (double)m->cfg.pdra_k_frac);
    }
    w->iters++;
    return ESR_OK;
}

/* Builds the mask cache from the trained density grid. */
static int build_mask(struct run *r, struct esr_model *m)
{
    const struct esr_grid *density = esr_model_grid(m, ESR_COMP_DENSITY);
    ESR_TRY(esr_mask_alloc(&m->mask, density));
    m->has_mask = 1;
    ESR_TRY(esr_mask_from_density(&m->mask, density, esr_model_values(m, ESR_COMP_DENSITY),
                                  m->density_shift, m->cfg.alphamask.step_vox, r->cfg.alpha_thres,
                                  1));
    size_t occ = esr_mask_count(&m->mask), all = esr_grid_voxels(density);
    say(r, ESR_STAGE_ALPHAMASK, "mask cache: %zu of %zu voxels occupied (%.1f%%)", occ, all,
        100.0 * (double)occ / (double)all);
    if (occ == 0) /* later stages would march no samples and learn nothing */
        return ESR_FAIL("alphamask: the mask cache is empty (no voxel reaches alpha_thres %g after "
                        "%d iterations); train the alphamask stage longer or lower alpha_thres",
                        (double)r->cfg.alpha_thres, m->cfg.alphamask.iters);
    return ESR_OK;
}

/* The lights of the emitter stage's model: found, calibrated on the lights-off training rays,
 * their colour balanced (esr_lights_estimate). */
static int find_lights(struct run *r, struct esr_model *m, enum esr_stage s)
{
    const struct esr_lights_estimate_opts eo = {1, 1, 1, (uint64_t)r->cfg.seed};
    struct esr_lights_report rep;
    const int rc = esr_lights_estimate(m, &r->rays, &eo, &rep);
    for (int i = 0; i < rep.n; i++)
        say(r, s, "%s", rep.line[i]);
    r->health.lights_found = m->lights.n;
    r->health.lights_left_out = m->lights.n_left_out;
    return rc;
}

/* The stage's step workspace, refused when it does not fit beside the rays and the model. Its
 * size is measured, not predicted: the buffers are allocated but none of their pages touched yet
 * (they cost no memory until the first step writes them), so the allocator's count of bytes in
 * use is exact where a formula per buffer would drift from the code. Unmeasured (0) under the
 * sanitizers, which replace the allocator. */
static int workspace_init(struct run *r, struct esr_train_step *b, const struct esr_model *m,
                          enum esr_stage s)
{
    const size_t before = esr_heap_in_use();
    ESR_TRY(esr_train_step_init(b, m, r->cfg.batch_rays));
    const size_t after = esr_heap_in_use();
    if (after <= before)
        return ESR_OK;
    char what[160];
    snprintf(what, sizeof what, "the %s stage's training workspace (batch of %d rays)",
             esr_stage_name(s), r->cfg.batch_rays);
    const size_t rays = esr_ray_set_bytes(r->rays.n), model = esr_model_memory_held(m);
    int rc = esr_limits_check_memory(rays + model, after - before, what);
    if (rc != ESR_OK)
        esr_train_step_free(b);
    else
        say(r, s, "memory: training rays %.1f MiB, model %.1f MiB, workspace %.1f MiB",
            (double)rays / 1048576.0, (double)model / 1048576.0, (double)(after - before) / 1048576.0);
    return rc;
}

static int run_stage(struct run *r, struct esr_model *m, enum esr_stage s)
{
    const struct esr_stage_config *sc = esr_stage_options(&r->cfg, s);
    const int B = r->cfg.batch_rays;
    struct esr_train_step b;
    ESR_TRY(workspace_init(r, &b, m, s));
    int rc = resume_transport_lights(m, &b, s);
    if (rc == ESR_OK && m->step == 0)
        rc = save(r, m, s);
    const long lights_step = transport_lights_step(m, s, sc, &b);
    struct window w;
    memset(&w, 0, sizeof w);
    double t_start = omp_get_wtime();
    const long first_step = m->step;
    w.t0 = t_start;
    say(r, s, "stage %s: iterations %ld..%d, %zu parameters, batch %d rays", esr_stage_name(s),
        m->step, sc->iters, m->params.count, B);
    while (rc == ESR_OK && m->step < sc->iters) {
        long it = m->step;
        float f = lr_factor(sc, s, it);
        double loss = 0.0;
        esr_prof_step_begin();
        rc = iterate(r, m, &b, s, it, &w, &loss);
        if (rc != ESR_OK) {
            esr_prof_step_end();
            break;
        }
        if (r->o->nan_test_iter == it && s >= r->o->nan_test_stage &&
            r->nan_injected < r->o->nan_test_times) {
            r->nan_injected++;
            m->params.g[m->params.count / 2] = NAN;
        }
        if (!isfinite(loss) || !esr_nn_all_finite(m->params.g, m->params.count)) {
            esr_prof_step_end();
            rc = recover(r, m, s, it, &b);
            memset(&w, 0, sizeof w);
            w.t0 = omp_get_wtime();
            continue;
        }
        esr_prof_enter(ESR_PROF_ADAM);
        adam_all(m, s, f * m->lr_scale, it + 1);
        esr_prof_exit(ESR_PROF_ADAM);
        esr_prof_step_end();
        /* inv-s follows the step, as esr_model_init and a checkpoint's load set it: what
         * follows a stage (the mask, the lights, the next stage's start, which renders this
         * model: lts's environment level) sees the model a resumed run loads */
        m->step = it + 1;
        m->inv_s = esr_stage_inv_s(&m->cfg, s, m->step);
        if (m->step == lights_step && (rc = transport_lights(r, m, &b, s)) != ESR_OK)
            break;
        if (m->step % r->cfg.log_every == 0 || m->step == sc->iters)
            report_window(r, m, s, &w, m->step, sc->iters, B);
        if (m->step % r->cfg.save_every == 0 && m->step < sc->iters)
            rc = save_in_stage(r, m, s, &b);
        if (rc == ESR_OK && r->o->interrupt && *r->o->interrupt) { /* keep what was trained */
            rc = save_in_stage(r, m, s, &b);
            if (rc == ESR_OK)
                rc = ESR_FAIL("interrupted at %s iteration %ld: checkpoint %s/ckpt_%s.bin saved; "
                              "`esr train --resume` continues from it",
                              esr_stage_name(s), m->step, r->o->run_dir, esr_stage_name(s));
        }
        if (r->o->stop_test_iter > 0 && s == r->o->stop_test_stage &&
            m->step == r->o->stop_test_iter) {
            r->stopped = 1;
            esr_train_step_free(&b);
            return ESR_OK;
        }
    }
    /* the mask and the lights trace rays of their own: not beside it (pdra.lights_at's mid-stage
     * find and calibration do run beside it: the demo's peak RSS 685 MiB against 556-678) */
    esr_train_step_free(&b);
    if (rc == ESR_OK && esr_stage_info(s)->builds_mask)
        rc = build_mask(r, m);
    if (rc == ESR_OK && esr_stage_info(s)->finds_lights)
        rc = find_lights(r, m, s);
    if (rc == ESR_OK) {
        m->stage_done = 1;
        rc = save(r, m, s);
    }
    if (rc == ESR_OK) {
        double secs = omp_get_wtime() - t_start;
        char line[256];
        snprintf(line, sizeof line, "{\"stage\":\"%s\",\"event\":\"done\",\"iters\":%d,\"seconds\":%.1f}",
                 esr_stage_name(s), sc->iters, secs);
        append_jsonl(r, line);
        say(r, s, "stage %s done in %.1f s; checkpoint %s/ckpt_%s.bin", esr_stage_name(s), secs,
            r->o->run_dir, esr_stage_name(s));
        report_stage_done(r, s, sc->iters - first_step, sc->iters, secs);
    }
    return rc;
}

/* Whether the dataset's lighting lets stage s run: the emitter stages compare lights-off and
 * lights-on images. No lights-off images: refused (nothing tells emission from reflection), and
 * a geometry stage whose surface would come from the lights-off photos only (geom_on < 1) takes
 * it from the lights-on ones. No lights-on images: lts trains materials and environment only,
 * pdra is skipped (*skip). */
static int check_lighting(struct run *r, enum esr_stage s, int *skip)
{
    *skip = 0;
    /* r->cfg is the run's own (mutable) copy; the accessor hands out const views */
    struct esr_stage_config *opt = (struct esr_stage_config *)esr_stage_options(&r->cfg, s);
    if (r->rays.n_off == 0 && opt->geom_on < 1.0f) {
        say(r, s, "no lights-off training images: stage %s shapes the surface from the "
                  "lights-on ones (%s.geom_on 1)", esr_stage_name(s), esr_stage_name(s));
        opt->geom_on = 1.0f;
    }
    if (!esr_stage_info(s)->lts_loss)
        return ESR_OK;
    const size_t n_on = r->rays.n - r->rays.n_off;
    if (n_on > 0) /* and lights-off ones: esr_train_run refused the run before any stage else */
        return ESR_OK;
    if (esr_stage_info(s)->ray_groups) {
        say(r, s, "no lights-on training images: no emitters to find, stage %s skipped",
            esr_stage_name(s));
        *skip = 1;
    } else {
        say(r, s, "no lights-on training images: stage %s trains materials and the environment "
                  "only (emission 0: no emission field, no lights-on term)", esr_stage_name(s));
        r->cfg.emission = 0; /* the stage's model takes it from here (and its checkpoint keeps it) */
    }
    return ESR_OK;
}

/* Model for stage s: the checkpoint when resuming, else a fresh one from prev. */
static int stage_model(struct run *r, enum esr_stage s, const struct esr_model *prev,
                       struct esr_model *m)
{
    char path[4200];
    ckpt_path(r, s, path, sizeof path);
    if (r->o->resume && esr_file_exists(path)) {
        ESR_TRY(esr_model_load(m, path));
        for (int a = 0; a < 3; a++) /* its grids lie over its box: the next stage's must too */
            if (fabsf(m->scene_min[a] - r->scene_min[a]) > 1e-5f || fabsf(m->scene_max[a] - r->scene_max[a]) > 1e-5f) {
                const int rc = ESR_FAIL("%s was trained over the scene box [%g, %g, %g] .. [%g, %g, %g], the "
                                        "dataset's is [%g, %g, %g] .. [%g, %g, %g] (a non-cubic box is "
                                        "widened to a cube since 2026-11-27): train into a new RUN",
                                        path, (double)m->scene_min[0], (double)m->scene_min[1],
                                        (double)m->scene_min[2], (double)m->scene_max[0],
                                        (double)m->scene_max[1], (double)m->scene_max[2],
                                        (double)r->scene_min[0], (double)r->scene_min[1],
                                        (double)r->scene_min[2], (double)r->scene_max[0],
                                        (double)r->scene_max[1], (double)r->scene_max[2]);
                esr_model_free(m);
                return rc;
            }
        say(r, s, "resuming stage %s from %s (iteration %ld%s)", esr_stage_name(s), path, m->step,
            m->stage_done ? ", finished" : "");
        /* a --set of how this stage trains (its iterations, learning rates) changes nothing
         * once it is trained; its sizes may still shape the stages after it */
        const size_t len = strlen(esr_stage_name(s));
        for (int i = 0; m->stage_done && i < r->o->n_resume_set; i++)
            if (!strncmp(r->o->resume_set[i], esr_stage_name(s), len) &&
                r->o->resume_set[i][len] == '.' &&
                (!strncmp(r->o->resume_set[i] + len + 1, "iters=", 6) ||
                 !strncmp(r->o->resume_set[i] + len + 1, "lr_", 3)))
                say(r, s, "resume: %s changes nothing: stage %s is finished (its checkpoint is "
                          "kept; train it again from a copy without its checkpoint)",
                    r->o->resume_set[i], esr_stage_name(s));
        return ESR_OK;
    }
    size_t need, n_params;
    ESR_TRY(esr_model_memory_need(&r->cfg, s, prev, r->scene_min, r->scene_max, &need, &n_params));
    char what[160];
    snprintf(what, sizeof what, "the %s stage's model (%zu parameters)", esr_stage_name(s), n_params);
    ESR_TRY(esr_limits_check_memory(esr_ray_set_bytes(r->rays.n) + (prev ? esr_model_memory_held(prev) : 0),
                                    need, what));
    ESR_TRY(esr_model_init(m, &r->cfg, s, prev, r->scene_min, r->scene_max));
    if (!esr_model_has(m, ESR_COMP_ENV) || (prev && esr_model_has(prev, ESR_COMP_ENV)))
        return ESR_OK;
    /* a fresh environment map: its starting brightness and colour (train/env_init.h) */
    float level[3] = {m->cfg.env_level, m->cfg.env_level, m->cfg.env_level}, surface[3];
    int rc = ESR_OK;
    if (level[0] <= 0.0f && prev && r->rays.n_off > 0) {
        const struct esr_env_init_rays er = {r->rays.orig3, r->rays.dir3, r->rays.rgb3, r->rays.n_off};
        rc = esr_env_init_level(prev, &er, (uint64_t)r->cfg.seed, m->cfg.env_from_photos, level, surface);
        if (rc == ESR_OK)
            say(r, s, "environment map starts at mean radiance %.3g %.3g %.3g, derived from the "
                      "data: the lights-off surfaces' mean radiance %.3g %.3g %.3g (%s) / %.1f (a "
                      "scene that averages grey)",
                level[0], level[1], level[2], (double)surface[0], (double)surface[1],
                (double)surface[2], m->cfg.env_from_photos ? "the photos' pixels" : "as the fine model renders them",
                (double)ESR_ENV_INIT_AV);
    }
    if (rc == ESR_OK && level[0] > 0.0f)
        esr_env_sg_set_level(esr_model_values(m, ESR_COMP_ENV), m->cfg.env_lobes, level);
    if (rc != ESR_OK)
        esr_model_free(m);
    return rc;
}

/* RUN/run.json records the absolute dataset path so that `esr render/eval/export RUN` find the
 * data without --data (eval/run_dir.h reads it). Rewritten on resume: the data may have moved;
 * a resumed run on another dataset than the one recorded is said (its earlier stages learned
 * that one). */
static int write_run_record(struct run *r)
{
    const char *run_dir = r->o->run_dir, *data_dir = r->o->data_dir;
    char abs[PATH_MAX];
    if (!realpath(data_dir, abs))
        return ESR_FAIL("dataset %s: %s", data_dir, strerror(errno));
    char path[4200];
    snprintf(path, sizeof path, "%s/run.json", run_dir);
    unsigned char *text;
    size_t size;
    if (r->o->resume && esr_file_exists(path) && esr_file_read_all(path, &text, &size) != ESR_OK) {
        esr_error_clear(); /* an unreadable old record is only replaced */
    } else if (r->o->resume && esr_file_exists(path)) {
        cJSON *old = cJSON_ParseWithLength((const char *)text, size);
        const cJSON *d = cJSON_GetObjectItemCaseSensitive(old, "data");
        char was[PATH_MAX]; /* an old path that is gone: the data moved, nothing to say */
        if (cJSON_IsString(d) && realpath(d->valuestring, was) && strcmp(was, abs) != 0)
            say(r, ESR_STAGE_COUNT, "resume: the run's earlier stages were trained on %s; the "
                                    "stages still to train use %s", d->valuestring, abs);
        cJSON_Delete(old);
        free(text);
    }
    cJSON *root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "data", abs);
    return esr_json_write_atomic(path, root);
}

/* The checkpoint files in RUN, by name, as "ckpt_alphamask.bin, ckpt_coarse.bin" into out;
 * 0 when there are none. */
static int run_checkpoints(const struct run *r, char *out, size_t n)
{
    char path[4200];
    out[0] = '\0';
    for (int s = 0; s < ESR_STAGE_COUNT; s++) {
        ckpt_path(r, (enum esr_stage)s, path, sizeof path);
        if (esr_file_exists(path))
            snprintf(out + strlen(out), n - strlen(out), "%s%s", out[0] ? ", " : "",
                     strrchr(path, '/') + 1);
    }
    return out[0] != '\0';
}

/* A run started over in a folder that holds an earlier one: that run's checkpoints go, or a
 * stage this run does not reach would be resumed, rendered or evaluated as this run's; so do the
 * lights listed from its pdra checkpoint and its metrics (the report's training curves would
 * run on from the earlier run's). RUN/log keeps its lines: the new ones follow. */
static int remove_earlier_run(struct run *r)
{
    char path[4200], gone[512];
    run_checkpoints(r, gone, sizeof gone);
    for (int s = 0; s < ESR_STAGE_COUNT; s++) {
        ckpt_path(r, (enum esr_stage)s, path, sizeof path);
        if (esr_file_exists(path) && remove(path) != 0)
            return ESR_FAIL("cannot remove the earlier run's checkpoint %s: %s", path, strerror(errno));
    }
    static const char *const derived[] = {"lights.json", "lights.png", "train_log.jsonl"};
    for (int i = 0; i < 3; i++) {
        snprintf(path, sizeof path, "%s/%s", r->o->run_dir, derived[i]);
        if (esr_file_exists(path) && remove(path) != 0)
            return ESR_FAIL("cannot remove the earlier run's %s: %s", path, strerror(errno));
    }
    if (gone[0])
        say(r, ESR_STAGE_COUNT, "starting over: removed the earlier run's checkpoints in %s (%s; "
                                "`esr train --resume` continues a run instead)", r->o->run_dir, gone);
    return ESR_OK;
}

/* The data's failure line (esr_train_health.psnr_floor): the PSNR of painting every training
 * pixel its lighting's mean colour, plus 3 dB. */
static double psnr_floor(const struct esr_ray_set *rs)
{
    double sq = 0.0;
    const size_t parts[3] = {0, rs->n_off, rs->n};
    for (int g = 0; g < 2; g++) {
        const size_t a = parts[g], b = parts[g + 1];
        if (b <= a)
            continue;
        for (int c = 0; c < 3; c++) {
            double sum = 0.0, sum2 = 0.0;
            for (size_t i = a; i < b; i++) {
                const double v = rs->rgb3[3 * i + c];
                sum += v;
                sum2 += v * v;
            }
            const double mean = sum / (double)(b - a);
            sq += sum2 - mean * sum; /* the squared deviations from the mean, summed */
        }
    }
    const double mse = rs->n > 0 ? sq / (3.0 * (double)rs->n) : 0.0;
    return esr_psnr_from_mse(mse > 1e-12 ? mse : 1e-12) + 3.0;
}

int esr_train_health_problems(const struct esr_train_health *h, char lines[][320], int max)
{
    int n = 0;
    if (!h->short_by_design) { /* a smoke run checks the install, not the reconstruction */
        if (h->trained && h->last_stage >= ESR_STAGE_COARSE && isfinite(h->last_psnr) &&
            h->last_psnr < h->psnr_floor && n < max)
            snprintf(lines[n++], 320, "stage %s ended at a training PSNR of %.1f dB, below this "
                     "dataset's floor of %.1f dB (a constant colour per lighting scores 3 dB "
                     "less): it did not converge (too few iterations, or a learning rate too high)",
                     esr_stage_name(h->last_stage), h->last_psnr, h->psnr_floor);
        if (h->lights_listed > 0 && h->lights_found > 2 * h->lights_listed &&
            h->lights_found >= h->lights_listed + 3 && n < max)
            snprintf(lines[n++], 320, "%d lights found where the dataset describes %d: the "
                     "emission is fragmented (the emitter stages did not converge)",
                     h->lights_found, h->lights_listed);
        else if (h->lights_left_out > 0 && n < max)
            snprintf(lines[n++], 320, "%d lights found and %d more emitting regions left out: "
                     "the emission is fragmented (the emitter stages did not converge)",
                     h->lights_found, h->lights_left_out);
    }
    if (h->nan_recoveries > 0 && n < max)
        snprintf(lines[n++], 320, "%d non-finite loss%s or gradients recovered from (learning "
                 "rate halved each time): check the run's figures", h->nan_recoveries,
                 h->nan_recoveries == 1 ? "" : "es");
    return n;
}

/* The run's options and training rays. The options, the dataset and every training image are
 * checked before anything is written: a bad dataset leaves a new RUN folder uncreated and an
 * existing run's config.json and run.json as they were. */
static int setup(struct run *r)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/config.json", r->o->run_dir);
    const int stored = r->o->resume && esr_file_exists(path);
    if (stored) {
        esr_config_defaults(&r->cfg, ESR_PRESET_FAST);
        ESR_TRY(esr_config_load_json(&r->cfg, path));
        /* options changed for the stages still to train (an A/B from one run's checkpoints);
         * a stage already trained keeps its checkpoint, the next starts from it as in a run
         * begun with these options */
        for (int i = 0; i < r->o->n_resume_set; i++)
            ESR_TRY(esr_config_set(&r->cfg, r->o->resume_set[i]));
    }
    if (!stored || r->o->n_resume_set > 0)
        ESR_TRY(esr_config_validate(&r->cfg));
    if (r->cfg.threads > 0)
        omp_set_num_threads(r->cfg.threads);
    struct esr_dataset ds;
    ESR_TRY(esr_dataset_load(r->o->data_dir, &ds));
    for (int a = 0; a < 3; a++) {
        r->scene_min[a] = ds.bbox_min[a];
        r->scene_max[a] = ds.bbox_max[a];
    }
    if (ds.bbox_made_cubic)
        say(r, ESR_STAGE_COUNT, "scene.json's bounding box is not a cube; the model's is its longest side "
                                "about its centre: [%.3g, %.3g, %.3g] .. [%.3g, %.3g, %.3g]",
            (double)ds.bbox_min[0], (double)ds.bbox_min[1], (double)ds.bbox_min[2], (double)ds.bbox_max[0],
            (double)ds.bbox_max[1], (double)ds.bbox_max[2]);
    { /* photos shot at other exposures bias the strengths: said before the minutes of training */
        struct esr_dataset_summary sum;
        esr_dataset_summarise(&ds, &sum);
        esr_dataset_exposure_warnings(&sum, say_warning, r);
    }
    r->health.lights_listed = ds.n_lights;
    int rc = esr_ray_set_build(&r->rays, &ds, ESR_PHASE_TRAIN);
    char root[sizeof ds.root];
    snprintf(root, sizeof root, "%s", ds.root);
    const int width = ds.width, height = ds.height;
    esr_dataset_free(&ds);
    if (rc != ESR_OK)
        return rc;
    /* grids sized to the images (res 0, the smoke preset's): numbers before config.json and the
     * checkpoints record them */
    char grids[512];
    const int resolved = esr_config_resolve_res(&r->cfg, width, height,
                                                r->rays.n_off ? r->rays.n_off : r->rays.n, grids,
                                                sizeof grids);
    /* refused before the geometry stages spend minutes (the emitter stages would stop there),
     * and before anything in RUN changes */
    for (int s = 0; s <= (int)r->o->until; s++)
        if (esr_stage_info((enum esr_stage)s)->lts_loss && r->rays.n_off == 0)
            return ESR_FAIL("stage %s needs lights-off training images to tell emission from "
                            "reflection, and this dataset has none (train with --until fine; "
                            "nothing was trained)", esr_stage_name((enum esr_stage)s));
    /* after the dataset's checks (their message says more), before anything in RUN changes */
    if (!r->o->resume && !r->o->force) { /* a forgotten --resume must not wipe a finished run */
        char held[512];
        if (esr_dir_list_entries(r->o->run_dir, held, sizeof held) > 0)
            return ESR_FAIL("%s is not empty (%s): add --resume to continue the run in it, or "
                            "--force to start over there (its checkpoints are then removed); "
                            "nothing was changed", r->o->run_dir, held);
    }
    ESR_TRY(esr_dir_prepare_output(r->o->run_dir));
    ESR_TRY(esr_dir_lock(r->o->run_dir, "train", &r->lock_fd));
    if (r->o->interrupt && *r->o->interrupt) /* before the earlier run's files go */
        return ESR_FAIL("interrupted before training began: nothing in %s changed",
                        r->o->run_dir);
    if (r->o->resume && !stored) { /* esr demo resumes whatever is there, even nothing */
        char found[512];
        if (run_checkpoints(r, found, sizeof found)) /* copied without their options (an A/B) */
            say(r, ESR_STAGE_COUNT, "resume: %s has no config.json: its checkpoints (%s) are "
                                    "resumed with the options given now, written to config.json",
                r->o->run_dir, found);
        else
            say(r, ESR_STAGE_COUNT, "resume: %s holds no run yet (no config.json): training from "
                                    "the start", r->o->run_dir);
    }
    r->health.psnr_floor = psnr_floor(&r->rays);
    r->health.short_by_design = r->cfg.preset == ESR_PRESET_SMOKE;
    if (!r->o->resume)
        ESR_TRY(remove_earlier_run(r));
    if (!stored || r->o->n_resume_set > 0 || resolved)
        ESR_TRY(esr_config_write_json(&r->cfg, path));
    for (int i = 0; stored && i < r->o->n_resume_set; i++)
        say(r, ESR_STAGE_COUNT, "resume: %s (written to %s)", r->o->resume_set[i], path);
    ESR_TRY(write_run_record(r));
    r->health.started = 1;
    snprintf(r->log_path, sizeof r->log_path, "%s/train_log.jsonl", r->o->run_dir);
    say(r, ESR_STAGE_COUNT, "dataset %s: %zu training rays (%zu lights-off)", root, r->rays.n,
        r->rays.n_off);
    if (resolved)
        say(r, ESR_STAGE_COUNT, "grids: %s", grids);
    if (r->cfg.background == ESR_BACKGROUND_AUTO) {
        r->cfg.background = r->rays.transparent ? ESR_BACKGROUND_WHITE : ESR_BACKGROUND_LEARNED;
        say(r, ESR_STAGE_COUNT, "background: %s", r->rays.transparent
            ? "white (the training images have alpha: rays that leave the scene see white)"
            : "learned (no training image has transparent pixels: photos, whose rays leave the "
              "scene into a room; fields/background.h)");
    }
    return ESR_OK;
}

/* The stage a run starts loading at: on resume, the last one up to --until whose checkpoint RUN
 * holds (its model is whole: a copy of a run that keeps only ckpt_fine.bin trains lts and pdra
 * from it, not everything again from alphamask); else the first. */
static int first_stage(struct run *r)
{
    for (int s = (int)r->o->until; r->o->resume && s > 0; s--) {
        char path[4200];
        ckpt_path(r, (enum esr_stage)s, path, sizeof path);
        if (esr_file_exists(path)) {
            char before[4200];
            ckpt_path(r, (enum esr_stage)(s - 1), before, sizeof before);
            if (!esr_file_exists(before))
                say(r, (enum esr_stage)s, "resume: starting from %s (the earlier stages' "
                                          "checkpoints are not in %s; it holds what they learned)",
                    path, r->o->run_dir);
            return s;
        }
    }
    return 0;
}

int esr_train_run(const struct esr_train_opts *o)
{
    struct run r;
    memset(&r, 0, sizeof r);
    r.o = o;
    r.cfg = o->cfg;
    r.lock_fd = -1;
    int rc = setup(&r);
    struct esr_model prev, cur;
    int have_prev = 0;
    const int first = rc == ESR_OK ? first_stage(&r) : 0;
    for (int s = 0; rc == ESR_OK && s <= (int)o->until; s++) {
        int skip = 0;
        rc = check_lighting(&r, (enum esr_stage)s, &skip);
        if (rc != ESR_OK || skip)
            break;
        if (s < first) /* a later stage's checkpoint holds all the earlier ones learned */
            continue;
        rc = stage_model(&r, (enum esr_stage)s, have_prev ? &prev : NULL, &cur);
        if (have_prev) /* the new stage took what it needs from it */
            esr_model_free(&prev);
        have_prev = 0;
        if (rc != ESR_OK)
            break;
        r.health.last_stage = (enum esr_stage)s;
        if (!cur.stage_done) {
            r.health.trained = 1;
            r.health.last_psnr = NAN;
            rc = run_stage(&r, &cur, (enum esr_stage)s);
        }
        prev = cur;
        have_prev = 1;
        if (rc == ESR_OK && o->interrupt && *o->interrupt && s < (int)o->until)
            rc = ESR_FAIL("interrupted after stage %s: its checkpoint is saved; `esr train "
                          "--resume` continues with the next", esr_stage_name((enum esr_stage)s));
        if (rc != ESR_OK || r.stopped)
            break;
    }
    if (have_prev)
        esr_model_free(&prev);
    esr_ray_set_free(&r.rays);
    esr_dir_unlock(r.lock_fd);
    r.health.nan_recoveries = r.nan_failures;
    if (o->health)
        *o->health = r.health;
    return rc;
}
