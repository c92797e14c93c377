/* Spherical-Gaussian environment map: lobes prepared once per call (unit axes, |lambda|, SoA on
 * the stack), the forward, the deterministic backward, initialisation and the equirectangular
 * image. */
#include "fields/env_sg.h"

#include "core/fast_exp.h"
#include <math.h>
#include <omp.h>
#include <stdlib.h>

#include "core/error.h"
#include "core/fast_exp.h"
#include "core/rng.h"
#include "core/sampling.h"
#include "nn/activation.h"

/* Fewer directions than this run on the calling thread: a parallel region costs more than the
 * work (48 lobes x 512 directions is ~50 us on one core). */
#define PARALLEL_MIN_DIRS 512
/* The backward pass walks the directions in chunks of this many; a chunk's upstream factors
 * (d_rgb * softplus') sit on the stack between its two phases (two buffers: 24 KB). */
#define BWD_CHUNK 1024

/* The lobes as the kernels read them. */
struct lobes {
    int count;
    float ux[ESR_ENV_SG_MAX_LOBES], uy[ESR_ENV_SG_MAX_LOBES], uz[ESR_ENV_SG_MAX_LOBES]; /* unit axis */
    float lam[ESR_ENV_SG_MAX_LOBES];                                                    /* |lambda| */
    float mu[3][ESR_ENV_SG_MAX_LOBES];
    float x_floor; /* -87: exp_nonpos's clamp */
};

int esr_env_sg_check_lobes(int lobes)
{
    if (lobes < 1 || lobes > ESR_ENV_SG_MAX_LOBES)
        return ESR_FAIL("environment map: %d lobes, expected 1 to %d", lobes, ESR_ENV_SG_MAX_LOBES);
    return ESR_OK;
}

size_t esr_env_sg_param_count(int lobes)
{
    if (lobes < 1 || lobes > ESR_ENV_SG_MAX_LOBES)
        return 0;
    return (size_t)ESR_ENV_SG_BLOCKS * (size_t)lobes;
}

/* 1 / |axis|, 0 for a zero axis (its lobe is then the constant exp(-|lambda|)). */
static float axis_inv_length(const float *params, int K, int k)
{
    float x = params[esr_env_sg_index(K, ESR_ENV_SG_XI_X, k)];
    float y = params[esr_env_sg_index(K, ESR_ENV_SG_XI_Y, k)];
    float z = params[esr_env_sg_index(K, ESR_ENV_SG_XI_Z, k)];
    float len = sqrtf(x * x + y * y + z * z);
    return len > 0.0f ? 1.0f / len : 0.0f;
}

static void prepare(const float *params, int K, struct lobes *L)
{
    L->count = K;
    L->x_floor = -87.0f;
    for (int k = 0; k < K; k++) {
        float inv = axis_inv_length(params, K, k);
        L->ux[k] = params[esr_env_sg_index(K, ESR_ENV_SG_XI_X, k)] * inv;
        L->uy[k] = params[esr_env_sg_index(K, ESR_ENV_SG_XI_Y, k)] * inv;
        L->uz[k] = params[esr_env_sg_index(K, ESR_ENV_SG_XI_Z, k)] * inv;
        L->lam[k] = fabsf(params[esr_env_sg_index(K, ESR_ENV_SG_LAMBDA, k)]);
        for (int c = 0; c < 3; c++)
            L->mu[c][k] = params[esr_env_sg_index(K, (enum esr_env_sg_block)(ESR_ENV_SG_MU_R + c), k)];
    }
}

/* e^x of a lobe's exponent |lambda| (d.u - 1) <= 0 (core/fast_exp.h), clamped at x_floor =
 * -87. The floor is passed in from struct lobes rather than written as a constant: with a
 * constant GCC folds e^-87 and turns the clamp into a branch, and the backward's loop no longer
 * vectorises. */
ESR_INLINE float exp_nonpos(float x, float x_floor)
{
    return esr_exp_nonpos(x < x_floor ? x_floor : x);
}

