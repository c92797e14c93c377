/* Scores of rendered material maps against the truth, on in-memory maps (eval/materials.h). */
#include "eval/materials.h"

#include <math.h>
#include <string.h>

#include "core/colour.h"
#include "core/error.h"
#include "eval/normals.h"

static int check_maps(const struct esr_material_maps *m, const struct esr_image *ref, const char *what)
{
    const struct esr_image *maps[4] = {m->base, m->roughness, m->metallic, m->opacity_or_normal};
    static const char *const names[4] = {"base colour", "roughness", "metallic", "normal / opacity"};
    for (int k = 0; k < 4; k++) {
        if (maps[k]->width != ref->width || maps[k]->height != ref->height)
            return ESR_FAIL("%s %s map is %dx%d but the rendered base colour map is %dx%d", what,
                            names[k], maps[k]->width, maps[k]->height, ref->width, ref->height);
        if (maps[k]->channels < 1)
            return ESR_FAIL("%s %s map has no channel", what, names[k]);
    }
    if (m->base->channels < 3)
        return ESR_FAIL("%s base colour map has %d channel(s); expected RGB", what, m->base->channels);
    return ESR_OK;
}

/* Channel c of pixel i of img. */
static float at(const struct esr_image *img, size_t i, int c)
{
    return img->data[(size_t)img->channels * i + (size_t)c];
}

/* The rendered value v of a pixel of opacity a, composited on white, taken off the white again. */
static float uncomposite(float v, float a)
{
    return esr_clamp01((v - (1.0f - a)) / a);
}

static void add_split(struct esr_material_split_sums *s, double ae_rough, double ae_metal, double metal)
{
    s->n++;
    s->ae_rough += ae_rough;
    s->ae_metal += ae_metal;
    s->pred_metal += metal;
}

/* Both passes: the first (gain NULL) adds everything but se_base_gain, the second only it. */
static int scan(struct esr_material_sums *s, const struct esr_material_maps *pred,
                const struct esr_material_maps *truth, const double *gain)
{
    ESR_TRY(check_maps(pred, pred->base, "rendered"));
    ESR_TRY(check_maps(truth, pred->base, "ground-truth"));
    if (truth->opacity_or_normal->channels < 3)
        return ESR_FAIL("ground-truth normal map has %d channel(s); expected 3 or 4",
                        truth->opacity_or_normal->channels);
    const struct esr_image *op = pred->opacity_or_normal, *nrm = truth->opacity_or_normal;
    const size_t n_pix = (size_t)pred->base->width * (size_t)pred->base->height;
    for (size_t i = 0; i < n_pix; i++) {
        if (at(nrm, i, 0) == 0.0f && at(nrm, i, 1) == 0.0f && at(nrm, i, 2) == 0.0f)
            continue; /* background in the truth */
        if (!gain)
            s->n_gt++;
        const float a = fminf(at(op, i, op->channels - 1), 1.0f);
        if (!(a > ESR_NORMAL_MIN_OPACITY))
            continue;
        for (int c = 0; c < 3; c++) {
            const float p = uncomposite(at(pred->base, i, c), a);
            const float t = at(truth->base, i, c);
            const float t_srgb = esr_srgb_from_linear(esr_clamp01(t));
            const double r = esr_linear_from_srgb(p);
            if (gain) {
                const double d = esr_srgb_from_linear(esr_clamp01((float)(gain[c] * r))) - t_srgb;
                s->se_base_gain += d * d;
            } else {
                const double d = (double)p - t_srgb;
                s->se_base += d * d;
                s->sum_tr[c] += (double)t * r;
                s->sum_rr[c] += r * r;
            }
        }
        if (gain)
            continue;
        s->n++;
        const float rough = uncomposite(at(pred->roughness, i, 0), a);
        const float metal = uncomposite(at(pred->metallic, i, 0), a);
        const float t_metal = at(truth->metallic, i, 0);
        const double ae_rough = fabs((double)rough - at(truth->roughness, i, 0));
        const double ae_metal = fabs((double)metal - t_metal);
        s->ae_rough += ae_rough;
        s->ae_metal += ae_metal;
        /* compared in float: a map storing 0.9 holds 0.9f, which is below the double 0.9 */
        if (t_metal >= (float)ESR_MATERIAL_METAL_AT_LEAST)
            add_split(&s->metal, ae_rough, ae_metal, metal);
        else if (t_metal <= (float)ESR_MATERIAL_DIELECTRIC_AT_MOST)
            add_split(&s->dielectric, ae_rough, ae_metal, metal);
    }
    return ESR_OK;
}

