/* A learned background for rays that leave the scene (real photos have no alpha and no white
 * backdrop behind the object): an equirectangular lattice of colour logits over directions, one
 * layer per lighting mode (a room behind the object is lit differently when the lamps are on),
 *     bg(d, mode) = sigmoid( bilinear(logits[mode], u(d), v(d)) )
 * with u = atan2(d_y, d_x) / 2 pi + 1/2 (wrapping around) and v = acos(d_z) / pi (+Z up, row 0
 * looking up, clamped at the poles). It holds what lies beyond the scene box as seen from its
 * centre: for a capture whose cameras stay at a similar distance this is the usual "background
 * at infinity" of NeRF-W/NeuS-style models, at 64 x 32 texels a smooth one (details of a near
 * wall come out blurred; they are not what the reconstruction is for).
 *
 * Layout: logits[((mode * BG_H + row) * BG_W + col) * 3 + c], mode 0 = lights off, 1 = on. */
#ifndef ESR_FIELDS_BACKGROUND_H
#define ESR_FIELDS_BACKGROUND_H

#include <stddef.h>
#include <stdint.h>

#define ESR_BACKGROUND_W 64
#define ESR_BACKGROUND_H 32
#define ESR_BACKGROUND_PARAMS ((size_t)2 * ESR_BACKGROUND_W * ESR_BACKGROUND_H * 3)

/* out3[r] = bg(dirs3[r], lights_on[r]) for n rays (directions need not be unit length). */
void esr_background_fwd(const float *logits, const float *dirs3, const uint8_t *lights_on, int n,
                        float *out3);
/* esr_background_fwd into srgb3, and lin3 = its sRGB decoded to linear radiance (what the
 * linear composites put behind a ray); lin3 may be srgb3 (decoded in place). */
void esr_background_fwd_linear(const float *logits, const float *dirs3, const uint8_t *lights_on, int n,
                               float *srgb3, float *lin3);
/* Adds d loss / d logits into g_logits given d loss / d out3. Serial over the rays in order (a
 * few thousand rays x 4 texels: cheaper than any reduction, and deterministic). */
void esr_background_bwd(const float *logits, const float *dirs3, const uint8_t *lights_on, int n,
                        const float *d_out3, float *g_logits);

#endif