/* s[c] = sum_k mu_kc exp(|lambda_k| (d . u_k - 1)): the map before the softplus. */
ESR_INLINE void lobe_sum(const struct lobes *L, const float *d, float s[3])
{
    const float x_floor = L->x_floor;
    float s0 = 0.0f, s1 = 0.0f, s2 = 0.0f;
#pragma omp simd reduction(+ : s0, s1, s2)
    for (int k = 0; k < L->count; k++) {
        float e = exp_nonpos(L->lam[k] * (L->ux[k] * d[0] + L->uy[k] * d[1] + L->uz[k] * d[2] - 1.0f), x_floor);
        s0 += L->mu[0][k] * e;
        s1 += L->mu[1][k] * e;
        s2 += L->mu[2][k] * e;
    }
    s[0] = s0;
    s[1] = s1;
    s[2] = s2;
}

ESR_HOT void esr_env_sg_fwd(const float *params, int lobes, const float *dirs, size_t n, float *rgb_out)
{
    struct lobes L;
    prepare(params, lobes, &L);
#pragma omp parallel for schedule(static) if (n >= PARALLEL_MIN_DIRS)
    for (size_t i = 0; i < n; i++) {
        float s[3];
        lobe_sum(&L, dirs + i * 3, s);
        for (int c = 0; c < 3; c++)
            rgb_out[i * 3 + c] = esr_nn_softplus_fwd(s[c]);
    }
}

/* One direction d with upstream factors g[c] = d_rgb_c * softplus'(s_c), into the sums of lobes
 * [lo, hi). With t = d . u_k - 1, e = exp(|lambda| t) and w = e sum_c g_c mu_kc:
 *     d/d mu_kc = g_c e,   d/d|lambda_k| = w t,   d/d u_k = |lambda_k| w d,
 * so acc holds per lobe sum g_c e (mu blocks), sum w t (lambda block) and sum w d (axis
 * blocks); esr_env_sg_bwd applies |lambda|, the sign and the normalisation at the end. */
ESR_INLINE void lobe_grad(const struct lobes *L, int lo, int hi, const float *d, const float *g,
                          float acc[ESR_ENV_SG_BLOCKS][ESR_ENV_SG_MAX_LOBES])
{
    const float d0 = d[0], d1 = d[1], d2 = d[2], g0 = g[0], g1 = g[1], g2 = g[2];
    const float *ux = L->ux, *uy = L->uy, *uz = L->uz, *lam = L->lam;
    const float *mr = L->mu[0], *mg = L->mu[1], *mb = L->mu[2], x_floor = L->x_floor;
    float *a_mr = acc[ESR_ENV_SG_MU_R], *a_mg = acc[ESR_ENV_SG_MU_G], *a_mb = acc[ESR_ENV_SG_MU_B];
    float *a_lam = acc[ESR_ENV_SG_LAMBDA];
    float *a_x = acc[ESR_ENV_SG_XI_X], *a_y = acc[ESR_ENV_SG_XI_Y], *a_z = acc[ESR_ENV_SG_XI_Z];
#pragma omp simd
    for (int k = lo; k < hi; k++) {
        float t = ux[k] * d0 + uy[k] * d1 + uz[k] * d2 - 1.0f;
        float e = exp_nonpos(lam[k] * t, x_floor);
        float w = e * (g0 * mr[k] + g1 * mg[k] + g2 * mb[k]);
        a_mr[k] += g0 * e;
        a_mg[k] += g1 * e;
        a_mb[k] += g2 * e;
        a_lam[k] += w * t;
        a_x[k] += w * d0;
        a_y[k] += w * d1;
        a_z[k] += w * d2;
    }
}

/* Two phases per chunk of directions: (1) in parallel over the chunk's directions, the upstream
 * factors g (needs the full lobe sum s per direction); (2) each thread adds the chunk's
 * directions, in order, into the sums of the lobes it owns. Every sum thus sees the directions
 * in the same order whatever the team size, and the final pass adds each sum to grad_params
 * once, so the result is bitwise independent of the thread count. g alternates between two
 * buffers, so one barrier per chunk (the end of phase 1) suffices: a thread can only start
 * writing a buffer again (chunk c+2) after every thread has passed the end of chunk c+1's phase
 * 1, hence has finished reading it in chunk c's phase 2. */
