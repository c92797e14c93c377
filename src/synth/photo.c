#include "synth/photo.h"

#include <math.h>
#include <string.h>

#include "core/colour.h"
#include "core/error.h"
#include "core/rng.h"
#include "io/exif_exposure.h"


int esr_photo_active(const struct esr_photo_options *opt)
{
    return opt->exposure_jitter != 0.0 || opt->on_exposure != 0.0 || opt->wb_jitter != 0.0 || opt->wb_follow ||
           opt->curve != ESR_PHOTO_CURVE_SRGB || opt->jpeg_quality || opt->noise != 0.0;
}

int esr_photo_check(const struct esr_photo_options *opt)
{
    if (!(opt->exposure_jitter >= 0.0 && opt->exposure_jitter <= 4.0))
        return ESR_FAIL("--exposure-jitter %g is out of range 0..4 stops", opt->exposure_jitter);
    if (!(opt->on_exposure >= -8.0 && opt->on_exposure <= 8.0))
        return ESR_FAIL("--on-exposure %g is out of range -8..8 stops", opt->on_exposure);
    if (!(opt->wb_jitter >= 0.0 && opt->wb_jitter <= 0.9))
        return ESR_FAIL("--wb-jitter %g is out of range 0..0.9", opt->wb_jitter);
    if (!(opt->noise >= 0.0 && opt->noise <= 1.0))
        return ESR_FAIL("--noise %g is out of range 0..1", opt->noise);
    if (opt->exif && !opt->jpeg_quality)
        return ESR_FAIL("--exif needs --jpeg (EXIF lives in JPEG files)");
    if (opt->jpeg_quality < 0 || opt->jpeg_quality > 100)
        return ESR_FAIL("--jpeg %d is out of range 1..100", opt->jpeg_quality);
    return ESR_OK;
}

/* The white-balance pull of a lights-on frame (photo.h): w_c = (m_c / gm(m))^(-1/2). */
static void follow_gains(const struct esr_synth_frame *f, int n_lights, double w[3])
{
    double m[3] = {0.0, 0.0, 0.0};
    for (int k = 0; k < n_lights; k++)
        for (int c = 0; c < 3; c++)
            m[c] += f->emission[k][c];
    if (!(m[0] > 0.0 && m[1] > 0.0 && m[2] > 0.0)) { /* a pure-hue light: nothing to divide by */
        w[0] = w[1] = w[2] = 1.0;
        return;
    }
    const double gm = cbrt(m[0] * m[1] * m[2]);
    for (int c = 0; c < 3; c++)
        w[c] = 1.0 / sqrt(m[c] / gm);
}

void esr_photo_plan(const struct esr_photo_options *opt, const struct esr_synth_plan *plan, int n_lights,
                    uint64_t seed, struct esr_photo_truth *out)
{
    const int n = plan->n_frames[ESR_PHASE_TRAIN];
    const struct esr_synth_frame *frames = plan->frames[ESR_PHASE_TRAIN];
    struct esr_rng rng = esr_rng_init(seed, ESR_PHOTO_TRUTH_STREAM);
    double sum[2] = {0.0, 0.0};
    int count[2] = {0, 0};
    for (int i = 0; i < n; i++) {
        const int on = frames[i].mode != ESR_LIGHT_OFF;
        out[i].stops = opt->exposure_jitter * (2.0 * esr_rng_float(&rng) - 1.0);
        for (int c = 0; c < 3; c++)
            out[i].gain[c] = 1.0 + opt->wb_jitter * (2.0 * esr_rng_float(&rng) - 1.0);
        sum[on] += out[i].stops;
        count[on]++;
    }
    for (int i = 0; i < n; i++) {
        const int on = frames[i].mode != ESR_LIGHT_OFF;
        out[i].stops += (on ? opt->on_exposure : 0.0) - sum[on] / count[on];
        if (on && opt->wb_follow) {
            double w[3];
            follow_gains(&frames[i], n_lights, w);
            for (int c = 0; c < 3; c++)
                out[i].gain[c] *= w[c];
        }
    }
}

double esr_photo_filmic(double linear)
{
    const double s = esr_srgb_from_linear((float)fmin(fmax(linear, 0.0), 1.0));
    const double a = pow(s, ESR_PHOTO_FILMIC_CONTRAST), b = pow(1.0 - s, ESR_PHOTO_FILMIC_CONTRAST);
    return a / (a + b);
}

double esr_photo_filmic_inverse(double code)
{
    const double y = fmin(fmax(code, 0.0), 1.0);
    const double a = pow(y, 1.0 / ESR_PHOTO_FILMIC_CONTRAST), b = pow(1.0 - y, 1.0 / ESR_PHOTO_FILMIC_CONTRAST);
    return esr_linear_from_srgb((float)(a / (a + b)));
}

double esr_photo_encode(enum esr_photo_curve curve, double linear)
{
    if (curve == ESR_PHOTO_CURVE_FILMIC)
        return esr_photo_filmic(linear);
    return esr_srgb_from_linear((float)fmin(fmax(linear, 0.0), 1.0));
}

int esr_photo_curve_parse(const char *name)
{
    if (!strcmp(name, "srgb"))
        return ESR_PHOTO_CURVE_SRGB;
    if (!strcmp(name, "filmic"))
        return ESR_PHOTO_CURVE_FILMIC;
    return -1;
}

const char *esr_photo_curve_name(enum esr_photo_curve curve)
{
    return curve == ESR_PHOTO_CURVE_FILMIC ? "filmic" : "srgb";
}

const char *esr_synth_train_ext(const struct esr_photo_options *opt)
{
    return opt->jpeg_quality ? ".jpg" : "";
}

void esr_photo_exif(const struct esr_photo_truth *t, struct esr_exif_exposure *out)
{
    out->exposure_time_s = ESR_PHOTO_EXIF_BASE_TIME_S * exp2(t->stops);
    out->f_number = ESR_PHOTO_EXIF_F_NUMBER;
    out->iso = ESR_PHOTO_EXIF_ISO;
}
