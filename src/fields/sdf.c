/* Whole-grid SDF operations: sphere init, Gaussian smoothing (and adjoint), resampling, TV. */
#include "fields/sdf.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "fields/trilerp.h"

#define SMOOTH_MAX_TAPS 15

int esr_sdf_init_sphere(const struct esr_grid *g, float *data, float radius)
{
    if (g->channels != 1)
        return ESR_FAIL("sphere SDF init: grid must have 1 channel, has %d", g->channels);
#pragma omp parallel for schedule(static)
    for (int iz = 0; iz < g->nz; iz++)
        for (int iy = 0; iy < g->ny; iy++)
            for (int ix = 0; ix < g->nx; ix++) {
                float p[3], r2 = 0.0f;
                esr_grid_voxel_pos(g, ix, iy, iz, p);
                for (int a = 0; a < 3; a++) {
                    float u = (2.0f * p[a] - g->bmin[a] - g->bmax[a]) / (g->bmax[a] - g->bmin[a]);
                    r2 += u * u;
                }
                data[((size_t)iz * g->ny + iy) * g->nx + ix] = sqrtf(r2) - radius;
            }
    return ESR_OK;
}

struct line_op {
    int n;             /* samples along the line */
    size_t stride;     /* floats between them */
    int r;             /* kernel radius */
    float w[SMOOTH_MAX_TAPS];
};

/* Forward 1-D smoothing of one line with point-reflected extension (see sdf.h). */
static void line_fwd(const struct line_op *op, const float *src, float *dst)
{
    const int n = op->n, last = n - 1;
    for (int i = 0; i < n; i++) {
        float acc = 0.0f;
        for (int k = -op->r; k <= op->r; k++) {
            int j = i + k;
            float v;
            if (j < 0)
                v = 2.0f * src[0] - src[(size_t)(-j) * op->stride];
            else if (j > last)
                v = 2.0f * src[(size_t)last * op->stride] - src[(size_t)(2 * last - j) * op->stride];
            else
                v = src[(size_t)j * op->stride];
            acc += op->w[k + op->r] * v;
        }
        dst[(size_t)i * op->stride] = acc;
    }
}

/* Transpose of line_fwd: dst = L^T src (dst overwritten). */
static void line_adj(const struct line_op *op, const float *src, float *dst)
{
    const int n = op->n, last = n - 1;
    for (int i = 0; i < n; i++)
        dst[(size_t)i * op->stride] = 0.0f;
    for (int i = 0; i < n; i++) {
        float d = src[(size_t)i * op->stride];
        for (int k = -op->r; k <= op->r; k++) {
            int j = i + k;
            float wd = op->w[k + op->r] * d;
            if (j < 0) {
                dst[0] += 2.0f * wd;
                dst[(size_t)(-j) * op->stride] -= wd;
            } else if (j > last) {
                dst[(size_t)last * op->stride] += 2.0f * wd;
                dst[(size_t)(2 * last - j) * op->stride] -= wd;
            } else {
                dst[(size_t)j * op->stride] += wd;
            }
        }
    }
}

/* The 1-D operator (or its transpose) along y or z, a whole x-row (channels included) at a time:
 * rows are contiguous, so the loops over a row vectorise, where a line along y or z touches a
 * cache line per sample. Each value sums the same terms in the same order as line_fwd and
 * line_adj. Along x the lines stay (a row there is one lattice point's channels: this form ran
 * the adjoint twice as slow on a 128^3 grid). */
