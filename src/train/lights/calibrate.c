/* The lights' strength, calibrated against the light they cast (see lights.h). */
#include "train/lights/lights.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/brdf.h"
#include "core/colour.h"
#include "core/error.h"
#include "core/order.h"
#include "core/rng.h"
#include "core/vec3.h"
#include "model/material_fields.h"
#include "model/trace.h"
#include "train/lights/direct.h"
#include "train/lights/surface.h"
#include "train/lights/fit.h"
#include "train/lts.h"

/* calibration: LTS points per call, hemisphere directions per point, area samples per point and
 * light */
#define CALIB_CHUNK 250
#define CALIB_DIRS 128
#define CALIB_LIGHT_SPP 64
/* points whose lights-on linear radiance exceeds this in a channel are clipped in the LDR images
 * (sRGB 0.9) and left out */
#define CALIB_MAX_ON 0.79f
/* camera rays traced per round of the search for calibration points, and rounds at most; nor
 * more rounds than draw the rays given CALIB_MAX_DRAWS times over: drawn at random with
 * replacement, more rounds find few new points (a small dataset whose undertrained field glows
 * everywhere spent 64 rounds, 32x its rays, finding none) */
#define CALIB_RAYS 8192
#define CALIB_MAX_ROUNDS 64
#define CALIB_MAX_DRAWS 4
/* a calibration point: a ray's strongest sample of at least this weight (a surface) ... */
#define CALIB_SURFACE_WEIGHT 0.3f
/* ... whose emission stays below this share of k (not an emitter, nor its fringe) */
#define CALIB_E_SHARE 0.25f
/* the lights-off correction of a point's base colour, L_off / L^_off, is clamped to
 * [1 / this, this] */
#define CALIB_MAX_CORRECTION 4.0

/* The rays calibration points are searched on. */
struct calib_rays {
    const float *orig3, *dir3; /* [n*3] origins and unit directions */
    size_t n;
};

/* Calibration points: the strongest sample (weight >= CALIB_SURFACE_WEIGHT) of random rays,
 * kept when it lies on no light and its E is well below k. */
static int calib_points(const struct esr_model *m, const struct calib_rays *rays, int want,
                        uint64_t seed, float *pos3, float *dir_out3, int *got)
{
    const float *orig3 = rays->orig3, *dir3 = rays->dir3;
    const size_t n = rays->n;
    const float *sdf = esr_model_values(m, ESR_COMP_SDF);
    const float k = m->cfg.emitter_k;
    struct esr_trace t;
    struct esr_material_fields mf;
    ESR_TRY(esr_trace_init(&t, m, CALIB_RAYS, 0));
    int rc = esr_material_fields_init(&mf, m, CALIB_RAYS, ESR_MATERIAL_EMISSION_ONLY);
    float *o = malloc(CALIB_RAYS * 3 * sizeof(float)), *d = malloc(CALIB_RAYS * 3 * sizeof(float));
    float *cand = malloc(CALIB_RAYS * 6 * sizeof(float));
    uint8_t *on = calloc(CALIB_RAYS, 1);
    if (rc == ESR_OK && (!o || !d || !cand || !on))
        rc = ESR_FAIL("lights: out of memory for the calibration rays");
    *got = 0;
    /* rounds of CALIB_RAYS random rays (a fixed stride would alias with the image width) */
    struct esr_rng rng = esr_rng_init(seed, 0x11ad5);
    const size_t draws = (CALIB_MAX_DRAWS * n + CALIB_RAYS - 1) / CALIB_RAYS;
    const int rounds = draws < CALIB_MAX_ROUNDS ? (int)draws : CALIB_MAX_ROUNDS;
    for (int round = 0; rc == ESR_OK && *got < want && round < rounds; round++) {
        const int nr = CALIB_RAYS;
        for (int i = 0; i < nr; i++) {
            const size_t r = (size_t)(esr_rng_u64(&rng) % n);
            memcpy(o + i * 3, orig3 + r * 3, 3 * sizeof(float));
            memcpy(d + i * 3, dir3 + r * 3, 3 * sizeof(float));
        }
        rc = esr_trace_fwd(&t, m, sdf, o, d, on, nr, seed);
        const struct esr_march *mc = &t.march;
        int nc = 0;
        for (int r = 0; rc == ESR_OK && r < nr; r++) {
            size_t best = 0;
            const float wmax = esr_march_strongest_kept(mc, r, &best);
            if (wmax < CALIB_SURFACE_WEIGHT || esr_lights_id_at(&m->lights, mc->kpos3 + best * 3) >= 0)
                continue;
            memcpy(cand + nc * 6, mc->kpos3 + best * 3, 3 * sizeof(float));
            memcpy(cand + nc * 6 + 3, mc->kdir3 + best * 3, 3 * sizeof(float));
            nc++;
        }
        for (int c = 0; c < nc; c++) /* positions contiguous for the E query */
            memcpy(o + c * 3, cand + c * 6, 3 * sizeof(float));
        if (rc == ESR_OK && nc > 0)
            rc = esr_material_fields_fwd(&mf, m, sdf, o, (size_t)nc);
        for (int c = 0; rc == ESR_OK && c < nc && *got < want; c++) {
            if (esr_max_channel(mf.emit3 + c * 3) >= CALIB_E_SHARE * k)
                continue;
            memcpy(pos3 + *got * 3, cand + c * 6, 3 * sizeof(float));
            memcpy(dir_out3 + *got * 3, cand + c * 6 + 3, 3 * sizeof(float));
            (*got)++;
        }
    }
    free(o), free(d), free(cand), free(on);
    esr_material_fields_free(&mf);
    esr_trace_free(&t);
    return rc;
}