ESR_HOT void esr_env_sg_bwd(const float *params, int lobes, const float *dirs, size_t n,
                            const float *d_rgb, float *grad_params)
{
    if (n == 0)
        return;
    struct lobes L;
    prepare(params, lobes, &L);
    float acc[ESR_ENV_SG_BLOCKS][ESR_ENV_SG_MAX_LOBES];
    float g_buf[2][BWD_CHUNK * 3];
#pragma omp parallel if (n >= PARALLEL_MIN_DIRS)
    {
        const int nt = omp_get_num_threads(), tid = omp_get_thread_num();
        const int lo = (int)((long)lobes * tid / nt), hi = (int)((long)lobes * (tid + 1) / nt);
        /* the thread's own sums (only [lo, hi) used), copied out once: accumulating straight into
         * the shared array would bounce the cache line holding two threads' boundary lobes */
        float mine[ESR_ENV_SG_BLOCKS][ESR_ENV_SG_MAX_LOBES];
        for (int b = 0; b < ESR_ENV_SG_BLOCKS; b++)
            for (int k = lo; k < hi; k++)
                mine[b][k] = 0.0f;
        for (size_t c0 = 0; c0 < n; c0 += BWD_CHUNK) {
            const size_t m = n - c0 < BWD_CHUNK ? n - c0 : BWD_CHUNK;
            float *g = g_buf[(c0 / BWD_CHUNK) & 1];
#pragma omp for schedule(static)
            for (size_t j = 0; j < m; j++) {
                float s[3];
                lobe_sum(&L, dirs + (c0 + j) * 3, s);
                for (int c = 0; c < 3; c++)
                    g[j * 3 + c] = d_rgb[(c0 + j) * 3 + c] * esr_nn_sigmoid_fwd(s[c]);
            }
            for (size_t j = 0; j < m; j++)
                lobe_grad(&L, lo, hi, dirs + (c0 + j) * 3, g + j * 3, mine);
        }
        for (int b = 0; b < ESR_ENV_SG_BLOCKS; b++)
            for (int k = lo; k < hi; k++)
                acc[b][k] = mine[b][k];
    }
    for (int k = 0; k < lobes; k++) {
        for (int c = 0; c < 3; c++) {
            enum esr_env_sg_block b = (enum esr_env_sg_block)(ESR_ENV_SG_MU_R + c);
            grad_params[esr_env_sg_index(lobes, b, k)] += acc[b][k];
        }
        const size_t il = esr_env_sg_index(lobes, ESR_ENV_SG_LAMBDA, k);
        grad_params[il] += params[il] >= 0.0f ? acc[ESR_ENV_SG_LAMBDA][k] : -acc[ESR_ENV_SG_LAMBDA][k];
        /* d/d u = |lambda| sum w d; through u = xi / |xi|: d/d xi = (I - u u^T) (d/d u) / |xi| */
        const float u[3] = {L.ux[k], L.uy[k], L.uz[k]};
        float du[3], udu = 0.0f;
        for (int a = 0; a < 3; a++) {
            du[a] = L.lam[k] * acc[ESR_ENV_SG_XI_X + a][k];
            udu += u[a] * du[a];
        }
        const float inv = axis_inv_length(params, lobes, k);
        for (int a = 0; a < 3; a++)
            grad_params[esr_env_sg_index(lobes, (enum esr_env_sg_block)(ESR_ENV_SG_XI_X + a), k)] +=
                (du[a] - u[a] * udu) * inv;
    }
}

/* Initial mu = 0: the map starts as softplus(0) = ln 2 ~ 0.69 in every direction and channel, a
 * dim uniform grey next to the scenes' emitters (strength ~8-16). Unlike a mu tuned to a target
 * mean, it is exactly uniform (sharp lobes leave gaps a sum of them cannot fill), its gradient is
 * softplus'(0) = 1/2 times each lobe's value, so every mu learns from the first step, and the
 * axes and sharpnesses follow once mu moves off zero. */
