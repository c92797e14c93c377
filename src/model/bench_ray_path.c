/* The primary-ray benchmark (see bench.h). */
#include "model/bench_ray_path.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/rng.h"
#include "fields/grid.h"
#include "fields/mask.h"
#include "fields/sdf.h"
#include "volume/composite.h"
#include "volume/neus.h"
#include "volume/sampler.h"

#define BENCH_RES 96
#define BENCH_FEAT 12
#define BENCH_MAX_PER_RAY 256

const char *esr_render_bench_stage_name(int stage)
{
    static const char *names[ESR_RENDER_BENCH_STAGE_COUNT] = {"sample", "sdf", "feature", "alpha",
                                                              "composite", "backward"};
    return stage >= 0 && stage < ESR_RENDER_BENCH_STAGE_COUNT ? names[stage] : NULL;
}

struct bench {
    struct esr_grid gs, gf;
    float *sdf, *feat, *g_sdf, *g_feat;
    struct esr_mask mask;
    struct esr_samples smp;
    struct esr_sample_params sp;
    float *orig, *dir;
    /* per sample */
    float *f, *grad, *fv, *col, *fp, *fn, *alpha, *w, *d_alpha, *d_col, *d_fv, *d_f, *d_grad;
    float *t_last, *rgb, *d_out;
    float s;
};

static void bench_free(struct bench *b)
{
    esr_mask_free(&b->mask);
    esr_samples_free(&b->smp);
    float *bufs[] = {b->sdf, b->feat, b->g_sdf, b->g_feat, b->orig, b->dir, b->f, b->grad, b->fv,
                     b->col, b->fp, b->fn, b->alpha, b->w, b->d_alpha, b->d_col, b->d_fv, b->d_f,
                     b->d_grad,
                     b->t_last, b->rgb, b->d_out};
    for (size_t i = 0; i < sizeof(bufs) / sizeof(bufs[0]); i++)
        free(bufs[i]);
}

/* Cameras on the radius-4 sphere aiming near the origin, like the dataset. */
static void make_rays(struct bench *b, int n)
{
    for (int r = 0; r < n; r++) {
        struct esr_rng rng = esr_rng_init(7, (uint64_t)r);
        float z = 0.2f + 0.7f * esr_rng_float(&rng), phi = 6.2831853f * esr_rng_float(&rng);
        float rho = sqrtf(1.0f - z * z), *o = b->orig + r * 3, *d = b->dir + r * 3;
        o[0] = 4.0f * rho * cosf(phi);
        o[1] = 4.0f * rho * sinf(phi);
        o[2] = 4.0f * z;
        float len = 0.0f;
        for (int a = 0; a < 3; a++) {
            d[a] = 0.8f * (esr_rng_float(&rng) - 0.5f) - o[a];
            len += d[a] * d[a];
        }
        for (int a = 0; a < 3; a++)
            d[a] /= sqrtf(len);
    }
}

