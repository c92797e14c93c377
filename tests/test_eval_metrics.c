/* Image metrics (MSE, PSNR, SSIM, HDR MSE, emitter IoU) and the `esr metrics` command. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "core/colour.h"
#include "core/error.h"
#include "core/rng.h"
#include "eval/metrics.h"
#include "io/image.h"
#include "test_support.h"

static struct esr_image make_image(int w, int h, int c)
{
    struct esr_image img = {0};
    assert_int_equal(esr_image_alloc(&img, w, h, c), ESR_OK);
    return img;
}

static void fill_constant(struct esr_image *img, float v)
{
    for (size_t i = 0; i < esr_image_count(img); i++)
        img->data[i] = v;
}

/* a: uniform noise; b: a plus noise of amplitude `noise`, clamped to [0,1] (correlated pair). */
static void fill_random_pair(struct esr_image *a, struct esr_image *b, float noise, uint64_t seed)
{
    struct esr_rng rng = esr_rng_init(seed, 0);
    for (size_t i = 0; i < esr_image_count(a); i++) {
        a->data[i] = esr_rng_float(&rng);
        float v = a->data[i] + noise * (2.0f * esr_rng_float(&rng) - 1.0f);
        b->data[i] = fminf(1.0f, fmaxf(0.0f, v));
    }
}

/* ---- MSE / PSNR ---- */

static void test_mse_psnr_by_hand(void **state)
{
    (void)state;
    struct esr_image a = make_image(4, 3, 3), b = make_image(4, 3, 3);
    fill_constant(&a, 0.5f);
    fill_constant(&b, 0.6f);
    double mse, psnr;
    assert_int_equal(esr_metric_mse(&a, &b, &mse), ESR_OK);
    assert_true(fabs(mse - 0.01) < 1e-8); /* (0.1)^2, up to float storage of 0.6 */
    assert_int_equal(esr_metric_psnr(&a, &b, &psnr), ESR_OK);
    assert_true(fabs(psnr - 20.0) < 1e-5); /* -10 log10(0.01) */
    b.data[0] = 1.5f;                       /* one of 36 values off by 1.0 instead of 0.1 */
    assert_int_equal(esr_metric_mse(&a, &b, &mse), ESR_OK);
    assert_true(fabs(mse - (35 * 0.01 + 1.0) / 36) < 1e-7);
    assert_int_equal(esr_metric_psnr(&a, &a, &psnr), ESR_OK);
    assert_true(isinf(psnr) && psnr > 0);
    esr_image_free(&a);
    esr_image_free(&b);
}

static void test_shape_mismatch_is_an_error(void **state)
{
    (void)state;
    struct esr_image a = make_image(16, 16, 3), b = make_image(16, 15, 3), c = make_image(16, 16, 4);
    fill_constant(&a, 0.1f);
    fill_constant(&b, 0.1f);
    fill_constant(&c, 0.1f);
    double v;
    esr_error_clear();
    assert_int_equal(esr_metric_mse(&a, &b, &v), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "16x16 with 3 channels vs 16x15 with 3 channels"));
    esr_error_clear();
    assert_int_equal(esr_metric_ssim(&a, &c, &v), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "SSIM"));
    esr_error_clear();
    struct esr_image tiny = make_image(10, 20, 1), tiny2 = make_image(10, 20, 1);
    fill_constant(&tiny, 0.0f);
    fill_constant(&tiny2, 0.0f);
    assert_int_equal(esr_metric_ssim(&tiny, &tiny2, &v), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "11x11"));
    esr_error_clear();
    esr_image_free(&a);
    esr_image_free(&b);
    esr_image_free(&c);
    esr_image_free(&tiny);
    esr_image_free(&tiny2);
}

