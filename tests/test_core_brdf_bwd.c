/* The BRDF's backward pass and its batched estimator (core/brdf.h): esr_brdf_eval_bwd against
 * finite differences of esr_brdf_eval for every material entry, the roughness clamp and the
 * below-surface zero; esr_brdf_reflect_fwd against a loop over esr_brdf_eval;
 * esr_brdf_reflect_bwd against finite differences on the material and on every incident
 * radiance entry, and against a sum of single backward passes.
 *
 * Finite differences: central differences of the float forward, summed in double, at steps h
 * and 2h combined by Richardson extrapolation ((4 D(h) - D(2h)) / 3, truncation error O(h^4)).
 * R is affine in base colour, metallic and incident radiance, so there only rounding remains;
 * roughness is the nonlinear input and takes a step relative to its value. A gradient passes
 * when |analytic - fd| <= rtol max(|analytic|, |fd|) + the rounding floor
 * ROUND_ULPS * FLT_EPSILON * scale / h, scale being the sum of the magnitudes of the terms of
 * the loss (what float rounding of the forward is proportional to). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/brdf.h"
#include "core/rng.h"
#include "core/sampling.h"

#define N_ENTRIES 5   /* base r, g, b, roughness, metallic */
#define ROUND_ULPS 8.0
#define MAX_M 256

static const char *const entry_name[N_ENTRIES] = {"base[0]", "base[1]", "base[2]", "roughness", "metallic"};

static float *entry(struct esr_material *m, int i)
{
    return i < 3 ? &m->base[i] : i == 3 ? &m->roughness : &m->metallic;
}

static float uniform(struct esr_rng *rng, float lo, float hi) { return lo + (hi - lo) * esr_rng_float(rng); }

static struct esr_vec3 random_unit(struct esr_rng *rng)
{
    float u1 = esr_rng_float(rng);
    return esr_sample_sphere_uniform(u1, esr_rng_float(rng));
}

/* A unit direction around n with n.w uniform in [cos_min, 1]. */
static struct esr_vec3 direction_above(struct esr_rng *rng, struct esr_vec3 n, float cos_min)
{
    struct esr_vec3 t, b;
    esr_v3_basis(n, &t, &b);
    float z = uniform(rng, cos_min, 1.0f);
    struct esr_vec3 local = esr_direction_from_polar(z, sqrtf(fmaxf(0.0f, 1.0f - z * z)), esr_rng_float(rng));
    return esr_v3_normalize(esr_v3_from_local(local, t, b, n));
}

static struct esr_material random_material(struct esr_rng *rng, float r_lo, float r_hi)
{
    struct esr_material m;
    for (int c = 0; c < 3; c++)
        m.base[c] = esr_rng_float(rng);
    m.roughness = uniform(rng, r_lo, r_hi);
    m.metallic = esr_rng_float(rng);
    return m;
}

/* A scalar loss of the material, given its context. */
typedef double (*loss_fn)(const struct esr_material *mat, const void *ctx);

/* d loss / d entry i by Richardson-extrapolated central differences at steps h and 2h. */
static double fd_entry(loss_fn loss, const void *ctx, const struct esr_material *mat, int i, float h)
{
    double d[2];
    for (int s = 0; s < 2; s++) {
        struct esr_material plus = *mat, minus = *mat;
        *entry(&plus, i) += h * (float)(s + 1);
        *entry(&minus, i) -= h * (float)(s + 1);
        double dx = (double)*entry(&plus, i) - (double)*entry(&minus, i); /* the step float really took */
        d[s] = (loss(&plus, ctx) - loss(&minus, ctx)) / dx;
    }
    return (4.0 * d[0] - d[1]) / 3.0;
}

/* Per entry (the last slot: incident radiance), the largest relative error |analytic - fd| /
 * max(|analytic|, |fd|) among the checks whose rounding floor is under 1% of that magnitude,
 * and the largest share of its tolerance any check used. */
struct fd_stats {
    double rel[N_ENTRIES + 1], used[N_ENTRIES + 1];
};

