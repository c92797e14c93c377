/* A COLMAP reconstruction aligned to and compared with true cameras (see colmap_align.h). */
#include "import/colmap_align.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cjson/cJSON.h>

#include "core/error.h"
#include "core/order.h"
#include "import/colmap_camera.h"
#include "io/file.h"

/* The true train frame named like image `name` ("off/sub/r_003.png" -> "r_003"), or NULL. */
static const struct esr_frame *true_frame(const struct esr_phase *train, const char *name)
{
    const char *slash = strrchr(name, '/'), *base = slash ? slash + 1 : name, *dot = strrchr(base, '.');
    size_t stem = dot ? (size_t)(dot - base) : strlen(base);
    for (int i = 0; i < train->n_frames; i++)
        if (strlen(train->frames[i].name) == stem && !strncmp(train->frames[i].name, base, stem))
            return &train->frames[i];
    return NULL;
}

/* Median (mean of the middle two for even n) and maximum of v[0..n-1], n > 0; sorts v. */
static void median_max(double *v, int n, double *median, double *max)
{
    *median = esr_median_doubles(v, (size_t)n);
    *max = v[n - 1];
}

int esr_colmap_scene_radius_parse(const char *text, size_t size, const char *name, double *radius)
{
    *radius = 1.0;
    cJSON *root = cJSON_ParseWithLength(text, size);
    if (!root)
        return ESR_FAIL("'%s' is not valid JSON", name);
    const cJSON *box = cJSON_GetObjectItemCaseSensitive(root, "bounding_box");
    const cJSON *lo = cJSON_GetObjectItemCaseSensitive(box, "tight_min");
    const cJSON *hi = cJSON_GetObjectItemCaseSensitive(box, "tight_max");
    int status = ESR_OK;
    if (lo || hi) {
        double half = 0.0;
        for (int k = 0; k < 3 && status == ESR_OK; k++) {
            const cJSON *a = cJSON_GetArrayItem(lo, k), *b = cJSON_GetArrayItem(hi, k);
            /* a finite, positive half side: 1e308 - -1e308 is not finite, 0.5 * 5e-324 is 0 */
            double side = cJSON_IsNumber(a) && cJSON_IsNumber(b) ? 0.5 * (b->valuedouble - a->valuedouble) : 0.0;
            if (!(side > 0.0 && isfinite(side)))
                status = ESR_FAIL("'%s': bounding_box.tight_min/tight_max must be two 3-vectors, min below max", name);
            else
                half = fmax(half, side);
        }
        if (status == ESR_OK)
            *radius = half;
    }
    cJSON_Delete(root);
    return status;
}

/* esr_colmap_scene_radius_parse on truth's scene.json, 1 without one. */
static int scene_radius(const struct esr_dataset *truth, double *radius)
{
    *radius = 1.0;
    char path[ESR_PATH_MAX + 16];
    snprintf(path, sizeof path, "%s/scene.json", truth->root);
    if (!esr_file_exists(path))
        return ESR_OK;
    unsigned char *text;
    size_t size;
    ESR_TRY(esr_file_read_all(path, &text, &size));
    int status = esr_colmap_scene_radius_parse((const char *)text, size, path, radius);
    free(text);
    return status;
}

/* The matched pairs: COLMAP camera centres and poses (esr convention, COLMAP world) and the true
 * frames, in model order. */
struct matches {
    int n;
    double *colmap_centres, *true_centres; /* n * 3 */
    double (*colmap_c2w)[3][4];
    const struct esr_frame **truth;
};

static void matches_free(struct matches *mt)
{
    free(mt->colmap_centres);
    free(mt->true_centres);
    free(mt->colmap_c2w);
    free(mt->truth);
}