/* ImageMagick 6 (`compare -metric PSNR`, Debian 12's 6.9.11) prints to stderr
 * 10 log10(1 / MSE) with MSE the mean over pixels and channels of the squared difference of
 * values normalised to [0,1] by QuantumRange; for 8-bit PNGs that is (v/255), the same
 * normalisation as esr_png_read, so the numbers are directly comparable (it prints 6 significant
 * digits, e.g. "23.8787"). Exit status 1 only means "images differ". */
static void test_psnr_matches_imagemagick(void **state)
{
    (void)state;
    if (system("command -v compare >/dev/null 2>&1") != 0) {
        print_message("ImageMagick `compare` not found: skipping the cross-check\n");
        return;
    }
    char *dir = test_make_tmpdir();
    assert_non_null(dir);
    struct esr_image a = make_image(37, 29, 3), b = make_image(37, 29, 3);
    const float noise[] = {0.02f, 0.1f, 0.4f};
    for (size_t k = 0; k < sizeof noise / sizeof noise[0]; k++) {
        fill_random_pair(&a, &b, noise[k], 100 + k);
        char pa[512], pb[512], cmd[1200], line[256] = {0};
        snprintf(pa, sizeof pa, "%s/a.png", dir);
        snprintf(pb, sizeof pb, "%s/b.png", dir);
        assert_int_equal(esr_png_write(pa, &a, 8), ESR_OK);
        assert_int_equal(esr_png_write(pb, &b, 8), ESR_OK);
        /* compare the 8-bit values as stored, not the floats before quantisation */
        struct esr_image qa = {0}, qb = {0};
        assert_int_equal(esr_png_read(pa, &qa), ESR_OK);
        assert_int_equal(esr_png_read(pb, &qb), ESR_OK);
        double ours;
        assert_int_equal(esr_metric_psnr(&qa, &qb, &ours), ESR_OK);
        snprintf(cmd, sizeof cmd, "compare -metric PSNR '%s' '%s' null: 2>&1", pa, pb);
        FILE *p = popen(cmd, "r");
        assert_non_null(p);
        size_t got = fread(line, 1, sizeof line - 1, p);
        pclose(p);
        assert_true(got > 0);
        double theirs = strtod(line, NULL);
        print_message("noise %.2f: esr %.4f dB, ImageMagick %s\n", noise[k], ours, line);
        assert_true(fabs(ours - theirs) < 0.01);
        esr_image_free(&qa);
        esr_image_free(&qb);
    }
    esr_image_free(&a);
    esr_image_free(&b);
    test_rmtree(dir);
    free(dir);
}

/* ---- SSIM ---- */

/* Direct, unoptimised SSIM: for each valid output pixel, the 2-D 11x11 Gaussian window's
 * weighted mean, variance and covariance computed as sums of centred products (so no clipping
 * is needed), then the SSIM formula; averaged over pixels and channels. */
static double ssim_direct(const struct esr_image *a, const struct esr_image *b)
{
    double w[11][11], wsum = 0.0;
    for (int i = 0; i < 11; i++)
        for (int j = 0; j < 11; j++)
            wsum += w[i][j] = exp(-((i - 5) * (i - 5) + (j - 5) * (j - 5)) / (2.0 * 1.5 * 1.5));
    const double c1 = 0.0001, c2 = 0.0009;
    int nc = a->channels, ow = a->width - 10, oh = a->height - 10;
    double total = 0.0;
    for (int c = 0; c < nc; c++) {
        for (int y = 0; y < oh; y++) {
            for (int x = 0; x < ow; x++) {
                double ma = 0, mb = 0;
                for (int i = 0; i < 11; i++) {
                    for (int j = 0; j < 11; j++) {
                        size_t at = ((size_t)(y + i) * a->width + (x + j)) * nc + c;
                        ma += w[i][j] / wsum * a->data[at];
                        mb += w[i][j] / wsum * b->data[at];
                    }
                }
                double va = 0, vb = 0, cov = 0;
                for (int i = 0; i < 11; i++) {
                    for (int j = 0; j < 11; j++) {
                        size_t at = ((size_t)(y + i) * a->width + (x + j)) * nc + c;
                        double da = a->data[at] - ma, db = b->data[at] - mb;
                        va += w[i][j] / wsum * da * da;
                        vb += w[i][j] / wsum * db * db;
                        cov += w[i][j] / wsum * da * db;
                    }
                }
                total += (2 * ma * mb + c1) * (2 * cov + c2) / ((ma * ma + mb * mb + c1) * (va + vb + c2));
            }
        }
    }
    return total / ((double)ow * oh * nc);
}