static void smooth_rows(const struct esr_grid *g, int axis, const float *w, int r, int adjoint,
                        const float *src, float *dst)
{
    const size_t row = (size_t)g->nx * (size_t)g->channels;
    const int n = axis == 1 ? g->ny : g->nz, last = n - 1, other = axis == 1 ? g->nz : g->ny;
    const size_t stride = axis == 1 ? row : row * (size_t)g->ny; /* between rows along axis */
    const size_t ostride = axis == 1 ? row * (size_t)g->ny : row;
#pragma omp parallel for schedule(static)
    for (int o = 0; o < other; o++) {
        const float *s = src + (size_t)o * ostride;
        float *d = dst + (size_t)o * ostride;
        if (!adjoint) {
            for (int i = 0; i < n; i++) {
                float *out = d + (size_t)i * stride;
                for (size_t x = 0; x < row; x++)
                    out[x] = 0.0f;
                for (int k = -r; k <= r; k++) {
                    const int j = i + k;
                    const float wk = w[k + r];
                    if (j < 0 || j > last) { /* point-reflected: 2 f(end) - f(mirror) */
                        const float *e = s + (size_t)(j < 0 ? 0 : last) * stride;
                        const float *m = s + (size_t)(j < 0 ? -j : 2 * last - j) * stride;
                        for (size_t x = 0; x < row; x++)
                            out[x] += wk * (2.0f * e[x] - m[x]);
                    } else {
                        const float *v = s + (size_t)j * stride;
                        for (size_t x = 0; x < row; x++)
                            out[x] += wk * v[x];
                    }
                }
            }
            continue;
        }
        for (int i = 0; i < n; i++)
            memset(d + (size_t)i * stride, 0, row * sizeof(float));
        for (int i = 0; i < n; i++) {
            const float *in = s + (size_t)i * stride;
            for (int k = -r; k <= r; k++) {
                const int j = i + k;
                const float wk = w[k + r];
                if (j < 0 || j > last) {
                    float *e = d + (size_t)(j < 0 ? 0 : last) * stride;
                    float *m = d + (size_t)(j < 0 ? -j : 2 * last - j) * stride;
                    for (size_t x = 0; x < row; x++) {
                        const float wd = wk * in[x];
                        e[x] += 2.0f * wd;
                        m[x] -= wd;
                    }
                } else {
                    float *v = d + (size_t)j * stride;
                    for (size_t x = 0; x < row; x++)
                        v[x] += wk * in[x];
                }
            }
        }
    }
}

/* Applies the 1-D operator (or its transpose) along `axis` to every line of the grid. */
static void smooth_axis(const struct esr_grid *g, int axis, const float *w, int r, int adjoint,
                        const float *src, float *dst)
{
    if (axis != 0) {
        smooth_rows(g, axis, w, r, adjoint, src, dst);
        return;
    }
    const int C = g->channels;
    const int n[3] = {g->nx, g->ny, g->nz};
    const size_t s[3] = {(size_t)C, (size_t)g->nx * C, (size_t)g->nx * g->ny * C};
    const int b = axis == 0 ? 1 : 0, c = axis == 2 ? 1 : 2; /* the two other axes */
    struct line_op op;
    op.n = n[axis];
    op.stride = s[axis];
    op.r = r;
    memcpy(op.w, w, sizeof(float) * (size_t)(2 * r + 1));
    const long lines = (long)n[b] * n[c] * C;
#pragma omp parallel for schedule(static)
    for (long L = 0; L < lines; L++) {
        long ch = L % C, rest = L / C;
        size_t start = (size_t)ch + (size_t)(rest % n[b]) * s[b] + (size_t)(rest / n[b]) * s[c];
        if (adjoint)
            line_adj(&op, src + start, dst + start);
        else
            line_fwd(&op, src + start, dst + start);
    }
}

static int smooth_kernel(const struct esr_grid *g, int ksize, float sigma, float *w)
{
    if (ksize < 1 || ksize % 2 == 0 || ksize > SMOOTH_MAX_TAPS)
        return ESR_FAIL("Gaussian smoothing: kernel size %d must be odd and in 1..%d", ksize,
                        SMOOTH_MAX_TAPS);
    if (!(sigma > 0.0f))
        return ESR_FAIL("Gaussian smoothing: sigma %g must be > 0", (double)sigma);
    const int r = ksize / 2;
    if (g->nx <= r || g->ny <= r || g->nz <= r)
        return ESR_FAIL("Gaussian smoothing: grid %dx%dx%d too small for kernel size %d", g->nx,
                        g->ny, g->nz, ksize);
    float sum = 0.0f;
    for (int k = -r; k <= r; k++)
        sum += w[k + r] = expf(-(float)(k * k) / (2.0f * sigma * sigma));
    for (int k = 0; k < ksize; k++)
        w[k] /= sum;
    return ESR_OK;
}

/* Runs the three axis passes (forward: x, y, z; adjoint: z, y, x) through buffers a -> b -> a -> b
 * starting from src; the result is in `b`. */
