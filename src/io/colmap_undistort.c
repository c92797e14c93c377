/* Undistortion and resampling of COLMAP photos (see colmap_undistort.h). */
#include "io/colmap_undistort.h"

#include <math.h>
#include <string.h>

#include "core/error.h"
#include "io/colmap_camera.h"

enum { BORDER_SAMPLES = 256, MAX_SUPERSAMPLE = 16 };

/* Point s of BORDER_SAMPLES + 1 along edge e (0 left, 1 right, 2 top, 3 bottom) of a w x h
 * rectangle whose top-left corner is (x0, y0). */
static void edge_point(int e, int s, double x0, double y0, double w, double h, double *x, double *y)
{
    double a = (double)s / BORDER_SAMPLES;
    *x = e == 0 ? x0 : e == 1 ? x0 + w : x0 + a * w;
    *y = e == 2 ? y0 : e == 3 ? y0 + h : y0 + a * h;
}

/* 1 when the whole border of the centred rectangle [-hx, hx] x [-hy, hy] (normalised, undistorted)
 * distorts to positions inside the image. */
static int rectangle_inside(const struct esr_colmap_intrinsics *k, int width, int height, double hx, double hy)
{
    const double slack = 1e-6;
    for (int e = 0; e < 4; e++)
        for (int s = 0; s <= BORDER_SAMPLES; s++) {
            double u, v, ud, vd;
            edge_point(e, s, -hx, -hy, 2 * hx, 2 * hy, &u, &v);
            esr_colmap_distort(k, u, v, &ud, &vd);
            double px = k->fx * ud + k->cx, py = k->fy * vd + k->cy;
            if (!(px >= -slack && px <= width + slack && py >= -slack && py <= height + slack))
                return 0;
        }
    return 1;
}

int esr_colmap_valid_extent(const struct esr_colmap_camera *cam, double *half_x, double *half_y)
{
    struct esr_colmap_intrinsics k;
    esr_colmap_intrinsics_of(cam, &k);
    double hx = INFINITY, hy = INFINITY;
    for (int e = 0; e < 4; e++)
        for (int s = 0; s <= BORDER_SAMPLES; s++) {
            double px, py, u, v;
            edge_point(e, s, 0.0, 0.0, cam->width, cam->height, &px, &py);
            if (esr_colmap_undistort(&k, (px - k.cx) / k.fx, (py - k.cy) / k.fy, &u, &v) != ESR_OK)
                return ESR_FAIL("camera %u (%s): its distortion cannot be inverted at the image border", cam->id,
                                esr_colmap_model_name(cam->model));
            /* the rectangle may reach no further than the innermost point of each edge */
            double reach = e == 0 ? -u : e == 1 ? u : e == 2 ? -v : v;
            if (e < 2)
                hx = fmin(hx, reach);
            else
                hy = fmin(hy, reach);
        }
    if (!(hx > 0.0 && hy > 0.0))
        return ESR_FAIL("camera %u: the principal point (%g, %g) is not inside the %dx%d image", cam->id, k.cx, k.cy,
                        cam->width, cam->height);
    /* in small steps: the edge samples can miss an edge's innermost point by a little */
    for (int it = 0; it < 2000 && !rectangle_inside(&k, cam->width, cam->height, hx, hy); it++) {
        hx *= 0.998;
        hy *= 0.998;
    }
    if (!rectangle_inside(&k, cam->width, cam->height, hx, hy))
        return ESR_FAIL("camera %u (%s): no undistorted rectangle around the optical axis fits in the image",
                        cam->id, esr_colmap_model_name(cam->model));
    *half_x = hx;
    *half_y = hy;
    return ESR_OK;
}

/* Bilinear sample of img at continuous pixel position (px, py) (pixel centres at +0.5), edges
 * clamped; adds weight x the sample to acc[channels]. */
static void bilinear_add(const struct esr_image *img, double px, double py, float weight, float *acc)
{
    double x = px - 0.5, y = py - 0.5;
    double fx0 = floor(x), fy0 = floor(y);
    float ax = (float)(x - fx0), ay = (float)(y - fy0);
    int x0 = (int)fx0, y0 = (int)fy0, x1 = x0 + 1, y1 = y0 + 1;
    x0 = x0 < 0 ? 0 : x0 >= img->width ? img->width - 1 : x0;
    x1 = x1 < 0 ? 0 : x1 >= img->width ? img->width - 1 : x1;
    y0 = y0 < 0 ? 0 : y0 >= img->height ? img->height - 1 : y0;
    y1 = y1 < 0 ? 0 : y1 >= img->height ? img->height - 1 : y1;
    const int c = img->channels;
    const float *p00 = img->data + ((size_t)y0 * (size_t)img->width + (size_t)x0) * (size_t)c;
    const float *p10 = img->data + ((size_t)y0 * (size_t)img->width + (size_t)x1) * (size_t)c;
    const float *p01 = img->data + ((size_t)y1 * (size_t)img->width + (size_t)x0) * (size_t)c;
    const float *p11 = img->data + ((size_t)y1 * (size_t)img->width + (size_t)x1) * (size_t)c;
    for (int ch = 0; ch < c; ch++) {
        float top = p00[ch] + ax * (p10[ch] - p00[ch]), bottom = p01[ch] + ax * (p11[ch] - p01[ch]);
        acc[ch] += weight * (top + ay * (bottom - top));
    }
}

int esr_colmap_undistort_image(const struct esr_colmap_camera *cam, const struct esr_image *src,
                               const struct esr_pinhole_view *view, struct esr_image *dst)
{
    if (src->width != cam->width || src->height != cam->height)
        return ESR_FAIL("image is %dx%d but COLMAP camera %u is %dx%d", src->width, src->height, cam->id, cam->width,
                        cam->height);
    if (!(view->focal > 0.0) || view->width <= 0 || view->height <= 0)
        return ESR_FAIL("invalid output view %dx%d, focal %g", view->width, view->height, view->focal);
    ESR_TRY(esr_image_alloc(dst, view->width, view->height, src->channels));
    struct esr_colmap_intrinsics k;
    esr_colmap_intrinsics_of(cam, &k);
    int ss = (int)ceil(fmax(k.fx, k.fy) / view->focal - 1e-9);
    ss = ss < 1 ? 1 : ss > MAX_SUPERSAMPLE ? MAX_SUPERSAMPLE : ss;
    const float weight = 1.0f / (float)(ss * ss);
    const int c = src->channels;
#pragma omp parallel for schedule(dynamic, 4)
    for (int j = 0; j < view->height; j++)
        for (int i = 0; i < view->width; i++) {
            float acc[4] = {0.0f, 0.0f, 0.0f, 0.0f};
            for (int b = 0; b < ss; b++)
                for (int a = 0; a < ss; a++) {
                    double u = (i + (a + 0.5) / ss - 0.5 * view->width) / view->focal;
                    double v = (j + (b + 0.5) / ss - 0.5 * view->height) / view->focal;
                    double ud, vd;
                    esr_colmap_distort(&k, u, v, &ud, &vd);
                    bilinear_add(src, k.fx * ud + k.cx, k.fy * vd + k.cy, weight, acc);
                }
            memcpy(dst->data + ((size_t)j * (size_t)view->width + (size_t)i) * (size_t)c, acc,
                   (size_t)c * sizeof(float));
        }
    return ESR_OK;
}