static void test_ssim_matches_direct_implementation(void **state)
{
    (void)state;
    const int shapes[][3] = {{37, 29, 3}, {11, 11, 1}, {24, 40, 4}, {64, 48, 3}};
    const float noise[] = {0.05f, 0.3f, 1.0f};
    for (size_t s = 0; s < sizeof shapes / sizeof shapes[0]; s++) {
        for (size_t k = 0; k < sizeof noise / sizeof noise[0]; k++) {
            struct esr_image a = make_image(shapes[s][0], shapes[s][1], shapes[s][2]);
            struct esr_image b = make_image(shapes[s][0], shapes[s][1], shapes[s][2]);
            fill_random_pair(&a, &b, noise[k], 7 * s + k);
            double fast, direct = ssim_direct(&a, &b);
            assert_int_equal(esr_metric_ssim(&a, &b, &fast), ESR_OK);
            assert_true(fabs(fast - direct) < 1e-9);
            assert_true(fast < 1.0 && fast > -1.0);
            esr_image_free(&a);
            esr_image_free(&b);
        }
    }
}

/* Smooth images make the moments nearly equal, where E[x^2] - mu^2 cancels: still as direct. */
static void test_ssim_smooth_images(void **state)
{
    (void)state;
    struct esr_image a = make_image(30, 30, 3), b = make_image(30, 30, 3);
    for (int y = 0; y < 30; y++)
        for (int x = 0; x < 30; x++)
            for (int c = 0; c < 3; c++) {
                size_t i = ((size_t)y * 30 + x) * 3 + c;
                a.data[i] = 0.8f + 0.001f * x;
                b.data[i] = 0.8f + 0.001f * y + 0.002f * c;
            }
    double fast;
    assert_int_equal(esr_metric_ssim(&a, &b, &fast), ESR_OK);
    assert_true(fabs(fast - ssim_direct(&a, &b)) < 1e-7);
    esr_image_free(&a);
    esr_image_free(&b);
}

/* Identical images give exactly 1; constant images a, b have zero variance, so the map is
 * (2ab + C1)(C2) / ((a^2 + b^2 + C1)(C2)) = (2ab + C1) / (a^2 + b^2 + C1) everywhere. */
static void test_ssim_by_hand(void **state)
{
    (void)state;
    struct esr_image a = make_image(20, 15, 3), b = make_image(20, 15, 3);
    fill_random_pair(&a, &b, 0.2f, 1);
    double v;
    assert_int_equal(esr_metric_ssim(&a, &a, &v), ESR_OK);
    assert_true(fabs(v - 1.0) < 1e-12);
    const float pairs[][2] = {{0.2f, 0.7f}, {0.0f, 1.0f}, {0.5f, 0.5f}, {0.9f, 0.85f}};
    for (size_t k = 0; k < sizeof pairs / sizeof pairs[0]; k++) {
        double ca = pairs[k][0], cb = pairs[k][1];
        fill_constant(&a, pairs[k][0]);
        fill_constant(&b, pairs[k][1]);
        assert_int_equal(esr_metric_ssim(&a, &b, &v), ESR_OK);
        double want = (2 * ca * cb + 1e-4) / (ca * ca + cb * cb + 1e-4);
        assert_true(fabs(v - want) < 1e-9);
    }
    esr_image_free(&a);
    esr_image_free(&b);
}

/* ---- HDR MSE ---- */

