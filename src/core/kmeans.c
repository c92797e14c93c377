/* Weighted k-means with farthest-first centres (see kmeans.h). */
#include "core/kmeans.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"

static float dist2(const float *a, const float *b, int d)
{
    float s = 0.0f;
    for (int c = 0; c < d; c++)
        s += (a[c] - b[c]) * (a[c] - b[c]);
    return s;
}

static double weight(const struct esr_kmeans_params *p, size_t i)
{
    return p->w ? (double)p->w[i] : 1.0;
}

/* Each point to its nearest of the k centres (ties: the lower index); returns how many moved. */
static long assign_nearest(const struct esr_kmeans_params *p, const float *centres, int k,
                           int32_t *assign)
{
    long moved = 0;
#pragma omp parallel for schedule(static) reduction(+ : moved)
    for (long long i = 0; i < (long long)p->n; i++) {
        const float *xi = p->x + (size_t)i * (size_t)p->dim;
        int best = 0;
        float bd = dist2(xi, centres, p->dim);
        for (int j = 1; j < k; j++) {
            const float d = dist2(xi, centres + (size_t)j * (size_t)p->dim, p->dim);
            if (d < bd)
                bd = d, best = j;
        }
        moved += assign[i] != best;
        assign[i] = best;
    }
    return moved;
}

/* The weighted mean of each cluster into centres (a cluster of no weight keeps its centre) and
 * its weight into wsum. Serial, in point order: the same sums for any thread count. */
static void update_centres(const struct esr_kmeans_params *p, const int32_t *assign, int k,
                           float *centres, double *wsum)
{
    double acc[ESR_KMEANS_MAX_K][ESR_KMEANS_MAX_DIM];
    memset(acc, 0, sizeof acc);
    for (int j = 0; j < k; j++)
        wsum[j] = 0.0;
    for (size_t i = 0; i < p->n; i++) {
        const double wi = weight(p, i);
        const int j = assign[i];
        wsum[j] += wi;
        for (int c = 0; c < p->dim; c++)
            acc[j][c] += wi * (double)p->x[i * (size_t)p->dim + (size_t)c];
    }
    for (int j = 0; j < k; j++)
        if (wsum[j] > 0.0)
            for (int c = 0; c < p->dim; c++)
                centres[j * p->dim + c] = (float)(acc[j][c] / wsum[j]);
}

static int check(const struct esr_kmeans_params *p, double *total)
{
    if (p->dim < 1 || p->dim > ESR_KMEANS_MAX_DIM || p->k_max < 1 || p->k_max > ESR_KMEANS_MAX_K ||
        !(p->min_separation >= 0.0f) || !(p->min_share >= 0.0f && p->min_share < 1.0f) ||
        p->iters < 0 || (p->n && !p->x))
        return ESR_FAIL("kmeans: dim %d (1..%d), k_max %d (1..%d), min_separation %g, min_share %g "
                        "or iters %d out of range",
                        p->dim, ESR_KMEANS_MAX_DIM, p->k_max, ESR_KMEANS_MAX_K,
                        (double)p->min_separation, (double)p->min_share, p->iters);
    *total = 0.0;
    for (size_t i = 0; i < p->n; i++) {
        const double wi = weight(p, i);
        if (!(wi >= 0.0) || !isfinite(wi))
            return ESR_FAIL("kmeans: weight %zu is %g (must be finite and >= 0)", i, wi);
        for (int c = 0; c < p->dim; c++)
            if (!isfinite(p->x[i * (size_t)p->dim + (size_t)c]))
                return ESR_FAIL("kmeans: point %zu is not finite", i);
        *total += wi;
    }
    return ESR_OK;
}

/* Lloyd iterations from the given centres; returns after p->iters or when no point moves. */
static void lloyd(const struct esr_kmeans_params *p, int k, float *centres, int32_t *assign,
                  double *wsum)
{
    for (int it = 0; it < p->iters; it++) {
        const long moved = assign_nearest(p, centres, k, assign);
        update_centres(p, assign, k, centres, wsum);
        if (it > 0 && moved == 0)
            break;
    }
    if (p->iters == 0) {
        assign_nearest(p, centres, k, assign);
        update_centres(p, assign, k, centres, wsum);
    }
}