static int smooth_passes(const struct esr_grid *g, int adjoint, const float *src, float *a, float *b,
                         int ksize, float sigma)
{
    float w[SMOOTH_MAX_TAPS];
    ESR_TRY(smooth_kernel(g, ksize, sigma, w));
    const int r = ksize / 2, first = adjoint ? 2 : 0, dir = adjoint ? -1 : 1;
    smooth_axis(g, first, w, r, adjoint, src, b);
    smooth_axis(g, first + dir, w, r, adjoint, b, a);
    smooth_axis(g, first + 2 * dir, w, r, adjoint, a, b);
    return ESR_OK;
}

int esr_grid_smooth_fwd(const struct esr_grid *g, const float *src, float *dst, float *scratch,
                        int ksize, float sigma)
{
    ESR_TRY(smooth_passes(g, 0, src, dst, scratch, ksize, sigma));
    memcpy(dst, scratch, sizeof(float) * esr_grid_count(g));
    return ESR_OK;
}

int esr_grid_smooth_bwd(const struct esr_grid *g, float *d_dst, float *d_src, float *scratch,
                        int ksize, float sigma)
{
    ESR_TRY(smooth_passes(g, 1, d_dst, d_dst, scratch, ksize, sigma));
    const size_t count = esr_grid_count(g);
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < count; i++)
        d_src[i] += scratch[i];
    return ESR_OK;
}

int esr_grid_resample(const struct esr_grid *src_g, const float *src, const struct esr_grid *dst_g,
                      float *dst)
{
    if (src_g->channels != dst_g->channels)
        return ESR_FAIL("grid resample: channel counts differ (%d -> %d)", src_g->channels,
                        dst_g->channels);
    const int C = dst_g->channels;
#pragma omp parallel for schedule(static)
    for (int iz = 0; iz < dst_g->nz; iz++)
        for (int iy = 0; iy < dst_g->ny; iy++)
            for (int ix = 0; ix < dst_g->nx; ix++) {
                float p[3];
                struct esr_trilerp t;
                esr_grid_voxel_pos(dst_g, ix, iy, iz, p);
                esr_trilerp_locate(src_g, p, &t);
                esr_trilerp_fwd(src, C, &t, dst + (((size_t)iz * dst_g->ny + iy) * dst_g->nx + ix) * C);
            }
    return ESR_OK;
}

/* One axis-neighbour pass of the TV over n contiguous floats: g[j] += scale * h'(x[j] - nb[j]),
 * h' the Huber derivative (clamped difference); returns sum h(x[j] - nb[j]) when count_loss (each
 * pair is counted from its lower end only). Branch-free so it vectorises. */
static float tv_pass(const float *restrict x, const float *restrict nb, float *restrict g, size_t n,
                     float scale, int count_loss)
{
    float acc = 0.0f;
    if (count_loss) {
#pragma omp simd reduction(+ : acc)
        for (size_t j = 0; j < n; j++) {
            float d = x[j] - nb[j], ad = d < 0.0f ? -d : d;
            acc += ad <= 1.0f ? 0.5f * d * d : ad - 0.5f;
            g[j] += scale * (d < -1.0f ? -1.0f : d > 1.0f ? 1.0f : d);
        }
    } else {
#pragma omp simd
        for (size_t j = 0; j < n; j++) {
            float d = x[j] - nb[j];
            g[j] += scale * (d < -1.0f ? -1.0f : d > 1.0f ? 1.0f : d);
        }
    }
    return acc;
}

int esr_grid_tv_add_grad(const struct esr_grid *g, const float *data, float weight, float *grad,
                         double *loss)
{
    double *plane_loss = (double *)calloc((size_t)g->nz, sizeof(double));
    if (!plane_loss)
        return ESR_FAIL("total variation: out of memory for %d plane sums", g->nz);
    const size_t C = (size_t)g->channels, row = (size_t)g->nx * C, plane = row * g->ny;
    const float scale = weight / (float)esr_grid_voxels(g);
    /* Rows along x are contiguous: the y and z neighbours of a row are whole rows, the x
     * neighbours the same row shifted by one voxel. */
#pragma omp parallel for schedule(static)
    for (int iz = 0; iz < g->nz; iz++) {
        double acc = 0.0;
        for (int iy = 0; iy < g->ny; iy++) {
            size_t o = (size_t)iz * plane + (size_t)iy * row;
            const float *x = data + o;
            float *gr = grad + o, part = 0.0f;
            part += tv_pass(x, x + C, gr, row - C, scale, 1);
            tv_pass(x + C, x, gr + C, row - C, scale, 0);
            if (iy + 1 < g->ny)
                part += tv_pass(x, x + row, gr, row, scale, 1);
            if (iy > 0)
                tv_pass(x, x - row, gr, row, scale, 0);
            if (iz + 1 < g->nz)
                part += tv_pass(x, x + plane, gr, row, scale, 1);
            if (iz > 0)
                tv_pass(x, x - plane, gr, row, scale, 0);
            acc += part;
        }
        plane_loss[iz] = acc;
    }
    double total = 0.0;
    for (int iz = 0; iz < g->nz; iz++)
        total += plane_loss[iz];
    free(plane_loss);
    if (loss)
        *loss = total * scale;
    return ESR_OK;
}