/* Whether analytic matches fd within rtol and the rounding floor; records the errors. */
static int fd_agrees(double analytic, double fd, double floor_abs, double rtol, struct fd_stats *st, int slot)
{
    double diff = fabs(analytic - fd), mag = fmax(fabs(analytic), fabs(fd)), allowed = rtol * mag + floor_abs;
    if (floor_abs < 1e-2 * mag)
        st->rel[slot] = fmax(st->rel[slot], diff / mag);
    st->used[slot] = fmax(st->used[slot], diff / allowed);
    if (diff > allowed)
        printf("  mismatch in %s: analytic %.9g, finite difference %.9g (floor %.3g)\n",
               slot < N_ENTRIES ? entry_name[slot] : "li", analytic, fd, floor_abs);
    return diff <= allowed;
}

/* ---------- single evaluation ---------- */

struct eval_ctx {
    struct esr_vec3 n, wo, wi;
    float g[3]; /* d loss / d R */
};

/* sum_c g_c R_c; *scale (when not NULL) = sum_c |g_c R_c|. */
static double eval_loss_scale(const struct esr_material *mat, const struct eval_ctx *ctx, double *scale)
{
    float r[3];
    esr_brdf_eval(mat, ctx->n, ctx->wo, ctx->wi, r);
    double sum = 0.0, mag = 0.0;
    for (int c = 0; c < 3; c++) {
        sum += (double)ctx->g[c] * r[c];
        mag += fabs((double)ctx->g[c] * r[c]);
    }
    if (scale)
        *scale = mag;
    return sum;
}

static double eval_loss(const struct esr_material *mat, const void *ctx) { return eval_loss_scale(mat, ctx, NULL); }

/* Material step for entry i: absolute for the affine entries, relative for roughness. */
static float fd_step(const struct esr_material *mat, int i) { return i == 3 ? 1e-3f * mat->roughness : 1e-2f; }

/* Checks every entry of esr_brdf_eval_bwd at one configuration; returns the failures. */
static int check_eval_config(const struct esr_material *mat, const struct eval_ctx *ctx, double rtol,
                             struct fd_stats *st)
{
    struct esr_material d = {{0, 0, 0}, 0, 0};
    esr_brdf_eval_bwd(mat, ctx->n, ctx->wo, ctx->wi, ctx->g, &d);
    double scale;
    eval_loss_scale(mat, ctx, &scale);
    int failures = 0;
    for (int i = 0; i < N_ENTRIES; i++) {
        float h = fd_step(mat, i);
        double fd = fd_entry(eval_loss, ctx, mat, i, h);
        failures += !fd_agrees(*entry(&d, i), fd, ROUND_ULPS * FLT_EPSILON * scale / h + 1e-12, rtol, st, i);
    }
    return failures;
}

static void print_stats(const char *what, const struct fd_stats *st, int with_li)
{
    printf("%s: worst relative error (share of tolerance used)", what);
    for (int i = 0; i < N_ENTRIES + with_li; i++)
        printf(" %s %.1e (%.2f)", i < N_ENTRIES ? entry_name[i] : "li", st->rel[i], st->used[i]);
    printf("\n");
}

/* Every entry at 3000 random configurations: any normal, wo and wi at least ~6 degrees above
 * the surface (R is smooth in the material at any angle; near-grazing directions only inflate
 * 1 / (4 n.wo) and the rounding with it), roughness in [0.08, 1] (clear of the clamp at 0.02),
 * random d loss / d R of either sign. */
static void test_eval_bwd_matches_finite_differences(void **state)
{
    (void)state;
    struct esr_rng rng = esr_rng_init(21, 0);
    struct fd_stats st = {{0}, {0}};
    int failures = 0;
    for (int it = 0; it < 3000; it++) {
        struct esr_material mat = random_material(&rng, 0.08f, 1.0f);
        struct eval_ctx ctx;
        ctx.n = random_unit(&rng);
        ctx.wo = direction_above(&rng, ctx.n, 0.1f);
        /* half the time wi near the mirror direction, where the specular lobe and its roughness
         * derivative are largest */
        if (it & 1) {
            struct esr_vec3 mirror = esr_v3_sub(esr_v3_scale(ctx.n, 2.0f * esr_v3_dot(ctx.n, ctx.wo)), ctx.wo);
            struct esr_vec3 jitter = esr_v3_scale(random_unit(&rng), 0.5f * mat.roughness * mat.roughness);
            ctx.wi = esr_v3_normalize(esr_v3_add(mirror, jitter));
            if (esr_v3_dot(ctx.n, ctx.wi) < 0.1f)
                ctx.wi = direction_above(&rng, ctx.n, 0.1f);
        } else {
            ctx.wi = direction_above(&rng, ctx.n, 0.1f);
        }
        for (int c = 0; c < 3; c++)
            ctx.g[c] = uniform(&rng, -1.0f, 1.0f);
        failures += check_eval_config(&mat, &ctx, 2e-3, &st);
    }
    print_stats("esr_brdf_eval_bwd vs finite differences", &st, 0);
    assert_int_equal(failures, 0);
}