void esr_env_sg_init(float *params, int lobes, uint64_t seed)
{
    /* golden angle as a fraction of a turn: 1 - 1/golden ratio = (3 - sqrt 5) / 2 */
    const double turn = 0.5 * (3.0 - sqrt(5.0));
    for (int k = 0; k < lobes; k++) {
        /* Fibonacci spiral: equal-area bands in z, azimuth advanced by the golden angle */
        float z = (float)(1.0 - (2.0 * k + 1.0) / lobes);
        double frac = turn * k - floor(turn * k);
        struct esr_vec3 axis = esr_direction_from_polar(z, sqrtf(fmaxf(0.0f, 1.0f - z * z)), (float)frac);
        /* |N(0,1)| by Box-Muller from stream k (u1 in (0, 1] keeps the log finite) */
        struct esr_rng rng = esr_rng_init(seed, (uint64_t)k);
        double u1 = 1.0 - (double)esr_rng_float(&rng), u2 = (double)esr_rng_float(&rng);
        double normal = sqrt(-2.0 * log(u1)) * cos(2.0 * M_PI * u2);
        params[esr_env_sg_index(lobes, ESR_ENV_SG_XI_X, k)] = axis.x;
        params[esr_env_sg_index(lobes, ESR_ENV_SG_XI_Y, k)] = axis.y;
        params[esr_env_sg_index(lobes, ESR_ENV_SG_XI_Z, k)] = axis.z;
        params[esr_env_sg_index(lobes, ESR_ENV_SG_LAMBDA, k)] = (float)(10.0 + fabs(20.0 * normal));
        for (int c = 0; c < 3; c++)
            params[esr_env_sg_index(lobes, (enum esr_env_sg_block)(ESR_ENV_SG_MU_R + c), k)] = 0.0f;
    }
}

void esr_env_sg_set_level(float *params, int lobes, const float level[3])
{
    enum { N = 512 };
    float dirs[N * 3], rgb[N * 3];
    for (int i = 0; i < N; i++) { /* Fibonacci sphere */
        const float z = 1.0f - (2.0f * (float)i + 1.0f) / N, r = sqrtf(fmaxf(0.0f, 1.0f - z * z));
        const float phi = 2.39996323f * (float)i;
        dirs[i * 3] = r * cosf(phi);
        dirs[i * 3 + 1] = r * sinf(phi);
        dirs[i * 3 + 2] = z;
    }
    /* a channel's mean rises monotonically with a common mu of that channel, and no other
     * channel's mu reaches it: bisect the three at once */
    float lo[3] = {-100.0f, -100.0f, -100.0f}, hi[3] = {100.0f, 100.0f, 100.0f};
    for (int it = 0; it < 60; it++) {
        for (int k = 0; k < lobes; k++)
            for (int c = 0; c < 3; c++)
                params[esr_env_sg_index(lobes, (enum esr_env_sg_block)(ESR_ENV_SG_MU_R + c), k)] =
                    0.5f * (lo[c] + hi[c]);
        esr_env_sg_fwd(params, lobes, dirs, N, rgb);
        for (int c = 0; c < 3; c++) {
            double mean = 0.0;
            for (int i = 0; i < N; i++)
                mean += rgb[i * 3 + c];
            if (mean / N < level[c])
                lo[c] = 0.5f * (lo[c] + hi[c]);
            else
                hi[c] = 0.5f * (lo[c] + hi[c]);
        }
    }
}

void esr_env_sg_equirect_dir(int width, int height, int row, int col, float dir[3])
{
    double theta = M_PI * (row + 0.5) / height, phi = 2.0 * M_PI * (col + 0.5) / width;
    dir[0] = (float)(sin(theta) * cos(phi));
    dir[1] = (float)(sin(theta) * sin(phi));
    dir[2] = (float)cos(theta);
}

int esr_env_sg_equirect(const float *params, int lobes, int width, int height, float *rgb_out)
{
    ESR_TRY(esr_env_sg_check_lobes(lobes));
    if (width < 1 || height < 1 || (size_t)width * (size_t)height > ((size_t)1 << 28))
        return ESR_FAIL("environment map image: size %dx%d must be positive and at most 2^28 pixels",
                        width, height);
    const size_t n = (size_t)width * (size_t)height;
    float *dirs = (float *)malloc(n * 3 * sizeof(float));
    if (!dirs)
        return ESR_FAIL("environment map image: out of memory for %dx%d directions", width, height);
    for (int row = 0; row < height; row++)
        for (int col = 0; col < width; col++)
            esr_env_sg_equirect_dir(width, height, row, col, dirs + ((size_t)row * width + col) * 3);
    esr_env_sg_fwd(params, lobes, dirs, n, rgb_out);
    free(dirs);
    return ESR_OK;
}
