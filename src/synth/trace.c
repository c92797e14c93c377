#include "synth/trace.h"

#include <string.h>

#include "synth/bsdf.h"

/* Offset of secondary ray origins along the normal, against self-intersection (scene scale ~1 m). */
#define RAY_EPS 1e-4f


void esr_synth_trace_setup(const struct esr_synth_scene *s, const float emission[][3],
                           struct esr_synth_trace_params *p)
{
    memset(p, 0, sizeof *p);
    p->scene = s;
    p->max_bounces = s->max_bounces;
    for (int c = 0; c < 3; c++)
        p->world[c] = s->world_rgb[c] * s->world_strength;
    for (int k = 0; k < s->n_lights; k++) {
        memcpy(p->emission[k], emission[k], sizeof p->emission[k]);
        p->lit[k] = emission[k][0] > 0.0f || emission[k][1] > 0.0f || emission[k][2] > 0.0f;
    }
}

int esr_synth_intersect(const struct esr_synth_scene *s, struct esr_vec3 o, struct esr_vec3 d, float tmin, float *t)
{
    int best = -1;
    for (int i = 0; i < s->n_prims; i++) {
        float ti = esr_synth_prim_hit(&s->prims[i], o, d, tmin, *t);
        if (ti < *t) {
            *t = ti;
            best = i;
        }
    }
    return best;
}

static int occluded(const struct esr_synth_scene *s, struct esr_vec3 o, struct esr_vec3 d, float tmax)
{
    for (int i = 0; i < s->n_prims; i++)
        if (esr_synth_prim_hit(&s->prims[i], o, d, 0.0f, tmax) < tmax)
            return 1;
    return 0;
}

static float power_heuristic(float a, float b) { return a * a / (a * a + b * b); }

/* The path vertex being shaded. */
struct vertex {
    struct esr_vec3 x;             /* the surface point */
    struct esr_vec3 n;             /* its unit normal, on the side wo sees */
    struct esr_vec3 wo;            /* unit direction back along the path */
    const struct esr_material *m;  /* the surface's material at x */
};

/* Light k's contribution at vertex v by one point sampled on its surface, MIS-weighted against
 * BRDF sampling. Adds beta * R * Le * w / pdf to l. Every lit light gets its own sample (rather
 * than one light picked at random), which removes the noise of the light choice for a second
 * shadow ray. */
static void sample_emitter(const struct esr_synth_trace_params *p, int k, const struct vertex *v,
                           struct esr_rng *rng, const float beta[3], float l[3])
{
    const struct esr_vec3 x = v->x, n = v->n, wo = v->wo;
    const struct esr_material *m = v->m;
    const struct esr_synth_scene *s = p->scene;
    const struct esr_synth_prim *lp = &s->prims[s->lights[k].prim];
    struct esr_vec3 y, ny;
    float u0 = esr_rng_float(rng), u1 = esr_rng_float(rng), u2 = esr_rng_float(rng);
    float area = esr_synth_prim_sample_toward(lp, x, u0, u1, u2, &y, &ny);
    if (area <= 0.0f) /* x on or inside the light: no part of it faces x */
        return;
    struct esr_vec3 o = esr_v3_add(x, esr_v3_scale(n, RAY_EPS));
    struct esr_vec3 to = esr_v3_sub(y, o);
    float dist2 = esr_v3_dot(to, to), dist = sqrtf(dist2);
    struct esr_vec3 wi = esr_v3_scale(to, 1.0f / dist);
    float cos_l = -esr_v3_dot(ny, wi);
    if (cos_l <= 0.0f || esr_v3_dot(n, wi) <= 0.0f)
        return;
    if (occluded(s, o, to, 1.0f - 1e-3f))
        return;
    float pdf_l = dist2 / (cos_l * area);
    float f[3];
    esr_brdf_eval(m, n, wo, wi, f);
    float w = power_heuristic(pdf_l, esr_synth_bsdf_pdf(m, n, wo, wi)) / pdf_l;
    for (int c = 0; c < 3; c++)
        l[c] += beta[c] * f[c] * p->emission[k][c] * w;
}

/* The world light's contribution at vertex v by one cosine-distributed direction, MIS-weighted. */
static void sample_world(const struct esr_synth_trace_params *p, const struct vertex *v, struct esr_rng *rng,
                         const float beta[3], float l[3])
{
    const struct esr_vec3 x = v->x, n = v->n, wo = v->wo;
    const struct esr_material *m = v->m;
    struct esr_vec3 t, b;
    esr_v3_basis(n, &t, &b);
    float u1 = esr_rng_float(rng), u2 = esr_rng_float(rng);
    struct esr_vec3 local = esr_sample_hemisphere_cosine(u1, u2);
    float pdf_e = esr_pdf_hemisphere_cosine(local);
    if (pdf_e <= 0.0f)
        return;
    struct esr_vec3 wi = esr_v3_from_local(local, t, b, n);
    if (occluded(p->scene, esr_v3_add(x, esr_v3_scale(n, RAY_EPS)), wi, INFINITY))
        return;
    float f[3];
    esr_brdf_eval(m, n, wo, wi, f);
    float w = power_heuristic(pdf_e, esr_synth_bsdf_pdf(m, n, wo, wi)) / pdf_e;
    for (int c = 0; c < 3; c++)
        l[c] += beta[c] * f[c] * p->world[c] * w;
}

