/* Undistortion and resampling of COLMAP photos (see colmap_undistort.h). */
#include "import/colmap_undistort.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/error.h"

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
            double px, py;
            esr_colmap_distort(k, u, v, &ud, &vd);
            esr_colmap_to_pixel(k, ud, vd, &px, &py);
            if (!(px >= -slack && px <= width + slack && py >= -slack && py <= height + slack))
                return 0;
        }
    return 1;
}

int esr_undistort_extent(const struct esr_colmap_intrinsics *k, int width, int height, const char *camera,
                         double *half_x, double *half_y)
{
    double hx = INFINITY, hy = INFINITY;
    for (int e = 0; e < 4; e++)
        for (int s = 0; s <= BORDER_SAMPLES; s++) {
            double px, py, ud, vd, u, v;
            edge_point(e, s, 0.0, 0.0, width, height, &px, &py);
            esr_colmap_from_pixel(k, px, py, &ud, &vd);
            if (esr_colmap_undistort(k, ud, vd, &u, &v) != ESR_OK)
                return ESR_FAIL("%s: its distortion cannot be inverted at the image border", camera);
            /* the rectangle may reach no further than the innermost point of each edge */
            double reach = e == 0 ? -u : e == 1 ? u : e == 2 ? -v : v;
            if (e < 2)
                hx = fmin(hx, reach);
            else
                hy = fmin(hy, reach);
        }
    if (!(hx > 0.0 && hy > 0.0))
        return ESR_FAIL("%s: the principal point (%g, %g) is not inside the %dx%d image", camera, k->cx, k->cy,
                        width, height);
    /* in small steps: the edge samples can miss an edge's innermost point by a little */
    for (int it = 0; it < 2000 && !rectangle_inside(k, width, height, hx, hy); it++) {
        hx *= 0.998;
        hy *= 0.998;
    }
    if (!rectangle_inside(k, width, height, hx, hy))
        return ESR_FAIL("%s: no undistorted rectangle around the optical axis fits in the image", camera);
    *half_x = hx;
    *half_y = hy;
    return ESR_OK;
}

int esr_colmap_valid_extent(const struct esr_colmap_camera *cam, double *half_x, double *half_y)
{
    struct esr_colmap_intrinsics k;
    esr_colmap_intrinsics_of(cam, &k);
    char name[64];
    snprintf(name, sizeof name, "camera %u (%s)", cam->id, esr_colmap_model_name(cam->model));
    return esr_undistort_extent(&k, cam->width, cam->height, name, half_x, half_y);
}

int esr_pinhole_view_fit(double half_x, double half_y, int size, struct esr_pinhole_view *v)
{
    if (half_x >= half_y) {
        v->width = size;
        v->focal = size / (2.0 * half_x);
        v->height = (int)floor(2.0 * half_y * v->focal);
    } else {
        v->height = size;
        v->focal = size / (2.0 * half_y);
        v->width = (int)floor(2.0 * half_x * v->focal);
    }
    if (v->width < 1 || v->height < 1)
        return ESR_FAIL("the cameras' common view is too narrow for %d pixels", size);
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

int esr_undistort_resample(const struct esr_colmap_intrinsics *k, const struct esr_image *src,
                           const struct esr_pinhole_view *view, struct esr_image *dst)
{
    if (!(view->focal > 0.0) || view->width <= 0 || view->height <= 0)
        return ESR_FAIL("invalid output view %dx%d, focal %g", view->width, view->height, view->focal);
    ESR_TRY(esr_image_alloc(dst, view->width, view->height, src->channels));
    int ss = (int)ceil(fmax(k->fx, k->fy) / view->focal - 1e-9);
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
                    double ud, vd, px, py;
                    esr_colmap_distort(k, u, v, &ud, &vd);
                    esr_colmap_to_pixel(k, ud, vd, &px, &py);
                    bilinear_add(src, px, py, weight, acc);
                }
            memcpy(dst->data + ((size_t)j * (size_t)view->width + (size_t)i) * (size_t)c, acc,
                   (size_t)c * sizeof(float));
        }
    return ESR_OK;
}

int esr_colmap_undistort_image(const struct esr_colmap_camera *cam, const struct esr_image *src,
                               const struct esr_pinhole_view *view, struct esr_image *dst)
{
    if (src->width != cam->width || src->height != cam->height)
        return ESR_FAIL("image is %dx%d but COLMAP camera %u is %dx%d", src->width, src->height, cam->id, cam->width,
                        cam->height);
    struct esr_colmap_intrinsics k;
    esr_colmap_intrinsics_of(cam, &k);
    return esr_undistort_resample(&k, src, view, dst);
}
