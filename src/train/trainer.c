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
#include "core/rng.h"
#include "fields/sdf.h"
#include "io/dataset.h"
#include "io/dir.h"
#include "io/file.h"
#include "io/json_file.h"
#include "nn/adam.h"
#include "nn/guard.h"
#include "nn/schedule.h"
#include "train/rays.h"
#include "train/render_loss.h"
#include "model/render_sdf.h"
#include "model/trace.h"

#define MAX_NAN_FAILURES 3

struct run {
    const struct esr_train_opts *o;
    struct esr_train_config cfg;
    struct esr_ray_set rays;
    float scene_min[3], scene_max[3];
    int nan_failures;
    int nan_injected;
    int stopped; /* the stop_test_iter hook fired */
    char log_path[4096];
};

/* A stage's working buffers, allocated once at stage start. */
struct stage_buf {
    struct esr_trace tr;
    float *orig3, *dir3, *tgt3, *d_rgb3, *d_lin3;
    float *sdf_view, *g_sdf_view, *scratch; /* coarse: smoothed SDF and its gradient */
    float *grad_tv_work;                    /* smoothed-gradient TV work space */
};

struct window {
    double t0, loss, mse, samples, kept;
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

static void ckpt_path(const struct run *r, enum esr_stage s, char *out, size_t n)
{
    snprintf(out, n, "%s/ckpt_%s.bin", r->o->run_dir, esr_stage_name(s));
}

static const struct esr_stage_config *stage_cfg(const struct esr_train_config *c, enum esr_stage s)
{
    return s == ESR_STAGE_ALPHAMASK ? &c->alphamask : s == ESR_STAGE_COARSE ? &c->coarse : &c->fine;
}

static void stage_buf_free(struct stage_buf *b)
{
    esr_trace_free(&b->tr);
    float *bufs[] = {b->orig3, b->dir3, b->tgt3, b->d_rgb3, b->d_lin3, b->sdf_view, b->g_sdf_view,
                     b->scratch, b->grad_tv_work};
    for (size_t i = 0; i < sizeof bufs / sizeof bufs[0]; i++)
        free(bufs[i]);
    memset(b, 0, sizeof(*b));
}

static int stage_buf_init(struct stage_buf *b, const struct esr_model *m, int B)
{
    memset(b, 0, sizeof(*b));
    ESR_TRY(esr_trace_init(&b->tr, m, B, 1));
    float **per_ray[] = {&b->orig3, &b->dir3, &b->tgt3, &b->d_rgb3, &b->d_lin3};
    int ok = 1;
    for (size_t i = 0; i < sizeof per_ray / sizeof per_ray[0]; i++)
        ok &= (*per_ray[i] = malloc((size_t)B * 3 * sizeof(float))) != NULL;
    if (ok && m->stage == ESR_STAGE_COARSE && m->cfg.smooth_ksize > 1) {
        size_t ns = esr_grid_count(&m->sdf);
        ok &= (b->sdf_view = malloc(ns * sizeof(float))) != NULL;
        ok &= (b->g_sdf_view = malloc(ns * sizeof(float))) != NULL;
        ok &= (b->scratch = malloc(ns * sizeof(float))) != NULL;
    }
    if (ok && m->stage != ESR_STAGE_ALPHAMASK && stage_cfg(&m->cfg, m->stage)->tv_sdf_grad > 0.0f)
        ok &= (b->grad_tv_work = malloc(esr_sdf_grad_tv_work(&m->sdf) * sizeof(float))) != NULL;
    if (!ok) {
        stage_buf_free(b);
        return ESR_FAIL("train: out of memory for a batch of %d rays", B);
    }
    return ESR_OK;
}

/* One Adam step over every parameter range of the stage with its learning rate. */
static void adam_all(struct esr_model *m, enum esr_stage s, float lr_scale, long t)
{
    const struct esr_stage_config *sc = stage_cfg(&m->cfg, s);
    struct range {
        size_t off, n;
        float lr;
        int grid;
    } rg[8];
    int n = 0;
    if (s == ESR_STAGE_ALPHAMASK) {
        rg[n++] = (struct range){m->density_off, esr_grid_count(&m->density), sc->lr_grid, 1};
        rg[n++] = (struct range){m->feat_off, esr_grid_count(&m->feat), sc->lr_feat, 1};
    } else if (s == ESR_STAGE_COARSE) {
        rg[n++] = (struct range){m->sdf_off, esr_grid_count(&m->sdf), sc->lr_grid, 1};
        rg[n++] = (struct range){m->feat_off, esr_grid_count(&m->feat), sc->lr_feat, 1};
        rg[n++] = (struct range){m->colour.offset, m->colour.count, sc->lr_mlp, 0};
    } else {
        rg[n++] = (struct range){m->sdf_off, esr_grid_count(&m->sdf), sc->lr_grid, 1};
        rg[n++] = (struct range){m->feat_off_off, esr_grid_count(&m->feat_off_g), sc->lr_feat, 1};
        rg[n++] = (struct range){m->feat_emo_off, esr_grid_count(&m->feat_emo_g), sc->lr_feat, 1};
        rg[n++] = (struct range){m->rad_off.offset, m->rad_off.count, sc->lr_mlp, 0};
        rg[n++] = (struct range){m->rad_emo.offset, m->rad_emo.count, sc->lr_mlp, 0};
        rg[n++] = (struct range){m->tone.offset, m->tone.count, sc->lr_mlp, 0};
    }
    for (int i = 0; i < n; i++) {
        struct esr_adam_hp hp;
        hp.lr = rg[i].lr * lr_scale;
        hp.beta1 = 0.9f;
        hp.beta2 = rg[i].grid ? 0.99f : 0.999f; /* DVGO/Voxurf grids */
        hp.eps = 1e-8f;
        hp.sparse = rg[i].grid;
        esr_adam_step(&hp, t, &m->adam, m->params.w, m->params.g, rg[i].off, rg[i].n);
    }
}

/* Learning-rate factor at step it: exponential decay (alphamask, coarse) or cosine (fine). */
static float lr_factor(const struct esr_stage_config *sc, enum esr_stage s, long it)
{
    if (s == ESR_STAGE_FINE)
        return esr_lr_cosine_factor(it, sc->iters, 0, sc->lr_final);
    return esr_lr_exp_factor(it, sc->iters, sc->lr_final);
}

/* Total-variation regularisers of the stage's grids: gradients added, loss added to *total. */
static int add_tv(struct esr_model *m, const struct stage_buf *b, enum esr_stage s, long it,
                  double *total)
{
    const struct esr_stage_config *sc = stage_cfg(&m->cfg, s);
    const int every = m->cfg.tv_every;
    double l = 0.0;
    if (s == ESR_STAGE_ALPHAMASK || it % every != 0)
        return ESR_OK;
    float *sdf = m->params.w + m->sdf_off, *g_sdf = m->params.g + m->sdf_off;
    if (sc->tv_sdf > 0.0f) {
        ESR_TRY(esr_grid_tv_add_grad(&m->sdf, sdf, sc->tv_sdf * (float)every, g_sdf, &l));
        *total += l;
    }
    if (b->grad_tv_work) {
        /* on the raw SDF, smoothed with the coarse stage's kernel (Voxurf's smooth_grad_tv) */
        int ksize = m->cfg.smooth_ksize > 1 ? m->cfg.smooth_ksize : 1;
        ESR_TRY(esr_sdf_grad_tv_add_grad(&m->sdf, sdf, sc->tv_sdf_grad * (float)every, ksize,
                                         m->cfg.smooth_sigma, b->grad_tv_work, g_sdf, &l));
        *total += l;
    }
    if (sc->tv_feat > 0.0f) {
        const float w = sc->tv_feat * (float)every;
        const struct esr_grid *g[2] = {&m->feat, &m->feat_off_g};
        size_t off[2] = {m->feat_off, m->feat_off_off};
        int ng = s == ESR_STAGE_COARSE ? 1 : 2;
        if (s == ESR_STAGE_FINE) {
            g[0] = &m->feat_off_g;
            off[0] = m->feat_off_off;
            g[1] = &m->feat_emo_g;
            off[1] = m->feat_emo_off;
        }
        for (int i = 0; i < ng; i++) {
            ESR_TRY(esr_grid_tv_add_grad(g[i], m->params.w + off[i], w, m->params.g + off[i], &l));
            *total += l;
        }
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
    char line[512];
    snprintf(line, sizeof line,
             "{\"stage\":\"%s\",\"iter\":%ld,\"loss\":%.6g,\"psnr\":%.3f,\"rays_per_s\":%.0f,"
             "\"samples_per_ray\":%.2f,\"kept_per_ray\":%.2f,\"inv_s\":%.2f}",
             esr_stage_name(s), it, p.loss, p.psnr, p.rays_per_s, p.samples_per_ray,
             p.kept_per_ray, (double)m->inv_s);
    append_jsonl(r, line);
    emit(r, &p);
    memset(w, 0, sizeof(*w));
    w->t0 = now;
}

/* Reloads the stage's last checkpoint into m (same layout) after a NaN. */
static int recover(struct run *r, struct esr_model *m, enum esr_stage s, long it, float *lr_scale)
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
    esr_model_free(&good);
    *lr_scale *= 0.5f;
    say(r, s, "non-finite loss or gradient at %s iteration %ld: reloaded %s (iteration %ld), "
              "learning rate halved (x%g), continuing",
        esr_stage_name(s), it, path, m->step, (double)*lr_scale);
    return ESR_OK;
}

/* Forward + loss + backward + regularisers for iteration it; returns the loss in *loss. */
static int iterate(struct run *r, struct esr_model *m, struct stage_buf *b, enum esr_stage s,
                   long it, struct window *w, double *loss)
{
    const int B = r->cfg.batch_rays;
    int n_off;
    uint64_t seed = esr_mix64((uint64_t)r->cfg.seed * 0x100000001b3ULL + (uint64_t)s);
    esr_ray_set_draw(&r->rays, seed, it, B, b->orig3, b->dir3, b->tgt3, &n_off);
    float *raw = m->params.w + m->sdf_off, *g_raw = m->params.g + m->sdf_off;
    const float *sdf = raw;
    float *g_sdf = g_raw;
    if (b->sdf_view) {
        ESR_TRY(esr_model_view_sdf(m, raw, b->sdf_view, b->scratch));
        sdf = b->sdf_view;
        g_sdf = b->g_sdf_view;
        memset(g_sdf, 0, esr_grid_count(&m->sdf) * sizeof(float));
    }
    esr_nn_params_zero_grad(&m->params, 0, m->params.count);
    ESR_TRY(esr_trace_fwd(&b->tr, m, s == ESR_STAGE_ALPHAMASK ? NULL : sdf, b->orig3, b->dir3, B,
                          n_off, esr_mix64(seed + (uint64_t)it)));
    float lambda = s == ESR_STAGE_FINE ? r->cfg.lambda_tau : 0.0f;
    struct esr_render_loss_result lr;
    esr_render_loss_batch(b->tr.rgb3, b->tr.lin_rgb3, b->tgt3, (size_t)B, lambda, b->d_rgb3,
                          s == ESR_STAGE_FINE ? b->d_lin3 : NULL, &lr);
    ESR_TRY(esr_trace_bwd(&b->tr, m, sdf, g_sdf, m->params.g, b->d_rgb3,
                          s == ESR_STAGE_FINE ? b->d_lin3 : NULL));
    if (b->sdf_view)
        ESR_TRY(esr_grid_smooth_bwd(&m->sdf, b->g_sdf_view, g_raw, b->scratch,
                                    m->cfg.smooth_ksize, m->cfg.smooth_sigma));
    *loss = lr.loss;
    ESR_TRY(add_tv(m, b, s, it, loss));
    w->loss += *loss;
    w->mse += lr.mse_tone;
    w->samples += (double)b->tr.smp.count;
    w->kept += (double)b->tr.n_kept;
    w->iters++;
    return ESR_OK;
}

static int save(struct run *r, const struct esr_model *m, enum esr_stage s)
{
    char path[4200];
    ckpt_path(r, s, path, sizeof path);
    return esr_model_save(m, path);
}

/* Builds the mask cache from the trained density grid. */
static int finish_alphamask(struct run *r, struct esr_model *m)
{
    ESR_TRY(esr_mask_alloc(&m->mask, &m->density));
    m->has_mask = 1;
    ESR_TRY(esr_mask_from_density(&m->mask, &m->density, m->params.w + m->density_off,
                                  m->density_shift, m->cfg.alphamask.step_vox, r->cfg.alpha_thres,
                                  1));
    size_t occ = esr_mask_count(&m->mask), all = esr_grid_voxels(&m->density);
    say(r, ESR_STAGE_ALPHAMASK, "mask cache: %zu of %zu voxels occupied (%.1f%%)", occ, all,
        100.0 * (double)occ / (double)all);
    if (occ == 0) /* later stages would march no samples and learn nothing */
        return ESR_FAIL("alphamask: the mask cache is empty (no voxel reaches alpha_thres %g after "
                        "%d iterations); train the alphamask stage longer or lower alpha_thres",
                        (double)r->cfg.alpha_thres, m->cfg.alphamask.iters);
    return ESR_OK;
}

static int run_stage(struct run *r, struct esr_model *m, enum esr_stage s)
{
    const struct esr_stage_config *sc = stage_cfg(&r->cfg, s);
    const int B = r->cfg.batch_rays;
    struct stage_buf b;
    ESR_TRY(stage_buf_init(&b, m, B));
    int rc = ESR_OK;
    if (m->step == 0)
        rc = save(r, m, s);
    float lr_scale = 1.0f;
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
        m->inv_s = esr_model_inv_s_at(m, it);
        double loss = 0.0;
        rc = iterate(r, m, &b, s, it, &w, &loss);
        if (rc != ESR_OK)
            break;
        if (r->o->nan_test_iter == it && r->nan_injected < r->o->nan_test_times) {
            r->nan_injected++;
            m->params.g[m->params.count / 2] = NAN;
        }
        if (!isfinite(loss) || !esr_nn_all_finite(m->params.g, m->params.count)) {
            rc = recover(r, m, s, it, &lr_scale);
            memset(&w, 0, sizeof w);
            w.t0 = omp_get_wtime();
            continue;
        }
        adam_all(m, s, f * lr_scale, it + 1);
        m->step = it + 1;
        if (m->step % r->cfg.log_every == 0 || m->step == sc->iters)
            report_window(r, m, s, &w, m->step, sc->iters, B);
        if (m->step % r->cfg.save_every == 0 && m->step < sc->iters)
            rc = save(r, m, s);
        if (r->o->stop_test_iter > 0 && s == r->o->stop_test_stage &&
            m->step == r->o->stop_test_iter) {
            r->stopped = 1;
            stage_buf_free(&b);
            return ESR_OK;
        }
    }
    if (rc == ESR_OK && s == ESR_STAGE_ALPHAMASK)
        rc = finish_alphamask(r, m);
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
    stage_buf_free(&b);
    return rc;
}

