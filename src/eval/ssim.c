/* SSIM as in JAXNeRF / mip-NeRF `compute_ssim` (see metrics.h for the exact variant).
 * Separable: per channel, a horizontal 11-tap pass over every row of the five moment images (a,
 * b, a^2, b^2, ab), then a vertical pass that produces one output row at a time and reduces it
 * straight into the SSIM sum. Double precision throughout: E[x^2] - mu^2 cancels in flat
 * regions, where float would leave errors comparable to C2. Rows are independent, so both passes
 * run OpenMP-parallel over rows; each output row's sum is kept separately and added up serially,
 * so the result is identical for any thread count. */
#include <math.h>
#include <omp.h>
#include <stdlib.h>

#include "core/error.h"
#include "core/simd.h"
#include "eval/metrics.h"
#include "eval/metrics_internal.h"

enum { SSIM_TAPS = 11, SSIM_MOMENTS = 5 };

#define SSIM_SIGMA 1.5
#define SSIM_C1 (0.01 * 0.01) /* (K1 * max_val)^2, max_val = 1 */
#define SSIM_C2 (0.03 * 0.03) /* (K2 * max_val)^2 */

/* Normalised 1-D Gaussian, centred on tap 5 (JAXNeRF's `shift` is 0 for an odd size). */
static void ssim_filter(double w[SSIM_TAPS])
{
    double sum = 0.0;
    for (int i = 0; i < SSIM_TAPS; i++) {
        double t = (i - SSIM_TAPS / 2) / SSIM_SIGMA;
        w[i] = exp(-0.5 * t * t);
        sum += w[i];
    }
    for (int i = 0; i < SSIM_TAPS; i++)
        w[i] /= sum;
}

/* One SSIM map value from the five filtered moments, with JAXNeRF's clipping. */
static inline double ssim_pixel(double mu0, double mu1, double e00, double e11, double e01)
{
    double s00 = e00 - mu0 * mu0, s11 = e11 - mu1 * mu1, s01 = e01 - mu0 * mu1;
    s00 = s00 > 0.0 ? s00 : 0.0;
    s11 = s11 > 0.0 ? s11 : 0.0;
    if (s01 * s01 > s00 * s11) /* |covariance| <= sqrt(var var); only rounding can break it */
        s01 = copysign(sqrt(s00 * s11), s01);
    double numer = (2.0 * mu0 * mu1 + SSIM_C1) * (2.0 * s01 + SSIM_C2);
    double denom = (mu0 * mu0 + mu1 * mu1 + SSIM_C1) * (s00 + s11 + SSIM_C2);
    return numer / denom;
}

/* Channel c of a and b as two contiguous planes, so the filter passes run over unit strides. */
static void ssim_split_channel(const struct esr_image *a, const struct esr_image *b, int c, double *ESR_RESTRICT pa,
                               double *ESR_RESTRICT pb)
{
    size_t n = (size_t)a->width * a->height;
    int nc = a->channels;
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++) {
        pa[i] = a->data[i * nc + c];
        pb[i] = b->data[i * nc + c];
    }
}

/* Horizontal pass: h[m][y*ow + x] = sum_k w[k] * moment_m(y, x+k), the moments being a, b, a^2,
 * b^2, ab. The tap loop is unrolled, leaving x as the vectorised loop with the five sums held in
 * registers. */
ESR_HOT static void ssim_pass_rows(const double *ESR_RESTRICT pa, const double *ESR_RESTRICT pb, int width,
                                   int height, const double *ESR_RESTRICT w, double *ESR_RESTRICT h)
{
    int ow = width - (SSIM_TAPS - 1);
    size_t plane = (size_t)height * ow;
#pragma omp parallel for schedule(static)
    for (int y = 0; y < height; y++) {
        const double *ra = pa + (size_t)y * width, *rb = pb + (size_t)y * width;
        double *ESR_RESTRICT out = h + (size_t)y * ow;
#pragma omp simd
        for (int x = 0; x < ow; x++) {
            double s0 = 0.0, s1 = 0.0, s00 = 0.0, s11 = 0.0, s01 = 0.0;
#pragma GCC unroll 11
            for (int k = 0; k < SSIM_TAPS; k++) {
                double va = ra[x + k], vb = rb[x + k], wa = w[k] * va, wb = w[k] * vb;
                s0 += wa;
                s1 += wb;
                s00 += wa * va;
                s11 += wb * vb;
                s01 += wa * vb;
            }
            out[x] = s0;
            out[plane + x] = s1;
            out[2 * plane + x] = s00;
            out[3 * plane + x] = s11;
            out[4 * plane + x] = s01;
        }
    }
}