/* Point p of an LTS call: its normal, camera direction and material; 0 when the camera sees it
 * from behind (nothing to estimate). */
static int point_frame(const struct esr_lts *l, size_t p, struct esr_vec3 *n, struct esr_vec3 *wo,
                       struct esr_material *mat)
{
    *n = esr_v3_at(l->nrm3, p);
    *wo = esr_v3_at(l->wo3, 2 * p); /* the camera direction */
    *mat = esr_material_of_row(l->mf.brdf5 + p * ESR_BRDF_CHANNELS, 1.0f);
    return esr_v3_dot(*n, *wo) > 0.0f;
}

/* One LTS call's points and what was measured at them. */
struct calib_chunk {
    const struct esr_lts *l;  /* the call: points, normals, materials, hemisphere directions */
    size_t P;                 /* its points */
    const float *hit_emit3;   /* [P * l->M * 3] E at the hemisphere directions' hits */
    const double *A;          /* the settled lights' direct light (esr_lights_direct's out) */
    const double *Ar;         /* the same from their undecided rims, or NULL: no light has one */
};

/* Adds one LTS call's points as rows: A from esr_lights_direct, B from the hemisphere directions
 * (the other surfaces' emo radiance, and the lights' own reflected part L_emo - E where a
 * direction hits one). */
static void accumulate(const struct esr_model *m, const struct calib_chunk *ch, int correct_base,
                       struct esr_calib_rows *rows, double *seen)
{
    const struct esr_lts *l = ch->l;
    const size_t P = ch->P;
    const float *hit_emit3 = ch->hit_emit3;
    const double *Aall = ch->A, *Rall = ch->Ar;
    const int K = m->lights.n;
    const size_t M = (size_t)l->M;
    for (size_t p = 0; p < P && rows->n < rows->cap; p++) {
        struct esr_vec3 n, wo;
        struct esr_material mat;
        if (!point_frame(l, p, &n, &wo, &mat))
            continue;
        /* a point the on images show clipped says only "at least this bright" */
        const float *L_on = l->pf.lin3 + (p * 4 + 1) * 3;
        if (fmaxf(L_on[0], fmaxf(L_on[1], L_on[2])) > CALIB_MAX_ON)
            continue;
        const double *A = Aall + p * 2 * ESR_MAX_LIGHTS * 3; /* the camera direction's */
        const double *Ar = Rall ? Rall + p * 2 * ESR_MAX_LIGHTS * 3 : NULL;
        double B[3] = {0, 0, 0}, Br[ESR_MAX_LIGHTS][3];
        memset(Br, 0, sizeof Br);
        for (size_t j = 0; j < M; j++) {
            const size_t i = p * M + j;
            if (l->hit_row[i] < 0)
                continue;
            float R[3];
            const float *wi = l->wi3 + i * 3;
            esr_brdf_eval(&mat, n, wo, esr_v3(wi[0], wi[1], wi[2]), R);
            const uint8_t label = esr_lights_label_at(&m->lights, l->hit_pos3 + i * 3);
            const int rim = label & ESR_LIGHT_UNDECIDED ? ESR_LIGHT_LABEL_ID(label) - 1 : -1;
            for (int c = 0; c < 3; c++) {
                const double w = (double)R[c] * l->wt[i], li = l->li_emo3[i * 3 + c];
                const double e = hit_emit3[i * 3 + c];
                B[c] += (label ? li - e : li) * w;
                if (rim >= 0) /* back in B while the rim stays dark (esr_calib_fit) */
                    Br[rim][c] += e * w;
            }
        }
        /* L_emo at the point for the camera direction: on row minus off row */
        const float *lin = l->pf.lin3;
        for (int c = 0; c < 3; c++) {
            const size_t row = rows->n * 3 + (size_t)c;
            const double w = esr_image_error_scale(L_on[c]); /* row weight: judged as images */
            const double off = lin[(p * 4) * 3 + c], hat_off = l->hat3[(p * 2) * 6 + c];
            rows->emo[row] = w * ((double)lin[(p * 4 + 1) * 3 + c] - off);
            rows->b[row] = w * B[c];
            rows->r[row] = correct_base && hat_off > 1e-6
                               ? fmin(fmax(off / hat_off, 1.0 / CALIB_MAX_CORRECTION),
                                      CALIB_MAX_CORRECTION)
                               : 1.0;
            for (int a = 0; a < K; a++) {
                rows->a[row * (size_t)K + (size_t)a] = w * A[a * 3 + c];
                rows->br[row * (size_t)K + (size_t)a] = w * Br[a][c];
                if (Ar)
                    rows->ar[row * (size_t)K + (size_t)a] = w * Ar[a * 3 + c];
            }
        }
        rows->n++;
        for (int a = 0; a < K; a++)
            seen[a] += A[a * 3] + A[a * 3 + 1] + A[a * 3 + 2] > 0.0;
    }
}

