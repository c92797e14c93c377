/* Colour maths from the seed: sRGB transfer curve (eq. 9) and RGB <-> HSV (eqs. 10-15). */
#ifndef ESR_CORE_COLOUR_H
#define ESR_CORE_COLOUR_H

/* IEC 61966-2-1 OETF: linear -> sRGB-encoded (seed eq. 9). Negative input maps through the
 * linear segment; the caller clamps where display values are wanted. */
float esr_srgb_from_linear(float linear);
/* Its exact inverse (EOTF): sRGB-encoded -> linear. */
float esr_linear_from_srgb(float encoded);
/* Derivative of esr_linear_from_srgb, for backward passes. */
float esr_linear_from_srgb_grad(float encoded);
/* Derivative of esr_srgb_from_linear, for backward passes. */
float esr_srgb_from_linear_grad(float linear);

/* How much an error in linear radiance shows in an image: the sRGB curve's slope at `linear`
 * floored at ESR_IMAGE_ERROR_FLOOR linear (6.45 there, 0.44 at 1; the floor keeps channels near
 * black, up to 12.92, from outweighing everything: the fine-tune measured 0.003, 0.01 and 0.05).
 * A least-squares fit judged as images weights its squared errors by this squared: relighting
 * is scored in sRGB, where a residual of 0.02 linear is 0.13 on a channel at 0.01 and 0.01 on
 * one near 1. Used by the fine-tune's loss (train/lts.c) and the lights' strength calibration
 * (train/lights/calibrate.c). */
#define ESR_IMAGE_ERROR_FLOOR 0.01f
float esr_image_error_scale(float linear);

/* x clamped to [0, 1], NaN to 0: colours for formats whose values must lie there (PLY, glTF). */
static inline float esr_clamp01(float x) { return x >= 0.0f ? (x <= 1.0f ? x : 1.0f) : 0.0f; }

/* RGB (linear, V unbounded) -> HSV with H, S in [0,1], V = max(R,G,B) (seed eqs. 10-13). */
void esr_rgb_to_hsv(const float rgb[3], float hsv[3]);
/* HSV -> RGB (seed eqs. 14-15); H is taken modulo 1. */
void esr_hsv_to_rgb(const float hsv[3], float rgb[3]);
/* The seed's edit rule: replace hue and saturation of `rgb` by those of `target_hs`, keep V. */
void esr_recolour_keep_value(const float rgb[3], float target_h, float target_s, float out[3]);

/* Relative luminance of linear Rec. 709 / sRGB primaries (ITU-R BT.709: 0.2126 R + 0.7152 G +
 * 0.0722 B). */
float esr_luminance(const float rgb[3]);
/* The largest of a colour's three channels. */
static inline float esr_max_channel(const float rgb[3])
{
    const float m = rgb[0] > rgb[1] ? rgb[0] : rgb[1];
    return m > rgb[2] ? m : rgb[2];
}

/* PSNR in dB for peak value 1: -10 log10(mse). +INFINITY when mse == 0 (callers that print
 * JSON floor mse first). The one PSNR of the code base: training logs, quick and full eval. */
double esr_psnr_from_mse(double mse);

#endif