/* The backward ADDS: a pre-filled gradient keeps its value plus the new one, and two calls give
 * twice the gradient of one. */
static void test_eval_bwd_accumulates(void **state)
{
    (void)state;
    struct esr_material mat = {{0.7f, 0.4f, 0.2f}, 0.4f, 0.3f};
    const struct esr_vec3 n = esr_v3(0, 0, 1), wo = esr_v3(0.6f, 0, 0.8f), wi = esr_v3(-0.48f, 0.6f, 0.64f);
    const float g[3] = {1.0f, -0.5f, 0.25f};
    struct esr_material once = {{0, 0, 0}, 0, 0}, twice = {{0, 0, 0}, 0, 0}, pre = {{1, 2, 3}, 4, 5};
    esr_brdf_eval_bwd(&mat, n, wo, wi, g, &once);
    esr_brdf_eval_bwd(&mat, n, wo, wi, g, &twice);
    esr_brdf_eval_bwd(&mat, n, wo, wi, g, &twice);
    esr_brdf_eval_bwd(&mat, n, wo, wi, g, &pre);
    struct esr_material start = {{1, 2, 3}, 4, 5};
    for (int i = 0; i < N_ENTRIES; i++) {
        assert_true(*entry(&once, i) != 0.0f);
        assert_float_equal(*entry(&twice, i), 2.0f * *entry(&once, i), 1e-6f * fabsf(*entry(&once, i)));
        assert_float_equal(*entry(&pre, i), *entry(&start, i) + *entry(&once, i), 1e-6f * fabsf(*entry(&pre, i)));
    }
}

/* Below ESR_BRDF_MIN_ROUGHNESS the forward is flat in roughness: the gradient is exactly 0 and
 * so is a finite difference that stays below the clamp. At the clamp value itself the gradient
 * flows and equals the one-sided difference from above (the one from below is 0). Just above
 * it, ordinary central differences hold. The other entries are unaffected by the clamp. */