void esr_synth_backdrop(struct esr_vec3 d, int lights_on, float rgb[3])
{
    const float len = sqrtf(esr_v3_dot(d, d)), z = d.z / len, phi = atan2f(d.y, d.x);
    static const float floor_rgb[3] = {0.30f, 0.24f, 0.18f}, horizon[3] = {0.75f, 0.72f, 0.66f},
                       zenith[3] = {0.40f, 0.55f, 0.80f};
    const float stripes = 0.12f * sinf(5.0f * phi) + 0.06f * cosf(2.0f * phi);
    for (int c = 0; c < 3; c++) {
        float v = z < 0.0f ? floor_rgb[c] + (horizon[c] - floor_rgb[c]) * expf(8.0f * z)
                           : zenith[c] + (horizon[c] - zenith[c]) * expf(-3.0f * z);
        v *= 1.0f + stripes;
        rgb[c] = v * (lights_on ? ESR_SYNTH_BACKDROP_LIT_GAIN : 1.0f);
    }
}

int esr_synth_trace_path(const struct esr_synth_trace_params *p, struct esr_vec3 o, struct esr_vec3 d,
                         struct esr_rng *rng, float rgb[3])
{
    const struct esr_synth_scene *s = p->scene;
    float beta[3] = {1.0f, 1.0f, 1.0f};
    float l[3] = {0.0f, 0.0f, 0.0f};
    const int world_on = p->world[0] > 0.0f || p->world[1] > 0.0f || p->world[2] > 0.0f,
              any_lit = esr_synth_trace_any_lit(p);
    float prev_pdf = 0.0f;          /* BRDF pdf of the direction that led here (0 at the camera) */
    struct esr_vec3 prev_n = esr_v3(0, 0, 0), prev_x = o;
    int primary_hit = 0;
    for (int depth = 0;; depth++) {
        float t = INFINITY;
        int hit = esr_synth_intersect(s, o, d, 0.0f, &t);
        if (hit < 0) {
            if (depth == 0 && p->backdrop) {
                esr_synth_backdrop(d, any_lit, l);
                primary_hit = 1; /* opaque, as a photograph */
            }
            /* The camera sees a transparent film; later vertices see the world light. */
            if (depth > 0 && world_on) {
                float w = power_heuristic(prev_pdf, fmaxf(esr_v3_dot(prev_n, d), 0.0f) * ESR_INV_PI);
                for (int c = 0; c < 3; c++)
                    l[c] += beta[c] * p->world[c] * w;
            }
            break;
        }
        if (depth == 0)
            primary_hit = 1;
        const struct esr_synth_prim *prim = &s->prims[hit];
        struct esr_vec3 x = esr_v3_add(o, esr_v3_scale(d, t));
        struct esr_vec3 n = esr_synth_prim_normal(prim, x);
        int k = prim->light;
        if (k >= 0 && esr_v3_dot(n, d) < 0.0f && p->lit[k]) {
            float w = 1.0f;
            if (depth > 0) {
                float cos_l = -esr_v3_dot(n, d);
                float pdf_l = t * t / (cos_l * esr_synth_prim_area_toward(prim, prev_x));
                w = power_heuristic(prev_pdf, pdf_l);
            }
            for (int c = 0; c < 3; c++)
                l[c] += beta[c] * p->emission[k][c] * w;
        }
        if (depth >= p->max_bounces || !(world_on || any_lit)) /* (nothing left to gather) */
            break;
        struct esr_vec3 wo = esr_v3_scale(d, -1.0f);
        if (esr_v3_dot(n, wo) < 0.0f) /* reached from inside through rounding: shade the side seen */
            n = esr_v3_scale(n, -1.0f);
        struct esr_material m = esr_synth_prim_material(prim, x);
        const struct vertex v = {x, n, wo, &m};
        for (int j = 0; j < s->n_lights; j++)
            if (p->lit[j])
                sample_emitter(p, j, &v, rng, beta, l);
        if (world_on)
            sample_world(p, &v, rng, beta, l);
        struct esr_vec3 wi;
        float pdf, f[3];
        float u0 = esr_rng_float(rng), u1 = esr_rng_float(rng), u2 = esr_rng_float(rng);
        if (!esr_synth_bsdf_sample(&m, n, wo, u0, u1, u2, &wi, &pdf))
            break;
        esr_brdf_eval(&m, n, wo, wi, f);
        for (int c = 0; c < 3; c++)
            beta[c] *= f[c] / pdf;
        if (depth >= 2) {
            /* Russian roulette keeps long paths unbiased: survivors are reweighted by 1/q. */
            float q = fminf(fmaxf(beta[0], fmaxf(beta[1], beta[2])), 0.95f);
            if (esr_rng_float(rng) >= q)
                break;
            for (int c = 0; c < 3; c++)
                beta[c] /= q;
        }
        prev_pdf = pdf;
        prev_n = n;
        prev_x = x;
        o = esr_v3_add(x, esr_v3_scale(n, RAY_EPS));
        d = wi;
    }
    memcpy(rgb, l, sizeof l);
    return primary_hit;
}