static int match_images(const struct esr_colmap_model *m, const struct esr_dataset *truth, struct matches *mt)
{
    const struct esr_phase *train = &truth->phases[ESR_PHASE_TRAIN];
    size_t n = (size_t)(m->n_images > 0 ? m->n_images : 1);
    mt->n = 0;
    mt->colmap_centres = malloc(n * 3 * sizeof(double));
    mt->true_centres = malloc(n * 3 * sizeof(double));
    mt->colmap_c2w = malloc(n * sizeof *mt->colmap_c2w);
    mt->truth = malloc(n * sizeof *mt->truth);
    if (!mt->colmap_centres || !mt->true_centres || !mt->colmap_c2w || !mt->truth)
        return ESR_FAIL("out of memory matching %d images to the true cameras", m->n_images);
    for (int i = 0; i < m->n_images; i++) {
        const struct esr_frame *f = true_frame(train, m->images[i].name);
        if (!f)
            return ESR_FAIL("COLMAP image '%s' has no train frame of that name in '%s' (the photos must be named "
                            "like the true dataset's train images)", m->images[i].name, truth->root);
        int k = mt->n++;
        mt->truth[k] = f;
        esr_colmap_camera_to_world(&m->images[i], mt->colmap_c2w[k]);
        for (int a = 0; a < 3; a++) {
            mt->colmap_centres[3 * k + a] = mt->colmap_c2w[k][a][3];
            mt->true_centres[3 * k + a] = f->camera.c2w[a][3];
        }
    }
    return ESR_OK;
}

#define RANSAC_SAMPLES 4000

/* Matched cameras whose centre s maps within thr of the true one: their count, and their
 * indices into `inliers` when non-NULL. */
static int count_inliers(const struct matches *mt, const struct esr_similarity *s, double thr, int *inliers)
{
    int n = 0;
    for (int k = 0; k < mt->n; k++) {
        double c[3], d2 = 0.0;
        esr_similarity_apply(s, &mt->colmap_centres[3 * k], c);
        for (int a = 0; a < 3; a++)
            d2 += pow(c[a] - mt->true_centres[3 * k + a], 2);
        if (d2 < thr * thr) {
            if (inliers)
                inliers[n] = k;
            n++;
        }
    }
    return n;
}

/* Least squares on the cameras listed in idx. */
static int fit_subset(const struct matches *mt, const int *idx, int n, double *x, double *y, struct esr_similarity *s)
{
    for (int i = 0; i < n; i++)
        for (int a = 0; a < 3; a++) {
            x[3 * i + a] = mt->colmap_centres[3 * idx[i] + a];
            y[3 * i + a] = mt->true_centres[3 * idx[i] + a];
        }
    return esr_similarity_fit(x, y, n, s);
}

/* The similarity of the 3-camera sample most cameras agree with, refitted on its inliers (the
 * least-squares fit on all cameras when no sample has more than 3 inliers). Samples come from a
 * fixed LCG, so the result is reproducible. */
static int robust_fit(const struct matches *mt, double thr, struct esr_colmap_alignment *a)
{
    int *idx = malloc((size_t)mt->n * sizeof *idx);
    double *x = malloc((size_t)mt->n * 3 * sizeof *x), *y = malloc((size_t)mt->n * 3 * sizeof *y);
    int status = idx && x && y ? ESR_OK : ESR_FAIL("out of memory aligning %d cameras", mt->n);
    int best = 0;
    struct esr_similarity best_s;
    uint64_t state = 0x9E3779B97F4A7C15ull;
    for (int t = 0; t < RANSAC_SAMPLES && status == ESR_OK; t++) {
        int sample[3];
        for (int i = 0; i < 3; i++) {
            state = state * 6364136223846793005ull + 1442695040888963407ull;
            sample[i] = (int)((state >> 33) % (uint64_t)mt->n);
        }
        struct esr_similarity s;
        if (sample[0] == sample[1] || sample[1] == sample[2] || sample[0] == sample[2])
            continue;
        if (fit_subset(mt, sample, 3, x, y, &s) != ESR_OK) {
            esr_error_clear(); /* a degenerate sample (collinear centres) is skipped, not an error */
            continue;
        }
        int n = count_inliers(mt, &s, thr, NULL);
        if (n > best) {
            best = n;
            best_s = s;
        }
    }
    if (status == ESR_OK) {
        if (best > 3) { /* refit on the inliers, twice: the refit can admit a few more */
            for (int pass = 0; pass < 2 && status == ESR_OK; pass++) {
                int n = count_inliers(mt, &best_s, thr, idx);
                if (n >= 3)
                    status = fit_subset(mt, idx, n, x, y, &best_s);
            }
            a->colmap_to_true = best_s;
        } else {
            for (int k = 0; k < mt->n; k++)
                idx[k] = k;
            status = fit_subset(mt, idx, mt->n, x, y, &a->colmap_to_true);
        }
    }
    if (status == ESR_OK)
        a->n_inliers = count_inliers(mt, &a->colmap_to_true, thr, NULL);
    free(idx);
    free(x);
    free(y);
    return status;
}