static void test_eval_bwd_roughness_clamp(void **state)
{
    (void)state;
    struct esr_rng rng = esr_rng_init(22, 0);
    struct fd_stats st = {{0}, {0}};
    for (int it = 0; it < 200; it++) {
        struct eval_ctx ctx;
        ctx.n = random_unit(&rng);
        ctx.wo = direction_above(&rng, ctx.n, 0.2f);
        /* within the lobe of the sharpest roughness (2/r^4 = 1.25e7), so its gradient is not 0 */
        struct esr_vec3 mirror = esr_v3_sub(esr_v3_scale(ctx.n, 2.0f * esr_v3_dot(ctx.n, ctx.wo)), ctx.wo);
        ctx.wi = esr_v3_normalize(esr_v3_add(mirror, esr_v3_scale(random_unit(&rng), 2e-4f)));
        for (int c = 0; c < 3; c++)
            ctx.g[c] = uniform(&rng, 0.2f, 1.0f);
        struct esr_material mat = random_material(&rng, 0.0f, 0.019f);
        struct esr_material d = {{0, 0, 0}, 0, 0};
        esr_brdf_eval_bwd(&mat, ctx.n, ctx.wo, ctx.wi, ctx.g, &d);
        assert_true(d.roughness == 0.0f);
        struct esr_material lo = mat, hi = mat;
        lo.roughness = 0.5f * mat.roughness;
        hi.roughness = 0.5f * (mat.roughness + ESR_BRDF_MIN_ROUGHNESS);
        double scale;
        eval_loss_scale(&mat, &ctx, &scale);
        assert_true(eval_loss(&lo, &ctx) == eval_loss(&hi, &ctx));
        for (int i = 0; i < N_ENTRIES; i++)
            if (i != 3)
                assert_true(fd_agrees(*entry(&d, i), fd_entry(eval_loss, &ctx, &mat, i, 1e-2f),
                                      ROUND_ULPS * FLT_EPSILON * scale / 1e-2, 1e-4, &st, i));

        /* at the clamp: one-sided differences, second order (-3 f0 + 4 f(h) - f(2h)) / 2h, to 2%:
         * with 2 / r^4 = 1.25e7 the exponent of D turns each float rounding of r^4 into a
         * relative change of D |arg| times larger, which the rounding floor does not model */
        mat.roughness = ESR_BRDF_MIN_ROUGHNESS;
        memset(&d, 0, sizeof d);
        esr_brdf_eval_bwd(&mat, ctx.n, ctx.wo, ctx.wi, ctx.g, &d);
        const float h = ldexpf(1.0f, -22); /* 128 ulps of 0.02: r + h and r + 2h are exact */
        struct esr_material r1 = mat, r2 = mat, below = mat;
        r1.roughness += h;
        r2.roughness += 2.0f * h;
        below.roughness -= h;
        double f0 = eval_loss_scale(&mat, &ctx, &scale), f1 = eval_loss(&r1, &ctx), f2 = eval_loss(&r2, &ctx);
        double right = (-3.0 * f0 + 4.0 * f1 - f2) / (2.0 * h);
        assert_true(eval_loss(&below, &ctx) == f0); /* flat from below */
        assert_true(d.roughness != 0.0f);
        assert_true(fd_agrees(d.roughness, right, ROUND_ULPS * FLT_EPSILON * scale / h, 2e-2, &st, 3));

        /* just above the clamp: central differences with a step that stays above it */
        mat.roughness = 0.03f;
        assert_int_equal(check_eval_config(&mat, &ctx, 2e-3, &st), 0);
    }
    print_stats("roughness clamp", &st, 0);
}

/* Where wo or wi is at or below the surface R is 0 and the backward adds nothing. */
static void test_eval_bwd_below_surface_is_zero(void **state)
{
    (void)state;
    struct esr_material mat = {{0.5f, 0.5f, 0.5f}, 0.3f, 0.2f};
    const struct esr_vec3 n = esr_v3(0, 0, 1), up = esr_v3(0.6f, 0, 0.8f), down = esr_v3(0.6f, 0, -0.8f);
    const struct esr_vec3 grazing = esr_v3(1, 0, 0);
    const float g[3] = {1, 1, 1};
    const struct esr_vec3 pairs[][2] = {{up, down}, {down, up}, {grazing, up}, {up, grazing}, {down, down}};
    for (size_t i = 0; i < sizeof pairs / sizeof pairs[0]; i++) {
        struct esr_material d = {{1, 2, 3}, 4, 5};
        esr_brdf_eval_bwd(&mat, n, pairs[i][0], pairs[i][1], g, &d);
        assert_true(d.base[0] == 1 && d.base[1] == 2 && d.base[2] == 3 && d.roughness == 4 && d.metallic == 5);
    }
}

/* ---------- batched estimator ---------- */

struct batch {
    int m;
    struct esr_vec3 n, wo;
    float wi[3 * MAX_M], li[3 * MAX_M], weight[MAX_M];
    float g[3]; /* d loss / d out */
};

static struct esr_brdf_incident incident(const struct batch *b)
{
    struct esr_brdf_incident inc = {b->m, b->wi, b->li, b->weight};
    return inc;
}

/* M directions uniform on the sphere (so about half are below the surface, some grazing), one
 * in eight replaced by a direction near the mirror of wo, radiance in [0, 2), weights around
 * 2 pi / M. */
