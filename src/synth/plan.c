#include "synth/plan.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/colour.h"
#include "core/error.h"
#include "core/rng.h"

const float esr_synth_palette_hue[ESR_SYNTH_PALETTE_SIZE] = {0.0f, 1.0f / 3.0f, 2.0f / 3.0f, 0.5f, 5.0f / 6.0f,
                                                             1.0f / 6.0f};
const char *const esr_synth_palette_name[ESR_SYNTH_PALETTE_SIZE] = {"red", "green", "blue", "cyan", "magenta", "yellow"};

/* Salts separating the camera RNG streams from the pixel streams of the same seed. */
#define TRAIN_CAMERA_SALT 0x747261696e63616dULL
#define TEST_CAMERA_SALT 0x7465737463616d73ULL

const char *esr_synth_mask_tag(enum esr_phase_id phase)
{
    switch (phase) {
    case ESR_PHASE_TEST_NV: return "nv";
    case ESR_PHASE_TEST_NVI: return "nvi";
    case ESR_PHASE_TEST_NVC: return "nvc";
    case ESR_PHASE_TEST_NVIC: return "nvic";
    default: return NULL;
    }
}

static void make_camera(uint64_t seed, uint64_t index, int res, struct esr_camera *cam)
{
    struct esr_rng rng = esr_rng_init(seed, index);
    double lo = sin(ESR_SYNTH_ELEVATION_MIN_DEG * M_PI / 180.0), hi = sin(ESR_SYNTH_ELEVATION_MAX_DEG * M_PI / 180.0);
    double el = asin(lo + (hi - lo) * esr_rng_float(&rng));
    double az = 2.0 * M_PI * esr_rng_float(&rng);
    double z[3] = {cos(el) * cos(az), cos(el) * sin(az), sin(el)}; /* camera +Z = away from the origin */
    double x[3] = {-z[1], z[0], 0.0};                              /* world up x z, horizontal */
    double xl = sqrt(x[0] * x[0] + x[1] * x[1]);
    x[0] /= xl;
    x[1] /= xl;
    double y[3] = {z[1] * x[2] - z[2] * x[1], z[2] * x[0] - z[0] * x[2], z[0] * x[1] - z[1] * x[0]};
    for (int r = 0; r < 3; r++) {
        cam->c2w[r][0] = (float)x[r];
        cam->c2w[r][1] = (float)y[r];
        cam->c2w[r][2] = (float)z[r];
        cam->c2w[r][3] = (float)(ESR_SYNTH_CAMERA_RADIUS * z[r]);
    }
    cam->width = cam->height = res;
    cam->focal = esr_focal_from_fov(res, (float)ESR_SYNTH_CAMERA_ANGLE_X);
}

/* Sets light k of f: JSON colour / intensity and the radiance it renders with. hue < 0 keeps the
 * original colour. */
static void set_light(struct esr_synth_frame *f, const struct esr_synth_light *l, int k, float json_h, float json_s,
                      float hue, float intensity)
{
    float rgb[3];
    if (hue >= 0.0f)
        esr_recolour_keep_value(l->rgb, hue, 1.0f, rgb);
    else
        memcpy(rgb, l->rgb, sizeof rgb);
    f->hsv[k][0] = json_h;
    f->hsv[k][1] = json_s;
    f->hsv[k][2] = 1.0f;
    f->intensity[k] = intensity;
    for (int c = 0; c < 3; c++)
        f->emission[k][c] = rgb[c] * l->strength * intensity;
}

static void plan_train(const struct esr_synth_scene *s, int n_train, struct esr_synth_frame *frames)
{
    for (int i = 0; i < 2 * n_train; i++) {
        struct esr_synth_frame *f = &frames[i];
        int on = i >= n_train;
        snprintf(f->name, sizeof f->name, "r_%03d", i);
        f->cam = i;
        f->mode = on ? ESR_LIGHT_ON : ESR_LIGHT_OFF;
        for (int k = 0; k < s->n_lights; k++)
            set_light(f, &s->lights[k], k, 0.0f, 0.0f, -1.0f, on ? 1.0f : 0.0f);
    }
}

/* Number of conditions per test camera in each phase. */
static int conditions(const struct esr_synth_scene *s, enum esr_phase_id phase)
{
    return phase == ESR_PHASE_TEST_NVI && s->n_lights >= 2 ? 3 : 2;
}