static int bench_setup(struct bench *b, int n_rays)
{
    const float bmin[3] = {-1.5f, -1.5f, -1.5f}, bmax[3] = {1.5f, 1.5f, 1.5f};
    ESR_TRY(esr_grid_init(&b->gs, 1, BENCH_RES, BENCH_RES, BENCH_RES, bmin, bmax));
    ESR_TRY(esr_grid_init(&b->gf, BENCH_FEAT, BENCH_RES, BENCH_RES, BENCH_RES, bmin, bmax));
    size_t ns = esr_grid_count(&b->gs), nf = esr_grid_count(&b->gf);
    size_t cap = (size_t)n_rays * BENCH_MAX_PER_RAY;
    b->sdf = malloc(ns * sizeof(float));
    b->g_sdf = calloc(ns, sizeof(float));
    b->feat = malloc(nf * sizeof(float));
    b->g_feat = calloc(nf, sizeof(float));
    b->orig = malloc((size_t)n_rays * 3 * sizeof(float));
    b->dir = malloc((size_t)n_rays * 3 * sizeof(float));
    float **per[] = {&b->f, &b->fp, &b->fn, &b->alpha, &b->w, &b->d_alpha, &b->d_f};
    for (size_t i = 0; i < sizeof(per) / sizeof(per[0]); i++)
        *per[i] = malloc(cap * sizeof(float));
    float **per3[] = {&b->grad, &b->d_grad, &b->col, &b->d_col};
    for (size_t i = 0; i < sizeof(per3) / sizeof(per3[0]); i++)
        *per3[i] = malloc(cap * 3 * sizeof(float));
    b->fv = malloc(cap * BENCH_FEAT * sizeof(float));
    b->d_fv = malloc(cap * BENCH_FEAT * sizeof(float));
    b->t_last = malloc((size_t)n_rays * sizeof(float));
    b->rgb = malloc((size_t)n_rays * 3 * sizeof(float));
    b->d_out = malloc((size_t)n_rays * 3 * sizeof(float));
    if (!b->sdf || !b->g_sdf || !b->feat || !b->g_feat || !b->orig || !b->dir || !b->f || !b->fv ||
        !b->fp || !b->fn || !b->alpha || !b->w || !b->d_alpha || !b->d_f || !b->grad ||
        !b->d_grad || !b->col || !b->d_col || !b->fv || !b->d_fv || !b->t_last || !b->rgb || !b->d_out)
        return ESR_FAIL("render bench: out of memory for %d rays", n_rays);
    ESR_TRY(esr_sdf_init_sphere(&b->gs, b->sdf, 0.5f));
    for (size_t i = 0; i < nf; i++)
        b->feat[i] = (float)(i % 7) * 0.1f;
    for (int i = 0; i < n_rays * 3; i++)
        b->d_out[i] = 0.01f;
    ESR_TRY(esr_mask_alloc(&b->mask, &b->gs));
    ESR_TRY(esr_mask_from_sdf(&b->mask, &b->gs, b->sdf, 0.1f, 1));
    ESR_TRY(esr_samples_alloc(&b->smp, cap, n_rays));
    esr_sample_params_init(&b->sp, bmin, bmax, 0.5f * esr_grid_voxel_size(&b->gs, 0));
    b->sp.jitter = 1;
    b->sp.max_per_ray = BENCH_MAX_PER_RAY;
    b->sp.mask = &b->mask;
    b->s = 64.0f;
    make_rays(b, n_rays);
    return ESR_OK;
}

static void stage_alpha(struct bench *b)
{
    size_t n = b->smp.count;
    const float dt = b->sp.step;
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++) {
        const float *d = b->dir + (size_t)b->smp.ray[i] * 3, *g = b->grad + i * 3;
        esr_neus_section_fwd(b->f[i], d[0] * g[0] + d[1] * g[1] + d[2] * g[2], dt, 1.0f, &b->fp[i], &b->fn[i]);
        b->alpha[i] = esr_neus_alpha_fwd(b->fp[i], b->fn[i], b->s);
    }
    esr_composite_weights(b->smp.n_rays, b->smp.ray_start, b->alpha, ESR_COMPOSITE_THRES, b->w, b->t_last);
}

static void composite_args(struct bench *b, struct esr_composite_args *a, const float *white)
{
    a->n_rays = b->smp.n_rays;
    a->ray_start = b->smp.ray_start;
    a->alpha = b->alpha;
    a->weight = b->w;
    a->t_last = b->t_last;
    a->thres = ESR_COMPOSITE_THRES;
    a->channels = 3;
    a->values = b->col;
    a->bg = white;
    a->bg_per_ray = 0;
}