static void random_batch(struct esr_rng *rng, int m, float roughness, struct batch *b)
{
    b->m = m;
    b->n = random_unit(rng);
    b->wo = direction_above(rng, b->n, 0.1f);
    struct esr_vec3 mirror = esr_v3_sub(esr_v3_scale(b->n, 2.0f * esr_v3_dot(b->n, b->wo)), b->wo);
    for (int j = 0; j < m; j++) {
        struct esr_vec3 w = random_unit(rng);
        if (j % 8 == 3)
            w = esr_v3_normalize(esr_v3_add(mirror, esr_v3_scale(w, 0.5f * roughness * roughness)));
        b->wi[j] = w.x;
        b->wi[m + j] = w.y;
        b->wi[2 * m + j] = w.z;
        for (int c = 0; c < 3; c++)
            b->li[c * m + j] = uniform(rng, 0.0f, 2.0f);
        b->weight[j] = uniform(rng, 0.5f, 1.5f) * 2.0f * ESR_PI / (float)m;
    }
    for (int c = 0; c < 3; c++)
        b->g[c] = uniform(rng, -1.0f, 1.0f);
}

static struct esr_vec3 batch_wi(const struct batch *b, int j)
{
    return esr_v3(b->wi[j], b->wi[b->m + j], b->wi[2 * b->m + j]);
}

/* out by a double-precision loop over esr_brdf_eval; *mag[c] = sum_j |li weight R|. */
static void reference_reflect(const struct esr_material *mat, const struct batch *b, double out[3], double mag[3])
{
    for (int c = 0; c < 3; c++)
        out[c] = mag[c] = 0.0;
    for (int j = 0; j < b->m; j++) {
        float r[3];
        esr_brdf_eval(mat, b->n, b->wo, batch_wi(b, j), r);
        for (int c = 0; c < 3; c++) {
            double term = (double)b->li[c * b->m + j] * b->weight[j] * r[c];
            out[c] += term;
            mag[c] += fabs(term);
        }
    }
}

/* Relative tolerance between two float evaluations of R that round differently (vector code
 * with FMA against the scalar path): 1e-5, plus what the lobe makes of the rounding of h.n,
 * which moves the exponent 2 (h.n - 1) / r^4 by 2 / r^4 times a few ulps. */
static double rounding_rtol(float roughness)
{
    double r = fmax(roughness, ESR_BRDF_MIN_ROUGHNESS);
    return 1e-5 + 8.0 * FLT_EPSILON * 2.0 / (r * r * r * r);
}

static const int batch_sizes[] = {1, 2, 3, 7, 8, 9, 31, 37, 64, 255, 256};
#define N_BATCH_SIZES (int)(sizeof batch_sizes / sizeof batch_sizes[0])

/* The batched forward equals the loop over the single evaluation, for sizes around the vector
 * widths (rounding_rtol of the sum of magnitudes; the worst seen is printed relative to that
 * sum); M = 0 and wo below the surface give 0. */
static void test_reflect_fwd_matches_eval_loop(void **state)
{
    (void)state;
    static struct batch b;
    struct esr_rng rng = esr_rng_init(23, 0);
    double worst = 0.0;
    for (int it = 0; it < 40; it++) {
        for (int s = 0; s < N_BATCH_SIZES; s++) {
            struct esr_material mat = random_material(&rng, it < 4 ? 0.0f : 0.05f, 1.0f);
            random_batch(&rng, batch_sizes[s], mat.roughness, &b);
            struct esr_brdf_incident inc = incident(&b);
            float out[3];
            double want[3], mag[3];
            esr_brdf_reflect_fwd(&mat, b.n, b.wo, &inc, out);
            reference_reflect(&mat, &b, want, mag);
            for (int c = 0; c < 3; c++) {
                /* float summation in another order: a few ulps of the sum of magnitudes */
                double err = fabs(out[c] - want[c]) / (rounding_rtol(mat.roughness) * mag[c] + 1e-30);
                worst = fmax(worst, err);
                assert_true(fabs(out[c] - want[c]) <= rounding_rtol(mat.roughness) * mag[c] + 1e-30);
            }
        }
    }
    printf("esr_brdf_reflect_fwd vs loop over esr_brdf_eval: worst share of tolerance used %.2f\n", worst);

    struct esr_material mat = {{0.5f, 0.5f, 0.5f}, 0.3f, 0.2f};
    random_batch(&rng, 16, mat.roughness, &b);
    float out[3] = {7, 7, 7};
    struct esr_brdf_incident inc = incident(&b);
    inc.count = 0;
    esr_brdf_reflect_fwd(&mat, b.n, b.wo, &inc, out);
    assert_true(out[0] == 0 && out[1] == 0 && out[2] == 0);
    inc.count = 16;
    out[0] = 7;
    esr_brdf_reflect_fwd(&mat, b.n, esr_v3_scale(b.wo, -1.0f), &inc, out);
    assert_true(out[0] == 0 && out[1] == 0 && out[2] == 0);
}