static void plan_test(const struct esr_synth_scene *s, enum esr_phase_id phase, int n_test, struct esr_synth_frame *frames)
{
    static const char *const nv_names[] = {"off", "on"}, *const nvi_names[] = {"i050", "i200", "ind"};
    static const char *const nvc_names[] = {"c0", "c1"}, *const nvic_names[] = {"ic0", "ic1"};
    int nc = conditions(s, phase);
    for (int c = 0; c < n_test; c++) {
        for (int n = 0; n < nc; n++) {
            struct esr_synth_frame *f = &frames[c * nc + n];
            const char *cond = phase == ESR_PHASE_TEST_NV    ? nv_names[n]
                               : phase == ESR_PHASE_TEST_NVI ? nvi_names[n]
                               : phase == ESR_PHASE_TEST_NVC ? nvc_names[n]
                                                             : nvic_names[n];
            snprintf(f->name, sizeof f->name, "c%03d_%s", c, cond);
            f->cam = c;
            int j = 2 * c + n;
            for (int k = 0; k < s->n_lights; k++) {
                const struct esr_synth_light *l = &s->lights[k];
                float hsv[3];
                esr_rgb_to_hsv(l->rgb, hsv);
                /* The JSON carries 6 decimals, as the reference scenes do. */
                float h6 = roundf(hsv[0] * 1e6f) / 1e6f, s6 = roundf(hsv[1] * 1e6f) / 1e6f;
                if (phase == ESR_PHASE_TEST_NV) {
                    f->mode = n ? ESR_LIGHT_ON : ESR_LIGHT_OFF;
                    set_light(f, l, k, 0.0f, 0.0f, -1.0f, (float)n);
                } else if (phase == ESR_PHASE_TEST_NVI) {
                    f->mode = ESR_LIGHT_I_CHANGE;
                    float inten = n == 0 ? 0.5f : n == 1 ? 2.0f : (k == 0 ? 0.0f : 1.0f);
                    set_light(f, l, k, h6, s6, -1.0f, inten);
                } else if (phase == ESR_PHASE_TEST_NVC) {
                    f->mode = ESR_LIGHT_C_CHANGE;
                    float hue = esr_synth_palette_hue[(j + 3 * k) % ESR_SYNTH_PALETTE_SIZE];
                    set_light(f, l, k, roundf(hue * 1e6f) / 1e6f, 1.0f, hue, 1.0f);
                } else {
                    f->mode = ESR_LIGHT_IC_CHANGE;
                    float hue = esr_synth_palette_hue[(j + 1 + 3 * k) % ESR_SYNTH_PALETTE_SIZE];
                    set_light(f, l, k, roundf(hue * 1e6f) / 1e6f, 1.0f, hue, n ? 2.0f : 0.5f);
                }
            }
        }
    }
}

int esr_synth_plan_make(const struct esr_synth_scene *s, int res, int n_train, int n_test, uint64_t seed,
                        struct esr_synth_plan *out)
{
    memset(out, 0, sizeof *out);
    if (n_train < 1 || n_test < 1)
        return ESR_FAIL("a dataset needs at least 1 train view per condition and 1 test camera (got %d, %d)", n_train,
                        n_test);
    out->n_train_cams = 2 * n_train;
    out->n_test_cams = n_test;
    out->train_cams = calloc((size_t)out->n_train_cams, sizeof *out->train_cams);
    out->test_cams = calloc((size_t)n_test, sizeof *out->test_cams);
    enum esr_phase_id phases[] = {ESR_PHASE_TRAIN, ESR_PHASE_TEST_NV, ESR_PHASE_TEST_NVI, ESR_PHASE_TEST_NVC,
                                  ESR_PHASE_TEST_NVIC};
    int ok = out->train_cams && out->test_cams;
    for (int i = 0; i < 5 && ok; i++) {
        enum esr_phase_id ph = phases[i];
        out->n_frames[ph] = ph == ESR_PHASE_TRAIN ? 2 * n_train : n_test * conditions(s, ph);
        out->frames[ph] = calloc((size_t)out->n_frames[ph], sizeof(struct esr_synth_frame));
        ok = out->frames[ph] != NULL;
    }
    if (!ok) {
        esr_synth_plan_free(out);
        return ESR_FAIL("out of memory planning %d train and %d test views", 2 * n_train, n_test);
    }
    for (int i = 0; i < out->n_train_cams; i++)
        make_camera(seed ^ TRAIN_CAMERA_SALT, (uint64_t)i, res, &out->train_cams[i]);
    for (int i = 0; i < n_test; i++)
        make_camera(seed ^ TEST_CAMERA_SALT, (uint64_t)i, res, &out->test_cams[i]);
    plan_train(s, n_train, out->frames[ESR_PHASE_TRAIN]);
    for (int i = 1; i < 5; i++)
        plan_test(s, phases[i], n_test, out->frames[phases[i]]);
    return ESR_OK;
}

void esr_synth_plan_free(struct esr_synth_plan *plan)
{
    free(plan->train_cams);
    free(plan->test_cams);
    for (int i = 0; i < ESR_PHASE_COUNT; i++)
        free(plan->frames[i]);
    memset(plan, 0, sizeof *plan);
}