size_t esr_sdf_grad_tv_work(const struct esr_grid *g) { return 8 * esr_grid_voxels(g); }

/* Neighbour indices and spacing of the central (one-sided at the faces) difference along axis a
 * at lattice coordinate i of n: G = (f[hi] - f[lo]) * inv. */
static void cdiff(int i, int n, size_t stride, float h, size_t v, size_t *lo, size_t *hi, float *inv)
{
    *lo = i > 0 ? v - stride : v;
    *hi = i + 1 < n ? v + stride : v;
    *inv = 1.0f / ((float)((i > 0) + (i + 1 < n)) * h);
}

/* df[v] = (D^T dG)[v], gathered from the (at most three) G entries along axis a whose stencil
 * reads f[v], so the adjoint runs in parallel without races. */
static float grad_adj_at(const struct esr_grid *g, const float *dG, size_t v, int a, int i, int n,
                         size_t stride)
{
    const float h = esr_grid_voxel_size(g, a);
    float acc = 0.0f;
    for (int k = -1; k <= 1; k++) {
        int j = i + k;
        if (j < 0 || j >= n)
            continue;
        size_t u = (size_t)((ptrdiff_t)v + k * (ptrdiff_t)stride), lo, hi;
        float inv;
        cdiff(j, n, stride, h, u, &lo, &hi, &inv);
        if (hi == v)
            acc += dG[u * 3 + a] * inv;
        if (lo == v)
            acc -= dG[u * 3 + a] * inv;
    }
    return acc;
}

/* Forward: out[v*3 + a] = central difference of in (= f) along a.
 * Adjoint: out[v] = (D^T in)[v] with in = dG. */
static void grad_field(const struct esr_grid *g, int adjoint, const float *in, float *out)
{
    const int n[3] = {g->nx, g->ny, g->nz};
    const size_t s[3] = {1, (size_t)g->nx, (size_t)g->nx * g->ny};
#pragma omp parallel for schedule(static)
    for (int iz = 0; iz < g->nz; iz++)
        for (int iy = 0; iy < g->ny; iy++)
            for (int ix = 0; ix < g->nx; ix++) {
                const int i[3] = {ix, iy, iz};
                size_t v = ix + s[1] * iy + s[2] * iz, lo, hi;
                float acc = 0.0f;
                for (int a = 0; a < 3; a++) {
                    float inv;
                    if (adjoint) {
                        acc += grad_adj_at(g, in, v, a, i[a], n[a], s[a]);
                        continue;
                    }
                    cdiff(i[a], n[a], s[a], esr_grid_voxel_size(g, a), v, &lo, &hi, &inv);
                    out[v * 3 + a] = (in[hi] - in[lo]) * inv;
                }
                if (adjoint)
                    out[v] = acc;
            }
}

int esr_sdf_grad_tv_add_grad(const struct esr_grid *g, const float *sdf, float weight, int ksize,
                             float sigma, float *work, float *grad, double *loss)
{
    if (g->channels != 1)
        return ESR_FAIL("smoothed-gradient TV: SDF grid must have 1 channel, has %d", g->channels);
    const size_t V = esr_grid_voxels(g);
    float *S = work, *scratch = work + V, *G = work + 2 * V, *dG = work + 5 * V;
    ESR_TRY(esr_grid_smooth_fwd(g, sdf, S, scratch, ksize, sigma));
    grad_field(g, 0, S, G);
    struct esr_grid g3 = *g;
    g3.channels = 3;
    memset(dG, 0, 3 * V * sizeof(float));
    ESR_TRY(esr_grid_tv_add_grad(&g3, G, weight, dG, loss));
    grad_field(g, 1, dG, S);
    return esr_grid_smooth_bwd(g, S, grad, scratch, ksize, sigma);
}