int esr_kmeans(const struct esr_kmeans_params *p, float *centres, int32_t *assign,
               double *weights, int *k_out)
{
    double total = 0.0;
    ESR_TRY(check(p, &total));
    const int d = p->dim;
    *k_out = 1;
    for (int c = 0; c < d; c++)
        centres[c] = 0.0f;
    if (weights)
        weights[0] = 0.0;
    if (p->n == 0)
        return ESR_OK;
    for (size_t i = 0; i < p->n; i++)
        assign[i] = 0;
    const struct esr_kmeans_params plain = {.x = p->x, .n = p->n, .dim = d, .k_max = 1};
    double wsum[ESR_KMEANS_MAX_K];
    if (total <= 0.0) { /* no weight anywhere: one cluster at the plain mean */
        update_centres(&plain, assign, 1, centres, wsum);
        return ESR_OK;
    }
    update_centres(p, assign, 1, centres, wsum);
    float *near2 = malloc(p->n * sizeof(float)); /* squared distance to the nearest centre */
    if (!near2)
        return ESR_FAIL("kmeans: out of memory for %zu points", p->n);
    for (size_t i = 0; i < p->n; i++)
        near2[i] = dist2(p->x + i * (size_t)d, centres, d);
    int k = 1;
    const float sep2 = p->min_separation * p->min_separation;
    while (k < p->k_max) { /* farthest first, among the points that weigh */
        size_t far = 0;
        float fd = -1.0f;
        for (size_t i = 0; i < p->n; i++)
            if (weight(p, i) > 0.0 && near2[i] > fd)
                fd = near2[i], far = i;
        if (fd < sep2 || fd <= 0.0f)
            break;
        float *cn = centres + (size_t)k * (size_t)d;
        memcpy(cn, p->x + far * (size_t)d, (size_t)d * sizeof(float));
        k++;
        for (size_t i = 0; i < p->n; i++)
            near2[i] = fminf(near2[i], dist2(p->x + i * (size_t)d, cn, d));
    }
    free(near2);
    for (size_t i = 0; i < p->n; i++)
        assign[i] = -1;
    lloyd(p, k, centres, assign, wsum);
    /* drop the clusters that hold too little weight, then settle the rest */
    int kept = 0;
    for (int j = 0; j < k; j++)
        if (wsum[j] > 0.0 && wsum[j] >= (double)p->min_share * total) {
            memmove(centres + (size_t)kept * (size_t)d, centres + (size_t)j * (size_t)d,
                    (size_t)d * sizeof(float));
            kept++;
        }
    if (kept == 0) { /* every cluster under the share: the one weighted mean */
        kept = 1;
        for (size_t i = 0; i < p->n; i++)
            assign[i] = 0;
        update_centres(p, assign, 1, centres, wsum);
    } else if (kept < k) {
        lloyd(p, kept, centres, assign, wsum);
    }
    k = kept;
    /* number by decreasing weight (ties: the earlier centre) */
    int order[ESR_KMEANS_MAX_K], rank[ESR_KMEANS_MAX_K];
    for (int j = 0; j < k; j++)
        order[j] = j;
    for (int a = 1; a < k; a++)
        for (int b = a; b > 0 && wsum[order[b]] > wsum[order[b - 1]]; b--) {
            const int t = order[b];
            order[b] = order[b - 1], order[b - 1] = t;
        }
    float sorted[ESR_KMEANS_MAX_K * ESR_KMEANS_MAX_DIM];
    for (int j = 0; j < k; j++) {
        rank[order[j]] = j;
        memcpy(sorted + (size_t)j * (size_t)d, centres + (size_t)order[j] * (size_t)d,
               (size_t)d * sizeof(float));
    }
    memcpy(centres, sorted, (size_t)k * (size_t)d * sizeof(float));
    for (int j = 0; weights && j < k; j++)
        weights[j] = wsum[order[j]];
    for (size_t i = 0; i < p->n; i++)
        assign[i] = rank[assign[i]];
    *k_out = k;
    return ESR_OK;
}