/* Ground truth premultiplied RGBA (0.3, 0.6, 2.0, a = 0.5) on white: rgb + (1 - a) =
 * (0.8, 1.1, 2.5); against a prediction (1, 1, 1) the MSE is (0.04 + 0.01 + 2.25) / 3. */
static void test_hdr_mse_by_hand(void **state)
{
    (void)state;
    struct esr_image gt = make_image(3, 2, 4), pred = make_image(3, 2, 3);
    const float px[4] = {0.3f, 0.6f, 2.0f, 0.5f};
    for (int i = 0; i < 6; i++)
        memcpy(gt.data + 4 * i, px, sizeof px);
    fill_constant(&pred, 1.0f);
    double mse;
    assert_int_equal(esr_metric_hdr_mse(&pred, &gt, &mse), ESR_OK);
    assert_true(fabs(mse - (0.04 + 0.01 + 2.25) / 3.0) < 1e-6);
    esr_error_clear();
    assert_int_equal(esr_metric_hdr_mse(&pred, &pred, &mse), ESR_ERR); /* needs RGBA ground truth */
    assert_non_null(strstr(esr_error_message(), "4-channel"));
    esr_error_clear();
    esr_image_free(&gt);
    esr_image_free(&pred);
}

/* ---- IoU ---- */

static void test_iou_by_hand(void **state)
{
    (void)state;
    struct esr_iou_accum acc;
    esr_iou_init(&acc);
    assert_true(esr_iou_value(&acc) == 1.0); /* nothing anywhere: perfect agreement */
    struct esr_image pred = make_image(4, 2, 3), gt = make_image(4, 2, 4);
    fill_constant(&pred, 0.0f);
    fill_constant(&gt, 0.0f);
    /* view 1: predicted emitters at pixels 0, 1, 2 (each via a different channel), truth 1, 2, 3 */
    pred.data[0 * 3 + 0] = 0.31f;
    pred.data[1 * 3 + 1] = 5.0f;
    pred.data[2 * 3 + 2] = 0.30001f;
    pred.data[4 * 3 + 0] = 0.3f;  /* equal to k: not an emitter */
    gt.data[1 * 4] = gt.data[2 * 4] = gt.data[3 * 4] = 1.0f;
    gt.data[5 * 4] = 0.5f;        /* equal to the mask threshold: not an emitter */
    gt.data[6 * 4 + 1] = 1.0f;    /* only channel 0 of the mask counts */
    assert_int_equal(esr_iou_add(&acc, &pred, 0.3f, &gt, 0.5f), ESR_OK);
    assert_true(acc.intersection == 2 && acc.union_count == 4);
    /* view 2: no prediction, one true emitter pixel -> intersection 0, union 1 */
    fill_constant(&pred, 0.0f);
    fill_constant(&gt, 0.0f);
    gt.data[7 * 4] = 0.9f;
    assert_int_equal(esr_iou_add(&acc, &pred, 0.3f, &gt, 0.5f), ESR_OK);
    assert_true(fabs(esr_iou_value(&acc) - 2.0 / 5.0) < 1e-15); /* sums, not a mean of 0.5 and 0 */
    struct esr_image other = make_image(2, 4, 3);
    esr_error_clear();
    assert_int_equal(esr_iou_add(&acc, &other, 0.3f, &gt, 0.5f), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "2x4"));
    esr_error_clear();
    esr_image_free(&pred);
    esr_image_free(&gt);
    esr_image_free(&other);
}

/* On the real scene a ground-truth emission mask, used as a prediction, agrees with itself. */
static void test_iou_real_mask(void **state)
{
    (void)state;
    const char *scene = test_shared_scene("lamp");
    if (!scene) {
        print_message("shared lamp scene absent: skipping\n");
        return;
    }
    char path[1200];
    snprintf(path, sizeof path, "%s/test_nv/emission/c000_on.png", scene);
    struct esr_image mask = {0};
    if (esr_png_read(path, &mask) != ESR_OK) {
        print_message("%s unreadable (%s): skipping\n", path, esr_error_message());
        esr_error_clear();
        return;
    }
    struct esr_iou_accum acc;
    esr_iou_init(&acc);
    assert_int_equal(esr_iou_add(&acc, &mask, 0.5f, &mask, 0.5f), ESR_OK);
    assert_true(acc.union_count > 0); /* the lamp's mask has emitter pixels */
    assert_true(esr_iou_value(&acc) == 1.0);
    esr_image_free(&mask);
}