/* Vertical pass + SSIM map; row_sum[y] receives the sum of output row y. The filtered moments of
 * a row go to `scratch` (SSIM_MOMENTS * ow doubles per thread, omp_get_max_threads() threads) in
 * a vectorised loop; the SSIM formula then runs over them. */
ESR_HOT static void ssim_pass_columns(const double *h, int ow, int height, const double *w,
                                      double *ESR_RESTRICT scratch, double *ESR_RESTRICT row_sum)
{
    int oh = height - (SSIM_TAPS - 1);
    size_t plane = (size_t)height * ow;
#pragma omp parallel
    {
        double *m = scratch + (size_t)omp_get_thread_num() * SSIM_MOMENTS * ow;
#pragma omp for schedule(static)
        for (int y = 0; y < oh; y++) {
            for (int q = 0; q < SSIM_MOMENTS; q++) {
                const double *ESR_RESTRICT src = h + q * plane + (size_t)y * ow;
                double *ESR_RESTRICT dst = m + (size_t)q * ow;
#pragma omp simd
                for (int x = 0; x < ow; x++) {
                    double acc = 0.0;
#pragma GCC unroll 11
                    for (int k = 0; k < SSIM_TAPS; k++)
                        acc += w[k] * src[(size_t)k * ow + x];
                    dst[x] = acc;
                }
            }
            double sum = 0.0;
            for (int x = 0; x < ow; x++)
                sum += ssim_pixel(m[x], m[ow + x], m[2 * ow + x], m[3 * ow + x], m[4 * ow + x]);
            row_sum[y] = sum;
        }
    }
}

int esr_metric_ssim(const struct esr_image *a, const struct esr_image *b, double *out)
{
    ESR_TRY(esr_metric_check_same_shape(a, b, "SSIM"));
    if (a->width < SSIM_TAPS || a->height < SSIM_TAPS)
        return ESR_FAIL("SSIM: image is %dx%d but the 11x11 window needs at least 11x11 pixels", a->width,
                        a->height);
    int ow = a->width - (SSIM_TAPS - 1), oh = a->height - (SSIM_TAPS - 1);
    size_t n = (size_t)a->width * a->height;
    size_t scratch_len = (size_t)omp_get_max_threads() * SSIM_MOMENTS * ow;
    double *planes = malloc(sizeof *planes * 2 * n);
    double *h = malloc(sizeof *h * SSIM_MOMENTS * (size_t)a->height * ow);
    double *scratch = malloc(sizeof *scratch * scratch_len);
    double *row_sum = malloc(sizeof *row_sum * (size_t)oh);
    if (!planes || !h || !scratch || !row_sum) {
        free(planes);
        free(h);
        free(scratch);
        free(row_sum);
        return ESR_FAIL("SSIM: out of memory for a %dx%d image", a->width, a->height);
    }
    double w[SSIM_TAPS];
    ssim_filter(w);
    double total = 0.0;
    for (int c = 0; c < a->channels; c++) {
        ssim_split_channel(a, b, c, planes, planes + n);
        ssim_pass_rows(planes, planes + n, a->width, a->height, w, h);
        ssim_pass_columns(h, ow, a->height, w, scratch, row_sum);
        for (int y = 0; y < oh; y++)
            total += row_sum[y];
    }
    free(planes);
    free(h);
    free(scratch);
    free(row_sum);
    *out = total / ((double)ow * oh * a->channels);
    return ESR_OK;
}
