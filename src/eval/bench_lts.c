/* LTS estimators against the faithful one on a trained checkpoint (see bench_lts.h). */
#include "eval/bench_lts.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "fields/grid.h"
#include "io/camera.h"
#include "io/dataset.h"
#include "model/trace.h"
#include "train/lts.h"

#define REF_CALLS 16
#define REF_DIRS 256
#define POINTS 100
/* a point is a kept sample of weight at least this (the ray reaches a surface there) */
#define SURFACE_WEIGHT 0.3f

/* The estimators compared: the fast default, the faithful one, and the fast one at the faithful
 * direction count (separates the first hit's bias from the direction count's variance). */
static const struct {
    const char *name;
    int estimator, dirs;
} rows[] = {
    {"first_hit_cosine_32", ESR_LTS_FIRST_HIT, 32},
    {"first_hit_cosine_256", ESR_LTS_FIRST_HIT, 256},
    {"volume_uniform_256", ESR_LTS_VOLUME, 256},
};

struct points {
    int n;
    float pos3[POINTS * 3], dir3[POINTS * 3];
};

/* Surface points seen from the first test_nv (else train) camera, spread over the image. */
static int pick_points(const struct esr_model *m, const struct esr_dataset *ds, struct points *pt)
{
    const struct esr_phase *ph = &ds->phases[ESR_PHASE_TEST_NV];
    if (!ph->present || ph->n_frames < 1)
        ph = &ds->phases[ESR_PHASE_TRAIN];
    if (!ph->present || ph->n_frames < 1)
        return ESR_FAIL("bench lts: dataset %s has no camera to pick points from", ds->root);
    const struct esr_camera *cam = &ph->frames[0].camera;
    const int n = cam->width * cam->height;
    float *o = malloc((size_t)n * 3 * sizeof(float)), *d = malloc((size_t)n * 3 * sizeof(float));
    uint8_t *on = calloc((size_t)n, 1);
    struct esr_trace t;
    int rc = o && d && on ? ESR_OK : ESR_FAIL("bench lts: out of memory for %d rays", n);
    if (rc == ESR_OK)
        rc = esr_trace_init(&t, m, n, 0);
    if (rc == ESR_OK) {
        esr_camera_pixel_rays(cam, o, d);
        rc = esr_trace_fwd(&t, m, esr_model_values(m, ESR_COMP_SDF), o, d, on, n, 1);
        /* per ray its strongest kept sample; rays with one above SURFACE_WEIGHT, evenly spaced */
        const struct esr_march *mc = &t.march;
        size_t *best = rc == ESR_OK ? malloc((size_t)n * sizeof(size_t)) : NULL;
        int nc = 0; /* best[0..nc): the qualifying rays' strongest samples */
        for (int r = 0; best && r < n; r++)
            nc += esr_march_strongest_kept(mc, r, &best[nc]) >= SURFACE_WEIGHT;
        if (rc == ESR_OK && !best)
            rc = ESR_FAIL("bench lts: out of memory");
        else if (rc == ESR_OK && nc < POINTS)
            rc = ESR_FAIL("bench lts: only %d pixels reach a surface (need %d)", nc, POINTS);
        pt->n = 0;
        for (int i = 0; rc == ESR_OK && i < POINTS; i++) {
            const size_t k = best[(size_t)i * (size_t)nc / POINTS];
            memcpy(pt->pos3 + i * 3, mc->kpos3 + k * 3, 3 * sizeof(float));
            memcpy(pt->dir3 + i * 3, mc->kdir3 + k * 3, 3 * sizeof(float));
            pt->n++;
        }
        free(best);
        esr_trace_free(&t);
    }
    free(o);
    free(d);
    free(on);
    return rc;
}

/* `calls` LTS calls of one estimator on the points; est[call][point][6] = the camera direction's
 * L^_off, L^_emo. Times the calls. */