/* ---- the `esr metrics` command ---- */

static double json_number(const cJSON *obj, const char *name)
{
    const cJSON *item = cJSON_GetObjectItemCaseSensitive(obj, name);
    assert_non_null(item);
    assert_true(cJSON_IsNumber(item));
    return item->valuedouble;
}

static void test_cli_metrics(void **state)
{
    (void)state;
    char *dir = test_make_tmpdir();
    assert_non_null(dir);
    char pa[512], pb[512], pc[512], pjson[512], args[2400], out[4096];
    snprintf(pa, sizeof pa, "%s/a.png", dir);
    snprintf(pb, sizeof pb, "%s/b.png", dir);
    snprintf(pc, sizeof pc, "%s/small.png", dir);
    snprintf(pjson, sizeof pjson, "%s/m.json", dir);
    struct esr_image a = make_image(32, 24, 3), b = make_image(32, 24, 3), c = make_image(31, 24, 3);
    fill_random_pair(&a, &b, 0.1f, 55);
    fill_constant(&c, 0.5f);
    assert_int_equal(esr_png_write(pa, &a, 8), ESR_OK);
    assert_int_equal(esr_png_write(pb, &b, 8), ESR_OK);
    assert_int_equal(esr_png_write(pc, &c, 8), ESR_OK);
    struct esr_image qa = {0}, qb = {0};
    assert_int_equal(esr_png_read(pa, &qa), ESR_OK);
    assert_int_equal(esr_png_read(pb, &qb), ESR_OK);
    double mse, ssim;
    assert_int_equal(esr_metric_mse(&qa, &qb, &mse), ESR_OK);
    assert_int_equal(esr_metric_ssim(&qa, &qb, &ssim), ESR_OK);

    snprintf(args, sizeof args, "metrics '%s' '%s' --json '%s'", pa, pb, pjson);
    assert_int_equal(test_run_esr(args, out, sizeof out), 0);
    cJSON *obj = cJSON_Parse(out);
    assert_non_null(obj);
    assert_true(fabs(json_number(obj, "mse") - mse) < 1e-12);
    assert_true(fabs(json_number(obj, "psnr") - esr_psnr_from_mse(mse)) < 1e-9);
    assert_true(fabs(json_number(obj, "ssim") - ssim) < 1e-12);
    assert_true(json_number(obj, "width") == 32 && json_number(obj, "height") == 24);
    cJSON_Delete(obj);
    FILE *f = fopen(pjson, "rb");
    assert_non_null(f);
    char saved[4096] = {0};
    size_t n_saved = fread(saved, 1, sizeof saved - 1, f);
    fclose(f);
    assert_true(n_saved > 0 && strncmp(saved, out, n_saved) == 0); /* same object as stdout */

    snprintf(args, sizeof args, "metrics '%s' '%s'", pa, pa); /* identical: PSNR infinite -> null */
    assert_int_equal(test_run_esr(args, out, sizeof out), 0);
    obj = cJSON_Parse(out);
    assert_non_null(obj);
    assert_true(cJSON_IsNull(cJSON_GetObjectItemCaseSensitive(obj, "psnr")));
    assert_true(json_number(obj, "ssim") == 1.0);
    cJSON_Delete(obj);

    snprintf(args, sizeof args, "metrics '%s' '%s'", pa, pc);
    assert_int_not_equal(test_run_esr(args, out, sizeof out), 0);
    assert_non_null(strstr(out, "32x24"));
    assert_non_null(strstr(out, "31x24"));
    assert_non_null(strstr(out, "small.png"));

    snprintf(args, sizeof args, "metrics '%s' '%s/missing.png'", pa, dir);
    assert_int_not_equal(test_run_esr(args, out, sizeof out), 0);
    assert_non_null(strstr(out, "missing.png"));
    assert_int_not_equal(test_run_esr("metrics onlyone.png", out, sizeof out), 0);
    assert_non_null(strstr(out, "two images"));
    /* an EXR (linear) against a PNG (sRGB-encoded): refused, not scored */
    char pe[512], pfifo[512], ptiny[512], ptiny2[512];
    snprintf(pe, sizeof pe, "%s/a.exr", dir);
    assert_int_equal(esr_exr_write(pe, &a, 0), ESR_OK);
    snprintf(args, sizeof args, "metrics '%s' '%s'", pe, pa);
    assert_int_not_equal(test_run_esr(args, out, sizeof out), 0);
    assert_non_null(strstr(out, "holds linear values"));
    /* a FIFO named like an image: refused at once (opening it waited for a writer forever) */
    snprintf(pfifo, sizeof pfifo, "%s/fifo.png", dir);
    assert_int_equal(mkfifo(pfifo, 0644), 0);
    snprintf(args, sizeof args, "metrics '%s' '%s'", pa, pfifo);
    assert_int_not_equal(test_run_esr(args, out, sizeof out), 0);
    assert_non_null(strstr(out, "not a regular file"));
    /* images under the SSIM window: PSNR and MSE, SSIM null */
    struct esr_image t1 = make_image(8, 8, 3), t2 = make_image(8, 8, 3);
    fill_random_pair(&t1, &t2, 0.1f, 56);
    snprintf(ptiny, sizeof ptiny, "%s/t1.png", dir);
    snprintf(ptiny2, sizeof ptiny2, "%s/t2.png", dir);
    assert_int_equal(esr_png_write(ptiny, &t1, 8), ESR_OK);
    assert_int_equal(esr_png_write(ptiny2, &t2, 8), ESR_OK);
    snprintf(args, sizeof args, "metrics '%s' '%s'", ptiny, ptiny2);
    assert_int_equal(test_run_esr(args, out, sizeof out), 0);
    obj = cJSON_Parse(out);
    assert_non_null(obj);
    assert_true(cJSON_IsNull(cJSON_GetObjectItemCaseSensitive(obj, "ssim")));
    assert_true(json_number(obj, "mse") > 0.0 && json_number(obj, "psnr") > 0.0);
    cJSON_Delete(obj);
    esr_image_free(&t1);
    esr_image_free(&t2);

    esr_image_free(&a);
    esr_image_free(&b);
    esr_image_free(&c);
    esr_image_free(&qa);
    esr_image_free(&qb);
    test_rmtree(dir);
    free(dir);
}