int esr_lights_calibrate(struct esr_model *m, const float *orig3, const float *dir3, size_t n,
                         int want, uint64_t seed, int correct_base)
{
    const int K = m->lights.n;
    const int none[ESR_MAX_LIGHTS] = {0};
    if (K == 0 || want <= 0 || n == 0) {
        ESR_TRY(esr_lights_settle(m, none)); /* no undecided label is left to be saved */
        if (K > 0 && want > 0)
            return ESR_FAIL("lights: no lights-off rays to calibrate the lights' strength with");
        return ESR_OK;
    }
    struct esr_light keep[ESR_MAX_LIGHTS]; /* put back if the calibration fails */
    memcpy(keep, m->lights.light, sizeof keep);
    /* solved from the field itself: the light samples below carry E at scale 1 */
    for (int a = 0; a < K; a++)
        for (int c = 0; c < 3; c++)
            m->lights.light[a].scale[c] = 1.0f;
    /* each light's settled part and its undecided rim, sampled apart */
    struct esr_light_samples ls[ESR_MAX_LIGHTS], lr[ESR_MAX_LIGHTS];
    memset(ls, 0, sizeof ls);
    memset(lr, 0, sizeof lr);
    int has_rim[ESR_MAX_LIGHTS] = {0}, any_rim = 0;
    const size_t abytes = (size_t)CALIB_CHUNK * 2 * ESR_MAX_LIGHTS * 3 * sizeof(double);
    double *Abuf = malloc(abytes), *Rbuf = malloc(abytes);
    float *pos = malloc((size_t)want * 3 * sizeof(float)), *dir = malloc((size_t)want * 3 * sizeof(float));
    struct esr_calib_rows rows = {0, (size_t)want, malloc((size_t)want * 3 * K * sizeof(double)),
                              malloc((size_t)want * 3 * K * sizeof(double)),
                              malloc((size_t)want * 3 * K * sizeof(double)),
                              malloc((size_t)want * 3 * sizeof(double)),
                              malloc((size_t)want * 3 * sizeof(double)),
                              malloc((size_t)want * 3 * sizeof(double)), {1, 1, 1}};
    double *ca = malloc((size_t)want * K * sizeof(double)), *cy = malloc((size_t)want * sizeof(double));
    double seen[ESR_MAX_LIGHTS] = {0};
    int got = 0;
    int rc = pos && dir && rows.a && rows.ar && rows.br && rows.emo && rows.b && rows.r && ca && cy && Abuf && Rbuf
                 ? ESR_OK
                 : ESR_FAIL("lights: out of memory for the calibration");
    for (int a = 0; rc == ESR_OK && a < K; a++) {
        rc = esr_light_samples_part(m, a, ESR_LIGHT_PART_SETTLED, &ls[a]);
        if (rc == ESR_OK)
            rc = esr_light_samples_part(m, a, ESR_LIGHT_PART_UNDECIDED, &lr[a]);
        has_rim[a] = lr[a].n > 0;
        any_rim |= has_rim[a];
    }
    const struct calib_rays rays = {orig3, dir3, n};
    if (rc == ESR_OK)
        rc = calib_points(m, &rays, want, seed, pos, dir, &got);
    /* the LTS machinery at these points: its own sizes, first hit */
    const long keep_step = m->step;
    m->step = 1; /* off the normal SDF's refresh period: computed once; restored below */
    struct esr_lts l;
    memset(&l, 0, sizeof l);
    if (rc == ESR_OK)
        rc = esr_lts_init_sized(&l, m, CALIB_CHUNK, CALIB_DIRS, ESR_LTS_FIRST_HIT);
    struct esr_material_fields mf;
    memset(&mf, 0, sizeof mf);
    if (rc == ESR_OK)
        rc = esr_material_fields_init(&mf, m, (size_t)CALIB_CHUNK * CALIB_DIRS,
                                      ESR_MATERIAL_EMISSION_ONLY);
    const float *sdf = esr_model_values(m, ESR_COMP_SDF);
    struct esr_light_shadows shadows;
    memset(&shadows, 0, sizeof shadows);
    if (rc == ESR_OK)
        rc = esr_light_shadows_init(&shadows, m);
    /* the direct light of each light's settled part and of its undecided rim, apart */
    const struct esr_direct_lights settled = {&shadows, ls, K, NULL, CALIB_LIGHT_SPP};
    const struct esr_direct_lights rims = {&shadows, lr, K, NULL, CALIB_LIGHT_SPP};
    for (int p0 = 0; rc == ESR_OK && p0 < got; p0 += CALIB_CHUNK) {
        const size_t P = (size_t)(got - p0 < CALIB_CHUNK ? got - p0 : CALIB_CHUNK);
        struct esr_march pts; /* the points as a kept list: the LTS takes each once */
        memset(&pts, 0, sizeof pts);
        pts.n_kept = P;
        pts.kpos3 = pos + (size_t)p0 * 3;
        pts.kdir3 = dir + (size_t)p0 * 3;
        struct esr_lts_stats st;
        const struct esr_lts_batch lb = {&pts, NULL, seed + (uint64_t)p0};
        rc = esr_lts_run(&l, m, sdf, NULL, NULL, &lb, &st);
        if (rc == ESR_OK)
            rc = esr_material_fields_fwd(&mf, m, sdf, l.hit_pos3, P * CALIB_DIRS);
        /* A_K: the samples carry the field's E (scales 1), the scale is what is solved for */
        const struct esr_direct_points dp = {P, l.pos3, l.nrm3, l.mf.brdf5, l.wo3, 2};
        const uint64_t dseed = seed ^ (uint64_t)(p0 + 1) * 0x9e3779b97f4a7c15ULL;
        if (rc == ESR_OK)
            rc = esr_lights_direct(&settled, &dp, dseed, Abuf, NULL);
        if (rc == ESR_OK && any_rim)
            rc = esr_lights_direct(&rims, &dp, ~dseed, Rbuf, NULL);
        const struct calib_chunk ch = {&l, P, mf.emit3, Abuf, any_rim ? Rbuf : NULL};
        if (rc == ESR_OK)
            accumulate(m, &ch, correct_base, &rows, seen);
    }
    esr_material_fields_free(&mf);
    esr_lts_free(&l);
    esr_light_shadows_free(&shadows);
    m->step = keep_step;
    for (int c = 0; rc == ESR_OK && c < 3; c++) {
        for (size_t p = 0; p < rows.n; p++) /* the median correction (cy as scratch) */
            cy[p] = rows.r[p * 3 + (size_t)c];
        rows.median[c] = rows.n ? esr_median_doubles(cy, rows.n) : 1.0;
    }
    int fit[ESR_MAX_LIGHTS], emits[ESR_MAX_LIGHTS] = {0};
    float t_on[ESR_MAX_LIGHTS] = {0};
    int nf = esr_lights_fitted(&m->lights, fit);
    const struct esr_calib_problem rim_pb = {&m->lights, &rows, fit, nf, ca, cy};
    if (rc == ESR_OK && any_rim && esr_calib_decide_rims(&rim_pb, has_rim, emits, t_on) != 0)
        rc = ESR_FAIL("lights: out of memory for the calibration");
    if (rc == ESR_OK)
        rc = esr_lights_settle(m, emits);
    for (int a = 0; rc == ESR_OK && a < K; a++)
        m->lights.rim[a] = (struct esr_light_rim){(long)lr[a].n, emits[a], t_on[a]};
    /* the lights to fit by their settled areas (a rim left dark can move one past the share) */
    nf = esr_lights_fitted(&m->lights, fit);
    const struct esr_calib_problem pb = {&m->lights, &rows, fit, nf, ca, cy};
    double scale[3][ESR_MAX_LIGHTS];
    if (rc == ESR_OK && esr_calib_fit(&pb, emits, scale, NULL, NULL, NULL) != 0)
        rc = ESR_FAIL("lights: out of memory for the calibration");
    for (int c = 0; rc == ESR_OK && c < 3; c++) {
        for (int f = 0; f < nf; f++)
            m->lights.light[fit[f]].scale[c] = (float)scale[c][f];
        esr_lights_share_scale(&m->lights, c);
    }
    for (int a = 0; rc == ESR_OK && a < K; a++) {
        struct esr_light *lt = &m->lights.light[a];
        esr_light_update_radiance(lt);
        /* a light too small to fit took the others' scale: no point of its own fixed it */
        lt->solved = 0, lt->bound_only = 0, lt->inseparable = 0, lt->strength_err = 0.0f;
        lt->calib_points = esr_light_strength_fitted(&m->lights, a) ? (float)seen[a] : 0.0f;
    }
    for (int a = 0; a < K; a++) {
        esr_light_samples_free(&ls[a]);
        esr_light_samples_free(&lr[a]);
    }
    free(pos), free(dir), free(rows.a), free(rows.ar), free(rows.br), free(rows.emo), free(rows.b), free(rows.r);
    free(ca), free(cy), free(Abuf), free(Rbuf);
    if (rc != ESR_OK) {
        memcpy(m->lights.light, keep, sizeof keep);
        (void)esr_lights_settle(m, none); /* no undecided label is left to be saved */
    }
    return rc;
}