/* Each matched camera moved into the true world by the fitted similarity and compared with its
 * true camera: rotation angle and centre distance, over all cameras and over the inliers. */
static int measure(const struct matches *mt, struct esr_colmap_alignment *a)
{
    double *rot = malloc((size_t)mt->n * sizeof *rot), *pos = malloc((size_t)mt->n * sizeof *pos);
    if (!rot || !pos) {
        free(rot);
        free(pos);
        return ESR_FAIL("out of memory measuring %d camera errors", mt->n);
    }
    const struct esr_similarity *s = &a->colmap_to_true;
    for (int k = 0; k < mt->n; k++) {
        double aligned[3][3], true_r[3][3], centre[3], d2 = 0.0;
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 3; c++) {
                aligned[r][c] = s->rotation[r][0] * mt->colmap_c2w[k][0][c] + s->rotation[r][1] * mt->colmap_c2w[k][1][c] +
                                s->rotation[r][2] * mt->colmap_c2w[k][2][c];
                true_r[r][c] = mt->truth[k]->camera.c2w[r][c];
            }
        esr_similarity_apply(s, &mt->colmap_centres[3 * k], centre);
        for (int c = 0; c < 3; c++)
            d2 += pow(centre[c] - mt->true_centres[3 * k + c], 2);
        rot[k] = esr_rotation_angle_deg(true_r, aligned);
        pos[k] = sqrt(d2);
    }
    /* the inliers first (pos below the threshold), compacted in place, then all of them */
    double *rot_in = malloc((size_t)mt->n * sizeof *rot_in), *pos_in = malloc((size_t)mt->n * sizeof *pos_in);
    if (!rot_in || !pos_in) {
        free(rot), free(pos), free(rot_in), free(pos_in);
        return ESR_FAIL("out of memory measuring %d camera errors", mt->n);
    }
    int n_in = 0;
    for (int k = 0; k < mt->n; k++)
        if (pos[k] < a->inlier_threshold) {
            rot_in[n_in] = rot[k];
            pos_in[n_in++] = pos[k];
        }
    if (n_in > 0) {
        median_max(rot_in, n_in, &a->rot_median_inliers_deg, &a->rot_max_inliers_deg);
        median_max(pos_in, n_in, &a->pos_median_inliers, &a->pos_max_inliers);
    }
    free(rot_in);
    free(pos_in);
    median_max(rot, mt->n, &a->rot_median_deg, &a->rot_max_deg);
    median_max(pos, mt->n, &a->pos_median, &a->pos_max);
    a->pos_median_rel = a->pos_median / a->scene_radius;
    a->pos_max_rel = a->pos_max / a->scene_radius;
    free(rot);
    free(pos);
    return ESR_OK;
}

int esr_colmap_align(const struct esr_colmap_model *m, const struct esr_dataset *truth,
                     struct esr_colmap_alignment *a)
{
    memset(a, 0, sizeof *a);
    a->n_registered = m->n_images;
    a->n_true = truth->phases[ESR_PHASE_TRAIN].n_frames;
    ESR_TRY(scene_radius(truth, &a->scene_radius));
    struct matches mt;
    memset(&mt, 0, sizeof mt);
    int status = match_images(m, truth, &mt);
    a->n_matched = mt.n;
    if (status == ESR_OK && mt.n < 3)
        status = ESR_FAIL("only %d COLMAP images match train frames of '%s'; the alignment needs 3", mt.n, truth->root);
    a->inlier_threshold = ESR_ALIGN_INLIER_FRACTION * a->scene_radius;
    if (status == ESR_OK)
        status = robust_fit(&mt, a->inlier_threshold, a);
    if (status == ESR_OK)
        status = measure(&mt, a);
    matches_free(&mt);
    return status;
}

void esr_colmap_alignment_frame(const struct esr_colmap_alignment *a, struct esr_scene_frame *f)
{
    /* s R x + t = s R (x - c) with c = -R^T t / s */
    const struct esr_similarity *s = &a->colmap_to_true;
    memset(f, 0, sizeof *f);
    memcpy(f->rotation, s->rotation, sizeof f->rotation);
    f->scale = s->scale;
    for (int i = 0; i < 3; i++)
        f->centre[i] = -(s->rotation[0][i] * s->translation[0] + s->rotation[1][i] * s->translation[1] +
                         s->rotation[2][i] * s->translation[2]) / s->scale;
    f->radius = a->scene_radius / s->scale; /* the true scene radius in COLMAP units */
    f->from_points = 0;
}