/* EXR inputs are premultiplied RGBA: the command composites them on white (rgb + 1 - a), so its
 * MSE equals esr_metric_hdr_mse of the composited prediction against the raw ground truth. */
static void test_cli_metrics_exr(void **state)
{
    (void)state;
    static const float white[3] = {1, 1, 1};
    char *dir = test_make_tmpdir();
    assert_non_null(dir);
    char pa[512], pb[512], args[1200], out[4096];
    snprintf(pa, sizeof pa, "%s/pred.exr", dir);
    snprintf(pb, sizeof pb, "%s/gt.EXR", dir); /* extension case does not matter */
    struct esr_image a = make_image(16, 12, 4), b = make_image(16, 12, 4);
    struct esr_rng rng = esr_rng_init(66, 0);
    for (size_t p = 0; p < (size_t)16 * 12; p++) {
        float alpha_a = esr_rng_float(&rng), alpha_b = esr_rng_float(&rng);
        for (int c = 0; c < 3; c++) { /* premultiplied HDR colour: rgb <= 4 a */
            a.data[4 * p + c] = 4.0f * alpha_a * esr_rng_float(&rng);
            b.data[4 * p + c] = 4.0f * alpha_b * esr_rng_float(&rng);
        }
        a.data[4 * p + 3] = alpha_a;
        b.data[4 * p + 3] = alpha_b;
    }
    assert_int_equal(esr_exr_write(pa, &a, 0), ESR_OK);
    assert_int_equal(esr_exr_write(pb, &b, 0), ESR_OK);
    struct esr_image pred = {0};
    assert_int_equal(esr_image_composite_premultiplied(&a, white, &pred), ESR_OK);
    double mse;
    assert_int_equal(esr_metric_hdr_mse(&pred, &b, &mse), ESR_OK);
    snprintf(args, sizeof args, "metrics '%s' '%s'", pa, pb);
    assert_int_equal(test_run_esr(args, out, sizeof out), 0);
    cJSON *obj = cJSON_Parse(out);
    assert_non_null(obj);
    assert_true(fabs(json_number(obj, "mse") - mse) < 1e-9 * fmax(1.0, mse));
    assert_true(mse > 0.1); /* HDR values well beyond [0,1] took part */
    cJSON_Delete(obj);
    esr_image_free(&a);
    esr_image_free(&b);
    esr_image_free(&pred);
    test_rmtree(dir);
    free(dir);
}

