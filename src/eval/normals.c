/* Angular error of rendered normals against ground-truth normal maps (eval/normals.h). */
#include "eval/normals.h"

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/buffers.h"
#include "core/error.h"
#include "core/order.h"
#include "io/file.h"

double esr_normal_angle_deg(const float a[3], const float b[3])
{
    double ax = a[0], ay = a[1], az = a[2], bx = b[0], by = b[1], bz = b[2];
    double la = sqrt(ax * ax + ay * ay + az * az), lb = sqrt(bx * bx + by * by + bz * bz);
    if (!(la > 0.0) || !(lb > 0.0) || !isfinite(la) || !isfinite(lb))
        return NAN;
    /* atan2(|a x b|, a . b) is accurate at 0 and 180 degrees, where acos of the dot is not. */
    double cx = ay * bz - az * by, cy = az * bx - ax * bz, cz = ax * by - ay * bx;
    double dot = ax * bx + ay * by + az * bz;
    return atan2(sqrt(cx * cx + cy * cy + cz * cz), dot) * (180.0 / M_PI);
}

int esr_normal_gt_path(const struct esr_dataset *ds, const struct esr_frame *f, char *out, size_t n)
{
    const char *name = f->name;
    size_t len = 1;
    if (name[0] != 'c')
        return 0;
    while (isdigit((unsigned char)name[len]))
        len++;
    if (len == 1 || name[len] != '_')
        return 0;
    int w = snprintf(out, n, "%s/gt/%.*s_normal.exr", ds->root, (int)len, name);
    return w > 0 && (size_t)w < n && esr_file_exists(out);
}

static int is_surface(const float *n)
{
    return n[0] != 0.0f || n[1] != 0.0f || n[2] != 0.0f;
}

int esr_normal_errors_add(struct esr_normal_errors *e, const struct esr_image *pred, const struct esr_image *gt)
{
    if (pred->width != gt->width || pred->height != gt->height)
        return ESR_FAIL("normal map is %dx%d but the ground truth is %dx%d", pred->width, pred->height, gt->width,
                        gt->height);
    if (pred->channels != 4)
        return ESR_FAIL("rendered normal map has %d channels; expected 4 (normal, opacity)", pred->channels);
    if (gt->channels < 3)
        return ESR_FAIL("ground-truth normal map has %d channels; expected 3 or 4", gt->channels);
    size_t n_pix = (size_t)gt->width * (size_t)gt->height;
    ESR_TRY(esr_floats_reserve(&e->deg, &e->cap, e->n + n_pix, "normal errors"));
    for (size_t i = 0; i < n_pix; i++) {
        const float *g = gt->data + (size_t)gt->channels * i, *p = pred->data + 4 * i;
        if (!is_surface(g))
            continue;
        e->n_gt++;
        if (!(p[3] > ESR_NORMAL_MIN_OPACITY))
            continue;
        double deg = esr_normal_angle_deg(p, g);
        if (!isnan(deg))
            e->deg[e->n++] = (float)deg;
    }
    return ESR_OK;
}

void esr_normal_errors_free(struct esr_normal_errors *e)
{
    free(e->deg);
    memset(e, 0, sizeof *e);
}

struct esr_normal_stats esr_normal_stats_of(float *deg, size_t n, long n_gt)
{
    struct esr_normal_stats s;
    s.n_gt = n_gt;
    s.n = (long)n;
    s.mean_deg = s.median_deg = s.frac_good = NAN;
    s.coverage = n_gt > 0 ? (double)n / (double)n_gt : NAN;
    if (n == 0)
        return s;
    esr_sort_floats(deg, n);
    double sum = 0.0;
    size_t good = 0;
    for (size_t i = 0; i < n; i++) {
        sum += deg[i];
        good += deg[i] < ESR_NORMAL_GOOD_DEG;
    }
    s.mean_deg = sum / (double)n;
    s.median_deg = n % 2 ? deg[n / 2] : 0.5 * ((double)deg[n / 2 - 1] + (double)deg[n / 2]);
    s.frac_good = (double)good / (double)n;
    return s;
}