static int run_calls(struct esr_model *m, const struct points *pt, int estimator, int dirs,
                     int calls, uint64_t seed0, float *est, struct esr_bench_lts_row *row)
{
    struct esr_lts l;
    ESR_TRY(esr_lts_init_sized(&l, m, pt->n, dirs, estimator));
    const size_t ns = esr_grid_count(esr_model_grid(m, ESR_COMP_SDF));
    float *grads = calloc(m->params.count, sizeof(float)), *g_sdf = calloc(ns, sizeof(float));
    int rc = grads && g_sdf ? ESR_OK : ESR_FAIL("bench lts: out of memory for the gradients");
    /* the points as a kept list of P rows: the stratified pick takes each once */
    struct esr_march mc;
    memset(&mc, 0, sizeof mc);
    mc.n_kept = (size_t)pt->n;
    mc.kpos3 = (float *)pt->pos3;
    mc.kdir3 = (float *)pt->dir3;
    double secs = 0.0, secondary = 0.0, hits = 0.0;
    for (int c = -1; rc == ESR_OK && c < calls; c++) { /* call -1 warms up, untimed */
        struct esr_lts_stats st;
        const struct esr_lts_batch lb = {&mc, NULL, seed0 + (uint64_t)(c + 1) * 7919u};
        const double t0 = omp_get_wtime();
        rc = esr_lts_run(&l, m, esr_model_values(m, ESR_COMP_SDF), g_sdf, grads, &lb, &st);
        if (c < 0)
            continue;
        secs += omp_get_wtime() - t0;
        secondary += (double)st.secondary;
        hits += (double)st.hits;
        for (int p = 0; rc == ESR_OK && p < pt->n; p++)
            memcpy(est + ((size_t)c * (size_t)pt->n + (size_t)p) * 6, l.hat3 + (size_t)p * 12,
                   6 * sizeof(float));
    }
    if (row && rc == ESR_OK) {
        row->ms_per_call = 1e3 * secs / calls;
        row->secondary_per_s = secondary / secs;
        row->hit_frac = hits / fmax(secondary, 1.0);
    }
    free(grads);
    free(g_sdf);
    esr_lts_free(&l);
    return rc;
}

/* Mean over calls of est, per point and value; NaN where any call had none. */
static void mean_of(const float *est, int calls, int n, double *mean)
{
    for (int i = 0; i < n * 6; i++) {
        double s = 0.0;
        for (int c = 0; c < calls; c++)
            s += est[(size_t)c * (size_t)n * 6 + (size_t)i];
        mean[i] = s / calls;
    }
}

/* RMS over points of the per-call standard deviation of est around mean, off and emo ([2]),
 * and the sum of squared differences of mean from ref (bias2, NULL: not wanted). Points without
 * an estimate (NaN) are skipped. Divided by 3 x the points counted. */
static void spread(const float *est, int calls, int n, const double *mean, const double *ref,
                   double sd[2], double bias[2])
{
    double b[2] = {0, 0}, v[2] = {0, 0};
    int cnt = 0;
    for (int p = 0; p < n; p++) {
        if (!isfinite(mean[p * 6]) || (ref && !isfinite(ref[p * 6])))
            continue;
        cnt++;
        for (int i = 0; i < 6; i++) {
            if (ref)
                b[i / 3] += (mean[p * 6 + i] - ref[p * 6 + i]) * (mean[p * 6 + i] - ref[p * 6 + i]);
            double var = 0.0;
            for (int c = 0; c < calls; c++) {
                const double x = est[((size_t)c * (size_t)n + (size_t)p) * 6 + (size_t)i];
                var += (x - mean[p * 6 + i]) * (x - mean[p * 6 + i]);
            }
            v[i / 3] += var / (calls - 1);
        }
    }
    const double n3 = 3.0 * (cnt > 0 ? cnt : 1);
    for (int t = 0; t < 2; t++) {
        sd[t] = sqrt(v[t] / n3);
        if (bias)
            bias[t] = sqrt(b[t] / n3);
    }
}

