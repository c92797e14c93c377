#include "core/colour.h"

#include <math.h>

float esr_srgb_from_linear(float linear)
{
    if (linear <= 0.0031308f)
        return 12.92f * linear;
    return 1.055f * powf(linear, 1.0f / 2.4f) - 0.055f;
}

float esr_linear_from_srgb(float encoded)
{
    if (encoded <= 0.04045f)
        return encoded / 12.92f;
    return powf((encoded + 0.055f) / 1.055f, 2.4f);
}

float esr_linear_from_srgb_grad(float encoded)
{
    if (encoded <= 0.04045f)
        return 1.0f / 12.92f;
    return (2.4f / 1.055f) * powf((encoded + 0.055f) / 1.055f, 1.4f);
}

float esr_srgb_from_linear_grad(float linear)
{
    if (linear <= 0.0031308f)
        return 12.92f;
    return (1.055f / 2.4f) * powf(linear, 1.0f / 2.4f - 1.0f);
}

float esr_image_error_scale(float linear)
{
    return esr_srgb_from_linear_grad(fmaxf(linear, ESR_IMAGE_ERROR_FLOOR));
}

void esr_rgb_to_hsv(const float rgb[3], float hsv[3])
{
    float r = rgb[0], g = rgb[1], b = rgb[2];
    float max = fmaxf(r, fmaxf(g, b));
    float min = fminf(r, fminf(g, b));
    float chroma = max - min;
    float h_prime;
    if (chroma == 0.0f)
        h_prime = 0.0f;
    else if (max == r)
        h_prime = (g - b) / chroma;
    else if (max == g)
        h_prime = (b - r) / chroma + 2.0f;
    else
        h_prime = (r - g) / chroma + 4.0f;
    float h = fmodf(h_prime / 6.0f, 1.0f);
    if (h < 0.0f)
        h += 1.0f; /* "mod 1.0" in the seed is the floored modulo: (-1/6) mod 1 = 5/6 */
    hsv[0] = h;
    hsv[1] = max == 0.0f ? 0.0f : chroma / max;
    hsv[2] = max;
}

void esr_hsv_to_rgb(const float hsv[3], float rgb[3])
{
    float h = hsv[0] - floorf(hsv[0]);
    float v = hsv[2];
    float chroma = hsv[1] * v;
    float h_prime = h * 6.0f;
    float x = chroma * (1.0f - fabsf(fmodf(h_prime, 2.0f) - 1.0f));
    float m = v - chroma;
    float r, g, b;
    switch ((int)h_prime) {
    case 0: r = chroma; g = x; b = 0.0f; break;
    case 1: r = x; g = chroma; b = 0.0f; break;
    case 2: r = 0.0f; g = chroma; b = x; break;
    case 3: r = 0.0f; g = x; b = chroma; break;
    case 4: r = x; g = 0.0f; b = chroma; break;
    default: r = chroma; g = 0.0f; b = x; break; /* 5 <= H' < 6 */
    }
    rgb[0] = r + m;
    rgb[1] = g + m;
    rgb[2] = b + m;
}

void esr_recolour_keep_value(const float rgb[3], float target_h, float target_s, float out[3])
{
    float hsv[3];
    esr_rgb_to_hsv(rgb, hsv);
    hsv[0] = target_h;
    hsv[1] = target_s;
    esr_hsv_to_rgb(hsv, out);
}

double esr_psnr_from_mse(double mse)
{
    return mse > 0.0 ? -10.0 * log10(mse) : INFINITY;
}

float esr_luminance(const float rgb[3])
{
    return 0.2126f * rgb[0] + 0.7152f * rgb[1] + 0.0722f * rgb[2];
}