/* sum_c g_c out_c for the batch's material-independent data. */
static double batch_loss(const struct esr_material *mat, const void *vctx)
{
    const struct batch *b = vctx;
    struct esr_brdf_incident inc = incident(b);
    float out[3];
    esr_brdf_reflect_fwd(mat, b->n, b->wo, &inc, out);
    return (double)b->g[0] * out[0] + (double)b->g[1] * out[1] + (double)b->g[2] * out[2];
}

/* sum_c |g_c| sum_j |li weight R|: what rounding of the batched forward is proportional to. */
static double batch_scale(const struct esr_material *mat, const struct batch *b)
{
    double out[3], mag[3];
    reference_reflect(mat, b, out, mag);
    return fabs(b->g[0]) * mag[0] + fabs(b->g[1]) * mag[1] + fabs(b->g[2]) * mag[2];
}

/* d loss / d li[k] by Richardson-extrapolated central differences at steps h and 2h. */
static double fd_li(const struct esr_material *mat, struct batch *b, int k, float h)
{
    const float keep = b->li[k];
    double d[2];
    for (int s = 0; s < 2; s++) {
        b->li[k] = keep + h * (float)(s + 1);
        double plus = batch_loss(mat, b), x_plus = b->li[k];
        b->li[k] = keep - h * (float)(s + 1);
        d[s] = (plus - batch_loss(mat, b)) / (x_plus - b->li[k]);
    }
    b->li[k] = keep;
    return (4.0 * d[0] - d[1]) / 3.0;
}

/* esr_brdf_reflect_bwd against finite differences on all five material entries and on every
 * entry of li, for batch sizes around the vector widths and up to 256 (the method's M); the
 * backward adds to pre-filled gradients, and NULL outputs are skipped. */
static void test_reflect_bwd_matches_finite_differences(void **state)
{
    (void)state;
    static struct batch b;
    static float d_li[3 * MAX_M], pre[3 * MAX_M];
    struct esr_rng rng = esr_rng_init(24, 0);
    struct fd_stats st = {{0}, {0}};
    int failures = 0;
    for (int it = 0; it < 6; it++) {
        for (int s = 0; s < N_BATCH_SIZES; s++) {
            struct esr_material mat = random_material(&rng, 0.08f, 1.0f);
            random_batch(&rng, batch_sizes[s], mat.roughness, &b);
            const int m = b.m;
            struct esr_brdf_incident inc = incident(&b);
            for (int k = 0; k < 3 * m; k++)
                pre[k] = d_li[k] = uniform(&rng, -1.0f, 1.0f);
            struct esr_material d = {{0.5f, -0.5f, 0.25f}, 1.0f, -1.0f}, start = d;
            esr_brdf_reflect_bwd(&mat, b.n, b.wo, &inc, b.g, &d, d_li);
            double scale = batch_scale(&mat, &b);
            for (int i = 0; i < N_ENTRIES; i++) {
                float h = fd_step(&mat, i);
                double fd = fd_entry(batch_loss, &b, &mat, i, h);
                failures += !fd_agrees((double)*entry(&d, i) - *entry(&start, i), fd,
                                       ROUND_ULPS * FLT_EPSILON * scale / h + 1e-12, 2e-3, &st, i);
            }
            for (int k = 0; k < 3 * m; k++) {
                const float h = 1e-2f;
                double fd = fd_li(&mat, &b, k, h);
                failures += !fd_agrees((double)d_li[k] - pre[k], fd, ROUND_ULPS * FLT_EPSILON * scale / h + 1e-12,
                                       1e-3, &st, N_ENTRIES);
            }
        }
    }
    print_stats("esr_brdf_reflect_bwd vs finite differences", &st, 1);
    assert_int_equal(failures, 0);
}