static int is_fitted(const struct esr_lights *L, int a, double total_area)
{
    return L->light[a].area >= ESR_LIGHTS_SMALL_SHARE * total_area;
}

static double lights_area(const struct esr_lights *L)
{
    double total = 0.0;
    for (int a = 0; a < L->n; a++)
        total += L->light[a].area;
    return total;
}

int esr_lights_fitted(const struct esr_lights *L, int *fit)
{
    const double total = lights_area(L);
    int nf = 0;
    for (int a = 0; a < L->n; a++)
        if (is_fitted(L, a, total))
            fit[nf++] = a;
    return nf;
}

int esr_lights_uncalibrated(const struct esr_lights *L)
{
    float points = 0.0f;
    for (int i = 0; i < L->n; i++)
        points += L->light[i].calib_points;
    return L->n > 0 && points == 0.0f;
}

int esr_light_strength_fitted(const struct esr_lights *L, int id)
{
    return id >= 0 && id < L->n && (L->light[id].solved || is_fitted(L, id, lights_area(L)));
}

void esr_lights_fit_columns(const struct esr_lights *L, const int *fit, int nf, const double *a,
                            double *cols)
{
    double left_out = 0.0, fitted_area = 0.0;
    for (int j = 0; j < L->n; j++)
        left_out += a[j];
    for (int f = 0; f < nf; f++) {
        left_out -= a[fit[f]];
        fitted_area += L->light[fit[f]].area;
    }
    for (int f = 0; f < nf; f++)
        cols[f] = a[fit[f]] + (fitted_area > 0.0 ? L->light[fit[f]].area / fitted_area : 0.0) * left_out;
}

void esr_lights_share_scale(struct esr_lights *L, int c)
{
    const double total = lights_area(L);
    double mean = 0.0, area = 0.0;
    for (int a = 0; a < L->n; a++)
        if (is_fitted(L, a, total)) {
            mean += (double)L->light[a].scale[c] * L->light[a].area;
            area += L->light[a].area;
        }
    for (int a = 0; a < L->n; a++)
        if (!is_fitted(L, a, total))
            L->light[a].scale[c] = (float)(area > 0.0 ? mean / area : 1.0);
}
