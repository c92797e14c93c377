/* Numbers drawn into an image with a built-in 3x5 pixel font (the lights' ids on `esr lights`'s
 * picture): no font library, legible at any size as whole-pixel blocks. */
#ifndef ESR_RENDER_DIGIT_FONT_H
#define ESR_RENDER_DIGIT_FONT_H

#include "io/image.h"

/* Width and height in pixels of the decimal number n >= 0 drawn at scale s (each font pixel an
 * s x s block, one font pixel between digits, a one-font-pixel margin all round). */
void esr_digits_size(int n, int s, int *width, int *height);
/* Draws n >= 0 with its top-left corner at (x, y): the margin box filled with bg, the digits in
 * fg (RGB, [0,1]); what falls outside img is clipped. img has 3 or 4 channels (alpha set 1). */
void esr_digits_draw(struct esr_image *img, int x, int y, int n, int s, const float fg[3],
                     const float bg[3]);

#endif