/* The batched backward is the sum over directions of single backward passes with
 * d loss / d R_c = g_c weight_j li_cj, and d li_cj = g_c weight_j R_c(wi_j); with d_li or d_mat
 * NULL the other output is unchanged. This pins the batched kernel to the single one entry by
 * entry, at tolerances far below what finite differences resolve. */
static void test_reflect_bwd_equals_sum_of_eval_bwd(void **state)
{
    (void)state;
    static struct batch b;
    static float d_li[3 * MAX_M], d_li_only[3 * MAX_M];
    struct esr_rng rng = esr_rng_init(25, 0);
    for (int it = 0; it < 20; it++) {
        for (int s = 0; s < N_BATCH_SIZES; s++) {
            struct esr_material mat = random_material(&rng, it < 2 ? 0.0f : 0.05f, 1.0f);
            random_batch(&rng, batch_sizes[s], mat.roughness, &b);
            const int m = b.m;
            struct esr_brdf_incident inc = incident(&b);
            memset(d_li, 0, sizeof d_li);
            memset(d_li_only, 0, sizeof d_li_only);
            struct esr_material d = {{0, 0, 0}, 0, 0}, d_only = d;
            esr_brdf_reflect_bwd(&mat, b.n, b.wo, &inc, b.g, &d, d_li);
            esr_brdf_reflect_bwd(&mat, b.n, b.wo, &inc, b.g, &d_only, NULL);
            esr_brdf_reflect_bwd(&mat, b.n, b.wo, &inc, b.g, NULL, d_li_only);
            double want[N_ENTRIES] = {0}, mag[N_ENTRIES] = {0}, li_max[3] = {0};
            static double want_li[3 * MAX_M];
            for (int j = 0; j < m; j++) {
                float r[3], t[3];
                esr_brdf_eval(&mat, b.n, b.wo, batch_wi(&b, j), r);
                for (int c = 0; c < 3; c++) {
                    want_li[c * m + j] = (double)b.g[c] * b.weight[j] * r[c];
                    li_max[c] = fmax(li_max[c], fabs(want_li[c * m + j]));
                    t[c] = b.g[c] * b.weight[j] * b.li[c * m + j];
                }
                struct esr_material one = {{0, 0, 0}, 0, 0};
                esr_brdf_eval_bwd(&mat, b.n, b.wo, batch_wi(&b, j), t, &one);
                for (int i = 0; i < N_ENTRIES; i++) {
                    want[i] += *entry(&one, i);
                    mag[i] += fabs(*entry(&one, i));
                }
            }
            /* each d li against the largest of its channel: n.wi of a grazing direction is a
             * cancelling dot product, so tiny entries carry rounding relative to the others */
            for (int k = 0; k < 3 * m; k++) {
                double tol = rounding_rtol(mat.roughness) * li_max[k / m] + 1e-30;
                assert_true(fabs(d_li[k] - want_li[k]) <= tol);
                assert_true(fabs(d_li_only[k] - d_li[k]) <= 1e-6 * li_max[k / m] + 1e-30);
            }
            for (int i = 0; i < N_ENTRIES; i++) {
                assert_true(fabs(*entry(&d, i) - want[i]) <= rounding_rtol(mat.roughness) * mag[i] + 1e-30);
                assert_true(fabs(*entry(&d_only, i) - *entry(&d, i)) <= 1e-6 * mag[i] + 1e-30);
            }
        }
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_eval_bwd_matches_finite_differences),
        cmocka_unit_test(test_eval_bwd_accumulates),
        cmocka_unit_test(test_eval_bwd_roughness_clamp),
        cmocka_unit_test(test_eval_bwd_below_surface_is_zero),
        cmocka_unit_test(test_reflect_fwd_matches_eval_loop),
        cmocka_unit_test(test_reflect_bwd_matches_finite_differences),
        cmocka_unit_test(test_reflect_bwd_equals_sum_of_eval_bwd),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
