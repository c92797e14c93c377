/* The primary-ray benchmark (see bench_ray_path.h). */
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
#include "volume/march.h"

#define BENCH_RES 96
#define BENCH_FEAT 12

const char *esr_render_bench_stage_name(int stage)
{
    static const char *names[ESR_RENDER_BENCH_STAGE_COUNT] = {"march", "feature", "composite",
                                                              "backward"};
    return stage >= 0 && stage < ESR_RENDER_BENCH_STAGE_COUNT ? names[stage] : NULL;
}

struct bench {
    struct esr_grid gs, gf;
    float *sdf, *feat, *g_sdf, *g_feat;
    struct esr_mask mask;
    struct esr_march mc;
    struct esr_march_geometry geom;
    float *orig, *dir, *rgb, *d_out;
    size_t cap_rows;
    float *fv, *col, *d_col, *d_fv; /* per kept row */
};

static void free_rows(struct bench *b)
{
    float *bufs[] = {b->fv, b->col, b->d_col, b->d_fv};
    for (size_t i = 0; i < sizeof bufs / sizeof bufs[0]; i++)
        free(bufs[i]);
    b->fv = b->col = b->d_col = b->d_fv = NULL;
    b->cap_rows = 0;
}

static int grow_rows(struct bench *b, size_t n)
{
    if (n <= b->cap_rows)
        return ESR_OK;
    free_rows(b);
    b->fv = malloc(n * BENCH_FEAT * sizeof(float));
    b->d_fv = malloc(n * BENCH_FEAT * sizeof(float));
    b->col = malloc(n * 3 * sizeof(float));
    b->d_col = malloc(n * 3 * sizeof(float));
    if (!b->fv || !b->d_fv || !b->col || !b->d_col)
        return ESR_FAIL("render bench: out of memory for %zu kept rows", n);
    b->cap_rows = n;
    return ESR_OK;
}

static void bench_free(struct bench *b)
{
    esr_mask_free(&b->mask);
    esr_march_free(&b->mc);
    free_rows(b);
    float *bufs[] = {b->sdf, b->feat, b->g_sdf, b->g_feat, b->orig, b->dir, b->rgb, b->d_out};
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
    b->sdf = malloc(ns * sizeof(float));
    b->g_sdf = calloc(ns, sizeof(float));
    b->feat = malloc(nf * sizeof(float));
    b->g_feat = calloc(nf, sizeof(float));
    b->orig = malloc((size_t)n_rays * 3 * sizeof(float));
    b->dir = malloc((size_t)n_rays * 3 * sizeof(float));
    b->rgb = malloc((size_t)n_rays * 3 * sizeof(float));
    b->d_out = malloc((size_t)n_rays * 3 * sizeof(float));
    if (!b->sdf || !b->g_sdf || !b->feat || !b->g_feat || !b->orig || !b->dir || !b->rgb || !b->d_out)
        return ESR_FAIL("render bench: out of memory for %d rays", n_rays);
    ESR_TRY(esr_sdf_init_sphere(&b->gs, b->sdf, 0.5f));
    for (size_t i = 0; i < nf; i++)
        b->feat[i] = (float)(i % 7) * 0.1f;
    for (int i = 0; i < n_rays * 3; i++)
        b->d_out[i] = 0.01f;
    ESR_TRY(esr_mask_alloc(&b->mask, &b->gs));
    ESR_TRY(esr_mask_from_sdf(&b->mask, &b->gs, b->sdf, 0.1f, 1));
    ESR_TRY(esr_march_init(&b->mc, n_rays, 1));
    b->geom.alpha = ESR_MARCH_NEUS;
    b->geom.grid = &b->gs;
    b->geom.values = b->sdf;
    b->geom.inv_s = 64.0f;
    b->geom.step = 0.5f * esr_grid_voxel_size(&b->gs, 0);
    b->geom.mask = &b->mask;
    for (int a = 0; a < 3; a++) {
        b->geom.bmin[a] = bmin[a];
        b->geom.bmax[a] = bmax[a];
    }
    make_rays(b, n_rays);
    return ESR_OK;
}

/* One forward + backward pass; t[] gets each stage's time in ms. */
static int run_once(struct bench *b, int n_rays, uint64_t seed, double *t)
{
    struct esr_march *mc = &b->mc;
    struct esr_march_rays rays;
    memset(&rays, 0, sizeof rays);
    rays.n = n_rays;
    rays.origins = b->orig;
    rays.dirs = b->dir;
    rays.seed = seed;
    rays.jitter = 1;
    double t0 = omp_get_wtime();
    ESR_TRY(esr_march_fwd(mc, &b->geom, &rays));
    double t1 = omp_get_wtime();
    const size_t nk = mc->n_kept;
    ESR_TRY(grow_rows(b, nk));
    esr_grid_sample_fwd(&b->gf, b->feat, mc->kpos3, nk, b->fv);
    double t2 = omp_get_wtime();
    /* "colour" is the first 3 feature channels (a stand-in for the colour head) */
#pragma omp parallel for schedule(static)
    for (size_t k = 0; k < nk; k++)
        for (int c = 0; c < 3; c++)
            b->col[k * 3 + c] = b->fv[k * BENCH_FEAT + c];
    static const float white[3] = {1.0f, 1.0f, 1.0f};
    struct esr_composite_args a;
    esr_march_composite_args(mc, b->col, 3, white, 0, &a);
    esr_composite_fwd(&a, b->rgb);
    double t3 = omp_get_wtime();
    esr_march_zero_d_alpha(mc);
    memset(b->d_col, 0, nk * 3 * sizeof(float));
    esr_composite_bwd(&a, b->d_out, mc->d_alpha, b->d_col);
    esr_march_bwd(mc, b->g_sdf);
#pragma omp parallel for schedule(static)
    for (size_t k = 0; k < nk; k++)
        for (int c = 0; c < BENCH_FEAT; c++)
            b->d_fv[k * BENCH_FEAT + c] = c < 3 ? b->d_col[k * 3 + c] : 0.0f;
    esr_grid_sample_bwd(&b->gf, mc->kpos3, nk, b->d_fv, b->g_feat);
    double t4 = omp_get_wtime();
    const double dt[ESR_RENDER_BENCH_STAGE_COUNT] = {t1 - t0, t2 - t1, t3 - t2, t4 - t3};
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
        rc = run_once(&b, n_rays, (uint64_t)r, t);
        for (int s = 0; rc == ESR_OK && r > 0 && s < ESR_RENDER_BENCH_STAGE_COUNT; s++)
            res->ms[s] = r == 1 ? t[s] : fmin(res->ms[s], t[s]);
    }
    if (rc == ESR_OK) {
        res->threads = omp_get_max_threads();
        res->n_rays = n_rays;
        res->samples = (double)b.mc.smp.count;
        res->kept = (double)b.mc.n_kept;
        double fwd = 0.0, all = 0.0;
        for (int s = 0; s < ESR_RENDER_BENCH_STAGE_COUNT; s++) {
            all += res->ms[s];
            if (s != ESR_RENDER_BENCH_BACKWARD)
                fwd += res->ms[s];
        }
        res->fwd_points_per_s = res->samples / (fwd * 1e-3);
        res->total_points_per_s = res->samples / (all * 1e-3);
        res->rays_per_s = (double)n_rays / (all * 1e-3);
    }
    bench_free(&b);
    return rc;
}
