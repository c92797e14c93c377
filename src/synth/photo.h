/* Photo-like train captures of `esr synth`: per-photo exposure and white balance, a camera tone
 * curve, as an automatic camera gives them (issue "Photos as cameras take them"). The truth of
 * every photo is kept so evaluation can compare what a model learns with it. */
#ifndef ESR_SYNTH_PHOTO_H
#define ESR_SYNTH_PHOTO_H

#include <stdint.h>

#include "synth/plan.h"

enum esr_photo_curve { ESR_PHOTO_CURVE_SRGB, ESR_PHOTO_CURVE_FILMIC };

struct esr_photo_options {
    double exposure_jitter; /* stops: per photo uniform in +-this before re-centring */
    double on_exposure;     /* stops: the lights-on set's mean exposure (lights-off set's is 0) */
    double wb_jitter;       /* per-photo per-channel gains uniform in 1 +- this */
    int wb_follow;          /* lights-on white balance pulled towards the lights' colour */
    enum esr_photo_curve curve;
    int jpeg_quality;       /* 1..100: train photos as JPEG (train/<name>.jpg); 0: PNG */
    double noise;           /* sigma of Gaussian noise on the exposed linear values (before the curve) */
    int exif;               /* JPEGs carry the EXIF exposure of esr_photo_exif */
};

/* The truth of one train photo: pixel = curve(clip(2^stops * gain[c] * linear[c] + n)), n
 * Gaussian of sigma opt.noise, per pixel and channel. */
struct esr_photo_truth {
    double stops;
    double gain[3];
};

/* RNG streams of seed: the photos' truth, and train frame i's noise at ESR_PHOTO_NOISE_STREAM + i
 * (apart from the plan's and the renders' streams) */
#define ESR_PHOTO_TRUTH_STREAM 0x70686f746f000000ULL
#define ESR_PHOTO_NOISE_STREAM 0x70686f746f100000ULL

/* Whether any option makes the train images differ from plain sRGB renders. */
int esr_photo_active(const struct esr_photo_options *opt);

/* Fails naming the option when one is outside its range (jitters 0..4 stops and 0..0.9, on
 * exposure -8..8 stops). */
int esr_photo_check(const struct esr_photo_options *opt);

/* The truth of every train frame of plan (out: plan->n_frames[ESR_PHASE_TRAIN] entries) from
 * seed. Exposure: u_i uniform in +-exposure_jitter, minus the mean of u over the photo's set
 * (lights off or on), plus on_exposure for the lights-on set: the lights-off set's mean is
 * exactly 0, the lights-on set's exactly on_exposure. White balance: gain_c uniform in
 * 1 +- wb_jitter; with wb_follow a lights-on photo's gains are also multiplied by
 * w_c = (m_c / gm(m))^(-1/2), m the frame's summed light emission and gm the geometric mean of
 * its channels: half the correction an auto white balance under the lamps alone would apply,
 * with geometric mean 1 so it changes colour, not exposure. */
void esr_photo_plan(const struct esr_photo_options *opt, const struct esr_synth_plan *plan, int n_lights,
                    uint64_t seed, struct esr_photo_truth *out);

/* The filmic curve: an S-shaped contrast curve on the sRGB code value s = srgb(x),
 *     y = s^g / (s^g + (1 - s)^g), g = ESR_PHOTO_FILMIC_CONTRAST,
 * monotone increasing on [0, 1] with y(0) = 0, y(1/2) = 1/2, y(1) = 1, darker shadows and
 * brighter highlights than sRGB. Its inverse is s = y^(1/g) / (y^(1/g) + (1 - y)^(1/g)). */
#define ESR_PHOTO_FILMIC_CONTRAST 1.6
double esr_photo_filmic(double linear);
double esr_photo_filmic_inverse(double code);

/* Linear value (clipped to [0, 1]) to code value in [0, 1] by curve. */
double esr_photo_encode(enum esr_photo_curve curve, double linear);

/* The camera settings a photo of stops exposure is written with under --exif: aperture f/4 and
 * ISO 100 fixed, exposure time (1/60 s) * 2^stops, so t * ISO / N^2 is proportional to 2^stops. */
#define ESR_PHOTO_EXIF_BASE_TIME_S (1.0 / 60.0)
#define ESR_PHOTO_EXIF_F_NUMBER 4.0
#define ESR_PHOTO_EXIF_ISO 100
struct esr_exif_exposure;
void esr_photo_exif(const struct esr_photo_truth *t, struct esr_exif_exposure *out);

/* The file name ending a train frame's file_path carries: ".jpg" for JPEG photos, "" for PNG
 * (FORMAT.md: a file_path without extension names a PNG). */
const char *esr_synth_train_ext(const struct esr_photo_options *opt);

/* "srgb" / "filmic" to the curve; -1 for another name. */
int esr_photo_curve_parse(const char *name);
const char *esr_photo_curve_name(enum esr_photo_curve curve);

#endif