int esr_material_add(struct esr_material_sums *s, const struct esr_material_maps *pred,
                     const struct esr_material_maps *truth)
{
    return scan(s, pred, truth, NULL);
}

int esr_material_add_gained(struct esr_material_sums *s, const struct esr_material_maps *pred,
                            const struct esr_material_maps *truth, const double gain[3])
{
    return scan(s, pred, truth, gain);
}

static void merge_split(struct esr_material_split_sums *a, const struct esr_material_split_sums *b)
{
    a->n += b->n;
    a->ae_rough += b->ae_rough;
    a->ae_metal += b->ae_metal;
    a->pred_metal += b->pred_metal;
}

void esr_material_sums_merge(struct esr_material_sums *a, const struct esr_material_sums *b)
{
    a->n_gt += b->n_gt;
    a->n += b->n;
    a->se_base += b->se_base;
    a->se_base_gain += b->se_base_gain;
    for (int c = 0; c < 3; c++) {
        a->sum_tr[c] += b->sum_tr[c];
        a->sum_rr[c] += b->sum_rr[c];
    }
    a->ae_rough += b->ae_rough;
    a->ae_metal += b->ae_metal;
    merge_split(&a->metal, &b->metal);
    merge_split(&a->dielectric, &b->dielectric);
}

void esr_material_gains(const struct esr_material_sums *s, double gain[3])
{
    for (int c = 0; c < 3; c++)
        gain[c] = s->sum_rr[c] > 0.0 ? s->sum_tr[c] / s->sum_rr[c] : 1.0;
}

static double mean_of(double sum, long n)
{
    return n > 0 ? sum / (double)n : NAN;
}

/* PSNR of a squared error summed over n pixels of 3 channels (NAN when n = 0). */
static double psnr_of(double se, long n)
{
    return n > 0 ? fmin(esr_psnr_from_mse(se / (3.0 * (double)n)), ESR_MATERIAL_PSNR_CAP) : NAN;
}

static struct esr_material_split_stats split_stats(const struct esr_material_split_sums *s)
{
    struct esr_material_split_stats o;
    o.n = s->n;
    o.roughness_mae = mean_of(s->ae_rough, s->n);
    o.metallic_mae = mean_of(s->ae_metal, s->n);
    o.mean_metallic = mean_of(s->pred_metal, s->n);
    return o;
}

struct esr_material_stats esr_material_stats_of(const struct esr_material_sums *s, const double gain[3])
{
    struct esr_material_stats o;
    memset(&o, 0, sizeof o);
    o.n_gt = s->n_gt;
    o.n = s->n;
    o.coverage = s->n_gt > 0 ? (double)s->n / (double)s->n_gt : NAN;
    o.base_color_psnr = psnr_of(s->se_base, s->n);
    o.base_color_psnr_gain = psnr_of(s->se_base_gain, s->n);
    for (int c = 0; c < 3; c++)
        o.gain[c] = gain[c];
    o.roughness_mae = mean_of(s->ae_rough, s->n);
    o.metallic_mae = mean_of(s->ae_metal, s->n);
    o.metal = split_stats(&s->metal);
    o.dielectric = split_stats(&s->dielectric);
    return o;
}