/* Model for stage s: the checkpoint when resuming, else a fresh one from prev. */
static int stage_model(struct run *r, enum esr_stage s, const struct esr_model *prev,
                       struct esr_model *m)
{
    char path[4200];
    ckpt_path(r, s, path, sizeof path);
    if (r->o->resume && esr_file_exists(path)) {
        ESR_TRY(esr_model_load(m, path));
        say(r, s, "resuming stage %s from %s (iteration %ld%s)", esr_stage_name(s), path, m->step,
            m->stage_done ? ", finished" : "");
        return ESR_OK;
    }
    return esr_model_init(m, &r->cfg, s, prev, r->scene_min, r->scene_max);
}

/* RUN/run.json records the absolute dataset path so that `esr render/eval/export RUN` find the
 * data without --data (eval/run_dir.h reads it). Rewritten on resume: the data may have moved. */
static int write_run_record(const char *run_dir, const char *data_dir)
{
    char abs[PATH_MAX];
    if (!realpath(data_dir, abs))
        return ESR_FAIL("dataset %s: %s", data_dir, strerror(errno));
    char path[4200];
    snprintf(path, sizeof path, "%s/run.json", run_dir);
    cJSON *root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "data", abs);
    return esr_json_write_atomic(path, root);
}

static int setup(struct run *r)
{
    char path[4200];
    ESR_TRY(esr_dir_create(r->o->run_dir));
    snprintf(path, sizeof path, "%s/config.json", r->o->run_dir);
    if (r->o->resume && esr_file_exists(path)) {
        esr_config_defaults(&r->cfg, ESR_PRESET_FAST);
        ESR_TRY(esr_config_load_json(&r->cfg, path));
    } else {
        ESR_TRY(esr_config_validate(&r->cfg));
        ESR_TRY(esr_config_write_json(&r->cfg, path));
    }
    ESR_TRY(write_run_record(r->o->run_dir, r->o->data_dir));
    snprintf(r->log_path, sizeof r->log_path, "%s/train_log.jsonl", r->o->run_dir);
    if (r->cfg.threads > 0)
        omp_set_num_threads(r->cfg.threads);
    struct esr_dataset ds;
    ESR_TRY(esr_dataset_load(r->o->data_dir, &ds));
    for (int a = 0; a < 3; a++) {
        r->scene_min[a] = ds.bbox_min[a];
        r->scene_max[a] = ds.bbox_max[a];
    }
    int rc = esr_ray_set_build(&r->rays, &ds, ESR_PHASE_TRAIN);
    if (rc == ESR_OK)
        say(r, ESR_STAGE_ALPHAMASK, "dataset %s: %zu training rays (%zu lights-off)", ds.root,
            r->rays.n, r->rays.n_off);
    esr_dataset_free(&ds);
    return rc;
}

int esr_train_run(const struct esr_train_opts *o)
{
    struct run r;
    memset(&r, 0, sizeof r);
    r.o = o;
    r.cfg = o->cfg;
    int rc = setup(&r);
    struct esr_model prev, cur;
    int have_prev = 0;
    for (int s = 0; rc == ESR_OK && s <= (int)o->until; s++) {
        rc = stage_model(&r, (enum esr_stage)s, have_prev ? &prev : NULL, &cur);
        if (rc != ESR_OK)
            break;
        if (!cur.stage_done)
            rc = run_stage(&r, &cur, (enum esr_stage)s);
        if (have_prev)
            esr_model_free(&prev);
        prev = cur;
        have_prev = 1;
        if (rc != ESR_OK || r.stopped)
            break;
    }
    if (have_prev)
        esr_model_free(&prev);
    esr_ray_set_free(&r.rays);
    return rc;
}