int esr_bench_lts(const char *ckpt, const char *data_dir, int repeats,
                  struct esr_bench_lts_result *r)
{
    memset(r, 0, sizeof(*r));
    if (repeats < 2)
        return ESR_FAIL("bench lts: at least 2 calls per estimator (got %d)", repeats);
    struct esr_model m;
    ESR_TRY(esr_model_load(&m, ckpt));
    /* off the normal SDF's refresh period: the warm-up call computes it once for all */
    m.step = 1;
    struct esr_dataset ds;
    memset(&ds, 0, sizeof ds);
    int rc = esr_stage_info((enum esr_stage)m.stage)->lts_loss
                 ? ESR_OK
                 : ESR_FAIL("bench lts: %s is a %s checkpoint; the estimators need lts or pdra",
                            ckpt, esr_stage_name((enum esr_stage)m.stage));
    if (rc == ESR_OK)
        rc = esr_dataset_load(data_dir, &ds);
    struct points pt;
    if (rc == ESR_OK)
        rc = pick_points(&m, &ds, &pt);
    const int calls_max = repeats > REF_CALLS ? repeats : REF_CALLS;
    float *est = malloc((size_t)calls_max * POINTS * 6 * sizeof(float));
    double *ref = malloc(POINTS * 6 * sizeof(double)), *mean = malloc(POINTS * 6 * sizeof(double));
    if (rc == ESR_OK && (!est || !ref || !mean))
        rc = ESR_FAIL("bench lts: out of memory");
    if (rc == ESR_OK)
        rc = run_calls(&m, &pt, ESR_LTS_VOLUME, REF_DIRS, REF_CALLS, 1000003, est, NULL);
    double ref_sd[2] = {0, 0};
    if (rc == ESR_OK) {
        mean_of(est, REF_CALLS, pt.n, ref);
        spread(est, REF_CALLS, pt.n, ref, NULL, ref_sd, NULL);
        snprintf(r->stage, sizeof r->stage, "%s", esr_stage_name((enum esr_stage)m.stage));
        r->points = pt.n;
        r->repeats = repeats;
        r->ref_dirs = REF_CALLS * REF_DIRS;
        double s[2] = {0, 0};
        int cnt = 0;
        for (int p = 0; p < pt.n; p++) {
            if (!isfinite(ref[p * 6]))
                continue; /* the camera direction faces away from the normal */
            cnt++;
            for (int i = 0; i < 6; i++)
                s[i / 3] += ref[p * 6 + i] * ref[p * 6 + i];
        }
        r->ref_rms_off = sqrt(s[0] / (3.0 * cnt));
        r->ref_rms_emo = sqrt(s[1] / (3.0 * cnt));
    }
    for (size_t e = 0; rc == ESR_OK && e < sizeof rows / sizeof rows[0]; e++) {
        struct esr_bench_lts_row *row = &r->rows[r->n_rows++];
        snprintf(row->name, sizeof row->name, "%s", rows[e].name);
        row->estimator = rows[e].estimator;
        row->dirs = rows[e].dirs;
        rc = run_calls(&m, &pt, rows[e].estimator, rows[e].dirs, repeats, 7, est, row);
        if (rc != ESR_OK)
            break;
        mean_of(est, repeats, pt.n, mean);
        double sd[2], bias[2];
        spread(est, repeats, pt.n, mean, ref, sd, bias);
        const double rms[2] = {fmax(r->ref_rms_off, 1e-12), fmax(r->ref_rms_emo, 1e-12)};
        row->bias_off = bias[0] / rms[0];
        row->bias_emo = bias[1] / rms[1];
        row->sd_off = sd[0] / rms[0];
        row->sd_emo = sd[1] / rms[1];
        /* what the bias reads from noise alone: both means' standard errors */
        for (int t = 0; t < 2; t++) {
            const double v = sd[t] * sd[t] / repeats + ref_sd[t] * ref_sd[t] / REF_CALLS;
            (t ? &row->noise_emo : &row->noise_off)[0] = sqrt(v) / rms[t];
        }
    }
    free(est);
    free(ref);
    free(mean);
    esr_dataset_free(&ds);
    esr_model_free(&m);
    return rc;
}
