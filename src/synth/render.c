/* Whole images from the path tracer: jittered box-filtered radiance with coverage alpha, and
 * the per-pixel ground-truth maps. */
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "synth/trace.h"

/* the sub-pixel positions' own streams (esr_synth_render_shared_jitter) derive from seed ^ this */
#define JITTER_SALT 0x6a09e667f3bcc909ULL

/* esr_synth_render's body; jitter_id NULL: the sub-pixel positions come from the path stream. */
static int render(const struct esr_synth_trace_params *p, const struct esr_camera *cam, int spp, uint64_t seed,
                  uint64_t image_id, const uint64_t *jitter_id, struct esr_image *out)
{
    if (spp < 1)
        return ESR_FAIL("render needs at least 1 sample per pixel, got %d", spp);
    ESR_TRY(esr_image_alloc(out, cam->width, cam->height, 4));
    const int w = cam->width;
    const long n_pix = (long)cam->width * cam->height;
    float *img = out->data;
    /* The first k*k samples of a pixel are stratified on a k x k grid (jittered within each cell),
     * which mostly removes the noise of coverage and of edges; any remainder is uniform. */
    int k = 1;
    while ((k + 1) * (k + 1) <= spp)
        k++;
#pragma omp parallel for schedule(dynamic, 16)
    for (long i = 0; i < n_pix; i++) {
        struct esr_rng rng = esr_rng_init(seed, image_id * (uint64_t)n_pix + (uint64_t)i), jrng = rng;
        if (jitter_id)
            jrng = esr_rng_init(seed ^ JITTER_SALT, *jitter_id * (uint64_t)n_pix + (uint64_t)i);
        struct esr_rng *jr = jitter_id ? &jrng : &rng;
        float sum[3] = {0.0f, 0.0f, 0.0f};
        int covered = 0;
        for (int sidx = 0; sidx < spp; sidx++) {
            float jx = esr_rng_float(jr), jy = esr_rng_float(jr);
            if (sidx < k * k) {
                jx = ((float)(sidx % k) + jx) / (float)k;
                jy = ((float)(sidx / k) + jy) / (float)k;
            }
            float px = (float)(i % w) + jx, py = (float)(i / w) + jy;
            float o[3], d[3], rgb[3];
            esr_camera_ray(cam, px, py, o, d);
            covered += esr_synth_trace_path(p, esr_v3(o[0], o[1], o[2]), esr_v3(d[0], d[1], d[2]), &rng, rgb);
            for (int c = 0; c < 3; c++)
                sum[c] += rgb[c];
        }
        /* The escaped samples contributed 0, so the mean is already premultiplied by coverage. */
        for (int c = 0; c < 3; c++)
            img[4 * i + c] = sum[c] / (float)spp;
        img[4 * i + 3] = (float)covered / (float)spp;
    }
    return ESR_OK;
}

int esr_synth_render(const struct esr_synth_trace_params *p, const struct esr_camera *cam, int spp, uint64_t seed,
                     uint64_t image_id, struct esr_image *out)
{
    return render(p, cam, spp, seed, image_id, NULL, out);
}

int esr_synth_render_shared_jitter(const struct esr_synth_trace_params *p, const struct esr_camera *cam, int spp,
                                   uint64_t seed, uint64_t image_id, uint64_t jitter_id, struct esr_image *out)
{
    return render(p, cam, spp, seed, image_id, &jitter_id, out);
}

void esr_synth_gt_free(struct esr_synth_gt *gt)
{
    free(gt->prim);
    esr_image_free(&gt->normal);
    esr_image_free(&gt->base);
    esr_image_free(&gt->roughness);
    esr_image_free(&gt->metallic);
    esr_image_free(&gt->emission);
    memset(gt, 0, sizeof *gt);
}

static int gt_alloc(struct esr_synth_gt *gt, int w, int h)
{
    memset(gt, 0, sizeof *gt);
    gt->prim = malloc((size_t)w * (size_t)h * sizeof(int));
    if (!gt->prim)
        return ESR_FAIL("out of memory for a %dx%d ground-truth map", w, h);
    ESR_TRY(esr_image_alloc(&gt->normal, w, h, 3));
    ESR_TRY(esr_image_alloc(&gt->base, w, h, 3));
    ESR_TRY(esr_image_alloc(&gt->roughness, w, h, 1));
    ESR_TRY(esr_image_alloc(&gt->metallic, w, h, 1));
    ESR_TRY(esr_image_alloc(&gt->emission, w, h, 3));
    return ESR_OK;
}

int esr_synth_render_gt(const struct esr_synth_scene *s, const struct esr_camera *cam, struct esr_synth_gt *out)
{
    if (gt_alloc(out, cam->width, cam->height) != ESR_OK) {
        esr_synth_gt_free(out);
        return ESR_ERR;
    }
    const int w = cam->width;
    const long n_pix = (long)cam->width * cam->height;
#pragma omp parallel for schedule(dynamic, 64)
    for (long i = 0; i < n_pix; i++) {
        float o[3], d[3], t = INFINITY;
        esr_camera_ray(cam, (float)(i % w) + 0.5f, (float)(i / w) + 0.5f, o, d);
        struct esr_vec3 ro = esr_v3(o[0], o[1], o[2]), rd = esr_v3(d[0], d[1], d[2]);
        int hit = esr_synth_intersect(s, ro, rd, 0.0f, &t);
        out->prim[i] = hit;
        float *nor = out->normal.data + 3 * i, *base = out->base.data + 3 * i, *em = out->emission.data + 3 * i;
        if (hit < 0) {
            nor[0] = nor[1] = nor[2] = base[0] = base[1] = base[2] = em[0] = em[1] = em[2] = 0.0f;
            out->roughness.data[i] = out->metallic.data[i] = 0.0f;
            continue;
        }
        const struct esr_synth_prim *p = &s->prims[hit];
        struct esr_vec3 x = esr_v3_add(ro, esr_v3_scale(rd, t));
        struct esr_vec3 n = esr_synth_prim_normal(p, x);
        struct esr_material m = esr_synth_prim_material(p, x);
        nor[0] = n.x, nor[1] = n.y, nor[2] = n.z;
        for (int c = 0; c < 3; c++) {
            base[c] = m.base[c];
            em[c] = p->light >= 0 ? s->lights[p->light].rgb[c] * s->lights[p->light].strength : 0.0f;
        }
        out->roughness.data[i] = m.roughness;
        out->metallic.data[i] = m.metallic;
    }
    return ESR_OK;
}