/* Dataset RGBA PNGs are composited on white: the command's numbers equal the in-process ones
 * computed from the composited images. */
static void test_cli_metrics_real_scene(void **state)
{
    (void)state;
    const char *scene = test_shared_scene("lamp");
    if (!scene) {
        print_message("shared lamp scene absent: skipping\n");
        return;
    }
    static const float white[3] = {1, 1, 1};
    char pa[1200], pb[1200], args[2600], out[4096];
    snprintf(pa, sizeof pa, "%s/test_nv/c000_off.png", scene);
    snprintf(pb, sizeof pb, "%s/test_nv/c000_on.png", scene);
    struct esr_image ra = {0}, rb = {0}, a = {0}, b = {0};
    assert_int_equal(esr_png_read(pa, &ra), ESR_OK);
    assert_int_equal(esr_png_read(pb, &rb), ESR_OK);
    assert_int_equal(esr_image_composite(&ra, white, &a), ESR_OK);
    assert_int_equal(esr_image_composite(&rb, white, &b), ESR_OK);
    double psnr, ssim;
    assert_int_equal(esr_metric_psnr(&a, &b, &psnr), ESR_OK);
    assert_int_equal(esr_metric_ssim(&a, &b, &ssim), ESR_OK);
    snprintf(args, sizeof args, "metrics '%s' '%s'", pa, pb);
    assert_int_equal(test_run_esr(args, out, sizeof out), 0);
    cJSON *obj = cJSON_Parse(out);
    assert_non_null(obj);
    assert_true(fabs(json_number(obj, "psnr") - psnr) < 1e-9);
    assert_true(fabs(json_number(obj, "ssim") - ssim) < 1e-12);
    assert_true(ssim > 0.0 && ssim < 1.0);
    cJSON_Delete(obj);
    esr_image_free(&ra);
    esr_image_free(&rb);
    esr_image_free(&a);
    esr_image_free(&b);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_mse_psnr_by_hand),
        cmocka_unit_test(test_shape_mismatch_is_an_error),
        cmocka_unit_test(test_psnr_matches_imagemagick),
        cmocka_unit_test(test_ssim_matches_direct_implementation),
        cmocka_unit_test(test_ssim_smooth_images),
        cmocka_unit_test(test_ssim_by_hand),
        cmocka_unit_test(test_hdr_mse_by_hand),
        cmocka_unit_test(test_iou_by_hand),
        cmocka_unit_test(test_iou_real_mask),
        cmocka_unit_test(test_cli_metrics),
        cmocka_unit_test(test_cli_metrics_exr),
        cmocka_unit_test(test_cli_metrics_real_scene),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