static void stage_backward(struct bench *b, const struct esr_composite_args *a)
{
    size_t n = b->smp.count;
    memset(b->d_alpha, 0, n * sizeof(float));
    memset(b->d_col, 0, n * 3 * sizeof(float));
    esr_composite_bwd(a, b->d_out, b->d_alpha, b->d_col);
    const float dt = b->sp.step;
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++) {
        const float *d = b->dir + (size_t)b->smp.ray[i] * 3, *g = b->grad + i * 3;
        float c = d[0] * g[0] + d[1] * g[1] + d[2] * g[2], dp, dn, dc;
        esr_neus_alpha_bwd(b->fp[i], b->fn[i], b->s, b->d_alpha[i], &dp, &dn, NULL);
        esr_neus_section_bwd(c, dt, 1.0f, dp, dn, &b->d_f[i], &dc);
        for (int k = 0; k < 3; k++)
            b->d_grad[i * 3 + k] = dc * d[k];
    }
    esr_grid_sample_value_dpoint_bwd(&b->gs, b->smp.pos, n, b->d_f, b->d_grad, b->g_sdf);
    /* "colour" is the first 3 feature channels (a stand-in for the colour MLP) */
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < BENCH_FEAT; c++)
            b->d_fv[i * BENCH_FEAT + c] = c < 3 ? b->d_col[i * 3 + c] : 0.0f;
    esr_grid_sample_bwd(&b->gf, b->smp.pos, n, b->d_fv, b->g_feat);
}

/* One pass over all stages; adds each stage's time to t[]. */
static int run_once(struct bench *b, int n_rays, double *t)
{
    double t0 = omp_get_wtime();
    ESR_TRY(esr_sample_rays(&b->sp, b->orig, b->dir, n_rays, &b->smp));
    double t1 = omp_get_wtime();
    size_t n = b->smp.count;
    esr_grid_sample_value_dpoint(&b->gs, b->sdf, b->smp.pos, n, b->f, b->grad);
    double t2 = omp_get_wtime();
    esr_grid_sample_fwd(&b->gf, b->feat, b->smp.pos, n, b->fv);
    double t3 = omp_get_wtime();
    stage_alpha(b);
    double t4 = omp_get_wtime();
    const float white[3] = {1.0f, 1.0f, 1.0f};
    struct esr_composite_args a;
    composite_args(b, &a, white);
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++)
            b->col[i * 3 + c] = b->fv[i * BENCH_FEAT + c];
    esr_composite_fwd(&a, b->rgb);
    double t5 = omp_get_wtime();
    stage_backward(b, &a);
    double t6 = omp_get_wtime();
    const double dt[ESR_RENDER_BENCH_STAGE_COUNT] = {t1 - t0, t2 - t1, t3 - t2, t4 - t3, t5 - t4, t6 - t5};
    for (int s = 0; s < ESR_RENDER_BENCH_STAGE_COUNT; s++)
        t[s] = dt[s] * 1e3;
    return ESR_OK;
}

int esr_render_bench(int n_rays, int reps, struct esr_render_bench_result *res)
{
    if (n_rays < 1 || reps < 1)
        return ESR_FAIL("render bench: %d rays and %d repetitions must both be >= 1", n_rays, reps);
    memset(res, 0, sizeof(*res));
    struct bench b;
    memset(&b, 0, sizeof(b));
    int rc = bench_setup(&b, n_rays);
    double t[ESR_RENDER_BENCH_STAGE_COUNT];
    for (int r = 0; rc == ESR_OK && r <= reps; r++) {
        rc = run_once(&b, n_rays, t);
        for (int s = 0; rc == ESR_OK && r > 0 && s < ESR_RENDER_BENCH_STAGE_COUNT; s++)
            res->ms[s] = r == 1 ? t[s] : fmin(res->ms[s], t[s]);
    }
    if (rc == ESR_OK) {
        res->threads = omp_get_max_threads();
        res->n_rays = n_rays;
        res->samples = (double)b.smp.count;
        double fwd = 0.0, all = 0.0;
        for (int s = 0; s < ESR_RENDER_BENCH_STAGE_COUNT; s++) {
            all += res->ms[s];
            if (s != ESR_RENDER_BENCH_BACKWARD)
                fwd += res->ms[s];
        }
        res->fwd_points_per_s = res->samples / (fwd * 1e-3);
        res->total_points_per_s = res->samples / (all * 1e-3);
    }
    bench_free(&b);
    return rc;
}
